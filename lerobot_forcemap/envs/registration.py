"""Gym ids of the tasks, registered on ``import lerobot_forcemap.envs`` (no MuJoCo import here).

Each entry: task name -> (gym id, entry point, max episode steps at the task's control rate). The
step counts equal the tasks' ``max_episode_steps`` (a test checks it); they live here too so that
registering does not import MuJoCo.
"""

from __future__ import annotations

from dataclasses import dataclass

import gymnasium as gym

NAMESPACE = "lerobot_forcemap"


@dataclass(frozen=True)
class TaskEntry:
    gym_id: str
    entry_point: str
    max_episode_steps: int
    control_hz: float = 20.0


TASKS: dict[str, TaskEntry] = {
    "press": TaskEntry(f"{NAMESPACE}/Press-v0", "lerobot_forcemap.envs.tasks.press:PressEnv", 200),
    "erase": TaskEntry(f"{NAMESPACE}/Erase-v0", "lerobot_forcemap.envs.tasks.erase:EraseEnv", 600),
    "peg_in_hole": TaskEntry(
        f"{NAMESPACE}/PegInHole-v0", "lerobot_forcemap.envs.tasks.peg_in_hole:PegInHoleEnv", 400
    ),
    # Kinova Gen3 + three-finger gripper; env kwarg ``object=`` picks the object (tasks/grasping.py)
    "grasp_push": TaskEntry(
        f"{NAMESPACE}/GraspPush-v0", "lerobot_forcemap.envs.tasks.grasp_push:GraspPushEnv", 500
    ),
    "grasp_flip": TaskEntry(
        f"{NAMESPACE}/GraspFlip-v0", "lerobot_forcemap.envs.tasks.grasp_flip:GraspFlipEnv", 400
    ),
}


def register_task(name: str, entry: TaskEntry) -> None:
    """Add a task (e.g. the Gen3 grasping tasks) to :data:`TASKS` and register its gym id."""
    if name in TASKS and TASKS[name] != entry:
        raise ValueError(f"task {name!r} is already registered as {TASKS[name]}")
    TASKS[name] = entry
    if entry.gym_id not in gym.registry:
        gym.register(
            id=entry.gym_id, entry_point=entry.entry_point, max_episode_steps=entry.max_episode_steps
        )


def register_all() -> None:
    for name, entry in list(TASKS.items()):
        register_task(name, entry)


def task_entry(task: str) -> TaskEntry:
    try:
        return TASKS[task]
    except KeyError:
        raise ValueError(f"unknown task {task!r}; known: {sorted(TASKS)}") from None


def env_class(task: str) -> type[gym.Env]:
    """The env class of ``task`` (imports its module, and so MuJoCo)."""
    import importlib

    module, name = task_entry(task).entry_point.split(":")
    return getattr(importlib.import_module(module), name)


def object_kwargs(task: str, object_name: str | None, what: str = "object") -> dict[str, str]:
    """``{"object": object_name}`` for a task whose env takes an object (the grasping tasks), ``{}`` for
    ``None``; ``ValueError`` naming ``what`` for a task without objects (``gym.make`` would raise a bare
    ``TypeError``)."""
    if object_name is None:
        return {}
    import inspect

    if "object" not in inspect.signature(env_class(task)).parameters:
        raise ValueError(
            f"{what}: task {task!r} has no objects to choose from (object= is for the grasping tasks)"
        )
    return {"object": object_name}


def make(task: str, **kwargs) -> gym.Env:
    """``gym.make`` by task name (``"press"``, ``"erase"``, ``"peg_in_hole"``, ...)."""
    register_all()
    return gym.make(task_entry(task).gym_id, **kwargs)
