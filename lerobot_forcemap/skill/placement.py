"""Place a fitted skill in a new scene: re-anchor it to the robot's pose and the objects' poses.

Objects come from the environment state by name: every ``<obj>_x <obj>_y <obj>_z`` triple of
``env_state_names`` is an object position, ``<obj>_qw .. <obj>_qz`` (if present) its orientation
(w first), ``<obj>_hx <obj>_hy <obj>_hz`` (if present, with the orientation) the half extents (m) of
its bounding box in its own frame; e.g. the press task's ``button_x ... button_qz``.

An anchored segment s is stored in the frame of its object's pose at the segment's first frame in
the demonstration (``anchor_pose`` A_s); ``anchor_initial_pose`` A_0 is the object's pose at the
demonstration's first frame. At reset, with the object at P now, the object is predicted to be at
``P ∘ A_0⁻¹ ∘ A_s`` when the segment starts (:func:`predicted_anchor_poses`: its demonstrated motion
up to the segment, moved with the object; for an object at rest A_s = A_0 and this is P).

Placing (:func:`place_skill`), per segment s with stored nodes y_s:

1. Anchored segments (stored in an object's frame) are moved rigidly with the object's (predicted)
   pose at the segment's start: ``p + R y``, orientations ``q ⊗ q_s``. The force-lifted contact
   nodes keep their shape. Consecutive segments anchored to the same object keep their fitted
   relation (they move rigidly together).
2. Free segments (base frame) keep their stored path plus a displacement field d(t) over the
   skill's time (s since the start), so nothing is re-fitted and a placement in the demonstrated
   scene from the demonstrated start is the fitted path itself. d is pinned at knots and linear in
   time between them:
   - at t = 0, the robot's position minus the stored start (zero without a robot pose);
   - at each boundary between a free and an anchored segment, the gap the anchored segment's motion
     opened there (the free side moves to meet it);
   - after the last knot d is held (a free retreat after an anchored press moves with the object);
     with no anchored segment at all, the start's displacement decays linearly to zero over
     ``start_window`` seconds (when None: at ``START_BLEND_SPEED``, or its rotation at
     ``START_BLEND_TURN_RATE``, whichever takes longer): a new start deforms the path near the start
     only, since without objects the demonstrated path is where the task is.
   The free orientations get the same field as a rotation (rotation vectors, base frame): none at
   t = 0, at each free-anchored boundary the turn from the free side's orientation onto the anchored
   side's, linear in time between knots, held after the last (a free lift after an anchored grasp
   keeps the grasp's orientation: turning back would twist the object in hand).
   An anchored first segment whose start has to move to the robot gets the start displacement
   fading over ``start_window`` (None: over the segment), and an anchored segment followed by one
   anchored to another object bends its end to meet it (linearly along its time law); its contact
   nodes keep their shape otherwise. ``resolve=True`` re-solves each displaced free segment by the
   elastic map with its new endpoints as equality constraints (smoother, but it re-fits the segment
   without its force points: an ablation, not the default).
3. The orientation of segment 0 is blended from the robot's current orientation to the stored one
   (rotation vector of the difference scaled by the same fade).

Provisional segments: an anchored segment whose object the robot will still move before the
segment starts (a grasp after a push; :func:`provisional_segments`) has only a predicted pose, which
may be wrong (an unseen object does not move like the demonstration's). It is laid out like a free
segment (its demonstrated base-frame path, displaced with its neighbours) and does not fix its
neighbours' endpoints until it is re-anchored when it starts.

Re-anchoring when a segment starts (:func:`reanchor_segment`, called by the policy online): the
object's observed position minus the position the placement assumed gives a shift d; segment s and
every later segment anchored to the same object move by d (translation only: a rolled sphere's or an
unseen object's orientation says nothing about where to grasp it), and segments s.. are placed
again by the rules above with the junction, the last target of segment s − 1 (already run), as
their start: segment s starts exactly where the robot was sent and the junction fades out over
``blend_s`` seconds (then it follows the shifted, object-relative path); free segments after it are
re-solved by the elastic map with their new endpoints as equality constraints. A provisional
segment (laid out on the demonstrated path, its object moved since) can be far off, and a grasp
segment closes the gripper as it starts: it gets a lead-in instead of the blend, ``lead_in_s``
seconds in which the robot travels from the junction to the shifted start with the
gripper held (:class:`SkillRun`: at ``REANCHOR_TRAVEL_SPEED``, over the higher of the two points and
down; every later segment starts that much later), then runs the shifted path as demonstrated.
A grasp (its gripper closes) on an object lower than the demonstration's is re-anchored that much
lower (:func:`grasp_lowering`: its height above the object's centre scaled by the ratio of the
objects' vertical half extents, never raised), so that the hand closes around the object, not on top.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
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
    slerp_sequence,
)
from lerobot_forcemap.skill.model import FittedSkill, Reproduction, SegmentMaps
from lerobot_forcemap.skill.params import ArmMap, SkillParams

__all__ = [
    "ObjectSlot",
    "object_slots",
    "object_poses",
    "to_object_frame",
    "from_object_frame",
    "object_positions",
    "object_half_heights",
    "grasp_lowering",
    "object_distances",
    "compose_poses",
    "invert_pose",
    "predicted_anchor_poses",
    "provisional_segments",
    "place_skill",
    "reanchor_segment",
    "SkillRun",
    "path_distances",
    "IDENTITY_POSE",
    "START_BLEND_SPEED",
    "START_BLEND_TURN_RATE",
    "REANCHOR_TRAVEL_SPEED",
    "GRASP_CLOSING",
    "demonstrated_reproduction",
]

Array = NDArray[np.float64]
IDENTITY_POSE = np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0])
#: a new start's displacement, when no anchored segment pins the path, decays at this speed (m/s) and
#: its rotation at this rate (rad/s), whichever takes longer: the start's offset adds no more than that
#: to the demonstrated motion
START_BLEND_SPEED = 0.05
START_BLEND_TURN_RATE = 0.5
#: a provisional segment re-anchored when it starts first travels to its shifted start at this speed
#: (m/s), its gripper held, so that it closes on the object where the demonstration did
REANCHOR_TRAVEL_SPEED = 0.1
#: a segment whose gripper command rises by at least this (of 0 open .. 1 closed) is a grasp: its
#: height is scaled to the object's (:func:`grasp_lowering`); approaches and pushes keep theirs
GRASP_CLOSING = 0.3


@dataclass(frozen=True)
class ObjectSlot:
    """Where one object's pose sits in the environment state: position columns (3), quaternion columns
    (4) or None, half-extent columns (3) or None (only with a quaternion)."""

    name: str
    position: tuple[int, int, int]
    quaternion: tuple[int, int, int, int] | None
    extents: tuple[int, int, int] | None = None


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
        extents = None
        if all(f"{obj}_q{a}" in index for a in "wxyz"):
            quat = tuple(index[f"{obj}_q{a}"] for a in "wxyz")
            if all(f"{obj}_h{a}" in index for a in "xyz"):
                extents = tuple(index[f"{obj}_h{a}"] for a in "xyz")
        slots.append(ObjectSlot(obj, pos, quat, extents))
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


def object_half_heights(env_state: Array, slots: Sequence[ObjectSlot]) -> dict[str, float]:
    """``{name: half height (m)}`` from one environment-state vector ``(E,)``: the vertical (base z)
    half extent of each object's bounding box as posed now, for the objects whose state gives half
    extents (others are left out)."""
    env_state = np.asarray(env_state, dtype=np.float64).reshape(-1)
    out = {}
    for s in slots:
        if s.extents is None or s.quaternion is None or max(s.extents) >= len(env_state):
            continue
        q = env_state[list(s.quaternion)]
        if not np.linalg.norm(q) >= 1e-6:
            continue
        axes = quat_rotate(quat_normalize(q), np.eye(3))  # rows: the object's axes in the base frame
        half = float(np.abs(axes[:, 2]) @ np.abs(env_state[list(s.extents)]))
        if np.isfinite(half):
            out[s.name] = half
    return out


def grasp_lowering(seg: SegmentMaps, demo_half_height: float, half_height: float | None) -> float:
    """How far (m, >= 0) to lower anchored segment ``seg`` (stored in its object's frame) for an object
    of ``half_height`` (m, base z, now) where the demonstration's was ``demo_half_height``: when ``seg``
    is a grasp (its gripper command rises by at least ``GRASP_CLOSING``), the height above the object's
    centre (base z) at which the demonstration closed the hand (:func:`_closing_height`) times
    ``1 − half_height / demo_half_height``. A grasp copied from a taller object would close above a low
    one. Never raised; 0 for other segments, when a height is unknown (<= 0 or None) or the hand
    closed below the centre."""
    if not half_height or half_height <= 0 or demo_half_height <= 0 or half_height >= demo_half_height:
        return 0.0
    if float(seg.gripper_nodes[-1, 0] - seg.gripper_nodes[0, 0]) < GRASP_CLOSING:
        return 0.0
    return max(_closing_height(seg), 0.0) * (1.0 - half_height / demo_half_height)


def _closing_height(seg: SegmentMaps) -> float:
    """Height (m, base z) above the object's centre of anchored segment ``seg`` (stored in its object's
    frame, posed by ``anchor_pose``) when its gripper command is halfway from its first to its last
    value: where the hand closed, after any approach within the segment."""
    g = seg.gripper_nodes[:, 0]
    t = seg.gripper_node_times[int(np.argmax(g >= g[0] + 0.5 * (g[-1] - g[0])))]
    z = quat_rotate(np.asarray(seg.anchor_pose[3:], float), seg.nodes)[:, 2]
    return float(np.interp(t, seg.node_times, z))


def object_positions(env_state: Array, slot: ObjectSlot) -> Array:
    """Positions ``(T, 3)`` of one object from environment-state rows ``(T, E)``."""
    env_state = np.asarray(env_state, dtype=np.float64)
    return env_state.reshape(-1, env_state.shape[-1])[:, list(slot.position)]


def object_distances(positions: Array, env_state: Array, slot: ObjectSlot, surface: bool = True) -> Array:
    """Distance (m) ``(T,)`` of positions ``(T, 3)`` to one object in environment-state rows ``(T, E)``
    (row t for position t): with ``surface``, to its bounding box (posed by row t) when the state
    gives its half extents, else to its position. A large object's surface, not its centre, is where
    the robot meets it."""
    env_state = np.asarray(env_state, dtype=np.float64).reshape(-1, np.shape(env_state)[-1])
    offset = np.asarray(positions, dtype=np.float64) - env_state[:, list(slot.position)]
    if not surface or slot.extents is None or slot.quaternion is None:
        return np.linalg.norm(offset, axis=1)
    local = quat_rotate(quat_conjugate(env_state[:, list(slot.quaternion)]), offset)
    outside = np.maximum(np.abs(local) - np.abs(env_state[:, list(slot.extents)]), 0.0)
    return np.linalg.norm(outside, axis=1)


def compose_poses(a: Array, b: Array) -> Array:
    """Pose ``a ∘ b`` (7,): b expressed in a's frame, mapped to a's parent frame."""
    return np.concatenate([a[:3] + quat_rotate(a[3:], b[:3]), quat_normalize(quat_multiply(a[3:], b[3:]))])


def invert_pose(a: Array) -> Array:
    """Pose ``a⁻¹`` (7,)."""
    q = quat_conjugate(a[3:])
    return np.concatenate([-quat_rotate(q, a[:3]), q])


def predicted_anchor_poses(skill: FittedSkill, object_pose: Mapping[str, Array]) -> list[Array | None]:
    """Per segment: the base-frame pose (7,) its anchor object is predicted to have when the segment
    starts, ``P ∘ A_0⁻¹ ∘ A_s`` with P = ``object_pose[anchor]`` now (None for free segments)."""
    out: list[Array | None] = []
    for s, seg in enumerate(skill.segments):
        if not seg.anchor:
            out.append(None)
            continue
        if seg.anchor not in object_pose:
            raise ValueError(
                f"segment {s} is anchored to object {seg.anchor!r}, but the scene has no pose for it "
                f"(objects: {sorted(object_pose)})"
            )
        now = np.asarray(object_pose[seg.anchor], dtype=np.float64)
        motion = compose_poses(invert_pose(np.asarray(seg.anchor_initial_pose, float)), seg.anchor_pose)
        out.append(compose_poses(now, motion))
    return out


def provisional_segments(
    skill: FittedSkill, reference: Mapping[str, Array], tolerance: float, started: int = 0
) -> list[bool]:
    """Per segment: True when it is anchored, has not started (index > ``started``), and its object
    moved by more than ``tolerance`` (m) in the demonstration between ``reference[object]`` (the
    demonstrated pose (7,) at the object's last observation: ``anchor_initial_pose`` at reset, the
    ``anchor_pose`` of the segment it was last re-anchored for) and the segment's start."""
    out = []
    for s, seg in enumerate(skill.segments):
        ref = reference.get(seg.anchor) if seg.anchor else None
        out.append(
            s > started
            and ref is not None
            and float(np.linalg.norm(np.asarray(seg.anchor_pose[:3]) - np.asarray(ref)[:3])) > tolerance
        )
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


