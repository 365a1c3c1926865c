"""Demonstrations as NumPy arrays: read the chosen episodes of a LeRobot dataset and check them.

``episodes_from_columns`` is pure NumPy (columns of the dataset table + its feature dict), so tests
and the benchmark can feed it directly; ``load_episodes`` reads a dataset through
``LeRobotDataset(repo_id, root=..., episodes=[...]).hf_dataset`` (LeRobot 0.6.1, no Hub call with a
local root).

Every check names the feature, the episode and the frame: missing features, NaN/inf values,
timestamps that do not increase, episodes the dataset lacks, too-short episodes.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap import layout
from lerobot_forcemap.data.schema import check_data_columns
from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

__all__ = ["EpisodeArrays", "episodes_from_columns", "load_episodes", "needed_columns", "finger_force_scalar"]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class EpisodeArrays:
    """One demonstration (T frames).

    times (T,) s from the episode start; pose (T, 7) [x y z qw qx qy qz] (from ``config.pose_key``);
    force (T, 3) N (zeros when the dataset has no force); gripper (T,) 0..1; gripper_force (T,) N
    along the gripper coordinate (negative = towards open) or None; env_state (T, E) or None;
    joints (T, J) or None; finger_force (T, F) or None (raw, for segmentation); segment_labels (T,)
    or None (the dataset's ``config.segment_column``, default ``segment_index``).
    """

    episode: int
    times: Array
    pose: Array
    force: Array
    gripper: Array
    gripper_force: Array | None
    env_state: Array | None
    joints: Array | None
    finger_force: Array | None
    segment_labels: NDArray[np.int64] | None
    has_force: bool = True

    @property
    def n_frames(self) -> int:
        return len(self.times)


def needed_columns(config: ForceMapConfig, features: Mapping[str, Any]) -> list[str]:
    """Dataset columns the fit reads (those of the config that the dataset has, plus bookkeeping)."""
    keys = [config.pose_key, config.gripper_key, "timestamp", "episode_index", "frame_index"]
    for key in (
        config.force_key,
        config.finger_force_key,
        config.env_state_key,
        config.joints_key,
        config.segment_column,
    ):
        if key in features:
            keys.append(key)
    return list(dict.fromkeys(keys))


def finger_force_scalar(values: Array, names: Sequence[str] | None) -> Array:
    """Per-frame finger force (T,) as a reaction on the gripper coordinate: ``−mean_i ‖f_i‖``.

    The object pushes the fingers open, so the reaction points towards "open" (decreasing closure).
    ``values (T, F)``: 3-D vectors per finger (names ``f<i>x f<i>y f<i>z``, F divisible by 3) or one
    scalar normal force per finger.
    """
    values = np.asarray(values, dtype=np.float64)
    names = list(names or [])
    vectors = values.shape[1] % 3 == 0 and (not names or all(n[-1:] in "xyz" for n in names))
    if vectors:
        per_finger = np.linalg.norm(values.reshape(len(values), -1, 3), axis=2)
    else:
        per_finger = np.abs(values)
    return -per_finger.mean(axis=1)


def _feature_width(features: Mapping[str, Any], key: str) -> int:
    shape = tuple(features[key]["shape"])
    return int(np.prod(shape))


def _check_finite(name: str, episode: int, values: Array, frames: NDArray[np.int64]) -> None:
    bad = ~np.isfinite(values.reshape(len(values), -1))
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise ValueError(
            f"feature {name!r}, episode {episode}, frame {int(frames[row])}: non-finite value "
            f"{values.reshape(len(values), -1)[row, col]} (component {col}; {int(bad.any(axis=1).sum())} bad frames)"
        )


def episodes_from_columns(
    columns: Mapping[str, np.ndarray],
    features: Mapping[str, Any],
    config: ForceMapConfig,
    episodes: Sequence[int] | None = None,
) -> list[EpisodeArrays]:
    """Split dataset columns (rows of any episodes, each ``(rows, *shape)``) into the chosen episodes.

    Needs ``episode_index``, ``timestamp``, ``config.pose_key`` (≥ 7 wide: x y z qw qx qy qz) and
    ``config.gripper_key``; uses ``config.force_key`` (first 3), ``finger_force_key``,
    ``env_state_key``, ``joints_key`` and ``segment_index`` when present.
    """
    episodes = list(config.episodes if episodes is None else episodes)
    for key in ("episode_index", "timestamp"):
        if key not in columns:
            raise ValueError(f"dataset column {key!r} is missing")
    for key, what in ((config.pose_key, "pose_key"), (config.gripper_key, "gripper_key")):
        if key not in features or key not in columns:
            raise ValueError(
                f"ForceMapConfig.{what}={key!r}: the dataset has no such feature (features: {sorted(features)})"
            )
    if config.force_key and config.force_key not in features:
        raise ValueError(
            f"ForceMapConfig.force_key={config.force_key!r}: the dataset has no such feature (features: "
            f"{sorted(features)}); the demonstrated force is what the method learns from. To fit plain "
            "elastic maps without it, set force_key='' (--policy.force_key='')"
        )
    # optional features: absent at their default names is fine (no fingertip sensors, no objects);
    # a name set by hand that the dataset lacks is a mistake, not a reason to fit without it
    for key, what, default in (
        (config.finger_force_key, "finger_force_key", layout.OBS_FINGER_FORCE),
        (config.env_state_key, "env_state_key", layout.OBS_ENV_STATE),
        (config.joints_key, "joints_key", layout.OBS_STATE),
    ):
        if key and key != default and key not in features:
            raise ValueError(
                f"ForceMapConfig.{what}={key!r}: the dataset has no such feature (features: {sorted(features)}); "
                f"leave it at {default!r} or set '' to fit without it"
            )
    if _feature_width(features, config.pose_key) < 7:
        raise ValueError(
            f"ForceMapConfig.pose_key={config.pose_key!r}: needs >= 7 entries [x y z qw qx qy qz], "
            f"the feature has shape {tuple(features[config.pose_key]['shape'])}"
        )
    width = _feature_width(features, config.gripper_key)
    if not -width <= config.gripper_index < width:
        raise ValueError(
            f"ForceMapConfig.gripper_index={config.gripper_index}: out of range for {config.gripper_key!r} of width {width}"
        )
    ep_col = np.asarray(columns["episode_index"]).reshape(-1).astype(np.int64)
    available = sorted(set(ep_col.tolist()))
    missing = [e for e in episodes if e not in available]
    if missing:
        raise ValueError(
            f"ForceMapConfig.episodes: episode(s) {missing} not in the dataset (it has {available})"
        )

    def col(key: str, rows: NDArray[np.int64]) -> Array:
        a = np.asarray(columns[key])[rows]
        return a.reshape(len(rows), -1).astype(np.float64)

    has_force = bool(config.force_key) and config.force_key in columns
    finger_names = (
        features.get(config.finger_force_key, {}).get("names")
        if config.finger_force_key in features
        else None
    )
    env_names = (
        features.get(config.env_state_key, {}).get("names") if config.env_state_key in features else None
    )
    out = []
    for e in episodes:
        rows = np.flatnonzero(ep_col == e)
        frames = (
            np.asarray(columns["frame_index"]).reshape(-1)[rows].astype(np.int64)
            if "frame_index" in columns
            else np.arange(len(rows))
        )
        order = np.argsort(frames, kind="stable")
        rows, frames = rows[order], frames[order]
        if len(rows) < 3:
            raise ValueError(f"episode {e}: {len(rows)} frames; a demonstration needs at least 3")
        times = col("timestamp", rows)[:, 0]
        _check_finite("timestamp", e, times, frames)
        step = np.diff(times)
        if np.any(step <= 0):
            i = int(np.argmax(step <= 0))
            raise ValueError(
                f"feature 'timestamp', episode {e}, frame {int(frames[i + 1])}: timestamps must increase "
                f"({times[i]:.6f} s -> {times[i + 1]:.6f} s; duplicated or out-of-order frame)"
            )
        pose = col(config.pose_key, rows)[:, :7]
        _check_finite(config.pose_key, e, pose, frames)
        qn = np.linalg.norm(pose[:, 3:7], axis=1)
        if np.any(qn < 1e-6):
            i = int(np.argmax(qn < 1e-6))
            raise ValueError(
                f"feature {config.pose_key!r}, episode {e}, frame {int(frames[i])}: zero quaternion"
            )
        pose[:, 3:7] /= qn[:, None]
        gripper = col(config.gripper_key, rows)[:, config.gripper_index]
        _check_finite(config.gripper_key, e, gripper, frames)
        if has_force:
            force = col(config.force_key, rows)
            if force.shape[1] < 3:
                raise ValueError(
                    f"feature {config.force_key!r}: needs >= 3 entries (fx fy fz), has {force.shape[1]}"
                )
            force = force[:, :3]
            _check_finite(config.force_key, e, force, frames)
        else:
            force = np.zeros((len(rows), 3))
        finger = gripper_force = None
        if config.finger_force_key in features and config.finger_force_key in columns:
            finger = col(config.finger_force_key, rows)
            _check_finite(config.finger_force_key, e, finger, frames)
            gripper_force = finger_force_scalar(finger, finger_names)
        env_state = None
        if config.env_state_key in features and config.env_state_key in columns:
            env_state = col(config.env_state_key, rows)
            _check_finite(config.env_state_key, e, env_state, frames)
            if env_names is not None and env_state.shape[1] != len(env_names):
                raise ValueError(
                    f"feature {config.env_state_key!r}: {env_state.shape[1]} columns but {len(env_names)} names"
                )
        joints = None
        if config.joints_key in features and config.joints_key in columns:
            joints = col(config.joints_key, rows)
            names = features[config.joints_key].get("names") or []
            if names and names[-1] == layout.GRIPPER_STATE_NAME:
                joints = joints[:, :-1]
            _check_finite(config.joints_key, e, joints, frames)
        labels = None
        if config.segment_column in columns:
            raw = np.asarray(columns[config.segment_column])[rows].reshape(-1)
            where = f"feature {config.segment_column!r}, episode {int(e)}"
            if raw.dtype.kind not in "iubf":
                raise ValueError(f"{where}: segment labels must be integers, got dtype {raw.dtype}")
            if raw.dtype.kind == "f":
                _check_finite(config.segment_column, e, raw, frames)
                # a fractional label would be truncated into its neighbour, merging two segments unseen
                if (fractional := raw != np.round(raw)).any():
                    k = int(np.argmax(fractional))
                    raise ValueError(
                        f"{where}, frame {int(frames[k])}: segment label {raw[k].item()!r} is not an integer"
                    )
            labels = raw.astype(np.int64)
        out.append(
            EpisodeArrays(
                episode=int(e),
                times=times - times[0],
                pose=pose,
                force=force,
                gripper=gripper,
                gripper_force=gripper_force,
                env_state=env_state,
                joints=joints,
                finger_force=finger,
                segment_labels=labels,
                has_force=has_force,
            )
        )
    return out


def load_episodes(
    repo_id: str, root: str | None, config: ForceMapConfig
) -> tuple[list[EpisodeArrays], dict, float, list[str]]:
    """Read ``config.episodes`` of a LeRobot dataset; returns (episodes, features, fps, the task
    strings of those episodes)."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset  # lazy: heavy import

    info = Path(root) / "meta" / "info.json" if root is not None else None
    if info is not None and info.is_file():
        # checked first: LeRobotDataset given an episode it lacks fails with "Instruction 'train'
        # corresponds to no data!", or goes looking on the Hub for the missing files
        total = int(json.loads(info.read_text())["total_episodes"])
        missing = sorted(int(e) for e in config.episodes if not 0 <= int(e) < total)
        if missing:
            raise ValueError(
                f"ForceMapConfig.episodes: episode(s) {missing} not in the dataset {root} "
                f"(it has episodes 0..{total - 1})"
            )
        check_data_columns(root)
    ds = LeRobotDataset(repo_id, root=root, episodes=sorted(int(e) for e in config.episodes))
    features = ds.meta.features
    keys = [k for k in needed_columns(config, features) if k in ds.hf_dataset.column_names]
    table = ds.hf_dataset.with_format("numpy", columns=keys)
    columns = {k: np.asarray(table[k]) for k in keys}
    episodes = episodes_from_columns(columns, features, config)
    return episodes, dict(features), float(ds.meta.fps), episode_tasks(ds.meta, config.episodes)


def episode_tasks(meta: Any, episodes: Sequence[int]) -> list[str]:
    """The task strings (sorted, distinct) of ``episodes`` in a ``LeRobotDatasetMetadata``."""
    chosen = {int(e) for e in episodes}
    table = meta.episodes.select_columns(["episode_index", "tasks"]).to_dict()
    found = {
        str(t)
        for e, tasks in zip(table["episode_index"], table["tasks"], strict=True)
        if int(e) in chosen
        for t in tasks
    }
    return sorted(found)
