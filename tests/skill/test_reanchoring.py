"""Re-anchoring object-anchored segments when they start, to an object that moved since reset.

Synthetic demonstration (``helpers.push_grasp_episode``): approach a box, push it 8 cm against a wall,
reach the box where it ended up, grasp it (gripper step), lift it. At run time the push leaves the box
somewhere else than in the demonstration; the grasp must follow the box observed when its segments
start, not the prediction made at reset.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch

from lerobot_forcemap.skill.fit import fit_skill
from lerobot_forcemap.skill.placement import (
    place_skill,
    predicted_anchor_poses,
    provisional_segments,
    reanchor_segment,
)
from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig
from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

from .helpers import GRASP_NAMES, TOOL_DOWN, push_grasp_episode

FPS = 20.0
BOX = np.array([0.45, 0.0, 0.02])
PUSH = 0.08
WALL = np.array([0.56, 0.0, 0.0])
KW = {"segments": "dataset", "anchor_by_moved_object": True}
APPROACH, PUSHING, REACH, GRASP, LIFT = range(5)


def _config(**kw) -> ForceMapConfig:
    return ForceMapConfig(device="cpu", **{**KW, **kw})


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
    rep = place_skill(
        skill, robot_pose=None, object_pose=skill.demo_object_poses(), params_for=cfg.segment_params
    )
    q = BOX + [PUSH - 0.03, 0.04, 0.0]  # the box ended up 3 cm short and 4 cm to the side
    shift = q - rep.segments[REACH].anchor_pose[:3]
    out = reanchor_segment(rep, skill, REACH, q, params_for=cfg.segment_params, blend_s=0.5)
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
        reanchor_segment(rep, skill, LIFT, q, params_for=cfg.segment_params)


def test_provisional_segments_do_not_pull_their_neighbours(fitted):
    skill, _, cfg = fitted
    flags = provisional_segments(skill, skill.demo_object_poses(), cfg.static_tolerance)
    assert flags == [False, False, True, True, False]  # the box moves (pushed) before the reach and grasp
    moved = {"box": np.array([*(BOX + [0.0, 0.03, 0.0]), 1, 0, 0, 0]), "wall": np.array([*WALL, 1, 0, 0, 0])}
    trusting = place_skill(skill, robot_pose=None, object_pose=moved, params_for=cfg.segment_params)
    careful = place_skill(
        skill, robot_pose=None, object_pose=moved, params_for=cfg.segment_params, provisional=flags
    )
    demo = place_skill(
        skill, robot_pose=None, object_pose=skill.demo_object_poses(), params_for=cfg.segment_params
    )
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


def _batch(tcp, box) -> dict[str, torch.Tensor]:
    return {
        "observation.ee_pose": torch.tensor([[*tcp, *TOOL_DOWN]], dtype=torch.float32),
        "observation.environment_state": torch.tensor(
            [[*box, 1.0, 0.0, 0.0, 0.0, *WALL]], dtype=torch.float32
        ),
    }


def _run_policy(policy: ForceMapPolicy, box_at_reset, box_after_push) -> tuple[np.ndarray, np.ndarray]:
    """Stream the reproduction; the observed box sits at ``box_at_reset`` until the reach segment
    starts and at ``box_after_push`` from then on. Returns (actions (K, 8), segment start times)."""
    policy.reset()
    starts = None
    tcp = np.array([0.30, 0.02, 0.15])
    out = []
    for k in range(int(9.0 * FPS)):
        t = k / FPS
        box = box_at_reset if starts is None or t < starts[REACH] else box_after_push
        a = policy.select_action(_batch(tcp, box))[0].numpy().astype(float)
        starts = policy._placed[0].start_times if starts is None else starts
        tcp = a[:3]
        out.append(a)
    return np.array(out), starts


@pytest.mark.parametrize("online", [True, False])
def test_the_policy_reanchors_a_segment_when_it_starts(online):
    policy = ForceMapPolicy(_config(reanchor_online=online))
    policy.fit_episodes([push_grasp_episode(box=BOX, wall=WALL, push=PUSH)], FPS, GRASP_NAMES)
    skill = policy.skill
    at_reset = BOX + [0.01, -0.01, 0.0]
    after_push = BOX + [PUSH - 0.03, 0.04, 0.0]  # not where the demonstration's push would have left it
    acts, starts = _run_policy(policy, at_reset, after_push)
    k_reach = int(np.ceil(starts[REACH] * FPS - 1e-9))
    k_grasp = int(np.ceil(starts[GRASP] * FPS - 1e-9))
    grasp_point = acts[k_grasp - 1, :3]  # the end of the reach, where the hand closes
    expected = after_push + skill.segments[REACH].nodes[-1]  # the demonstrated grasp, on the observed box
    if not online:  # anchored at reset only: the grasp goes where the box was predicted to be
        assert np.linalg.norm(grasp_point - expected) > 0.04
        assert policy.reanchor_log == []
        return
    np.testing.assert_allclose(grasp_point, expected, atol=2e-3)
    [entry] = [e for e in policy.reanchor_log if e["segment"] == REACH]
    np.testing.assert_allclose(entry["shift"], after_push - (at_reset + [PUSH, 0.0, 0.0]), atol=1e-6)
    # the junction is smooth: no jump of the target when the reach starts
    steps = np.linalg.norm(np.diff(acts[:, :3], axis=0), axis=1)
    assert steps[k_reach - 1] < 0.012 and steps[k_reach - 1 : k_reach + 25].max() < 0.015
    # the hand closes on the box (a step within two control periods) and lifts it from there
    g = acts[k_grasp:, 7]
    assert np.count_nonzero((g > 0.05) & (g < 0.95)) <= 1 and g[-1] > 0.95
    np.testing.assert_allclose(acts[-1, :3], expected + [0.0, 0.0, 0.10], atol=3e-3)
