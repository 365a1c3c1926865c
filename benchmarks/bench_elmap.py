"""Benchmark: force-constrained elastic-map fits, banded O(N) M-step vs cvxpy + OSQP.

Median time per fit for M in {1000, 2730, 10000} samples, d = 3, N in {50, 100, 200}, with and without
force points, with EM iterations (a synthetic wipe, plus a press-like path that folds back on itself),
and in the same run the same problems solved the way the authors' code does (dense stacked clustering
matrix B and weight matrix A = diag(B·1), dense stacked E and R, a cvxpy problem rebuilt every M-step,
OSQP with warm start; EM capped at 50 iterations, stopping on unchanged assignments), with our force
points and weights so both solve the same problems. Ours is timed twice: as installed (with the
compiled E-step loops when they were built) and on the NumPy reference path; the two fits are checked
to be identical.

    .venv/bin/python -m benchmarks.bench_elmap [--repeats 7] [--baseline-repeats 3] [--quick]

Before any timing, one untimed fit of ours and one of the baseline (imports, first-call set-up).
"""

from __future__ import annotations

import argparse
import contextlib
import json
import os
import platform
import time
from pathlib import Path

import numpy as np
from tqdm import tqdm

from lerobot_forcemap._validation import check_int, usage_errors
from lerobot_forcemap.elmap import (
    DEFAULT_DELTA,
    DEFAULT_F_CONTACT,
    DEFAULT_LAMBDA,
    DEFAULT_MU,
    DEFAULT_STIFFNESS,
    arc_length_resample,
    assign_nearest,
    cluster_sums,
    fit_force_elastic_map,
    force_point_weights,
    make_force_points,
)
from lerobot_forcemap.elmap.kernel import NUMPY_ENV, load_em_kernel


def wipe_problem(m: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A wipe-like demo: approach, an S stroke in contact with the board z = 0, retreat (m samples)."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, m)
    s = np.clip((t - 0.2) / 0.6, 0.0, 1.0)
    x = np.stack(
        [0.3 * s, 0.06 * np.sin(2 * np.pi * s), 0.05 * (np.abs(t - 0.5) > 0.3) * (np.abs(t - 0.5) - 0.3) * 5],
        axis=1,
    )
    x += 3e-4 * rng.normal(size=x.shape)
    f = np.zeros_like(x)
    contact = (t > 0.2) & (t < 0.8)
    f[contact, 2] = 15.0 + 2.0 * rng.normal(size=contact.sum())
    f[contact, :2] = 1.5 * rng.normal(size=(contact.sum(), 2))
    return x, f


def fold_problem(m: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """A press-like demo that folds back on itself: 10 cm down, a press at the bottom, and up the same
    line 1 mm aside (m samples), so the map's two legs lie closer than its node spacing."""
    rng = np.random.default_rng(seed)
    t = np.linspace(0.0, 1.0, m)
    x = np.stack([1e-3 * t, np.zeros_like(t), 0.1 * np.abs(2 * t - 1)], axis=1)
    x += 2e-4 * rng.normal(size=x.shape)
    f = np.zeros_like(x)
    f[np.abs(2 * t - 1) < 0.05, 2] = 30.0
    return x, f


PROBLEMS = {"wipe": wipe_problem, "fold": fold_problem}


def cvxpy_fit(
    x: np.ndarray, f: np.ndarray | None, n_nodes: int, max_iter: int = 50
) -> tuple[np.ndarray, int]:
    """The authors' EM and M-step (see module docstring), with our force points and weights."""
    import cvxpy as cp

    m, d = x.shape
    n = n_nodes
    size = n * d
    E = np.eye(n) - np.eye(n, k=-1)
    E[0, 0] = 0.0
    R = -np.eye(n) + 0.5 * np.eye(n, k=-1) + 0.5 * np.eye(n, k=1)
    R[0, 1] = 1.0
    R[-1, -2] = 1.0
    E_big = np.kron(np.eye(d), E)
    R_big = np.kron(np.eye(d), R)
    S = float(m * np.sqrt(d))
    nodes = arc_length_resample(x, n)
    fp = make_force_points(x, f, DEFAULT_DELTA, DEFAULT_F_CONTACT) if f is not None else None
    labels = None
    var = cp.Variable((size, 1))
    it = 0
    for it in range(1, max_iter + 1):  # noqa: B007 (it is reported after the loop)
        new = assign_nearest(x, nodes)
        if labels is not None and np.array_equal(new, labels):
            break
        labels = new
        W, b = cluster_sums(labels, None, x, n)
        if fp is not None and len(fp):
            tied = labels[fp.source]
            fw = force_point_weights(
                fp, tied, nodes, W, delta=DEFAULT_DELTA, stiffness=DEFAULT_STIFFNESS, rho_max=0.75
            )
            Wf, bf = cluster_sums(tied, fw.weights, fp.points, n)
            W, b = W + Wf, b + bf
        # the authors' dense clustering matrix B (N·d × (M + K)·d) times the stacked data
        pts, wts, lab = x, np.ones((m, d)), labels
        if fp is not None and len(fp):
            pts = np.concatenate([x, fp.points])
            wts = np.concatenate([wts, fw.weights])
            lab = np.concatenate([labels, tied])
        mk = len(pts)
        B = np.zeros((size, mk * d))
        for i in range(n):
            in_cluster = lab == i
            for j in range(d):
                B[i + n * j, mk * j : mk * (j + 1)] = wts[:, j] * in_cluster
        A = np.diag(B.sum(axis=1))
        Bxi = B @ pts.T.reshape(-1, 1)
        var.value = nodes.T.reshape(-1, 1)
        objective = cp.Minimize(
            (1 / S) * cp.sum_squares(A @ var - Bxi)
            + DEFAULT_LAMBDA * cp.sum_squares(E_big @ var)
            + DEFAULT_MU * cp.sum_squares(R_big @ var)
        )
        cp.Problem(objective).solve(solver=cp.OSQP, warm_start=True, max_iter=1_000_000)
        nodes = np.asarray(var.value).reshape(d, n).T
    return nodes, it


def median_time(fn, repeats: int) -> tuple[float, object]:
    out = None
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times)), out


