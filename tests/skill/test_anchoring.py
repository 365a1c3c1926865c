"""Placing a fitted skill in a new scene: objects move anchored segments rigidly, the robot's pose
becomes the start, boundaries stay continuous, equality constraints hold exactly."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.geometry import quat_multiply, quat_rotate, rotvec_to_quat
from lerobot_forcemap.skill.fit import fit_skill
from lerobot_forcemap.skill.placement import (
    ObjectSlot,
    object_poses,
    object_slots,
    place_skill,
)

from .helpers import GRASP_NAMES, OBJECT_NAMES, TOOL_DOWN, params, press_episode, push_grasp_episode

CFG = params(segments="dataset")


@pytest.fixture(scope="module")
def skill():
    s, report = fit_skill([press_episode(0)], CFG, 20.0, OBJECT_NAMES)
    assert report.anchors == ("", "box", "box", "box")
    return s


def _place(skill, robot_pose, box_pose, **kw):
    return place_skill(
        skill, CFG, robot_pose=robot_pose, object_pose={"box": np.asarray(box_pose, float)}, **kw
    )


def _pose(p, q=(1.0, 0.0, 0.0, 0.0)):
    return np.array([*p, *q], dtype=float)


def test_object_slots_from_state_names():
    press = [
        "button_x",
        "button_y",
        "button_z",
        "button_qw",
        "button_qx",
        "button_qy",
        "button_qz",
        "button_travel",
    ]
    assert object_slots(press) == (ObjectSlot("button", (0, 1, 2), (3, 4, 5, 6)),)
    assert object_slots(["peg_x", "peg_y", "peg_z", "hole_x"]) == (ObjectSlot("peg", (0, 1, 2), None),)
    poses = object_poses(np.array([0.5, 0.1, 0.02, 2.0, 0.0, 0.0, 0.0, 9.0]), object_slots(press))
    np.testing.assert_allclose(poses["button"], [0.5, 0.1, 0.02, 1.0, 0.0, 0.0, 0.0])  # quaternion normalised


def test_moved_object_moves_anchored_segments_rigidly_and_robot_start_is_exact(skill):
    box = np.array([0.57, -0.03, 0.05])
    robot = _pose([0.35, 0.06, 0.19], TOOL_DOWN)
    rep = _place(skill, robot, _pose(box))
    for s in (1, 2, 3):  # anchored: exactly the stored object-frame nodes at the new box
        np.testing.assert_allclose(rep.segments[s].nodes, box + skill.segments[s].nodes, rtol=0, atol=1e-12)
    np.testing.assert_allclose(rep.segments[0].nodes[0], robot[:3], rtol=0, atol=1e-9)
    # free -> anchored boundary: continuous; anchored -> anchored (same box): the fitted relation, moved rigidly
    np.testing.assert_allclose(rep.segments[0].nodes[-1], rep.segments[1].nodes[0], rtol=0, atol=1e-9)
    for s in (1, 2):
        gap = rep.segments[s + 1].nodes[0] - rep.segments[s].nodes[-1]
        np.testing.assert_allclose(
            gap, skill.segments[s + 1].nodes[0] - skill.segments[s].nodes[-1], atol=1e-12
        )
        assert np.linalg.norm(gap) < 1e-3
    a = rep.actions_at(np.array([0.0]))[0]
    np.testing.assert_allclose(a[:3], robot[:3], atol=1e-9)


def test_rotated_object_rotates_anchored_segments():
    # pressed 2 cm off the box's z-axis, so a turn about z moves the anchored nodes (on-axis ones would not)
    skill, _ = fit_skill([press_episode(0, lateral=0.02)], CFG, 20.0, OBJECT_NAMES)
    q = rotvec_to_quat(np.array([0.0, 0.0, np.pi / 2]))
    box = np.array([0.5, 0.0, 0.03])
    rep = _place(skill, None, _pose(box, q))
    for s in (1, 2, 3):
        local = skill.segments[s].nodes
        np.testing.assert_allclose(rep.segments[s].nodes - box, quat_rotate(q, local), atol=1e-12)
        # the turn moved them: x ~ 0.02 in the box frame became y ~ 0.02 in the base frame
        assert np.min(np.linalg.norm(rep.segments[s].nodes - box - local, axis=1)) > 0.02
        np.testing.assert_allclose(
            rep.segments[s].orientations, quat_multiply(q, skill.segments[s].orientations), atol=1e-12
        )


def _same_orientations(a, b):
    """Rows of quaternions ``a`` and ``b`` (n, 4) are the same rotations (either sign)."""
    np.testing.assert_allclose(np.abs(np.einsum("ij,ij->i", a, b)), 1.0, atol=1e-9)


def test_a_free_lift_after_a_turned_grasp_keeps_the_grasp_orientation():
    """A free segment next to an anchored one turns to meet it (the free side's counterpart of the
    displacement at the boundary), and after the last anchored segment keeps its turn: the hand lifts
    a grasped object without turning it back to the demonstrated orientation."""
    cfg = params(segments="dataset", anchor_by_moved_object=True)
    skill, report = fit_skill([push_grasp_episode()], cfg, 20.0, GRASP_NAMES)
    assert report.anchors == ("box", "wall", "box", "box", "")
    turn = rotvec_to_quat(np.array([0.0, 0.0, 0.3]))
    scene = skill.demo_object_poses()
    scene["box"] = _pose(scene["box"][:3], turn)
    rep = place_skill(skill, cfg, robot_pose=None, object_pose=scene)
    grasp, lift = rep.segments[3], rep.segments[4]
    _same_orientations(grasp.orientations, quat_multiply(turn, skill.segments[3].orientations))
    _same_orientations(lift.orientations[:1], grasp.orientations[-1:])
    _same_orientations(lift.orientations, quat_multiply(turn, skill.segments[4].orientations))
    np.testing.assert_allclose(lift.nodes[0], grasp.nodes[-1], atol=1e-9)


def test_a_free_approach_turns_to_meet_a_turned_anchored_segment(skill):
    turn = rotvec_to_quat(np.array([0.0, 0.0, -0.4]))
    rep = _place(skill, _pose([0.4, 0.0, 0.15], TOOL_DOWN), _pose([0.5, 0.0, 0.03], turn))
    approach, press = rep.segments[0], rep.segments[1]
    _same_orientations(approach.orientations[:1], TOOL_DOWN[None, :])  # from the robot's
    _same_orientations(approach.orientations[-1:], press.orientations[:1])  # onto the turned press


def test_start_orientation_blends_from_the_robot_to_the_stored_one(skill):
    tilt = quat_multiply(rotvec_to_quat(np.array([0.0, 0.2, 0.0])), TOOL_DOWN)
    rep = _place(skill, _pose([0.4, 0.0, 0.15], tilt), _pose([0.5, 0.0, 0.03]))
    q = rep.segments[0].orientations
    assert abs(np.dot(q[0], tilt)) == pytest.approx(1.0, abs=1e-9)
    assert abs(np.dot(q[-1], skill.segments[0].orientations[-1])) == pytest.approx(1.0, abs=1e-9)


def test_free_segment_resolve_keeps_the_blended_path(skill):
    robot = _pose([0.36, 0.05, 0.18], TOOL_DOWN)
    box = _pose([0.52, 0.01, 0.03])
    solved = _place(skill, robot, box, resolve=True).segments[0]
    blended = _place(skill, robot, box, resolve=False).segments[0]
    np.testing.assert_allclose(solved.nodes[[0, -1]], blended.nodes[[0, -1]], atol=1e-9)
    assert np.max(np.linalg.norm(solved.nodes - blended.nodes, axis=1)) < 0.005


def test_unknown_object_is_a_clear_error(skill):
    with pytest.raises(ValueError, match="anchored to object 'box'"):
        place_skill(skill, CFG, robot_pose=None, object_pose={})


def test_demo_scene_reproduces_the_base_frame_fit(skill):
    """Fitted in the box's frame and placed back in the demonstration's scene, the anchored segments are
    the maps a fit with no anchors gives in the base frame (the box is axis-aligned there, so the fit's
    per-axis force weights see the same axes)."""
    rep = place_skill(skill, CFG, robot_pose=None, object_pose=skill.demo_object_poses())
    unanchored_cfg = params(segments="dataset", anchor_radius=1e-9)
    base, report = fit_skill([press_episode(0)], unanchored_cfg, 20.0, OBJECT_NAMES)
    assert report.anchors == ("", "", "", "")
    for s in (1, 2, 3):  # the box-anchored ones (segment 0 starts at the robot and is re-solved)
        np.testing.assert_allclose(rep.segments[s].nodes, base.segments[s].nodes, rtol=0, atol=1e-12)
