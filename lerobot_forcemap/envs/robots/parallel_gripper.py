"""A parallel two-finger gripper in the spirit of a Robotiq 2F-85 (85 mm stroke), primitive geometry.

Two fingers on prismatic joints, mechanically coupled by a joint equality (like the real linkage),
one position actuator. Stroke per finger 0 (open, 85 mm between pads) .. 41.5 mm (closed, 2 mm gap:
the pads never touch each other). Fingertips 140 mm from the mounting face; the default TCP is the
centre between the fingertips. Grip force saturates at 40 N per finger.
"""

from __future__ import annotations

import mujoco
import numpy as np

from .base import (
    DARK_RGBA,
    ROBOT_CONAFFINITY,
    ROBOT_CONTYPE,
    ROBOT_RGBA,
    GripperSpec,
    ToolBuilder,
    clip_unit,
)

OPEN_HALF_WIDTH = 0.0425  # m, pad face to centre when open
STROKE = 0.0415  # m per finger; closed leaves a 2 mm gap
PALM_LENGTH = 0.085  # m, mounting face to finger roots
FINGER_LENGTH = 0.055  # m
TCP_Z = PALM_LENGTH + FINGER_LENGTH  # 0.14 m
FINGER_HALF = (0.005, 0.011, FINGER_LENGTH / 2)  # box half sizes (x toward the centre)
GRIP_KP = 1000.0  # N/m
GRIP_FORCE = 40.0  # N per finger (actuator saturation)
PAD_FRICTION = (1.5, 0.02, 0.002)


def build_parallel_gripper(tool: ToolBuilder | None = None) -> mujoco.MjSpec:
    """The gripper spec (contract in ``robots/base.py``): palm, two coupled fingers, one actuator, ``tcp``."""
    spec = mujoco.MjSpec()
    spec.modelname = "parallel_gripper"
    spec.compiler.autolimits = True
    spec.compiler.degree = False
    base = spec.worldbody.add_body(name="base", gravcomp=1.0)
    _add_palm(base)
    for side, sign in (("left", -1.0), ("right", 1.0)):
        _add_finger(base, side, sign)
    spec.add_equality(
        type=mujoco.mjtEq.mjEQ_JOINT,
        name="coupling",
        name1="right_slide",
        name2="left_slide",
        data=[0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0],
    )
    act = spec.add_actuator(name="actuator", target="left_slide", trntype=mujoco.mjtTrn.mjTRN_JOINT)
    act.set_to_position(kp=GRIP_KP, kv=40.0)
    act.ctrlrange = [0.0, STROKE]
    act.forcerange = [-GRIP_FORCE, GRIP_FORCE]
    act.ctrllimited = 1
    act.forcelimited = 1
    base.add_site(name="tcp", pos=[0, 0, TCP_Z], size=[0.004, 0, 0], rgba=[1, 0.2, 0.2, 1], group=4)
    if tool is not None:
        tool(spec)
    return spec


def _add_palm(base: mujoco.MjsBody) -> None:
    base.add_geom(
        name="palm",
        type=mujoco.mjtGeom.mjGEOM_CYLINDER,
        size=[0.04, 0.035, 0],
        pos=[0, 0, 0.035],
        mass=0.6,
        rgba=DARK_RGBA,
        contype=ROBOT_CONTYPE,
        conaffinity=ROBOT_CONAFFINITY,
    )
    base.add_geom(
        name="rail",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=[0.05, 0.015, 0.0075],
        pos=[0, 0, PALM_LENGTH - 0.0075],
        mass=0.1,
        rgba=ROBOT_RGBA,
        contype=ROBOT_CONTYPE,
        conaffinity=ROBOT_CONAFFINITY,
    )


def _add_finger(base: mujoco.MjsBody, side: str, sign: float) -> None:
    """One finger on its slide (``sign`` -1 left, +1 right of the centre), open at reset."""
    finger = base.add_body(name=f"{side}_finger", pos=[sign * OPEN_HALF_WIDTH, 0, PALM_LENGTH], gravcomp=1.0)
    finger.add_joint(
        name=f"{side}_slide",
        type=mujoco.mjtJoint.mjJNT_SLIDE,
        axis=[-sign, 0, 0],
        range=[0.0, STROKE],
        armature=0.01,
        damping=5.0,
    )
    finger.add_geom(
        name=f"{side}_pad",
        type=mujoco.mjtGeom.mjGEOM_BOX,
        size=list(FINGER_HALF),
        pos=[sign * FINGER_HALF[0], 0, FINGER_HALF[2]],
        mass=0.08,
        friction=list(PAD_FRICTION),
        condim=4,
        rgba=DARK_RGBA,
        contype=ROBOT_CONTYPE,
        conaffinity=ROBOT_CONAFFINITY,
    )


def parallel_gripper_opening(qpos: np.ndarray) -> np.ndarray:
    """Closure 0 (open) .. 1 (closed) from the two finger slides ``(..., 2)`` (their mean)."""
    q = np.asarray(qpos, dtype=float)
    if q.shape == (2,):  # one configuration (the env's every step): the same arithmetic in floats
        left, right = q.tolist()
        return clip_unit((left + right) / 2 / STROKE)
    return np.clip(q.mean(axis=-1) / STROKE, 0.0, 1.0)


def parallel_gripper_closure_qpos(closure: float) -> np.ndarray:
    c = float(np.clip(closure, 0.0, 1.0))
    return np.array([c * STROKE, c * STROKE])


PARALLEL_GRIPPER = GripperSpec(
    name="parallel_gripper",
    build=build_parallel_gripper,
    joint_names=("left_slide", "right_slide"),
    opening=parallel_gripper_opening,
    closure_qpos=parallel_gripper_closure_qpos,
    finger_body_names=("left_finger", "right_finger"),
)
