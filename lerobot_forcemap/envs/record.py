"""Scripted demonstrations of a sim task into a LeRobot v3 dataset (the library part of ``forcemap
record``; the command line is ``lerobot_forcemap/cli/record.py``).

Episode ``e`` runs the env with seed ``seed + k`` (k counts attempts) and a demonstrator whose
generator is spawned from the same seed. Failed demonstrations are not written (the paper excluded
demonstrations that hit the safety stop), and each skip is reported. fps = the task's control rate.

Per frame: ``observation.state/ee_pose/force/environment_state`` (+ ``finger_force`` for grippers with
fingertip sensors, + ``observation.images.front`` with ``images``), ``action``, and ground-truth
columns from ``layout``: ``contact_force`` (the env's filtered contact force), ``demo_phase``, and the
contact features every dataset of the project has (``data.contacts.frame_contact_features``: no hand
guides the tool, so ``contact_reaction`` is the contact force and ``contact`` the frames where it
exceeds 2 N).
Per episode, ``meta/forcemap_episodes.json`` holds the seed, the env's ``info`` force statistics
(max / mean contact force, norm and per axis) and task metrics, and the demonstrator's parameters —
the numbers a reproduction is compared with. The dataset is written beside ``out`` and moved there
only when complete: a failure leaves no dataset, and an existing one untouched.
"""

from __future__ import annotations

import json
import shutil
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .._validation import check_bool, check_int, fail, is_int
from ..data.hub import check_repo_id
from ..data.staging import check_output, partial_dir, replace_dir
from ..layout import (
    ACTION,
    CONTACT_FORCE,
    CONTACT_FORCE_NAMES,
    DEMO_PHASE,
    ENV_AGENT_POS,
    ENV_EE_POSE,
    ENV_FINGER_FORCE,
    ENV_FORCE,
    ENV_PIXELS,
    ENV_STATE,
    EPISODES_FILE,
    OBS_EE_POSE,
    OBS_ENV_STATE,
    OBS_FINGER_FORCE,
    OBS_FORCE,
    OBS_IMAGES_PREFIX,
    OBS_STATE,
)
from .registration import TaskSpec, make, object_kwargs, task_spec
from .rollout import Episode, Step, run_episode
from .scene import CAMERA

__all__ = ["EPISODES_FILE", "RecordResult", "episode_record", "record_demonstrations", "summary"]


@dataclass
class RecordResult:
    """What :func:`record_demonstrations` wrote: the dataset root, the seeds recorded and skipped, and
    the per-episode records of ``meta/forcemap_episodes.json``."""

    root: Path
    task: str
    n_episodes: int
    seeds: list[int]
    skipped_seeds: list[int]
    episodes: list[dict[str, Any]] = field(default_factory=list)


def _json_value(v: Any) -> Any:
    if isinstance(v, np.ndarray):
        return [float(x) for x in v.ravel()]
    if isinstance(v, (np.floating, float)):
        return float(v)
    if isinstance(v, (np.integer, int, np.bool_, bool)):
        return v.item() if hasattr(v, "item") else v
    return v


def episode_record(
    info: dict[str, Any], seed: int, n_frames: int, demo_params: dict[str, Any]
) -> dict[str, Any]:
    """The per-episode summary stored in ``meta/forcemap_episodes.json`` (JSON-safe)."""
    keep = {k: _json_value(v) for k, v in info.items() if not k.startswith("clip_") and k != "contact_force"}
    return {
        "seed": int(seed),
        "n_frames": int(n_frames),
        **keep,
        "demonstrator": {k: _json_value(v) for k, v in demo_params.items()},
    }


