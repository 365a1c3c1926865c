"""Scene composition with ``MjSpec``: world options, table, robot, impedance target, sensors, camera.

:func:`build_scene` is robot- and task-agnostic: the task contributes objects through a callback
and names the environment bodies whose contacts with the robot (and with held objects) count as
"contact force". After compiling, :class:`SceneIndex` holds every id and sensordata slice the env
needs, looked up once by name.

World frame: the table top is the plane z = 0; the robot base frame is placed by ``SceneConfig``
(identity by default, so base frame = world frame unless a task moves the robot).
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import mujoco
import numpy as np

from ..geometry import quat_conjugate, quat_multiply, quat_rotate
from .control import add_cartesian_impedance
from .robots import ENV_CONAFFINITY, ENV_CONTYPE, ImpedanceGains, RobotSpec, ToolBuilder, assemble_robot

TARGET_BODY = "impedance_target"
TARGET_SITE = "impedance_target_site"
CAMERA = "front"

# MuJoCo contact-sensor parameters: data bits (force = 2), reduction (netforce = 3), 1 slot.
_CONTACT_DATA_FOUND = 1
_CONTACT_DATA_FORCE = 2
_CONTACT_REDUCE_NETFORCE = 3


@dataclass(frozen=True)
class SceneConfig:
    timestep: float = 0.002
    robot_base_pos: tuple[float, float, float] = (0.0, 0.0, 0.0)
    robot_base_quat: tuple[float, float, float, float] = (1.0, 0.0, 0.0, 0.0)
    table_center: tuple[float, float] = (0.35, 0.0)
    table_half_size: tuple[float, float] = (0.6, 0.7)
    render_width: int = 256
    render_height: int = 256
    camera_pos: tuple[float, float, float] = (0.98, -0.5, 0.42)
    camera_lookat: tuple[float, float, float] = (0.48, 0.0, 0.06)


@dataclass(frozen=True)
class BaseFrame:
    """The robot base frame in the world: converts poses between world and base (action) frames.

    Every conversion returns a new float64 array; at the identity (the default scene: position 0,
    quaternion (1, 0, 0, 0)) it is a copy of its input.
    """

    pos: np.ndarray
    quat: np.ndarray  # w x y z

    @classmethod
    def from_config(cls, config: SceneConfig) -> BaseFrame:
        return cls(np.asarray(config.robot_base_pos, float), np.asarray(config.robot_base_quat, float))

    @functools.cached_property
    def is_identity(self) -> bool:
        """No translation and no rotation (a quaternion of either sign)."""
        return bool(np.all(self.pos == 0) and abs(self.quat[0]) == 1.0)

    @functools.cached_property
    def _copies(self) -> bool:
        # (-1, 0, 0, 0) is the identity rotation too, but products with it flip a quaternion's sign
        return self.is_identity and self.quat[0] == 1.0

    def pos_to_world(self, p: np.ndarray) -> np.ndarray:
        if self._copies:
            return np.array(p, dtype=float)
        return self.pos + quat_rotate(self.quat, p)

    def quat_to_world(self, q: np.ndarray) -> np.ndarray:
        if self._copies:
            return np.array(q, dtype=float)
        return quat_multiply(self.quat, q)

    def pos_to_base(self, p: np.ndarray) -> np.ndarray:
        if self._copies:
            return np.array(p, dtype=float)
        return quat_rotate(quat_conjugate(self.quat), np.asarray(p, float) - self.pos)

    def quat_to_base(self, q: np.ndarray) -> np.ndarray:
        if self._copies:
            return np.array(q, dtype=float)
        return quat_multiply(quat_conjugate(self.quat), q)

    def vec_to_base(self, v: np.ndarray) -> np.ndarray:
        if self._copies:
            return np.array(v, dtype=float)
        return quat_rotate(quat_conjugate(self.quat), v)


@dataclass(frozen=True)
class ContactMonitor:
    """Contact sensors summed into the env's "contact force": env bodies against robot and held bodies.

    ``environment`` are body names (after prefixing) the robot should only touch gently (table, task
    objects); ``held`` are free bodies carried by the robot (their contacts with the environment are
    transmitted to the wrist). Contacts inside the robot or between held bodies and the robot do not count,
    and a held body's contacts count only while it touches the robot: once let go, its weight resting on
    the table is no force on the robot.
    """

    environment: tuple[str, ...] = ("table",)
    held: tuple[str, ...] = ()


def _look_at_quat(pos: np.ndarray, target: np.ndarray) -> list[float]:
    """Camera quaternion looking from ``pos`` at ``target`` with world z up (camera looks along -z)."""
    fwd = target - pos
    fwd /= np.linalg.norm(fwd)
    right = np.cross(fwd, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    up = np.cross(right, fwd)
    mat = np.stack([right, up, -fwd], axis=1)
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, mat.ravel())
    return q.tolist()


def build_scene(
    robot: RobotSpec,
    add_objects: Callable[[mujoco.MjSpec], None],
    contacts: ContactMonitor,
    *,
    tool: ToolBuilder | None = None,
    gains: ImpedanceGains | None = None,
    config: SceneConfig = SceneConfig(),
    extra_sensors: Callable[[mujoco.MjSpec, str], None] | None = None,
) -> mujoco.MjSpec:
    """The full scene spec (compile with ``spec.compile()``).

    ``add_objects(spec)`` adds the task's bodies to ``spec.worldbody``; ``extra_sensors(spec, prefix)``
    adds task sensors (``prefix`` is the robot's element prefix, e.g. ``"ur5e/"``). Elements are added
    in a fixed order (world, task objects, robot, controller, sensors): the compiled model, and so the
    simulation, depends on it.
    """
    spec = _new_spec(robot, config)
    _add_world(spec, config)
    add_objects(spec)
    prefix = _attach_robot(spec, robot, tool, config)
    add_cartesian_impedance(spec, f"{prefix}tcp", TARGET_SITE, gains or robot.impedance)
    _add_sensors(spec, prefix, contacts)
    if extra_sensors is not None:
        extra_sensors(spec, prefix)
    return spec


def _new_spec(robot: RobotSpec, config: SceneConfig) -> mujoco.MjSpec:
    """An empty spec with the physics options and the offscreen/visual settings."""
    spec = mujoco.MjSpec()
    spec.modelname = f"forcemap_{robot.name}"
    spec.compiler.autolimits = True
    spec.compiler.degree = False
    # Options on the root before attaching: attach conflicts keep the parent's values silently.
    spec.option.timestep = config.timestep
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
    spec.option.impratio = 10.0
    spec.visual.global_.offwidth = config.render_width
    spec.visual.global_.offheight = config.render_height
    spec.visual.quality.shadowsize = 0
    spec.visual.quality.offsamples = 0
    spec.visual.headlight.ambient = [0.45, 0.45, 0.45]
    spec.visual.headlight.diffuse = [0.5, 0.5, 0.5]
    return spec


def _add_world(spec: mujoco.MjSpec, config: SceneConfig) -> None:
    """Light, floor, table, the front camera and the impedance target's mocap body."""
    world = spec.worldbody
    world.add_light(name="top", pos=[0.3, 0, 2.0], dir=[0, 0, -1], castshadow=False)
    world.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[2, 2, 0.1], pos=[0, 0, -0.75],
        rgba=[0.35, 0.37, 0.4, 1], contype=0, conaffinity=0,
    )  # fmt: skip
    table = world.add_body(name="table", pos=[config.table_center[0], config.table_center[1], 0.0])
    table.add_geom(
        name="table_top",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[config.table_half_size[0], config.table_half_size[1], 0.02],
        pos=[0, 0, -0.02],
        rgba=[0.55, 0.45, 0.35, 1],
        friction=[0.6, 0.005, 0.0001],
        contype=ENV_CONTYPE,
        conaffinity=ENV_CONAFFINITY,
    )
    cam_pos = np.asarray(config.camera_pos, dtype=float)
    world.add_camera(
        name=CAMERA,
        pos=cam_pos.tolist(),
        quat=_look_at_quat(cam_pos, np.asarray(config.camera_lookat, float)),
        fovy=45,
    )
    target = world.add_body(name=TARGET_BODY, mocap=True)
    target.add_site(name=TARGET_SITE, size=[0.006, 0, 0], rgba=[0.1, 0.8, 0.1, 0.5], group=4)