def _fade(seg: SegmentMaps, start_window: float | None) -> tuple[Array, Array]:
    """(u, fade) per node: u its fraction of the segment's time law (0 .. 1), fade = 1 − u, or with
    ``start_window`` (s) shorter than the segment a linear fade to 0 over that time."""
    t = seg.node_times
    span = t[-1] - t[0]
    u = (t - t[0]) / span if span > 0 else np.linspace(0.0, 1.0, len(t))
    fade = 1.0 - u
    if start_window is not None and start_window < span:
        fade = np.clip(1.0 - (t - t[0]) / max(start_window, 1e-9), 0.0, 1.0)
    return u, fade


def _blend(seg: SegmentMaps, d_start: Array, d_end: Array, start_window: float | None = None) -> Array:
    """Nodes displaced by ``fade d_start + u d_end`` (:func:`_fade`)."""
    u, fade = _fade(seg, start_window)
    return seg.nodes + fade[:, None] * d_start + u[:, None] * d_end


def _blend_start_orientation(seg: SegmentMaps, q_start: Array, start_window: float | None = None) -> Array:
    """Orientations rotated by ``fade`` of the rotation from the first node's to ``q_start`` (:func:`_fade`)."""
    q0 = seg.orientations[0]
    q_start = quat_normalize(q_start)
    if np.dot(q_start, q0) < 0:
        q_start = -q_start
    delta = quat_to_rotvec(quat_multiply(q_start, quat_conjugate(q0)))
    _, fade = _fade(seg, start_window)
    rot = rotvec_to_quat(fade[:, None] * delta[None, :])
    return quat_normalize(quat_multiply(rot, seg.orientations))