def record_demonstrations(
    task: str,
    episodes: int,
    seed: int,
    out: str | Path,
    *,
    images: bool = False,
    image_size: int = 128,
    repo_id: str | None = None,
    overwrite: bool = False,
    max_attempts: int | None = None,
    progress: bool = True,
    object_name: str | None = None,
) -> RecordResult:
    """Record ``episodes`` successful scripted demonstrations of ``task`` into a dataset at ``out``.

    ``seed``: of the first attempt; ``images``: also the front camera at ``image_size`` px (video);
    ``repo_id``: default ``local/forcemap_<task>``; ``overwrite``: replace a dataset at ``out``;
    ``max_attempts``: give up after that many attempts (default ``3 * episodes``); ``object_name``: the
    grasping tasks' object. Raises ``ValueError`` for bad arguments before any work, ``RuntimeError``
    when too few demonstrations succeed (nothing written).
    """
    spec, limit, env_kwargs = _check_arguments(
        task, episodes, seed, max_attempts, repo_id, images, overwrite, object_name
    )
    # Checked before any work, and the dataset is written beside `out` (staging): a failed run leaves
    # an existing dataset at `out` as it was, and no half-written one.
    out = check_output(out, overwrite=overwrite)
    env = make(
        task,
        obs_type="pixels_state" if images else "state",
        render_mode=None,
        image_size=image_size,
        **env_kwargs,
    )
    root = partial_dir(out)
    try:
        result = _record(env, spec, episodes, seed, limit, root, out, repo_id, images, image_size, progress)
    finally:
        env.close()
    replace_dir(out, root)
    result.root = out
    return result


def _check_arguments(task, episodes, seed, max_attempts, repo_id, images, overwrite, object_name):
    """(spec, attempt limit, env kwargs) after checking every argument of :func:`record_demonstrations`."""
    spec = task_spec(task)
    check_int("episodes (--episodes)", episodes, low=1)
    # numpy's SeedSequence would refuse it only later, as "expected non-negative integer"
    check_int("seed (--seed)", seed, low=0)
    limit = 3 * episodes if max_attempts is None else max_attempts
    if not (is_int(limit) and limit >= episodes):
        fail("max_attempts (--max-attempts)", f"be an integer >= episodes ({episodes})", max_attempts)
    if repo_id is not None:
        check_repo_id(repo_id, "repo_id (--repo-id)")
    check_bool("images (--images)", images)
    check_bool("overwrite (--overwrite)", overwrite)
    return spec, int(limit), object_kwargs(task, object_name)


def _dataset_features(base, images: bool, image_size: int) -> dict[str, dict[str, Any]]:
    """The recorded columns: the observations of ``base`` (the unwrapped env), action and ground truth."""
    from ..data.schema import dataset_features

    names = base.state_names
    features = dataset_features(
        names[ENV_AGENT_POS],
        finger_force_names=names.get(ENV_FINGER_FORCE),
        env_state_names=names[ENV_STATE],
        image_shapes={CAMERA: (image_size, image_size, 3)} if images else None,
        contacts=True,
    )
    features[CONTACT_FORCE] = {"dtype": "float32", "shape": (3,), "names": list(CONTACT_FORCE_NAMES)}
    features[DEMO_PHASE] = {"dtype": "int64", "shape": (1,), "names": None}
    return features


