"""Optional: the UR5e arm from a local MuJoCo Menagerie copy (meshes) instead of primitives.

Nothing is downloaded: set ``MENAGERIE_ROOT`` to a folder laid out like ``mujoco_menagerie`` (with
``universal_robots_ur5e/ur5e.xml``) and make an env with ``robot="ur5e_menagerie"``. The Menagerie
arm is adapted to the RobotSpec contract (``robots/base.py``): its position servos and keyframes are
removed (the scene adds the Cartesian impedance actuators), joints renamed to
``layout.UR5E_JOINT_NAMES``, ``attachment_site`` becomes ``flange``, bodies get ``gravcomp = 1`` and
collision geoms the robot collision masks. Menagerie's UR5e base is rotated by 180 degrees about z
(``quat="0 0 0 -1"``), hence the home configuration with the first joint shifted by pi. Rendering with
the full meshes costs tens of ms per frame (the primitive model: 1-8 ms).
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import mujoco

from ...layout import UR5E_JOINT_NAMES
from .base import ROBOT_CONAFFINITY, ROBOT_CONTYPE, RobotSpec
from .parallel_gripper import PARALLEL_GRIPPER
from .ur5e import HOME_QPOS

MENAGERIE_ENV = "MENAGERIE_ROOT"
UR5E_XML = Path("universal_robots_ur5e") / "ur5e.xml"
MENAGERIE_JOINTS = {f"{name}_joint": name for name in UR5E_JOINT_NAMES}


def menagerie_root() -> Path | None:
    value = os.environ.get(MENAGERIE_ENV)
    return Path(value) if value else None


def build_menagerie_ur5e_arm(root: str | Path | None = None) -> mujoco.MjSpec:
    root = Path(root) if root is not None else menagerie_root()
    if root is None:
        raise ValueError(f"robot 'ur5e_menagerie' needs {MENAGERIE_ENV} set to a local mujoco_menagerie copy")
    path = root / UR5E_XML
    if not path.is_file():
        raise ValueError(f"{MENAGERIE_ENV}={root}: {UR5E_XML} not found")
    spec = mujoco.MjSpec.from_file(str(path))
    for actuator in list(spec.actuators):
        spec.delete(actuator)
    for key in list(spec.keys):
        spec.delete(key)
    spec.nkey = 0  # a <size nkey=...> would otherwise keep empty keyframes of the arm's old nq
    for joint in spec.joints:
        if joint.name in MENAGERIE_JOINTS:
            joint.name = MENAGERIE_JOINTS[joint.name]
    missing = [j for j in UR5E_JOINT_NAMES if spec.joint(j) is None]
    if missing:
        raise ValueError(
            f"{path}: joints {missing} not found (expected Menagerie names {sorted(MENAGERIE_JOINTS)})"
        )
    site = spec.site("attachment_site")
    if site is None:
        raise ValueError(f"{path}: no site 'attachment_site' (the tool flange)")
    site.name = "flange"
    if spec.body("base") is None:
        raise ValueError(f"{path}: no body 'base'")
    for body in spec.bodies:
        if body.name not in ("world", "base"):
            body.gravcomp = 1.0
    for geom in spec.geoms:
        if geom.contype or geom.conaffinity:
            geom.contype, geom.conaffinity = ROBOT_CONTYPE, ROBOT_CONAFFINITY
    return spec


UR5E_MENAGERIE = RobotSpec(
    name="ur5e_menagerie",
    build_arm=build_menagerie_ur5e_arm,
    joint_names=UR5E_JOINT_NAMES,
    gripper=PARALLEL_GRIPPER,
    home_qpos=(HOME_QPOS[0] - math.pi, *HOME_QPOS[1:]),
)
