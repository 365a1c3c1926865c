"""The task interface: a :class:`TaskSpec` (what the rest of the project knows about a task) and a
:class:`ForceTask` (what the task adds to the shared scene and env machinery).

A task file (``tasks/press.py`` ...) holds the task's ``SPEC``, its ``ForceTask`` subclass (objects,
randomisation at reset, privileged environment state, success test) and its gym env class. Everything
else (robot, controller, sensing, protective stop, observations, rendering, seeding) is the base
env's (``envs/base_env.py``). ``docs/envs.md`` has the recipe for adding a task.
"""

from __future__ import annotations

import abc
from dataclasses import dataclass
from typing import ClassVar

import mujoco
import numpy as np

from ..._validation import fail
from ..control import SpeedLimit, Workspace
from ..robots import ImpedanceGains, RobotSpec, ToolBuilder
from ..scene import BaseFrame, ContactMonitor, SceneConfig, SceneIndex
from ..variation import VariedParts

#: gym namespace of the tasks: ``lerobot_forcemap/<TaskSpec.env_id>``
NAMESPACE = "lerobot_forcemap"


@dataclass(frozen=True)
class TaskSpec:
    """One task as the rest of the project sees it; everything else about the task derives from it.

    ``name``: the task's name in ``make``, ``forcemap record/eval`` and the experiments (``"press"``);
    ``env_id``: gym id ``lerobot_forcemap/<env_id>`` and LeRobot's ``--env.task`` (``"Press-v0"``);
    ``entry_point``: ``"module:EnvClass"`` of its gym env; ``description``: the task string (LeRobot's
    ``task_description``, the datasets' task); ``max_episode_steps``: the time limit in control steps;
    ``anchor``: the object a demonstration is re-anchored to (the prefix of its ``environment_state``
    names, e.g. ``button`` for ``button_x ...``); ``demonstrator``: ``"module:Class"`` of its scripted
    demonstrator; ``robot``: the default of the ``robot=`` env kwarg; ``control_hz``: control rate
    (= dataset fps); ``objects``: the names ``object=`` accepts, the first being the default (the
    demonstration object); empty for a task without a choice of object.
    """

    name: str
    env_id: str
    entry_point: str
    description: str
    max_episode_steps: int
    anchor: str
    demonstrator: str
    robot: str = "ur5e"
    control_hz: float = 20.0
    objects: tuple[str, ...] = ()

    @property
    def gym_id(self) -> str:
        return f"{NAMESPACE}/{self.env_id}"

    @property
    def env_type(self) -> str:
        """The LeRobot env type (``--env.type``) of the task."""
        return f"forcemap_{self.name}"

    @property
    def default_object(self) -> str | None:
        return self.objects[0] if self.objects else None

    def check_object(self, value: object, name: str = "object") -> str | None:
        """``value`` if it is one of :attr:`objects` or None; else ``ValueError`` naming ``name`` (and, for a
        task without objects, the tasks that have some)."""
        if value is None:
            return None
        if not self.objects:
            from ..registration import TASKS

            takers = ", ".join(s.name for s in TASKS.values() if s.objects)
            fail(name, f"be None: task {self.name!r} has no objects (tasks with objects: {takers})", value)
        if not isinstance(value, str) or value not in self.objects:
            fail(name, f"be one of {list(self.objects)} (the objects of {self.name})", value)
        return value


@dataclass(frozen=True)
class StartState:
    """Where an episode starts: TCP pose (base frame), gripper command, initial finger closure.

    ``arm_qpos``: start at these arm joints instead (rad; no IK; the TCP pose is then their forward
    kinematics and ``tcp_pos`` / ``tcp_quat`` are ignored).
    """

    tcp_pos: np.ndarray
    tcp_quat: np.ndarray
    gripper: float
    gripper_closure: float | None = None  # initial finger position as a 0..1 closure (None: = gripper)
    arm_qpos: np.ndarray | None = None


@dataclass(slots=True)  # not frozen: made every control step, and a frozen init costs 4x
class StepBlock:
    """The physics steps of one control step, handed to :meth:`ForceTask.update`.

    ``sensordata (n, nsensordata)`` raw rows; ``contact_force (n, 3)`` filtered summed contact force
    (reaction on the robot, base frame); ``wrench (n, 6)`` filtered tared wrist wrench (base frame).
    """

    sensordata: np.ndarray
    contact_force: np.ndarray
    wrench: np.ndarray
    time: float  # s since the episode started, at the end of the block


@dataclass(slots=True)
class TaskStatus:
    """A task's verdict after a control step. ``success`` ends the episode as a success; ``failed`` as a failure."""

    success: bool = False
    failed: bool = False
    failure_reason: str = ""


class ForceTask(abc.ABC):
    """One task. Class attributes document the task; instances hold per-model ids and per-episode state."""

    spec: ClassVar[TaskSpec]
    force_limit: ClassVar[float]  # N: protective stop on the filtered summed contact force
    finger_force_limit: ClassVar[float | None] = None  # N per fingertip (grippers with finger sensors)
    workspace: ClassVar[Workspace]
    speed_limit: ClassVar[SpeedLimit] = SpeedLimit()
    state_names: ClassVar[tuple[str, ...]]  # names of environment_state
    success_test: ClassVar[str]  # one-line description of the success test (documentation, dataset card)
    varied: ClassVar[VariedParts] = (
        VariedParts()
    )  # what randomize="wide" moves and softens (envs/variation.py)

    def __init__(self, robot: RobotSpec, *, randomize: bool = True):
        self.robot = robot
        self.randomize = randomize

    # ---- building (once per env) ------------------------------------------------------------------
    def contacts(self) -> ContactMonitor:
        return ContactMonitor(environment=("table",))

    def tool(self) -> ToolBuilder | None:
        return None

    def scene_config(self) -> SceneConfig:
        """The scene's layout (robot base, table, camera); render sizes are the env's."""
        return SceneConfig()

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

    def scene_moved(self, model: mujoco.MjModel, data: mujoco.MjData) -> None:  # noqa: B027
        """Called after randomize="wide" moved the scene (refresh what :meth:`reset` cached of it)."""

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