def _record(env, spec: TaskSpec, episodes, seed, limit, root, out, repo_id, images, image_size, progress):
    """Create the dataset at ``root`` and fill it; removes ``root`` on any failure."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    base = env.unwrapped
    features = _dataset_features(base, images, image_size)
    fps = int(round(spec.control_hz))
    dataset = LeRobotDataset.create(
        repo_id=repo_id or f"local/forcemap_{spec.name}",
        fps=fps,
        features=features,
        root=root,
        robot_type=base.robot.name,
        use_videos=images,
    )
    try:
        result, demo_cls = _record_episodes(
            env, dataset, features, spec, episodes, seed, limit, root, progress
        )
        if result.n_episodes < episodes:
            raise RuntimeError(
                f"record {spec.name}: only {result.n_episodes} of {episodes} demonstrations succeeded in "
                f"{limit} attempts (failed seeds {result.skipped_seeds}); nothing written to {out}"
            )
        dataset.finalize()
        _write_metadata(result, base, demo_cls, fps, images)
    except BaseException:
        dataset.finalize()  # close the writers, then remove the half-written dataset
        shutil.rmtree(root, ignore_errors=True)
        raise
    return result


def _record_episodes(env, dataset, features, spec: TaskSpec, episodes, seed, limit, root, progress):
    """Attempts seeds ``seed, seed + 1, ...`` until ``episodes`` succeeded or ``limit`` attempts ran;
    returns the result and the demonstrator class. ``features``: the recorded columns."""
    from tqdm import tqdm

    from ..data.contacts import frame_contact_features
    from ..data.schema import add_episode

    result = RecordResult(root=root, task=spec.name, n_episodes=0, seeds=[], skipped_seeds=[])
    demo_cls = None
    bar = tqdm(total=episodes, desc=f"record {spec.name}", disable=not progress)
    try:
        for ep_seed in range(seed, seed + limit):
            if result.n_episodes == episodes:
                break
            episode, demo = _demonstrate(env, spec, ep_seed, features)
            demo_cls = type(demo)
            info = episode.info
            if not info["is_success"]:
                result.skipped_seeds.append(ep_seed)
                warnings.warn(
                    f"record {spec.name}: demonstration with seed {ep_seed} failed "
                    f"({info['termination_reason'] or 'time limit'}); not recorded",
                    stacklevel=4,
                )
                continue
            arrays = {
                k: np.asarray([row[k] for row in episode.trace]) for k in features if k in episode.trace[0]
            }
            times = np.arange(len(episode.trace)) / spec.control_hz
            arrays.update(frame_contact_features(times, arrays[OBS_EE_POSE][:, :3], arrays[CONTACT_FORCE]))
            n = add_episode(dataset, arrays, env.unwrapped.task_description, episode=result.n_episodes)
            result.episodes.append(episode_record(info, ep_seed, n, demo.describe()))
            result.seeds.append(ep_seed)
            result.n_episodes += 1
            bar.update(1)
    finally:
        bar.close()
    return result, demo_cls


def _demonstrate(env, spec: TaskSpec, ep_seed: int, features) -> tuple[Episode, Any]:
    """One scripted demonstration with seed ``ep_seed``; ``Episode.trace`` holds a row per frame."""
    from . import demonstrators

    names = env.unwrapped.state_names
    demo_rng = np.random.default_rng(np.random.SeedSequence(ep_seed).spawn(1)[0])
    demo = demonstrators.make_demonstrator(
        spec.name, demo_rng, state_names=names[ENV_STATE], control_hz=spec.control_hz
    )
    fingers = OBS_FINGER_FORCE in features
    image_key = OBS_IMAGES_PREFIX + CAMERA
    images = image_key in features

    def row(step: Step) -> dict[str, Any]:
        obs = step.obs
        frame = {
            OBS_STATE: obs[ENV_AGENT_POS],
            OBS_EE_POSE: obs[ENV_EE_POSE],
            OBS_FORCE: obs[ENV_FORCE],
            OBS_ENV_STATE: obs[ENV_STATE],
            ACTION: step.action,
            CONTACT_FORCE: step.info["contact_force"],
            DEMO_PHASE: [demo.phase_index],
        }
        if fingers:
            frame[OBS_FINGER_FORCE] = obs[ENV_FINGER_FORCE]
        if images:
            frame[image_key] = obs[ENV_PIXELS][CAMERA]
        return frame

    episode = run_episode(
        env, demo.act, ep_seed, reset=demo.reset, trace=row, max_steps=spec.max_episode_steps
    )
    return episode, demo


def summary(episodes: list[dict[str, Any]]) -> dict[str, Any]:
    """Mean / std / min / max over episodes of the force figures of :func:`episode_record` records."""
    out = {}
    for key in ("max_contact_force", "mean_contact_force"):
        v = np.array([e[key] for e in episodes], dtype=float)
        out[key] = {
            "mean": float(v.mean()),
            "std": float(v.std()),
            "min": float(v.min()),
            "max": float(v.max()),
        }
    for key in ("max_contact_force_xyz", "mean_contact_force_xyz", "max_finger_force", "mean_finger_force"):
        if key not in episodes[0]:  # finger forces: grippers with fingertip sensors only
            continue
        v = np.array([e[key] for e in episodes], dtype=float)
        out[key] = {"mean": v.mean(axis=0).tolist(), "std": v.std(axis=0).tolist()}
    return out


def _finger_summary(s: dict[str, Any]) -> str:
    """Per-finger max / mean fingertip force (mean ± std over episodes), for the dataset card."""
    parts = []
    for i, (mx, sx, mn, sn) in enumerate(
        zip(
            s["max_finger_force"]["mean"],
            s["max_finger_force"]["std"],
            s["mean_finger_force"]["mean"],
            s["mean_finger_force"]["std"],
            strict=True,
        )
    ):
        parts.append(f"f{i}: max {mx:.1f} ± {sx:.1f} N, mean {mn:.2f} ± {sn:.2f} N")
    return "; ".join(parts) + " per episode"


def _write_metadata(result: RecordResult, base, demo_cls, fps: int, images: bool) -> None:
    """``meta/forcemap_episodes.json`` and the dataset card of a finished recording."""
    meta = _episodes_meta(result, base, demo_cls, fps)
    (result.root / "meta" / EPISODES_FILE).write_text(json.dumps(meta, indent=1))
    _write_card(result, base, meta, images)


def _episodes_meta(result: RecordResult, base, demo_cls, fps: int) -> dict[str, Any]:
    t = base.task_impl
    return {
        "task": result.task,
        "gym_id": task_spec(result.task).gym_id,
        "robot": base.robot.name,
        "fps": fps,
        "controller": {
            "type": "cartesian_impedance",
            "stiffness_pos_N_per_m": list(base.gains.stiffness_pos),
            "stiffness_rot_Nm_per_rad": list(base.gains.stiffness_rot),
            "damping_ratio": base.gains.damping_ratio,
            "physics_timestep_s": base.timestep,
        },
        "force_filter_cutoff_hz": base.force_cutoff_hz,
        "force_limit_N": t.force_limit,
        "finger_force_limit_N": t.finger_force_limit,
        "success_test": t.success_test,
        "demonstrator": demo_cls.__name__ if demo_cls else None,
        "phases": list(demo_cls.phases) if demo_cls else [],
        "summary": summary(result.episodes),
        "episodes": result.episodes,
    }


def _write_card(result: RecordResult, base, meta: dict[str, Any], images: bool) -> None:
    from ..data.schema import write_dataset_card

    t, s = base.task_impl, meta["summary"]
    stop = f"filtered contact force > {t.force_limit:g} N"
    extra: dict[str, str] = {}
    if t.finger_force_limit is not None:
        stop += f", or a filtered fingertip force > {t.finger_force_limit:g} N"
    if "max_finger_force" in s:
        extra["fingertip forces"] = _finger_summary(s)
        extra[f"`{OBS_FINGER_FORCE}`"] = (
            "per fingertip (f0 thumb, f1, f2) the low-passed net contact force on the finger's distal link, "
            "N, base frame, reaction on the robot (the force the object exerts on the finger); arm and "
            "gripper streams share the frames: `action` holds the TCP target and the gripper command "
            "(index 7), `observation.state` the joints and the gripper closure"
        )
    if hasattr(t, "obj"):
        extra["object"] = t.obj.description
    write_dataset_card(
        result.root,
        title=f"forcemap sim: {result.task} — scripted demonstrations",
        source=f"MuJoCo task `{meta['gym_id']}` (lerobot_forcemap), scripted demonstrator `{meta['demonstrator']}`, "
        f"seeds {result.seeds}",
        robot=f"{base.robot.name} + {base.robot.gripper.name} + wrist F/T (simulated)",
        extra={
            "task": base.task_description,
            "success test": t.success_test,
            "protective stop": stop,
            "controller": f"Cartesian impedance at {1 / base.timestep:.0f} Hz, K = {list(base.gains.stiffness_pos)} N/m",
            "demonstration forces": f"max {s['max_contact_force']['mean']:.1f} ± {s['max_contact_force']['std']:.1f} N, "
            f"mean {s['mean_contact_force']['mean']:.2f} ± {s['mean_contact_force']['std']:.2f} N per episode",
            f"`{CONTACT_FORCE}`": "the env's low-passed summed contact force (N, base frame, reaction on the robot)",
            "`contact_reaction`, `contact`": "the same force as the contact reaction the fit reads (no hand on the "
            "tool), and the frames where its norm exceeds 2 N",
            f"`{DEMO_PHASE}`": "scripted phase index: "
            + ", ".join(f"{i} {p}" for i, p in enumerate(meta["phases"])),
            "per-episode metrics": f"meta/{EPISODES_FILE}",
            "images": "observation.images.front (front camera)" if images else "none (state only)",
            **extra,
        },
        tags=["simulation", "mujoco", result.task],
    )
