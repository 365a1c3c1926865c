"""``twin``: the simulated twin of one recording (``envs/twin/`` builds its :class:`TwinScene`).

The UR5e starts at the recording's first joint configuration, in the recording's base frame (the
robot base is raised by ``BASE_HEIGHT`` above the table so that surfaces below the base's mounting
plane fit). The task object is a spring-mounted surface: a slide along the surface normal with a
spring (``stiffness`` N/m, ``preload`` N at rest) and a hard stop ``stop_depth`` below the rest
surface; a round button cap for a press, a board for a wipe.

Actions and ``ee_pose`` are poses of the *recorded* tool frame (``TwinScene.tool_offset``: that frame
in the flange frame), so a policy fitted on the recording runs unchanged; the env converts them to
and from the simulated gripper's TCP.

Success: press: the surface travelled at least ``success_depth``, then released (travel < 1 mm,
contact < 0.5 N). Wipe: at least ``coverage_goal`` of the demonstrated path points (``path``, base
frame) were passed within ``PATH_RADIUS`` with a contact force above ``WIPE_FORCE``, then released.
Protective stop: filtered contact force above ``FORCE_LIMIT``.
environment_state: the rest surface's centre pose (7), the travel (m), the wipe coverage.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import ClassVar

import mujoco
import numpy as np

from ...geometry import quat_conjugate, quat_multiply, quat_rotate
from ..control import SpeedLimit, Workspace, set_impedance_damping
from ..robots import ENV_CONAFFINITY, ENV_CONTYPE
from ..scene import ContactMonitor, SceneConfig
from .base import ForceTask, StartState, StepBlock, TaskSpec, TaskStatus

SPEC = TaskSpec(
    name="twin",
    env_id="Twin-v0",
    entry_point="lerobot_forcemap.envs.tasks.twin:TwinEnv",
    description="Repeat the recorded demonstration.",
    max_episode_steps=2000,
    anchor="surface",
    demonstrator="",
)

BASE_HEIGHT = 0.4  # m, robot base above the table top
FORCE_LIMIT = 150.0  # N
RELEASE_TRAVEL = 0.001  # m
RELEASE_FORCE = 0.5  # N
WIPE_FORCE = 1.0  # N
PATH_RADIUS = 0.01  # m
SURFACE_THICKNESS = 0.01  # m
KINDS = ("press", "wipe")


@dataclass(frozen=True)
class TwinScene:
    """Everything the twin env needs (JSON-able through :meth:`to_dict` / :meth:`from_dict`).

    ``kind``: "press" or "wipe"; ``start_qpos (6,)`` rad; ``gripper`` 0..1; ``tool_offset``: the recorded
    tool frame in the flange frame, position (3,) m then quaternion (4,) w x y z; ``surface_pos (3,)``
    base frame m: the rest surface's centre; ``surface_quat (4,)``: its frame (local z = the outward
    normal); ``half_size (2,)`` m: cap radius (press, second entry unused) or board half extents;
    ``stiffness`` N/m; ``preload`` N; ``stop_depth`` m; ``success_depth`` m (press); ``path (P, 3)``
    base frame (wipe); ``coverage_goal``; ``workspace_low/high (3,)`` base frame m; ``max_steps``;
    ``damping_qpos (6,)``: the joints the impedance damping is computed at (the contact's; empty: the
    start's; a recording may start near a singularity, whose inertia would overdamp the whole episode);
    ``arm_stiffness`` N/m: the impedance controller's translational stiffness (0: the robot's).
    """

    kind: str
    start_qpos: tuple[float, ...]
    gripper: float
    tool_offset: tuple[float, ...]
    surface_pos: tuple[float, ...]
    surface_quat: tuple[float, ...]
    half_size: tuple[float, float]
    stiffness: float
    preload: float
    stop_depth: float
    success_depth: float
    workspace_low: tuple[float, ...]
    workspace_high: tuple[float, ...]
    max_steps: int
    path: tuple[tuple[float, float, float], ...] = ()
    coverage_goal: float = 0.9
    damping_qpos: tuple[float, ...] = ()
    arm_stiffness: float = 0.0
    name: str = ""
    task: str = SPEC.description
    extra: dict = field(default_factory=dict, compare=False)

    def to_dict(self) -> dict:
        d = {k: getattr(self, k) for k in self.__dataclass_fields__}
        return {
            k: (list(map(list, v)) if k == "path" else list(v) if isinstance(v, tuple) else v)
            for k, v in d.items()
        }

    @classmethod
    def from_dict(cls, d: dict) -> TwinScene:
        d = dict(d)
        for k in (
            "start_qpos",
            "tool_offset",
            "surface_pos",
            "surface_quat",
            "half_size",
            "workspace_low",
            "workspace_high",
        ):
            d[k] = tuple(float(x) for x in d[k])
        d["path"] = tuple(tuple(float(x) for x in p) for p in d.get("path", ()))
        return cls(**d)


def _geom_size(tw: TwinScene) -> np.ndarray:
    """MuJoCo size of the surface geom: (radius, half height, 0) for the cap, half extents for the board."""
    if tw.kind == "press":
        return np.array([tw.half_size[0], SURFACE_THICKNESS / 2, 0.0])
    return np.array([tw.half_size[0], tw.half_size[1], SURFACE_THICKNESS / 2])


class TwinTask(ForceTask):
    spec: ClassVar[TaskSpec] = SPEC
    force_limit: ClassVar[float] = FORCE_LIMIT
    workspace: Workspace
    speed_limit: ClassVar[SpeedLimit] = SpeedLimit(linear=1.0, angular=3.0)
    state_names: ClassVar[tuple[str, ...]] = (
        "surface_x", "surface_y", "surface_z", "surface_qw", "surface_qx", "surface_qy", "surface_qz",
        "surface_travel", "coverage",
    )  # fmt: skip
    sensor_names: ClassVar[tuple[str, ...]] = ("surface_pos",)
    success_test: ClassVar[str] = (
        "press: the demonstrated depth then released; wipe: the demonstrated path covered"
    )
    twin: ClassVar[TwinScene]

    def __init__(self, robot, *, randomize: bool = True):
        super().__init__(robot, randomize=randomize)
        self.workspace = Workspace(low=self.twin.workspace_low, high=self.twin.workspace_high)

    def gains(self):
        k = self.twin.arm_stiffness
        return replace(self.robot.impedance, stiffness_pos=(k, k, k)) if k > 0 else self.robot.impedance

    def scene_config(self) -> SceneConfig:
        """The base raised above the table (poses stay in the base frame)."""
        return SceneConfig(robot_base_pos=(0.0, 0.0, BASE_HEIGHT))

    def contacts(self) -> ContactMonitor:
        return ContactMonitor(environment=("table", "twin_mount", "twin_surface"))

    def add_objects(self, spec: mujoco.MjSpec) -> None:
        tw, press = self.twin, self.twin.kind == "press"
        base_pos = np.asarray(self.scene_config().robot_base_pos)  # the base frame's rotation is identity
        mount = spec.worldbody.add_body(
            name="twin_mount", pos=(base_pos + tw.surface_pos).tolist(), quat=list(tw.surface_quat)
        )
        body = mount.add_body(name="twin_surface")
        body.add_joint(
            name="twin_slide",
            type=mujoco.mjtJoint.mjJNT_SLIDE,
            axis=[0, 0, 1],
            range=[-tw.stop_depth, 0.0],
            stiffness=tw.stiffness,
            springref=tw.preload / tw.stiffness,
            damping=5.0,
            solref_limit=[0.004, 1.0],
        )
        body.add_geom(
            name="twin_surface",
            type=mujoco.mjtGeom.mjGEOM_CYLINDER if press else mujoco.mjtGeom.mjGEOM_BOX,
            size=_geom_size(tw).tolist(),
            pos=[0, 0, -SURFACE_THICKNESS / 2],
            mass=0.05,
            rgba=[0.85, 0.15, 0.1, 1] if press else [0.95, 0.95, 0.95, 1],
            friction=[0.5, 0.005, 0.0001],
            contype=ENV_CONTYPE,
            conaffinity=ENV_CONAFFINITY,
        )

    def add_sensors(self, spec: mujoco.MjSpec, prefix: str) -> None:
        spec.add_sensor(
            name="surface_pos",
            type=mujoco.mjtSensor.mjSENS_JOINTPOS,
            objtype=mujoco.mjtObj.mjOBJ_JOINT,
            objname="twin_slide",
        )

    def bind(self, model, index, frame) -> None:
        super().bind(model, index, frame)
        self._mount = model.body("twin_mount").id
        self._geom = model.geom("twin_surface").id
        self._joint = model.joint("twin_slide").id
        self._slide_qpos = int(model.jnt_qposadr[self._joint])
        self._pos_col = index.extra["surface_pos"].start

    def apply(self, model: mujoco.MjModel) -> None:
        """Put the twin's surface, spring and stop into ``model`` (no recompiling; the calibration changes
        them between replays)."""
        tw = self.twin
        model.body_pos[self._mount] = self.frame.pos_to_world(np.asarray(tw.surface_pos))
        model.body_quat[self._mount] = self.frame.quat_to_world(np.asarray(tw.surface_quat))
        model.geom_size[self._geom] = _geom_size(tw)
        half = np.array(
            [
                tw.half_size[0],
                tw.half_size[0] if tw.kind == "press" else tw.half_size[1],
                SURFACE_THICKNESS / 2,
            ]
        )
        model.geom_rbound[self._geom] = float(np.linalg.norm(half))
        model.geom_aabb[self._geom] = [0.0, 0.0, 0.0, *half]
        model.jnt_stiffness[self._joint] = tw.stiffness
        model.qpos_spring[self._slide_qpos] = tw.preload / tw.stiffness
        model.jnt_range[self._joint] = [-tw.stop_depth, 0.0]

    def reset(self, model, data, rng: np.random.Generator) -> StartState:
        self.apply(model)
        self.travel = 0.0
        self.max_travel = 0.0
        self.pressed = False
        self.released = False
        self._covered = np.zeros(len(self.twin.path), bool)
        qpos = np.asarray(self.twin.start_qpos, float)
        return StartState(
            tcp_pos=np.zeros(3), tcp_quat=np.array([1.0, 0, 0, 0]), gripper=self.twin.gripper, arm_qpos=qpos
        )

    def coverage(self) -> float:
        return float(self._covered.mean()) if len(self._covered) else 0.0

    def environment_state(self, data) -> np.ndarray:
        tw = self.twin
        travel = max(0.0, -float(data.qpos[self._slide_qpos]))
        return np.concatenate([tw.surface_pos, tw.surface_quat, [travel, self.coverage()]])

    def update(self, data, block: StepBlock) -> TaskStatus:
        travel = np.maximum(0.0, -block.sensordata[:, self._pos_col])
        self.travel = float(travel[-1])
        self.max_travel = max(self.max_travel, float(travel.max()))
        force_now = float(np.linalg.norm(block.contact_force[-1]))
        if self.twin.kind == "wipe" and len(self._covered):
            self._mark_path(data, float(np.linalg.norm(block.contact_force, axis=1).max()))
        done = (
            self.max_travel >= self.twin.success_depth
            if self.twin.kind == "press"
            else self.coverage() >= self.twin.coverage_goal
        )
        self.pressed = self.pressed or done
        if self.pressed:
            self.released = self.travel < RELEASE_TRAVEL and force_now < RELEASE_FORCE
        return TaskStatus(
            success=self.pressed and self.released, failure_reason="" if self.pressed else "not_reached"
        )

    def _mark_path(self, data, force: float) -> None:
        if force <= WIPE_FORCE:
            return
        tcp = self.frame.pos_to_base(data.site_xpos[self.index.tcp_site])
        n = quat_rotate(np.asarray(self.twin.surface_quat), np.array([0.0, 0.0, 1.0]))
        rel = np.asarray(self.twin.path) - tcp
        lateral = rel - np.outer(rel @ n, n)
        self._covered |= np.linalg.norm(lateral, axis=1) <= PATH_RADIUS

    def episode_metrics(self) -> dict[str, float]:
        return {
            "surface_travel": self.travel,
            "max_surface_travel": self.max_travel,
            "coverage": self.coverage(),
        }


# The gym entry point (SPEC.entry_point).
from ..base_env import ForceTaskEnv  # noqa: E402


class TwinEnv(ForceTaskEnv):
    """The twin of one recording: ``twin`` a :class:`TwinScene` (or its dict); other kwargs as
    :class:`ForceTaskEnv` (``randomize`` has no effect: a twin is one scene)."""

    task_class = TwinTask

    def __init__(self, *, twin: TwinScene | dict, **kwargs):
        scene = twin if isinstance(twin, TwinScene) else TwinScene.from_dict(twin)
        self.task_class = type("BoundTwinTask", (TwinTask,), {"twin": scene})
        self.twin = scene
        super().__init__(**kwargs)
        self._tool_from_tcp()

    def _tool_from_tcp(self) -> None:
        """The recorded tool frame relative to the simulated TCP (constant: both ride on the flange)."""
        d, ix = self._scratch, self.index
        d.qpos[:] = self.model.qpos0
        mujoco.mj_kinematics(self.model, d)
        flange = self.model.site(f"{self.robot.name}/flange").id
        qf, qt = np.empty(4), np.empty(4)
        mujoco.mju_mat2Quat(qf, d.site_xmat[flange])
        mujoco.mju_mat2Quat(qt, d.site_xmat[ix.tcp_site])
        # tcp in flange frame
        p_ft = quat_rotate(quat_conjugate(qf), d.site_xpos[ix.tcp_site] - d.site_xpos[flange])
        q_ft = quat_multiply(quat_conjugate(qf), qt)
        p_off, q_off = np.asarray(self.twin.tool_offset[:3]), np.asarray(self.twin.tool_offset[3:])
        # tcp in tool frame: T_off^-1 T_ft
        self._tcp_in_tool = (
            quat_rotate(quat_conjugate(q_off), p_ft - p_off),
            quat_multiply(quat_conjugate(q_off), q_ft),
        )
        self._tool_ref_quat = np.asarray(self.twin.extra.get("ref_quat", [1.0, 0, 0, 0]), float)

    def _place_robot(self, start: StartState) -> tuple[np.ndarray, np.ndarray]:
        pose = super()._place_robot(start)
        if self.twin.damping_qpos:
            d, ix = self._scratch, self.index
            d.qpos[:] = self.data.qpos
            d.qpos[ix.arm_qpos] = self.twin.damping_qpos
            mujoco.mj_forward(self.model, d)
            self.damping = set_impedance_damping(
                self.model, d, ix.impedance_actuators, ix.tcp_site, ix.arm_dof, self.gains
            )
        return pose

    @property
    def task_description(self) -> str:
        """The recording's task string (a policy fitted on it checks it)."""
        return self.twin.task

    @property
    def task(self) -> str:
        return self.twin.task

    def tool_to_tcp(self, pos: np.ndarray, quat: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """A recorded-tool-frame pose (base frame) as the simulated TCP's pose."""
        p, q = self._tcp_in_tool
        return pos + quat_rotate(quat, p), quat_multiply(quat, q)

    def tcp_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """The recorded tool frame's pose (base frame), from the simulated TCP."""
        pos, quat = super().tcp_pose()
        p, q = self._tcp_in_tool
        q_tool = quat_multiply(quat, quat_conjugate(q))
        return pos - quat_rotate(q_tool, p), self._align(q_tool)

    def step(self, action):
        a = self._check_action(action)
        quat = a[3:7] / max(float(np.linalg.norm(a[3:7])), 1e-12)
        pos, q = self.tool_to_tcp(a[:3], quat)
        return super().step(np.concatenate([pos, q, a[7:]]))
