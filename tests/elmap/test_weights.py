"""Force points and the well-posedness law (a node at x̄ + r/(1−r)(x̄ − p̄), r capped at rho_max)."""

import numpy as np
import pytest

from lerobot_forcemap.elmap import (
    ForceNodeSums,
    assign_nearest,
    cluster_sums,
    fit_force_elastic_map,
    force_point_weights,
    make_force_points,
    solve_m_step_banded,
)


def three_clusters(n=50, seed=0):
    """Three well separated blobs, one per node, so that with λ = μ = 0 every node is isolated."""
    rng = np.random.default_rng(seed)
    centres = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    x = np.concatenate([c + 0.01 * rng.normal(size=(n, 3)) for c in centres])
    return x, centres


@pytest.mark.parametrize("r", [0.25, 0.5, 0.7])
def test_isolated_node_law_in_the_m_step(r):
    """y = x̄ + r/(1−r)(x̄ − p̄) with r = Σ|w_force| / Σ w_demo, per axis, smoothness off."""
    rng = np.random.default_rng(1)
    x, _ = three_clusters()
    labels = np.repeat([0, 1, 2], 50)
    forces = rng.normal(size=x.shape)  # arbitrary directions and sizes
    fp = make_force_points(x, forces, delta=0.01, f_contact=0.0)
    tied = labels[fp.source]
    # weights with exactly ratio r per node and axis: scale raw |f| by r·n / Σ|f|
    mag = fp.magnitude
    per_node = np.stack([np.bincount(tied, weights=mag[:, q], minlength=3) for q in range(3)], axis=1)
    wf = -mag * (r * 50 / per_node)[tied]
    Wd, bd = cluster_sums(labels, None, x, 3)
    Wf, bf = cluster_sums(tied, wf, fp.points, 3)
    y = solve_m_step_banded(Wd + Wf, bd + bf, float(len(x) * np.sqrt(3)), 0.0, 0.0)
    for i in range(3):
        sel = tied == i
        xbar = x[labels == i].mean(axis=0)
        pbar = (np.abs(wf[sel]) * fp.points[sel]).sum(axis=0) / np.abs(wf[sel]).sum(axis=0)
        np.testing.assert_allclose(y[i], xbar + r / (1 - r) * (xbar - pbar), rtol=0, atol=1e-8)


def blobs_flat_in_z(n=50, seed=0):
    """Three blobs spread in x and y only: every sample of a blob has the same height."""
    x, centres = three_clusters(n, seed)
    x[:, 2] = np.repeat(centres[:, 2], n)
    return x


@pytest.mark.parametrize("r", [0.25, 0.5, 0.7])
def test_isolated_node_law_in_the_full_fit(r):
    """All samples of one blob press with F along +z. At the fixed point the node obeys the law with the
    ratio r of its final weights; for samples at one point (no spread) r = a/(1+a) with a = F/(kδ), and
    the node lifts by exactly r/(1−r)·δ = F/k (Hooke's law)."""
    k, delta = 1000.0, 0.01
    F = r / (1 - r) * k * delta
    for spread in (True, False):
        x = (
            blobs_flat_in_z()
            if spread
            else np.repeat(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), 50, axis=0)
        )
        forces = np.zeros_like(x)
        forces[50:100, 2] = F
        fit = fit_force_elastic_map(
            x, forces, n_nodes=3, lam=0.0, mu=0.0, delta=delta, stiffness=k, f_contact=0.0, rho_max=0.75
        )
        assert fit.stop_reason == "converged"
        y = fit.nodes[1]
        xbar = x[50:100].mean(axis=0)
        p = x[50:100] - delta * np.array([0, 0, 1.0])
        w = F / (k * np.maximum(np.linalg.norm(p - y, axis=1), delta))  # |w_z| of each force point
        r_fit = w.sum() / 50
        pbar = (w[:, None] * p).sum(axis=0) / w.sum()
        np.testing.assert_allclose(
            y[2], xbar[2] + r_fit / (1 - r_fit) * (xbar[2] - pbar[2]), rtol=0, atol=1e-8
        )
        np.testing.assert_allclose(y[:2], xbar[:2], atol=1e-12)  # no force on x, y
        if not spread:
            np.testing.assert_allclose(r_fit, r, rtol=0, atol=1e-8)
            np.testing.assert_allclose(y[2] - xbar[2], F / k, rtol=0, atol=1e-8)
        assert len(fit.capped_nodes) == 0
        np.testing.assert_allclose(fit.nodes[0], x[:50].mean(axis=0), atol=1e-12)


