"""Seeded scripted demonstrators: a "human" per task, with noise and the force habits of the paper.

One file per task (``TaskSpec.demonstrator`` names its class), over the shared pieces of ``base.py``
(minimum-jerk paths, smooth hand noise, :class:`ScriptedDemonstrator`) and, for the Gen3 tasks,
``grasping.py``. :func:`make_demonstrator` builds a task's demonstrator from a generator or an int
seed; :func:`run_demonstration` rolls one with the episode loop (``envs/rollout.py``).
"""

from __future__ import annotations

import importlib

from ..registration import TASKS, task_spec
from .base import (
    DemoFrame,
    PathPlan,
    ScriptedDemonstrator,
    Segment,
    SmoothNoise,
    min_jerk,
    move_duration,
    run_demonstration,
)

__all__ = [
    "DEMONSTRATORS",
    "DemoFrame",
    "PathPlan",
    "ScriptedDemonstrator",
    "Segment",
    "SmoothNoise",
    "demonstrator_class",
    "make_demonstrator",
    "min_jerk",
    "move_duration",
    "run_demonstration",
]


def demonstrator_class(task: str) -> type[ScriptedDemonstrator]:
    """The scripted demonstrator class of ``task`` (its ``TaskSpec.demonstrator``)."""
    module, name = task_spec(task).demonstrator.split(":")
    return getattr(importlib.import_module(module), name)


def make_demonstrator(task: str, rng, **kwargs) -> ScriptedDemonstrator:
    """``task``'s demonstrator seeded by ``rng`` (a ``numpy.random.Generator`` or an int seed)."""
    return demonstrator_class(task)(rng, **kwargs)


#: task name -> demonstrator class, for every registered task
DEMONSTRATORS: dict[str, type[ScriptedDemonstrator]] = {name: demonstrator_class(name) for name in TASKS}