def _resolve(seg: SegmentMaps, data: Array, start: Array, end: Array, arm: ArmMap) -> SegmentMaps:
    """Re-solve a free segment against ``data (N, 3)`` (its displaced nodes) with start/end equalities.

    With ``arm.time_scale = v > 0`` the re-solve is in space-time like the fit: the node times
    scaled by v are a 4th coordinate whose ends are constrained to the stored ones.
    """
    t = seg.node_times
    timed = t[-1] > t[0]
    v = float(arm.time_scale or 0.0)
    if v > 0:
        data = np.column_stack([data, v * t])
        start = np.append(start, v * t[0])
        end = np.append(end, v * t[-1])
    fit = fit_force_elastic_map(
        data,
        n_nodes=len(data),
        lam=float(arm.lam),
        mu=float(arm.mu),
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
    params: SkillParams,
    *,
    robot_pose: Array | None,
    object_pose: Mapping[str, Array] | None = None,
    resolve: bool = False,
    anchor_poses: Sequence[Array | None] | None = None,
    start_window: float | None = None,
    provisional: Sequence[bool] | None = None,
) -> Reproduction:
    """The skill placed in a scene (see the module docstring).

    params: the settings the skill was fitted with (``resolve`` uses each segment's ``lam``, ``mu``,
    ``time_scale``);
    robot_pose: (7,) current end-effector pose [x y z qw qx qy qz] (None: keep the stored start);
    object_pose: {object name: (7,) pose now} for every anchor of the skill (pass
    ``skill.demo_object_poses()`` to replay the demonstration's scene);
    resolve: re-solve displaced free segments with the elastic map (default False: the displacement
    field only);
    anchor_poses: per segment the base-frame anchor pose at its start (7,) (None for free segments),
    instead of the prediction from ``object_pose`` (:func:`predicted_anchor_poses`);
    start_window: seconds over which the start displacement (robot pose vs stored start) decays:
    for an anchored first segment (None: over the segment), and for a skill without anchored
    segments (None: at ``START_BLEND_SPEED`` / ``START_BLEND_TURN_RATE``);
    provisional: per segment, True for an anchored segment whose object the robot will still move
    before the segment starts (:func:`provisional_segments`): its predicted pose is a guess, so it
    does not fix its neighbours' endpoints; it is laid out like a free segment (its demonstrated
    base-frame path, displaced with its neighbours) until it is re-anchored when it starts.
    Each placed anchored segment keeps the pose it was placed with (or will be re-anchored from, when
    provisional) as its ``anchor_pose``.
    """
    arms = [params.segment(s).arm for s in range(skill.n_segments)]
    if anchor_poses is None:
        anchor_poses = predicted_anchor_poses(skill, object_pose or {})
    return _place(skill.segments, arms, robot_pose, anchor_poses, resolve, start_window, provisional)


