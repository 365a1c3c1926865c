"""Checks shared by the env tests."""

import numpy as np


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
