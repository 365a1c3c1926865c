"""Evaluate a LeRobot policy checkpoint in a sim task: one record per episode, and the eval document.

    records = evaluate_policy("outputs/press_policy", "press", episodes=20, seed=1000, trace=True)
    doc = evaluation_document("outputs/press_policy", "press", 1000, records, "datasets/press")

The rollout is ``lerobot-eval``'s, one env at a time: ``preprocess_observation`` (raw env keys ->
``observation.*``), the env config's processor when ``env_state_extras`` are asked for, the
checkpoint's saved pre-processor, ``policy.select_action``, the post-processor, ``env.step``. Any
LeRobot policy checkpoint loads (its ``config.json`` names the type; plugin policies are found by
LeRobot's plugin discovery), not only ``forcemap``. Episode i uses env seed ``seed + i`` and seeds
torch with it, so a sampling policy (Diffusion) repeats its episode. ``lerobot-eval`` reports success
only; the force figures come from the env's ``info`` (``records.py``).

Eval document: ``{"task", ["object"], "policy", "seed", "episodes": [record...], "summary",
"demonstrations": {"dataset", "source", "fitted_episodes", "episodes": [record...], "summary_all",
"summary_fitted"}, "comparison"}`` (the demonstrations and the comparison when a dataset is known;
summaries are ``stats.summarize``'s, comparisons ``stats.percent_change``'s). ``forcemap eval``
(``lerobot_forcemap/cli/eval.py``) writes it.
"""

from __future__ import annotations

import functools
import json
import sys
from collections.abc import Callable, Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap._validation import check_int
from lerobot_forcemap.evaluation.demonstrations import demonstration_records
from lerobot_forcemap.evaluation.records import (
    episode_record,
    finite_or_none,
    to_json,
    trace_block,
    trace_row,
)
from lerobot_forcemap.evaluation.stats import percent_change, summarize
from lerobot_forcemap.executor import Executor
from lerobot_forcemap.jsonfile import read_json_object

__all__ = [
    "PROCESSOR_FILES",
    "load_policy",
    "lerobot_actor",
    "rollout",
    "EvalJob",
    "evaluate_policy",
    "run_episodes",
    "evaluation_document",
    "default_dataset",
    "write_video",
]

#: LeRobot's pre-/post-processor pipelines saved next to a policy (``make_pre_post_processors`` reads them)
PROCESSOR_FILES = ("policy_preprocessor.json", "policy_postprocessor.json")


# ---- loading ------------------------------------------------------------------------------------------


@functools.cache
def _register_plugins() -> None:
    """LeRobot's plugin discovery (once per process): imports the installed ``lerobot_policy_*`` /
    ``lerobot_env_*`` distributions, which register their policy and env types as ``lerobot-eval`` finds them."""
    from lerobot.utils.import_utils import register_third_party_plugins

    register_third_party_plugins()


def load_policy(path: str | Path, device: str = "cpu"):
    """(policy, preprocessor, postprocessor) of a local checkpoint folder, as ``lerobot-eval`` builds them.

    ``ValueError`` naming the file for a folder without ``config.json`` or the processor pipelines, a
    config that does not parse, tensors that do not fit the config's policy type (loaded strictly: a
    config of another type next to the tensors must not load with random weights), and for a device
    torch does not know or this machine lacks.
    """
    from lerobot.policies.factory import get_policy_class, make_pre_post_processors

    path = _checkpoint_folder(path)
    _check_device(device)
    _register_plugins()
    cfg = _read_policy_config(path)
    cfg.device = device
    cfg.pretrained_path = path
    for name in PROCESSOR_FILES:
        if not (path / name).is_file():
            raise ValueError(
                f"{path / name}: file not found (a checkpoint saved by lerobot-train or forcemap fit has "
                f"{' and '.join(PROCESSOR_FILES)} next to config.json)"
            )
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


def _checkpoint_folder(path: str | Path) -> Path:
    """``path`` if it holds ``config.json``; the error hints at downloading a Hub repo id first."""
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
    return path


