"""M-step solvers: banded vs dense vs Clarabel, and constraint satisfaction."""

import numpy as np
import pytest

from lerobot_forcemap.elmap import (
    BandedMStep,
    Constraints,
    InequalityRows,
    energy_terms,
    resolve_constraints,
    solve_m_step_banded,
    solve_m_step_clarabel,
)

from .helpers import dense_m_step


def random_problem(n=40, d=3, seed=0, empty=0.2):
    rng = np.random.default_rng(seed)
    W = rng.integers(1, 30, size=(n, 1)).astype(float) * np.ones((1, d))
    W[rng.random(n) < empty] = 0.0  # empty clusters, held by smoothness alone
    b = W * rng.normal(size=(n, d))
    return W, b, float(W.sum() * np.sqrt(d) + 1.0)


@pytest.mark.parametrize("lam,mu", [(0.1, 0.01), (0.0, 0.05), (0.3, 0.0), (1e-3, 1e-3)])
def test_banded_equals_dense_normal_equations(lam, mu):
    W, b, S = random_problem(seed=int(lam * 1000 + mu * 100))
    y = solve_m_step_banded(W, b, S, lam, mu)
    np.testing.assert_allclose(y, dense_m_step(W, b, S, lam, mu), rtol=1e-9, atol=1e-11)


def test_banded_with_negative_cluster_weights_equals_dense():
    # force points make cluster weights smaller (never below (1 - rho_max) of the demo weight)
    W, b, S = random_problem(seed=3, empty=0.0)
    W = W * np.random.default_rng(4).uniform(0.25, 1.0, size=W.shape)
    y = solve_m_step_banded(W, b, S, 0.05, 0.02)
    np.testing.assert_allclose(y, dense_m_step(W, b, S, 0.05, 0.02), rtol=1e-9, atol=1e-11)


def test_solution_is_the_energy_minimum():
    W, b, S = random_problem(seed=5)
    y = solve_m_step_banded(W, b, S, 0.1, 0.01)
    e0 = energy_terms(y, W, b, S, 0.1, 0.01).total
    rng = np.random.default_rng(6)
    for _ in range(20):
        assert energy_terms(y + 1e-4 * rng.normal(size=y.shape), W, b, S, 0.1, 0.01).total > e0


def test_eliminated_equalities_hold_exactly_and_match_clarabel():
    n, d = 30, 2
    W, b, S = random_problem(n, d, seed=7)
    fixed = np.array([0, 1, 13, 15, n - 1])
    values = np.random.default_rng(8).normal(size=(len(fixed), d))
    y = BandedMStep(n, d, 0.1, 0.01, fixed, values).solve(W, b, S)
    np.testing.assert_array_equal(y[fixed], values)
    rc = resolve_constraints(Constraints(via=[(int(i), v) for i, v in zip(fixed, values, strict=True)]), n, d)
    yc = solve_m_step_clarabel(W, b, S, 0.1, 0.01, rc)
    np.testing.assert_allclose(yc, y, atol=1e-7)
    np.testing.assert_allclose(yc[fixed], values, atol=1e-9)
    # free nodes solve the reduced normal equations: the gradient of the energy vanishes there
    eps = 1e-6
    e = lambda z: energy_terms(z, W, b, S, 0.1, 0.01).total  # noqa: E731
    for i in (5, 14, 20):
        zp, zm = y.copy(), y.copy()
        zp[i, 0] += eps
        zm[i, 0] -= eps
        assert abs(e(zp) - e(zm)) / (2 * eps) < 1e-7


def test_empty_clusters_without_smoothness_keep_previous_nodes():
    W, b, S = random_problem(10, 2, seed=9, empty=0.5)
    prev = np.arange(20.0).reshape(10, 2)
    y = solve_m_step_banded(W, b, S, 0.0, 0.0, previous=prev)
    empty = W[:, 0] == 0
    assert empty.any()
    np.testing.assert_array_equal(y[empty], prev[empty])
    np.testing.assert_allclose(y[~empty], b[~empty] / W[~empty])


def test_clarabel_inequalities_hold():
    n, d = 25, 2
    W, b, S = random_problem(n, d, seed=10, empty=0.0)
    rc = resolve_constraints(
        Constraints(box=([-0.5, -np.inf], [0.5, 0.3]), halfspaces=[([1.0, 1.0], 0.4)], max_step=0.08), n, d
    )
    rows = InequalityRows(np.array([3, 4]), np.array([[0.0, 1.0], [0.0, 1.0]]), np.array([0.1, 0.12]))
    y = solve_m_step_clarabel(W, b, S, 0.01, 0.01, rc, rows)
    assert np.all(y[:, 0] >= -0.5 - 1e-7) and np.all(y[:, 0] <= 0.5 + 1e-7) and np.all(y[:, 1] <= 0.3 + 1e-7)
    assert np.all(y.sum(axis=1) <= 0.4 + 1e-7)
    assert np.all(np.linalg.norm(np.diff(y, axis=0), axis=1) <= 0.08 + 1e-7)
    assert y[3, 1] >= 0.1 - 1e-7 and y[4, 1] >= 0.12 - 1e-7
    # and the constraints bind: the unconstrained solution violates at least one of them
    y0 = solve_m_step_banded(W, b, S, 0.01, 0.01)
    assert np.any(np.abs(y0[:, 0]) > 0.5) or np.any(y0.sum(axis=1) > 0.4) or np.any(y0[:, 1] > 0.3)