def test_cap_engages_at_rho_max_and_is_reported():
    x = blobs_flat_in_z()
    k, delta, rho_max = 1000.0, 0.01, 0.75
    forces = np.zeros_like(x)
    forces[50:100, 2] = 50.0  # a = F/(kδ) = 5: the uncapped ratio would exceed rho_max
    fit = fit_force_elastic_map(
        x, forces, n_nodes=3, lam=0.0, mu=0.0, delta=delta, stiffness=k, f_contact=0.0, rho_max=rho_max
    )
    assert fit.stop_reason == "converged"
    xbar = x[50:100].mean(axis=0)
    # r is held at rho_max: lift = rho_max/(1 − rho_max)·δ = 3δ along the force
    np.testing.assert_allclose(fit.nodes[1, 2], xbar[2] + rho_max / (1 - rho_max) * delta, rtol=0, atol=1e-8)
    np.testing.assert_allclose(fit.nodes[1, :2], xbar[:2], atol=1e-12)
    assert fit.capped_nodes.tolist() == [[1, 2]]


def test_default_stiffness_keeps_a_100_newton_contact_below_the_cap():
    """The default k keeps r under rho_max for forces up to 100 N at the default δ."""
    import inspect

    from lerobot_forcemap.elmap.fit import DEFAULT_DELTA, DEFAULT_STIFFNESS

    params = inspect.signature(fit_force_elastic_map).parameters
    assert params["rho_max"].default == 0.75
    assert (params["stiffness"].default, params["delta"].default) == (DEFAULT_STIFFNESS, DEFAULT_DELTA)
    x = np.repeat(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), 50, axis=0)
    forces = np.zeros_like(x)
    forces[50:100, 2] = 100.0
    a = 100.0 / (DEFAULT_STIFFNESS * DEFAULT_DELTA)  # r before the node lifts (springs of length δ)
    # first iteration: the node sits on the contact, every spring is δ long, r = a
    first = fit_force_elastic_map(x, forces, n_nodes=3, lam=0.0, mu=0.0, max_iter=1)
    assert len(first.capped_nodes) == 0
    np.testing.assert_allclose(first.nodes[1, 2], a / (1 - a) * DEFAULT_DELTA, rtol=0, atol=1e-12)
    # steady state: r = a/(1+a), the node lifts by F/k
    fit = fit_force_elastic_map(x, forces, n_nodes=3, lam=0.0, mu=0.0)
    assert fit.stop_reason == "converged" and len(fit.capped_nodes) == 0
    np.testing.assert_allclose(fit.nodes[1, 2], 100.0 / DEFAULT_STIFFNESS, rtol=0, atol=1e-8)


@pytest.mark.parametrize("force, capped", [(88.0, False), (100.0, True)])
def test_cap_onset_is_three_k_delta(force, capped):
    """At the steady state r = a/(1+a), a = F/(k·δ): the rho_max = 0.75 cap binds from F = 3kδ (90 N at
    the policy's k = 3000 N/m, δ = 1 cm), not from F = 0.75·kδ; beyond it the lift stops following F/k."""
    k, delta = 3000.0, 0.01
    x = np.repeat(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), 50, axis=0)
    forces = np.zeros_like(x)
    forces[50:100, 2] = force
    fit = fit_force_elastic_map(
        x, forces, n_nodes=3, lam=0.0, mu=0.0, stiffness=k, delta=delta, max_iter=1000
    )
    assert fit.stop_reason == "converged"
    assert (len(fit.capped_nodes) > 0) is capped
    # uncapped: lifted by F/k; capped at r = 0.75: lifted by r/(1-r)·δ = 3δ, short of F/k
    want = 3 * delta if capped else force / k
    np.testing.assert_allclose(fit.nodes[1, 2], want, rtol=0, atol=1e-8)