def _place(
    segs: Sequence[SegmentMaps],
    arms: Sequence[ArmMap],
    robot_pose: Array | None,
    anchor_poses: Sequence[Array | None],
    resolve: bool,
    start_window: float | None,
    provisional: Sequence[bool] | None,
) -> Reproduction:
    """:func:`place_skill` of the segments ``segs`` with their arm-map parameters ``arms``."""
    S = len(segs)
    if len(anchor_poses) != S:
        raise ValueError(f"anchor_poses: {len(anchor_poses)} entries for {S} segments")
    prov = [False] * S if provisional is None else [bool(p) for p in provisional]
    if len(prov) != S:
        raise ValueError(f"provisional: {len(prov)} entries for {S} segments")
    base = _in_base_frame(segs, anchor_poses, prov)
    fixed = [bool(seg.anchor) and not prov[s] for s, seg in enumerate(base)]
    starts = np.concatenate([[0.0], np.cumsum([seg.duration for seg in base])])
    knot_t, knot_d = _free_knots(base, fixed, robot_pose, starts)
    turn_t, turn_r = _free_turn_knots(base, fixed, starts)
    decay = start_window
    if not any(fixed):  # no anchored segment pins the path: a new start's displacement decays
        decay = start_window if start_window is not None else _start_blend_s(base[0], robot_pose)
        knot_t, knot_d = np.array([0.0, max(decay, 1e-9)]), np.stack([knot_d[0], np.zeros(3)])
    placed = []
    for s, seg in enumerate(base):
        if fixed[s]:
            out = _place_anchored(base, fixed, s, robot_pose, start_window)
        else:
            u, _ = _fade(seg, None)  # the first node stands for the segment's start, the last for its end
            t = starts[s] + u * seg.duration
            shift = _at(knot_t, knot_d, t)
            turned = quat_multiply(rotvec_to_quat(_at(turn_t, turn_r, t)), seg.orientations)
            out = replace(seg, nodes=seg.nodes + shift, orientations=quat_normalize(turned))
            if resolve and np.abs(shift).max() > 0.0:
                out = _resolve(out, out.nodes, out.nodes[0], out.nodes[-1], arms[s])
        if s == 0 and robot_pose is not None:
            q_robot = np.asarray(robot_pose[3:7], float)
            out = replace(out, orientations=_blend_start_orientation(out, q_robot, decay))
        placed.append(out)
    return Reproduction(tuple(placed))


