"""Kinova Gen3 (7 DoF) from Kinova's published kinematics and inertias; primitive geometry, no meshes.

Kinematics: the joint origins of Kinova's ``kortex_description`` (Gen3 7-DoF, spherical wrist), the
same chain as the classic DH table of the Gen3 user guide (d = -0.2848, -0.0118, -0.4208, -0.0128,
-0.3143, 0, -0.1674 m, alpha = pi/2 (x6), pi, with a base frame rotated by pi about x; the DH table
rounds the offsets to 0.1 mm). Body i is joint i's moving link; every hinge is its body's local z.
Link offsets base -> flange: 0.15643, 0.12838, 0.21038, 0.21038, 0.20843, 0.10593, 0.10593, 0.061525 m.

Joint limits (Kinova's specification): joints 1, 3, 5, 7 turn continuously; joint 2 +-128.9 deg,
joint 4 +-147.8 deg, joint 6 +-120.3 deg. Masses, centres of mass and principal inertias per link as
published by Kinova (total arm 8.2 kg incl. the 1.697 kg base).

Collision and visual geometry: one capsule per link along the link offsets (radius 45 mm for the
large actuators, 38 mm for the wrist), a cylinder for the base. The impedance controller acts on the
6-D TCP only, so the 7th (elbow-swivel) degree of freedom is held by joint damping and weak posture
springs (``stiffness``/``springref`` at :data:`HOME_QPOS`) — the robots/base.py contract for a
redundant arm.
"""

from __future__ import annotations

import math

import mujoco

from .base import JOINT_RGBA, ROBOT_CONAFFINITY, ROBOT_CONTYPE, ROBOT_RGBA, ImpedanceGains, RobotSpec
from .three_finger_gripper import THREE_FINGER_GRIPPER

JOINT_NAMES = tuple(f"joint_{i}" for i in range(1, 8))

_S = math.sqrt(0.5)
# (body, position in the parent, orientation in the parent (w x y z)) — Kinova's joint origins.
CHAIN = (
    ("shoulder_link", (0.0, 0.0, 0.15643), (0.0, 1.0, 0.0, 0.0)),
    ("half_arm_1_link", (0.0, 0.005375, -0.12838), (_S, _S, 0.0, 0.0)),
    ("half_arm_2_link", (0.0, -0.21038, -0.006375), (_S, -_S, 0.0, 0.0)),
    ("forearm_link", (0.0, 0.006375, -0.21038), (_S, _S, 0.0, 0.0)),
    ("spherical_wrist_1_link", (0.0, -0.20843, -0.006375), (_S, -_S, 0.0, 0.0)),
    ("spherical_wrist_2_link", (0.0, 0.00017505, -0.10593), (_S, _S, 0.0, 0.0)),
    ("bracelet_link", (0.0, -0.10593, -0.00017505), (_S, -_S, 0.0, 0.0)),
)
# Tool flange in the bracelet frame: 61.525 mm along -z, z out of the flange.
FLANGE_POS = (0.0, 0.0, -0.061525)
FLANGE_QUAT = (0.0, 1.0, 0.0, 0.0)

JOINT_LIMIT_DEG = (None, 128.9, None, 147.8, None, 120.3, None)  # None: continuous
JOINT_RANGE = tuple(None if d is None else (-math.radians(d), math.radians(d)) for d in JOINT_LIMIT_DEG)

# Kinova's inertial data: mass (kg), centre of mass (m), principal axes (w x y z), principal inertias (kg m^2).
BASE_INERTIAL = (1.697, (-0.000648, -0.000166, 0.084487), (0.999294, 0.00139618, -0.0118387, 0.035636),
                 (0.00462407, 0.00449437, 0.00207755))  # fmt: skip
LINK_INERTIAL = (
    (1.3773, (-2.3e-05, -0.010364, -0.07336), (0.707051, 0.0451246, -0.0453544, 0.704263),
     (0.00488868, 0.00457, 0.00135132)),
    (1.1636, (-4.4e-05, -0.09958, -0.013278), (0.482348, 0.516286, -0.516862, 0.483366),
     (0.0113017, 0.011088, 0.00102532)),
    (1.1636, (-4.4e-05, -0.006641, -0.117892), (0.706144, 0.0213722, -0.0209128, 0.707437),
     (0.0111633, 0.010932, 0.00100671)),
    (0.9302, (-1.8e-05, -0.075478, -0.015006), (0.483678, 0.515961, -0.515859, 0.483455),
     (0.00834839, 0.008147, 0.000598606)),
    (0.6781, (1e-06, -0.009432, -0.063883), (0.703558, 0.0707492, -0.0707492, 0.703558),
     (0.00165901, 0.001596, 0.000346988)),
    (0.6781, (1e-06, -0.045483, -0.00965), (0.44426, 0.550121, -0.550121, 0.44426),
     (0.00170087, 0.001641, 0.00035013)),
    (0.5006, (0.000281, 0.011402, -0.029798), (0.394358, 0.596779, -0.577293, 0.393789),
     (0.000657336, 0.000587019, 0.000320645)),
)  # fmt: skip
LINK_MASS = tuple(m for m, *_ in LINK_INERTIAL)

