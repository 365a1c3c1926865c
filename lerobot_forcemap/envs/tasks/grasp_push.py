"""``grasp_push``: push a flat book upright against a low wall, then grasp it and lift it (Kinova Gen3).

Scene: a low wall (a stop strip 3 mm high, 4 cm deep, 40 cm long, its front face across x) and the
book (18 x 12 x 5 cm, 250 g) lying flat in front of it, long side toward the wall. Flat, the book is
wider than the open hand (11.4 cm between the pads) both ways and too thin to pinch from above. Pushed
into the wall at its rear edge it pivots about its front-bottom edge, held by the wall (a taller wall
would jam the pivot: the front face would have to move into it), and stands up; pushed to about 85
degrees it stays upright at the wall. Then the hand grasps it across its 5 cm thickness.

Success test: the book stood upright (long axis within 15 degrees of vertical) while on the table,
and afterwards its lowest point stayed >= 5 cm above the table for 1 s (see ``tasks/grasping.py``;
unseen objects: lifted and held only). Protective stop: contact force > 60 N or a fingertip force
> 40 N. Randomised: wall position +-1 cm in x; object 2-5 cm from the wall, +-2 cm in y, +-3 degrees
of yaw; TCP start +-5 mm. Objects (``object=``): ``book`` (demonstration), ``apple``, ``banana``
(placed where the book's centre would be).
environment_state: object state (``tasks/grasping.py``), then the wall's front-top edge centre
``wall_x, wall_y, wall_z`` and its orientation ``wall_qw .. wall_qz`` (base frame; turned by the yaw of
``randomize="wide"``).
"""

from __future__ import annotations

from typing import ClassVar

import mujoco
import numpy as np

from ..base_env import ForceTaskEnv
from ..robots import ENV_CONAFFINITY, ENV_CONTYPE
from ..variation import VariedParts
from .base import TaskSpec
from .grasping import GRASP_OBJECTS, GraspTask, yaw_quat

SPEC = TaskSpec(
    name="grasp_push",
    env_id="GraspPush-v0",
    entry_point="lerobot_forcemap.envs.tasks.grasp_push:GraspPushEnv",
    description="Push the book upright against the wall, then grasp it and lift it.",
    max_episode_steps=500,  # 25 s at 20 Hz
    anchor="obj",
    demonstrator="lerobot_forcemap.envs.demonstrators.grasp_push:GraspPushDemonstrator",
    robot="gen3",
    objects=("book", "apple", "banana"),
)

WALL_NOMINAL_X = 0.60
WALL_RANDOM_X = 0.01
WALL_HEIGHT = 0.003
WALL_DEPTH = 0.04
WALL_HALF_LENGTH = 0.2
GAP_RANGE = (0.02, 0.05)  # m, book front face to the wall
OBJECT_RANDOM_Y = 0.02
OBJECT_RANDOM_YAW = np.deg2rad(3.0)
UPRIGHT_ANGLE = np.deg2rad(15.0)


class GraspPushTask(GraspTask):
    spec: ClassVar[TaskSpec] = SPEC
    pregrasp_name: ClassVar[str] = "upright"
    fixture_bodies: ClassVar[tuple[str, ...]] = ("wall",)
    varied: ClassVar[VariedParts] = VariedParts(bodies=("wall",), free_joints=("object_free",))
    state_names: ClassVar[tuple[str, ...]] = (
        *GraspTask.object_state_names, "wall_x", "wall_y", "wall_z", "wall_qw", "wall_qx", "wall_qy", "wall_qz",
    )  # fmt: skip

    def add_fixtures(self, spec: mujoco.MjSpec) -> None:
        wall = spec.worldbody.add_body(name="wall", pos=[WALL_NOMINAL_X, 0.0, 0.0])
        wall.add_geom(
            name="wall", type=mujoco.mjtGeom.mjGEOM_BOX, size=[WALL_DEPTH / 2, WALL_HALF_LENGTH, WALL_HEIGHT / 2],
            pos=[WALL_DEPTH / 2, 0.0, WALL_HEIGHT / 2], rgba=[0.45, 0.45, 0.5, 1], friction=[0.8, 0.005, 0.0001],
            contype=ENV_CONTYPE, conaffinity=ENV_CONAFFINITY,
        )  # fmt: skip

    def bind(self, model, index, frame) -> None:
        super().bind(model, index, frame)
        self._wall_body = model.body("wall").id

    def randomize_fixtures(self, model, rng) -> None:
        x = WALL_NOMINAL_X + (rng.uniform(-WALL_RANDOM_X, WALL_RANDOM_X) if rng is not None else 0.0)
        model.body_pos[self._wall_body] = [x, 0.0, 0.0]

    def wall_edge_world(self) -> np.ndarray:
        """Centre of the wall's front-top edge (world, m)."""
        return self.model.body_pos[self._wall_body] + np.array([0.0, 0.0, WALL_HEIGHT])

    def initial_object_pose(self, rng):
        book = GRASP_OBJECTS["book"].half_extents
        gap = rng.uniform(*GAP_RANGE) if rng is not None else float(np.mean(GAP_RANGE))
        y = rng.uniform(-OBJECT_RANDOM_Y, OBJECT_RANDOM_Y) if rng is not None else 0.0
        yaw = rng.uniform(-OBJECT_RANDOM_YAW, OBJECT_RANDOM_YAW) if rng is not None else 0.0
        x = self.model.body_pos[self._wall_body][0] - book[0] - gap  # where the book's centre would be
        return np.array([x, y]), yaw_quat(yaw)

    def pregrasp_achieved(self, pos, rot) -> bool:
        return bool(abs(rot[2, 0]) >= np.cos(UPRIGHT_ANGLE))  # the book's long axis (local x) vertical

    def fixture_state(self) -> np.ndarray:
        quat = self.frame.quat_to_base(self.model.body_quat[self._wall_body])
        return np.concatenate([self.frame.pos_to_base(self.wall_edge_world()), quat])


class GraspPushEnv(ForceTaskEnv):
    """``lerobot_forcemap/GraspPush-v0``; ``object=`` one of ``SPEC.objects`` (default ``book``)."""

    task_class = GraspPushTask