def _start_blend_s(first: SegmentMaps, robot_pose: Array | None) -> float:
    """Seconds for the robot's offset from the stored start to decay at ``START_BLEND_SPEED`` (and its
    rotation at ``START_BLEND_TURN_RATE``)."""
    if robot_pose is None:
        return 0.0
    offset = float(np.linalg.norm(np.asarray(robot_pose[:3], float) - first.nodes[0]))
    angle = float(
        np.linalg.norm(
            quat_to_rotvec(
                quat_multiply(quat_normalize(robot_pose[3:7]), quat_conjugate(first.orientations[0]))
            )
        )
    )
    return max(offset / START_BLEND_SPEED, angle / START_BLEND_TURN_RATE)


def _free_knots(
    base: list[SegmentMaps], fixed: list[bool], robot_pose: Array | None, starts: Array
) -> tuple[Array, Array]:
    """Knots (times (K,) s, displacements (K, 3) m) of the free segments' displacement field: the
    robot's start (when segment 0 is free) and the gaps at every free-anchored boundary."""
    times, values = [], []
    if not fixed[0]:
        robot = base[0].nodes[0] if robot_pose is None else np.asarray(robot_pose[:3], float)
        times.append(0.0)
        values.append(robot - base[0].nodes[0])
    for s in range(1, len(base)):
        if fixed[s] != fixed[s - 1]:  # the free side moves to meet the anchored one
            gap = base[s].nodes[0] - base[s - 1].nodes[-1]
            times.append(float(starts[s]))
            values.append(gap if fixed[s] else -gap)
    if not times:
        return np.zeros(0), np.zeros((0, 3))
    return np.asarray(times), np.stack(values)


def _free_turn_knots(base: list[SegmentMaps], fixed: list[bool], starts: Array) -> tuple[Array, Array]:
    """Knots (times (K,) s, rotation vectors (K, 3) rad, base frame) of the free segments' rotation
    field, the orientation counterpart of :func:`_free_knots`: zero at the start when segment 0 is
    free (its orientation is blended to the robot's on its own), and at every free-anchored boundary
    the turn that takes the free side's orientation there onto the anchored side's. A hand that leaves
    an object-anchored grasp keeps the grasp's orientation instead of turning back to the
    demonstrated one with the object in hand."""
    times, values = [], []
    if not fixed[0]:
        times.append(0.0)
        values.append(np.zeros(3))
    for s in range(1, len(base)):
        if fixed[s] != fixed[s - 1]:
            free, anchored = base[s - 1].orientations[-1], base[s].orientations[0]
            if not fixed[s]:
                free, anchored = base[s].orientations[0], base[s - 1].orientations[-1]
            times.append(float(starts[s]))
            values.append(quat_to_rotvec(quat_multiply(anchored, quat_conjugate(free))))
    if not times:
        return np.zeros(0), np.zeros((0, 3))
    return np.asarray(times), np.stack(values)


def _at(knot_t: Array, knot_d: Array, t: Array) -> Array:
    """The displacement field (N, 3) at times ``t (N,)``: linear between knots, held outside them."""
    if not len(knot_t):
        return np.zeros((len(t), 3))
    return np.stack([np.interp(t, knot_t, knot_d[:, q]) for q in range(3)], axis=1)


def _place_anchored(
    base: list[SegmentMaps], fixed: list[bool], s: int, robot_pose: Array | None, start_window: float | None
) -> SegmentMaps:
    """Anchored segment ``s`` as moved with its object; if it is the first segment its start moves to the
    robot (fading over ``start_window``), and if the next segment is anchored to another object its end
    bends to meet it."""
    seg, S = base[s], len(base)
    d0 = np.zeros(3)
    if s == 0 and robot_pose is not None:
        d0 = np.asarray(robot_pose[:3], float) - seg.nodes[0]
    d1 = np.zeros(3)
    if s < S - 1 and fixed[s + 1] and base[s + 1].anchor != seg.anchor:
        d1 = base[s + 1].nodes[0] - seg.nodes[-1]
    if max(np.abs(d0).max(), np.abs(d1).max()) == 0.0:
        return seg
    return replace(seg, nodes=_blend(seg, d0, d1, start_window if s == 0 else None))


