"""EM fit: force neutrality, fixed point, constraints through the fit, lift monotonicity, bad input."""

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from lerobot_forcemap.elmap import (
    MAX_NODES,
    Constraints,
    assign_nearest,
    cluster_sums,
    fit_force_elastic_map,
    force_point_weights,
    make_force_points,
    resolve_constraints,
    solve_m_step_banded,
)
from lerobot_forcemap.elmap.fit import arc_length_resample
from lerobot_forcemap.elmap.timing import node_time_law

from .helpers import line_demo, s_curve


def contact_forces(x, lo, hi, magnitude, axis=2):
    f = np.zeros_like(x)
    f[lo:hi, axis] = magnitude
    return f


# ---- forces that must not change anything


def test_zero_delta_or_zero_force_gives_the_plain_fit_exactly():
    x = s_curve()
    plain = fit_force_elastic_map(x, n_nodes=60)
    f = contact_forces(x, 100, 400, 30.0)
    np.testing.assert_array_equal(fit_force_elastic_map(x, f, n_nodes=60, delta=0.0).nodes, plain.nodes)
    np.testing.assert_array_equal(fit_force_elastic_map(x, np.zeros_like(x), n_nodes=60).nodes, plain.nodes)
    # and below the contact threshold forces are ignored as well
    np.testing.assert_array_equal(
        fit_force_elastic_map(x, 0.5 * np.ones_like(x) / np.sqrt(3), n_nodes=60).nodes, plain.nodes
    )


def test_zero_force_axis_is_unchanged_in_the_m_step():
    """For a fixed assignment the axes decouple: forces on z only leave the x and y solutions as they were."""
    x = s_curve()
    rng = np.random.default_rng(0)
    nodes = x[np.linspace(0, len(x) - 1, 50).astype(int)]
    labels = assign_nearest(x, nodes)
    f = contact_forces(x, 100, 400, 30.0) + np.c_[np.zeros((len(x), 2)), rng.normal(size=len(x))]
    fp = make_force_points(x, f * np.array([0, 0, 1.0]), delta=0.01, f_contact=2.0)
    Wd, bd = cluster_sums(labels, None, x, 50)
    fw = force_point_weights(fp, labels[fp.source], nodes, Wd, delta=0.01, stiffness=15000.0, rho_max=0.75)
    Wf, bf = cluster_sums(labels[fp.source], fw.weights, fp.points, 50)
    S = len(x) * np.sqrt(3)
    with_force = solve_m_step_banded(Wd + Wf, bd + bf, S, 0.01, 0.01)
    without = solve_m_step_banded(Wd, bd, S, 0.01, 0.01)
    np.testing.assert_array_equal(with_force[:, :2], without[:, :2])
    assert np.max(np.abs(with_force[:, 2] - without[:, 2])) > 1e-4


def test_uniform_contact_lifts_the_map_along_the_force_only():
    """A wipe in steady contact along its whole length: every node lifts along the force by nearly F/k (a
    little less, since samples spread along the stroke have springs longer than δ + lift), and the
    force-free axes (x, y) are unchanged."""
    x = line_demo(n=400, noise=0.0)
    F, k = 30.0, 15000.0
    plain = fit_force_elastic_map(x, n_nodes=40)
    fit = fit_force_elastic_map(x, contact_forces(x, 0, len(x), F), n_nodes=40, stiffness=k)
    assert fit.stop_reason == "converged"
    np.testing.assert_allclose(fit.nodes[:, :2], plain.nodes[:, :2], atol=1e-9)
    lift = fit.nodes[:, 2] - plain.nodes[:, 2]
    assert np.all(lift > 0.95 * F / k) and np.all(lift <= F / k + 1e-12)


# ---- the fixed point


@pytest.mark.parametrize("with_force", [False, True])
def test_returned_nodes_are_a_fixed_point_of_em(with_force):
    x = s_curve(n=800, seed=1)
    f = contact_forces(x, 200, 600, 25.0) if with_force else None
    kw = dict(n_nodes=50, lam=0.01, mu=0.01, delta=0.01, stiffness=5000.0, f_contact=2.0)
    fit = fit_force_elastic_map(x, f, **kw)
    assert fit.stop_reason == "converged", fit.stop_reason
    labels = assign_nearest(x, fit.nodes)
    np.testing.assert_array_equal(labels, fit.labels)
    W, b = cluster_sums(labels, None, x, 50)
    if with_force:
        fp = make_force_points(x, f, 0.01, 2.0)
        fw = force_point_weights(
            fp, labels[fp.source], fit.nodes, W, delta=0.01, stiffness=5000.0, rho_max=0.75
        )
        Wf, bf = cluster_sums(labels[fp.source], fw.weights, fp.points, 50)
        W, b = W + Wf, b + bf
    again = solve_m_step_banded(W, b, len(x) * np.sqrt(3), 0.01, 0.01)
    np.testing.assert_allclose(again, fit.nodes, rtol=0, atol=1e-8)


