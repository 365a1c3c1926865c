"""Shared fixtures of the env tests: scripted demonstrations rolled once per task and reused."""

from __future__ import annotations

import numpy as np
import pytest

import lerobot_forcemap.envs as E
from lerobot_forcemap.envs.demonstrators import make_demonstrator, run_episode

N_DEMO_SEEDS = 20
TASK_NAMES = ("press", "erase", "peg_in_hole")


def roll_demos(task: str, seeds) -> list[dict]:
    env = E.make(task)
    names = env.unwrapped.state_names["environment_state"]
    out = []
    for seed in seeds:
        demo = make_demonstrator(task, np.random.default_rng(10_000 + seed), state_names=names)
        frames, info = run_episode(env, demo, seed)
        out.append(
            {
                "seed": seed,
                "info": info,
                "actions": np.array([f[1] for f in frames]),
                "force": np.array([f[0]["force"] for f in frames]),
                "phase": np.array([demo.phases[f[2]] for f in frames]),
                "params": demo.describe(),
            }
        )
    env.close()
    return out


@pytest.fixture(scope="session")
def demo_rollouts():
    """{task: [20 rollouts]}; computed lazily per task on first use."""
    cache: dict[str, list[dict]] = {}

    def get(task: str) -> list[dict]:
        if task not in cache:
            cache[task] = roll_demos(task, range(N_DEMO_SEEDS))
        return cache[task]

    return get
