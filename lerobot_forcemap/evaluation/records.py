"""Episode records: what one evaluated episode is reduced to, and its per-step trace layout.

A record is a JSON object (plain dicts, lists, bool, int, float, str)::

    {"seed", "success", "protective_stop", "termination_reason", "steps", "wall_s",
     <figures>: max_contact_force (N), mean_contact_force (N), max_contact_force_xyz [3],
                mean_contact_force_xyz [3] (per-axis |F|), and with ``FINGER_KEYS`` per-finger forces,
     "metrics": {the task's other info entries: scalars, strings, vectors of <= 16 numbers},
     "trace": {"columns", "rows", "environment_state", "environment_state_names"}   (optional)}

The force figures are the env's own episode statistics (filtered contact force at physics rate,
environment on robot, base frame), the same as the recorder stores per demonstration in
``meta/forcemap_episodes.json``. A trace row holds :data:`TRACE_COLUMNS` per control step: time (s),
the contact force (N) the action was chosen with, the measured TCP pose (m, quaternion w first) and
the commanded action (target pose and gripper command 0 = open .. 1 = closed).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from lerobot_forcemap._validation import fail

__all__ = [
    "FORCE_KEYS",
    "FINGER_KEYS",
    "ALL_FIGURES",
    "TRACE_COLUMNS",
    "DEMO_TRACE_COLUMNS",
    "GRIPPER_PHASES",
    "to_json",
    "finite_or_none",
    "episode_outcome",
    "episode_record",
    "trace_row",
    "trace_block",
    "force_by_gripper_phase",
]

#: the per-episode force figures of every task (env ``info`` keys)
FORCE_KEYS = ("max_contact_force", "mean_contact_force", "max_contact_force_xyz", "mean_contact_force_xyz")
#: per-finger fingertip force figures of the grasping tasks (one number per finger)
FINGER_KEYS = ("max_finger_force", "mean_finger_force")
ALL_FIGURES = (*FORCE_KEYS, *FINGER_KEYS)
#: columns of a trace row: time, contact force, measured TCP pose, commanded action
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
#: the columns every trace holds, a demonstration's (read from a dataset) included: what the plots read
DEMO_TRACE_COLUMNS = ("t", "fx", "fy", "fz", "x", "y", "z", "target_x", "target_y", "target_z")
#: gripper-command phases: closed (command >= 0.95), moving (between), open (<= 0.05)
GRIPPER_PHASES = ("closed", "moving", "open")
#: info entries that are not task metrics: the outcome, the per-step force and the clip reports
_NOT_METRICS = ("is_success", "protective_stop", "termination_reason", "contact_force")


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


def finite_or_none(v: Any) -> Any:
    """``v`` with every non-finite float replaced by ``None`` (JSON has no NaN), recursively."""
    if isinstance(v, float) and not math.isfinite(v):
        return None
    if isinstance(v, dict):
        return {k: finite_or_none(x) for k, x in v.items()}
    if isinstance(v, list):
        return [finite_or_none(x) for x in v]
    return v


def episode_outcome(episode) -> dict[str, Any]:
    """The head of a record from a finished ``lerobot_forcemap.envs.rollout.Episode``: seed, success,
    protective stop, why it ended (the task's reason, else ``time_limit`` when truncated), steps and
    wall time (s)."""
    info = episode.info
    return {
        "seed": episode.seed,
        "success": bool(info["is_success"]),
        "protective_stop": bool(info["protective_stop"]),
        "termination_reason": info.get("termination_reason") or ("time_limit" if episode.truncated else ""),
        "steps": episode.steps,
        "wall_s": episode.wall_s,
    }


def episode_record(episode, figures: Sequence[str] = FORCE_KEYS) -> dict[str, Any]:
    """The record of a finished episode (module docstring): its outcome, the ``figures`` its last
    ``info`` holds (top level) and the task's metrics (every other info entry of at most 16 numbers,
    clip reports left out)."""
    info = episode.info
    record = {**episode_outcome(episode), **{k: to_json(info[k]) for k in figures if k in info}}
    skip = {*_NOT_METRICS, *figures}
    record["metrics"] = {
        k: to_json(v)
        for k, v in info.items()
        if k not in skip and not k.startswith("clip_") and np.ndim(v) <= 1 and np.size(v) <= 16
    }
    return record


def trace_row(step, fps: float) -> list[float]:
    """One :data:`TRACE_COLUMNS` row of an ``envs.rollout.Step``: time ``index / fps``, the contact
    force and TCP pose the action was chosen with, the action."""
    from lerobot_forcemap import layout

    return [
        step.index / fps,
        *step.info["contact_force"],
        *step.obs[layout.ENV_EE_POSE],
        *np.asarray(step.action).tolist(),
    ]


def trace_block(
    rows: Sequence[Sequence[float]],
    env_state: Any,
    state_names: Sequence[str],
    *,
    decimals: int | None = None,
) -> dict[str, Any]:
    """A record's ``trace``: the :data:`TRACE_COLUMNS` rows (rounded to ``decimals`` when given), the
    last environment state and its names (the plots draw paths relative to its first object)."""
    table = np.asarray(rows)
    return {
        "columns": list(TRACE_COLUMNS),
        "rows": to_json(table if decimals is None else np.round(table, decimals)),
        "environment_state": to_json(env_state) if env_state is not None else None,
        "environment_state_names": list(state_names),
    }


def force_by_gripper_phase(forces: np.ndarray, gripper: np.ndarray) -> dict[str, Any]:
    """Max |F| per axis ``(3,)`` and step count per :data:`GRIPPER_PHASES` phase, from the per-step
    contact force ``forces (T, 3)`` (control-rate samples of the filtered force, so maxima can read below
    the physics-rate ``max_contact_force_xyz``) and the gripper commands ``gripper (T,)``: in which phase
    a force peak happened (e.g. during a release)."""
    forces = np.asarray(forces, dtype=np.float64).reshape(-1, 3)
    g = np.asarray(gripper, dtype=np.float64).reshape(-1)
    if len(forces) != len(g):
        fail(
            "force_by_gripper_phase",
            f"get one gripper command per force sample ({len(forces)} force samples for {len(g)} commands)",
        )
    masks = {"closed": g >= 0.95, "open": g <= 0.05}
    masks["moving"] = ~(masks["closed"] | masks["open"])
    out = {}
    for name in GRIPPER_PHASES:
        m = masks[name]
        out[name] = {
            "steps": int(m.sum()),
            "max_xyz": to_json(np.abs(forces[m]).max(axis=0)) if m.any() else [0.0, 0.0, 0.0],
        }
    return out