@pytest.mark.parametrize("with_force", [False, True])
def test_last_step_is_how_far_the_last_iteration_moved_the_nodes(with_force):
    x = s_curve(n=800, seed=1)
    f = contact_forces(x, 200, 600, 25.0) if with_force else None
    kw = dict(n_nodes=50, lam=0.01, mu=0.01, delta=0.01, stiffness=5000.0, f_contact=2.0)
    fits = [fit_force_elastic_map(x, f, max_iter=k, **kw) for k in (2, 3)]
    assert fits[1].stop_reason == "max_iter"
    # the EM is deterministic: iteration 3 starts from where a fit stopped after 2
    moved = np.max(np.abs(fits[1].nodes - fits[0].nodes))
    assert moved > 1e-4 and fits[1].last_step == pytest.approx(moved, rel=1e-12)
    done = fit_force_elastic_map(x, f, **kw)
    assert done.step_tolerance == pytest.approx(1e-9 * np.ptp(x, axis=0).max(), rel=1e-12)
    assert done.stop_reason == "converged" and done.last_step <= done.step_tolerance
    # the spring lengths are the other half of the stop test: still moving after 3 iterations, settled at the end
    if with_force:
        assert fits[1].last_spring_step > done.step_tolerance >= done.last_spring_step
    else:
        assert fits[1].last_spring_step == done.last_spring_step == 0.0


# ---- constraints through the fit


def test_banded_and_clarabel_agree_with_equality_constraints():
    x = s_curve(n=500, seed=2)
    f = contact_forces(x, 150, 350, 20.0)
    cons = Constraints(
        start=[0.0, 0.01, 0.0], end=[0.31, 0.0, 0.03], via=[(0.5, [0.15, 0.0, 0.01]), (10, [0.03, 0.03, 0.0])]
    )
    kw = dict(n_nodes=40, constraints=cons, stiffness=5000.0)
    banded = fit_force_elastic_map(x, f, solver="banded", **kw)
    clar = fit_force_elastic_map(x, f, solver="clarabel", **kw)
    assert banded.solver == "banded" and clar.solver == "clarabel"
    np.testing.assert_allclose(clar.nodes, banded.nodes, atol=1e-6)
    rc = resolve_constraints(cons, 40, 3, lambda frac: 20)  # only to read which nodes the ints/ends fix
    for fit in (banded, clar):
        np.testing.assert_allclose(fit.nodes[0], [0.0, 0.01, 0.0], atol=1e-9)
        np.testing.assert_allclose(fit.nodes[-1], [0.31, 0.0, 0.03], atol=1e-9)
        np.testing.assert_allclose(fit.nodes[10], [0.03, 0.03, 0.0], atol=1e-9)
        # the time-fraction via point fixed some node to its value
        assert np.min(np.abs(fit.nodes - [0.15, 0.0, 0.01]).max(axis=1)) < 1e-9
    assert 0 in rc.fixed_index and 39 in rc.fixed_index


def test_time_fraction_via_maps_to_the_node_at_that_arc_length():
    # constant speed: time fraction = arc-length fraction
    x = line_demo(n=300)
    fit = fit_force_elastic_map(x, n_nodes=31, constraints=Constraints(via=[(0.5, [0.2, 0.05, 0.0])]))
    np.testing.assert_allclose(fit.nodes[15], [0.2, 0.05, 0.0], atol=1e-12)


@pytest.mark.parametrize(
    ("n_samples", "frac", "node"), [(2, 0.3, 3), (2, 0.5, 5), (11, 0.35, 35), (11, 0.01, 1)]
)
def test_time_fraction_via_interpolates_between_sparse_samples(n_samples, frac, node):
    # a sparse demo: the fraction lies between samples and must not snap to the next one
    x = np.linspace(0.0, 1.0, n_samples)[:, None] * [1.0, 2.0]
    n_nodes = 11 if n_samples == 2 else 101
    fit = fit_force_elastic_map(
        x, n_nodes=n_nodes, constraints=Constraints(via=[(frac, [9.0, 9.0])]), max_iter=1
    )
    assert np.flatnonzero(np.all(fit.nodes == 9.0, axis=1)).tolist() == [node]


