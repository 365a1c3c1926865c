"""What a robot is to the envs: an arm builder, a gripper builder, a wrist F/T body, and metadata.

A robot is a frozen :class:`RobotSpec`. :func:`assemble_robot` turns it into one ``MjSpec`` with
fixed element names that the scene, controller, base env and recorder rely on (unprefixed names,
inside the robot spec; the scene attaches the robot with the prefix ``<robot.name>/``):

    body  ``base``            root of the arm (placed by the scene at the robot's base pose)
    joints ``robot.joint_names``  arm hinge joints, base to flange order
    site  ``flange``          on the last arm link: tool flange, z out of the flange
    body  ``ft_sensor``       wrist force/torque sensor body, welded to the flange
    site  ``ft_site``         sensor measurement frame (tool-side face, z = tool axis)
    body  ``gripper/...``     the gripper (``gripper/base`` is its root), attached at the sensor's tool face
    site  ``tcp``             tool centre point (what the action targets), on ``gripper/base``
    actuator ``gripper/actuator``  the gripper's one position actuator (command 0 open .. 1 closed)

Contracts of the builders:

* ``build_arm() -> MjSpec``: root body ``base`` (its frame is the robot base frame of the action
  layout), hinge joints named as ``joint_names`` with ranges, a site ``flange``. No actuators: the
  scene adds the Cartesian impedance actuators. Bodies should set ``gravcomp = 1`` (the controller
  relies on MuJoCo's gravity compensation). Collision geoms use ``ROBOT_CONTYPE/ROBOT_CONAFFINITY``
  (no self-collision, collide with the environment).
* ``GripperSpec.build(tool) -> MjSpec``: root body ``base`` (mounting face at its origin, z along the
  tool axis), a site ``tcp`` (default tool centre point), one actuator ``actuator`` whose
  ``ctrlrange`` maps linearly from command 0 (open) to 1 (closed), joints ``joint_names`` whose
  positions map to the closure via ``GripperSpec.opening`` (and back via ``closure_qpos``). Optional
  fingertip sensors (Gen3): names in ``finger_sensor_names``, each a 3-D force in the world frame
  (e.g. a ``contact`` sensor with ``reduce=netforce``), multiplied by ``finger_sensor_sign`` to give
  the reaction on the finger; the env rotates them to the base frame, filters them, reports them as
  ``finger_force`` and applies ``ForceTask.finger_force_limit``.
* A ``ToolBuilder`` (task-specific, e.g. the spring-mounted eraser) adds bodies to the gripper spec
  before it is attached (elements added after attaching get no prefix) and may move the TCP.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Protocol

import mujoco
import numpy as np

# Collision bit masks. Robot geoms do not collide with each other (no self-collision: the tasks keep
# the arm far from itself) but collide with every environment geom; environment geoms collide with
# everything. A geom collides with another if (a.contype & b.conaffinity) or (b.contype & a.conaffinity).
ROBOT_CONTYPE = 2
ROBOT_CONAFFINITY = 1
ENV_CONTYPE = 1
ENV_CONAFFINITY = 3

ROBOT_RGBA = (0.72, 0.74, 0.78, 1.0)
JOINT_RGBA = (0.20, 0.45, 0.70, 1.0)
DARK_RGBA = (0.15, 0.15, 0.17, 1.0)


class ToolBuilder(Protocol):
    """Adds a task tool to a gripper spec before it is attached (e.g. the spring-mounted eraser)."""

    def __call__(self, gripper: mujoco.MjSpec) -> None: ...


@dataclass(frozen=True)
class ImpedanceGains:
    """Cartesian impedance of the TCP, expressed in the target frame.

    ``stiffness_pos`` N/m and ``stiffness_rot`` N·m/rad per axis; damping is chosen per axis as
    ``2 * damping_ratio * sqrt(K * Lambda_ii)`` with the operational-space inertia Lambda evaluated at the
    episode's start configuration, at every reset (the controller then runs entirely inside MuJoCo at
    physics rate).
    ``force_limit`` N and ``torque_limit`` N·m saturate the commanded wrench (like a real arm's limits).
    """

    stiffness_pos: tuple[float, float, float] = (2000.0, 2000.0, 2000.0)
    stiffness_rot: tuple[float, float, float] = (150.0, 150.0, 150.0)
    damping_ratio: float = 1.0
    force_limit: float = 400.0
    torque_limit: float = 60.0

    def replace(self, **changes) -> ImpedanceGains:
        from dataclasses import replace

        return replace(self, **changes)


@dataclass(frozen=True)
class FTSensorSpec:
    """Wrist force/torque sensor body (defaults: a Robotiq FT-300-like puck, 0.3 kg, Ø75 × 37.5 mm)."""

    mass: float = 0.3
    radius: float = 0.0375
    length: float = 0.0375


def clip_unit(v: float) -> float:
    """``np.clip(v, 0.0, 1.0)`` of one float, as a float (NumPy's clip: the max with 0, then the min
    with 1, a bound on ties, NaN kept); the grippers' openings use it for a single configuration, where
    ``np.clip`` on a scalar costs far more than the rest of the opening."""
    v = v if (v != v or v > 0.0) else 0.0
    return v if (v != v or v < 1.0) else 1.0


@dataclass(frozen=True)
class GripperSpec:
    """A gripper: builder plus the mapping between command/joint positions and the 0..1 opening."""

    name: str
    build: Callable[[ToolBuilder | None], mujoco.MjSpec]
    joint_names: tuple[str, ...]
    # closure (0 open .. 1 closed) from the gripper joints' qpos, vectorised over leading axes
    opening: Callable[[np.ndarray], np.ndarray]
    # gripper joints' qpos for a closure in [0, 1] (used to place the fingers at reset)
    closure_qpos: Callable[[float], np.ndarray]
    # fingertip force sensors (3-D, world frame). MuJoCo contact sensors with the finger as the first
    # side report the force on the *other* side, hence the default sign -1 (reaction on the finger).
    finger_sensor_names: tuple[str, ...] = ()
    finger_sensor_sign: float = -1.0
    # bodies whose contacts count as "the gripper" for task logic (e.g. grasp checks), unprefixed
    finger_body_names: tuple[str, ...] = ()


@dataclass(frozen=True)
class RobotSpec:
    """One robot for the envs. ``name`` is also the prefix of its elements in a scene (``ur5e/...``)."""

    name: str
    build_arm: Callable[[], mujoco.MjSpec]
    joint_names: tuple[str, ...]
    gripper: GripperSpec
    home_qpos: tuple[float, ...]  # IK seed: a configuration with the tool pointing down in front of the robot
    impedance: ImpedanceGains = field(default_factory=ImpedanceGains)
    ft_sensor: FTSensorSpec = field(default_factory=FTSensorSpec)
    # default TCP orientation for "tool pointing down" (w x y z, base frame)
    tool_down_quat: tuple[float, float, float, float] = (0.0, 1.0, 0.0, 0.0)

    @property
    def n_joints(self) -> int:
        return len(self.joint_names)

    def __post_init__(self) -> None:
        if len(self.home_qpos) != len(self.joint_names):
            raise ValueError(
                f"robot {self.name!r}: home_qpos has {len(self.home_qpos)} values for {len(self.joint_names)} joints"
            )


def add_ft_sensor_body(arm: mujoco.MjSpec, ft: FTSensorSpec) -> mujoco.MjsSite:
    """Weld the F/T sensor body to the arm's ``flange`` site; return its tool-side mount site ``ft_mount``."""
    flange = arm.site("flange")
    if flange is None:
        raise ValueError("arm spec has no site 'flange' (see the RobotSpec contract)")
    parent = flange.parent
    body = parent.add_body(name="ft_sensor", pos=flange.pos, quat=flange.quat, gravcomp=1.0)
    body.add_geom(
        name="ft_housing",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[ft.radius, ft.length / 2, 0],
        pos=[0, 0, ft.length / 2],
        mass=ft.mass,
        rgba=DARK_RGBA,
        contype=0,
        conaffinity=0,
    )
    # Measurement frame on the tool-side face; the MuJoCo force/torque sensors at this site report
    # what the arm exerts on the sensor-and-tool subtree, in this frame.
    body.add_site(name="ft_site", pos=[0, 0, ft.length], size=[0.005, 0, 0], group=4)
    return body.add_site(name="ft_mount", pos=[0, 0, ft.length], size=[0.005, 0, 0], group=4)


def assemble_robot(robot: RobotSpec, tool: ToolBuilder | None = None) -> mujoco.MjSpec:
    """Arm + wrist F/T body + gripper (+ tool) as one spec, with the names of the module docstring."""
    arm = robot.build_arm()
    for name in robot.joint_names:
        if arm.joint(name) is None:
            raise ValueError(f"robot {robot.name!r}: arm spec lacks joint {name!r}")
    mount = add_ft_sensor_body(arm, robot.ft_sensor)
    gripper = robot.gripper.build(tool)
    if gripper.site("tcp") is None or gripper.actuator("actuator") is None:
        raise ValueError(
            f"gripper {robot.gripper.name!r}: spec needs a site 'tcp' and an actuator 'actuator'"
        )
    arm.attach(gripper, prefix="gripper/", site=mount)
    # The TCP lives in the arm namespace so every robot exposes the same name.
    tcp = arm.site("gripper/tcp")
    tcp.name = "tcp"
    return arm