def _attach_robot(
    spec: mujoco.MjSpec, robot: RobotSpec, tool: ToolBuilder | None, config: SceneConfig
) -> str:
    """Attach the assembled robot at its base pose; returns its element prefix (``"<name>/"``)."""
    arm = assemble_robot(robot, tool)
    frame = spec.worldbody.add_frame(pos=list(config.robot_base_pos), quat=list(config.robot_base_quat))
    prefix = f"{robot.name}/"
    spec.attach(arm, prefix=prefix, frame=frame)
    return prefix


def _add_sensors(spec: mujoco.MjSpec, prefix: str, contacts: ContactMonitor) -> None:
    """Wrist force, torque and orientation at the F/T site; a contact sensor per monitored pair; per held
    body, the count of its contacts with the robot."""
    site = mujoco.mjtObj.mjOBJ_SITE
    spec.add_sensor(
        name="wrist_force", type=mujoco.mjtSensor.mjSENS_FORCE, objtype=site, objname=f"{prefix}ft_site"
    )
    spec.add_sensor(
        name="wrist_torque", type=mujoco.mjtSensor.mjSENS_TORQUE, objtype=site, objname=f"{prefix}ft_site"
    )
    spec.add_sensor(
        name="ft_quat", type=mujoco.mjtSensor.mjSENS_FRAMEQUAT, objtype=site, objname=f"{prefix}ft_site"
    )
    for i, (env_body, tool_obj, tool_type) in enumerate(_contact_pairs(contacts, f"{prefix}base")):
        spec.add_sensor(
            name=f"contact_{i}",
            type=mujoco.mjtSensor.mjSENS_CONTACT,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            objname=env_body,
            reftype=tool_type,
            refname=tool_obj,
            intprm=[_CONTACT_DATA_FORCE, _CONTACT_REDUCE_NETFORCE, 1],
        )
    for held in contacts.held:
        spec.add_sensor(
            name=held_found_sensor(held),
            type=mujoco.mjtSensor.mjSENS_CONTACT,
            objtype=mujoco.mjtObj.mjOBJ_BODY,
            objname=held,
            reftype=mujoco.mjtObj.mjOBJ_XBODY,
            refname=f"{prefix}base",
            intprm=[_CONTACT_DATA_FOUND, 0, 1],  # the number of contacts between the held body and the robot
        )


