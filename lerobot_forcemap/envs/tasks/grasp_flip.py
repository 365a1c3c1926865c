"""``grasp_flip``: flip a standing carton over onto its side, then grasp it and lift it (Kinova Gen3).

Scene: a tall carton (6 x 8 x 18 cm, 200 g) standing on the table. The hand, closed to a fist,
pushes its upper part sideways (+y): it tips about its bottom edge (tipping needs ~0.5 N at 14 cm,
sliding 1.6 N) and falls onto its side, long axis along y; then the hand grasps it across its 6 cm
width and lifts it.

Success test: the carton was flipped (long axis within 15 degrees of horizontal) while on the table,
and afterwards its lowest point stayed >= 5 cm above the table for 1 s (see ``tasks/grasping.py``;
unseen objects: lifted and held only). Protective stop: contact force > 60 N or a fingertip force
> 40 N. Randomised: object centre +-2 cm in x and y, +-6 degrees of yaw; TCP start +-5 mm.
Objects (``object=``): ``carton`` (demonstration), ``apple``, ``banana``.
environment_state: object state (``tasks/grasping.py``).
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np

from ..base_env import ForceTaskEnv
from .base import TaskSpec
from .grasping import GraspTask, yaw_quat

SPEC = TaskSpec(
    name="grasp_flip",
    env_id="GraspFlip-v0",
    entry_point="lerobot_forcemap.envs.tasks.grasp_flip:GraspFlipEnv",
    description="Flip the carton over onto its side, then grasp it and lift it.",
    max_episode_steps=400,  # 20 s at 20 Hz
    anchor="obj",
    demonstrator="lerobot_forcemap.envs.demonstrators.grasp_flip:GraspFlipDemonstrator",
    robot="gen3",
    objects=("carton", "apple", "banana"),
)

OBJECT_NOMINAL_XY = (0.48, -0.06)
OBJECT_RANDOM_XY = 0.02
OBJECT_RANDOM_YAW = np.deg2rad(6.0)
FLIPPED_ANGLE = np.deg2rad(15.0)


class GraspFlipTask(GraspTask):
    spec: ClassVar[TaskSpec] = SPEC
    pregrasp_name: ClassVar[str] = "flipped"
    state_names: ClassVar[tuple[str, ...]] = GraspTask.object_state_names

    def initial_object_pose(self, rng):
        xy = np.array(OBJECT_NOMINAL_XY)
        yaw = 0.0
        if rng is not None:
            xy = xy + rng.uniform(-OBJECT_RANDOM_XY, OBJECT_RANDOM_XY, size=2)
            yaw = rng.uniform(-OBJECT_RANDOM_YAW, OBJECT_RANDOM_YAW)
        return xy, yaw_quat(yaw)

    def pregrasp_achieved(self, pos, rot) -> bool:
        return bool(abs(rot[2, 2]) <= np.sin(FLIPPED_ANGLE))  # the carton's long axis (local z) horizontal


class GraspFlipEnv(ForceTaskEnv):
    """``lerobot_forcemap/GraspFlip-v0``; ``object=`` one of ``SPEC.objects`` (default ``carton``)."""

    task_class = GraspFlipTask
