"""Faithful placement: from the demonstration's own start the fitted path itself; from a new start a
displacement that deforms the path near the start and fades out, nothing re-fitted."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.skill.fit import fit_skill
from lerobot_forcemap.skill.placement import START_BLEND_SPEED, demonstrated_reproduction, place_skill

from .helpers import OBJECT_NAMES, TOOL_DOWN, params, press_episode

FPS = 20.0


@pytest.fixture(scope="module")
def anchored():
    cfg = params(segments="dataset")
    skill, report = fit_skill([press_episode(0)], cfg, FPS, OBJECT_NAMES)
    assert report.anchors == ("", "box", "box", "box")
    return skill, cfg


@pytest.fixture(scope="module")
def free():
    cfg = params(segments="dataset", anchor_radius=1e-9)
    skill, report = fit_skill([press_episode(0)], cfg, FPS, OBJECT_NAMES)
    assert not any(report.anchors)
    return skill, cfg


def _start(skill):
    return np.concatenate([skill.segments[0].nodes[0], skill.segments[0].orientations[0]])


@pytest.mark.parametrize("which", ["anchored", "free"])
def test_from_the_demonstrated_start_the_placement_is_the_fitted_path(which, request):
    skill, cfg = request.getfixturevalue(which)
    rep = place_skill(skill, cfg, robot_pose=_start(skill), object_pose=skill.demo_object_poses())
    times = np.arange(0.0, rep.duration, 1.0 / FPS)
    np.testing.assert_allclose(
        rep.actions_at(times), demonstrated_reproduction(skill).actions_at(times), rtol=0, atol=1e-12
    )


def test_a_new_start_deforms_the_path_near_the_start_and_fades_out(free):
    skill, cfg = free
    offset = np.array([0.02, -0.01, 0.0])
    robot = np.concatenate([skill.segments[0].nodes[0] + offset, TOOL_DOWN])
    rep = place_skill(skill, cfg, robot_pose=robot)
    stored = demonstrated_reproduction(skill)
    fade_s = np.linalg.norm(offset) / START_BLEND_SPEED  # 0.45 s
    times = np.arange(0.0, rep.duration, 1.0 / FPS)
    shift = rep.actions_at(times)[:, :3] - stored.actions_at(times)[:, :3]
    np.testing.assert_allclose(shift[0], offset, atol=1e-12)  # the robot's pose is the first target
    # each node of the first segment moved by the offset decaying linearly in time over fade_s
    t = rep.segments[0].node_times
    moved = rep.segments[0].nodes - stored.segments[0].nodes
    np.testing.assert_allclose(moved, np.clip(1.0 - t / fade_s, 0.0, 1.0)[:, None] * offset, atol=1e-12)
    # from the first node past fade_s on, the targets are the stored path itself
    np.testing.assert_allclose(shift[times >= t[t >= fade_s][0]], 0.0, atol=1e-12)
    for seg, placed in zip(skill.segments[1:], rep.segments[1:], strict=True):
        np.testing.assert_array_equal(placed.nodes, seg.nodes)  # later segments untouched


def test_a_new_start_before_an_anchored_segment_bends_the_approach_to_meet_it(anchored):
    skill, cfg = anchored
    offset = np.array([0.0, 0.03, 0.01])
    robot = np.concatenate([skill.segments[0].nodes[0] + offset, TOOL_DOWN])
    rep = place_skill(skill, cfg, robot_pose=robot, object_pose=skill.demo_object_poses())
    stored = demonstrated_reproduction(skill)
    approach, fitted = rep.segments[0], stored.segments[0]
    u = approach.node_times / approach.duration
    # from the robot's offset at the start to none at the (unmoved) object's segment: linear in time
    np.testing.assert_allclose(approach.nodes - fitted.nodes, (1.0 - u)[:, None] * offset, atol=1e-12)
    for s in (1, 2, 3):
        np.testing.assert_allclose(rep.segments[s].nodes, stored.segments[s].nodes, atol=1e-12)


def test_skill_run_refuses_robot_poses_that_are_not_poses(free):
    """``SkillRun.start`` places from ``[x y z qw qx qy qz]`` rows: another width, or a quaternion too
    small to carry an orientation, is named with the row."""
    from lerobot_forcemap.skill.placement import SkillRun

    skill, cfg = free
    good = np.stack([_start(skill), _start(skill)])
    SkillRun.start(skill, cfg, good, [{}, {}], online=False)
    with pytest.raises(ValueError, match=r"robot_poses: needs \[x y z qw qx qy qz\], got width 8"):
        SkillRun.start(skill, cfg, np.pad(good, ((0, 0), (0, 1))), [{}, {}], online=False)
    good[1, 3:7] = 1e-7
    with pytest.raises(ValueError, match=r"pose: zero quaternion \(qw qx qy qz\) at batch row 1"):
        SkillRun.start(skill, cfg, good, [{}, {}], online=False, robot_name="pose")
