"""The task registry: each task's :class:`TaskSpec`, read from its task file, and its gym id.

Importing this module imports the task files listed in :data:`TASK_MODULES` (and so MuJoCo) and
registers their gym ids. Everything that needs to know about the tasks (the LeRobot env types,
``forcemap record`` / ``eval``, the experiments) reads :data:`TASKS` or :func:`task_spec`.
"""

from __future__ import annotations

import importlib

import gymnasium as gym

from .._validation import check_choice
from .tasks.base import NAMESPACE, TaskSpec

__all__ = [
    "NAMESPACE",
    "TASKS",
    "TASK_MODULES",
    "TaskSpec",
    "env_class",
    "make",
    "object_kwargs",
    "register_task",
    "task_spec",
]

#: the task files of ``envs/tasks/``, each defining ``SPEC``; a new task adds its module here
TASK_MODULES = ("press", "erase", "peg_in_hole", "grasp_push", "grasp_flip")

#: task name -> spec, in registration order
TASKS: dict[str, TaskSpec] = {}


def register_task(spec: TaskSpec) -> TaskSpec:
    """Add ``spec`` to :data:`TASKS` and register its gym id (for a task defined outside ``envs/tasks``)."""
    if spec.name in TASKS and TASKS[spec.name] != spec:
        raise ValueError(f"task {spec.name!r}: already registered as {TASKS[spec.name]}")
    TASKS[spec.name] = spec
    if spec.gym_id not in gym.registry:
        gym.register(id=spec.gym_id, entry_point=spec.entry_point, max_episode_steps=spec.max_episode_steps)
    return spec


def task_spec(task: str) -> TaskSpec:
    """The spec of a registered task (``ValueError`` naming ``task`` for an unknown one)."""
    return TASKS[check_choice("task", task, TASKS)]


def env_class(task: str) -> type[gym.Env]:
    """The gym env class of ``task``."""
    module, name = task_spec(task).entry_point.split(":")
    return getattr(importlib.import_module(module), name)


def object_kwargs(task: str, object_name: str | None, name: str = "object") -> dict[str, str]:
    """``{"object": object_name}`` for a task with objects, ``{}`` for ``None``; ``ValueError`` naming
    ``name`` for an object the task does not have (checked before any env is made)."""
    if object_name is None:
        return {}
    return {"object": task_spec(task).check_object(object_name, name)}


def make(task: str, **kwargs) -> gym.Env:
    """``gym.make`` by task name (``"press"``, ``"erase"``, ``"peg_in_hole"``, ...)."""
    return gym.make(task_spec(task).gym_id, **kwargs)


for _module in TASK_MODULES:
    register_task(importlib.import_module(f"{__package__}.tasks.{_module}").SPEC)

#: the twin of a recording (``envs/twin``): a gym id, not a task of TASKS (it has no demonstrator; its
#: scene is the ``twin`` kwarg, and its time limit the kwarg ``max_episode_steps``)
TWIN_GYM_ID = f"{NAMESPACE}/Twin-v0"
if TWIN_GYM_ID not in gym.registry:
    gym.register(id=TWIN_GYM_ID, entry_point="lerobot_forcemap.envs.tasks.twin:TwinEnv")
