"""What every scripted demonstrator shares: minimum-jerk paths, smooth hand noise, the base class.

A demonstrator is a policy over the env's observations (``act(obs) -> action`` in the layout of
``lerobot_forcemap.layout``). It reads the privileged object poses from ``environment_state`` (names
in ``env.unwrapped.state_names``) the way a person sees the scene, plans a timed path with
minimum-jerk segments, and adds smooth hand noise (a few random low-frequency sinusoids). ``phase`` /
``phase_index`` name the current phase (recorded into the datasets as ground-truth segment labels).
All randomness comes from the ``numpy.random.Generator`` given at construction (or an int seed).
"""

from __future__ import annotations

import abc
from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..._validation import check_real, fail, is_int
from ...layout import ACTION_DIM, ENV_STATE
from ..rollout import Episode, Step, run_episode

__all__ = [
    "DemoFrame",
    "PathPlan",
    "ScriptedDemonstrator",
    "Segment",
    "SmoothNoise",
    "min_jerk",
    "move_duration",
    "run_demonstration",
]


def min_jerk(s: np.ndarray | float) -> np.ndarray | float:
    """Minimum-jerk time scaling 10 s^3 - 15 s^4 + 6 s^5 on s in [0, 1]."""
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2)


def move_duration(a: np.ndarray, b: np.ndarray, base: float, max_speed: float = 0.15) -> float:
    """Duration of a minimum-jerk move: at least ``base``, and slow enough for ``max_speed`` at the peak."""
    return max(base, 1.875 * float(np.linalg.norm(np.asarray(b) - np.asarray(a))) / max_speed)


class SmoothNoise:
    """Band-limited hand noise: a sum of ``n`` sinusoids per axis with random frequency and phase.

    ``amplitude`` (per axis) is the standard deviation of the sum; frequencies uniform in ``freq_hz``.
    """

    def __init__(self, rng: np.random.Generator, amplitude: Sequence[float], freq_hz=(0.2, 1.5), n: int = 4):
        amp = np.asarray(amplitude, dtype=float)
        self.freq = rng.uniform(*freq_hz, size=(n, len(amp)))
        self.phase = rng.uniform(0, 2 * np.pi, size=(n, len(amp)))
        # each sinusoid has variance a^2/2; n of them sum to n a^2 / 2
        self.a = amp * np.sqrt(2.0 / n)

    def __call__(self, t: float) -> np.ndarray:
        return (self.a * np.sin(2 * np.pi * self.freq * t + self.phase)).sum(axis=0)


@dataclass(frozen=True)
class Segment:
    """A straight minimum-jerk move to ``target`` (base frame, m) over ``duration`` s, in ``phase``."""

    target: np.ndarray
    duration: float
    phase: str
    gripper: float | None = None  # command during the segment (None: keep)


class PathPlan:
    """Piecewise minimum-jerk path through segments, sampled by time (s from its start)."""

    def __init__(self, start: np.ndarray, segments: Sequence[Segment], gripper: float):
        self.start = np.asarray(start, dtype=float)
        self.segments = list(segments)
        self.t_end = np.cumsum([s.duration for s in self.segments])
        self.t_start = self.t_end - np.array([s.duration for s in self.segments])
        starts = [self.start] + [s.target for s in self.segments[:-1]]
        self.seg_start = [np.asarray(p, float) for p in starts]
        grips, g = [], gripper
        for s in self.segments:
            g = g if s.gripper is None else s.gripper
            grips.append(g)
        self.grippers = grips

    @property
    def duration(self) -> float:
        return float(self.t_end[-1]) if len(self.segments) else 0.0

    def sample(self, t: float) -> tuple[np.ndarray, float, int]:
        """Position, gripper command and segment index at time ``t`` (held at the end after the last)."""
        if not self.segments:
            return self.start.copy(), 0.0, 0
        i = int(np.searchsorted(self.t_end, t, side="right"))
        if i >= len(self.segments):
            return self.segments[-1].target.copy(), self.grippers[-1], len(self.segments) - 1
        seg = self.segments[i]
        s = (t - self.t_start[i]) / seg.duration if seg.duration > 0 else 1.0
        p = self.seg_start[i] + min_jerk(s) * (seg.target - self.seg_start[i])
        return p, self.grippers[i], i


class ScriptedDemonstrator(abc.ABC):
    """Base: holds the rng, the control period and the phase; subclasses plan in :meth:`reset`.

    ``rng``: a ``numpy.random.Generator`` or an int seed; ``control_hz``: the env's control rate;
    ``state_names``: the env's ``environment_state`` names (default: the task's).
    """

    task: ClassVar[str]
    phases: ClassVar[tuple[str, ...]]

    def __init__(self, rng: np.random.Generator | int, *, control_hz: float = 20.0, state_names=None):
        if not (isinstance(rng, np.random.Generator) or is_int(rng)):
            # default_rng(None) would draw OS entropy: a demonstration nobody could record again
            fail("rng", "be a numpy Generator or an int seed", rng)
        self.rng = rng if isinstance(rng, np.random.Generator) else np.random.default_rng(rng)
        self.dt = 1.0 / check_real("control_hz", control_hz, low=0.0, low_open=True, unit="Hz")
        self.state_names = tuple(state_names) if state_names is not None else None
        self.phase = self.phases[0]
        self.t = 0.0

    @property
    def phase_index(self) -> int:
        return self.phases.index(self.phase)

    def state(self, obs: dict, name: str) -> float:
        """A named entry of ``environment_state`` (names from the env's ``state_names``)."""
        names = self.state_names or self.default_state_names()
        return float(obs[ENV_STATE][names.index(name)])

    def default_state_names(self) -> tuple[str, ...]:
        from ..registration import env_class

        return env_class(self.task).task_class.state_names

    @abc.abstractmethod
    def reset(self, obs: dict) -> None: ...

    def describe(self) -> dict[str, float]:
        """This episode's sampled demonstrator parameters (recorded per episode)."""
        return {}

    @abc.abstractmethod
    def act(self, obs: dict) -> np.ndarray: ...

    def _action(self, pos: np.ndarray, quat: np.ndarray, gripper: float) -> np.ndarray:
        a = np.empty(ACTION_DIM, dtype=np.float32)
        a[0:3] = pos
        a[3:7] = quat
        a[7] = gripper
        return a


@dataclass(frozen=True)
class DemoFrame:
    """One step of a demonstration: the observation, the demonstrator's action and its phase index."""

    obs: dict
    action: np.ndarray
    phase_index: int


def run_demonstration(
    env, demonstrator: ScriptedDemonstrator, seed: int, *, max_steps: int | None = None
) -> Episode:
    """One demonstration with the episode loop; ``Episode.trace`` holds a :class:`DemoFrame` per step."""

    def frame(step: Step) -> DemoFrame:
        return DemoFrame(step.obs, step.action, demonstrator.phase_index)

    return run_episode(
        env, demonstrator.act, seed, reset=demonstrator.reset, trace=frame, max_steps=max_steps
    )