def held_found_sensor(body: str) -> str:
    """Name of the sensor counting the contacts between held ``body`` and the robot."""
    return f"held_{body}_robot"


def _contact_pairs(contacts: ContactMonitor, robot_root: str) -> list[tuple[str, str, int]]:
    pairs = [(env, robot_root, mujoco.mjtObj.mjOBJ_XBODY) for env in contacts.environment]
    pairs += [(env, held, mujoco.mjtObj.mjOBJ_BODY) for env in contacts.environment for held in contacts.held]
    return pairs


def _sensor_slice(model: mujoco.MjModel, name: str) -> slice:
    sid = model.sensor(name).id
    adr = int(model.sensor_adr[sid])
    return slice(adr, adr + int(model.sensor_dim[sid]))


@dataclass(frozen=True)
class SceneIndex:
    """Ids and sensordata slices of a compiled scene (looked up once by name)."""

    prefix: str
    arm_qpos: np.ndarray
    arm_dof: np.ndarray
    gripper_qpos: np.ndarray
    gripper_dof: np.ndarray
    impedance_actuators: np.ndarray
    gripper_actuator: int
    gripper_ctrlrange: tuple[float, float]
    mocap: int
    tcp_site: int
    ft_site: int
    ft_body: int
    robot_root_body: int
    wrist_force: slice
    wrist_torque: slice
    ft_quat: slice
    contact_sensors: tuple[slice, ...]
    #: sensordata column counting each held body's contacts with the robot (``ContactMonitor.held``)
    held_found: dict[str, int] = field(default_factory=dict)
    #: per contact sensor: the held body it measures (environment on held body), None for environment on robot
    contact_held: tuple[str | None, ...] = ()
    finger_sensors: tuple[slice, ...] = ()
    payload_mass: float = 0.0
    extra: dict[str, slice] = field(default_factory=dict)

    @property
    def contact_columns(self) -> np.ndarray:
        """sensordata columns (n_pairs * 3,) of all contact sensors, for one fancy-index copy."""
        return (
            np.concatenate([np.arange(s.start, s.stop) for s in self.contact_sensors])
            if self.contact_sensors
            else np.zeros(0, int)
        )


