import numpy as np
import pytest

from lerobot_forcemap import geometry as g


def random_quats(n, seed=0):
    rng = np.random.default_rng(seed)
    return g.quat_normalize(rng.normal(size=(n, 4)))


def test_quat_rows_to_matrix_equals_quat_to_matrix_bit_for_bit():
    rows = np.random.default_rng(3).normal(size=(50, 9)) * np.array([1e-3, 1, 1e3, 1, 1, 1, 1, 1, 1])
    q = rows[:, 2:6]  # a strided column block, as the envs pass the sensor rows; not normalised
    assert g.quat_rows_to_matrix(q).tobytes() == g.quat_to_matrix(q).tobytes()


def test_matrix_round_trip_and_rotation_agree():
    q = random_quats(200)
    m = g.quat_to_matrix(q)
    np.testing.assert_allclose(
        np.einsum("nij,njk->nik", m, np.swapaxes(m, 1, 2)), np.broadcast_to(np.eye(3), m.shape), atol=1e-12
    )
    q2 = g.matrix_to_quat(m)
    # same rotation up to sign
    np.testing.assert_allclose(np.abs(np.sum(q * q2, axis=1)), 1.0, atol=1e-10)
    v = np.random.default_rng(1).normal(size=(200, 3))
    np.testing.assert_allclose(g.quat_rotate(q, v), np.einsum("nij,nj->ni", m, v), atol=1e-12)


def test_multiply_composes_rotations():
    a, b = random_quats(50, 2), random_quats(50, 3)
    v = np.random.default_rng(4).normal(size=(50, 3))
    np.testing.assert_allclose(
        g.quat_rotate(g.quat_multiply(a, b), v), g.quat_rotate(a, g.quat_rotate(b, v)), atol=1e-12
    )


def test_rotvec_round_trip():
    r = np.random.default_rng(5).uniform(-1.5, 1.5, size=(100, 3))
    np.testing.assert_allclose(g.quat_to_rotvec(g.rotvec_to_quat(r)), r, atol=1e-12)
    np.testing.assert_allclose(g.quat_to_rotvec([1.0, 0, 0, 0]), 0.0)


def test_slerp_endpoints_midpoint_and_constant_speed():
    q0 = g.rotvec_to_quat([0, 0, 0.0])
    q1 = g.rotvec_to_quat([0, 0, 1.2])
    np.testing.assert_allclose(g.slerp(q0, q1, 0.0), q0, atol=1e-12)
    np.testing.assert_allclose(g.slerp(q0, q1, 1.0), q1, atol=1e-12)
    t = np.linspace(0, 1, 7)
    angles = g.quat_to_rotvec(g.slerp(q0, q1, t))[:, 2]
    np.testing.assert_allclose(angles, 1.2 * t, atol=1e-12)
    # short arc: -q1 is the same rotation
    np.testing.assert_allclose(g.quat_to_rotvec(g.slerp(q0, -q1, 0.5))[2], 0.6, atol=1e-12)


def test_slerp_sequence_clamps_and_interpolates():
    times = np.array([0.0, 1.0, 2.0])
    quats = g.rotvec_to_quat([[0, 0, 0], [0, 0, 1.0], [0, 0, 1.5]])
    out = g.quat_to_rotvec(g.slerp_sequence(times, quats, [-1.0, 0.5, 1.5, 3.0]))[:, 2]
    np.testing.assert_allclose(out, [0.0, 0.5, 1.25, 1.5], atol=1e-12)


def test_zero_quaternion_rejected():
    with pytest.raises(
        ValueError, match=r"^q: must hold quaternions of norm >= 1e-12, got a \(near\) zero norm"
    ):
        g.quat_normalize([0, 0, 0, 0])


def test_polyline_distances_to_segments_ends_and_a_single_point():
    path = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]])
    points = np.array([[0.5, 0.2, 0.0], [-0.3, 0.0, 0.4], [1.2, 0.5, 0.0], [0.5, 0.5, 0.0]])
    expected = [0.2, 0.5, 0.2, 0.5]
    np.testing.assert_allclose(g.polyline_distances(points, path), expected, atol=1e-12)
    # chunks of points give the same answer as one block
    many = np.random.default_rng(3).uniform(-1, 2, size=(700, 3))
    np.testing.assert_array_equal(g.polyline_distances(many, path, chunk=7), g.polyline_distances(many, path))
    np.testing.assert_allclose(g.polyline_distances(points[:1], path[1:2]), [np.hypot(0.5, 0.2)], atol=1e-12)