def test_without_cap_the_node_is_pulled_into_the_surface():
    """The defect the cap fixes: for r > 1 the node moves *behind* the demonstrated contact."""
    x = np.repeat(np.array([[0.0, 0, 0], [1, 0, 0], [2, 0, 0]]), 50, axis=0)
    labels = np.repeat([0, 1, 2], 50)
    forces = np.zeros_like(x)
    forces[50:100, 2] = 50.0
    fp = make_force_points(x, forces, delta=0.01, f_contact=0.0)
    nodes = np.array([x[labels == i].mean(axis=0) for i in range(3)])
    Wd, bd = cluster_sums(labels, None, x, 3)
    raw = force_point_weights(fp, labels[fp.source], nodes, Wd, delta=0.01, stiffness=1000.0, rho_max=None)
    capped = force_point_weights(fp, labels[fp.source], nodes, Wd, delta=0.01, stiffness=1000.0, rho_max=0.75)
    np.testing.assert_allclose(raw.ratio[1, 2], 5.0)  # F/(kδ) with Δ = δ
    assert capped.capped[1, 2] and not capped.capped[1, :2].any()
    np.testing.assert_allclose(-capped.weights[:, 2].sum() / 50, 0.75)
    for fw, below in ((raw, True), (capped, False)):
        Wf, bf = cluster_sums(labels[fp.source], fw.weights, fp.points, 3)
        y = solve_m_step_banded(Wd + Wf, bd + bf, 1.0, 0.0, 0.0)
        assert (y[1, 2] < nodes[1, 2]) == below


def test_force_points_only_above_contact_threshold_and_none_for_zero_delta():
    x = np.zeros((4, 3))
    f = np.array([[0, 0, 1.0], [0, 0, 3.0], [4.0, 0, 0], [0, 0, 0]])
    fp = make_force_points(x, f, delta=0.02, f_contact=2.0)
    np.testing.assert_array_equal(fp.source, [1, 2])
    np.testing.assert_allclose(fp.points, [[0, 0, -0.02], [-0.02, 0, 0]])  # behind the surface
    assert len(make_force_points(x, f, delta=0.0, f_contact=0.0)) == 0


@pytest.mark.parametrize("rho_max", [None, 0.75, 0.05])
def test_force_node_sums_equal_the_per_point_weights(rho_max):
    """The EM loop's fused sums (no per-point weights) against force_point_weights + cluster_sums."""
    rng = np.random.default_rng(7)
    x = rng.normal(scale=0.05, size=(400, 3))
    f = rng.normal(scale=10.0, size=(400, 3))
    nodes = x[rng.choice(400, 12, replace=False)]
    labels = assign_nearest(x, nodes)
    fp = make_force_points(x, f, delta=0.01, f_contact=2.0)
    tied = labels[fp.source]
    spring = np.maximum(np.linalg.norm(fp.points - nodes[tied], axis=1), 0.01) * rng.uniform(1, 1.2, len(fp))
    Wd, _ = cluster_sums(labels, None, x, 12)
    fw = force_point_weights(
        fp, tied, nodes, Wd, delta=0.01, stiffness=3000.0, rho_max=rho_max, spring_length=spring
    )
    want_W, want_b = cluster_sums(tied, fw.weights, fp.points, 12)
    sums = ForceNodeSums(fp, 12, stiffness=3000.0, rho_max=rho_max)
    for _ in range(2):  # the second call reuses the cached index
        W, b, capped = sums(tied, spring, Wd)
        np.testing.assert_allclose(W, want_W, rtol=1e-12, atol=1e-15)
        np.testing.assert_allclose(b, want_b, rtol=1e-12, atol=1e-15)
        np.testing.assert_array_equal(capped, fw.capped)
    if rho_max == 0.05:
        assert capped.any()