def test_time_fraction_via_with_an_end_constraint_on_a_two_sample_demo():
    x = np.array([[0.0, 0.0], [1.0, 2.0]])
    cons = Constraints(end=[1.0, 2.0], via=[(0.5, [0.5, 1.0])])
    fit = fit_force_elastic_map(x, n_nodes=5, constraints=cons)
    np.testing.assert_allclose(fit.nodes[[2, 4]], [[0.5, 1.0], [1.0, 2.0]], atol=1e-9)


def test_inequality_constraints_hold_through_the_fit():
    x = s_curve(n=500, seed=4)
    cons = Constraints(box=([-1, -0.03, -1], [1, 0.03, 1]), halfspaces=[([0, 0, 1.0], 0.015)], max_step=0.012)
    fit = fit_force_elastic_map(x, n_nodes=40, constraints=cons)
    y = fit.nodes
    assert fit.solver == "clarabel"
    assert np.all(np.abs(y[:, 1]) <= 0.03 + 1e-7)
    assert np.all(y[:, 2] <= 0.015 + 1e-7)
    assert np.all(np.linalg.norm(np.diff(y, axis=0), axis=1) <= 0.012 + 1e-7)
    plain = fit_force_elastic_map(x, n_nodes=40)
    assert np.max(np.abs(plain.nodes[:, 1])) > 0.03 + 1e-3  # the box binds


def test_force_limit_keeps_nodes_behind_the_contact():
    x = line_demo(n=400, noise=2e-4, seed=5)
    f = contact_forces(x, 100, 300, 40.0)
    k, limit = 5000.0, 10.0
    fit = fit_force_elastic_map(x, f, n_nodes=40, stiffness=k, force_limit=limit)
    assert fit.solver == "clarabel" and fit.n_force_limit_rows == 200
    labels = fit.labels
    need = x[100:300, 2] + (40.0 - limit) / k
    assert np.all(fit.nodes[labels[100:300], 2] >= need - 1e-7)
    weights_only = fit_force_elastic_map(x, f, n_nodes=40, stiffness=k)
    assert np.min(weights_only.nodes[labels[100:300], 2] - need) < -1e-4  # the constraint binds


def test_force_limit_applies_to_contact_samples_only():
    """A touch below f_contact is no contact (no force points): force_limit below f_contact adds no rows."""
    x = line_demo(n=200, noise=2e-4, seed=6)
    f = contact_forces(x, 50, 150, 3.0)
    fit = fit_force_elastic_map(x, f, n_nodes=20, f_contact=5.0, force_limit=1.0)
    assert fit.n_force_limit_rows == 0
    np.testing.assert_allclose(
        fit.nodes, fit_force_elastic_map(x, n_nodes=20, solver="clarabel").nodes, atol=1e-7
    )
    assert fit_force_elastic_map(x, f, n_nodes=20, f_contact=2.0, force_limit=1.0).n_force_limit_rows == 100


def test_infeasible_constraints_raise_naming_constraints():
    x = line_demo(n=100)
    with pytest.raises(ValueError, match="constraints"):
        fit_force_elastic_map(
            x, n_nodes=10, constraints=Constraints(start=[0, 0, 0], box=([0.1, -1, -1], [1, 1, 1]))
        )
    with pytest.raises(ValueError, match="constraints"):
        fit_force_elastic_map(
            x, n_nodes=10, constraints=Constraints(halfspaces=[([1, 0, 0], -1.0), ([-1, 0, 0], -1.0)])
        )
    with pytest.raises(ValueError, match="constraints"):
        fit_force_elastic_map(x, n_nodes=10, constraints=Constraints(start=[0, 0, 0], via=[(0, [1, 0, 0])]))


def test_infeasible_force_limit_names_force_limit():
    """Two neighbouring samples pressing 60 N in opposite directions cannot both keep a 20 N limit's lift."""
    x = line_demo(n=100)
    f = np.zeros_like(x)
    f[50, 2], f[51, 2] = 60.0, -60.0
    with pytest.raises(ValueError, match="^force_limit: must describe a feasible set of node positions"):
        fit_force_elastic_map(x, f, n_nodes=10, force_limit=20.0, stiffness=100.0)
    with pytest.raises(
        ValueError, match="^constraints and force_limit: must describe a feasible set of node positions"
    ):
        fit_force_elastic_map(
            x, f, n_nodes=10, force_limit=20.0, stiffness=100.0, constraints=Constraints(max_step=1.0)
        )


