"""The task interface: what a task adds to the shared scene / env machinery.

A task is a small class that builds its objects, randomises them at reset, reports its privileged
environment state and decides success. Everything else (robot, controller, sensing, protective stop,
observations, rendering, seeding) is the base env's (``envs/base_env.py``). To add a task: subclass
:class:`ForceTask`, fill the class attributes, implement the abstract methods, subclass
``ForceTaskEnv`` with ``task_class = YourTask`` and register a gym id in ``envs/registration.py``.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass, field
from typing import ClassVar

import mujoco
import numpy as np

from ..control import SpeedLimit, Workspace
from ..robots import ImpedanceGains, RobotSpec, ToolBuilder
from ..scene import BaseFrame, ContactMonitor, SceneIndex


@dataclass(frozen=True)
class StartState:
    """Where an episode starts: TCP pose (base frame), gripper command, initial finger closure."""

    tcp_pos: np.ndarray
    tcp_quat: np.ndarray
    gripper: float
    gripper_closure: float | None = None  # initial finger position as a 0..1 closure (None: = gripper)


@dataclass(frozen=True)
class StepBlock:
    """The physics steps of one control step, handed to :meth:`ForceTask.update`.

    ``sensordata (n, nsensordata)`` raw rows; ``contact_force (n, 3)`` filtered summed contact force
    (reaction on the robot, base frame); ``wrench (n, 6)`` filtered tared wrist wrench (base frame).
    """

    sensordata: np.ndarray
    contact_force: np.ndarray
    wrench: np.ndarray
    time: float  # s since the episode started, at the end of the block


@dataclass
class TaskStatus:
    """A task's verdict after a control step. ``success`` ends the episode as a success; ``failed`` as a failure."""

    success: bool = False
    failed: bool = False
    failure_reason: str = ""
    metrics: dict[str, float] = field(default_factory=dict)


class ForceTask(abc.ABC):
    """One task. Class attributes document the task; instances hold per-model ids and per-episode state."""

    name: ClassVar[str]
    description: ClassVar[str]  # natural-language task string (LeRobot's task_description)
    robot_name: ClassVar[str] = "ur5e"
    control_hz: ClassVar[float] = 20.0
    max_episode_steps: ClassVar[int]
    force_limit: ClassVar[float]  # N: protective stop on the filtered summed contact force
    finger_force_limit: ClassVar[float | None] = None  # N per fingertip (grippers with finger sensors)
    workspace: ClassVar[Workspace]
    speed_limit: ClassVar[SpeedLimit] = SpeedLimit()
    state_names: ClassVar[tuple[str, ...]]  # names of environment_state
    success_test: ClassVar[str]  # one-line description of the success test (documentation, dataset card)

    def __init__(self, robot: RobotSpec, *, randomize: bool = True):
        self.robot = robot
        self.randomize = randomize

    # ---- building (once per env) ------------------------------------------------------------------
    def contacts(self) -> ContactMonitor:
        return ContactMonitor(environment=("table",))

    def tool(self) -> ToolBuilder | None:
        return None

    def gains(self) -> ImpedanceGains:
        return self.robot.impedance

    @abc.abstractmethod
    def add_objects(self, spec: mujoco.MjSpec) -> None:
        """Add the task's bodies to ``spec.worldbody``."""

    def add_sensors(self, spec: mujoco.MjSpec, prefix: str) -> None:  # noqa: B027 - optional hook
        """Add task sensors (their names must be in :attr:`sensor_names`)."""

    sensor_names: ClassVar[tuple[str, ...]] = ()

    def bind(self, model: mujoco.MjModel, index: SceneIndex, frame: BaseFrame) -> None:
        """Look up ids after compiling (called once)."""
        self.model = model
        self.index = index
        self.frame = frame

    # ---- episodes -----------------------------------------------------------------------------------
    @abc.abstractmethod
    def reset(self, model: mujoco.MjModel, data: mujoco.MjData, rng: np.random.Generator) -> StartState:
        """Randomise objects (edit ``model``/``data``, never recompile) and return the start state."""

    def before_settle(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:  # noqa: B027
        """Called after the robot is placed, before the settle steps (e.g. put a held object in the hand)."""

    def after_settle(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:  # noqa: B027
        """Called after the settle steps, before the tare."""

    @abc.abstractmethod
    def environment_state(self, data: mujoco.MjData) -> np.ndarray:
        """Privileged object state, ``(len(state_names),)`` in the base frame."""

    @abc.abstractmethod
    def update(self, data: mujoco.MjData, block: StepBlock) -> TaskStatus:
        """Advance task bookkeeping with one control step's physics; decide success / failure."""

    def episode_metrics(self) -> dict[str, float]:
        """Task metrics for ``info`` (e.g. button travel, coverage, insertion depth)."""
        return {}