@contextlib.contextmanager
def numpy_path():
    """Fits inside run on the NumPy reference path (``LEROBOT_FORCEMAP_NUMPY_EM=1``), not the compiled loops."""
    as_installed = os.environ.get(NUMPY_ENV)
    os.environ[NUMPY_ENV] = "1"
    try:
        yield
    finally:
        if as_installed is None:
            del os.environ[NUMPY_ENV]
        else:
            os.environ[NUMPY_ENV] = as_installed


def warm_up() -> None:
    """One untimed fit of ours (both paths) and one untimed baseline fit on a small problem, so that the
    first timed call of each pays no import (``import cvxpy`` alone takes ~1 s) and no first-call set-up."""
    x, f = wipe_problem(500)
    fit_force_elastic_map(x, f, n_nodes=20)
    with numpy_path():
        fit_force_elastic_map(x, f, n_nodes=20)
    cvxpy_fit(x, f, 20, max_iter=2)


#: (path, M, N, forces) of every timed problem
GRID = [
    *(("wipe", m, n, force) for m in (1000, 2730, 10000) for n in (50, 100, 200) for force in (False, True)),
    *(("fold", 2730, 100, force) for force in (False, True)),
]


def bench_row(path: str, m: int, n: int, force: bool, args: argparse.Namespace, compiled: bool) -> dict:
    """One problem: ours as installed and on the NumPy path (checked identical), and the baseline
    unless ``--quick`` leaves it out."""
    x, f = PROBLEMS[path](m)
    forces = f if force else None
    ours_s, fit = median_time(lambda: fit_force_elastic_map(x, forces, n_nodes=n), args.repeats)
    with numpy_path():
        numpy_s, numpy_fit = median_time(lambda: fit_force_elastic_map(x, forces, n_nodes=n), args.repeats)
    assert np.array_equal(numpy_fit.nodes, fit.nodes), "compiled and NumPy paths disagree"
    row = dict(
        path=path,
        M=m,
        N=n,
        forces=force,
        ours_ms=1e3 * ours_s,
        numpy_ms=1e3 * numpy_s,
        compiled=compiled,
        ours_iter=fit.n_iter,
        ours_stop=fit.stop_reason,
    )
    if not args.quick or (path == "wipe" and m == 2730 and n == 100):
        base_s, (_, base_iter) = median_time(lambda: cvxpy_fit(x, forces, n), args.baseline_repeats)
        row.update(cvxpy_ms=1e3 * base_s, cvxpy_iter=base_iter, speedup=base_s / ours_s)
    return row


def print_table(rows: list[dict], args: argparse.Namespace, compiled: bool) -> None:
    print(
        f"\nmachine: {platform.machine()}, {os.cpu_count()} cores, OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}"
    )
    print(
        f"ours: median of {args.repeats} fits ({'with' if compiled else 'WITHOUT'} the compiled E-step loops; "
        f"'NumPy path' = {NUMPY_ENV}=1); cvxpy + OSQP: median of {args.baseline_repeats}\n"
    )
    print(
        "| path | M | N | forces | ours (ms) | NumPy path (ms) | ours iters (stop) | cvxpy+OSQP (ms) "
        "| cvxpy iters | speed-up |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        base = (
            f"{r['cvxpy_ms']:.0f} | {r['cvxpy_iter']} | {r['speedup']:.0f}x"
            if "cvxpy_ms" in r
            else "– | – | –"
        )
        print(
            f"| {r['path']} | {r['M']} | {r['N']} | {'yes' if r['forces'] else 'no'} | {r['ours_ms']:.2f} | "
            f"{r['numpy_ms']:.2f} | {r['ours_iter']} ({r['ours_stop']}) | {base} |"
        )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7, help="timed fits of ours per problem (>= 1)")
    ap.add_argument(
        "--baseline-repeats", type=int, default=3, help="timed cvxpy + OSQP fits per problem (>= 1)"
    )
    ap.add_argument("--quick", action="store_true", help="baseline only for M = 2730, N = 100")
    ap.add_argument("--json", default=None, help="also write the rows as JSON here")
    args = ap.parse_args(argv)
    with usage_errors(ap):
        check_int("--repeats", args.repeats, low=1)
        check_int("--baseline-repeats", args.baseline_repeats, low=1)
    warm_up()
    compiled = load_em_kernel() is not None
    rows = [bench_row(*problem, args, compiled) for problem in tqdm(GRID, desc="bench_elmap")]
    print_table(rows, args, compiled)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
