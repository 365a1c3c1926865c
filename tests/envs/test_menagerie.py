"""The optional Menagerie path, against a Menagerie-style folder written from our own arm.

The real mujoco_menagerie files are not downloaded in tests; this checks the adaptation (servos and
keyframes removed, joints and flange renamed, base rotated 180 degrees) and that a task runs on it.
"""

import math

import mujoco
import numpy as np
import pytest

from lerobot_forcemap.envs.robots.menagerie import MENAGERIE_ENV, build_menagerie_ur5e_arm
from lerobot_forcemap.envs.robots.ur5e import build_ur5e_arm


@pytest.fixture()
def fake_menagerie(tmp_path, monkeypatch):
    spec = build_ur5e_arm()
    for j in spec.joints:
        j.name = f"{j.name}_joint"
    spec.site("flange").name = "attachment_site"
    spec.body("base").quat = [0, 0, 0, -1]
    for j in ("shoulder_pan_joint", "elbow_joint"):
        act = spec.add_actuator(name=j.replace("_joint", ""), target=j, trntype=mujoco.mjtTrn.mjTRN_JOINT)
        act.set_to_position(kp=2000, kv=400)
    spec.add_key(name="home", qpos=[0.0] * 6)
    folder = tmp_path / "universal_robots_ur5e"
    folder.mkdir()
    (folder / "ur5e.xml").write_text(spec.to_xml())
    monkeypatch.setenv(MENAGERIE_ENV, str(tmp_path))
    return tmp_path


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
    # the same TCP start pose is reached with the first joint turned by pi (base rotated 180 degrees)
    ref = E.make("press")
    obs_ref, _ = ref.reset(seed=0)
    np.testing.assert_allclose(obs["ee_pose"], obs_ref["ee_pose"], atol=1e-4)
    assert abs(abs(obs["agent_pos"][0] - obs_ref["agent_pos"][0]) - math.pi) < 1e-3
    obs, *_ = env.step(np.concatenate([obs["ee_pose"], [1.0]]))


def test_missing_root_is_a_clear_error(monkeypatch):
    monkeypatch.delenv(MENAGERIE_ENV, raising=False)
    with pytest.raises(ValueError, match=MENAGERIE_ENV):
        build_menagerie_ur5e_arm()