def _in_base_frame(
    segs: Sequence[SegmentMaps], anchor_poses: Sequence[Array | None], prov: list[bool]
) -> list[SegmentMaps]:
    """Anchored segments moved rigidly to their anchor pose (a provisional one to its demonstrated
    pose); each keeps the pose it was placed with, or will be re-anchored from, as ``anchor_pose``."""
    base: list[SegmentMaps] = []
    for s, seg in enumerate(segs):
        if not seg.anchor:
            base.append(seg)
            continue
        if anchor_poses[s] is None:
            raise ValueError(f"anchor_poses[{s}]: segment {s} is anchored to {seg.anchor!r} but has no pose")
        pose = np.asarray(anchor_poses[s], dtype=np.float64)
        frame = np.asarray(seg.anchor_pose, dtype=np.float64) if prov[s] else pose
        nodes, quats = from_object_frame(frame, seg.nodes, seg.orientations)
        base.append(replace(seg, nodes=nodes, orientations=quats, anchor_pose=pose))
    return base


def demonstrated_reproduction(skill: FittedSkill) -> Reproduction:
    """The skill in the scene it was demonstrated in: anchored segments at their stored anchor poses,
    free segments as stored, the stored start (what a placement from the demonstration's own start
    and scene gives)."""
    poses = [np.asarray(seg.anchor_pose, float) if seg.anchor else None for seg in skill.segments]
    return Reproduction(tuple(_in_base_frame(skill.segments, poses, [False] * skill.n_segments)))


def reanchor_segment(
    rep: Reproduction,
    skill: FittedSkill,
    s: int,
    position: Array,
    params: SkillParams,
    *,
    resolve: bool = True,
    blend_s: float | None = None,
    provisional: Sequence[bool] | None = None,
    lead_in_s: float = 0.0,
    lead_in_speed: float = 0.0,
) -> Reproduction:
    """``rep`` with segment ``s`` (anchored) re-anchored to its object's observed ``position (3,)``
    when it starts (module docstring). Segments before s are kept; ``skill`` is the fitted skill that
    ``rep`` places (its segments in their objects' frames). ``blend_s``: the junction (the last target
    of segment s − 1 vs the shifted start of s) fades out over this many seconds of segment s
    (None: over the whole segment); provisional: per segment of the skill, as in :func:`place_skill`
    (for the segments after s; segment s itself is observed now); ``lead_in_s`` > 0 (or, when 0,
    ``lead_in_speed`` > 0 m/s along its path): instead of the blend, segment s first travels from the
    junction to its shifted start in this many seconds (:func:`_lead_in_path`, the orientation
    SLERPed, the gripper held), which delays every later segment."""
    if not 0 < s < len(skill.segments):
        raise ValueError(f"reanchor_segment: segment {s} out of range 1..{len(skill.segments) - 1}")
    obj = skill.segments[s].anchor
    if not obj:
        raise ValueError(f"reanchor_segment: segment {s} is not anchored to an object")
    placed = rep.segments
    shift = np.asarray(position, dtype=np.float64).reshape(3) - placed[s].anchor_pose[:3]
    poses: list[Array | None] = []
    for k in range(s, len(placed)):
        anchor = skill.segments[k].anchor
        if not anchor:
            poses.append(None)
            continue
        pose = np.asarray(placed[k].anchor_pose, dtype=np.float64).copy()
        if anchor == obj:
            pose[:3] += shift
        poses.append(pose)
    prev = placed[s - 1]
    junction = np.concatenate([prev.nodes[-1], prev.orientations[-1]])
    lead = lead_in_s > 0 or lead_in_speed > 0
    rest = _place(
        skill.segments[s:],
        [params.segment(k).arm for k in range(s, skill.n_segments)],
        None if lead else junction,
        poses,
        resolve,
        blend_s,
        None if provisional is None else [False, *list(provisional)[s + 1 :]],
    ).segments
    if lead:
        rest = (_with_lead_in(rest[0], prev, lead_in_s, lead_in_speed), *rest[1:])
    return Reproduction((*placed[:s], *rest))


def _lead_in_path(a: Array, b: Array) -> Array:
    """Waypoints ``(K, 3)`` from ``a (3,)`` to ``b (3,)`` (base frame, z up): up (or down) to the
    higher of their heights, across, then down to b; legs of zero length left out. The hand never
    sweeps sideways below where it was or where it is going (into the object it is about to grasp)."""
    top = max(a[2], b[2])
    pts = np.array([a, [a[0], a[1], top], [b[0], b[1], top], b], dtype=np.float64)
    keep = np.concatenate([np.linalg.norm(np.diff(pts, axis=0), axis=1) > 1e-9, [True]])
    return pts[keep]