# Reflected rotor inertia and viscous friction of the drives (large: joints 1-4, small: 5-7), and the
# posture springs that hold the null space. They act on every joint, not only in the null space, so they
# pull the TCP off a free-space target the further it is from home: 0.1 mm at home, 2.1 mm at
# (0.55, 0, 0.10), 7.1 mm at (0.6, 0.25, 0.1), 21 mm at (0.7, -0.3, 0.05) (info["tracking_error"] after
# 10 s; the UR5e: 0.0 mm at all of them). The grasp tasks work at x = 0.45-0.6 m (the flip object at
# (0.48, -0.06), the push wall at x = 0.6); the demonstrations
# were recorded, and the policies run, with the same springs.
ARMATURE = (0.1, 0.1, 0.1, 0.1, 0.05, 0.05, 0.05)
DAMPING = (2.0, 2.0, 2.0, 2.0, 0.8, 0.8, 0.8)
POSTURE_STIFFNESS = (2.0, 2.0, 2.0, 2.0, 0.5, 0.5, 0.5)
LINK_RADIUS = (0.045, 0.045, 0.045, 0.045, 0.038, 0.038, 0.035)

# Tool pointing down (tool_down_quat), elbow up, arm in the x-z plane, TCP at about (0.42, 0, 0.25) m
# (solved offline with joints 1, 3, 5 fixed; rad).
HOME_QPOS = (0.0, 0.28, math.pi, -1.55, 0.0, -1.32, 0.0)


def _set_inertial(body, inertial) -> None:
    mass, pos, quat, diag = inertial
    body.explicitinertial = True
    body.mass = mass
    body.ipos = list(pos)
    body.iquat = list(quat)
    body.inertia = list(diag)


def build_gen3_arm(home_qpos: tuple[float, ...] | None = None) -> mujoco.MjSpec:
    """The Gen3 arm (no gripper, no actuators) following the RobotSpec contract (robots/base.py)."""
    home = HOME_QPOS if home_qpos is None else home_qpos
    spec = mujoco.MjSpec()
    spec.modelname = "gen3"
    spec.compiler.autolimits = True
    spec.compiler.degree = False
    base = spec.worldbody.add_body(name="base")
    _set_inertial(base, BASE_INERTIAL)
    base.add_geom(
        name="base_housing", type=mujoco.mjtGeom.mjGEOM_CYLINDER, fromto=[0, 0, 0, 0, 0, 0.15],
        size=[0.05, 0, 0], rgba=ROBOT_RGBA, contype=ROBOT_CONTYPE, conaffinity=ROBOT_CONAFFINITY,
    )  # fmt: skip
    parent = base
    for i, (name, pos, quat) in enumerate(CHAIN):
        body = parent.add_body(name=name, pos=list(pos), quat=list(quat), gravcomp=1.0)
        _set_inertial(body, LINK_INERTIAL[i])
        joint = body.add_joint(
            name=JOINT_NAMES[i],
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=[0, 0, 1],
            armature=ARMATURE[i],
            damping=DAMPING[i],
            stiffness=POSTURE_STIFFNESS[i],
            springref=float(home[i]),
        )
        if JOINT_RANGE[i] is None:
            joint.limited = mujoco.mjtLimited.mjLIMITED_FALSE
        else:
            joint.range = list(JOINT_RANGE[i])
            joint.limited = mujoco.mjtLimited.mjLIMITED_TRUE
        end = CHAIN[i + 1][1] if i + 1 < len(CHAIN) else FLANGE_POS
        body.add_geom(
            name=f"{name}_capsule",
            type=mujoco.mjtGeom.mjGEOM_CAPSULE,
            fromto=[0.0, 0.0, 0.0, *end],
            size=[LINK_RADIUS[i], 0, 0],
            rgba=JOINT_RGBA if i % 2 else ROBOT_RGBA,
            contype=ROBOT_CONTYPE,
            conaffinity=ROBOT_CONAFFINITY,
        )
        parent = body
    parent.add_site(name="flange", pos=list(FLANGE_POS), quat=list(FLANGE_QUAT), size=[0.005, 0, 0], group=4)
    return spec


GEN3 = RobotSpec(
    name="gen3",
    build_arm=build_gen3_arm,
    joint_names=JOINT_NAMES,
    gripper=THREE_FINGER_GRIPPER,
    home_qpos=HOME_QPOS,
    # A lighter arm than the UR5e: softer TCP stiffness (pushing objects over stays gentle), lower limits.
    impedance=ImpedanceGains(
        stiffness_pos=(1500.0, 1500.0, 1500.0),
        stiffness_rot=(100.0, 100.0, 100.0),
        force_limit=200.0,
        torque_limit=30.0,
    ),
)

__all__ = ["GEN3", "HOME_QPOS", "JOINT_NAMES", "JOINT_RANGE", "LINK_MASS", "build_gen3_arm"]
