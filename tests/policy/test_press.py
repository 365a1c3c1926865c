"""The one-shot policy in the MuJoCo press task: success, lower force than the demonstration, and
re-anchoring to a new start pose and a moved button (slow: ~100 simulated episodes)."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def loaded(press_checkpoint):
    from lerobot_forcemap.evaluation.evaluate import load_policy

    return load_policy(press_checkpoint)


@pytest.fixture(scope="module")
def env():
    from lerobot_forcemap.envs import make

    e = make("press", render_mode=None)
    yield e
    e.close()


def _demo_figures(dataset):
    """Max / mean contact force and button position of demonstration 0 (the one the policy learned)."""
    meta = json.loads((dataset / "meta" / "forcemap_episodes.json").read_text())["episodes"][0]
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    ds = LeRobotDataset("local/press", root=dataset, episodes=[0])
    button = np.asarray(ds.hf_dataset.with_format("numpy")["observation.environment_state"])[0, :3]
    return meta["max_contact_force"], meta["mean_contact_force"], button


def _run(env, policy, pre, post, obs, max_steps=200):
    import torch
    from lerobot.envs.utils import preprocess_observation

    policy.reset()
    first = None
    info = {}
    for _ in range(max_steps):
        batch = pre({**preprocess_observation(obs), "task": [env.unwrapped.task_description]})
        with torch.inference_mode():
            action = post(policy.select_action(batch)).numpy().reshape(-1)
        first = action if first is None else first
        obs, _, terminated, truncated, info = env.step(action.astype(np.float32))
        if terminated or truncated:
            break
    return info, first


def test_press_success_and_less_force_than_the_demonstration(press_checkpoint, press_dataset):
    from lerobot_forcemap.evaluation.evaluate import evaluate_policy

    demo_max, demo_mean, _ = _demo_figures(press_dataset)
    records = evaluate_policy(press_checkpoint, "press", 20, 1000, progress=False)
    success = np.mean([r["success"] for r in records])
    assert success >= 0.9, [r["termination_reason"] for r in records]
    assert not any(r["protective_stop"] for r in records)
    assert max(r["max_contact_force"] for r in records) < demo_max
    assert np.mean([r["mean_contact_force"] for r in records]) < demo_mean


def test_new_start_pose(loaded, env):
    policy, pre, post = loaded
    for seed, start in ((11, (0.35, 0.08, 0.21)), (12, (0.47, -0.09, 0.12))):
        obs, _ = env.reset(seed=seed)
        hold = np.array([*start, *obs["ee_pose"][3:7], 1.0], dtype=np.float32)
        for _ in range(40):  # drive the arm somewhere the demonstration never started from
            obs, *_ = env.step(hold)
        assert np.linalg.norm(obs["ee_pose"][:3] - np.array(start)) < 0.01
        info, first = _run(env, policy, pre, post, obs, max_steps=150)
        np.testing.assert_allclose(first[:3], obs["ee_pose"][:3], atol=1e-5)  # starts where the robot is
        assert info["is_success"], info["termination_reason"]


def test_moved_button_needs_reanchoring(loaded, env, press_dataset):
    policy, pre, post = loaded
    _, _, demo_button = _demo_figures(press_dataset)
    offsets = []
    for seed in range(2000, 2200):
        obs, _ = env.reset(seed=seed)
        offsets.append((np.linalg.norm(obs["environment_state"][:2] - demo_button[:2]), seed))
    far = [s for d, s in sorted(offsets)[-3:]]
    assert min(d for d, _ in sorted(offsets)[-3:]) > 0.025  # well beyond the 18 mm cap radius
    for seed in far:
        obs, _ = env.reset(seed=seed)
        info, _ = _run(env, policy, pre, post, obs)
        assert info["is_success"], (seed, info["termination_reason"])
    policy.config.reanchor = False  # replay the demonstration where it happened
    try:
        for seed in far:
            obs, _ = env.reset(seed=seed)
            info, _ = _run(env, policy, pre, post, obs)
            assert not info["is_success"], seed
    finally:
        policy.config.reanchor = True


def test_env_control_rate_equals_the_dataset_fps(loaded, env):
    """select_action advances 1/fps of the dataset per call: only right if the env steps at that rate."""
    from lerobot.envs.configs import EnvConfig

    policy, _, _ = loaded
    assert env.unwrapped.metadata["render_fps"] == policy.config.fps == 20.0
    assert EnvConfig.get_choice_class("forcemap_press")().fps == policy.config.fps
