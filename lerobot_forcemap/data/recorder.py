"""Read the lab recorder h5 format and the GBTI grasping file (pure h5py/NumPy, no LeRobot).

Recorder layout (described in ``docs/data.md``)::

    joint_state_info/{joint_positions (n,6) rad, joint_velocities, joint_effort, joint_time (n,2)}
    transform_info/{transform_positions (n,3) m, transform_orientations (n,4) x y z w, transform_time (n,2)}
    wrench_info/{wrench_force (n,3) N, wrench_torque (n,3) N·m, wrench_time (n,2)}   tool frame, biased
    gripper_info/{gripper_position (n,1), gripper_time (n,2)}                           optional
    GBTI: gripper_info/{gripper_vals (n,1) counts, gripper_time, forces (n,1) raw finger-force counts, force_time}

Times are ``[sec, nsec]`` rows; here they become float64 seconds since the Unix epoch. Orientations
are converted to the project's scalar-first ``w x y z``; joints are reordered from ROS's alphabetical
order to the kinematic chain (``layout.UR5E_JOINT_NAMES``). The transform is the flange (tool0) in the
robot base frame. Values are kept as recorded otherwise
(no tare, no rotation, no resampling: see :mod:`lerobot_forcemap.data.transforms`).
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import h5py
import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap.geometry import xyzw_to_wxyz

__all__ = [
    "Recording",
    "GbtiKey",
    "RECORDER_TO_CHAIN_ORDER",
    "read_recording",
    "iter_gbti_demos",
    "gbti_keys",
    "GBTI_OBJECTS",
]

F64 = NDArray[np.float64]
GBTI_OBJECTS = ("Cube", "Mug", "Plate")
# Column order of ``joint_state_info/joint_positions`` is ROS /joint_states' alphabetical order
# (elbow, shoulder_lift, shoulder_pan, wrist_1, wrist_2, wrist_3). Indexing with this gives the
# kinematic order of ``layout.UR5E_JOINT_NAMES``. Verified: UR5e forward kinematics (published DH) of
# the reordered joints reproduces ``transform_positions`` within 1 mm on the press, three-button and
# GBTI files; the file order misses by 0.2-0.5 m.
RECORDER_TO_CHAIN_ORDER = (2, 1, 0, 3, 4, 5)


@dataclass(frozen=True)
class Recording:
    """One demonstration as recorded. Times: float64 seconds since the epoch; T differs per stream.

    name: file stem or GBTI key ``"Cube/User1/Position1"``.
    joint_time (Tj,), joint_positions (Tj, 6) rad in kinematic order ``layout.UR5E_JOINT_NAMES``
    (reordered from the file's alphabetical ROS order, see ``RECORDER_TO_CHAIN_ORDER``).
    pose_time (Tp,), positions (Tp, 3) m, orientations (Tp, 4) unit quaternions w x y z (base frame).
    wrench_time (Tw,), force_tool (Tw, 3) N, torque_tool (Tw, 3) N·m: raw sensor wrench, tool frame, biased.
    gripper_time/gripper (Tg,) raw gripper reading (counts, 0 open .. ~100 closed) or None.
    finger_force_time/finger_force (Tf,) raw GBTI finger-force counts (uncalibrated) or None.
    not_converted: datasets of the format present in the file but not read (joint velocities and
    efforts, :data:`NOT_CONVERTED`), for the converter to report.
    """

    name: str
    joint_time: F64
    joint_positions: F64
    pose_time: F64
    positions: F64
    orientations: F64
    wrench_time: F64
    force_tool: F64
    torque_tool: F64
    gripper_time: F64 | None = None
    gripper: F64 | None = None
    finger_force_time: F64 | None = None
    finger_force: F64 | None = None
    not_converted: tuple[str, ...] = ()

    @property
    def streams(self) -> dict[str, tuple[F64, F64]]:
        """``{stream name: (times (T,), values (T, k))}`` for every stream present."""
        out = {
            "joint": (self.joint_time, self.joint_positions),
            "pose": (self.pose_time, np.concatenate([self.positions, self.orientations], axis=1)),
            "wrench": (self.wrench_time, np.concatenate([self.force_tool, self.torque_tool], axis=1)),
        }
        if self.gripper is not None and self.gripper_time is not None:
            out["gripper"] = (self.gripper_time, self.gripper[:, None])
        if self.finger_force is not None and self.finger_force_time is not None:
            out["finger_force"] = (self.finger_force_time, self.finger_force[:, None])
        return out

    @property
    def start_time(self) -> float:
        return float(min(t[0] for t, _ in self.streams.values()))


@dataclass(frozen=True, order=True)
class GbtiKey:
    """Address of a GBTI demo: ``/{object}/User{user}/Position{position}``."""

    object: str
    user: int
    position: int

    def __str__(self) -> str:
        return f"{self.object}/User{self.user}/Position{self.position}"

    @classmethod
    def parse(cls, text: str) -> GbtiKey:
        m = re.fullmatch(r"/?(\w+)/User(\d+)/Position(\d+)/?", text)
        if not m:
            raise ValueError(f"not a GBTI key (Object/UserN/PositionM): {text!r}")
        return cls(m.group(1), int(m.group(2)), int(m.group(3)))


def _group(parent: h5py.Group, name: str, rec: str) -> h5py.Group:
    if name not in parent or not isinstance(parent[name], h5py.Group):
        found = sorted(parent.keys())
        what = f"{name!r} is not a group" if name in parent else f"missing group {name!r}"
        hint = ""
        if parent.name == "/" and found and all(_looks_like_gbti_object(parent[k]) for k in found):
            hint = "; this looks like a GBTI file (object/UserN/PositionM groups): pass --gbti"
        raise ValueError(f"recording {rec!r}: {what} (found {found}){hint}")
    return parent[name]


def _looks_like_gbti_object(item: h5py.Group | h5py.Dataset) -> bool:
    return isinstance(item, h5py.Group) and any(re.fullmatch(r"User\d+", k) for k in item)


def _numbers(dataset: h5py.Dataset, path: str, rec: str) -> F64:
    """The dataset as float64, or a ValueError naming it (strings, compound types, a group)."""
    if not isinstance(dataset, h5py.Dataset):
        raise ValueError(f"recording {rec!r}: {path!r} is not a dataset")
    try:
        return np.asarray(dataset[()], dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise ValueError(
            f"recording {rec!r}: {path!r} holds {dataset.dtype} values, not numbers ({err})"
        ) from None


def _array(group: h5py.Group, name: str, rec: str, cols: int | None) -> F64:
    path = f"{group.name.rsplit('/', 1)[-1]}/{name}"
    if name not in group or not isinstance(group[name], h5py.Dataset):
        what = f"{path!r} is not a dataset" if name in group else f"missing dataset {path!r}"
        raise ValueError(f"recording {rec!r}: {what} (found {sorted(group.keys())})")
    arr = _numbers(group[name], path, rec)
    if cols is None:  # (n,) or (n, 1) -> (n,)
        if arr.ndim == 2 and arr.shape[1] == 1:
            arr = arr[:, 0]
        if arr.ndim != 1:
            raise ValueError(f"recording {rec!r}: {path!r} has shape {arr.shape}, expected (n,) or (n, 1)")
    elif arr.ndim != 2 or arr.shape[1] != cols:
        raise ValueError(f"recording {rec!r}: {path!r} has shape {arr.shape}, expected (n, {cols})")
    if arr.shape[0] < 2:
        raise ValueError(f"recording {rec!r}: {path!r} has {arr.shape[0]} samples, need at least 2")
    finite = np.isfinite(arr.reshape(arr.shape[0], -1))
    if not finite.all():
        row = int(np.argwhere(~finite)[0, 0])
        raise ValueError(f"recording {rec!r}: {path!r} is not finite (NaN/inf) at sample {row}")
    return arr


def _times(group: h5py.Group, name: str, rec: str, n: int) -> F64:
    """``[sec, nsec]`` rows -> float64 seconds; also accepts plain (n,) seconds."""
    path = f"{group.name.rsplit('/', 1)[-1]}/{name}"
    raw = _numbers(group[name], path, rec) if name in group else None
    if raw is None:
        raise ValueError(f"recording {rec!r}: missing dataset {path!r} (found {sorted(group.keys())})")
    if raw.ndim == 2 and raw.shape[1] == 2:
        nsec = raw[:, 1]
        bad = np.isfinite(nsec) & ~((nsec >= 0) & (nsec < 1e9))  # non-finite: reported below
        if bad.any():
            i = int(np.argmax(bad))
            raise ValueError(
                f"recording {rec!r}: {path!r} column 1 (nanoseconds) must lie in [0, 1e9), got {nsec[i]:.6g} "
                f"at sample {i}"
            )
        t = raw[:, 0] + raw[:, 1] * 1e-9
    elif raw.ndim == 1 or (raw.ndim == 2 and raw.shape[1] == 1):
        t = raw.reshape(-1)
    else:
        raise ValueError(f"recording {rec!r}: {path!r} has shape {raw.shape}, expected (n, 2) [sec, nsec]")
    if len(t) != n:
        raise ValueError(f"recording {rec!r}: {path!r} has {len(t)} rows but its data has {n}")
    if not np.all(np.isfinite(t)):
        raise ValueError(
            f"recording {rec!r}: {path!r} is not finite (NaN/inf) at sample {int(np.argmax(~np.isfinite(t)))}"
        )
    return t


#: every group and dataset of the lab-recorder format (``docs/data.md``); joint efforts and
#: velocities are known but not converted
RECORDER_LAYOUT: dict[str, frozenset[str]] = {
    "joint_state_info": frozenset({"joint_positions", "joint_time", "joint_effort", "joint_velocities"}),
    "transform_info": frozenset({"transform_positions", "transform_orientations", "transform_time"}),
    "wrench_info": frozenset({"wrench_force", "wrench_torque", "wrench_time"}),
    "gripper_info": frozenset({"gripper_position", "gripper_vals", "gripper_time", "forces", "force_time"}),
}
#: datasets of :data:`RECORDER_LAYOUT` that are not converted (the dataset holds joint positions only)
NOT_CONVERTED = ("joint_state_info/joint_velocities", "joint_state_info/joint_effort")


def _unknown_content(g: h5py.Group) -> list[str]:
    """Content outside :data:`RECORDER_LAYOUT` (not converted: warned about and listed in
    ``Recording.not_converted``, so the dataset's sources file and card name it too)."""
    unknown = [key for key in g if key not in RECORDER_LAYOUT]
    for group, known in RECORDER_LAYOUT.items():
        if group in g and isinstance(g[group], h5py.Group):
            unknown += [f"{group}/{key}" for key in g[group] if key not in known]
    return sorted(unknown)


def _read_group(g: h5py.Group, name: str) -> Recording:
    js = _group(g, "joint_state_info", name)
    joints = _array(js, "joint_positions", name, 6)
    tf, pos, quat = _read_pose(g, name)
    ws, force, torque = _read_wrench(g, name)
    gripper_time, gripper, ff_time, ff = _read_gripper_info(g, name)
    recording = Recording(
        name=name,
        joint_time=_times(js, "joint_time", name, len(joints)),
        joint_positions=joints[:, RECORDER_TO_CHAIN_ORDER],
        pose_time=_times(tf, "transform_time", name, len(pos)),
        positions=pos,
        orientations=quat,
        wrench_time=_times(ws, "wrench_time", name, len(force)),
        force_tool=force,
        torque_tool=torque,
        gripper_time=gripper_time,
        gripper=gripper,
        finger_force_time=ff_time,
        finger_force=ff,
        not_converted=tuple(p for p in NOT_CONVERTED if p in g) + tuple(unknown := _unknown_content(g)),
    )
    if unknown:  # after a successful read: a file of another layout fails with its reason
        warnings.warn(
            f"recording {name!r}: {unknown} not part of the lab-recorder format; not converted",
            stacklevel=2,
        )
    return recording


def _read_pose(g: h5py.Group, name: str) -> tuple[h5py.Group, F64, F64]:
    """``transform_info``: the group, positions (n, 3) and unit quaternions (n, 4) w x y z."""
    tf = _group(g, "transform_info", name)
    pos = _array(tf, "transform_positions", name, 3)
    quat_xyzw = _array(tf, "transform_orientations", name, 4)
    norms = np.linalg.norm(quat_xyzw, axis=1)
    if np.any(np.abs(norms - 1.0) > 1e-3):
        row = int(np.argmax(np.abs(norms - 1.0) > 1e-3))
        raise ValueError(
            f"recording {name!r}: 'transform_info/transform_orientations' is not a unit quaternion at sample {row} "
            f"(norm {norms[row]:.4f})"
        )
    if len(pos) != len(quat_xyzw):
        raise ValueError(
            f"recording {name!r}: transform_positions has {len(pos)} rows, transform_orientations {len(quat_xyzw)}"
        )
    return tf, pos, xyzw_to_wxyz(quat_xyzw / norms[:, None])


def _read_wrench(g: h5py.Group, name: str) -> tuple[h5py.Group, F64, F64]:
    """``wrench_info``: the group, force (n, 3) and torque (n, 3) as recorded (tool frame, biased)."""
    ws = _group(g, "wrench_info", name)
    force = _array(ws, "wrench_force", name, 3)
    torque = _array(ws, "wrench_torque", name, 3)
    if len(force) != len(torque):
        raise ValueError(
            f"recording {name!r}: wrench_force has {len(force)} rows, wrench_torque {len(torque)}"
        )
    return ws, force, torque


def _read_gripper_info(g: h5py.Group, name: str) -> tuple[F64 | None, F64 | None, F64 | None, F64 | None]:
    """``gripper_info`` (optional): gripper times and raw readings, finger-force times and raw counts."""
    if "gripper_info" not in g:
        return None, None, None, None
    gi = _group(g, "gripper_info", name)
    if "gripper_position" in gi and "gripper_vals" in gi:  # no documented precedence: do not guess
        raise ValueError(
            f"recording {name!r}: 'gripper_info' holds both 'gripper_position' (lab recorder) and "
            "'gripper_vals' (GBTI); expected one gripper reading"
        )
    key = next((k for k in ("gripper_position", "gripper_vals") if k in gi), None)
    if key is None:
        raise ValueError(
            f"recording {name!r}: 'gripper_info' has neither gripper_position nor gripper_vals "
            f"(found {sorted(gi.keys())})"
        )
    gripper = _array(gi, key, name, None)
    gripper_time = _times(gi, "gripper_time", name, len(gripper))
    if "force_time" in gi and "forces" not in gi:
        raise ValueError(
            f"recording {name!r}: 'gripper_info' has 'force_time' but no 'forces' (the finger force is "
            "missing; without it this demonstration would convert without finger force)"
        )
    if "forces" not in gi:
        return gripper_time, gripper, None, None
    ff = _array(gi, "forces", name, None)
    return gripper_time, gripper, _times(gi, "force_time", name, len(ff)), ff


def read_recording(path_or_group: str | Path | h5py.Group, name: str | None = None) -> Recording:
    """Read one recording from a lab-recorder file (path) or an open h5 group (e.g. a GBTI demo).

    Raises ``ValueError`` naming the recording and the dataset for a missing group/dataset, a wrong
    shape, mismatched lengths, NaN/inf values (with the sample index) or non-unit quaternions.
    Orientations are normalised (deviation up to 1e-3 accepted) and returned as w x y z.
    """
    if isinstance(path_or_group, h5py.Group):
        return _read_group(path_or_group, name or path_or_group.name.strip("/") or "recording")
    path = Path(path_or_group)
    if not path.is_file():
        raise ValueError(f"recording file not found: {path}")
    with _open_h5(path) as f:
        return _read_group(f, name or path.stem)


def _open_h5(path: Path) -> h5py.File:
    """``h5py.File(path, "r")``; a file that is not HDF5 is a ``ValueError`` naming it."""
    try:
        return h5py.File(path, "r")
    except OSError as err:
        raise ValueError(f"{path}: not a readable HDF5 file ({err})") from None


def gbti_keys(path: str | Path) -> list[GbtiKey]:
    """All demo keys of a GBTI file, sorted by object, user, position.

    Datasets beside the object and user groups (notes, calibration) are not demos: they are skipped
    with a warning naming them."""
    keys = []
    skipped = []
    with _open_h5(Path(path)) as f:
        for obj in f:
            if not isinstance(f[obj], h5py.Group):
                skipped.append(obj)
                continue
            for user in f[obj]:
                if not isinstance(f[obj][user], h5py.Group):
                    skipped.append(f"{obj}/{user}")
                    continue
                for pos in f[obj][user]:
                    if (
                        not isinstance(f[obj][user][pos], h5py.Group)
                        or "wrench_info" not in f[obj][user][pos]
                    ):
                        raise ValueError(
                            f"{path}: {obj}/{user}/{pos} is not a GBTI demo group (not a GBTI file? a lab-"
                            "recorder file is converted without --gbti)"
                        )
                    try:
                        keys.append(GbtiKey.parse(f"{obj}/{user}/{pos}"))
                    except ValueError as err:
                        raise ValueError(f"{path}: {err}") from None
    if not keys:
        raise ValueError(f"{path}: no /Object/UserN/PositionM groups (not a GBTI file?)")
    if skipped:  # say so rather than drop it silently, as _read_group does for a demo's unknown content
        warnings.warn(
            f"{path}: {sorted(skipped)} not part of the GBTI layout (/Object/UserN/PositionM groups); "
            "not converted",
            stacklevel=2,
        )
    return sorted(keys)


def iter_gbti_demos(
    path: str | Path, keys: list[GbtiKey] | None = None
) -> Iterator[tuple[GbtiKey, Recording]]:
    """Yield ``(GbtiKey, Recording)`` for every demo of the GBTI file (or the given ``keys``), in key order."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"GBTI file not found: {path}")
    keys = gbti_keys(path) if keys is None else list(keys)
    with _open_h5(path) as f:
        for key in keys:
            if str(key) not in f:
                raise ValueError(f"{path}: missing GBTI demo group {str(key)!r}")
            yield key, _read_group(f[str(key)], str(key))
