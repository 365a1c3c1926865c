"""Where consecutive segment maps meet, and where the skill starts and ends (pure NumPy).

An elastic map's end node is the mean of a cluster of samples on one side of it only, so it lags the
segment's boundary in space and time: two maps fitted apart do not meet (on the UR5e recordings by
2-30 mm), and a reproduction that holds a map's first node from the segment's start until that node's
time, then hurries on, steps far faster than the demonstration did. So, after the fit:

- at each boundary between segments a and b, a node at the boundary's time is added to both maps: the
  point on the line from a's last node to b's first node where the boundary falls in time (arm
  position, orientation by SLERP, gripper). The maps share it, so the skill has no jump there and runs
  through it at the demonstrated pace; each map's own nodes, force-lifted ones included, stay as
  fitted;
- the skill's first segment gets a node at time 0 at the demonstrated first sample, its last segment
  one at its duration at the demonstrated last sample (means over the episodes).

An end node within ``merge_s`` (a frame) of the boundary's time is replaced by the new node
instead of getting a neighbour that close: between the two the reproduction would cover the end lag of
the fit within a frame (a recording that starts while moving at 0.5 m/s would step 1.5 times its own
largest step there).

Junctions are computed in the demonstrated scene (each segment at its stored ``anchor_pose``, the first
episode's) and stored in each segment's own frame.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap.geometry import slerp
from lerobot_forcemap.skill.model import SegmentMaps
from lerobot_forcemap.skill.placement import from_object_frame, to_object_frame

__all__ = ["SegmentEnds", "join_segments"]

Array = NDArray[np.float64]
#: time (s) below which two node times are the same
TIME_EPS = 1e-9


@dataclass(frozen=True)
class SegmentEnds:
    """A segment's demonstrated first and last sample in its own frame (means over the episodes):
    positions (2, 3) m, orientations (2, 4) w first, gripper (2, 1)."""

    positions: Array
    orientations: Array
    gripper: Array


def join_segments(
    segments: Sequence[SegmentMaps],
    first: SegmentEnds | None = None,
    last: SegmentEnds | None = None,
    *,
    merge_s: float = TIME_EPS,
) -> tuple[SegmentMaps, ...]:
    """The segments with consecutive maps joined (module docstring); ``first`` / ``last``: the ends of
    the first / last segment to start / end the skill at (None: as fitted); ``merge_s`` (s): an end node
    within this of a boundary is replaced by its node."""
    out = list(segments)
    for s in range(1, len(out)):
        out[s - 1], out[s] = _joined(out[s - 1], out[s], merge_s)
    if first is not None:
        out[0] = _with_node(
            out[0], 0, (first.positions[0], first.orientations[0], first.gripper[0]), 0.0, merge_s
        )
    if last is not None:
        end = (last.positions[1], last.orientations[1], last.gripper[1])
        out[-1] = _with_node(out[-1], -1, end, out[-1].duration, merge_s)
    return tuple(out)


def _joined(a: SegmentMaps, b: SegmentMaps, merge_s: float) -> tuple[SegmentMaps, SegmentMaps]:
    """Segments a and b sharing a node at their boundary."""
    w = _fraction(a.duration - a.node_times[-1], b.node_times[0])
    pa, qa = _in_scene(a, a.nodes[-1:], a.orientations[-1:])
    pb, qb = _in_scene(b, b.nodes[:1], b.orientations[:1])
    point, quat = pa + w * (pb - pa), slerp(qa[0], qb[0], w)[None, :]
    wg = _fraction(a.duration - a.gripper_node_times[-1], b.gripper_node_times[0])
    grip = a.gripper_nodes[-1] + wg * (b.gripper_nodes[0] - a.gripper_nodes[-1])
    (pa, qa), (pb, qb) = _from_scene(a, point, quat), _from_scene(b, point, quat)
    return (
        _with_node(a, -1, (pa[0], qa[0], grip), a.duration, merge_s),
        _with_node(b, 0, (pb[0], qb[0], grip), 0.0, merge_s),
    )


def _fraction(before: float, after: float) -> float:
    """Where the boundary lies between a node ``before`` s ahead of it and one ``after`` s after it."""
    total = before + after
    return before / total if total > 0 else 0.5


def _in_scene(seg: SegmentMaps, nodes: Array, quats: Array) -> tuple[Array, Array]:
    """Nodes (N, 3) and orientations (N, 4) of ``seg`` in the base frame of the demonstrated scene."""
    if not seg.anchor:
        return nodes, quats
    return from_object_frame(np.asarray(seg.anchor_pose, float), nodes, quats)


def _from_scene(seg: SegmentMaps, nodes: Array, quats: Array) -> tuple[Array, Array]:
    """Inverse of :func:`_in_scene`."""
    if not seg.anchor:
        return nodes, quats
    p, _, q = to_object_frame(np.asarray(seg.anchor_pose, float), nodes, quats=quats)
    return p, q


def _with_node(
    seg: SegmentMaps, i: int, values: tuple[Array, Array, Array], t: float, merge_s: float
) -> SegmentMaps:
    """``seg`` with a node at time ``t`` at its start (``i = 0``) or end (``i = -1``): ``values`` = the
    arm map's position (3,) and orientation (4,), the gripper map's value (1,)."""
    node, quat, grip = values
    arm = [(seg.nodes, node), (seg.orientations, quat)]
    times, (nodes, quats) = _end_node(seg.node_times, i, t, arm, merge_s)
    gtimes, (gnodes,) = _end_node(seg.gripper_node_times, i, t, [(seg.gripper_nodes, grip)], merge_s)
    return replace(
        seg,
        nodes=nodes,
        orientations=quats,
        node_times=times,
        gripper_nodes=gnodes,
        gripper_node_times=gtimes,
    )


def _end_node(
    times: Array, i: int, t: float, columns: list[tuple[Array, Array]], merge_s: float
) -> tuple[Array, list[Array]]:
    """``times (N,)`` and each ``(values (N, k), new (k,))`` with the node at end ``i`` set to ``new`` at
    time ``t``: replaced when it is within ``merge_s`` of ``t`` (and its neighbour is not), else added."""
    neighbour = times[1] if i == 0 else times[-2]
    near = merge_s + TIME_EPS
    if abs(float(times[i]) - t) <= near and abs(float(neighbour) - t) > near:
        out = [values.copy() for values, _ in columns]
        for values, (_, new) in zip(out, columns, strict=True):
            values[i] = new
        times = times.copy()
        times[i] = t
        return times, out
    if i == 0:
        return np.concatenate([[t], times]), [np.concatenate([new[None], v]) for v, new in columns]
    return np.concatenate([times, [t]]), [np.concatenate([v, new[None]]) for v, new in columns]
