"""Re-anchoring object-anchored segments when they start, to an object that moved since reset.

Synthetic demonstration (``helpers.push_grasp_episode``): approach a box, push it 8 cm against a wall,
reach the box where it ended up, grasp it (gripper step), lift it. At run time the push leaves the box
somewhere else than in the demonstration; the grasp must follow the box observed when its segments
start, not the prediction made at reset (the policy's run: ``tests/policy/test_online_reanchoring.py``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from lerobot_forcemap.skill.fit import fit_skill
from lerobot_forcemap.skill.placement import (
    place_skill,
    predicted_anchor_poses,
    provisional_segments,
    reanchor_segment,
)

from .helpers import GRASP_NAMES, params, push_grasp_episode

FPS = 20.0
BOX = np.array([0.45, 0.0, 0.02])
PUSH = 0.08
WALL = np.array([0.56, 0.0, 0.0])
KW = {"segments": "dataset", "anchor_by_moved_object": True}
APPROACH, PUSHING, REACH, GRASP, LIFT = range(5)


def _config(**kw):
    return params(**{**KW, **kw})


@pytest.fixture(scope="module")
def fitted():
    cfg = _config()
    skill, report = fit_skill([push_grasp_episode(box=BOX, wall=WALL, push=PUSH)], cfg, FPS, GRASP_NAMES)
    return skill, report, cfg


def test_anchors_follow_what_each_segment_does():
    ep = push_grasp_episode(box=BOX, wall=WALL, push=PUSH)
    _, by_path = fit_skill([ep], _config(anchor_by_moved_object=False), FPS, GRASP_NAMES)
    _, by_moved = fit_skill([ep], _config(), FPS, GRASP_NAMES)
    # nearest object at rest to the robot's path: the carried box makes the wall the lift's anchor
    assert by_path.anchors == ("box", "", "box", "box", "wall")
    # by where the moved object goes: pushed against the wall -> wall; lifted into free space -> none
    assert by_moved.anchors == ("box", "wall", "box", "box", "")


def _yaw(angle: float) -> tuple[np.ndarray, np.ndarray]:
    """Rotation matrix (3, 3) and quaternion (4,) of a turn by ``angle`` about z."""
    c, s = np.cos(angle), np.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]), np.array(
        [np.cos(angle / 2), 0, 0, np.sin(angle / 2)]
    )


def test_a_push_against_a_turned_wall_turns_with_it():
    """Package defaults: the push is anchored to the wall (where the box ends), and with the wall's
    orientation in the state a scene turned about the wall turns the push, not only moves it."""
    ep = push_grasp_episode(box=BOX, wall=WALL, push=PUSH)
    names = [*GRASP_NAMES, "wall_qw", "wall_qx", "wall_qy", "wall_qz"]
    ep = replace(
        ep, env_state=np.column_stack([ep.env_state, np.tile([1.0, 0, 0, 0], (len(ep.env_state), 1))])
    )
    cfg = params(segments="dataset")
    skill, report = fit_skill([ep], cfg, FPS, names)
    assert report.anchors == ("box", "wall", "box", "box", "")
    rot, q = _yaw(0.4)
    scene = {
        "box": np.array([*(WALL + rot @ (BOX - WALL)), *q]),
        "wall": np.array([*WALL, *q]),
    }
    demo = place_skill(skill, cfg, robot_pose=None, object_pose=skill.demo_object_poses())
    turned = place_skill(skill, cfg, robot_pose=None, object_pose=scene)
    expected = WALL + (demo.segments[PUSHING].nodes - WALL) @ rot.T
    np.testing.assert_allclose(turned.segments[PUSHING].nodes, expected, atol=1e-9)
    push = turned.segments[PUSHING].nodes[-1] - turned.segments[PUSHING].nodes[0]
    np.testing.assert_allclose(push[:2] / np.linalg.norm(push[:2]), [np.cos(0.4), np.sin(0.4)], atol=1e-3)


def test_segments_are_stored_in_the_object_frame_at_their_start(fitted):
    skill, _, _ = fitted
    box_end = BOX + [PUSH, 0.0, 0.0]
    np.testing.assert_allclose(skill.segments[REACH].anchor_pose[:3], box_end, atol=1e-12)
    np.testing.assert_allclose(skill.segments[REACH].anchor_initial_pose[:3], BOX, atol=1e-12)
    np.testing.assert_allclose(skill.segments[APPROACH].anchor_pose[:3], BOX, atol=1e-12)
    # the reach ends on the box (grasp point = its centre) in the box frame at the segment's start
    np.testing.assert_allclose(skill.segments[REACH].nodes[-1], 0.0, atol=2e-3)
    # at reset the box is predicted to be where the demonstrated push left it, moved with the box
    moved = {"box": np.array([*(BOX + [0.01, 0.02, 0.0]), 1, 0, 0, 0]), "wall": np.array([*WALL, 1, 0, 0, 0])}
    pred = predicted_anchor_poses(skill, moved)
    np.testing.assert_allclose(pred[REACH][:3], box_end + [0.01, 0.02, 0.0], atol=1e-12)
    assert pred[LIFT] is None


def test_reanchor_segment_shifts_the_rest_and_keeps_the_junction(fitted):
    skill, _, cfg = fitted
    rep = place_skill(skill, cfg, robot_pose=None, object_pose=skill.demo_object_poses())
    q = BOX + [PUSH - 0.03, 0.04, 0.0]  # the box ended up 3 cm short and 4 cm to the side
    shift = q - rep.segments[REACH].anchor_pose[:3]
    out = reanchor_segment(rep, skill, REACH, q, cfg, blend_s=0.5)
    for s in (APPROACH, PUSHING):  # already run: untouched
        np.testing.assert_array_equal(out.segments[s].nodes, rep.segments[s].nodes)
    # the re-anchored segment starts where the robot was sent (exact) ...
    np.testing.assert_allclose(out.segments[REACH].nodes[0], rep.segments[PUSHING].nodes[-1], atol=1e-12)
    # ... and after the blend window follows the demonstrated path moved by the shift
    seg = out.segments[REACH]
    late = seg.node_times - seg.node_times[0] >= 0.5
    np.testing.assert_allclose(seg.nodes[late], rep.segments[REACH].nodes[late] + shift, atol=1e-12)
    # the grasp (same box) moves with it; the free lift starts where the grasp ends
    np.testing.assert_allclose(out.segments[GRASP].nodes, rep.segments[GRASP].nodes + shift, atol=1e-12)
    np.testing.assert_allclose(out.segments[GRASP].anchor_pose[:3], q, atol=1e-12)
    np.testing.assert_allclose(out.segments[LIFT].nodes[0], out.segments[GRASP].nodes[-1], atol=1e-9)
    np.testing.assert_allclose(out.segments[LIFT].nodes[-1], rep.segments[LIFT].nodes[-1] + shift, atol=1e-9)
    # the gripper maps are not touched by anchoring
    np.testing.assert_array_equal(out.segments[GRASP].gripper_nodes, rep.segments[GRASP].gripper_nodes)
    with pytest.raises(ValueError, match="not anchored"):
        reanchor_segment(rep, skill, LIFT, q, cfg)


def test_provisional_segments_do_not_pull_their_neighbours(fitted):
    skill, _, cfg = fitted
    flags = provisional_segments(skill, skill.demo_object_poses(), cfg.anchoring.static_tolerance)
    assert flags == [False, False, True, True, False]  # the box moves (pushed) before the reach and grasp
    moved = {"box": np.array([*(BOX + [0.0, 0.03, 0.0]), 1, 0, 0, 0]), "wall": np.array([*WALL, 1, 0, 0, 0])}
    trusting = place_skill(skill, cfg, robot_pose=None, object_pose=moved)
    careful = place_skill(skill, cfg, robot_pose=None, object_pose=moved, provisional=flags)
    demo = place_skill(skill, cfg, robot_pose=None, object_pose=skill.demo_object_poses())
    # trusting the prediction (the box moved 3 cm aside, so the pushed box is expected 3 cm aside), the
    # wall-anchored push would be bent to end next to the predicted reach start ...
    bent = trusting.segments[PUSHING].nodes[-1] - demo.segments[PUSHING].nodes[-1]
    np.testing.assert_allclose(bent, [0.0, 0.03, 0.0], atol=1e-9)
    # ... while with the reach provisional it ends where the wall (which did not move) says (up to the
    # sub-millimetre gap between the separately fitted push and reach, which the demo scene closes)
    np.testing.assert_allclose(careful.segments[PUSHING].nodes, demo.segments[PUSHING].nodes, atol=2e-4)
    # the provisional reach keeps its demonstrated path until it starts (up to the fitted gaps to its
    # neighbours, < 1 mm), with its predicted anchor pose to be re-anchored from
    np.testing.assert_allclose(careful.segments[REACH].nodes, demo.segments[REACH].nodes, atol=1e-3)
    np.testing.assert_allclose(careful.segments[REACH].anchor_pose, trusting.segments[REACH].anchor_pose)


def test_lead_in_path_never_sweeps_below_its_ends():
    from lerobot_forcemap.skill.placement import _lead_in_path

    high, low = np.array([0.6, 0.0, 0.11]), np.array([0.5, 0.03, 0.05])
    # from the hand's height across, then down onto the object (not diagonally into it)
    np.testing.assert_allclose(_lead_in_path(high, low), [high, [0.5, 0.03, 0.11], low])
    # from low up to the target's height first, then across
    np.testing.assert_allclose(_lead_in_path(low, high), [low, [0.5, 0.03, 0.11], high])
    np.testing.assert_allclose(_lead_in_path(low, low + [0.0, 0.0, 0.02]), [low, low + [0.0, 0.0, 0.02]])


def test_a_provisional_segment_travels_to_its_shifted_start_with_the_gripper_held(fitted):
    """Re-anchored when it starts, a provisional reach (the box was pushed somewhere else) first goes
    to its shifted start with the gripper as it was, then runs as demonstrated on the box; every
    later segment starts that much later, so the grasp closes on the box, not on the way to it."""
    from lerobot_forcemap.skill.placement import REANCHOR_TRAVEL_SPEED

    skill, _, cfg = fitted
    flags = provisional_segments(skill, skill.demo_object_poses(), cfg.anchoring.static_tolerance)
    rep = place_skill(skill, cfg, robot_pose=None, object_pose=skill.demo_object_poses(), provisional=flags)
    q = BOX + [PUSH - 0.03, 0.04, 0.0]
    shift = q - rep.segments[REACH].anchor_pose[:3]
    out = reanchor_segment(rep, skill, REACH, q, cfg, provisional=flags, lead_in_speed=REANCHOR_TRAVEL_SPEED)
    seg, junction = out.segments[REACH], rep.segments[PUSHING].nodes[-1]
    span = seg.duration - skill.segments[REACH].duration
    k = int(np.searchsorted(seg.node_times, span))  # the first node of the demonstrated reach
    np.testing.assert_allclose(seg.nodes[0], junction, atol=1e-12)
    length = np.linalg.norm(np.diff(seg.nodes[: k + 1], axis=0), axis=1).sum()
    assert span == pytest.approx(length / REANCHOR_TRAVEL_SPEED) and length >= np.linalg.norm(shift) - 1e-3
    # after the lead-in: the demonstrated reach on the box where it is, no blend
    np.testing.assert_allclose(seg.nodes[k:], rep.segments[REACH].nodes + shift, atol=1e-3)
    np.testing.assert_allclose(seg.node_times[k:], skill.segments[REACH].node_times + span, atol=1e-12)
    # the gripper holds during the lead-in, then follows its demonstrated law, delayed
    g = out.actions_at(np.linspace(out.start_times[REACH], out.start_times[REACH] + span, 9))[:, 7]
    np.testing.assert_allclose(g, rep.segments[PUSHING].gripper_nodes[-1, 0], atol=1e-12)
    np.testing.assert_allclose(out.start_times[GRASP:], rep.start_times[GRASP:] + span, atol=1e-9)
    np.testing.assert_allclose(out.segments[GRASP].nodes, rep.segments[GRASP].nodes + shift, atol=1e-3)
