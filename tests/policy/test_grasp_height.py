"""The grasp height follows the object's height: a grasp demonstrated on a book stood upright (9 cm
half height) is lowered for a banana (1.8 cm), which it would otherwise close over the top of."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.conftest import REPO_ROOT

DATASET = REPO_ROOT / "datasets" / "grasp_push"
BOOK_UPRIGHT, BOOK_FLAT = 0.09, 0.025  # m, the book's vertical half extent stood up / lying flat
needs_dataset = pytest.mark.skipif(
    not (DATASET / "meta" / "info.json").is_file(), reason="datasets/grasp_push not shipped"
)


@pytest.fixture(scope="module")
def policy():
    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    policy = ForceMapPolicy(ForceMapConfig(device="cpu", episodes=[6]))
    policy.fit_dataset(DATASET)
    return policy


def _grasps(skill):
    from lerobot_forcemap.skill.placement import GRASP_CLOSING

    return [
        s
        for s, seg in enumerate(skill.segments)
        if seg.anchor and seg.gripper_nodes[-1, 0] - seg.gripper_nodes[0, 0] >= GRASP_CLOSING
    ]


def test_half_heights_of_a_turned_box():
    from lerobot_forcemap.skill.placement import object_half_heights, object_slots

    names = ["obj_x", "obj_y", "obj_z", "obj_qw", "obj_qx", "obj_qy", "obj_qz", "obj_hx", "obj_hy", "obj_hz"]
    flat = [0.5, 0, 0.025, 1, 0, 0, 0, 0.09, 0.06, 0.025]
    half = np.sqrt(0.5)
    upright = [0.5, 0, 0.09, half, 0, half, 0]  # 90 degrees about y: the long axis (x) vertical
    slots = object_slots(names)
    assert object_half_heights(np.array(flat), slots) == pytest.approx({"obj": 0.025})
    assert object_half_heights(np.array(upright + flat[7:]), slots) == pytest.approx({"obj": 0.09})
    assert object_half_heights(np.array(flat[:7]), object_slots(names[:7])) == {}  # no extents: unknown


@needs_dataset
def test_the_fit_stores_the_demonstration_objects_height_and_only_grasps_are_lowered(policy):
    from lerobot_forcemap.skill.placement import grasp_lowering

    skill = policy.skill
    heights = policy.config.segment_anchor_half_heights
    assert heights == [seg.anchor_half_height for seg in skill.segments]
    (grasp,) = _grasps(skill)
    assert heights[grasp] == pytest.approx(BOOK_UPRIGHT, abs=0.005)
    assert any(abs(h - BOOK_FLAT) < 0.002 for h in heights)  # the push, on the book lying flat
    seg = skill.segments[grasp]
    drop = grasp_lowering(seg, seg.anchor_half_height, 0.018)
    assert 0 < drop < 0.03
    assert grasp_lowering(seg, seg.anchor_half_height, 0.1) == 0.0  # never raised
    assert grasp_lowering(seg, 0.0, 0.018) == 0.0  # unknown demonstration height
    others = [s for s, seg in enumerate(skill.segments) if seg.anchor and s != grasp]
    assert all(grasp_lowering(skill.segments[s], heights[s], 0.001) == 0.0 for s in others)


@needs_dataset
def test_a_checkpoint_without_the_heights_loads_and_keeps_the_old_grasp(policy, tmp_path):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    policy.save_pretrained(tmp_path)
    data = json.loads((tmp_path / "config.json").read_text())
    del data["segment_anchor_half_heights"]
    (tmp_path / "config.json").write_text(json.dumps(data))
    old = ForceMapPolicy.from_pretrained(tmp_path)
    assert old.config.segment_anchor_half_heights == []
    assert all(seg.anchor_half_height == 0.0 for seg in old.skill.segments)
    data["segment_anchor_half_heights"] = [0.1]
    (tmp_path / "config.json").write_text(json.dumps(data))
    with pytest.raises(ValueError, match="segment_anchor_half_heights"):
        ForceMapPolicy.from_pretrained(tmp_path)


def _grasp_height(policy, env, seed: int) -> tuple[float, dict]:
    """TCP height above the object's centre (m) when the gripper command, once opened (the push is
    made with the hand closed), passes 0.5, and the episode's last info."""
    import torch
    from lerobot.envs.utils import preprocess_observation

    from lerobot_forcemap import layout

    obs, info = env.reset(seed=seed)
    policy.reset()
    height, opened, done = None, False, False
    while not done:
        with torch.inference_mode():
            action = policy.select_action(preprocess_observation(obs)).numpy().reshape(-1)
        opened = opened or action[layout.ACTION_GRIPPER] < 0.1
        if height is None and opened and action[layout.ACTION_GRIPPER] > 0.5:
            height = float(obs[layout.ENV_EE_POSE][2] - obs[layout.ENV_STATE][2])
        obs, _, terminated, truncated, info = env.step(action.astype(np.float32))
        done = terminated or truncated
    return height, info


@needs_dataset
def test_the_banana_is_grasped_lower_than_the_book_was(policy):
    from lerobot_forcemap.envs import make

    env = make("grasp_push", render_mode=None, object="banana", randomize="wide")
    try:
        policy.config.scale_grasp_height = False
        flat, _ = _grasp_height(policy, env, seed=2000)  # a tuning seed, not an evaluation seed
        policy.config.scale_grasp_height = True
        low, info = _grasp_height(policy, env, seed=2000)
    finally:
        policy.config.scale_grasp_height = True
        env.close()
    assert info["is_success"], info["termination_reason"]
    assert flat - low > 0.005  # the unscaled grasp closes near the banana's top (1.8 cm above its centre)
