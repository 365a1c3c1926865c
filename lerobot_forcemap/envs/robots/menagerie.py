"""Optional: the UR5e and Gen3 arms from a local MuJoCo Menagerie copy (meshes) instead of primitives.

Nothing is downloaded: set ``MENAGERIE_ROOT`` to a folder laid out like ``mujoco_menagerie`` (with
``universal_robots_ur5e/ur5e.xml`` and/or ``kinova_gen3/gen3.xml``) and make an env with
``robot="ur5e_menagerie"`` or ``robot="gen3_menagerie"``. A Menagerie arm is adapted to the RobotSpec
contract (``robots/base.py``) by :func:`load_menagerie_arm`: its position servos and keyframes are
removed (the scene adds the Cartesian impedance actuators), joints renamed to our names, the root body
becomes ``base`` and the tool site ``flange``, bodies get ``gravcomp = 1`` and collision geoms the
robot collision masks. Rendering a 256 px frame with the meshes: UR5e 10 ms, Gen3 5 ms (primitives:
2 ms). Checked against a local copy (Menagerie's UR5e; its Gen3 XML with Kinova's STL meshes): the
scripted demonstrators succeed in 20 of 20 seeds in every task on these arms.

* UR5e: Menagerie's base is rotated by 180 degrees about z (``quat="0 0 0 -1"``) and its link frames
  differ from the DH frames of ``ur5e.py``, but the two cancel: the same joint angles put the flange at
  the same pose as Universal Robots' DH convention (checked against a local Menagerie copy: orientation
  equal, position within 0.5 mm, as Menagerie rounds d1 to 0.163 m), so the home configuration is the
  same. Its joints keep Menagerie's armature and damping.
* Gen3: Menagerie's chain has the same joint origins as ``gen3.py`` (Kinova's kortex_description), so
  the home configuration is the same. Its joints carry no damping and no posture springs, and the
  impedance controller acts on the 6-D TCP only, so the drive model of ``gen3.py`` (armature, damping,
  posture springs at the home configuration that hold the 7th, elbow-swivel, DoF) is set on them.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from dataclasses import replace
from pathlib import Path

import mujoco

from ...layout import UR5E_JOINT_NAMES
from . import gen3
from .base import ROBOT_CONAFFINITY, ROBOT_CONTYPE
from .ur5e import UR5E

MENAGERIE_ENV = "MENAGERIE_ROOT"
UR5E_XML = Path("universal_robots_ur5e") / "ur5e.xml"
GEN3_XML = Path("kinova_gen3") / "gen3.xml"
UR5E_MENAGERIE_JOINTS = {f"{name}_joint": name for name in UR5E_JOINT_NAMES}
GEN3_MENAGERIE_JOINTS = {name: name for name in gen3.JOINT_NAMES}


def menagerie_root() -> Path | None:
    value = os.environ.get(MENAGERIE_ENV)
    return Path(value) if value else None


def load_menagerie_arm(
    robot: str,
    xml: Path,
    *,
    joints: Mapping[str, str],
    base: str,
    flange: str,
    root: str | Path | None = None,
) -> mujoco.MjSpec:
    """Load ``root / xml`` and adapt it to the RobotSpec contract (see the module docstring).

    ``joints`` maps Menagerie joint names to ours, ``base`` names Menagerie's root body and ``flange``
    its tool-flange site. Missing files or elements raise ``ValueError`` naming the robot and path.
    """
    root = Path(root) if root is not None else menagerie_root()
    if root is None:
        raise ValueError(f"robot {robot!r} needs {MENAGERIE_ENV} set to a local mujoco_menagerie copy")
    path = root / xml
    if not path.is_file():
        raise ValueError(f"robot {robot!r}: {MENAGERIE_ENV}={root}: {xml} not found")
    spec = mujoco.MjSpec.from_file(str(path))
    for actuator in list(spec.actuators):
        spec.delete(actuator)
    for key in list(spec.keys):
        spec.delete(key)
    spec.nkey = 0  # a <size nkey=...> would otherwise keep empty keyframes of the arm's old nq
    for joint in spec.joints:
        if joint.name in joints:
            joint.name = joints[joint.name]
    missing = [ours for ours in joints.values() if spec.joint(ours) is None]
    if missing:
        raise ValueError(f"{path}: joints {missing} not found (expected Menagerie names {sorted(joints)})")
    site = spec.site(flange)
    if site is None:
        raise ValueError(f"{path}: no site {flange!r} (the tool flange)")
    site.name = "flange"
    root_body = spec.body(base)
    if root_body is None:
        raise ValueError(f"{path}: no body {base!r} (the arm's root)")
    root_body.name = "base"
    for body in spec.bodies:
        if body.name not in ("world", "base"):
            body.gravcomp = 1.0
    for geom in spec.geoms:
        if geom.contype or geom.conaffinity:
            geom.contype, geom.conaffinity = ROBOT_CONTYPE, ROBOT_CONAFFINITY
    return spec


def build_menagerie_ur5e_arm(root: str | Path | None = None) -> mujoco.MjSpec:
    return load_menagerie_arm(
        "ur5e_menagerie",
        UR5E_XML,
        joints=UR5E_MENAGERIE_JOINTS,
        base="base",
        flange="attachment_site",
        root=root,
    )


def build_menagerie_gen3_arm(root: str | Path | None = None) -> mujoco.MjSpec:
    spec = load_menagerie_arm(
        "gen3_menagerie",
        GEN3_XML,
        joints=GEN3_MENAGERIE_JOINTS,
        base="base_link",
        flange="pinch_site",
        root=root,
    )
    for i, name in enumerate(gen3.JOINT_NAMES):
        joint = spec.joint(name)
        joint.armature = gen3.ARMATURE[i]
        # MuJoCo 4 joint damping and stiffness are polynomial coefficients (linear term first)
        joint.damping = [gen3.DAMPING[i], 0.0, 0.0]
        joint.stiffness = [gen3.POSTURE_STIFFNESS[i], 0.0, 0.0]
        joint.springref = float(gen3.HOME_QPOS[i])
    return spec


# Same joint conventions, home configuration, gripper, gains and F/T sensor as the primitive robots;
# only the arm's geometry differs.
UR5E_MENAGERIE = replace(UR5E, name="ur5e_menagerie", build_arm=build_menagerie_ur5e_arm)
GEN3_MENAGERIE = replace(gen3.GEN3, name="gen3_menagerie", build_arm=build_menagerie_gen3_arm)