def test_a_clarabel_m_step_without_a_solution_names_the_constraints_and_what_to_change():
    """Two nearly parallel half-spaces (z <= 0 and z >= 1e-6·x) leave the nodes a sliver along x = 0 that
    Clarabel cannot converge into (status InsufficientProgress); its failure named no argument."""
    x = line_demo(n=50)
    sliver = Constraints(halfspaces=[([0.0, 0.0, 1.0], 0.0), ([1e-6, 0.0, -1.0], 0.0)])
    with pytest.raises(
        ValueError,
        match=r"^constraints: must give the Clarabel M-step a problem it can solve \(loosen or remove nearly "
        r"contradictory or nearly parallel inequalities, .*\), got status (?!Solved)\w+ \(EM iteration \d+\)$",
    ):
        fit_force_elastic_map(x, n_nodes=20, constraints=sliver)


@pytest.mark.parametrize(
    ("user", "limits", "blamed"),
    [
        (True, False, "constraints"),
        (False, True, "force_limit"),
        (True, True, "constraints and force_limit"),
        (False, False, "solver"),
    ],
)
@pytest.mark.parametrize("status", ["NumericalError", "MaxIterations", "InsufficientProgress"])
def test_every_unsolved_clarabel_status_is_charged_to_an_argument(user, limits, blamed, status):
    import clarabel

    from lerobot_forcemap.elmap.mstep import InequalityRows, _raise_unless_solved

    rc = resolve_constraints(Constraints(max_step=1.0) if user else None, 5, 2)
    extra = InequalityRows(np.array([1]), np.array([[0.0, 1.0]]), np.array([0.0])) if limits else None
    with pytest.raises(
        ValueError,
        match=rf"^{blamed}: must give the Clarabel M-step a problem it can solve .*got status {status}$",
    ):
        _raise_unless_solved(getattr(clarabel.SolverStatus, status), rc, extra)


# ---- force size


def test_larger_force_lifts_nodes_monotonically():
    x = line_demo(n=600, noise=3e-4, seed=6)
    lifts = []
    for F in (0.0, 5.0, 10.0, 20.0, 40.0, 80.0):
        fit = fit_force_elastic_map(x, contact_forces(x, 150, 450, F), n_nodes=60)
        contact_nodes = np.unique(fit.labels[200:400])
        lifts.append(float(np.mean(fit.nodes[contact_nodes, 2])))
    assert np.all(np.diff(lifts) > 0), lifts
    assert lifts[0] == pytest.approx(0.0, abs=2e-4)


# ---- several demos, 1-D maps, time law


def test_several_demos_and_a_gripper_map():
    rng = np.random.default_rng(7)
    base = s_curve(n=400, noise=0.0)
    demos = [base + 1e-3 * rng.normal(size=base.shape) for _ in range(3)]
    fit = fit_force_elastic_map(demos, n_nodes=40)
    assert fit.labels.shape == (1200,)
    # the map runs along the mean path (nodes may slide along it, so compare with the curve)
    dense = s_curve(n=20000, noise=0.0)
    gap = np.min(np.linalg.norm(fit.nodes[:, None, :] - dense[None, :, :], axis=2), axis=1)
    assert np.max(gap) < 2e-3
    # m identical demos scale W and b by m and S by m, i.e. the data term by m (the
    # squared cluster weight): exactly the map of one demo with λ/m and μ/m.
    copies = fit_force_elastic_map([base] * 3, n_nodes=40)
    one = fit_force_elastic_map(base, n_nodes=40, lam=0.01 / 3, mu=0.01 / 3)
    np.testing.assert_allclose(copies.nodes, one.nodes, atol=1e-12)
    assert np.max(np.abs(fit_force_elastic_map(base, n_nodes=40).nodes - one.nodes)) > 1e-4
    # gripper: 1-D opening that closes, with finger force while closed
    g = np.concatenate([np.zeros(100), np.linspace(0, 1, 50), np.ones(150)])
    fg = np.where(g > 0.99, -15.0, 0.0)  # the object pushes the fingers open
    grip = fit_force_elastic_map(g, fg, n_nodes=30, delta=0.05, stiffness=300.0)
    plain = fit_force_elastic_map(g, n_nodes=30)
    assert grip.nodes.shape == (30, 1)
    assert grip.nodes.max() < plain.nodes.max() - 0.01  # squeezes less


