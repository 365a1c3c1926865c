"""Learned baselines (ACT, Diffusion): the training dataset they see, their configs, their result records.

How force reaches them. LeRobot 0.6.1's ACT and Diffusion read only ``observation.state``,
``observation.environment_state`` and images, so ``observation.force`` alone would be ignored. They
are trained on a derived copy of a shipped dataset whose environment state is

    observation.environment_state = [object state | ee_pose (7) | force (6)]     (extras "ee_pose,force")

(``lerobot_env_forcemap/env_state.py`` defines the layout and names), and evaluated with the env
processor ``--env.env_state_extras=ee_pose,force`` that builds the same vector from the live
observation. ``ENV`` features are normalised like ``STATE`` (ACT: mean/std, Diffusion: min/max; both
policies leave ``ENV`` unnormalised by default, which would feed raw newtons next to metres).

    derive_env_state_dataset("datasets/press", "outputs/learned/datasets/press")
    cmd = train_command("act", dataset_root, output_dir, steps=300, config=ACT_CONFIG)
    doc = result_document("press", "act", records, seeds, train_steps=..., ...)
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap import layout
from lerobot_forcemap.evaluation.records import FORCE_KEYS, to_json
from lerobot_forcemap.evaluation.stats import summarize

__all__ = [
    "DEFAULT_EXTRAS",
    "ACT_CONFIG",
    "DIFFUSION_CONFIG",
    "SMOKE_OVERRIDES",
    "METHODS",
    "ENV_STATE_META_FILE",
    "derive_env_state_dataset",
    "policy_config",
    "train_settings",
    "train_command",
    "settings_to_cli",
    "force_inputs_text",
    "result_document",
]

#: what is appended to observation.environment_state for the learned baselines
DEFAULT_EXTRAS: tuple[str, ...] = ("ee_pose", "force")
#: written into a derived dataset's meta/: source, extras, names
ENV_STATE_META_FILE = "forcemap_env_state.json"

# Small CPU configs (``--policy.<key>=<value>``). ACT: 20-frame chunks (1 s at 20 fps), re-planned every
# 5 frames (4 Hz) so contact forces feed back quickly; no VAE-free shortcut, the VAE is ACT's.
ACT_CONFIG: dict[str, Any] = {
    "chunk_size": 20,
    "n_action_steps": 5,
    "dim_model": 256,
    "n_heads": 4,
    "dim_feedforward": 1024,
    "n_encoder_layers": 2,
    "n_decoder_layers": 1,
    "n_vae_encoder_layers": 2,
    "latent_dim": 32,
    "use_vae": True,
    "kl_weight": 10.0,
    "dropout": 0.1,
    "optimizer_lr": 1e-4,
    "normalization_mapping": {
        "VISUAL": "MEAN_STD",
        "STATE": "MEAN_STD",
        "ENV": "MEAN_STD",
        "ACTION": "MEAN_STD",
    },
}
# Diffusion: horizon 16 (0.8 s), 2 observation steps, 8 executed actions, DDIM with 10 inference steps
# (DDPM's ancestral sampler is meant for all 100 steps).
DIFFUSION_CONFIG: dict[str, Any] = {
    "horizon": 16,
    "n_obs_steps": 2,
    "n_action_steps": 8,
    "down_dims": [64, 128, 256],
    "noise_scheduler_type": "DDIM",
    "num_train_timesteps": 100,
    "num_inference_steps": 10,
    "optimizer_lr": 1e-4,
    "normalization_mapping": {
        "VISUAL": "MEAN_STD",
        "STATE": "MIN_MAX",
        "ENV": "MIN_MAX",
        "ACTION": "MIN_MAX",
    },
}
METHODS: dict[str, dict[str, Any]] = {"act": ACT_CONFIG, "diffusion": DIFFUSION_CONFIG}
#: the --smoke mode shrinks the models further (tests)
SMOKE_OVERRIDES: dict[str, dict[str, Any]] = {
    "act": {
        "dim_model": 32,
        "n_heads": 2,
        "dim_feedforward": 64,
        "n_encoder_layers": 1,
        "n_vae_encoder_layers": 1,
    },
    "diffusion": {"down_dims": [16, 32, 64], "diffusion_step_embed_dim": 32, "num_inference_steps": 2},
}


# ---- dataset -----------------------------------------------------------------------------------------


def derive_env_state_dataset(
    source: str | Path,
    out: str | Path,
    extras: Sequence[str] = DEFAULT_EXTRAS,
    *,
    repo_id: str | None = None,
    overwrite: bool = False,
) -> Path:
    """Copy a LeRobot v3 dataset to ``out`` with ``observation.environment_state`` extended by ``extras``.

    Per frame: ``env_state_new (D + sum d_e,) = cat(env_state (D,), obs[extra_1] (d_1,), ...)``, float32;
    every other column, the episode boundaries and the stats of the other features are unchanged (the
    new column's stats are recomputed by LeRobot). ``meta/forcemap_*.json`` are copied and
    ``meta/forcemap_env_state.json`` records source, extras and names. Returns ``out``.
    Raises ValueError if the source lacks environment_state or an extra's feature, or has NaNs there.
    """
    from lerobot.datasets.dataset_tools import modify_features

    from lerobot_env_forcemap.env_state import parse_env_state_extras
    from lerobot_forcemap.data.reader import lerobot_dataset, to_meta
    from lerobot_forcemap.data.schema import require_dataset_root

    source, out = require_dataset_root(source, "source"), Path(out)
    extras = parse_env_state_extras(extras)
    if not extras:
        raise ValueError("derive_env_state_dataset: extras is empty (nothing to derive)")
    if out.exists():
        if not overwrite:
            raise ValueError(f"{out} exists; pass overwrite=True to replace it")
        shutil.rmtree(out)
    repo_id = repo_id or f"local/{source.name}_env_{'_'.join(extras)}"
    ds = lerobot_dataset(source, repo_id=repo_id)
    values, spec, episode_index = _extended_env_state(source, to_meta(ds), extras)
    tmp = out.with_name(out.name + ".tmp_no_env_state")
    if tmp.exists():
        shutil.rmtree(tmp)
    try:
        stripped = modify_features(ds, remove_features=layout.OBS_ENV_STATE, output_dir=tmp, repo_id=repo_id)
        modify_features(
            stripped, add_features={layout.OBS_ENV_STATE: (values, spec)}, output_dir=out, repo_id=repo_id
        )
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    _write_feature_stats(out, layout.OBS_ENV_STATE, values, episode_index, spec)
    for extra_meta in sorted((source / "meta").glob("forcemap_*.json")):
        shutil.copy2(extra_meta, out / "meta" / extra_meta.name)
    (out / "meta" / ENV_STATE_META_FILE).write_text(
        json.dumps({"source": str(source), "extras": list(extras), "names": spec["names"]}, indent=1)
    )
    return out


def _extended_env_state(
    source: Path, meta: Any, extras: Sequence[str]
) -> tuple[np.ndarray, dict[str, Any], np.ndarray]:
    """The new ``observation.environment_state`` column ``(rows, D + sum d_e)`` float32, its feature
    spec and the rows' episode indices ``(rows,)``, in the dataset's row order; ValueError naming the
    episode and frame of a value that is not finite."""
    from lerobot_env_forcemap.env_state import ENV_STATE_EXTRA_KEYS, extended_env_state_names
    from lerobot_forcemap.data.reader import read_columns

    features = meta.features
    keys = [layout.OBS_ENV_STATE, *(ENV_STATE_EXTRA_KEYS[e] for e in extras)]
    for k in keys:
        if k not in features:
            raise ValueError(
                f"derive_env_state_dataset: {source} has no feature {k!r} (extras {list(extras)})"
            )
    table = read_columns(meta, list(range(meta.total_episodes)), [*keys, "episode_index", "frame_index"])
    episode_index = np.asarray(table["episode_index"]).reshape(-1).astype(int)
    rows = len(episode_index)
    cols = [np.asarray(table[k], dtype=np.float32).reshape(rows, -1) for k in keys]
    for k, c in zip(keys, cols, strict=True):
        bad = np.argwhere(~np.isfinite(c))
        if len(bad):
            row = int(bad[0, 0])
            fr = int(np.asarray(table["frame_index"])[row])
            raise ValueError(
                f"derive_env_state_dataset: {k} is not finite at episode {episode_index[row]}, frame {fr}"
            )
    values = np.concatenate(cols, axis=1)
    extra_names = {e: features[ENV_STATE_EXTRA_KEYS[e]]["names"] for e in extras}
    names = extended_env_state_names(features[layout.OBS_ENV_STATE]["names"], extras, extra_names)
    return values, {"dtype": "float32", "shape": (values.shape[1],), "names": names}, episode_index


def _write_feature_stats(
    root: Path, key: str, values: np.ndarray, episode_index: np.ndarray, spec: dict[str, Any]
) -> None:
    """(Re)write one feature's per-episode stats (meta/episodes parquet) and aggregated stats
    (meta/stats.json) the way LeRobot computes them at record time. ``values (rows, D)`` in the
    dataset's row order, ``episode_index (rows,)``. (``modify_features`` keeps no stats for an
    added feature and would keep the source's per-episode stats of a replaced one.)"""
    import pandas as pd
    from lerobot.datasets.compute_stats import aggregate_stats, compute_episode_stats
    from lerobot.datasets.io_utils import load_stats, write_stats

    files = sorted((root / "meta" / "episodes").glob("*/*.parquet"))
    if not files:
        raise ValueError(f"{root}: no meta/episodes/*/*.parquet")
    per_episode: dict[int, dict[str, np.ndarray]] = {}
    for e in np.unique(episode_index):
        per_episode[int(e)] = compute_episode_stats({key: values[episode_index == e]}, {key: spec})[key]
    for path in files:
        df = pd.read_parquet(path)
        for stat in next(iter(per_episode.values())):
            df[f"stats/{key}/{stat}"] = [
                np.asarray(per_episode[int(e)][stat], dtype=float).reshape(-1) for e in df["episode_index"]
            ]
        df.to_parquet(path, index=False)
    stats = load_stats(root) or {}
    stats[key] = aggregate_stats([{key: st} for st in per_episode.values()])[key]
    write_stats(stats, root)


# ---- training -------------------------------------------------------------------------------------------


def policy_config(method: str, *, smoke: bool = False) -> dict[str, Any]:
    """The ``--policy.*`` settings of a method (``act`` / ``diffusion``), smaller under ``smoke``."""
    if method not in METHODS:
        raise ValueError(f"method must be one of {sorted(METHODS)}, got {method!r}")
    cfg = dict(METHODS[method])
    if smoke:
        cfg.update(SMOKE_OVERRIDES[method])
    return cfg


def _cli_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, dict):
        return json.dumps(v)
    if isinstance(v, (list, tuple)):
        return "[" + ",".join(str(x) for x in v) + "]"
    return str(v)


