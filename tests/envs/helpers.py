"""Checks and rollouts shared by the env tests."""

import warnings

import numpy as np
from gymnasium.utils.env_checker import check_env

import lerobot_forcemap.envs as E
from lerobot_forcemap.envs.demonstrators import make_demonstrator, run_demonstration


def roll_demos(task: str, seeds, **env_kwargs) -> list[dict]:
    """One scripted demonstration per seed (demonstrator seeded 10000 + seed): info, frame count,
    actions, wrist force, per-finger forces (3, 3) when the robot has them, phases and parameters."""
    env = E.make(task, **env_kwargs)
    names = env.unwrapped.state_names["environment_state"]
    out = []
    for seed in seeds:
        demo = make_demonstrator(task, np.random.default_rng(10_000 + seed), state_names=names)
        episode = run_demonstration(env, demo, seed)
        frames = episode.trace
        record = {
            "seed": seed,
            "info": episode.info,
            "n": len(frames),
            "actions": np.array([f.action for f in frames]),
            "force": np.array([f.obs["force"] for f in frames]),
            "phase": np.array([demo.phases[f.phase_index] for f in frames]),
            "params": demo.describe(),
        }
        if "finger_force" in frames[0].obs:
            record["finger"] = np.array([f.obs["finger_force"] for f in frames]).reshape(len(frames), 3, 3)
        out.append(record)
    env.close()
    return out


def assert_seed_determinism(env, seed: int, steps: int = 10) -> None:
    """Two runs from ``reset(seed)`` with the same random actions give identical observations, and
    ``seed + 1`` gives a different scene."""
    runs = []
    for _ in range(2):
        obs, _ = env.reset(seed=seed)
        traj = [obs]
        rng = np.random.default_rng(0)
        for _ in range(steps):
            a = np.concatenate(
                [obs["ee_pose"][:3] + rng.uniform(-0.01, 0.01, 3), obs["ee_pose"][3:], [rng.uniform()]]
            )
            obs, *_ = env.step(a)
            traj.append(obs)
        runs.append(traj)
    for o1, o2 in zip(*runs, strict=True):
        for k in o1:
            np.testing.assert_array_equal(o1[k], o2[k])
    other, _ = env.reset(seed=seed + 1)
    assert not np.array_equal(other["environment_state"], runs[0][0]["environment_state"])


def check_task_env(task: str, **env_kwargs) -> None:
    """gymnasium's ``check_env`` (render check included) on a task. Two of its advisories are by
    design here and silenced, every other warning or error stands: the action is an absolute Cartesian
    pose in metres (the action layout datasets and policies share, not a normalised [-1, 1] box), and
    wrist and finger forces have no finite bound (a protective stop ends the episode instead)."""
    env = E.make(task, **env_kwargs)
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=".*symmetric and normalized space", category=UserWarning)
        warnings.filterwarnings("ignore", message=".*Box observation space m.*infinity", category=UserWarning)
        check_env(env.unwrapped, skip_render_check=False)
    env.close()
