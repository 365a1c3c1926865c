"""``press``: push a spring button past its switch point with the closed gripper, then let go.

Button: a static housing and a cap on a vertical slide (contacts between the two excluded, else the
housing pushes the cap: a 15-20 N phantom force). Spring 800 N/m with 2 mm preload (1.6 N at rest),
travel 8 mm to a hard stop (8 N at the bottom); the switch point is at 6 mm (6.4 N).

Success test: the cap travelled >= 6 mm (switch point) at some time, and afterwards it was released
(travel < 1 mm and contact force < 0.5 N): the episode then terminates as a success.
Protective stop: filtered contact force > 100 N.
Randomised: button position +-2 cm in x and y; TCP start +-5 mm.
environment_state: the press point (cap top centre at rest, base frame) as a pose, then the cap travel (m).
"""

from __future__ import annotations

from typing import ClassVar

import mujoco
import numpy as np

from ..control import Workspace
from ..robots import ENV_CONAFFINITY, ENV_CONTYPE
from ..scene import ContactMonitor
from ..variation import VariedParts
from .base import ForceTask, StartState, StepBlock, TaskSpec, TaskStatus

SPEC = TaskSpec(
    name="press",
    env_id="Press-v0",
    entry_point="lerobot_forcemap.envs.tasks.press:PressEnv",
    description="Press the red button until it clicks, then let go.",
    max_episode_steps=200,  # 10 s at 20 Hz
    anchor="button",
    demonstrator="lerobot_forcemap.envs.demonstrators.press:PressDemonstrator",
)

BUTTON_NOMINAL_XY = (0.5, 0.0)
BUTTON_RANDOM_XY = 0.02  # m, uniform +-
HOUSING_RADIUS = 0.03
HOUSING_HEIGHT = 0.015
CAP_RADIUS = 0.018
CAP_HEIGHT = 0.012
TRAVEL = 0.008  # m to the hard stop
SWITCH_TRAVEL = 0.006  # m
RELEASE_TRAVEL = 0.001  # m
RELEASE_FORCE = 0.5  # N
SPRING_STIFFNESS = 800.0  # N/m
SPRING_PRELOAD = 0.002  # m (springref above the upper limit)
PRESS_POINT_Z = HOUSING_HEIGHT + CAP_HEIGHT  # cap top at rest, 27 mm above the table
START_POS = (0.42, 0.0, 0.15)
START_RANDOM = 0.005  # m, uniform +-
CAP_RGBA = np.array([0.85, 0.15, 0.1, 1.0])
CAP_PRESSED_RGBA = np.array([0.1, 0.75, 0.2, 1.0])


