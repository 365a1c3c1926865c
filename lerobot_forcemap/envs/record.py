"""Scripted demonstrations of a sim task into a LeRobot v3 dataset (the library part of ``forcemap
record``; the command line is ``lerobot_forcemap/cli/record.py``).

Episode ``e`` runs the env with seed ``seed + k`` (k counts attempts) and a demonstrator whose
generator is spawned from the same seed. Failed demonstrations are not written (the paper excluded
demonstrations that hit the safety stop), and each skip is reported. fps = the task's control rate.

Per frame: ``observation.state/ee_pose/force/environment_state`` (+ ``finger_force`` for grippers with
fingertip sensors, + ``observation.images.front`` with ``--images``), ``action``, and two ground-truth
columns from ``layout``: ``contact_force`` (the env's filtered contact force) and ``demo_phase``.
Per episode, ``meta/forcemap_episodes.json`` holds the seed, the env's ``info`` force statistics
(max / mean contact force, norm and per axis) and task metrics, and the demonstrator's parameters —
the numbers a reproduction is compared with.
"""

from __future__ import annotations

import json
import shutil
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

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
    OBS_EE_POSE,
    OBS_ENV_STATE,
    OBS_FINGER_FORCE,
    OBS_FORCE,
    OBS_IMAGES_PREFIX,
    OBS_STATE,
)
from .registration import make, object_kwargs, task_spec
from .scene import CAMERA

EPISODES_FILE = "forcemap_episodes.json"


@dataclass
class RecordResult:
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
    from lerobot.datasets.lerobot_dataset import LeRobotDataset
    from tqdm import tqdm

    from ..data.schema import add_episode, dataset_features
    from .demonstrators import make_demonstrator

    if episodes < 1:
        raise ValueError(f"episodes (--episodes) must be >= 1, got {episodes}")
    # numpy's SeedSequence would refuse it only later, as "expected non-negative integer"
    if seed < 0:
        raise ValueError(f"seed (--seed) must be a non-negative integer, got {seed}")
    limit = max_attempts if max_attempts is not None else 3 * episodes
    if limit < episodes:
        raise ValueError(f"max_attempts (--max-attempts) must be >= episodes ({episodes}), got {limit}")
    if repo_id is not None:
        check_repo_id(repo_id, "repo_id (--repo-id)")
    # Checked before any work, and the dataset is written beside `out` (staging): a failed run leaves
    # an existing dataset at `out` as it was, and no half-written one.
    out = check_output(out, overwrite=overwrite)
    entry = task_spec(task)
    env_kwargs = object_kwargs(task, object_name)
    env = make(
        task,
        obs_type="pixels_state" if images else "state",
        render_mode=None,
        image_size=image_size,
        **env_kwargs,
    )
    base = env.unwrapped
    names = base.state_names
    fingers = ENV_FINGER_FORCE in names
    features = dataset_features(
        names[ENV_AGENT_POS],
        finger_force_names=names[ENV_FINGER_FORCE] if fingers else None,
        env_state_names=names[ENV_STATE],
        image_shapes={CAMERA: (image_size, image_size, 3)} if images else None,
    )
    features[CONTACT_FORCE] = {"dtype": "float32", "shape": (3,), "names": list(CONTACT_FORCE_NAMES)}
    features[DEMO_PHASE] = {"dtype": "int64", "shape": (1,), "names": None}
    fps = int(round(entry.control_hz))
    root = partial_dir(out)
    dataset = LeRobotDataset.create(
        repo_id=repo_id or f"local/forcemap_{task}",
        fps=fps,
        features=features,
        root=root,
        robot_type=base.robot.name,
        use_videos=images,
    )
    demo_cls = None
    result = RecordResult(root=root, task=task, n_episodes=0, seeds=[], skipped_seeds=[])
    bar = tqdm(total=episodes, desc=f"record {task}", disable=not progress)
    attempt = 0
    try:
        while result.n_episodes < episodes and attempt < limit:
            ep_seed = seed + attempt
            attempt += 1
            demo_rng = np.random.default_rng(np.random.SeedSequence(ep_seed).spawn(1)[0])
            demo = make_demonstrator(
                task, demo_rng, state_names=names[ENV_STATE], control_hz=entry.control_hz
            )
            demo_cls = type(demo)
            obs, info = env.reset(seed=ep_seed)
            demo.reset(obs)
            cols: dict[str, list] = {k: [] for k in features}
            for _ in range(entry.max_episode_steps):
                action = demo.act(obs)
                cols[OBS_STATE].append(obs[ENV_AGENT_POS])
                cols[OBS_EE_POSE].append(obs[ENV_EE_POSE])
                cols[OBS_FORCE].append(obs[ENV_FORCE])
                cols[OBS_ENV_STATE].append(obs[ENV_STATE])
                if fingers:
                    cols[OBS_FINGER_FORCE].append(obs[ENV_FINGER_FORCE])
                if images:
                    cols[OBS_IMAGES_PREFIX + CAMERA].append(obs[ENV_PIXELS][CAMERA])
                cols[ACTION].append(action)
                cols[CONTACT_FORCE].append(info["contact_force"])
                cols[DEMO_PHASE].append([demo.phase_index])
                obs, _, terminated, truncated, info = env.step(action)
                if terminated or truncated:
                    break
            if not info["is_success"]:
                result.skipped_seeds.append(ep_seed)
                warnings.warn(
                    f"record {task}: demonstration with seed {ep_seed} failed ({info['termination_reason'] or 'time limit'}); "
                    "not recorded",
                    stacklevel=2,
                )
                continue
            arrays = {k: np.asarray(v) for k, v in cols.items()}
            n = add_episode(dataset, arrays, base.task_description, episode=result.n_episodes)
            result.episodes.append(episode_record(info, ep_seed, n, demo.describe()))
            result.seeds.append(ep_seed)
            result.n_episodes += 1
            bar.update(1)
        if result.n_episodes < episodes:
            raise RuntimeError(
                f"record {task}: only {result.n_episodes} of {episodes} demonstrations succeeded in {attempt} "
                f"attempts (failed seeds {result.skipped_seeds}); nothing written to {out}"
            )
        dataset.finalize()
        _write_metadata(result, base, demo_cls, fps, images)
    except BaseException:
        dataset.finalize()  # close the writers, then remove the half-written dataset
        shutil.rmtree(root, ignore_errors=True)
        raise
    finally:
        bar.close()
        env.close()
    replace_dir(out, root)
    result.root = out
    return result


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
    from ..data.schema import write_dataset_card

    t = base.task_impl
    meta = {
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
    (result.root / "meta" / EPISODES_FILE).write_text(json.dumps(meta, indent=1))
    s = meta["summary"]
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
            f"`{DEMO_PHASE}`": "scripted phase index: "
            + ", ".join(f"{i} {p}" for i, p in enumerate(meta["phases"])),
            "per-episode metrics": f"meta/{EPISODES_FILE}",
            "images": "observation.images.front (front camera)" if images else "none (state only)",
            **extra,
        },
        tags=["simulation", "mujoco", result.task],
    )
