"""The optional Menagerie path, against Menagerie-style folders written from our own arms.

The real mujoco_menagerie files are not downloaded in tests; this checks the adaptation (servos and
keyframes removed, joints, root body and flange renamed, the Gen3 drive model restored) and that tasks
run on the adapted arms with the primitive arms' joint conventions. With ``MENAGERIE_ROOT`` set when
pytest starts, the last test runs the scripted demonstrators on the real Menagerie arms too.
"""

import os

import mujoco
import numpy as np
import pytest

from lerobot_forcemap.envs.robots.gen3 import build_gen3_arm
from lerobot_forcemap.envs.robots.menagerie import (
    GEN3_XML,
    MENAGERIE_ENV,
    UR5E_XML,
    build_menagerie_gen3_arm,
    build_menagerie_ur5e_arm,
)
from lerobot_forcemap.envs.robots.ur5e import build_ur5e_arm

from .helpers import roll_demos

REAL_MENAGERIE = os.environ.get(MENAGERIE_ENV)  # read before any fixture patches it


def _write_menagerie(spec: mujoco.MjSpec, path, monkeypatch):
    """Write ``spec`` as a Menagerie model file at ``MENAGERIE_ROOT / <robot folder> / <file>``."""
    path.parent.mkdir(parents=True)
    path.write_text(spec.to_xml())
    root = path.parents[1]
    monkeypatch.setenv(MENAGERIE_ENV, str(root))
    return root


@pytest.fixture()
def fake_menagerie(tmp_path, monkeypatch):
    spec = build_ur5e_arm()
    for j in spec.joints:
        j.name = f"{j.name}_joint"
    spec.site("flange").name = "attachment_site"
    # as in Menagerie's ur5e.xml: the base turned by 180 degrees about z, the link frames turned back
    # (the same joint angles give the same flange pose as the DH arm)
    spec.body("base").quat = [0, 0, 0, -1]
    spec.body("link_1").quat = [0, 0, 0, 1]
    for j in ("shoulder_pan_joint", "elbow_joint"):
        act = spec.add_actuator(name=j.replace("_joint", ""), target=j, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=2000, kv=400)
    spec.add_key(name="home", qpos=[0.0] * 6)
    return _write_menagerie(spec, tmp_path / UR5E_XML, monkeypatch)


def test_menagerie_arm_is_adapted(fake_menagerie):
    spec = build_menagerie_ur5e_arm()
    model = spec.compile()
    assert model.nu == 0 and model.nkey == 0
    assert model.site("flange").id >= 0 and model.joint("shoulder_pan").id >= 0
    assert all(model.body_gravcomp[i] == 1 for i in range(2, model.nbody))


def test_task_runs_on_the_menagerie_arm(fake_menagerie):
    import lerobot_forcemap.envs as E

    env = E.make("press", robot="ur5e_menagerie")
    obs, _ = env.reset(seed=0)
    assert env.unwrapped.state_names["agent_pos"][0] == "shoulder_pan"
    # the same start: TCP pose and joint configuration (elbow up; a wrong IK seed ends elbow-down with
    # the forearm on the table)
    ref = E.make("press")
    obs_ref, _ = ref.reset(seed=0)
    np.testing.assert_allclose(obs["ee_pose"], obs_ref["ee_pose"], atol=1e-4)
    np.testing.assert_allclose(obs["agent_pos"], obs_ref["agent_pos"], atol=1e-4)
    [demo] = roll_demos("press", [0], robot="ur5e_menagerie")
    assert demo["info"]["is_success"] and not demo["info"]["protective_stop"]


def test_missing_root_is_a_clear_error(monkeypatch):
    monkeypatch.delenv(MENAGERIE_ENV, raising=False)
    with pytest.raises(ValueError, match=MENAGERIE_ENV):
        build_menagerie_ur5e_arm()


@pytest.fixture()
def fake_gen3_menagerie(tmp_path, monkeypatch):
    """Our Gen3 arm written the way Menagerie's kinova_gen3/gen3.xml names it: root body
    ``base_link``, tool site ``pinch_site``, joints without damping or springs, servos and keyframes."""
    spec = build_gen3_arm()
    spec.body("base").name = "base_link"
    spec.site("flange").name = "pinch_site"
    for j in spec.joints:
        j.armature = j.springref = 0.0
        j.damping = j.stiffness = [0.0, 0.0, 0.0]
        act = spec.add_actuator(name=j.name, target=j.name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=2000, kv=100)
    spec.add_key(name="home", qpos=[0.0] * 7)
    return _write_menagerie(spec, tmp_path / GEN3_XML, monkeypatch)


def test_menagerie_gen3_arm_is_adapted_with_the_drive_model(fake_gen3_menagerie):
    model = build_menagerie_gen3_arm().compile()
    ref = build_gen3_arm().compile()
    assert model.nu == 0 and model.nkey == 0
    assert model.body("base").id == 1 and model.site("flange").id >= 0
    # the null-space drive (armature, damping, posture springs at home) is restored on Menagerie's bare joints
    for field in ("dof_armature", "dof_damping", "jnt_stiffness", "qpos_spring"):
        np.testing.assert_array_equal(getattr(model, field), getattr(ref, field))
    assert all(model.body_gravcomp[i] == 1 for i in range(2, model.nbody))


def test_grasp_demonstration_runs_on_the_menagerie_gen3(fake_gen3_menagerie):
    [menagerie] = roll_demos("grasp_push", [0], robot="gen3_menagerie")
    [primitive] = roll_demos("grasp_push", [0])
    assert menagerie["info"]["is_success"] and not menagerie["info"]["protective_stop"]
    # the same arm under another name: the same motion to float precision of the XML round trip
    assert menagerie["n"] == primitive["n"]
    np.testing.assert_allclose(menagerie["actions"], primitive["actions"], atol=1e-6)


@pytest.mark.parametrize("build", [build_menagerie_ur5e_arm, build_menagerie_gen3_arm])
def test_missing_menagerie_file_names_the_robot_and_path(build, tmp_path):
    with pytest.raises(ValueError, match=r"menagerie'.*not found"):
        build(tmp_path)


@pytest.mark.skipif(not REAL_MENAGERIE, reason=f"set {MENAGERIE_ENV} to a local mujoco_menagerie copy")
@pytest.mark.parametrize(
    "task, robot",
    [("press", "ur5e_menagerie"), ("erase", "ur5e_menagerie"), ("peg_in_hole", "ur5e_menagerie"),
     ("grasp_push", "gen3_menagerie"), ("grasp_flip", "gen3_menagerie")],
)  # fmt: skip
def test_demonstrators_succeed_on_the_real_menagerie_arms(task, robot, monkeypatch):
    monkeypatch.setenv(MENAGERIE_ENV, REAL_MENAGERIE)
    for demo in roll_demos(task, range(3), robot=robot):
        assert demo["info"]["is_success"] and not demo["info"]["protective_stop"], (task, demo["seed"])