class PressTask(ForceTask):
    spec: ClassVar[TaskSpec] = SPEC
    force_limit: ClassVar[float] = 100.0
    workspace: ClassVar[Workspace] = Workspace(low=(0.25, -0.3, -0.1), high=(0.75, 0.3, 0.45))
    state_names: ClassVar[tuple[str, ...]] = (
        "button_x", "button_y", "button_z", "button_qw", "button_qx", "button_qy", "button_qz", "button_travel",
    )  # fmt: skip
    sensor_names: ClassVar[tuple[str, ...]] = ("button_pos",)
    varied: ClassVar[VariedParts] = VariedParts(bodies=("button_base",), springs=("button_slide",))
    success_test: ClassVar[str] = (
        f"cap travel >= {SWITCH_TRAVEL * 1e3:.0f} mm (switch point), then released "
        f"(travel < {RELEASE_TRAVEL * 1e3:.0f} mm and contact force < {RELEASE_FORCE} N)"
    )

    def contacts(self) -> ContactMonitor:
        return ContactMonitor(environment=("table", "button_base", "button_cap"))

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        base = spec.worldbody.add_body(name="button_base", pos=[*BUTTON_NOMINAL_XY, 0.0])
        base.add_geom(
            name="button_housing",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[HOUSING_RADIUS, HOUSING_HEIGHT / 2, 0],
            pos=[0, 0, HOUSING_HEIGHT / 2],
            rgba=[0.2, 0.2, 0.22, 1],
            contype=ENV_CONTYPE,
            conaffinity=ENV_CONAFFINITY,
        )
        cap = base.add_body(name="button_cap", pos=[0, 0, HOUSING_HEIGHT])
        cap.add_joint(
            name="button_slide",
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[0, 0, 1],
            range=[-TRAVEL, 0.0],
            stiffness=SPRING_STIFFNESS,
            springref=SPRING_PRELOAD,
            damping=2.0,
            solref_limit=[0.004, 1.0],
        )
        cap.add_geom(
            name="button_cap",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER,
            size=[CAP_RADIUS, CAP_HEIGHT / 2, 0],
            pos=[0, 0, CAP_HEIGHT / 2],
            mass=0.02,
            rgba=CAP_RGBA.tolist(),
            friction=[0.8, 0.005, 0.0001],
            contype=ENV_CONTYPE,
            conaffinity=ENV_CONAFFINITY,
        )
        spec.add_exclude(bodyname1="button_base", bodyname2="button_cap")

    def add_sensors(self, spec: mujoco.MjSpec, prefix: str) -> None:
        spec.add_sensor(
            name="button_pos",
            type=mujoco.mjtSensor.mjSENS_JOINTPOS,
            objtype=mujoco.mjtObj.mjOBJ_JOINT,
            objname="button_slide",
        )

    def bind(self, model, index, frame) -> None:
        super().bind(model, index, frame)
        self._base_body = model.body("button_base").id
        self._cap_geom = model.geom("button_cap").id
        self._slide_qpos = int(model.jnt_qposadr[model.joint("button_slide").id])
        self._pos_col = index.extra["button_pos"].start

    def reset(self, model, data, rng: np.random.Generator) -> StartState:
        xy = np.array(BUTTON_NOMINAL_XY)
        start = np.array(START_POS)
        if self.randomize:
            xy = xy + rng.uniform(-BUTTON_RANDOM_XY, BUTTON_RANDOM_XY, size=2)
            start = start + rng.uniform(-START_RANDOM, START_RANDOM, size=3)
        model.body_pos[self._base_body] = [xy[0], xy[1], 0.0]
        model.geom_rgba[self._cap_geom] = CAP_RGBA
        self.max_travel = 0.0
        self.travel = 0.0
        self.pressed = False
        self.released = False
        return StartState(tcp_pos=start, tcp_quat=np.array(self.robot.tool_down_quat, float), gripper=1.0)

    def press_point(self) -> np.ndarray:
        """Cap top centre at rest, base frame (m)."""
        world = self.model.body_pos[self._base_body] + np.array([0.0, 0.0, PRESS_POINT_Z])
        return self.frame.pos_to_base(world)

    def environment_state(self, data) -> np.ndarray:
        quat = self.frame.quat_to_base(np.array([1.0, 0.0, 0.0, 0.0]))
        travel = max(0.0, -float(data.qpos[self._slide_qpos]))
        return np.concatenate([self.press_point(), quat, [travel]])

    def update(self, data, block: StepBlock) -> TaskStatus:
        travel = np.maximum(0.0, -block.sensordata[:, self._pos_col])
        self.travel = float(travel[-1])
        self.max_travel = max(self.max_travel, float(travel.max()))
        if not self.pressed and self.max_travel >= SWITCH_TRAVEL:
            self.pressed = True
            self.model.geom_rgba[self._cap_geom] = CAP_PRESSED_RGBA
        if self.pressed:
            force_now = float(np.linalg.norm(block.contact_force[-1]))
            self.released = self.travel < RELEASE_TRAVEL and force_now < RELEASE_FORCE
        return TaskStatus(
            success=self.pressed and self.released, failure_reason="" if self.pressed else "not_pressed"
        )

    def episode_metrics(self) -> dict[str, float]:
        return {
            "button_travel": self.travel,
            "max_button_travel": self.max_travel,
            "button_pressed": bool(self.pressed),
        }


# The gym entry point (SPEC.entry_point).
from ..base_env import ForceTaskEnv  # noqa: E402


class PressEnv(ForceTaskEnv):
    task_class = PressTask
