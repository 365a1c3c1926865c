"""Force sensing laws: wrist F/T (tared, filtered, reaction, base frame) vs the summed contact force."""

import numpy as np
import pytest

import lerobot_forcemap.envs as E


def hold(env, target, gripper, steps):
    for _ in range(steps):
        obs, _, term, _, info = env.step(np.concatenate([target, [gripper]]))
        assert not term, info["termination_reason"]
    return obs, info


def move_to(env, obs, pos, gripper, steps=40):
    start = obs["ee_pose"][:3].astype(float)
    quat = obs["ee_pose"][3:].astype(float)
    for s in np.linspace(0, 1, steps)[1:]:
        obs, _, term, _, info = env.step(np.concatenate([start + s * (pos - start), quat, [gripper]]))
    return obs, info


def assert_agree(obs, info, min_force):
    wrist = obs["force"][:3].astype(float)
    contact = info["contact_force"]
    assert np.linalg.norm(contact) > min_force
    assert np.linalg.norm(wrist - contact) <= 0.05 * np.linalg.norm(contact), (wrist, contact)
    assert wrist[2] > 0  # reaction convention: pushing down reads +z (away from the surface)


def test_wrist_agrees_with_contacts_pressing_the_button():
    env = E.make("press")
    obs, _ = env.reset(seed=1)
    p = obs["environment_state"][:3].astype(float)
    quat = obs["ee_pose"][3:].astype(float)
    obs, info = move_to(env, obs, p + [0, 0, 0.02], 1.0)
    obs, info = move_to(env, obs, p - [0, 0, 0.025], 1.0, steps=30)
    obs, info = hold(env, np.concatenate([p - [0, 0, 0.025], quat]), 1.0, 30)
    assert_agree(obs, info, min_force=10.0)
    assert info["max_button_travel"] >= 0.008


def test_wrist_agrees_with_contacts_erasing():
    env = E.make("erase")
    obs, _ = env.reset(seed=2)
    names = env.unwrapped.state_names["environment_state"]
    st = dict(zip(names, obs["environment_state"].astype(float), strict=True))
    board = np.array([st["board_x"], st["board_y"], st["board_z"]])
    quat = obs["ee_pose"][3:].astype(float)
    obs, info = move_to(env, obs, board + [0, 0, 0.02], 0.6)
    obs, info = move_to(env, obs, board - [0, 0, 0.015], 0.6, steps=30)
    obs, info = hold(env, np.concatenate([board - [0, 0, 0.015], quat]), 0.6, 30)
    assert_agree(obs, info, min_force=8.0)
    # the eraser spring and the arm in series: F = d / (1/K_arm + 1/K_spring) = 0.015 m * 1000 N/m
    assert info["contact_force"][2] == pytest.approx(15.0, rel=0.1)


def test_wrist_agrees_with_contacts_through_a_held_disc():
    env = E.make("peg_in_hole")
    obs, _ = env.reset(seed=3)
    names = env.unwrapped.state_names["environment_state"]
    st = dict(zip(names, obs["environment_state"].astype(float), strict=True))
    tcp = obs["ee_pose"][:3].astype(float)
    disc_offset = np.array([st["disc_x"], st["disc_y"], st["disc_z"]]) - tcp
    # press the disc flat on the table next to the peg (held object -> contacts with the table count)
    target = np.array([st["peg_x"] - 0.09, st["peg_y"], 0.005]) - disc_offset
    obs, info = move_to(env, obs, target + [0, 0, 0.03], 1.0)
    obs, info = move_to(env, obs, target - [0, 0, 0.006], 1.0, steps=20)
    obs, info = hold(env, np.concatenate([target - [0, 0, 0.006], obs["ee_pose"][3:]]), 1.0, 30)
    assert_agree(obs, info, min_force=5.0)