def test_a_demo_that_does_not_move_keeps_its_time_law():
    """A rotation in place: every sample ties at one node, but time (and so the rotation) must still
    run along the map, not collapse to the mean time."""
    t = np.linspace(0.0, 2.0, 100)
    x = np.tile([0.3, 0.1, 0.2], (100, 1))
    ang = np.linspace(0.0, np.pi / 2, 100)
    q = np.stack([np.cos(ang / 2), 0 * ang, 0 * ang, np.sin(ang / 2)], axis=1)
    fit = fit_force_elastic_map(x, n_nodes=10, times=t, orientations=q)
    np.testing.assert_allclose(fit.node_times, np.linspace(0.0, 2.0, 10))
    np.testing.assert_allclose(fit.orientation_at([0.0, 2.0]), q[[0, -1]], atol=1e-9)


def test_time_law_and_orientation():
    from lerobot_forcemap.geometry import quat_to_rotvec, rotvec_to_quat

    t = np.linspace(0.0, 4.0, 401)
    x = np.stack([np.sin(t), np.cos(t), 0.1 * t], axis=1)  # constant speed helix
    q = rotvec_to_quat(np.stack([np.zeros_like(t), np.zeros_like(t), 0.3 * t], axis=1))
    fit = fit_force_elastic_map(x, n_nodes=41, times=t, orientations=q, lam=1e-4, mu=1e-4)
    assert np.all(np.diff(fit.node_times) >= 0)
    assert fit.duration == pytest.approx(4.0)
    np.testing.assert_allclose(fit.node_times, np.linspace(0, 4, 41), atol=0.06)
    # orientation = the demo orientation at the node time
    np.testing.assert_allclose(quat_to_rotvec(fit.orientations)[:, 2], 0.3 * fit.node_times, atol=1e-9)
    np.testing.assert_allclose(fit.position_at([0.0])[0], fit.nodes[0])
    np.testing.assert_allclose(fit.position_at([4.0])[0], fit.nodes[-1])
    assert fit.orientation_at([1.0, 2.0]).shape == (2, 4)


def test_time_law_is_made_non_decreasing_on_an_out_and_back_path():
    """The time law: node times are the clusters' mean times made non-decreasing (a path that folds back)."""
    t = np.linspace(0.0, 1.0, 201)
    x = np.zeros((201, 3))
    x[:, 0] = np.where(t <= 0.5, 2 * t, 1 - 0.8 * (t - 0.5))  # out to 1 m, back to 0.6 m
    fit = fit_force_elastic_map(x, n_nodes=20, times=4 * t)
    counts = np.bincount(fit.labels, minlength=20)
    raw = np.bincount(fit.labels, weights=t, minlength=20) / counts  # every cluster holds samples here
    assert np.min(np.diff(raw)) < -0.05  # the raw cluster means run backwards where the path folds
    assert np.all(np.diff(fit.node_times) >= 0)
    np.testing.assert_allclose(fit.node_times, 4 * np.maximum.accumulate(raw), rtol=0, atol=1e-12)


def test_time_law_interpolates_empty_clusters():
    """The time law: empty clusters interpolate between the neighbouring clusters' mean times."""
    labels = np.array([0, 0, 1, 4, 4])  # nodes 2 and 3 hold no sample
    u = np.array([0.0, 0.2, 0.3, 0.85, 0.95])  # cluster means 0.1, 0.3, -, -, 0.9
    times = node_time_law(labels, u, n_nodes=5, duration=2.0)
    np.testing.assert_allclose(times, 2.0 * np.array([0.1, 0.3, 0.5, 0.7, 0.9]), rtol=0, atol=1e-12)


# ---- stop reasons and the initial map


def test_energy_tol_stops_at_the_first_small_relative_energy_change():
    """EM stops when the relative energy change is below `tol` (reason "energy_tol")."""
    x = s_curve()
    full = fit_force_elastic_map(x, n_nodes=60, tol=0.0)
    h = np.array(full.energy_history)
    rel = np.abs(np.diff(h)) / np.abs(h[:-1])  # 0.011, 0.0030, 0.0019, 0.00016
    assert full.stop_reason == "converged" and full.n_iter == 6
    for tol, n_iter in ((1e-2, 3), (1e-3, 5)):
        fit = fit_force_elastic_map(x, n_nodes=60, tol=tol)
        assert (fit.stop_reason, fit.n_iter) == ("energy_tol", n_iter)
        assert n_iter == 2 + int(np.argmax(rel <= tol))  # the first iteration below tol
        np.testing.assert_array_equal(fit.nodes, fit_force_elastic_map(x, n_nodes=60, max_iter=n_iter).nodes)