def _check_device(device: str) -> None:
    import torch

    try:
        torch.device(device)
    except (RuntimeError, TypeError) as err:
        raise ValueError(f"--device {device}: not a torch device (e.g. cpu, cuda, cuda:1, mps)") from err
    if device.startswith("cuda") and not torch.cuda.is_available():
        raise ValueError(f"--device {device}: no CUDA device on this machine (use --device cpu)")


def _read_policy_config(path: Path):
    """The checkpoint's config; a config that does not parse is named with its reason (draccus says only
    that it failed; the reason, e.g. the config's own ValueError naming the field, is its cause)."""
    from lerobot.configs.policies import PreTrainedConfig

    try:
        return PreTrainedConfig.from_pretrained(path)
    except Exception as err:  # draccus' ParsingError/DecodingError, JSONDecodeError, the config's ValueErrors
        cause = err.__cause__ or err.__context__
        detail = f"{err}" + (f" ({cause})" if cause is not None else "")
        raise ValueError(f"--policy {path / 'config.json'}: cannot read the policy config: {detail}") from err


# ---- rollouts -----------------------------------------------------------------------------------------


def lerobot_actor(
    policy, pre, post, task_description: str, *, torch_seed: int | None = None, env_pre=None
) -> tuple[Callable[[dict], None], Callable[[dict], np.ndarray]]:
    """``(reset, act)`` hooks of ``envs.rollout.run_episode`` running a LeRobot policy the way
    ``lerobot-eval`` does. ``torch_seed``: seed torch at reset (a sampling policy repeats its episode);
    ``env_pre``: the env config's pre-processor, between ``preprocess_observation`` and the policy's."""
    import torch
    from lerobot.envs.utils import preprocess_observation

    def reset(obs: dict) -> None:
        if torch_seed is not None:
            torch.manual_seed(torch_seed)
        policy.reset()

    def act(obs: dict) -> np.ndarray:
        batch = preprocess_observation(obs)
        batch["task"] = [task_description]
        if env_pre is not None:
            batch = env_pre(batch)
        batch = pre(batch)
        with torch.inference_mode():
            action = policy.select_action(batch)
        return post(action).detach().cpu().numpy().reshape(-1)

    return reset, act


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
    """One episode of a LeRobot policy (torch seeded with ``seed``); returns its record (``records.py``).
    ``frames``: a list that collects ``env.render()`` images; ``env_pre``: see :func:`lerobot_actor`."""
    from lerobot_forcemap import layout
    from lerobot_forcemap.envs.rollout import run_episode

    base = env.unwrapped
    reset, act = lerobot_actor(policy, pre, post, base.task_description, torch_seed=seed, env_pre=env_pre)
    fps = base.metadata["render_fps"]
    episode = run_episode(
        env,
        act,
        seed,
        reset=reset,
        trace=(lambda step: trace_row(step, fps)) if trace else None,
        render=frames is not None,
    )
    if frames is not None:
        frames.extend(episode.frames)
    record = episode_record(episode)
    if trace:
        record["trace"] = trace_block(
            episode.trace,
            episode.obs.get(layout.ENV_STATE),
            base.state_names.get(layout.ENV_STATE, ()),
        )
    return record


