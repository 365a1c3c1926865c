"""MuJoCo force tasks as gymnasium envs, recorded and evaluated through LeRobot.

Importing this package sets ``MUJOCO_GL=egl`` unless already set (headless rendering; it must happen
before ``import mujoco``), imports the task files and registers their gym ids
(``lerobot_forcemap/Press-v0``, ``Erase-v0``, ``PegInHole-v0``, ``GraspPush-v0``, ``GraspFlip-v0``).

    import lerobot_forcemap.envs as E
    env = E.make("press")                                  # = gym.make("lerobot_forcemap/Press-v0")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(action)   # action: layout.ACTION_NAMES

``docs/envs.md`` describes the scenes, robots, controller, sensing, the tasks and their success tests,
the demonstrators, the episode loop (``rollout.py``), the LeRobot env types and how to add a task.
"""

from __future__ import annotations

import os

os.environ.setdefault("MUJOCO_GL", "egl")

from .registration import TASKS, TaskSpec, env_class, make, register_task, task_spec  # noqa: E402

__all__ = ["TASKS", "TaskSpec", "env_class", "make", "register_task", "task_spec"]
