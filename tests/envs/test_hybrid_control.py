import numpy as np
import pytest

import lerobot_forcemap.envs as E
from lerobot_forcemap.envs.hybrid_control import FORCE, POSITION, HybridConfig, HybridForcePositionPolicy

DEMO = np.tile([0.5, 0.0, 0.1, 0.0, 1.0, 0.0, 0.0, 1.0], (10, 1))


def obs(force_z, tcp_z=0.05):
    return {
        "force": np.array([0, 0, force_z, 0, 0, 0], np.float32),
        "ee_pose": np.array([0.5, 0, tcp_z, 0, 1, 0, 0], np.float32),
    }


def test_position_mode_replays_the_demonstration():
    pol = HybridForcePositionPolicy(DEMO, HybridConfig(force_threshold=10.0))
    np.testing.assert_allclose(pol.act(obs(2.0)), DEMO[0])
    assert pol.modes == [POSITION]


def test_force_mode_regulates_along_the_normal_and_releases():
    demo = DEMO.copy()
    demo[:, 2] = -0.05  # the demonstration pushes 10 cm below the TCP
    cfg = HybridConfig(force_threshold=10.0, force_setpoint=8.0, stiffness=2000.0, integral_gain=0.0)
    pol = HybridForcePositionPolicy(demo, cfg)
    a = pol.act(obs(12.0, tcp_z=0.05))
    assert pol.mode == FORCE
    assert a[2] == pytest.approx(0.05 - 8.0 / 2000.0)  # target = tcp - F_set / K
    np.testing.assert_allclose(
        a[[0, 1, 3, 4, 5, 6, 7]], demo[0, [0, 1, 3, 4, 5, 6, 7]]
    )  # tangential etc. follow
    # the demonstration withdraws above the force-controlled target: back to position control
    pol.demo[:, 2] = 0.2
    a = pol.act(obs(12.0, tcp_z=0.05))
    assert pol.mode == POSITION and a[2] == pytest.approx(0.2)


def test_offset_and_validation():
    pol = HybridForcePositionPolicy(DEMO)
    pol.reset(offset=[0.01, 0, 0])
    assert pol.act(obs(0.0))[0] == pytest.approx(0.51)
    with pytest.raises(ValueError, match=r"demo_actions: must have shape \(any, 8\), got shape \(5, 7\)"):
        HybridForcePositionPolicy(np.zeros((5, 7)))
    bad = DEMO.copy()
    bad[3, 0] = np.nan
    with pytest.raises(
        ValueError, match=r"demo_actions: must hold finite values only .* at step 3, column 0\)"
    ):
        HybridForcePositionPolicy(bad)
    for normal in ((0, 0, 0), (0, 0, np.nan), (0, 1)):  # a zero normal would never engage force control
        with pytest.raises(ValueError, match="HybridConfig.normal: must be a finite non-zero 3-vector"):
            HybridConfig(normal=normal)
    bad_settings = {
        "force_threshold": (np.nan, 0.0, -1.0, np.inf),
        "stiffness": (np.nan, 0.0),
        "control_hz": (0.0, np.nan),
        "force_setpoint": (np.nan, np.inf, 0.0),
        "integral_gain": (-0.1, np.nan, np.inf),
        "release_fraction": (np.nan, -0.1, 1.0),
    }
    for name, values in bad_settings.items():
        for value in values:
            with pytest.raises(ValueError, match=f"HybridConfig.{name}: must be a finite number"):
                HybridConfig(**{name: value})
    HybridConfig(
        force_threshold=np.float32(3.0), integral_gain=0, release_fraction=0
    )  # numpy and int are fine


def test_hybrid_control_lowers_the_press_force_and_still_succeeds(demo_rollouts):
    rollout = demo_rollouts("press")[0]
    env = E.make("press")
    results = {}
    for label, policy in (
        ("replay", None),
        ("hybrid", HybridForcePositionPolicy(rollout["actions"], HybridConfig(force_threshold=10.0))),
    ):
        obs_, info = env.reset(seed=rollout["seed"])
        for t in range(env.spec.max_episode_steps):
            a = (
                rollout["actions"][min(t, len(rollout["actions"]) - 1)]
                if policy is None
                else policy.act(obs_)
            )
            obs_, _, term, trunc, info = env.step(a)
            if term or trunc:
                break
        results[label] = info
    assert results["replay"]["max_contact_force"] == pytest.approx(
        rollout["info"]["max_contact_force"]
    )  # deterministic
    assert results["hybrid"]["is_success"]
    assert results["hybrid"]["max_contact_force"] < 0.8 * results["replay"]["max_contact_force"]
    assert results["hybrid"]["mean_contact_force"] < 0.6 * results["replay"]["mean_contact_force"]