@dataclass(frozen=True)
class EvalJob:
    """Episodes ``episodes`` (indices; env seed ``seed + i``) of one policy in one task: a job of an
    :mod:`lerobot_forcemap.executor` (what :func:`evaluate_policy` hands its workers)."""

    policy_path: str
    task: str
    episodes: tuple[int, ...]
    seed: int
    trace: bool = False
    video_dir: str | None = None
    n_videos: int = 1
    device: str = "cpu"
    env_state_extras: str | tuple[str, ...] | None = None
    object_name: str | None = None
    randomize: str = "paper"
    progress: bool = False


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
    randomize: str = "paper",
    executor: Executor | None = None,
) -> list[dict[str, Any]]:
    """Records of ``episodes`` episodes (env seeds seed .. seed+episodes-1); videos of the first ``n_videos``.

    ``env_state_extras`` (e.g. ``"ee_pose,force"``): observation keys appended to
    ``observation.environment_state`` by the task's env processor, as ``lerobot-eval
    --env.env_state_extras=...`` does (for ACT / Diffusion trained on a derived dataset, see
    ``lerobot_env_forcemap/env_state.py``). A checkpoint whose environment_state size differs from
    the env's (after the extras) raises ValueError. ``object_name``: the grasping tasks' object (e.g. an
    unseen ``"apple"``; default: the demonstration object). ``randomize``: the env's randomisation level
    (``"none"``, ``"paper"``, ``"wide"``: ``lerobot_forcemap/envs/variation.py``). ``executor``: runs the
    episodes in contiguous blocks, one per worker, each loading the policy once (default: all in this
    process); the records are the same either way (each episode depends only on its seed)."""
    from lerobot_forcemap.envs.registration import object_kwargs

    check_int("--episodes", episodes, low=1)
    check_int("--seed", seed, low=0)  # gymnasium's own error names no flag
    check_int("--videos", n_videos, low=0)
    object_kwargs(task, object_name, "--object")  # checked before the policy loads
    extras = (
        env_state_extras
        if env_state_extras is None or isinstance(env_state_extras, str)
        else tuple(env_state_extras)
    )
    job = EvalJob(
        str(policy_path),
        task,
        tuple(range(episodes)),
        seed,
        trace=trace,
        video_dir=None if video_dir is None else str(video_dir),
        n_videos=n_videos,
        device=device,
        env_state_extras=extras,
        object_name=object_name,
        randomize=randomize,
        progress=progress,
    )
    if executor is None or executor.kind == "serial":
        return run_episodes(job)
    return _run_blocks(job, executor, progress)


def _run_blocks(job: EvalJob, executor: Executor, progress: bool) -> list[dict[str, Any]]:
    """``job``'s episodes on ``executor``: one contiguous block per worker, records in episode order."""
    n = len(job.episodes)
    blocks = [b.tolist() for b in np.array_split(np.arange(n), min(n, executor.workers))]
    jobs = [replace(job, episodes=tuple(b), progress=False) for b in blocks]
    weights = [len(b) for b in blocks]
    done = executor.map(
        run_episodes, jobs, desc=f"eval {job.task}", unit="episode", weights=weights, progress=progress
    )
    return [rec for block in done for rec in block]


def run_episodes(job: EvalJob) -> list[dict[str, Any]]:
    """The records of ``job``'s episodes, rolled out here: the policy loaded once, one env."""
    from tqdm.auto import tqdm

    from lerobot_forcemap.envs import make
    from lerobot_forcemap.envs.registration import object_kwargs

    env_kwargs = object_kwargs(job.task, job.object_name, "--object")
    policy, pre, post = load_policy(job.policy_path, job.device)
    _match_control_rate(policy, job.task)
    want_video = job.video_dir is not None and job.n_videos > 0
    env = make(
        job.task, render_mode="rgb_array" if want_video else None, randomize=job.randomize, **env_kwargs
    )
    records = []
    try:
        env_pre = _env_preprocessor(job.task, env, policy, job.env_state_extras)
        for i in tqdm(job.episodes, desc=f"eval {job.task}", unit="episode", disable=not job.progress):
            frames = [] if want_video and i < job.n_videos else None
            rec = rollout(
                env, policy, pre, post, job.seed + i, trace=job.trace, frames=frames, env_pre=env_pre
            )
            rec["episode"] = i
            if frames:
                video = Path(job.video_dir) / f"eval_episode_{i}.mp4"
                rec["video"] = str(write_video(frames, video, env.metadata["render_fps"]))
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
    from lerobot_env_forcemap.env_state import parse_env_state_extras

    extras = parse_env_state_extras(env_state_extras)
    env_pre = None
    if extras:
        if task not in ENV_TYPES:
            raise ValueError(
                f"--env-state-extras: task {task!r} has no LeRobot env type (known: {sorted(ENV_TYPES)})"
            )
        env_cfg = EnvConfig.get_choice_class(ENV_TYPES[task])(env_state_extras=",".join(extras))
        env_pre, _ = env_cfg.get_env_processors()
    _check_env_state_size(task, env, policy, extras)
    return env_pre


