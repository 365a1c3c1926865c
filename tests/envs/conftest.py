"""Shared fixtures of the env tests: scripted demonstrations rolled once per task and reused."""

from __future__ import annotations

import pytest

from .helpers import roll_demos

N_DEMO_SEEDS = 20
TASK_NAMES = ("press", "erase", "peg_in_hole")


@pytest.fixture(scope="session")
def demo_rollouts():
    """{task: [20 rollouts]}; computed lazily per task on first use."""
    cache: dict[str, list[dict]] = {}

    def get(task: str) -> list[dict]:
        if task not in cache:
            cache[task] = roll_demos(task, range(N_DEMO_SEEDS))
        return cache[task]

    return get
