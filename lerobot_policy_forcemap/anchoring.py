"""Place a fitted skill in a new scene: re-anchor it to the robot's pose and the objects' poses.

Objects come from the environment state by name: every ``<obj>_x <obj>_y <obj>_z`` triple of
``env_state_names`` is an object position, ``<obj>_qw .. <obj>_qz`` (if present) its orientation
(w first); e.g. the press task's ``button_x ... button_qz``.

Placing (:func:`place_skill`), per segment s with stored nodes y_s:

1. Anchored segments (stored in an object's frame) are moved rigidly with the object's current
   pose: ``p + R y``, orientations ``q ⊗ q_s``. The force-lifted contact nodes keep their shape.
2. Boundary points: the start of segment 0 is the robot's current pose; a boundary next to an
   anchored segment is that segment's own (moved) endpoint; the remaining boundaries (between two
   free segments, or the end of trailing free segments) get the displacement interpolated in time
   between the known ones (held after the last known one). Consecutive segments anchored to the
   same object keep their fitted relation (they move rigidly together, small fitted gaps included).
3. Each free segment (base frame) gets the new start/end points as equality constraints
   (``Constraints(start=..., end=...)``) and is re-solved by the elastic map against its own stored
   nodes, first displaced by the endpoint displacements blended linearly along the segment's time
   law. The blend is needed because the squared cluster weight of the data term (SPEC §1)
   dominates the smoothness terms at the fitted λ, μ: a re-solve against the unmoved nodes only
   bends the few nodes next to a moved end (a kink, not a new path). An anchored segment whose
   endpoint has to move (it is the first segment, or its neighbour is anchored elsewhere) gets the
   blend only, so its contact nodes stay as fitted.
4. The orientation of segment 0 is blended from the robot's current orientation to the stored one
   (rotation vector of the difference scaled by 1 − u along the segment).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap.elmap import Constraints, fit_force_elastic_map
from lerobot_forcemap.geometry import (
    quat_conjugate,
    quat_multiply,
    quat_normalize,
    quat_rotate,
    quat_to_rotvec,
    rotvec_to_quat,
)

from .skill import FittedSkill, Reproduction, SegmentMaps

__all__ = [
    "ObjectSlot",
    "object_slots",
    "object_poses",
    "to_object_frame",
    "from_object_frame",
    "place_skill",
    "IDENTITY_POSE",
]

Array = NDArray[np.float64]
IDENTITY_POSE = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])


@dataclass(frozen=True)
class ObjectSlot:
    """Where one object's pose sits in the environment state: position columns (3), quaternion columns (4) or None."""

    name: str
    position: tuple[int, int, int]
    quaternion: tuple[int, int, int, int] | None


def object_slots(names: Sequence[str]) -> tuple[ObjectSlot, ...]:
    """Objects named in ``env_state_names`` (``<obj>_x/_y/_z`` and optionally ``<obj>_qw/_qx/_qy/_qz``)."""
    names = [str(n) for n in names]
    index = {n: i for i, n in enumerate(names)}
    slots = []
    for n in names:
        if not n.endswith("_x"):
            continue
        obj = n[:-2]
        if not obj or not all(f"{obj}_{a}" in index for a in "yz"):
            continue
        pos = tuple(index[f"{obj}_{a}"] for a in "xyz")
        quat = None
        if all(f"{obj}_q{a}" in index for a in "wxyz"):
            quat = tuple(index[f"{obj}_q{a}"] for a in "wxyz")
        slots.append(ObjectSlot(obj, pos, quat))
    return tuple(slots)


def object_poses(env_state: Array, slots: Sequence[ObjectSlot]) -> dict[str, Array]:
    """``{name: pose (7,) [x y z qw qx qy qz]}`` from one environment-state vector ``(E,)``."""
    env_state = np.asarray(env_state, dtype=np.float64).reshape(-1)
    out = {}
    for s in slots:
        idx = [*s.position, *(s.quaternion or ())]
        if max(idx) >= len(env_state):
            raise ValueError(
                f"environment state has {len(env_state)} entries; object {s.name!r} needs column {max(idx)}"
            )
        pose = IDENTITY_POSE.copy()
        pose[:3] = env_state[list(s.position)]
        if s.quaternion is not None:
            q = env_state[list(s.quaternion)]
            if np.linalg.norm(q) < 1e-6:
                raise ValueError(f"environment state: object {s.name!r} has a zero quaternion")
            pose[3:] = quat_normalize(q)
        if not np.all(np.isfinite(pose)):
            raise ValueError(f"environment state: object {s.name!r} has a non-finite pose {pose.tolist()}")
        out[s.name] = pose
    return out


def to_object_frame(pose: Array, positions: Array, vectors: Array | None = None, quats: Array | None = None):
    """Express base-frame positions (T, 3), free vectors (T, 3) and orientations (T, 4) in the frame
    of an object at ``pose (7,)``; returns the three (None stays None)."""
    q_inv = quat_conjugate(pose[3:])
    p = quat_rotate(q_inv, positions - pose[:3])
    v = None if vectors is None else quat_rotate(q_inv, vectors)
    q = None if quats is None else quat_multiply(q_inv, quats)
    return p, v, q


def from_object_frame(pose: Array, positions: Array, quats: Array) -> tuple[Array, Array]:
    """Inverse of :func:`to_object_frame` for positions (N, 3) and orientations (N, 4)."""
    return pose[:3] + quat_rotate(pose[3:], positions), quat_multiply(pose[3:], quats)