def _with_lead_in(seg: SegmentMaps, prev: SegmentMaps, lead_in_s: float, speed: float) -> SegmentMaps:
    """``seg`` preceded by a lead-in from the last target of ``prev`` to ``seg``'s first node along
    :func:`_lead_in_path`, taking ``lead_in_s`` seconds (0: its length at ``speed``), times spread
    by length; the orientation SLERPs from ``prev``'s last to ``seg``'s first, the gripper holds
    ``prev``'s last value."""
    path = _lead_in_path(prev.nodes[-1], seg.nodes[0])
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(path, axis=0), axis=1))])
    span = lead_in_s if lead_in_s > 0 else arc[-1] / speed
    frac = arc[:-1] / arc[-1] if arc[-1] > 0 else np.zeros(len(arc) - 1)
    quats = slerp_sequence([0.0, 1.0], np.stack([prev.orientations[-1], seg.orientations[0]]), frac)
    return replace(
        seg,
        nodes=np.vstack([path[:-1], seg.nodes]),
        node_times=np.concatenate([span * frac, seg.node_times + span]),
        orientations=np.vstack([quats, seg.orientations]),
        gripper_nodes=np.vstack([prev.gripper_nodes[-1], seg.gripper_nodes]),
        gripper_node_times=np.concatenate([[0.0], seg.gripper_node_times + span]),
        duration=seg.duration + span,
    )


