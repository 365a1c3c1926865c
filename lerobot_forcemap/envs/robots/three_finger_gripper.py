"""A three-finger underactuated gripper in the spirit of an Openhand Model O, with fingertip force sensors.

Geometry (gripper frame: origin on the mounting face, z along the tool axis): a palm cylinder
(radius 45 mm, 60 mm long); a thumb at -x and two fingers at +x (y = +-22 mm) rooted on the palm's
face at 35 mm from the axis. Each finger is a proximal (55 mm) and a distal (45 mm) capsule ending in
a spherical fingertip pad (radius 12 mm, friction 1.0, condim 4); open, the fingers splay 20 degrees
outward (114 mm between opposing pad surfaces). Fingers close in the x-z plane, the two fingers
parallel to each other, opposing the thumb.

Transmission — one actuator closes all three fingers, underactuated between them: a position
actuator pulls one fixed tendon whose length is the weighted sum of the proximal joint angles
(thumb 0.5, each finger 0.25), so one tension ``T`` acts on every finger (thumb 0.5 T, fingers
0.25 T each: the thumb balances the two fingers). A finger that touches the object stops while the
others keep closing (the differential of a tendon-driven hand), and the grip force grows with the
command past contact: compliant, like the real elastic-jointed hand. Each distal joint follows its
proximal joint at 0.7x (joint equality: the finger curls). Weak joint springs open the hand and share
free motion equally. Command 0 opens fully; 0.33 closes a free hand fully; above, the tendon target
lies beyond the closed stop, i.e. higher commands squeeze harder (tendon stiffness 8 N·m/rad, tension
limit 14 N·m): on a 4-7 cm object the thumb pad force grows by ~55 N per unit of command past
contact, ~48 N at command 1 on the apple (the fingers take half each).

Fingertip sensing: per finger a MuJoCo ``contact`` sensor on the distal link (pad included) with
``reduce=netforce``: the net 3-D contact force in the world frame over every contact of that link.
The sensor reports the force the finger exerts on the other side, so ``finger_sensor_sign = -1``
turns it into the reaction on the finger (the convention of ``observation.force``: the force the
environment exerts on the robot). Sensor order = ``finger_force`` order: thumb (f0), finger 1 at +y
(f1), finger 2 at -y (f2).
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from ...geometry import quat_multiply
from .base import DARK_RGBA, ROBOT_CONAFFINITY, ROBOT_CONTYPE, ROBOT_RGBA, GripperSpec, ToolBuilder, clip_unit

PALM_RADIUS = 0.045
PALM_LENGTH = 0.06  # m, mounting face to finger roots
ROOT_RADIUS = 0.035  # m, finger roots from the axis
FINGER_SPREAD = 0.022  # m, the two fingers at y = +-spread
PROXIMAL_LENGTH = 0.055
DISTAL_LENGTH = 0.045
PAD_RADIUS = 0.012
SPLAY = math.radians(20.0)  # open: fingers tilted outward
DISTAL_RATIO = 0.7  # distal angle / proximal angle
Q_MAX = 0.6  # rad, proximal closing range (pads cross the axis: small objects are reachable)
TENDON_COEF = (0.5, 0.25, 0.25)  # thumb, finger 1, finger 2
_TENDON_COEF = np.array(TENDON_COEF)
TENDON_TARGET_MAX = 1.8  # rad of tendon length at command 1 (0.33: the closed stop of a free hand)
TENDON_KP = 8.0  # N·m/rad
TENDON_KV = 0.5  # N·m·s/rad
TENDON_FORCE_MAX = 14.0  # N·m
JOINT_ARMATURE = 0.002  # kg m^2 per finger (thumb: double, like its coefficient)
JOINT_DAMPING = 0.02
JOINT_SPRING = 0.05  # N·m/rad (thumb: double)
PAD_FRICTION = (1.0, 0.01, 0.0005)
# Default TCP: on the axis, at the height of the pads' centres when closed on a mid-size object.
TCP_Z = 0.155
FINGERS = ("thumb", "finger1", "finger2")
SENSOR_NAMES = tuple(f"{f}_force" for f in FINGERS)
PROXIMAL_JOINTS = tuple(f"{f}_proximal_joint" for f in FINGERS)
DISTAL_JOINTS = tuple(f"{f}_distal_joint" for f in FINGERS)
DISTAL_BODIES = tuple(f"{f}_distal" for f in FINGERS)
PALM_MASS = 0.45
PROXIMAL_MASS = 0.03
DISTAL_MASS = 0.025


def _root(finger: str) -> tuple[list[float], list[float]]:
    """Root position and orientation of a finger: local z along the finger, +x inward, hinge about +y."""
    half = -SPLAY / 2  # rotation about local y by -SPLAY: the tip leans outward
    tilt = np.array([math.cos(half), 0.0, math.sin(half), 0.0])
    if finger == "thumb":
        return [-ROOT_RADIUS, 0.0, PALM_LENGTH], tilt.tolist()
    y = FINGER_SPREAD if finger == "finger1" else -FINGER_SPREAD
    yaw = np.array([0.0, 0.0, 0.0, 1.0])  # pi about z: inward is -x
    return [ROOT_RADIUS, y, PALM_LENGTH], quat_multiply(yaw, tilt).tolist()


def build_three_finger_gripper(tool: ToolBuilder | None = None) -> mujoco.MjSpec:
    """The gripper spec (contract in ``robots/base.py``): palm, three fingers on one tendon, fingertip
    sensors, one actuator, ``tcp``."""
    spec = mujoco.MjSpec()
    spec.modelname = "three_finger_gripper"
    spec.compiler.autolimits = True
    spec.compiler.degree = False
    base = spec.worldbody.add_body(name="base", gravcomp=1.0)
    base.add_geom(
        name="palm", type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[PALM_RADIUS, PALM_LENGTH / 2, 0],
        pos=[0, 0, PALM_LENGTH / 2], mass=PALM_MASS, rgba=DARK_RGBA,
        contype=ROBOT_CONTYPE, conaffinity=ROBOT_CONAFFINITY,
    )  # fmt: skip
    tendon = spec.add_tendon(name="closing")
    for k in range(len(FINGERS)):
        _add_finger(spec, base, tendon, k)
    act = spec.add_actuator(name="actuator", target="closing", trntype=mujoco.mjtTrn.mjTRN_TENDON)
    act.set_to_position(kp=TENDON_KP, kv=TENDON_KV)
    act.ctrlrange = [0.0, TENDON_TARGET_MAX]
    act.ctrllimited = 1
    act.forcerange = [-TENDON_FORCE_MAX, TENDON_FORCE_MAX]
    act.forcelimited = 1
    base.add_site(name="tcp", pos=[0, 0, TCP_Z], size=[0.004, 0, 0], rgba=[1, 0.2, 0.2, 1], group=4)
    if tool is not None:
        tool(spec)
    return spec


def _add_finger(spec: mujoco.MjSpec, base: mujoco.MjsBody, tendon: mujoco.MjsTendon, k: int) -> None:
    """Finger ``FINGERS[k]``: proximal and distal links with their joints, pad, tip site, curl coupling,
    its share of the closing tendon and its fingertip contact sensor."""
    finger = FINGERS[k]
    scale = 2.0 if finger == "thumb" else 1.0
    pos, quat = _root(finger)
    prox = base.add_body(name=f"{finger}_proximal", pos=pos, quat=quat, gravcomp=1.0)
    prox.add_joint(
        name=PROXIMAL_JOINTS[k], type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0], range=[0.0, Q_MAX],
        armature=scale * JOINT_ARMATURE, damping=scale * JOINT_DAMPING, stiffness=scale * JOINT_SPRING,
    )  # fmt: skip
    prox.add_geom(
        name=f"{finger}_proximal", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
        fromto=[0, 0, 0, 0, 0, PROXIMAL_LENGTH], size=[0.011, 0, 0], mass=PROXIMAL_MASS,
        rgba=ROBOT_RGBA, contype=ROBOT_CONTYPE, conaffinity=ROBOT_CONAFFINITY,
    )  # fmt: skip
    dist = prox.add_body(name=DISTAL_BODIES[k], pos=[0, 0, PROXIMAL_LENGTH], gravcomp=1.0)
    dist.add_joint(
        name=DISTAL_JOINTS[k], type=mujoco.mjtJoint.mjJNT_HINGE, axis=[0, 1, 0],
        range=[0.0, DISTAL_RATIO * Q_MAX], armature=scale * JOINT_ARMATURE / 2,
        damping=scale * JOINT_DAMPING / 2,
    )  # fmt: skip
    dist.add_geom(
        name=f"{finger}_distal", type=mujoco.mjtGeom.mjGEOM_CAPSULE,
        fromto=[0, 0, 0, 0, 0, DISTAL_LENGTH], size=[0.0095, 0, 0], mass=DISTAL_MASS * 0.6,
        rgba=ROBOT_RGBA, contype=ROBOT_CONTYPE, conaffinity=ROBOT_CONAFFINITY,
    )  # fmt: skip
    dist.add_geom(
        name=f"{finger}_pad", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[PAD_RADIUS, 0, 0],
        pos=[0, 0, DISTAL_LENGTH], mass=DISTAL_MASS * 0.4, friction=list(PAD_FRICTION), condim=4,
        rgba=DARK_RGBA, contype=ROBOT_CONTYPE, conaffinity=ROBOT_CONAFFINITY,
    )  # fmt: skip
    dist.add_site(name=f"{finger}_tip", pos=[0, 0, DISTAL_LENGTH], size=[0.004, 0, 0], group=4)
    spec.add_equality(
        type=mujoco.mjtEq.mjEQ_JOINT, name=f"{finger}_curl", name1=DISTAL_JOINTS[k],
        name2=PROXIMAL_JOINTS[k], data=[0, DISTAL_RATIO, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    )  # fmt: skip
    tendon.wrap_joint(PROXIMAL_JOINTS[k], TENDON_COEF[k])
    spec.add_sensor(
        name=SENSOR_NAMES[k], type=mujoco.mjtSensor.mjSENS_CONTACT, objtype=mujoco.mjtObj.mjOBJ_BODY,
        objname=DISTAL_BODIES[k], intprm=[2, 3, 1],  # data: force; reduce: netforce; 1 slot
    )  # fmt: skip


def three_finger_opening(qpos: np.ndarray) -> np.ndarray:
    """Closure 0 (open) .. 1 (closed) from the gripper joints ``(..., 6)`` (proximal x3, distal x3).

    The tendon length (weighted proximal angles) over its closed-stop value.
    """
    q = np.asarray(qpos, dtype=float)
    if q.ndim == 1:  # one configuration (the env's every step): the same arithmetic, a float clip
        return clip_unit(float(q[:3] @ _TENDON_COEF) / Q_MAX)
    return np.clip(q[..., :3] @ _TENDON_COEF / Q_MAX, 0.0, 1.0)


def three_finger_closure_qpos(closure: float) -> np.ndarray:
    """Joint positions (proximal x3, distal x3) of a free hand at ``closure`` in [0, 1]."""
    q = float(np.clip(closure, 0.0, 1.0)) * Q_MAX
    return np.array([q, q, q, DISTAL_RATIO * q, DISTAL_RATIO * q, DISTAL_RATIO * q])


THREE_FINGER_GRIPPER = GripperSpec(
    name="three_finger_gripper",
    build=build_three_finger_gripper,
    joint_names=PROXIMAL_JOINTS + DISTAL_JOINTS,
    opening=three_finger_opening,
    closure_qpos=three_finger_closure_qpos,
    finger_sensor_names=SENSOR_NAMES,
    finger_sensor_sign=-1.0,
    finger_body_names=tuple(f"{f}_proximal" for f in FINGERS) + DISTAL_BODIES,
)

__all__ = [
    "THREE_FINGER_GRIPPER",
    "build_three_finger_gripper",
    "three_finger_closure_qpos",
    "three_finger_opening",
]


def pad_position(finger: str, closure: float) -> np.ndarray:
    """Fingertip pad centre (3,) in the gripper frame for a free hand at ``closure`` in [0, 1]."""
    if finger not in FINGERS:
        raise ValueError(f"finger must be one of {FINGERS}, got {finger!r}")
    q = float(np.clip(closure, 0.0, 1.0)) * Q_MAX
    b1 = -SPLAY + q
    b2 = b1 + DISTAL_RATIO * q
    inward = PROXIMAL_LENGTH * math.sin(b1) + DISTAL_LENGTH * math.sin(b2)  # toward the axis, along x
    down = PALM_LENGTH + PROXIMAL_LENGTH * math.cos(b1) + DISTAL_LENGTH * math.cos(b2)
    if finger == "thumb":
        return np.array([-ROOT_RADIUS + inward, 0.0, down])
    y = FINGER_SPREAD if finger == "finger1" else -FINGER_SPREAD
    return np.array([ROOT_RADIUS - inward, y, down])