def index_scene(model: mujoco.MjModel, robot: RobotSpec, extra_sensors: Sequence[str] = ()) -> SceneIndex:
    prefix = f"{robot.name}/"
    joints = [model.joint(f"{prefix}{j}") for j in robot.joint_names]
    gjoints = [model.joint(f"{prefix}gripper/{j}") for j in robot.gripper.joint_names]
    gact = model.actuator(f"{prefix}gripper/actuator")
    n_contact = sum(1 for i in range(model.nsensor) if model.sensor(i).name.startswith("contact_"))
    held = tuple(
        model.body(model.sensor(f"contact_{i}").refid[0]).name
        if model.sensor(f"contact_{i}").reftype[0] == mujoco.mjtObj.mjOBJ_BODY
        else None
        for i in range(n_contact)
    )
    ft_body = model.body(f"{prefix}ft_sensor").id
    return SceneIndex(
        prefix=prefix,
        arm_qpos=np.array([int(model.jnt_qposadr[j.id]) for j in joints]),
        arm_dof=np.array([int(model.jnt_dofadr[j.id]) for j in joints]),
        gripper_qpos=np.array([int(model.jnt_qposadr[j.id]) for j in gjoints]),
        gripper_dof=np.array([int(model.jnt_dofadr[j.id]) for j in gjoints]),
        impedance_actuators=np.array(
            [model.actuator(f"impedance_{a}").id for a in ("x", "y", "z", "rx", "ry", "rz")]
        ),
        gripper_actuator=gact.id,
        gripper_ctrlrange=(
            float(model.actuator_ctrlrange[gact.id, 0]),
            float(model.actuator_ctrlrange[gact.id, 1]),
        ),
        mocap=int(model.body_mocapid[model.body(TARGET_BODY).id]),
        tcp_site=model.site(f"{prefix}tcp").id,
        ft_site=model.site(f"{prefix}ft_site").id,
        ft_body=ft_body,
        robot_root_body=model.body(f"{prefix}base").id,
        wrist_force=_sensor_slice(model, "wrist_force"),
        wrist_torque=_sensor_slice(model, "wrist_torque"),
        ft_quat=_sensor_slice(model, "ft_quat"),
        contact_sensors=tuple(_sensor_slice(model, f"contact_{i}") for i in range(n_contact)),
        held_found={b: _sensor_slice(model, held_found_sensor(b)).start for b in held if b is not None},
        contact_held=held,
        finger_sensors=tuple(
            _sensor_slice(model, f"{prefix}gripper/{n}") for n in robot.gripper.finger_sensor_names
        ),
        payload_mass=float(model.body_subtreemass[ft_body]),
        extra={name: _sensor_slice(model, name) for name in extra_sensors},
    )
