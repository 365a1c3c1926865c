"""The fitted skill (what a checkpoint holds) and its anchored reproduction (what an episode runs).

Pure NumPy. A :class:`FittedSkill` is a sequence of segments; segment s has an arm map
(``nodes (N_s, 3)``, ``node_times (N_s,)`` in seconds from the segment start, ``orientations (N_s, 4)``
w first) and a gripper map (``gripper_nodes (G_s, 1)``, ``gripper_node_times (G_s,)``), a duration,
and an anchor: ``""`` (nodes in the robot base frame) or an object name (nodes in that object's
frame at the segment's start). The arrays of all segments are stored concatenated (``segment_n_nodes``
splits them), which is also how the policy keeps them as buffers.

A :class:`Reproduction` is the skill placed in one scene (base frame, every segment's nodes final):
``actions_at(t)`` gives the ``[x y z qw qx qy qz gripper]`` targets at times t (s since reset).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap import layout
from lerobot_forcemap.geometry import slerp_sequence

__all__ = ["SegmentMaps", "FittedSkill", "Reproduction", "check_flat_arrays", "MAX_MAGNITUDE"]

Array = NDArray[np.float64]
#: the largest magnitude of a fitted value (m, s, gripper units): a skill lives within a robot's reach
#: and an episode's time; beyond it the arrays are corrupt (and squared distances would overflow)
MAX_MAGNITUDE = 1e6


@dataclass(frozen=True)
class SegmentMaps:
    """One segment: arm map nodes (N, 3), node_times (N,), orientations (N, 4); gripper map
    gripper_nodes (G, 1), gripper_node_times (G,); duration (s); anchor ("" or an object name).

    anchor_pose (7,): the anchor object's pose at the segment's first frame in the (first)
    demonstration: the frame the nodes are stored in (identity when free). In a placed segment
    (:class:`Reproduction`) it is the object's base-frame pose the placement assumed at the segment's
    start, which the policy compares with the observed pose when the segment starts.
    anchor_initial_pose (7,): the anchor object's pose at the demonstration's first frame (identity
    when free). The two differ when the object moved before the segment (pushed, flipped); the pair
    predicts at reset where the object will be when the segment starts, and rebuilds the
    demonstration's scene for plots and the replay ablation.
    anchor_half_height (m): the anchor object's vertical (base z) bounding-box half extent at
    ``anchor_pose`` in the demonstration, which scales the grasp height for another object
    (``placement.grasp_lowering``); 0: unknown (free segments, objects without extents, old
    checkpoints). Kept in the policy config, not among the tensors."""

    nodes: Array
    node_times: Array
    orientations: Array
    gripper_nodes: Array
    gripper_node_times: Array
    duration: float
    anchor: str = ""
    anchor_pose: Array = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]))
    anchor_initial_pose: Array = field(default_factory=lambda: np.array([0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0]))
    anchor_half_height: float = 0.0


@dataclass(frozen=True)
class FittedSkill:
    """All segments of a fitted demonstration, in order."""

    segments: tuple[SegmentMaps, ...]

    def __post_init__(self) -> None:
        if not self.segments:
            raise ValueError("FittedSkill: at least one segment is needed")
        for s, seg in enumerate(self.segments):
            n, g = len(seg.nodes), len(seg.gripper_nodes)
            checks = {
                "nodes": (seg.nodes.shape, (n, 3)),
                "node_times": (seg.node_times.shape, (n,)),
                "orientations": (seg.orientations.shape, (n, 4)),
                "gripper_nodes": (seg.gripper_nodes.shape, (g, 1)),
                "gripper_node_times": (seg.gripper_node_times.shape, (g,)),
                "anchor_pose": (np.shape(seg.anchor_pose), (7,)),
                "anchor_initial_pose": (np.shape(seg.anchor_initial_pose), (7,)),
            }
            for name, (got, want) in checks.items():
                if got != want:
                    raise ValueError(f"segment {s}: {name} has shape {got}, expected {want}")
            if n < 2 or g < 2:
                raise ValueError(f"segment {s}: needs >= 2 arm and gripper nodes, got {n} and {g}")
            if not np.isfinite(seg.duration) or seg.duration <= 0:
                raise ValueError(f"segment {s}: duration must be > 0 s, got {seg.duration}")

    @property
    def n_segments(self) -> int:
        return len(self.segments)

    @property
    def durations(self) -> Array:
        return np.array([s.duration for s in self.segments])

    @property
    def anchors(self) -> tuple[str, ...]:
        return tuple(s.anchor for s in self.segments)

    def demo_object_poses(self) -> dict[str, Array]:
        """Anchor object poses at the first frame of the (first) demonstration: ``{name: (7,)}``."""
        out: dict[str, Array] = {}
        for s in self.segments:
            if s.anchor and s.anchor not in out:
                out[s.anchor] = np.asarray(s.anchor_initial_pose, dtype=np.float64)
        return out

    # ---- flat (buffer) form ----------------------------------------------------------------------------
    def flat_arrays(self) -> dict[str, Array]:
        """Concatenated arrays: nodes (ΣN, 3), node_times (ΣN,), orientations (ΣN, 4),
        gripper_nodes (ΣG, 1), gripper_node_times (ΣG,), durations (S,), anchor_poses (S, 7),
        anchor_initial_poses (S, 7)."""
        cat = np.concatenate
        return {
            "nodes": cat([s.nodes for s in self.segments]),
            "node_times": cat([s.node_times for s in self.segments]),
            "orientations": cat([s.orientations for s in self.segments]),
            "gripper_nodes": cat([s.gripper_nodes for s in self.segments]),
            "gripper_node_times": cat([s.gripper_node_times for s in self.segments]),
            "durations": self.durations,
            "anchor_poses": np.stack([np.asarray(s.anchor_pose, dtype=np.float64) for s in self.segments]),
            "anchor_initial_poses": np.stack(
                [np.asarray(s.anchor_initial_pose, dtype=np.float64) for s in self.segments]
            ),
        }

    @classmethod
    def from_flat(
        cls,
        arrays: dict[str, Array],
        segment_n_nodes: Sequence[int],
        segment_n_gripper_nodes: Sequence[int],
        anchors: Sequence[str],
        anchor_half_heights: Sequence[float] = (),
    ) -> FittedSkill:
        """Inverse of :meth:`flat_arrays` given the per-segment sizes and anchors (values checked by
        :func:`check_flat_arrays`); ``anchor_half_heights``: one per segment, or empty (all 0: unknown)."""
        check_flat_arrays(arrays, segment_n_nodes, segment_n_gripper_nodes)
        cut = np.cumsum(segment_n_nodes)[:-1]
        gcut = np.cumsum(segment_n_gripper_nodes)[:-1]
        parts = {
            k: np.split(np.asarray(arrays[k], dtype=np.float64), cut)
            for k in ("nodes", "node_times", "orientations")
        }
        gparts = {
            k: np.split(np.asarray(arrays[k], dtype=np.float64), gcut)
            for k in ("gripper_nodes", "gripper_node_times")
        }
        durations = np.asarray(arrays["durations"], dtype=np.float64)
        anchor_poses = np.asarray(arrays["anchor_poses"], dtype=np.float64)
        initial_poses = np.asarray(arrays["anchor_initial_poses"], dtype=np.float64)
        heights = [float(h) for h in anchor_half_heights] or [0.0] * len(segment_n_nodes)
        return cls(
            tuple(
                SegmentMaps(
                    nodes=parts["nodes"][s],
                    node_times=parts["node_times"][s],
                    orientations=parts["orientations"][s],
                    gripper_nodes=gparts["gripper_nodes"][s],
                    gripper_node_times=gparts["gripper_node_times"][s],
                    duration=float(durations[s]),
                    anchor=str(anchors[s]),
                    anchor_pose=anchor_poses[s],
                    anchor_initial_pose=initial_poses[s],
                    anchor_half_height=heights[s],
                )
                for s in range(len(segment_n_nodes))
            )
        )


def check_flat_arrays(
    arrays: Mapping[str, np.ndarray],
    segment_n_nodes: Sequence[int],
    segment_n_gripper_nodes: Sequence[int],
    source: str = "",
) -> None:
    """Raise ``ValueError("<source>: tensor '<name>' ...")`` unless the flat arrays
    (:meth:`FittedSkill.flat_arrays`, plus any others given, which are checked for range only) hold
    possible values: finite and within ±:data:`MAX_MAGNITUDE`, durations > 0, node times non-decreasing
    within their segment's ``[0, duration]``, unit quaternions. ``source``: where the arrays come from
    (a file), named first when given."""
    at = f"{source}: " if source else ""
    for name, a in arrays.items():
        bad = ~(np.abs(a) <= MAX_MAGNITUDE)
        if bad.any():
            what = "non-finite" if not np.isfinite(a).all() else f"beyond ±{MAX_MAGNITUDE:g}"
            first = np.argwhere(bad)[0].tolist()
            raise ValueError(f"{at}tensor {name!r} has {int(bad.sum())} {what} value(s), first at {first}")
    durations = arrays["durations"]
    if np.any(durations <= 0):
        raise ValueError(f"{at}tensor 'durations' must be > 0, got {durations.tolist()}")
    for name, sizes in (("node_times", segment_n_nodes), ("gripper_node_times", segment_n_gripper_nodes)):
        for s, part in enumerate(np.split(arrays[name], np.cumsum(sizes)[:-1])):
            if np.any(np.diff(part) < 0):
                raise ValueError(f"{at}tensor {name!r} decreases within segment {s}")
            slack = 1e-6 * max(1.0, float(durations[s]))  # float32 rounding of node times
            if part.size and (part[0] < -slack or part[-1] > durations[s] + slack):
                raise ValueError(
                    f"{at}tensor {name!r} in segment {s} spans [{part[0]:.6g}, {part[-1]:.6g}] s, "
                    f"outside the segment's [0, {durations[s]:.6g}] s (tensor 'durations')"
                )
    for name, quats in (
        ("orientations", arrays["orientations"]),
        ("anchor_poses", arrays["anchor_poses"][:, 3:7]),  # [x y z qw qx qy qz] per segment
        ("anchor_initial_poses", arrays["anchor_initial_poses"][:, 3:7]),
    ):
        norms = np.linalg.norm(quats, axis=1)
        if np.any(np.abs(norms - 1.0) > 1e-6):
            i = int(np.argmax(np.abs(norms - 1.0)))
            raise ValueError(f"{at}tensor {name!r} row {i} is not a unit quaternion (norm {norms[i]:.6g})")


@dataclass(frozen=True)
class Reproduction:
    """A skill placed in one scene: every segment in the base frame, run back to back in time.

    segments: the placed segments (``anchor`` names the object, ``anchor_pose`` is the object's
    base-frame pose the placement assumed at the segment's start: see ``placement.reanchor_segment``);
    start_times (S,) s since reset at which each segment starts; total duration = last end.
    """

    segments: tuple[SegmentMaps, ...]

    @property
    def start_times(self) -> Array:
        d = np.array([s.duration for s in self.segments])
        return np.concatenate([[0.0], np.cumsum(d)[:-1]])

    @property
    def duration(self) -> float:
        return float(sum(s.duration for s in self.segments))

    def actions_at(self, t: Array | float) -> Array:
        """Targets ``(K, 8)`` = [x y z qw qx qy qz gripper] at times ``t (K,)`` (s since reset).

        Within a segment positions are linear between nodes along the time law, orientations SLERP,
        the gripper linear and clipped to [0, 1]; before 0 the first node, after the end the last
        (the final pose is held).
        """
        t = np.atleast_1d(np.asarray(t, dtype=np.float64))
        starts = self.start_times
        seg = np.clip(np.searchsorted(starts, t, side="right") - 1, 0, len(self.segments) - 1)
        out = np.empty((len(t), layout.ACTION_DIM))
        for s in np.unique(seg):  # segments, not samples
            rows = np.flatnonzero(seg == s)
            m = self.segments[s]
            local = t[rows] - starts[s]
            if s == len(self.segments) - 1:
                local = np.where(local > m.duration, np.inf, local)  # hold the last node after the end
            out[rows, layout.ACTION_POS] = np.stack(
                [np.interp(local, m.node_times, m.nodes[:, q]) for q in range(3)], axis=1
            )
            out[rows, layout.ACTION_QUAT] = slerp_sequence(m.node_times, m.orientations, local)
            g = np.interp(local, m.gripper_node_times, m.gripper_nodes[:, 0])
            out[rows, layout.ACTION_GRIPPER] = np.clip(g, layout.GRIPPER_OPEN, layout.GRIPPER_CLOSED)
        return out

    def segment_at(self, t: float) -> int:
        """Index of the segment running at time ``t`` (s since reset; the last one after the end)."""
        s = int(np.searchsorted(self.start_times, float(t), side="right")) - 1
        return min(max(s, 0), len(self.segments) - 1)

    def path(self) -> Array:
        """All arm nodes (ΣN, 3) in the base frame, in order (for plots)."""
        return np.concatenate([s.nodes for s in self.segments])