def train_settings(
    method: str,
    dataset_root: str | Path,
    output_dir: str | Path,
    *,
    steps: int,
    config: dict[str, Any],
    batch_size: int = 8,
    seed: int = 1000,
    repo_id: str | None = None,
) -> dict[str, Any]:
    """A ``lerobot-train`` configuration as a nested dict (the layout of LeRobot's ``train_config.json``,
    so ``json.dump`` of it is a ``--config_path`` file): CPU, no Hub push, no workers, one checkpoint at
    the end. ``method``: a LeRobot policy type; ``config``: its ``--policy.<key>`` values (see
    ``policy_config``)."""
    if steps < 1:
        raise ValueError(f"steps must be >= 1, got {steps}")
    policy = {"type": method, "device": "cpu", "push_to_hub": False, **config}
    if method == "diffusion":
        # a short run cannot afford the default 500 warm-up steps
        policy.setdefault("scheduler_warmup_steps", max(1, steps // 20))
    return {
        "dataset": {"repo_id": repo_id or f"local/{Path(dataset_root).name}", "root": str(dataset_root)},
        "policy": policy,
        "output_dir": str(output_dir),
        "steps": steps,
        "save_freq": steps,
        "log_freq": max(1, min(50, steps // 10)),
        "batch_size": batch_size,
        "seed": seed,
        "num_workers": 0,
        "wandb": {"enable": False},
    }


def train_command(*args: Any, python: str = "python", **kwargs: Any) -> list[str]:
    """``lerobot-train`` argv (run as ``python -m lerobot.scripts.lerobot_train``) of
    ``train_settings(*args, **kwargs)``."""
    return [python, "-m", "lerobot.scripts.lerobot_train", *settings_to_cli(train_settings(*args, **kwargs))]


def settings_to_cli(settings: dict[str, Any]) -> list[str]:
    """``--key=value`` arguments of a nested LeRobot configuration dict: a top-level dict is a section
    (``--policy.type=act``); deeper values are written whole (a dict as JSON, a list as ``[a,b]``)."""
    argv = []
    for key, value in settings.items():
        if isinstance(value, dict):
            argv += [f"--{key}.{k}={_cli_value(v)}" for k, v in value.items()]
        else:
            argv.append(f"--{key}={_cli_value(value)}")
    return argv


def eval_settings(
    checkpoint: str | Path,
    task: str,
    output_dir: str | Path,
    seeds: Sequence[int],
    env: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """A ``lerobot-eval`` configuration as a nested dict (a ``--config_path`` file when dumped) on seeds
    ``seeds[0] ..`` one env at a time (LeRobot seeds batch ``b`` with ``seed + b*batch_size ...``), CPU.
    ``env``: more ``--env.<key>`` values (e.g. ``env_state_extras``)."""
    return {
        "env": {"type": f"forcemap_{task}", **(env or {})},
        "eval": {"n_episodes": len(seeds), "batch_size": 1},
        "policy": {"path": str(checkpoint), "device": "cpu"},
        "output_dir": str(output_dir),
        "seed": int(seeds[0]),
    }


def eval_command(*args: Any, python: str = "python", **kwargs: Any) -> list[str]:
    """``lerobot-eval`` argv (run as ``python -m lerobot.scripts.lerobot_eval``) of
    ``eval_settings(*args, **kwargs)``."""
    return [python, "-m", "lerobot.scripts.lerobot_eval", *settings_to_cli(eval_settings(*args, **kwargs))]


def read_lerobot_eval(out_dir: Path, seeds: Sequence[int]) -> dict[str, Any]:
    """Success per seed from ``lerobot-eval``'s ``eval_info.json`` in ``out_dir``."""
    from lerobot_forcemap.jsonfile import read_json_object

    path = Path(out_dir) / "eval_info.json"
    info = read_json_object(path)
    try:
        successes = [bool(s) for task in info["per_task"] for s in task["metrics"]["successes"]]
    except (KeyError, TypeError) as err:
        raise ValueError(f"{path}: no per_task[*].metrics.successes ({err!r})") from err
    if len(successes) != len(seeds):
        raise ValueError(f"{path}: {len(successes)} episodes, expected {len(seeds)} (seeds {list(seeds)})")
    return {
        "n": len(successes),
        "seeds": [int(s) for s in seeds],
        "success_rate": float(np.mean(successes)),
        "successes": successes,
    }


# ---- results ----------------------------------------------------------------------------------------------


def force_inputs_text(extras: Sequence[str] = DEFAULT_EXTRAS) -> str:
    sizes = {"ee_pose": 7, "force": 6, "finger_force": None}
    parts = ", ".join(f"{e} ({sizes[e]})" if sizes.get(e) else e for e in extras)
    return (
        f"observation.environment_state = [object state, {parts}]: the tared base-frame wrist wrench "
        "(fx fy fz tx ty tz) and TCP pose appended to the object pose in a derived training dataset "
        f"(experiments.learned.baselines.derive_env_state_dataset) and at eval time by the env "
        f"processor --env.env_state_extras={','.join(extras)} (lerobot_env_forcemap/env_state.py); "
        "ENV features normalised like STATE; observation.force itself is ignored by ACT/Diffusion"
    )


def result_document(
    task: str,
    method: str,
    records: Sequence[dict[str, Any]],
    seeds: Sequence[int],
    *,
    train_steps: int,
    train_wall_time_s: float,
    eval_wall_time_s: float,
    config: dict[str, Any],
    force_inputs: str,
    lerobot_eval: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """The ``results/learned/<task>__<method>.json`` document (schema in python -m experiments.learned).

    Spreads are sample std over episodes (ddof 1). ``lerobot_eval``: ``read_lerobot_eval``'s record of
    the same checkpoint on the same seeds, when ``lerobot-eval`` was run."""
    if not records:
        raise ValueError(f"result_document {task}/{method}: no episode records")
    if len(seeds) != len(records):
        raise ValueError(f"result_document {task}/{method}: {len(seeds)} seeds for {len(records)} records")
    rec_seeds = [int(r["seed"]) for r in records]
    if rec_seeds != [int(s) for s in seeds]:
        raise ValueError(f"result_document {task}/{method}: record seeds {rec_seeds} != seeds {list(seeds)}")

    summary = summarize(records, FORCE_KEYS, clipped=False)
    doc = {
        "task": task,
        "method": method,
        "n": summary["n"],
        "seeds": [int(s) for s in seeds],
        "success_rate": summary["success_rate"],
        "protective_stops": summary["protective_stops"],
        # mean and sample std (ddof 1) over episodes, as the experiments' tables report every spread
        **{k: {"mean": summary[k]["mean"], "std": summary[k]["std"]} for k in FORCE_KEYS},
        "train_steps": int(train_steps),
        "train_wall_time_s": float(train_wall_time_s),
        "eval_wall_time_s": float(eval_wall_time_s),
        "wall_time_s": float(
            train_wall_time_s + eval_wall_time_s + ((lerobot_eval or {}).get("wall_time_s") or 0.0)
        ),
        "lerobot_eval": lerobot_eval,
        "config": config,
        "force_inputs": force_inputs,
        "episodes": list(records),
    }
    return to_json(doc)