def test_clarabel_reports_infeasible_constraints():
    n, d = 10, 1
    W, b, S = random_problem(n, d, seed=11, empty=0.0)
    rc = resolve_constraints(
        Constraints(halfspaces=[([1.0], -1.0), ([-1.0], -1.0)]), n, d
    )  # y <= -1 and y >= 1
    with pytest.raises(ValueError, match="constraints"):
        solve_m_step_clarabel(W, b, S, 0.1, 0.01, rc)


@pytest.mark.parametrize("scale,offset", [(1e-6, 0.0), (1e-3, 0.0), (1e3, 0.0), (1.0, 10.0), (1.0, -1e3)])
def test_clarabel_is_equivariant_to_units_and_translation(scale, offset):
    """The energy is quadratic: fitting in millimetres or micrometres, or 10 m away, must give the same
    nodes up to that change of units (Clarabel's absolute tolerances once made it differ by 16 %)."""
    n, d = 30, 2
    W, b, S = random_problem(n, d, seed=12, empty=0.1)
    box = ([-0.4, -np.inf], [0.4, 0.25])
    half = [([1.0, 1.0], 0.35)]
    ref = solve_m_step_clarabel(
        W, b, S, 0.01, 0.01, resolve_constraints(Constraints(box=box, halfspaces=half, max_step=0.1), n, d)
    )
    lo, hi = (np.asarray(v) * scale + offset for v in box)
    rc = resolve_constraints(
        Constraints(box=(lo, hi), halfspaces=[([1.0, 1.0], 0.35 * scale + 2 * offset)], max_step=0.1 * scale),
        n,
        d,
    )
    # cluster sums of the moved data: b = W·mean, S unchanged; λ, μ act on differences (scale²: energy ratio kept)
    y = solve_m_step_clarabel(W, W * ((b / np.where(W > 0, W, 1)) * scale + offset), S, 0.01, 0.01, rc)
    np.testing.assert_allclose((y - offset) / scale, ref, atol=1e-7 * max(1.0, abs(offset) / scale * 1e-3))


def _bounded_least_squares(W, b, S, lam, mu, lo, hi):
    """The M-step per axis as a bounded linear least-squares problem (scipy's BVLS, an active-set method
    independent of Clarabel): rows diag(W)/√S, √λ·E, √μ·R against b/√S, 0, 0."""
    from scipy.optimize import lsq_linear

    n, d = W.shape
    E = np.diff(np.eye(n), axis=0)
    R = np.diff(np.eye(n), 2, axis=0)
    out = np.empty((n, d))
    for q in range(d):
        A = np.vstack([np.diag(W[:, q]) / np.sqrt(S), np.sqrt(lam) * E, np.sqrt(mu) * R])
        rhs = np.concatenate([b[:, q] / np.sqrt(S), np.zeros(2 * n - 3)])
        out[:, q] = lsq_linear(A, rhs, bounds=(lo[:, q], hi[:, q]), method="bvls", tol=1e-15).x
    return out


@pytest.mark.parametrize("seed", range(4))
def test_clarabel_with_binding_bounds_is_the_exact_minimiser(seed):
    """Empty clusters held only by weak smoothness make the energy nearly flat; Clarabel's duality-gap
    stop left such nodes up to 11.8 mm from the optimum before the active-set polish."""
    n, d, lam, mu = 60, 2, 1e-4, 1e-4
    W, b, S = random_problem(n, d, seed=20 + seed, empty=0.6)
    box_lo, box_hi = np.array([-0.3, -np.inf]), np.array([0.3, 0.2])
    # force-limit rows on single coordinates are bounds too: y[5, 1] >= 0.15, y[40, 0] >= 0.1
    rows = InequalityRows(np.array([5, 40]), np.array([[0.0, 1.0], [1.0, 0.0]]), np.array([0.15, 0.1]))
    y = solve_m_step_clarabel(
        W, b, S, lam, mu, resolve_constraints(Constraints(box=(box_lo, box_hi)), n, d), rows
    )
    lo, hi = np.tile(box_lo, (n, 1)), np.tile(box_hi, (n, 1))
    lo[5, 1], lo[40, 0] = 0.15, 0.1
    expected = _bounded_least_squares(W, b, S, lam, mu, lo, hi)
    assert np.sum(np.isclose(expected, lo) | np.isclose(expected, hi)) >= 5  # the bounds bind
    np.testing.assert_allclose(y, expected, atol=1e-9)


def test_a_demonstration_at_rest_against_a_bound_fits_flat_on_it_and_converges():
    """The audit's case: 1000 samples at one point, a box 1 cm above it: every node sits on the bound
    (the interior-point answer spread over 11.8 mm) and the fit stops as converged."""
    from lerobot_forcemap.elmap import fit_force_elastic_map

    fit = fit_force_elastic_map(
        np.tile([0.3, 0.1, 0.2], (1000, 1)),
        n_nodes=100,
        constraints=Constraints(box=([-1, -1, 0.21], [1, 1, 1])),
    )
    np.testing.assert_allclose(fit.nodes[:, 2], 0.21, atol=1e-9)
    assert fit.stop_reason == "converged"
    # at rest with force_limit rows (a closed gripper squeezing): the stop test's unit is the data's
    # magnitude, not the 1e-12 floor of its zero extent that no solver step reaches
    grip = fit_force_elastic_map(
        np.full(1000, 0.02), np.full(1000, -15.0), n_nodes=100, delta=0.05, stiffness=300.0, force_limit=5.0
    )
    assert grip.stop_reason == "converged" and grip.step_tolerance == pytest.approx(1e-9)