def _blend(seg: SegmentMaps, d_start: Array, d_end: Array) -> Array:
    """Nodes displaced by ``(1-u) d_start + u d_end``, u the node's fraction of the segment's time law."""
    t = seg.node_times
    span = t[-1] - t[0]
    u = (t - t[0]) / span if span > 0 else np.linspace(0.0, 1.0, len(t))
    return seg.nodes + (1.0 - u)[:, None] * d_start + u[:, None] * d_end


def _resolve(
    seg: SegmentMaps, data: Array, start: Array, end: Array, params: Mapping[str, float]
) -> SegmentMaps:
    """Re-solve a free segment against ``data (N, 3)`` (its displaced nodes) with start/end equalities.

    With ``params["time_scale"] = v > 0`` the re-solve is in space-time like the fit: the node times
    scaled by v are a 4th coordinate whose ends are constrained to the stored ones.
    """
    t = seg.node_times
    timed = t[-1] > t[0]
    v = float(params.get("time_scale") or 0.0)
    if v > 0:
        data = np.column_stack([data, v * t])
        start = np.append(start, v * t[0])
        end = np.append(end, v * t[-1])
    fit = fit_force_elastic_map(
        data,
        n_nodes=len(data),
        lam=float(params["lam"]),
        mu=float(params["mu"]),
        constraints=Constraints(start=start, end=end),
        times=t if timed else None,
        orientations=seg.orientations,
        max_iter=50,
    )
    # the re-solve's time law runs from 0 over the stored span; keep the segment's own offset
    times = t[0] + fit.node_times if timed else t
    return replace(seg, nodes=fit.nodes[:, :3], node_times=times, orientations=fit.orientations)


def place_skill(
    skill: FittedSkill,
    *,
    robot_pose: Array | None,
    object_pose: Mapping[str, Array],
    params_for: Callable[[int], Mapping[str, float]],
    resolve: bool = True,
) -> Reproduction:
    """The skill placed in a scene (see the module docstring).

    robot_pose: (7,) current end-effector pose [x y z qw qx qy qz] (None: keep the stored start);
    object_pose: {object name: (7,) pose} for every anchor of the skill (anchored segments are
    stored in their object's frame; pass the demonstration's object poses to replay the demo);
    params_for(s): the segment's elastic-map parameters (``lam``, ``mu`` are used);
    resolve: re-solve free segments with the elastic map (False: the blended displacement only).
    """
    segs = list(skill.segments)
    S = len(segs)
    base: list[SegmentMaps] = []
    for s, seg in enumerate(segs):
        if seg.anchor:
            if seg.anchor not in object_pose:
                raise ValueError(
                    f"segment {s} is anchored to object {seg.anchor!r}, but the scene has no pose for it "
                    f"(objects: {sorted(object_pose)})"
                )
            nodes, quats = from_object_frame(
                np.asarray(object_pose[seg.anchor], float), seg.nodes, seg.orientations
            )
            base.append(replace(seg, nodes=nodes, orientations=quats))
        else:
            base.append(seg)

    # boundary points b_0..b_S (None where not fixed by the robot or an anchored neighbour)
    known: list[Array | None] = [None] * (S + 1)
    demo_point = [base[s].nodes[0] for s in range(S)] + [base[-1].nodes[-1]]
    known[0] = np.asarray(robot_pose[:3], float) if robot_pose is not None else base[0].nodes[0].copy()
    for s in range(1, S):
        if base[s].anchor:
            known[s] = base[s].nodes[0]
        elif base[s - 1].anchor:
            known[s] = base[s - 1].nodes[-1]
    if base[-1].anchor:
        known[S] = base[-1].nodes[-1]
    starts = np.concatenate([[0.0], np.cumsum([s.duration for s in base])])
    have = [i for i in range(S + 1) if known[i] is not None]
    disp = np.array([known[i] - demo_point[i] for i in have])
    points = []
    for i in range(S + 1):
        if known[i] is not None:
            points.append(known[i])
        else:  # displacement interpolated in time between the fixed boundaries, held after the last
            d = np.array([np.interp(starts[i], starts[have], disp[:, q]) for q in range(3)])
            points.append(demo_point[i] + d)

    placed = []
    for s, seg in enumerate(base):
        # consecutive segments anchored to the same object keep their fitted relation (rigid together)
        same_before = s > 0 and seg.anchor and base[s - 1].anchor == seg.anchor
        same_after = s < S - 1 and seg.anchor and base[s + 1].anchor == seg.anchor
        d0 = np.zeros(3) if same_before else points[s] - seg.nodes[0]
        d1 = np.zeros(3) if same_after else points[s + 1] - seg.nodes[-1]
        moved = max(np.abs(d0).max(), np.abs(d1).max()) > 0.0
        out = seg
        if moved:
            data = _blend(seg, d0, d1)
            if seg.anchor or not resolve:
                out = replace(seg, nodes=data)
            else:
                out = _resolve(seg, data, data[0], data[-1], params_for(s))
        if s == 0 and robot_pose is not None:
            out = replace(out, orientations=_blend_start_orientation(out, np.asarray(robot_pose[3:7], float)))
        placed.append(out)
    return Reproduction(tuple(placed))


def _blend_start_orientation(seg: SegmentMaps, q_start: Array) -> Array:
    """Orientations rotated by ``(1-u)`` of the rotation from the first node's to ``q_start``."""
    q0 = seg.orientations[0]
    q_start = quat_normalize(q_start)
    if np.dot(q_start, q0) < 0:
        q_start = -q_start
    delta = quat_to_rotvec(quat_multiply(q_start, quat_conjugate(q0)))
    t = seg.node_times
    span = t[-1] - t[0]
    u = (t - t[0]) / span if span > 0 else np.linspace(0.0, 1.0, len(t))
    rot = rotvec_to_quat((1.0 - u)[:, None] * delta[None, :])
    return quat_normalize(quat_multiply(rot, seg.orientations))
