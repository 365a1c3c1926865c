"""``forcemap eval``: roll a policy checkpoint in a sim task; one JSON record per episode, next to the
demonstrations' same figures.

    forcemap eval --policy outputs/press_policy --task press --episodes 20 --seed 1000 --json outputs/eval.json \
        [--dataset datasets/press] [--trace] [--video-dir outputs/videos --videos 1] [--env-state-extras ee_pose,force]
    forcemap eval --policy outputs/grasp_policy --task grasp_push --object apple --episodes 10 --json ...

The rollout is ``lerobot-eval``'s, one env at a time: ``preprocess_observation`` (raw env keys ->
``observation.*``), the checkpoint's saved pre-processor, ``policy.select_action``, the
post-processor, ``env.step``. Any LeRobot policy checkpoint loads (its ``config.json`` names the
type), not only ``forcemap``; ``--env-state-extras`` adds the env processor that ACT / Diffusion
checkpoints trained on a derived dataset need (``lerobot_env_forcemap/env_state.py``). Episode i uses
env seed ``seed + i``. ``lerobot-eval`` reports success
only; the force figures come from the env's ``info`` (filtered contact force at physics rate, the
same statistics the recorder stores per demonstration in ``meta/forcemap_episodes.json``).

JSON: ``{"task", "policy", "seed", "episodes": [record...], "summary", "demonstrations": {"source",
"fitted_episodes", "episodes": [record...], "summary_all", "summary_fitted"}, "comparison"}``; a record
has ``success, protective_stop, termination_reason, max_contact_force, mean_contact_force,
max_contact_force_xyz, mean_contact_force_xyz, steps`` and the task's metrics, plus ``trace``
(per step: t, contact force, ee pose, action) with ``--trace``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap.jsonfile import read_json_object

__all__ = [
    "FORCE_KEYS",
    "TRACE_COLUMNS",
    "to_json",
    "load_policy",
    "rollout",
    "evaluate_policy",
    "demonstration_records",
    "summarize",
    "compare",
    "add_arguments",
    "run",
]

#: columns of a rollout trace row: time, contact force, measured TCP pose, commanded action
TRACE_COLUMNS = (
    "t",
    "fx",
    "fy",
    "fz",
    "x",
    "y",
    "z",
    "qw",
    "qx",
    "qy",
    "qz",
    "target_x",
    "target_y",
    "target_z",
    "target_qw",
    "target_qx",
    "target_qy",
    "target_qz",
    "gripper",
)
#: the per-episode force figures (env ``info`` keys) compared between demonstration and reproduction
#: the trace columns of a demonstration (a subset of TRACE_COLUMNS): what forcemap report plots
DEMO_TRACE_COLUMNS = ("t", "fx", "fy", "fz", "x", "y", "z", "target_x", "target_y", "target_z")
FORCE_KEYS = ("max_contact_force", "mean_contact_force", "max_contact_force_xyz", "mean_contact_force_xyz")


def to_json(v: Any) -> Any:
    """Plain JSON types (dicts, lists, bool, int, float) from NumPy values, recursively."""
    if isinstance(v, dict):
        return {str(k): to_json(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [to_json(x) for x in v]
    if isinstance(v, np.ndarray):
        return to_json(v.tolist())
    if isinstance(v, (np.bool_, bool)):
        return bool(v)
    if isinstance(v, (np.integer, int)):
        return int(v)
    if isinstance(v, (np.floating, float)):
        return float(v)
    return v


def episode_outcome(episode) -> dict[str, Any]:
    """The head of an episode record from a finished ``lerobot_forcemap.envs.rollout.Episode``: seed,
    success, protective stop, why it ended (the task's reason, else ``time_limit`` when truncated),
    steps and wall time."""
    info = episode.info
    return {
        "seed": episode.seed,
        "success": bool(info["is_success"]),
        "protective_stop": bool(info["protective_stop"]),
        "termination_reason": info.get("termination_reason") or ("time_limit" if episode.truncated else ""),
        "steps": episode.steps,
        "wall_s": episode.wall_s,
    }


def load_policy(path: str | Path, device: str = "cpu"):
    """(policy, preprocessor, postprocessor) of a checkpoint folder, as ``lerobot-eval`` builds them."""
    from lerobot.configs.policies import PreTrainedConfig
    from lerobot.policies.factory import get_policy_class, make_pre_post_processors

    import lerobot_policy_forcemap  # noqa: F401  (registers the forcemap policy and env types)
    from lerobot_policy_forcemap.checkpoint import check_processor_files
    from lerobot_policy_forcemap.configuration_forcemap import config_error_detail

    path = Path(path)
    if not (path / "config.json").is_file():
        hint = (
            f"; forcemap eval reads local folders: `hf download {path} --local-dir DIR` first, or "
            f"`lerobot-eval --policy.path={path}`"
            if not path.exists() and len(path.parts) == 2 and not path.is_absolute()
            else ""
        )
        raise ValueError(
            f"--policy {path}: no config.json (pass a checkpoint's pretrained_model folder){hint}"
        )
    import torch

    try:
        torch.device(device)
    except (RuntimeError, TypeError) as err:
        raise ValueError(f"--device {device}: not a torch device (e.g. cpu, cuda, cuda:1, mps)") from err
    if device.startswith("cuda") and not torch.cuda.is_available():
        raise ValueError(f"--device {device}: no CUDA device on this machine (use --device cpu)")
    try:
        cfg = PreTrainedConfig.from_pretrained(path)
    except Exception as err:  # draccus' ParsingError/DecodingError, JSONDecodeError, the config's ValueErrors
        raise ValueError(
            f"--policy {path / 'config.json'}: cannot read the policy config: {config_error_detail(err)}"
        ) from err
    cfg.device = device
    cfg.pretrained_path = path
    check_processor_files(path, required=True)
    # strict: a config.json of another policy type next to forcemap tensors must not load with random weights
    try:
        policy = get_policy_class(cfg.type).from_pretrained(path, config=cfg, strict=True)
    except RuntimeError as err:  # torch/safetensors: missing or unexpected keys in the state dict
        raise ValueError(
            f"--policy {path / 'model.safetensors'}: its tensors do not fit the {cfg.type!r} policy that "
            f"config.json describes ({' '.join(str(err).split())[:400]})"
        ) from err
    pre, post = make_pre_post_processors(
        cfg,
        pretrained_path=str(path),
        preprocessor_overrides={"device_processor": {"device": device}},
    )
    return policy, pre, post


def rollout(
    env,
    policy,
    pre,
    post,
    seed: int,
    *,
    trace: bool = False,
    frames: list | None = None,
    env_pre=None,
) -> dict[str, Any]:
    """One episode; returns its record. ``frames``: a list that collects ``env.render()`` images.
    ``env_pre``: the env config's pre-processor (``EnvConfig.get_env_processors()[0]``), applied
    between ``preprocess_observation`` and the policy's pre-processor as ``lerobot-eval`` does."""
    import torch
    from lerobot.envs.utils import preprocess_observation

    from lerobot_forcemap import layout
    from lerobot_forcemap.envs.rollout import Step, run_episode

    base = env.unwrapped

    def reset(obs: dict) -> None:
        # a stochastic policy (Diffusion's sampling noise) repeats its episode; forcemap draws nothing
        torch.manual_seed(seed)
        policy.reset()

    def act(obs: dict) -> np.ndarray:
        batch = preprocess_observation(obs)
        batch["task"] = [base.task_description]
        if env_pre is not None:
            batch = env_pre(batch)
        batch = pre(batch)
        with torch.inference_mode():
            action = policy.select_action(batch)
        return post(action).detach().cpu().numpy().reshape(-1)

    def row(step: Step) -> list[float]:
        t = step.index / base.metadata["render_fps"]
        return [t, *step.info["contact_force"], *step.obs[layout.ENV_EE_POSE], *step.action.tolist()]

    episode = run_episode(
        env, act, seed, reset=reset, trace=row if trace else None, render=frames is not None
    )
    if frames is not None:
        frames.extend(episode.frames)
    info, obs = episode.info, episode.obs
    record = {
        **episode_outcome(episode),
        **{k: to_json(info[k]) for k in FORCE_KEYS},
    }
    # task metrics: scalars and short vectors (e.g. per-finger max/mean forces); the per-step contact
    # force and the clip reports are not episode figures
    skip = {"is_success", "protective_stop", "termination_reason", "contact_force", *FORCE_KEYS}
    record["metrics"] = {
        k: to_json(v)
        for k, v in info.items()
        if k not in skip and not k.startswith("clip_") and np.ndim(v) <= 1 and np.size(v) <= 16
    }
    if trace:
        record["trace"] = {
            "columns": list(TRACE_COLUMNS),
            "rows": to_json(np.asarray(episode.trace)),
            "environment_state": to_json(obs[layout.ENV_STATE]) if layout.ENV_STATE in obs else None,
            "environment_state_names": list(base.state_names.get(layout.ENV_STATE, ())),
        }
    return record


def evaluate_policy(
    policy_path: str | Path,
    task: str,
    episodes: int,
    seed: int,
    *,
    trace: bool = False,
    video_dir: str | Path | None = None,
    n_videos: int = 1,
    device: str = "cpu",
    progress: bool = True,
    env_state_extras: str | Sequence[str] | None = None,
    object_name: str | None = None,
) -> list[dict[str, Any]]:
    """Records of ``episodes`` episodes (seeds seed .. seed+episodes-1); videos of the first ``n_videos``.

    ``env_state_extras`` (e.g. ``"ee_pose,force"``): observation keys appended to
    ``observation.environment_state`` by the task's env processor, as ``lerobot-eval
    --env.env_state_extras=...`` does (for ACT / Diffusion trained on a derived dataset, see
    ``lerobot_env_forcemap/env_state.py``). A checkpoint whose environment_state size differs from
    the env's (after the extras) raises ValueError. ``object_name``: the grasping tasks' object (e.g. an
    unseen ``"apple"``; default: the demonstration object)."""
    from tqdm.auto import tqdm

    from lerobot_forcemap.envs import make
    from lerobot_forcemap.envs.registration import object_kwargs

    if episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {episodes}")
    if seed < 0:  # gymnasium's own error names no flag, and comes as a traceback
        raise ValueError(f"--seed must be >= 0, got {seed}")
    env_kwargs = object_kwargs(task, object_name, "--object")  # checked before the policy loads
    policy, pre, post = load_policy(policy_path, device)
    _match_control_rate(policy, task)
    want_video = video_dir is not None and n_videos > 0
    env = make(task, render_mode="rgb_array" if want_video else None, **env_kwargs)
    try:
        env_pre = _env_preprocessor(task, env, policy, env_state_extras)
    except Exception:
        env.close()
        raise
    records = []
    try:
        for i in tqdm(range(episodes), desc=f"eval {task}", unit="episode", disable=not progress):
            frames = [] if want_video and i < n_videos else None
            rec = rollout(env, policy, pre, post, seed + i, trace=trace, frames=frames, env_pre=env_pre)
            rec["episode"] = i
            if frames:
                rec["video"] = str(
                    write_video(frames, Path(video_dir) / f"eval_episode_{i}.mp4", env.metadata["render_fps"])
                )
            records.append(rec)
    finally:
        env.close()
    return records


def _match_control_rate(policy, task: str) -> None:
    """A forcemap skill fitted at another rate than the task's control rate (a real 50 fps demonstration
    in the 20 Hz sim) advances by the env's control period per step: ``control_fps`` is set, with a note."""
    from lerobot_forcemap.envs.registration import task_spec

    cfg = policy.config
    rate = task_spec(task).control_hz
    if getattr(cfg, "type", None) != "forcemap" or cfg.control_fps is not None or abs(cfg.fps - rate) < 1e-9:
        return
    cfg.control_fps = rate
    print(
        f"note: the policy was fitted at {cfg.fps:g} fps and {task} steps at {rate:g} Hz: control_fps={rate:g} "
        f"(lerobot-eval: --policy.control_fps={rate:g})",
        file=sys.stderr,
    )


def _env_preprocessor(task: str, env, policy, env_state_extras):
    """The task's env pre-processor with ``env_state_extras`` (None when there are none), after
    checking that the policy's environment_state size equals the env's after the extras."""
    from lerobot.envs.configs import EnvConfig

    from lerobot_env_forcemap.configs import ENV_TYPES
    from lerobot_env_forcemap.env_state import ENV_STATE_EXTRA_KEYS, parse_env_state_extras
    from lerobot_forcemap import layout

    extras = parse_env_state_extras(env_state_extras)
    extras_spec = ",".join(extras)
    env_pre = None
    if extras:
        if task not in ENV_TYPES:
            raise ValueError(
                f"--env-state-extras: task {task!r} has no LeRobot env type (known: {sorted(ENV_TYPES)})"
            )
        env_cfg = EnvConfig.get_choice_class(ENV_TYPES[task])(env_state_extras=extras_spec)
        env_pre, _ = env_cfg.get_env_processors()
    spaces = getattr(env.observation_space, "spaces", {})
    wanted = getattr(policy.config, "input_features", {}).get(layout.OBS_ENV_STATE)
    if wanted is not None and layout.ENV_STATE in spaces:
        raw_for = {v: k for k, v in layout.ENV_TO_FEATURE.items()}
        have = spaces[layout.ENV_STATE].shape[0]
        for e in extras:
            raw = raw_for[ENV_STATE_EXTRA_KEYS[e]]
            if raw not in spaces:
                raise ValueError(f"--env-state-extras: env {task!r} has no observation {raw!r} (extra {e!r})")
            have += spaces[raw].shape[0]
        if have != wanted.shape[0]:
            raise ValueError(
                f"policy expects observation.environment_state of size {wanted.shape[0]}, env {task!r} gives {have} "
                f"with env_state_extras={list(extras)} (a checkpoint trained on a derived dataset needs "
                "--env-state-extras, e.g. ee_pose,force; see lerobot_env_forcemap/env_state.py)"
            )
    return env_pre


def write_video(frames: Sequence[np.ndarray], path: Path, fps: float) -> Path:
    import imageio.v2 as imageio

    path.parent.mkdir(parents=True, exist_ok=True)
    with imageio.get_writer(str(path), fps=fps, codec="libx264", macro_block_size=1) as writer:
        for f in frames:
            writer.append_data(np.asarray(f))
    return path


# ---- demonstrations -------------------------------------------------------------------------------------


def demonstration_records(
    dataset: str | Path, *, trace: bool = False, task: str | None = None
) -> tuple[list[dict[str, Any]], str]:
    """Per-episode force figures of the demonstrations in a dataset; returns (records, source).

    Source ``meta/forcemap_episodes.json`` (written by ``forcemap record``: the env's own statistics,
    comparable to eval records), else the dataset's ``contact_force`` column, else the wrist force
    ``observation.force`` (both at the dataset's frame rate, so maxima may read lower). ``trace``
    adds per-frame rows ``t, fx, fy, fz, x, y, z, target_x, target_y, target_z`` and the episode's
    first environment state. ``task``: the evaluated task; demonstrations ``forcemap record`` wrote for
    another task are refused (a press policy compared with erase demonstrations says nothing).
    """
    from lerobot_forcemap import layout

    root = Path(dataset)
    meta_file = root / "meta" / "forcemap_episodes.json"
    records: list[dict[str, Any]] = []
    source = ""
    if meta_file.is_file():
        data = read_json_object(meta_file)
        if task is not None and data.get("task") not in (None, task):
            raise ValueError(
                f"--dataset {root}: demonstrations of task {data['task']!r} ({meta_file.name}), not of the "
                f"evaluated task {task!r}"
            )
        for i, ep in enumerate(data.get("episodes", [])):
            _check_force_figures(ep, f"{meta_file}: episodes[{i}]")
            records.append(
                {
                    "episode": i,
                    "seed": ep.get("seed"),
                    "success": bool(ep.get("is_success", True)),
                    "protective_stop": bool(ep.get("protective_stop", False)),
                    **({"object": ep["object"]} if "object" in ep else {}),
                    **{k: ep[k] for k in FORCE_KEYS if k in ep},
                }
            )
        source = str(meta_file)
    need_table = trace or not records
    if need_table:
        table, names = _read_table(root)
        ep_col = table["episode_index"].astype(int)
        force_key = layout.CONTACT_FORCE if layout.CONTACT_FORCE in table else layout.OBS_FORCE
        if not records:
            source = f"{root} column {force_key!r} (frame rate)"
        for e in np.unique(ep_col):
            rows = ep_col == e
            f = table[force_key][rows][:, :3].astype(float)
            if len(records) <= e:
                n = np.linalg.norm(f, axis=1)
                records.append(
                    {
                        "episode": int(e),
                        "success": True,
                        "protective_stop": False,
                        "max_contact_force": float(n.max()),
                        "mean_contact_force": float(n.mean()),
                        "max_contact_force_xyz": np.abs(f).max(axis=0).tolist(),
                        "mean_contact_force_xyz": np.abs(f).mean(axis=0).tolist(),
                    }
                )
            if trace:
                t = table["timestamp"][rows].astype(float).reshape(-1)
                ee = table[layout.OBS_EE_POSE][rows][:, :3].astype(float)
                act = table[layout.ACTION][rows][:, :3].astype(float)
                env_state = table[layout.OBS_ENV_STATE][rows][0] if layout.OBS_ENV_STATE in table else None
                records[int(e)]["trace"] = {
                    "columns": list(DEMO_TRACE_COLUMNS),
                    "rows": to_json(np.column_stack([t - t[0], f, ee, act])),
                    "environment_state": to_json(env_state) if env_state is not None else None,
                    "environment_state_names": names,
                    "force_source": force_key,
                }
    return records, source


def is_finite_number(value: object) -> bool:
    """A finite int or float, not a bool (JSON's NaN and Infinity would print as "nan" in tables)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)


def _check_force_figures(record: Any, where: str) -> None:
    """The force figures of one record are finite numbers (3 per ``_xyz`` key); ``ValueError`` naming
    ``where`` and the key otherwise (a NaN would print as "+nan%" and write non-standard JSON)."""
    if not isinstance(record, dict):
        raise ValueError(f"{where}: expected an object, got {type(record).__name__}")
    for key in FORCE_KEYS:
        if key not in record:
            continue
        value = np.asarray(record[key], dtype=object)
        shape = (3,) if key.endswith("_xyz") else ()
        ok = value.shape == shape and all(map(is_finite_number, value.flat))
        if not ok:
            raise ValueError(
                f"{where}.{key}: {record[key]!r} is not {'3 finite numbers' if shape else 'a finite number'}"
            )


def _read_table(root: Path) -> tuple[dict[str, np.ndarray], list[str]]:
    """Numeric 1-D features of a LeRobot v3 dataset as ``{key: (rows, width)}`` (episode_index,
    timestamp, frame_index as ``(rows,)``), read by ``lerobot_forcemap.data.reader`` (no video
    decoding); + env-state names."""
    from lerobot_forcemap.data.reader import read_columns, read_meta

    meta = read_meta(root)
    features = meta.features
    keys = [
        k
        for k, ft in features.items()
        if ft["dtype"] not in ("image", "video", "string", "language") and len(ft["shape"]) == 1
    ]
    cols = read_columns(meta, list(range(meta.total_episodes)), keys)
    out = {k: v.reshape(len(v), -1) for k, v in cols.items()}
    for k in ("episode_index", "timestamp", "frame_index"):
        out[k] = out[k][:, 0]
    names = list(features.get("observation.environment_state", {}).get("names") or [])
    return out, names


# ---- summaries --------------------------------------------------------------------------------------------


def summarize(records: Sequence[dict[str, Any]]) -> dict[str, Any]:
    """n, success rate, protective stops, and mean/std of the force figures over episodes (the sample
    std, ddof 1, as the experiments report gives; 0 for one episode)."""
    if not records:
        return {"n": 0}
    out: dict[str, Any] = {
        "n": len(records),
        "success_rate": float(np.mean([r["success"] for r in records])),
        "protective_stops": int(sum(r["protective_stop"] for r in records)),
    }
    for k in FORCE_KEYS:
        v = np.array([r[k] for r in records if k in r], dtype=float)
        if len(v):
            out[k] = {
                "mean": to_json(v.mean(axis=0)),
                "std": to_json(v.std(axis=0, ddof=1) if len(v) > 1 else np.zeros_like(v[0])),
                "max": to_json(v.max(axis=0)),
            }
    # the env clips targets outside its workspace / speed limit and says so per step in info; here the
    # episodes' counts add up, so a report shows whether the policy asked for what the robot did not do
    clipped = [r["metrics"]["n_clipped_steps"] for r in records if "n_clipped_steps" in r.get("metrics", {})]
    if clipped:
        out["clipped_steps"] = int(sum(clipped))
        out["episodes_clipped"] = int(sum(c > 0 for c in clipped))
    return out


def compare(reproduction: dict[str, Any], demonstration: dict[str, Any]) -> dict[str, Any]:
    """% change of the mean force figures, reproduction vs demonstration (negative = less force)."""
    out = {}
    for k in FORCE_KEYS:
        if k in reproduction and k in demonstration:
            r = np.asarray(reproduction[k]["mean"], dtype=float)
            d = np.asarray(demonstration[k]["mean"], dtype=float)
            with np.errstate(divide="ignore", invalid="ignore"):
                out[k + "_change_pct"] = to_json(np.where(d != 0, 100.0 * (r - d) / d, np.nan))
    return out


def evaluation_document(
    policy_path: str | Path,
    task: str,
    seed: int,
    records: list[dict[str, Any]],
    dataset: str | Path | None,
    *,
    demo_trace: bool = False,
    object_name: str | None = None,
    demonstrations: tuple[list[dict[str, Any]], str] | None = None,
) -> dict[str, Any]:
    """The eval JSON document (module docstring). ``demonstrations``: ``demonstration_records(dataset)``
    if already read (``forcemap eval`` reads them before the rollouts, so a bad dataset fails first)."""
    doc: dict[str, Any] = {
        "task": task,
        **({"object": object_name} if object_name is not None else {}),
        "policy": str(policy_path),
        "seed": int(seed),
        "episodes": records,
        "summary": summarize(records),
    }
    fitted = _fitted_episodes(policy_path)
    if dataset is not None:
        demos, source = demonstrations or demonstration_records(dataset, trace=demo_trace, task=task)
        used = [d for d in demos if d["episode"] in fitted] if fitted else []
        doc["demonstrations"] = {
            "dataset": str(dataset),
            "source": source,
            "fitted_episodes": fitted,
            "episodes": demos,
            "summary_all": summarize(demos),
            "summary_fitted": summarize(used),
        }
        ref = doc["demonstrations"]["summary_fitted"] if used else doc["demonstrations"]["summary_all"]
        doc["comparison"] = {
            "against": "fitted demonstrations" if used else "all demonstrations",
            **compare(doc["summary"], ref),
            "vs_all_demonstrations": compare(doc["summary"], doc["demonstrations"]["summary_all"]),
        }
    return to_json(doc)


def _fitted_episodes(policy_path: str | Path) -> list[int]:
    try:
        cfg = json.loads((Path(policy_path) / "config.json").read_text())
    except (OSError, json.JSONDecodeError):
        return []
    return [int(e) for e in cfg.get("episodes", [])] if cfg.get("type") == "forcemap" else []


def _default_dataset(policy_path: Path) -> Path | None:
    """The demonstrations a checkpoint was fitted on, if still there: lerobot-train's ``train_config.json``
    (``dataset.root``), else ``forcemap fit``'s ``fit_report.json`` (``dataset``). A relative path (as
    typed when training) is looked for from the current folder, then from the checkpoint's parent
    folders (run from elsewhere); a dataset named but not found is said on stderr."""
    named = []
    for name, field in (("train_config.json", ("dataset", "root")), ("fit_report.json", ("dataset",))):
        path = policy_path / name
        if not path.is_file():
            continue
        try:
            value: Any = read_json_object(path)
        except (OSError, ValueError):  # a best-effort default: an unreadable file names no dataset
            continue
        for key in field:
            value = value.get(key) if isinstance(value, dict) else None
        if not (isinstance(value, str) and value):
            continue
        candidates = [Path(value)]
        if not Path(value).is_absolute():
            candidates += [parent / value for parent in policy_path.resolve().parents]
        for candidate in candidates:
            if (candidate / "meta" / "info.json").is_file():
                return candidate
        named.append(f"{value!r} ({name})")
    if named:
        print(
            f"note: the fitted dataset {' / '.join(named)} was not found from here; no comparison with the "
            "demonstrations (pass --dataset)",
            file=sys.stderr,
        )
    return None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from lerobot_forcemap.envs.registration import TASKS

    parser.add_argument("--policy", required=True, help="checkpoint folder (config.json + model.safetensors)")
    # choices: a typo is named as such, before the checkpoint's dataset is compared with it
    parser.add_argument("--task", required=True, choices=sorted(TASKS), help="sim task")
    parser.add_argument("--episodes", type=int, default=20, help="number of episodes (default 20)")
    parser.add_argument("--seed", type=int, default=1000, help="env seed of the first episode (default 1000)")
    parser.add_argument("--json", required=True, help="output JSON file")
    parser.add_argument(
        "--dataset",
        default=None,
        help="demonstration dataset for the comparison (default: the dataset named in the checkpoint's "
        "train_config.json or fit_report.json, if it is still there)",
    )
    parser.add_argument(
        "--object",
        default=None,
        help="grasping tasks: the object, e.g. apple (default: the demonstration object)",
    )
    parser.add_argument("--trace", action="store_true", help="store per-step force / pose / action traces")
    parser.add_argument(
        "--video-dir", default=None, help="write mp4 videos of the first --videos episodes here"
    )
    parser.add_argument(
        "--videos", type=int, default=None, help="how many episodes to film (default 1; needs --video-dir)"
    )
    parser.add_argument("--device", default="cpu")
    parser.add_argument(
        "--env-state-extras",
        default=None,
        help="observation keys appended to environment_state before the policy, e.g. ee_pose,force "
        "(ACT / Diffusion checkpoints trained on a derived dataset; lerobot-eval: --env.env_state_extras)",
    )


def run(args: argparse.Namespace) -> int:
    out = Path(args.json)
    if out.is_dir():  # found before the rollouts, not after
        raise ValueError(f"--json {out}: is a folder; give the path of the JSON file to write")
    for flag, given, folder in (("--json", out, out.parent), ("--video-dir", args.video_dir, args.video_dir)):
        if folder is None:
            continue
        blocked = next((p for p in (Path(folder), *Path(folder).parents) if p.exists()), None)
        if blocked is not None and not blocked.is_dir():
            raise ValueError(f"{flag} {given}: {blocked} is a file, not a folder")
    if args.videos is not None and (args.video_dir is None or args.videos < 0):
        raise ValueError(
            f"--videos {args.videos}: "
            + ("must be >= 0" if args.videos < 0 else "give --video-dir too (where the mp4 files go)")
        )
    if args.videos is not None and args.videos > args.episodes:  # would film fewer than asked, silently
        raise ValueError(
            f"--videos {args.videos}: more than --episodes {args.episodes}; film at most every episode"
        )
    if args.dataset:  # found before the rollouts, not after them with nothing written
        from lerobot_forcemap.data.schema import require_dataset_root

        require_dataset_root(args.dataset, "--dataset")
    dataset = args.dataset or _default_dataset(Path(args.policy))
    demonstrations = (
        demonstration_records(dataset, trace=args.trace, task=args.task) if dataset is not None else None
    )
    records = evaluate_policy(
        args.policy,
        args.task,
        args.episodes,
        args.seed,
        trace=args.trace,
        video_dir=args.video_dir,
        n_videos=1 if args.videos is None else args.videos,
        device=args.device,
        env_state_extras=getattr(args, "env_state_extras", None),
        object_name=getattr(args, "object", None),
    )
    doc = evaluation_document(
        args.policy,
        args.task,
        args.seed,
        records,
        dataset,
        demo_trace=args.trace,
        object_name=args.object,
        demonstrations=demonstrations,
    )
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(json.dumps(doc, indent=1))
    s = doc["summary"]
    print(
        f"{args.task}{f' ({args.object})' if args.object else ''}: success {100 * s['success_rate']:.0f}% of {s['n']}, protective stops {s['protective_stops']}, "
        f"max force {s['max_contact_force']['mean']:.1f} N, mean force {s['mean_contact_force']['mean']:.2f} N"
    )
    if "comparison" in doc:
        c = doc["comparison"]
        print(
            f"vs {c['against']}: max force {c['max_contact_force_change_pct']:+.0f}%, "
            f"mean force {c['mean_contact_force_change_pct']:+.0f}%"
        )
    print(f"wrote {out}")
    return 0
