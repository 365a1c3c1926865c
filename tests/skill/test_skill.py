"""FittedSkill flat form and the time-indexed reproduction."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.skill.model import FittedSkill, Reproduction, SegmentMaps


def _segment(n, t0, duration, anchor=""):
    nodes = np.column_stack([np.linspace(0, 1, n) + t0, np.zeros(n), np.linspace(1, 0, n)])
    q = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    times = np.linspace(0.0, duration, n)
    g = np.linspace(0.0, 1.2, n)[:, None]
    return SegmentMaps(nodes, times, q, g, times.copy(), duration, anchor)


def test_flat_round_trip_is_exact():
    skill = FittedSkill((_segment(5, 0.0, 1.0), _segment(7, 1.0, 2.0, "button")))
    back = FittedSkill.from_flat(skill.flat_arrays(), [5, 7], [5, 7], ["", "button"])
    for a, b in zip(skill.segments, back.segments, strict=True):
        for name in (
            "nodes",
            "node_times",
            "orientations",
            "gripper_nodes",
            "gripper_node_times",
            "anchor_pose",
            "anchor_initial_pose",
        ):
            np.testing.assert_array_equal(getattr(a, name), getattr(b, name))
        assert a.duration == b.duration and a.anchor == b.anchor


def test_actions_follow_the_time_law_and_hold_the_end():
    rep = Reproduction((_segment(5, 0.0, 1.0), _segment(7, 1.0, 2.0)))
    assert rep.duration == pytest.approx(3.0)
    a = rep.actions_at(np.array([0.0, 0.25, 1.0 + 2.0 / 6, 3.0, 10.0]))
    np.testing.assert_allclose(a[0, :3], rep.segments[0].nodes[0])
    np.testing.assert_allclose(a[1, :3], rep.segments[0].nodes[1])
    np.testing.assert_allclose(a[2, :3], rep.segments[1].nodes[1])
    np.testing.assert_allclose(a[3, :3], rep.segments[1].nodes[-1])
    np.testing.assert_allclose(a[4, :3], rep.segments[1].nodes[-1])  # held after the end
    assert a[:, 7].max() <= 1.0 and a[:, 7].min() >= 0.0  # gripper clipped to [0, 1]
    np.testing.assert_allclose(np.linalg.norm(a[:, 3:7], axis=1), 1.0)


def test_bad_shapes_are_rejected():
    seg = _segment(5, 0.0, 1.0)
    bad = SegmentMaps(
        seg.nodes[:, :2], seg.node_times, seg.orientations, seg.gripper_nodes, seg.gripper_node_times, 1.0
    )
    with pytest.raises(ValueError, match="segment 0: nodes has shape"):
        FittedSkill((bad,))
    with pytest.raises(ValueError, match="duration must be > 0"):
        FittedSkill(
            (
                SegmentMaps(
                    seg.nodes,
                    seg.node_times,
                    seg.orientations,
                    seg.gripper_nodes,
                    seg.gripper_node_times,
                    0.0,
                ),
            )
        )