def _check_env_state_size(task: str, env, policy, extras: Sequence[str]) -> None:
    """The policy's ``observation.environment_state`` size equals the env's after ``extras``."""
    from lerobot_env_forcemap.env_state import ENV_STATE_EXTRA_KEYS
    from lerobot_forcemap import layout

    spaces = getattr(env.observation_space, "spaces", {})
    wanted = getattr(policy.config, "input_features", {}).get(layout.OBS_ENV_STATE)
    if wanted is None or layout.ENV_STATE not in spaces:
        return
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


def write_video(frames: Sequence[np.ndarray], path: Path, fps: float) -> Path:
    """An H.264 mp4 of ``frames`` at ``fps`` (the folder is made); returns ``path``."""
    import imageio.v2 as imageio

    path.parent.mkdir(parents=True, exist_ok=True)
    with imageio.get_writer(str(path), fps=fps, codec="libx264", macro_block_size=1) as writer:
        for f in frames:
            writer.append_data(np.asarray(f))
    return path


# ---- the eval document --------------------------------------------------------------------------------


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
    """The eval document (module docstring), JSON-ready (non-finite numbers as null).
    ``demonstrations``: ``demonstration_records(dataset)`` if already read (``forcemap eval`` reads
    them before the rollouts, so a bad dataset fails first)."""
    doc: dict[str, Any] = {
        "task": task,
        **({"object": object_name} if object_name is not None else {}),
        "policy": str(policy_path),
        "seed": int(seed),
        "episodes": records,
        "summary": summarize(records),
    }
    if dataset is not None:
        demos, source = demonstrations or demonstration_records(dataset, trace=demo_trace, task=task)
        doc.update(_comparison(doc["summary"], demos, source, dataset, _fitted_episodes(policy_path)))
    return finite_or_none(to_json(doc))


def _comparison(
    summary: dict[str, Any], demos: list[dict[str, Any]], source: str, dataset: str | Path, fitted: list[int]
) -> dict[str, Any]:
    """The document's ``demonstrations`` and ``comparison``: against the fitted demonstrations when the
    checkpoint names them, else against all."""
    used = [d for d in demos if d["episode"] in fitted] if fitted else []
    block = {
        "dataset": str(dataset),
        "source": source,
        "fitted_episodes": fitted,
        "episodes": demos,
        "summary_all": summarize(demos),
        "summary_fitted": summarize(used),
    }
    ref = block["summary_fitted"] if used else block["summary_all"]
    comparison = {
        "against": "fitted demonstrations" if used else "all demonstrations",
        **percent_change(summary, ref),
        "vs_all_demonstrations": percent_change(summary, block["summary_all"]),
    }
    return {"demonstrations": block, "comparison": comparison}


def _fitted_episodes(policy_path: str | Path) -> list[int]:
    """The demonstrations a forcemap checkpoint was fitted on (its ``config.json`` ``episodes``)."""
    try:
        cfg = json.loads((Path(policy_path) / "config.json").read_text())
    except (OSError, json.JSONDecodeError):
        return []
    return [int(e) for e in cfg.get("episodes", [])] if cfg.get("type") == "forcemap" else []


def default_dataset(policy_path: Path) -> Path | None:
    """The demonstrations a checkpoint was fitted on, if still there: lerobot-train's ``train_config.json``
    (``dataset.root``), else ``forcemap fit``'s ``fit_report.json`` (``dataset``). A relative path (as
    typed when training) is looked for from the current folder, then from the checkpoint's parent
    folders (run from elsewhere); a dataset named but not found is said on stderr."""
    named = []
    for name, field in (("train_config.json", ("dataset", "root")), ("fit_report.json", ("dataset",))):
        value = _named_dataset(policy_path / name, field)
        if value is None:
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


def _named_dataset(path: Path, field: tuple[str, ...]) -> str | None:
    """The non-empty string at ``field`` of the JSON file ``path`` (None when it is not there: a
    best-effort default, an unreadable file names no dataset)."""
    if not path.is_file():
        return None
    try:
        value: Any = read_json_object(path)
    except (OSError, ValueError):
        return None
    for key in field:
        value = value.get(key) if isinstance(value, dict) else None
    return value if isinstance(value, str) and value else None