def test_an_alternating_assignment_stops_as_a_cycle():
    """EM: an assignment that repeats with period 2 stops with reason "cycle", not at max_iter."""
    x = np.random.default_rng(48).normal(size=(12, 1))
    kw = dict(n_nodes=4, lam=0.1, mu=0.1)
    fit = fit_force_elastic_map(x, max_iter=100, **kw)
    assert (fit.stop_reason, fit.n_iter) == ("cycle", 4)
    # the assignment of iteration k + 1 is the one to the nodes after k M-steps
    seq = [assign_nearest(x, arc_length_resample(x, 4))]
    seq += [fit_force_elastic_map(x, max_iter=k, **kw).labels for k in (1, 2, 3)]
    assert not np.array_equal(seq[0], seq[1])
    np.testing.assert_array_equal(seq[2], seq[0])
    np.testing.assert_array_equal(seq[3], seq[1])
    e = fit.energy_history
    assert e[2] == e[0] != e[1] == e[3]


def test_initial_map_is_equally_spaced_in_arc_length_not_in_time():
    """EM starts from the first demo resampled by arc length (a demo that dwells near its start)."""
    centres = np.array([0.0, 0.25, 0.5, 0.75, 1.0])
    dwell = [20, 10, 5, 2, 1]  # samples per place: most of the demo's time is spent near x = 0
    offsets = [(0.0,), (-0.05, 0.0, 0.05), (-0.05, 0.0, 0.05), (-0.05, 0.0, 0.05), (0.0,)]
    path = [c + o for c, offs, k in zip(centres, offsets, dwell, strict=True) for o in offs for _ in range(k)]
    x = np.zeros((len(path), 2))
    x[:, 0] = path
    # with λ = μ = 0 a node is its cluster's mean: the equally spaced init (whose clusters are
    # symmetric about it) is already the fixed point
    fit = fit_force_elastic_map(x, n_nodes=5, lam=0.0, mu=0.0)
    assert fit.stop_reason == "converged" and fit.n_iter == 2
    np.testing.assert_allclose(fit.nodes[:, 0], centres, rtol=0, atol=1e-12)
    np.testing.assert_array_equal(fit.nodes[:, 1], 0.0)


# ---- bad input


