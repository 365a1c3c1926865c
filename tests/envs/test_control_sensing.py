import mujoco
import numpy as np
import pytest

from lerobot_forcemap.envs.control import SpeedLimit, Workspace, clip_target, interpolate_targets
from lerobot_forcemap.envs.sensing import ForceStats, LowPass, Payload
from lerobot_forcemap.geometry import quat_multiply, quat_to_matrix, quat_to_rotvec, rotvec_to_quat

WS = Workspace(low=(0.0, -0.5, -0.1), high=(1.0, 0.5, 0.5))
DOWN = np.array([0.0, 1.0, 0.0, 0.0])


def test_clip_inside_is_identity():
    p, q, rep = clip_target(
        np.array([0.5, 0, 0.2]), DOWN, np.array([0.5, 0, 0.2]), DOWN, 0.05, WS, SpeedLimit()
    )
    assert not rep.any and rep.clipped_distance == 0
    np.testing.assert_allclose(q, DOWN)


def test_clip_speed_and_workspace_are_reported():
    prev = np.array([0.5, 0.0, 0.2])
    p, q, rep = clip_target(np.array([0.5, 0.0, 0.9]), DOWN, prev, DOWN, 0.05, WS, SpeedLimit(linear=0.2))
    assert rep.workspace and rep.speed
    np.testing.assert_allclose(p, prev + [0, 0, 0.2 * 0.05])
    np.testing.assert_allclose(rep.clipped_distance, 0.9 - 0.21)


def test_clip_rotation_speed_and_invalid_quaternion():
    big = quat_multiply(rotvec_to_quat([0.0, 0.0, 1.0]), DOWN)
    p, q, rep = clip_target(
        np.array([0.5, 0, 0.2]), big, np.array([0.5, 0, 0.2]), DOWN, 0.05, WS, SpeedLimit(angular=1.0)
    )
    assert rep.speed
    angle = np.linalg.norm(quat_to_rotvec(quat_multiply(q, DOWN * [1, -1, -1, -1])))
    np.testing.assert_allclose(angle, 0.05, atol=1e-9)
    p, q, rep = clip_target(
        np.array([0.5, 0, 0.2]), np.zeros(4), np.array([0.5, 0, 0.2]), DOWN, 0.05, WS, SpeedLimit()
    )
    assert rep.orientation_invalid
    np.testing.assert_allclose(q, DOWN)


def test_interpolation_is_linear_and_slerp():
    q1 = quat_multiply(rotvec_to_quat([0.0, 0.0, 0.4]), DOWN)
    P, Q = interpolate_targets(np.zeros(3), DOWN, np.array([0.1, 0.0, 0.0]), q1, 4)
    np.testing.assert_allclose(P[:, 0], [0.025, 0.05, 0.075, 0.1])
    np.testing.assert_allclose(Q[-1], q1, atol=1e-12)
    angles = [np.linalg.norm(quat_to_rotvec(quat_multiply(q, DOWN * [1, -1, -1, -1]))) for q in Q]
    np.testing.assert_allclose(angles, [0.1, 0.2, 0.3, 0.4], atol=1e-9)


def test_lowpass_matches_loop_and_is_continuous_across_blocks():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(100, 3))
    f = LowPass(10.0, 0.002, 3)
    y = np.vstack([f(x[:37]), f(x[37:])])
    a = f.alpha
    ref = np.zeros(3)
    out = []
    for row in x:
        ref = ref + a * (row - ref)
        out.append(ref)
    np.testing.assert_allclose(y, np.array(out), atol=1e-12)
    np.testing.assert_allclose(a, 1 - np.exp(-2 * np.pi * 10 * 0.002))


def test_payload_wrench_at_any_orientation():
    payload = Payload(mass=1.2, com_site=np.array([0.01, -0.02, 0.05]))
    rng = np.random.default_rng(1)
    q = rng.normal(size=(10, 4))
    q /= np.linalg.norm(q, axis=1, keepdims=True)
    w = payload.expected_wrench(q)
    R = quat_to_matrix(q)
    f_world = np.einsum("nij,nj->ni", R, w[:, :3])
    np.testing.assert_allclose(f_world, np.tile([0, 0, 1.2 * 9.81], (10, 1)), atol=1e-12)
    np.testing.assert_allclose(w[:, 3:], np.cross(payload.com_site, w[:, :3]), atol=1e-12)


def test_force_stats():
    rng = np.random.default_rng(2)
    a, b = rng.normal(size=(30, 3, 3)), rng.normal(size=(20, 3, 3))  # 3 signals
    s = ForceStats(3)
    np.testing.assert_array_equal(s.mean_norm, 0.0)
    s.update(a)
    s.update(b)
    for k in range(3):
        allf = np.vstack([a[:, k], b[:, k]])
        assert s.max_norm[k] == pytest.approx(np.linalg.norm(allf, axis=1).max())
        assert s.mean_norm[k] == pytest.approx(np.linalg.norm(allf, axis=1).mean())
        np.testing.assert_allclose(s.max_abs[k], np.abs(allf).max(axis=0))
        np.testing.assert_allclose(s.mean_abs[k], np.abs(allf).mean(axis=0))


def test_impedance_static_stiffness_law():
    """A force F at the TCP displaces it by F / K (K = 2000 N/m along each base axis)."""
    import lerobot_forcemap.envs as E

    env = E.make("press", randomize=False).unwrapped
    env.reset(seed=0)
    m, d, ix = env.model, env.data, env.index
    body = m.site_bodyid[ix.tcp_site]
    K = env.gains.stiffness_pos[0]
    for axis, F in ((0, 15.0), (2, 20.0)):
        env.reset(seed=0)
        p0 = d.site_xpos[ix.tcp_site].copy()
        force = np.zeros(3)
        force[axis] = F
        for _ in range(1500):  # 3 s: settle under the constant force
            d.qfrc_applied[:] = 0
            mujoco.mj_applyFT(m, d, force, np.zeros(3), d.site_xpos[ix.tcp_site], body, d.qfrc_applied)
            mujoco.mj_step(m, d)
        disp = d.site_xpos[ix.tcp_site] - p0
        assert disp[axis] == pytest.approx(F / K, rel=0.02)


def test_base_frame_round_trip():
    from lerobot_forcemap.envs.scene import BaseFrame

    frame = BaseFrame(np.array([0.1, -0.2, 0.3]), rotvec_to_quat([0.0, 0.0, np.pi / 2]))
    p = np.array([0.5, 0.0, 0.1])
    np.testing.assert_allclose(frame.pos_to_world(p), [0.1, 0.3, 0.4], atol=1e-12)
    np.testing.assert_allclose(frame.pos_to_base(frame.pos_to_world(p)), p, atol=1e-12)
    q = rotvec_to_quat([0.3, -0.2, 0.1])
    np.testing.assert_allclose(np.abs(frame.quat_to_base(frame.quat_to_world(q)) @ q), 1.0, atol=1e-12)
    np.testing.assert_allclose(frame.vec_to_base([0.0, 1.0, 0.0]), [1.0, 0.0, 0.0], atol=1e-12)
    assert not frame.is_identity and BaseFrame(np.zeros(3), np.array([1.0, 0, 0, 0])).is_identity