class SkillRun:
    """One episode of a fitted skill acted out in a batch of scenes, one placement per batch row.

    Placed at the start (:meth:`start`) from each row's robot pose and object poses; while it runs,
    each object-anchored segment is re-anchored when it starts (``online``) to its object's position
    observed then (:meth:`due`, :meth:`reanchor`). ``log`` lists every re-anchoring: segment, batch
    row, time (s since the start), shift (m) and lead-in (s; 0 unless the segment was provisional).
    """

    def __init__(
        self,
        skill: FittedSkill,
        params: SkillParams,
        placed: list[Reproduction],
        provisional: list[bool],
        *,
        online: bool,
        tolerance: float,
        blend_s: float | None,
    ):
        self.skill, self.params, self.placed = skill, params, placed
        self.provisional = provisional
        self.online, self.tolerance, self.blend_s = online, tolerance, blend_s
        self.next_segment = 1  # the next segment whose start may re-anchor it (segment 0: at the start)
        # per object: its demonstrated pose (7,) at its last observation (the start, or a re-anchoring)
        self.observed_as: dict[str, Array] = skill.demo_object_poses()
        self.log: list[dict] = []

    @classmethod
    def start(
        cls,
        skill: FittedSkill,
        params: SkillParams,
        robot_poses: Array | None,
        object_poses: Sequence[Mapping[str, Array]],
        *,
        online: bool,
        tolerance: float = 0.0,
        blend_s: float | None = None,
        robot_name: str = "robot_poses",
    ) -> SkillRun:
        """Place the skill in each row's scene: ``robot_poses (n, 7)`` (None: the stored start; a zero
        quaternion or another width is refused, naming ``robot_name``) and ``object_poses[i]``
        ``{object: (7,)}``. ``online``: re-anchor segments when they start, and until then lay out those
        whose object moves before them as provisional; ``tolerance`` (m): shifts at most this are
        ignored; ``blend_s``: see :func:`reanchor_segment`."""
        if robot_poses is not None:
            _check_robot_poses(robot_name, robot_poses)
        demo = skill.demo_object_poses()
        provisional = (
            provisional_segments(skill, demo, params.anchoring.static_tolerance)
            if online
            else [False] * skill.n_segments
        )
        placed = [
            place_skill(
                skill,
                params,
                robot_pose=None if robot_poses is None else robot_poses[i, :7],
                object_pose=poses,
                provisional=provisional,
            )
            for i, poses in enumerate(object_poses)
        ]
        return cls(skill, params, placed, provisional, online=online, tolerance=tolerance, blend_s=blend_s)

    def actions_at(self, times: Array) -> Array:
        """Targets ``(n, K, 8)`` of every row at ``times (K,)`` (s since the start)."""
        return np.stack([rep.actions_at(times) for rep in self.placed])

    def due(self, t: float) -> list[int]:
        """The anchored segments that started by ``t`` and were not re-anchored yet; segments with
        nothing to re-anchor are passed over here."""
        current = self.placed[0].segment_at(t)
        if not self.online or self.next_segment > current:
            return []
        started = [s for s in range(self.next_segment, current + 1) if self.skill.segments[s].anchor]
        if not started:
            self.next_segment = current + 1
        return started

    def reanchor(
        self,
        t: float,
        object_poses: Sequence[Mapping[str, Array]],
        half_heights: Sequence[Mapping[str, float]] | None = None,
    ) -> None:
        """Re-anchor the segments :meth:`due` at ``t`` to the objects observed now (``{object: (7,)}``
        per row); call it once the observation has been read. ``half_heights``: per row the objects'
        vertical half extents now (``{object: m}``, :func:`object_half_heights`): a segment whose object
        is lower than the demonstration's is lowered by :func:`grasp_lowering` (None: never)."""
        started = self.due(t)
        if not started:
            return
        self.next_segment = self.placed[0].segment_at(t) + 1
        for s in started:
            was_provisional = self.provisional[s]
            obj = self.skill.segments[s].anchor
            self.observed_as[obj] = np.asarray(self.skill.segments[s].anchor_pose, dtype=np.float64)
            self.provisional = provisional_segments(
                self.skill, self.observed_as, self.params.anchoring.static_tolerance, started=s
            )
            targets = [
                self._target(s, i, poses[obj][:3], half_heights) for i, poses in enumerate(object_poses)
            ]
            if was_provisional:
                self._lead_in(s, t, targets)
                continue
            for i, position in enumerate(targets):
                shift = position - self.placed[i].segments[s].anchor_pose[:3]
                if float(np.linalg.norm(shift)) <= self.tolerance:
                    continue
                self.placed[i] = reanchor_segment(
                    self.placed[i],
                    self.skill,
                    s,
                    position,
                    self.params,
                    blend_s=self.blend_s,
                    provisional=self.provisional,
                )
                self._note(s, i, t, shift, 0.0)

    def _target(
        self, s: int, row: int, position: Array, half_heights: Sequence[Mapping[str, float]] | None
    ) -> Array:
        """Where segment ``s`` of ``row`` is re-anchored: the object's observed ``position (3,)``,
        lowered for a lower object than the demonstration's (:func:`grasp_lowering`)."""
        position = np.asarray(position, dtype=np.float64).copy()
        if half_heights is not None:
            seg = self.skill.segments[s]
            position[2] -= grasp_lowering(seg, seg.anchor_half_height, half_heights[row].get(seg.anchor))
        return position

    def _lead_in(self, s: int, t: float, positions: Sequence[Array]) -> None:
        """Re-anchor provisional segment ``s`` of every row with a lead-in at
        ``REANCHOR_TRAVEL_SPEED``; the longest row's time for all, so the rows' segments keep
        starting together."""
        shifts = [
            np.asarray(p, float) - rep.segments[s].anchor_pose[:3]
            for p, rep in zip(positions, self.placed, strict=True)
        ]

        def again(i: int, **lead) -> Reproduction:
            return reanchor_segment(
                self.placed[i], self.skill, s, positions[i], self.params, provisional=self.provisional, **lead
            )

        placed = [again(i, lead_in_speed=REANCHOR_TRAVEL_SPEED) for i in range(len(positions))]
        spans = [rep.segments[s].duration - self.skill.segments[s].duration for rep in placed]
        span = float(max(spans))
        for i, rep in enumerate(placed):
            self.placed[i] = rep if spans[i] == span else again(i, lead_in_s=span)
            self._note(s, i, t, shifts[i], span)

    def _note(self, s: int, row: int, t: float, shift: Array, lead_in: float) -> None:
        self.log.append(
            {
                "segment": s,
                "row": row,
                "t": float(t),
                "shift": [float(v) for v in shift],
                "lead_in_s": lead_in,
            }
        )


def _check_robot_poses(name: str, poses: Array) -> None:
    """``poses (n, 7)`` are ``[x y z qw qx qy qz]`` rows whose quaternions carry an orientation (norm
    >= 1e-6, as the env's action check)."""
    if poses.shape[1] != 7:
        raise ValueError(f"{name}: needs [x y z qw qx qy qz], got width {poses.shape[1]}")
    if np.any(zero := np.linalg.norm(poses[:, 3:7], axis=1) < 1e-6):
        raise ValueError(f"{name}: zero quaternion (qw qx qy qz) at batch row {int(np.argmax(zero))}")


def path_distances(
    skill: FittedSkill, params: SkillParams, targets: Array, object_poses: Sequence[Mapping[str, Array]]
) -> Array:
    """Distance (m) of each target position ``targets (n, 3)`` to the skill's path placed in its own
    scene ``object_poses[i]`` (the stored start, no robot pose): ``(n,)``."""
    dist = np.empty(len(targets))
    for i, x in enumerate(targets):
        path = place_skill(skill, params, robot_pose=None, object_pose=object_poses[i]).path()
        dist[i] = float(np.min(np.linalg.norm(path - x, axis=1)))
    return dist