@pytest.mark.parametrize(
    "kwargs,field",
    [
        (dict(positions=np.array([[0.0, 0], [np.nan, 1], [2, 2]])), r"positions\[0\].*frame 1"),
        (dict(positions=np.array([[0.0, 0], [1, np.inf], [2, 2]])), r"positions\[0\]"),
        (
            dict(forces=np.zeros((5, 2))),
            r"^forces\[0\]: must have the shape of positions\[0\], \(20, 3\), got shape \(5, 2\)",
        ),
        (dict(forces=np.full((20, 3), np.nan)), r"forces\[0\]"),
        (dict(n_nodes=2), "^n_nodes: must be an integer >= 3 and <= 10000, got 2"),
        (
            dict(positions=np.zeros((1, 3))),
            r"^positions\[0\]: must hold at least 2 samples, got shape \(1, 3\)",
        ),
        (dict(lam=-0.1), "^lam: must be a finite number >= 0, got -0.1"),
        (dict(mu=-1.0), "^mu: must be a finite number >= 0, got -1.0"),
        (dict(delta=-0.01), "^delta: must be a finite number >= 0 and <= 1e\\+150 m, got -0.01"),
        (dict(stiffness=0.0), "^stiffness: must be a finite number > 0 N/m, got 0.0"),
        (dict(rho_max=1.5), "^rho_max: must be a finite number > 0 and < 1 or None, got 1.5"),
        (
            dict(times=np.arange(20.0)[::-1]),
            r"^times\[0\]: must be non-decreasing, got 19 s -> 18 s at frame 1$",
        ),
        (dict(solver="osqp"), r"^solver: must be one of \['auto', 'banded', 'clarabel'\], got 'osqp'"),
        (dict(positions=[np.zeros((5, 3)), np.zeros((5, 2))]), r"positions\[1\]"),
        (dict(force_limit=5.0), "^force_limit: must be None when forces is None"),
        (
            dict(constraints=Constraints(box=([np.inf, -1, -1], [np.inf, 1, 1]))),
            r"^constraints.box: must leave room on every axis .*, got lo\[0\]=inf",
        ),
        (
            dict(constraints=Constraints(box=([-1, -1, -np.inf], [1, 1, -np.inf]))),
            r"^constraints.box: must leave room on every axis .*, got lo\[2\]=-inf",
        ),
        (
            dict(constraints=Constraints(box=(["a", 0, 0], [1, 1, 1]))),
            "^constraints.box.lo: must be an array of numbers",
        ),
        (
            dict(constraints=Constraints(halfspaces=[([0, 0, 1], "a")])),
            r"^constraints.halfspaces\[0\].offset: must be a finite number, got 'a'",
        ),
        (dict(constraints=Constraints(start=["a", 0, 0])), "^constraints.start: must be an array of numbers"),
        (dict(positions=np.zeros((5, 0))), r"^positions\[0\]: must have at least 1 coordinate per sample"),
        (
            dict(positions=line_demo(n=20) * 1e160),
            r"^positions\[0\]: must hold \|coordinates\| <= 1e\+150 .* overflow",
        ),
        (dict(delta=1e200), "^delta: must be a finite number >= 0 and <= 1e\\+150 m, got 1e\\+200"),
        (dict(positions=line_demo(n=20) * 1e-160), "^positions: must span at least 1e-100 .* underflow"),
        (
            dict(weights=np.full(20, 1e300)),
            r"^weights\[0\]: must lie in \[1e-100, 1e\+100\] \(the first bad one is at frame 0, axis 0; .*got 1e\+300",
        ),
        (
            dict(weights=np.full(20, 1e-300)),
            r"^weights\[0\]: must lie in \[1e-100, 1e\+100\] \(the first bad one is at frame 0, axis 0; .*got 1e-300",
        ),
        (
            dict(forces=np.full((20, 3), 1e200), rho_max=None),
            r"^forces\[0\]: must hold \|values\| <= 1e\+150 \(the first bad one is at frame 0, axis 0; .*got 1e\+200",
        ),
        (
            dict(forces=np.full((20, 3), 1e140), rho_max=None, weights=np.full(20, 1e-100)),
            "^positions/forces/weights: must .*M-step 1 overflowed float64",
        ),
        # list(x) of one (20, 3) demo fitted 20 one-dimensional demos of 3 samples, silently
        (
            dict(positions=list(line_demo(n=20))),
            r"^positions: must be a \(T, d\) array or a list .*got a list of 20 one-dimensional arrays of 3 samples",
        ),
        (
            dict(positions=[line_demo(n=20).tolist(), line_demo(n=12).tolist()]),
            r"^positions\[0\]: must be a rectangular array of numbers \(several demos of different lengths",
        ),
        (
            dict(positions=np.stack([line_demo(n=20)] * 2)),
            r"^positions\[0\]: must have shape \(T, d\) or \(T,\); several demos go in a list .*got shape \(2, 20, 3\)",
        ),
        (
            dict(positions=line_demo(n=20) * (1 + 1j)),
            r"^positions\[0\]: must be an array of numbers .*\(complex128\)",
        ),
        (
            dict(constraints=Constraints(max_step="a")),
            "^constraints.max_step: must be a finite number > 0 or None, got 'a'",
        ),
        (
            dict(orientations=np.tile([1e200, 0.0, 0.0, 0.0], (20, 1))),
            r"^orientations\[0\]: must hold quaternions .* of finite norm .*at frame 0\), got inf",
        ),
    ],
)
@pytest.mark.filterwarnings(
    "ignore:overflow encountered:RuntimeWarning"
)  # the overflow case, before its error
def test_bad_input_names_the_argument(kwargs, field):
    args = dict(positions=line_demo(n=20))
    args.update(kwargs)
    positions = args.pop("positions")
    with pytest.raises(ValueError, match=field):
        fit_force_elastic_map(positions, **args)


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    seed=st.integers(0, 10_000),
    t=st.integers(2, 80),
    d=st.integers(1, 4),
    n_nodes=st.integers(3, 30),
    repeats=st.booleans(),
    force_scale=st.sampled_from([0.0, 1.0, 50.0, 1e4]),
    lam=st.sampled_from([0.0, 1e-3, 0.1]),
    mu=st.sampled_from([0.0, 1e-3, 0.1]),
)
def test_fuzz_never_returns_nan(seed, t, d, n_nodes, repeats, force_scale, lam, mu):
    rng = np.random.default_rng(seed)
    x = rng.normal(size=(t, d)) * rng.choice([1e-6, 1.0, 100.0])
    if repeats:
        x[: t // 2] = x[0]  # a stationary start (duplicated samples)
    f = force_scale * rng.normal(size=(t, d))
    fit = fit_force_elastic_map(x, f, n_nodes=n_nodes, lam=lam, mu=mu, max_iter=30)
    assert np.all(np.isfinite(fit.nodes))
    assert np.all(np.isfinite(fit.node_times))
    assert fit.stop_reason in {"converged", "energy_tol", "cycle", "max_iter"}


def test_array_objects_and_datetimes_are_read_as_documented():
    """pandas demos in a list were refused as "not a list of arrays"; datetime timestamps were read as
    nanoseconds (duration 1e9 instead of seconds)."""
    import pandas as pd

    x = line_demo(n=40)
    ref = fit_force_elastic_map([x, x[:30]], n_nodes=8, times=[np.arange(40) * 0.01, np.arange(30) * 0.01])
    fit = fit_force_elastic_map(
        [pd.DataFrame(x), pd.DataFrame(x[:30])],
        n_nodes=8,
        times=[
            pd.Series(pd.date_range("2026-11-24", periods=40, freq="10ms")),
            np.arange(30, dtype="timedelta64[ms]") * 10,
        ],
    )
    np.testing.assert_array_equal(fit.nodes, ref.nodes)
    assert fit.duration == pytest.approx(ref.duration) and ref.duration == pytest.approx(
        0.34
    )  # mean of 0.39 s and 0.29 s
    with pytest.raises(
        ValueError, match=r"^forces\[0\]: must be an array of numbers, got datetime64\[ns\] values"
    ):
        fit_force_elastic_map(x, pd.Series(pd.date_range("2026-11-24", periods=40, freq="10ms")))


def test_times_whose_span_leaves_float64_are_refused():
    """Finite times 2e308 apart normalised to NaN node times."""
    x = line_demo(n=3)
    with pytest.raises(ValueError, match=r"^times\[0\]: must span a duration within float64's range"):
        fit_force_elastic_map(x, n_nodes=3, times=[-1e308, 0.0, 1e308])
    # every demo's span is finite, their mean is not
    with pytest.raises(ValueError, match=r"^times: must have a mean demo duration within float64's range"):
        fit_force_elastic_map([x, x], n_nodes=3, times=[np.array([0.0, 1e308, 1.5e308])] * 2)
    fit = fit_force_elastic_map(x, n_nodes=3, times=[-1e307, 0.0, 1e307])  # large but inside: fine
    assert np.all(np.isfinite(fit.node_times)) and fit.duration == pytest.approx(2e307)


@pytest.mark.parametrize("n_nodes", [MAX_NODES + 1, 10**12])
def test_n_nodes_is_bounded(n_nodes):
    """10**12 nodes ran into a MemoryError in the E-step (it holds the N×N node distances)."""
    with pytest.raises(
        ValueError, match=rf"^n_nodes: must be an integer >= 3 and <= {MAX_NODES}, got {n_nodes}$"
    ):
        fit_force_elastic_map(line_demo(n=20), n_nodes=n_nodes)
    with pytest.raises(ValueError, match=rf"^n: must be an integer >= 1 and <= {MAX_NODES}, got {n_nodes}$"):
        arc_length_resample(line_demo(n=20), n_nodes)


def test_arc_length_resample_refuses_what_gave_nan_or_a_bare_error():
    with pytest.raises(
        ValueError, match=r"^path: must have shape \(T, d\) with d >= 1 and \|coordinates\| <= 1e\+150"
    ):
        arc_length_resample(
            np.full((4, 2), 1e200) * [[1], [-1], [1], [-1]], 5
        )  # arc length overflowed to NaN
    with pytest.raises(ValueError, match=r"^path: must have shape \(T, d\) with d >= 1 .*got shape \(4, 0\)"):
        arc_length_resample(np.zeros((4, 0)), 5)  # numpy's "need at least one array to stack"


def test_query_times_must_be_finite_numbers_or_a_1d_array():
    fit = fit_force_elastic_map(line_demo(n=40), n_nodes=8)
    assert fit.position_at(0.1).shape == (1, 3) and fit.position_at([0.0, 0.1]).shape == (2, 3)
    with pytest.raises(ValueError, match=r"^t: must have 0 or 1 dimension\(s\), got shape \(2, 2\)"):
        fit.position_at(np.zeros((2, 2)))
    with pytest.raises(
        ValueError, match=r"^t: must hold finite values only \(the first bad one is at index 1\)"
    ):
        fit.position_at([0.0, np.nan])
