"""The episode loop: every demonstration, recording, evaluation and experiment episode runs here.

    episode = run_episode(env, act, seed, reset=..., trace=..., render=..., max_steps=...)

``env.reset(seed=seed)``, then ``reset(obs)`` (the actor's reset hook), then per control step
``action = act(obs)``, ``env.step(action as float32)`` and ``trace(step)``, until the env terminates or
truncates (``gym.make`` adds the task's time limit) or ``max_steps`` steps ran. What a caller records
(dataset columns, an evaluation trace, force samples) is what its ``trace`` returns per step; the
loop itself is the same for all of them. No torch or LeRobot here: the caller's ``act`` wraps a policy.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

__all__ = ["Episode", "Step", "run_episode"]


@dataclass(frozen=True)
class Step:
    """One control step, handed to ``trace`` after ``env.step``.

    ``index``: 0-based step; ``obs`` / ``info``: what the action was chosen from (``env.reset``'s for
    step 0); ``action``: what ``act`` returned (the env got it as float32); ``next_info``: the info
    ``env.step`` returned.
    """

    index: int
    obs: dict[str, Any]
    info: dict[str, Any]
    action: Any
    next_info: dict[str, Any]


@dataclass
class Episode:
    """What one episode ended with.

    ``steps``: control steps run; ``obs`` / ``info``: the last observation and info; ``terminated`` /
    ``truncated``: the last step's flags (both False when ``max_steps`` ended it); ``wall_s``: wall time
    of the steps (from after the reset hook and the first frame); ``trace``: ``trace(step)`` per step;
    ``frames``: ``env.render()`` after the reset, then after each step (``render=True``).
    """

    seed: int
    steps: int
    obs: dict[str, Any]
    info: dict[str, Any]
    terminated: bool = False
    truncated: bool = False
    wall_s: float = 0.0
    trace: list[Any] = field(default_factory=list)
    frames: list[np.ndarray] = field(default_factory=list)


def run_episode(
    env,
    act: Callable[[dict[str, Any]], Any],
    seed: int,
    *,
    reset: Callable[[dict[str, Any]], None] | None = None,
    trace: Callable[[Step], Any] | None = None,
    render: bool = False,
    max_steps: int | None = None,
) -> Episode:
    """Run one episode of ``env`` from ``env.reset(seed=seed)`` (see the module docstring).

    ``act(obs) -> action (8,)``; ``reset(obs)``: called once after the env reset; ``trace(step)``: its
    return value is appended to ``Episode.trace``; ``render``: collect frames; ``max_steps``: stop
    after that many steps (None: when the env ends the episode).
    """
    obs, info = env.reset(seed=seed)
    if reset is not None:
        reset(obs)
    episode = Episode(seed=int(seed), steps=0, obs=obs, info=info)
    if render:
        episode.frames.append(env.render())
    t0 = time.perf_counter()
    while max_steps is None or episode.steps < max_steps:
        action = act(obs)
        next_obs, _, terminated, truncated, next_info = env.step(np.asarray(action, dtype=np.float32))
        if trace is not None:
            episode.trace.append(trace(Step(episode.steps, obs, info, action, next_info)))
        if render:
            episode.frames.append(env.render())
        obs, info = next_obs, next_info
        episode.steps += 1
        if terminated or truncated:
            episode.terminated, episode.truncated = bool(terminated), bool(truncated)
            break
    episode.obs, episode.info = obs, info
    episode.wall_s = time.perf_counter() - t0
    return episode
