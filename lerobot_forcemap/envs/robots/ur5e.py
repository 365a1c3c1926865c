"""Universal Robots UR5e from its published DH parameters, primitive geometry (no meshes, no downloads).

DH (Universal Robots, a and d in m): d = (0.1625, 0, 0, 0.1333, 0.0997, 0.0996),
a = (0, -0.425, -0.3922, 0, 0, 0), alpha = (pi/2, 0, 0, pi/2, -pi/2, 0). Link masses 3.761, 8.058,
2.846, 1.37, 1.3, 0.365 kg. Joint ranges +-2 pi, elbow +-pi (as on the real arm with the elbow limit).

Body i's frame is DH frame i-1 rotated by joint i about its z axis, so each hinge is the local z
axis at the body origin and the static part of the DH transform places the next body.
"""

from __future__ import annotations

import math

import mujoco

from ...layout import UR5E_JOINT_NAMES
from .base import (
    JOINT_RGBA,
    ROBOT_CONAFFINITY,
    ROBOT_CONTYPE,
    ROBOT_RGBA,
    ImpedanceGains,
    RobotSpec,
)
from .parallel_gripper import PARALLEL_GRIPPER

DH_D = (0.1625, 0.0, 0.0, 0.1333, 0.0997, 0.0996)
DH_A = (0.0, -0.425, -0.3922, 0.0, 0.0, 0.0)
DH_ALPHA = (math.pi / 2, 0.0, 0.0, math.pi / 2, -math.pi / 2, 0.0)
LINK_MASS = (3.761, 8.058, 2.846, 1.37, 1.3, 0.365)
JOINT_NAMES = UR5E_JOINT_NAMES
JOINT_RANGE = ((-2 * math.pi, 2 * math.pi),) * 2 + ((-math.pi, math.pi),) + ((-2 * math.pi, 2 * math.pi),) * 3
# Reflected rotor inertia and viscous friction (stabilise the torque-controlled arm, as the real drives do).
ARMATURE = (0.1, 0.1, 0.1, 0.05, 0.05, 0.05)
DAMPING = (1.0, 1.0, 1.0, 0.5, 0.5, 0.5)


def _dh_static(i: int) -> tuple[list[float], list[float]]:
    """Position and quaternion of DH frame i relative to frame i-1 at zero joint angle."""
    half = DH_ALPHA[i] / 2
    return [DH_A[i], 0.0, DH_D[i]], [math.cos(half), math.sin(half), 0.0, 0.0]


def _capsule(body, name: str, a, b, radius: float, mass: float, rgba=ROBOT_RGBA) -> None:
    body.add_geom(
        name=name,
        type=mujoco.mjtGeom.mjGEOM_CAPSULE,
        fromto=[*a, *b],
        size=[radius, 0, 0],
        mass=mass,
        rgba=rgba,
        contype=ROBOT_CONTYPE,
        conaffinity=ROBOT_CONAFFINITY,
    )


def _cylinder(body, name: str, a, b, radius: float, mass: float, rgba=JOINT_RGBA) -> None:
    body.add_geom(
        name=name,
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        fromto=[*a, *b],
        size=[radius, 0, 0],
        mass=mass,
        rgba=rgba,
        contype=ROBOT_CONTYPE,
        conaffinity=ROBOT_CONAFFINITY,
    )


def build_ur5e_arm() -> mujoco.MjSpec:
    """The UR5e arm (no gripper, no actuators) following the RobotSpec contract."""
    spec = mujoco.MjSpec()
    spec.modelname = "ur5e"
    spec.compiler.autolimits = True
    spec.compiler.degree = False
    base = spec.worldbody.add_body(name="base")
    # Base housing sits on the mounting surface (z >= 0); mass irrelevant (welded to the world).
    _cylinder(base, "base_housing", (0, 0, 0), (0, 0, 0.086), 0.075, 4.0, rgba=ROBOT_RGBA)

    link_geoms = {
        # body index: list of (kind, name, from, to, radius, mass fraction)
        0: [("cyl", "shoulder", (0, 0, 0.086), (0, 0, DH_D[0] + 0.06), 0.06, 1.0)],
        1: [
            ("cyl", "shoulder_joint", (0, 0, -0.07), (0, 0, 0.07), 0.06, 0.25),
            ("cap", "upper_arm", (0, 0, 0.0), (DH_A[1], 0, 0.0), 0.05, 0.75),
        ],
        2: [
            ("cyl", "elbow_joint", (0, 0, -0.06), (0, 0, 0.06), 0.05, 0.25),
            ("cap", "forearm", (0, 0, 0.0), (DH_A[2], 0, 0.0), 0.04, 0.75),
        ],
        3: [("cyl", "wrist_1_link", (0, 0, -0.05), (0, 0, DH_D[3] + 0.04), 0.045, 1.0)],
        4: [("cyl", "wrist_2_link", (0, 0, -0.04), (0, 0, DH_D[4] + 0.04), 0.045, 1.0)],
        5: [("cyl", "wrist_3_link", (0, 0, -0.04), (0, 0, DH_D[5] - 0.005), 0.04, 1.0)],
    }

    parent = base
    pos, quat = [0.0, 0.0, 0.0], [1.0, 0.0, 0.0, 0.0]
    for i, jname in enumerate(JOINT_NAMES):
        body = parent.add_body(name=f"link_{i + 1}", pos=pos, quat=quat, gravcomp=1.0)
        body.add_joint(
            name=jname,
            type=mujoco.mjtJoint.mjJNT_HINGE,
            axis=[0, 0, 1],
            range=list(JOINT_RANGE[i]),
            armature=ARMATURE[i],
            damping=DAMPING[i],
        )
        for kind, gname, a, b, r, frac in link_geoms[i]:
            (_cylinder if kind == "cyl" else _capsule)(body, gname, a, b, r, LINK_MASS[i] * frac)
        pos, quat = _dh_static(i)
        parent = body
    parent.add_site(name="flange", pos=pos, quat=quat, size=[0.005, 0, 0], group=4)
    return spec


# Elbow-up, tool-down configuration in front of the robot (TCP about 0.5 m ahead, 0.3 m up).
HOME_QPOS = (2.87, -1.56, 1.84, -1.86, -1.571, -1.84)

UR5E = RobotSpec(
    name="ur5e",
    build_arm=build_ur5e_arm,
    joint_names=JOINT_NAMES,
    gripper=PARALLEL_GRIPPER,
    home_qpos=HOME_QPOS,
    impedance=ImpedanceGains(),
)

__all__ = ["UR5E", "build_ur5e_arm", "JOINT_NAMES", "HOME_QPOS"]