def test_a_let_go_disc_is_no_force_on_the_robot():
    """ContactMonitor: a held body's contacts count only while it touches the robot; once let go, the
    disc's weight on the table is measured by its contact sensors but left out of the contact force."""
    env = E.make("peg_in_hole")
    u = env.unwrapped
    obs, _ = env.reset(seed=3)
    names = u.state_names["environment_state"]
    st = dict(zip(names, obs["environment_state"].astype(float), strict=True))
    tcp = obs["ee_pose"][:3].astype(float)
    disc_offset = np.array([st["disc_x"], st["disc_y"], st["disc_z"]]) - tcp
    target = np.array([st["peg_x"] - 0.09, st["peg_y"], 0.006]) - disc_offset  # disc resting on the table
    obs, info = move_to(env, obs, target + [0, 0, 0.03], 1.0)
    obs, info = move_to(env, obs, target, 1.0, steps=20)
    quat = obs["ee_pose"][3:].astype(float)
    obs, info = hold(env, np.concatenate([target, quat]), 0.0, 3)  # open: the disc stays on the table
    obs, info = hold(env, np.concatenate([target + [0, 0, 0.04], quat]), 0.0, 5)  # hand away, < 0.5 s
    assert info["disc_released_s"] > 0.2
    held = [i for i, b in enumerate(u.index.contact_held) if b == "disc"]
    on_table = u.data.sensordata[
        np.concatenate([np.arange(s.start, s.stop) for s in (u.index.contact_sensors[i] for i in held)])
    ]
    assert np.linalg.norm(on_table.reshape(-1, 3).sum(axis=0)) == pytest.approx(0.05 * 9.81, rel=0.1)
    assert np.linalg.norm(info["contact_force"]) < 1e-3, info["contact_force"]


def test_held_disc_is_tared_after_reset():
    """The F/T sensor is tared after reset: the held disc's weight (about 0.5 N) does not read as force."""
    env = E.make("peg_in_hole")
    obs, _ = env.reset(seed=3)
    obs, info = hold(env, obs["ee_pose"].astype(float), 1.0, 30)  # hold the start pose, disc gripped
    assert np.linalg.norm(info["contact_force"]) == 0.0
    assert np.linalg.norm(obs["force"][:3]) < 0.05, obs["force"]
    assert np.linalg.norm(obs["force"][3:]) < 0.005, obs["force"]
    assert env.unwrapped.bias_site[2] == pytest.approx(-0.5, abs=0.1)  # what the tare removed


def test_driving_into_the_table_triggers_the_protective_stop():
    env = E.make("press")
    obs, info = env.reset(seed=0)
    p = obs["ee_pose"][:3].astype(float)
    target = np.concatenate([[p[0] - 0.08, p[1] + 0.1, -0.1], obs["ee_pose"][3:], [1.0]])  # beside the button
    limit = env.unwrapped.task_impl.force_limit
    for _ in range(100):
        obs, reward, terminated, truncated, info = env.step(target)
        if terminated:
            break
    assert terminated and not truncated
    assert info["protective_stop"] and not info["is_success"] and reward == 0.0
    assert info["termination_reason"] == "protective_stop"
    # the arm stops at the physics step where the filtered force crossed the limit
    assert limit <= info["max_contact_force"] <= 1.02 * limit
    assert np.linalg.norm(info["contact_force"]) == pytest.approx(info["max_contact_force"])
    assert info["max_contact_force_xyz"][2] > 0.95 * limit


def test_excess_force_follows_the_stiffness():
    """Pressing the table: force = K x (TCP height - target height), K = 2000 N/m."""
    env = E.make("press")
    obs, _ = env.reset(seed=0)
    quat = obs["ee_pose"][3:].astype(float)
    spot = np.array([0.35, 0.15, 0.0])
    obs, _ = move_to(env, obs, spot + [0, 0, 0.02], 1.0)
    for depth in (0.005, 0.015):
        obs, info = move_to(env, obs, spot - [0, 0, depth], 1.0, steps=15)
        obs, info = hold(env, np.concatenate([spot - [0, 0, depth], quat]), 1.0, 30)
        expected = 2000.0 * (obs["ee_pose"][2] + depth)
        assert info["contact_force"][2] == pytest.approx(expected, rel=0.03)
