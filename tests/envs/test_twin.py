"""The twin of a recording: on a press recorded in the simulator itself (the scene it came from is
known) and, with ``realdata``, on the lab recordings."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import numpy as np
import pytest

from lerobot_forcemap.data.reader import read_episodes
from lerobot_forcemap.envs import make
from lerobot_forcemap.envs.tasks import press as press_task
from lerobot_forcemap.envs.twin import build_twin, make_twin, read_recording, replay, replay_actions

REPO = Path(__file__).resolve().parents[2]
PRESS = REPO / "datasets" / "press"

# tolerances of the recovered scene
BUTTON_Z_MM = 2.0  # rest surface height against the press point
BUTTON_XY_MM = 5.0  # the demonstrator aims up to a few mm off the button centre
STIFFNESS_REL = 0.25
TOOL_OFFSET_MM = 1.0


@pytest.fixture(scope="module")
def press_twin():
    return build_twin(PRESS, 0, kinesthetic=False)


def _tcp_in_flange() -> np.ndarray:
    """The press env's TCP in its flange frame (what the recorded ee_pose is, in the simulator)."""
    env = make("press").unwrapped
    m, d = env.model, mujoco.MjData(env.model)
    mujoco.mj_kinematics(m, d)
    f, t = m.site("ur5e/flange").id, m.site("ur5e/tcp").id
    out = d.site_xmat[f].reshape(3, 3).T @ (d.site_xpos[t] - d.site_xpos[f])
    env.close()
    return out


def test_synthetic_press_recovers_the_scene(press_twin):
    r, scene = press_twin.report, press_twin.scene
    assert r["kind"] == "press"
    truth = read_episodes(PRESS, [0], ["observation.environment_state"]).columns[
        "observation.environment_state"
    ][0]
    pos = np.asarray(scene.surface_pos)
    assert abs(pos[2] - truth[2]) * 1e3 < BUTTON_Z_MM
    assert np.linalg.norm(pos[:2] - truth[:2]) * 1e3 < BUTTON_XY_MM
    assert abs(scene.stiffness - press_task.SPRING_STIFFNESS) < STIFFNESS_REL * press_task.SPRING_STIFFNESS
    np.testing.assert_allclose(
        np.asarray(r["tool_offset_mm"]) / 1e3, _tcp_in_flange(), atol=TOOL_OFFSET_MM / 1e3
    )
    assert r["tcp_residual_rms_mm"] < 1.0
    assert r["replay"]["correlation"] > 0.9
    assert abs(r["replay"]["peak_error_n"]) < 0.2 * r["replay"]["peak_recorded_n"]


def test_twin_env_replays_to_success_and_round_trips(press_twin):
    scene = press_twin.scene
    env = make_twin(scene.to_dict(), render_mode=None)
    rec = read_recording(PRESS, 0)
    obs, _ = env.reset(seed=0)
    # the env reports the recorded tool frame: its start is the recording's
    np.testing.assert_allclose(obs["ee_pose"][:3], rec.pose[0, :3], atol=1e-3)
    force, info = replay(env, replay_actions(rec))
    env.close()
    assert info["is_success"]
    assert force.shape[1] == 3 and force[:, 2].max() > 10.0
    assert json.loads(json.dumps(scene.to_dict())) == scene.to_dict()


def test_refuses_a_recording_without_ur5e_joints():
    with pytest.raises(ValueError, match=r"episode grasp_push\[0\]: must have UR5e joint positions"):
        build_twin(REPO / "datasets" / "grasp_push", 0)


@pytest.mark.realdata
@pytest.mark.slow
def test_real_press_and_wipe_twins(shared_data, tmp_path):
    from lerobot_forcemap.data.convert import convert_recordings

    ur5e = shared_data / "ur5e"
    convert_recordings([ur5e / "press_2023-07-27_160940.h5"], tmp_path / "press")
    convert_recordings([ur5e / "erase_2024-09-09_153311.h5"], tmp_path / "erase")
    convert_recordings([ur5e / "circle_cw1.h5"], tmp_path / "circle")
    for name, kind in (("press", "press"), ("erase", "wipe")):
        r = build_twin(tmp_path / name, 0).report
        assert r["kind"] == kind
        # the converted ee_pose is the flange: the scene's UR5e matches the lab's within a millimetre
        assert r["tcp_residual_rms_mm"] < 1.0
        assert np.linalg.norm(r["tool_offset_mm"]) < 2.0
    with pytest.raises(ValueError, match=r"episode circle\[0\]: must have a detectable contact"):
        build_twin(tmp_path / "circle", 0)


def test_forcemap_twin_env_type(press_twin, tmp_path):
    from lerobot.envs.factory import make_env, make_env_config

    import lerobot_env_forcemap  # noqa: F401  (registers the env types)
    from lerobot_forcemap.envs.twin import write_twin

    write_twin(press_twin, tmp_path / "twin")
    cfg = make_env_config("forcemap_twin", twin=str(tmp_path / "twin"))
    assert cfg.episode_length == press_twin.scene.max_steps
    env = make_env(cfg, n_envs=1)["forcemap_twin"][0]
    obs, _ = env.reset(seed=0)
    assert obs["environment_state"].shape == (1, 9) and obs["ee_pose"].shape == (1, 7)
    assert env.call("task_description")[0] == press_twin.scene.task
    env.close()
    with pytest.raises(ValueError, match="twin: must be an existing path"):
        make_env_config("forcemap_twin", twin=str(tmp_path / "absent"))
