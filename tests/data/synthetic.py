"""Synthetic recorder / GBTI h5 files with known contents, for the data tests."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np

from lerobot_forcemap.data.recorder import RECORDER_TO_CHAIN_ORDER
from lerobot_forcemap.geometry import (
    quat_conjugate,
    quat_normalize,
    quat_rotate,
    rotvec_to_quat,
    wxyz_to_xyzw,
)

T0_EPOCH = 1_700_000_000.25


def sec_nsec(t: np.ndarray) -> np.ndarray:
    """Float seconds -> [sec, nsec] rows as the recorder writes them."""
    sec = np.floor(t)
    return np.stack([sec, np.round((t - sec) * 1e9)], axis=1)


def make_streams(
    n: int = 400, rate: float = 100.0, seed: int = 0, gripper: bool = True, finger: bool = False
) -> dict:
    """Known smooth streams on a common clock (seconds since epoch)."""
    rng = np.random.default_rng(seed)
    t = T0_EPOCH + np.arange(n) / rate
    s = np.linspace(0.0, 1.0, n)
    joints = np.stack([np.sin(2 * s + k) for k in range(6)], axis=1)
    pos = np.stack([0.3 + 0.1 * s, -0.4 + 0.05 * np.sin(3 * s), 0.5 - 0.2 * s], axis=1)
    rotvec = np.stack([np.pi + 0.3 * s, 0.2 * s, 0.1 + 0 * s], axis=1)
    quat = quat_normalize(rotvec_to_quat(rotvec))  # w x y z
    bias_f = np.array([3.0, -1.0, 2.0])
    bias_t = np.array([0.1, 0.05, -0.02])
    # Contact in the middle: +20 N up and a small torque in the base frame, seen by the tool-frame sensor.
    contact = (s > 0.4) & (s < 0.6)
    f_base = np.where(contact[:, None], [0.0, 0.0, 20.0], 0.0)
    t_base = np.where(contact[:, None], [0.5, 0.0, 0.0], 0.0)
    force = bias_f + quat_rotate(quat_conjugate(quat), f_base) + 0.05 * rng.standard_normal((n, 3))
    torque = bias_t + quat_rotate(quat_conjugate(quat), t_base) + 0.005 * rng.standard_normal((n, 3))
    out = dict(
        t=t,
        joints=joints,
        pos=pos,
        quat=quat,
        force=force,
        torque=torque,
        bias_f=bias_f,
        bias_t=bias_t,
        f_base=f_base,
        t_base=t_base,
        contact=contact,
    )
    if gripper:
        out["gripper"] = np.where(s > 0.5, 80.0, 1.0)
    if finger:
        out["finger"] = 370.0 + 300.0 * (s > 0.6)
    return out


def write_group(g: h5py.Group, st: dict, *, gbti: bool = False, skip: tuple[str, ...] = ()) -> None:
    """Write the four recorder groups into ``g`` (``skip`` leaves out groups or 'group/dataset')."""
    ts = sec_nsec(st["t"])
    spec = {
        "joint_state_info": {
            # st["joints"] is in kinematic order; the recorder writes ROS's alphabetical order.
            "joint_positions": st["joints"][:, list(RECORDER_TO_CHAIN_ORDER)],
            "joint_velocities": np.zeros_like(st["joints"]),
            "joint_effort": np.zeros_like(st["joints"]),
            "joint_time": ts,
        },
        "transform_info": {
            "transform_positions": st["pos"],
            "transform_orientations": wxyz_to_xyzw(st["quat"]),
            "transform_time": ts,
        },
        "wrench_info": {"wrench_force": st["force"], "wrench_torque": st["torque"], "wrench_time": ts},
    }
    if "gripper" in st:
        key = "gripper_vals" if gbti else "gripper_position"
        spec["gripper_info"] = {key: st["gripper"][:, None], "gripper_time": ts}
        if "finger" in st:
            spec["gripper_info"].update(forces=st["finger"][:, None], force_time=ts)
    for group, datasets in spec.items():
        if group in skip:
            continue
        gg = g.create_group(group)
        for name, arr in datasets.items():
            if f"{group}/{name}" in skip:
                continue
            gg.create_dataset(name, data=arr)


def write_recorder_file(path: Path, st: dict, **kw) -> Path:
    with h5py.File(path, "w") as f:
        write_group(f, st, **kw)
    return path


def write_gbti_file(path: Path, keys: list[tuple[str, int, int]], n: int = 300) -> Path:
    with h5py.File(path, "w") as f:
        for i, (obj, user, pos) in enumerate(keys):
            st = make_streams(n=n + 10 * i, seed=i, finger=True)
            write_group(f.create_group(f"{obj}/User{user}/Position{pos}"), st, gbti=True)
    return path
