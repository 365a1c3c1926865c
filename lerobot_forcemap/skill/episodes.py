"""Demonstrations as NumPy arrays, split from the columns of a dataset table.

Pure NumPy: the columns come from ``lerobot_forcemap.data.reader`` (or from a test, or a benchmark).
Every check names the setting, the feature, the episode and the frame: missing features, NaN/inf
values, timestamps that do not increase, episodes the columns lack, too-short episodes.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap import layout
from lerobot_forcemap.contact import mask_to_intervals, without_held_weight
from lerobot_forcemap.skill.params import Columns, SkillParams

__all__ = [
    "EpisodeArrays",
    "episodes_from_columns",
    "needed_columns",
    "finger_force_scalar",
]

Array = NDArray[np.float64]
Frames = NDArray[np.int64]

#: the bookkeeping columns every read needs (LeRobot's automatic columns)
BOOKKEEPING = ("timestamp", "episode_index", "frame_index")


@dataclass(frozen=True)
class EpisodeArrays:
    """One demonstration (T frames).

    times (T,) s from the episode start; pose (T, 7) [x y z qw qx qy qz] (from ``pose_key``);
    force (T, 3) N, the force points' force (zeros when the dataset has no force); gripper (T,) 0..1;
    gripper_force (T,) N along the gripper coordinate (negative = towards open) or None; env_state
    (T, E) or None; joints (T, J) or None; finger_force (T, F) or None (raw, for segmentation);
    segment_labels (T,) or None (the dataset's ``segment_column``); wrench (T, 3) N: the measured wrist
    wrench when ``force`` is not the wrench itself (the contact reaction, or the wrench without a held
    object's weight; the segmentation's wrist-force stream; None: it is ``force``); contact (T,) bool:
    the dataset's per-frame contact flag, or None.
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
    wrench: Array | None = None
    contact: NDArray[np.bool_] | None = None

    @property
    def n_frames(self) -> int:
        return len(self.times)

    @property
    def measured_force(self) -> Array:
        """The measured wrist force (T, 3) N: ``wrench`` when given, else ``force``."""
        return self.force if self.wrench is None else self.wrench

    def contact_intervals(self) -> Array:
        """(K, 2) [first, last] frame times (s) of the runs of ``contact`` (empty without it)."""
        if self.contact is None:
            return np.zeros((0, 2))
        return mask_to_intervals(self.times, self.contact)


def needed_columns(params: SkillParams) -> list[str]:
    """Dataset columns the fit reads (those a dataset lacks are optional or refused later, by name)."""
    c = params.columns
    keys = [c.pose_key, c.gripper_key, *BOOKKEEPING]
    keys += [c.force_key, c.reaction_key, c.finger_force_key, c.env_state_key, c.joints_key]
    keys += [c.segment_column, layout.CONTACT]
    return [k for k in dict.fromkeys(keys) if k]


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


def episodes_from_columns(
    columns: Mapping[str, np.ndarray],
    features: Mapping[str, Any],
    params: SkillParams,
    episodes: Sequence[int],
) -> list[EpisodeArrays]:
    """Split dataset columns (rows of any episodes, each ``(rows, *shape)``) into ``episodes``, in order.

    Needs ``episode_index``, ``timestamp``, ``pose_key`` (≥ 7 wide: x y z qw qx qy qz) and
    ``gripper_key``; uses ``force_key`` (first 3), ``finger_force_key``, ``env_state_key``,
    ``joints_key`` and ``segment_column`` when present. ``features``: LeRobot's feature dict.

    The force points read ``reaction_key`` when the dataset has it, else the wrench; then, on the
    frames where the fingers hold something (finger force above ``gripper_f_contact``), without the
    held object's downward pull (``contact.without_held_weight``): its weight is no contact.
    """
    _check_features(columns, features, params.columns)
    episode_column = np.asarray(columns["episode_index"]).reshape(-1).astype(np.int64)
    available = sorted(set(episode_column.tolist()))
    missing = [e for e in episodes if e not in available]
    if missing:
        raise ValueError(f"episodes: episode(s) {missing} not in the dataset (it has {available})")
    reader = _EpisodeReader(columns, features, params.columns, float(params.gripper.gripper_f_contact))
    return [reader.episode(int(e), np.flatnonzero(episode_column == e)) for e in episodes]


def _check_features(columns: Mapping[str, np.ndarray], features: Mapping[str, Any], c: Columns) -> None:
    """The features the fit needs are there, and the optional ones set by hand too."""
    for key in ("episode_index", "timestamp"):
        if key not in columns:
            raise ValueError(f"dataset column {key!r} is missing")
    for key, what in ((c.pose_key, "pose_key"), (c.gripper_key, "gripper_key")):
        if key not in features or key not in columns:
            raise ValueError(
                f"{what}={key!r}: the dataset has no such feature (features: {sorted(features)})"
            )
    if c.force_key and c.force_key not in features:
        raise ValueError(
            f"force_key={c.force_key!r}: the dataset has no such feature (features: {sorted(features)}); "
            "the demonstrated force is what the method learns from. To fit plain elastic maps without it, "
            "set force_key='' (--policy.force_key='')"
        )
    # optional features: absent at their default names is fine (no fingertip sensors, no objects);
    # a name set by hand that the dataset lacks is a mistake, not a reason to fit without it
    for key, what, default in (
        (c.finger_force_key, "finger_force_key", layout.OBS_FINGER_FORCE),
        (c.reaction_key, "reaction_key", layout.CONTACT_REACTION),
        (c.env_state_key, "env_state_key", layout.OBS_ENV_STATE),
        (c.joints_key, "joints_key", layout.OBS_STATE),
    ):
        if key and key != default and key not in features:
            raise ValueError(
                f"{what}={key!r}: the dataset has no such feature (features: {sorted(features)}); "
                f"leave it at {default!r} or set '' to fit without it"
            )
    if _width(features, c.pose_key) < 7:
        raise ValueError(
            f"pose_key={c.pose_key!r}: needs >= 7 entries [x y z qw qx qy qz], "
            f"the feature has shape {tuple(features[c.pose_key]['shape'])}"
        )
    width = _width(features, c.gripper_key)
    if not -width <= c.gripper_index < width:
        raise ValueError(
            f"gripper_index={c.gripper_index}: out of range for {c.gripper_key!r} of width {width}"
        )


def _width(features: Mapping[str, Any], key: str) -> int:
    return int(np.prod(tuple(features[key]["shape"])))


def _check_finite(name: str, episode: int, values: Array, frames: Frames) -> None:
    flat = values.reshape(len(values), -1)
    bad = ~np.isfinite(flat)
    if bad.any():
        row, col = np.argwhere(bad)[0]
        raise ValueError(
            f"feature {name!r}, episode {episode}, frame {int(frames[row])}: non-finite value "
            f"{flat[row, col]} (component {col}; {int(bad.any(axis=1).sum())} bad frames)"
        )


class _EpisodeReader:
    """Reads one episode's arrays out of the columns, feature by feature."""

    def __init__(
        self, columns: Mapping[str, np.ndarray], features: Mapping[str, Any], c: Columns, holding_n: float
    ):
        self.columns, self.features, self.c = columns, features, c
        self.holding_n = holding_n  # the finger force (N) above which the gripper holds an object
        self.has_force = bool(c.force_key) and c.force_key in columns
        # with a contact reaction the force points read it, and the measured wrench stays beside it
        self.reacting = self.has_force and bool(c.reaction_key) and self._has(c.reaction_key)
        self.force_key = c.reaction_key if self.reacting else c.force_key

    def _has(self, key: str) -> bool:
        return key in self.features and key in self.columns

    def _names(self, key: str) -> list[str] | None:
        return self.features[key].get("names") if key in self.features else None

    def _col(self, key: str, rows: Frames) -> Array:
        return np.asarray(self.columns[key])[rows].reshape(len(rows), -1).astype(np.float64)

    def _checked(self, key: str, e: int, rows: Frames, frames: Frames) -> Array:
        values = self._col(key, rows)
        _check_finite(key, e, values, frames)
        return values

    def episode(self, e: int, rows: Frames) -> EpisodeArrays:
        """Episode ``e`` from its rows (in any order: sorted by ``frame_index``)."""
        c = self.c
        frames = (
            np.asarray(self.columns["frame_index"]).reshape(-1)[rows].astype(np.int64)
            if "frame_index" in self.columns
            else np.arange(len(rows))
        )
        order = np.argsort(frames, kind="stable")
        rows, frames = rows[order], frames[order]
        if len(rows) < 3:
            raise ValueError(f"episode {e}: {len(rows)} frames; a demonstration needs at least 3")
        times = self._times(e, rows, frames)
        pose = self._pose(e, rows, frames)
        gripper = self._col(c.gripper_key, rows)[:, c.gripper_index]
        _check_finite(c.gripper_key, e, gripper, frames)
        force, wrench = self._force(e, rows, frames), self._wrench(e, rows, frames)
        finger = self._checked(c.finger_force_key, e, rows, frames) if self._has(c.finger_force_key) else None
        gripper_force = (
            None if finger is None else finger_force_scalar(finger, self._names(c.finger_force_key))
        )
        if wrench is None and gripper_force is not None and self.has_force:
            holding = gripper_force < -self.holding_n
            if holding.any():
                force, wrench = without_held_weight(force, holding), force
        return EpisodeArrays(
            episode=e,
            times=times - times[0],
            pose=pose,
            force=force,
            gripper=gripper,
            gripper_force=gripper_force,
            env_state=self._env_state(e, rows, frames),
            joints=self._joints(e, rows, frames),
            finger_force=finger,
            segment_labels=self._labels(e, rows, frames),
            has_force=self.has_force,
            wrench=wrench,
            contact=self._contact(e, rows, frames),
        )

    def _times(self, e: int, rows: Frames, frames: Frames) -> Array:
        times = self._checked("timestamp", e, rows, frames)[:, 0]
        step = np.diff(times)
        if np.any(step <= 0):
            i = int(np.argmax(step <= 0))
            raise ValueError(
                f"feature 'timestamp', episode {e}, frame {int(frames[i + 1])}: timestamps must increase "
                f"({times[i]:.6f} s -> {times[i + 1]:.6f} s; duplicated or out-of-order frame)"
            )
        return times

    def _pose(self, e: int, rows: Frames, frames: Frames) -> Array:
        key = self.c.pose_key
        pose = self._col(key, rows)[:, :7]
        _check_finite(key, e, pose, frames)
        norms = np.linalg.norm(pose[:, 3:7], axis=1)
        if np.any(norms < 1e-6):
            raise ValueError(
                f"feature {key!r}, episode {e}, frame {int(frames[np.argmax(norms < 1e-6)])}: zero quaternion"
            )
        pose[:, 3:7] /= norms[:, None]
        return pose

    def _force(self, e: int, rows: Frames, frames: Frames, key: str = "") -> Array:
        if not (key or self.has_force):
            return np.zeros((len(rows), 3))
        key = key or self.force_key
        force = self._col(key, rows)
        if force.shape[1] < 3:
            raise ValueError(f"feature {key!r}: needs >= 3 entries (fx fy fz), has {force.shape[1]}")
        force = force[:, :3]
        _check_finite(key, e, force, frames)
        return force

    def _wrench(self, e: int, rows: Frames, frames: Frames) -> Array | None:
        return self._force(e, rows, frames, self.c.force_key) if self.reacting else None

    def _contact(self, e: int, rows: Frames, frames: Frames) -> NDArray[np.bool_] | None:
        if not self._has(layout.CONTACT):
            return None
        return self._checked(layout.CONTACT, e, rows, frames)[:, 0] > 0.5

    def _env_state(self, e: int, rows: Frames, frames: Frames) -> Array | None:
        key = self.c.env_state_key
        if not self._has(key):
            return None
        env_state = self._checked(key, e, rows, frames)
        names = self._names(key)
        if names is not None and env_state.shape[1] != len(names):
            raise ValueError(f"feature {key!r}: {env_state.shape[1]} columns but {len(names)} names")
        return env_state

    def _joints(self, e: int, rows: Frames, frames: Frames) -> Array | None:
        key = self.c.joints_key
        if not self._has(key):
            return None
        joints = self._col(key, rows)
        names = self._names(key) or []
        if names and names[-1] == layout.GRIPPER_STATE_NAME:
            joints = joints[:, :-1]
        _check_finite(key, e, joints, frames)
        return joints

    def _labels(self, e: int, rows: Frames, frames: Frames) -> NDArray[np.int64] | None:
        key = self.c.segment_column
        if key not in self.columns:
            return None
        raw = np.asarray(self.columns[key])[rows].reshape(-1)
        where = f"feature {key!r}, episode {e}"
        if raw.dtype.kind not in "iubf":
            raise ValueError(f"{where}: segment labels must be integers, got dtype {raw.dtype}")
        if raw.dtype.kind == "f":
            _check_finite(key, e, raw, frames)
            # a fractional label would be truncated into its neighbour, merging two segments unseen
            if (fractional := raw != np.round(raw)).any():
                k = int(np.argmax(fractional))
                raise ValueError(
                    f"{where}, frame {int(frames[k])}: segment label {raw[k].item()!r} is not an integer"
                )
        return raw.astype(np.int64)
