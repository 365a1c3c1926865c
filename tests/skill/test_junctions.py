"""A continuous skill: consecutive segment maps share their boundary, the skill starts and ends at the
demonstrated samples, and the reproduction steps no faster than the demonstration did."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.skill.fit import fit_skill
from lerobot_forcemap.skill.junctions import SegmentEnds, join_segments
from lerobot_forcemap.skill.model import SegmentMaps
from lerobot_forcemap.skill.placement import demonstrated_reproduction

from .helpers import OBJECT_NAMES, params, press_episode

FPS = 20.0


def _segment(x0: float, x1: float, times: list[float], duration: float, anchor: str = "") -> SegmentMaps:
    n = len(times)
    nodes = np.column_stack([np.linspace(x0, x1, n), np.zeros(n), np.zeros(n)])
    quats = np.tile([1.0, 0.0, 0.0, 0.0], (n, 1))
    t = np.asarray(times, dtype=np.float64)
    return SegmentMaps(nodes, t, quats, np.linspace(0.0, 1.0, n)[:, None], t.copy(), duration, anchor)


@pytest.fixture(scope="module")
def press():
    ep = press_episode(0, depth=0.02, K=2000.0, fps=FPS)
    skill, _ = fit_skill([ep], params(segments="dataset"), FPS, OBJECT_NAMES)
    return ep, skill


def test_consecutive_maps_meet_and_the_skill_spans_the_demonstration(press):
    ep, skill = press
    demo = demonstrated_reproduction(skill)  # anchored segments in the demonstrated scene
    for a, b in zip(demo.segments[:-1], demo.segments[1:], strict=True):
        np.testing.assert_allclose(a.nodes[-1], b.nodes[0], atol=1e-12)
        np.testing.assert_allclose(a.orientations[-1], b.orientations[0], atol=1e-12)
        assert a.node_times[-1] == pytest.approx(a.duration) and b.node_times[0] == 0.0
    np.testing.assert_allclose(demo.segments[0].nodes[0], ep.pose[0, :3], atol=1e-12)
    np.testing.assert_allclose(demo.segments[-1].nodes[-1], ep.pose[-1, :3], atol=1e-12)


def test_the_reproduction_steps_no_faster_than_the_demonstration(press):
    ep, skill = press
    targets = demonstrated_reproduction(skill).actions_at(ep.times)[:, :3]
    step = np.linalg.norm(np.diff(targets, axis=0), axis=1).max()
    demo_step = np.linalg.norm(np.diff(ep.pose[:, :3], axis=0), axis=1).max()
    assert step <= 1.5 * demo_step


def test_the_junction_lies_where_the_boundary_falls_between_the_two_maps():
    a = _segment(0.0, 1.0, [0.0, 0.5, 0.8], 1.0)  # last node 0.2 s before the boundary
    b = _segment(2.0, 3.0, [0.6, 1.0, 2.0], 2.0)  # first node 0.6 s after it
    ja, jb = join_segments([a, b])
    np.testing.assert_allclose(ja.nodes[-1], [1.25, 0.0, 0.0])  # a quarter of the way from 1 to 2
    np.testing.assert_allclose(jb.nodes[0], ja.nodes[-1])
    assert len(ja.nodes) == 4 and len(jb.nodes) == 4  # added: the fitted nodes stay as they were
    np.testing.assert_array_equal(ja.nodes[:3], a.nodes)
    assert ja.node_times[-1] == 1.0 and jb.node_times[0] == 0.0
    np.testing.assert_allclose(ja.gripper_nodes[-1], jb.gripper_nodes[0])


def test_an_end_node_within_a_frame_of_the_boundary_is_replaced():
    a = _segment(0.0, 1.0, [0.02, 0.5, 1.0], 1.0)
    ends = SegmentEnds(
        positions=np.array([[-0.1, 0.0, 0.0], [1.0, 0.0, 0.0]]),
        orientations=np.tile([1.0, 0.0, 0.0, 0.0], (2, 1)),
        gripper=np.array([[0.0], [1.0]]),
    )
    (kept,) = join_segments([a], ends)
    assert len(kept.nodes) == 4 and kept.node_times[0] == 0.0  # a node 20 ms away: one more node
    (merged,) = join_segments([a], ends, merge_s=0.02)
    assert len(merged.nodes) == 3 and merged.node_times[0] == 0.0
    np.testing.assert_allclose(merged.nodes[0], [-0.1, 0.0, 0.0])
    np.testing.assert_array_equal(merged.nodes[1:], a.nodes[1:])
