"""M-step solvers for the convex elastic-map energy.

Per axis q the energy decouples into

    (1/S) Σ_i (W_iq y_iq − b_iq)² + λ Σ_i (y_{i+1,q} − y_iq)² + μ Σ_i (y_iq − 2y_{i+1,q} + y_{i+2,q})²

whose normal equations ``(diag(W_q)²/S + λEᵀE + μRᵀR) y_q = diag(W_q) b_q / S`` are pentadiagonal and
SPD. The d systems are stacked into one block-diagonal matrix of size N·d — still bandwidth 2 because
the blocks do not touch — and solved with a single banded Cholesky call (LAPACK ``pbsv``): O(N·d).
Fixed nodes (equality constraints) are eliminated, which keeps the band. Inequality constraints go to
Clarabel with the same objective (sparse P and A), refined by an active-set polish to the exact
minimiser when every constraint is linear.

Layout: nodes ``y (N, d)``; cluster sums ``W, b (N, d)``; the stacked vector is axis-major,
``γ = [y[:, 0]; y[:, 1]; ...]``, entry (i, q) at ``q·N + i``.

Entry points: :func:`solve_m_step_banded` and :func:`solve_m_step_clarabel` check their inputs;
:class:`BandedMStep` and :func:`clarabel_m_step` are what the EM loop calls every iteration, on inputs
it built itself, and check nothing.
"""

from __future__ import annotations

from dataclasses import dataclass

import clarabel
import numpy as np
import scipy.sparse as sp
from numpy.typing import NDArray
from scipy.linalg import lapack

from .._validation import check_array, check_int_array, check_int_list, check_real, fail
from .constraints import ResolvedConstraints

__all__ = [
    "EnergyTerms",
    "InequalityRows",
    "smoothness_bands",
    "energy_terms",
    "BandedMStep",
    "solve_m_step_banded",
    "solve_m_step_clarabel",
    "clarabel_m_step",
    "polish_active_set",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class EnergyTerms:
    """The three terms of the convex energy at a node placement."""

    approximation: float
    stretching: float
    bending: float

    @property
    def total(self) -> float:
        return self.approximation + self.stretching + self.bending


@dataclass(frozen=True)
class InequalityRows:
    """Extra half-spaces tied to single nodes: ``normals[k] · y[node[k]] >= lower[k]``.

    Used for the force-limit constraints, which are rebuilt every EM iteration from the assignment.
    node (K,), normals (K, d), lower (K,).
    """

    node: NDArray[np.intp]
    normals: Array
    lower: Array

    def __len__(self) -> int:
        return len(self.node)


def smoothness_bands(n_nodes: int, lam: float, mu: float) -> tuple[Array, Array, Array]:
    """Bands of ``λEᵀE + μRᵀR`` (N×N, symmetric): main diagonal (N,), first (N−1,) and second (N−2,) off-diagonals."""
    n = n_nodes
    d0 = np.zeros(n)
    d1 = np.zeros(max(n - 1, 0))
    d2 = np.zeros(max(n - 2, 0))
    if n >= 2 and lam:
        # E rows (-1, 1) on (i, i+1)
        d0[:-1] += lam
        d0[1:] += lam
        d1 -= lam
    if n >= 3 and mu:
        # R rows (1, -2, 1) on (r, r+1, r+2)
        d0[:-2] += mu
        d0[1:-1] += 4 * mu
        d0[2:] += mu
        d1[:-1] -= 2 * mu
        d1[1:] -= 2 * mu
        d2 += mu
    return d0, d1, d2


def energy_terms(y: Array, W: Array, b: Array, S: float, lam: float, mu: float) -> EnergyTerms:
    """Energy of nodes ``y (N, d)`` for cluster sums ``W, b (N, d)`` and normaliser ``S``."""
    r = (W * y - b).ravel()
    dy = y[1:] - y[:-1]
    ddy = (dy[1:] - dy[:-1]).ravel()
    dy = dy.ravel()
    return EnergyTerms(float(r @ r) / S, float(lam * (dy @ dy)), float(mu * (ddy @ ddy)))


def _banded_matvec(d0: Array, d1: Array, d2: Array, y: Array) -> Array:
    """``A @ y`` for the symmetric pentadiagonal A given by its bands; d0 (N, d) per axis, d1/d2 shared."""
    out = d0 * y
    if len(d1):
        out[:-1] += d1[:, None] * y[1:]
        out[1:] += d1[:, None] * y[:-1]
    if len(d2):
        out[:-2] += d2[:, None] * y[2:]
        out[2:] += d2[:, None] * y[:-2]
    return out


class BandedMStep:
    """The banded M-step for fixed (N, d, λ, μ, fixed nodes): everything that does not change between
    EM iterations is computed once here; :meth:`solve` then costs one ``pbsv`` call.

    Fixed nodes are eliminated: the reduced matrix ``A_FF`` keeps bandwidth 2 because neighbours in
    the free set F are 1 or 2 apart in the full index (or further, then uncoupled).
    """

    def __init__(
        self,
        n_nodes: int,
        dim: int,
        lam: float,
        mu: float,
        fixed_index: NDArray[np.intp] | None = None,
        fixed_value: Array | None = None,
    ) -> None:
        n = n_nodes
        self.n, self.d = n, dim
        self.s0, self.s1, self.s2 = smoothness_bands(n, lam, mu)
        self.free = np.ones(n, dtype=bool)
        self.y_fixed = None
        if fixed_index is not None and len(fixed_index):
            self.free[fixed_index] = False
            self.fixed_index = np.asarray(fixed_index)
            self.fixed_value = np.asarray(fixed_value, dtype=float)
            y_fixed = np.zeros((n, dim))
            y_fixed[fixed_index] = fixed_value
            self.y_fixed = y_fixed
        F = np.flatnonzero(self.free)
        nf = len(F)
        self.nf = nf
        # a slice when every node is free: W[F] is then a view, not a gather
        self.F = F if nf < n else slice(None)
        sub1 = np.zeros(max(nf - 1, 0))
        if nf >= 2:
            gap1 = np.diff(F)
            if n >= 2:
                sub1 = np.where(gap1 == 1, self.s1[np.minimum(F[:-1], n - 2)], 0.0)
            if n >= 3:
                sub1 = np.where(gap1 == 2, self.s2[np.minimum(F[:-1], n - 3)], sub1)
        sub2 = np.zeros(max(nf - 2, 0))
        if nf >= 3 and n >= 3:
            sub2 = np.where(F[2:] - F[:-2] == 2, self.s2[np.minimum(F[:-2], n - 3)], 0.0)
        # off-diagonal rows of the stacked (nf·d) lower-banded matrix; zero where axis blocks meet
        self.ab = np.zeros((3, nf * dim))
        if nf >= 2:
            blk = np.zeros((dim, nf))
            blk[:, :-1] = sub1
            self.ab[1] = blk.reshape(-1)
        if nf >= 3:
            blk = np.zeros((dim, nf))
            blk[:, :-2] = sub2
            self.ab[2] = blk.reshape(-1)
        # A_F,fixed · y_fixed only involves the smoothness bands (diag(W)² is diagonal)
        if self.y_fixed is not None:
            self.fixed_rhs = _banded_matvec(np.zeros((n, dim)), self.s1, self.s2, self.y_fixed)[F]
        else:
            self.fixed_rhs = None

    def solve(self, W: Array, b: Array, S: float, previous: Array | None = None) -> Array:
        """Nodes (N, d) minimising the energy for cluster sums W, b (N, d) and normaliser S.

        ``previous (N, d)`` holds nodes whose row is undetermined (an empty cluster with λ = μ = 0,
        or a singular system): they stay where they were.
        """
        n, d, F = self.n, self.d, self.F
        y = np.zeros((n, d)) if previous is None else np.array(previous, dtype=float, copy=True)
        if self.y_fixed is not None:
            y[self.fixed_index] = self.fixed_value
        nf = self.nf
        if nf == 0:
            return y
        Wf = W[F]
        diag_f = Wf * Wf / S + self.s0[F, None]
        rhs_f = Wf * b[F] / S
        if self.fixed_rhs is not None:
            rhs_f = rhs_f - self.fixed_rhs
        # Rows no energy term touches (only when λ = μ = 0, so they couple to nothing): keep the
        # previous node.
        dead = diag_f <= 0.0
        if dead.any():
            diag_f = np.where(dead, 1.0, diag_f)
            rhs_f = np.where(dead, y[F], rhs_f)
        ab = self.ab.copy()
        ab[0] = diag_f.T.reshape(-1)
        rhs_flat = rhs_f.T.reshape(-1)
        # LAPACK pbsv directly: scipy's solveh_banded wrapper costs more than the O(N) solve itself
        _, sol, info = lapack.dpbsv(ab, rhs_flat, lower=1)
        if info != 0:
            # Semi-definite (e.g. λ = 0 and a single non-empty cluster): a tiny ridge towards the
            # previous nodes picks the solution nearest to them.
            ridge = 1e-10 * max(float(np.max(ab[0])), 1e-300)
            ab = self.ab.copy()
            ab[0] = diag_f.T.reshape(-1) + ridge
            _, sol, info = lapack.dpbsv(ab, rhs_flat + ridge * y[F].T.reshape(-1), lower=1)
            if info != 0:
                raise np.linalg.LinAlgError(
                    f"banded M-step: matrix not positive definite (LAPACK info {info})"
                )
        y[F] = sol.reshape(d, nf).T
        return y


def _check_sums(
    W: object, b: object, S: object, lam: object, mu: object
) -> tuple[Array, Array, float, float, float]:
    """The inputs every M-step takes: cluster sums W, b (N, d) finite, S > 0, λ, μ >= 0."""
    W = check_array("W", W, ndim=2, min_len=1, axes=("node", "axis"))
    b = check_array("b", b, shape=W.shape, axes=("node", "axis"))
    if W.shape[1] < 1:
        fail("W", f"have at least one axis, got shape {W.shape}")
    S = check_real("S", S, low=0.0, low_open=True)
    return W, b, S, check_real("lam", lam, low=0.0), check_real("mu", mu, low=0.0)


def solve_m_step_banded(
    W: Array,
    b: Array,
    S: float,
    lam: float,
    mu: float,
    fixed_index: NDArray[np.intp] | None = None,
    fixed_value: Array | None = None,
    previous: Array | None = None,
) -> Array:
    """One banded M-step (see :class:`BandedMStep`): W, b (N, d) cluster sums -> nodes y (N, d).

    S > 0 the normaliser; lam, mu >= 0; fixed_index (K,) distinct node indices held at fixed_value
    (K, d); previous (N, d) nodes that undetermined rows keep (default zeros).
    """
    W, b, S, lam, mu = _check_sums(W, b, S, lam, mu)
    n, d = W.shape
    if fixed_index is not None and len(fixed_index):
        fixed_index = np.asarray(
            check_int_list("fixed_index", fixed_index, low=0, distinct=True), dtype=np.intp
        )
        if fixed_index.max() >= n:
            fail("fixed_index", f"hold node indices below N = {n}", fixed_index.tolist())
        fixed_value = check_array(
            "fixed_value", fixed_value, shape=(len(fixed_index), d), axes=("row", "axis")
        )
    if previous is not None:
        previous = check_array("previous", previous, shape=(n, d), axes=("node", "axis"))
    return BandedMStep(n, d, lam, mu, fixed_index, fixed_value).solve(W, b, S, previous)


# ----------------------------------------------------------------------------------------------
# Clarabel


def _clarabel_settings(tol: float) -> clarabel.DefaultSettings:
    s = clarabel.DefaultSettings()
    s.verbose = False
    s.tol_gap_abs = tol
    s.tol_gap_rel = tol
    s.tol_feas = tol
    s.tol_ktratio = 1e-8
    s.max_iter = 200
    return s


def solve_m_step_clarabel(
    W: Array,
    b: Array,
    S: float,
    lam: float,
    mu: float,
    constraints: ResolvedConstraints,
    extra: InequalityRows | None = None,
    tol: float = 1e-10,
    polish: bool = True,
) -> Array:
    """Same objective as :func:`solve_m_step_banded`, with every constraint as a conic row (Clarabel).

    W, b (N, d) cluster sums; S > 0; lam, mu >= 0; constraints resolved for (N, d) by
    :func:`~.constraints.resolve_constraints`; extra: half-spaces on single nodes (the force limits);
    tol > 0 Clarabel's gap and feasibility tolerance (on the normalised problem). ``polish``: refine
    Clarabel's answer to the exact minimiser with :func:`polish_active_set` when the constraints are
    linear (no ``max_step`` cone); off only to measure what it changes. Returns nodes (N, d).

    Raises ``ValueError`` naming ``constraints`` (or ``force_limit`` for the extra rows) when the set is
    infeasible or Clarabel stops without a solution.
    """
    W, b, S, lam, mu = _check_sums(W, b, S, lam, mu)
    if not isinstance(constraints, ResolvedConstraints) or (constraints.n_nodes, constraints.dim) != W.shape:
        fail(
            "constraints",
            f"be ResolvedConstraints for {W.shape} nodes (see resolve_constraints)",
            constraints,
        )
    if extra is not None:
        _check_extra(extra, *W.shape)
    tol = check_real("tol", tol, low=0.0, low_open=True)
    return clarabel_m_step(W, b, S, lam, mu, constraints, extra, tol, bool(polish))


def _check_extra(extra: object, n: int, d: int) -> None:
    """``extra`` as InequalityRows on the nodes of an (n, d) map."""
    if not isinstance(extra, InequalityRows):
        fail("extra", f"be InequalityRows or None, got {type(extra).__name__}")
    k = len(extra)
    nodes = check_int_array("extra.node", extra.node, low=0)
    if nodes.shape != (k,) or (k and nodes.max() >= n):
        fail("extra.node", f"hold {k} node indices below N = {n}", nodes.tolist())
    check_array("extra.normals", extra.normals, shape=(k, d), axes=("row", "axis"))
    check_array("extra.lower", extra.lower, shape=(k,), axes=("row",))


def clarabel_m_step(
    W: Array,
    b: Array,
    S: float,
    lam: float,
    mu: float,
    constraints: ResolvedConstraints,
    extra: InequalityRows | None = None,
    tol: float = 1e-10,
    polish: bool = True,
) -> Array:
    """:func:`solve_m_step_clarabel` on inputs the EM loop built (nothing is checked)."""
    n, d = W.shape
    P, q = _objective(W, b, S, lam, mu)
    A, bvec, cones, n_eq, n_ineq = _conic_rows(constraints, extra, n, d)
    # Solve for z with γ = c + L·z (c the clusters' centre, L their extent) and the objective scaled to
    # unit curvature: Clarabel's tolerances are absolute, so in raw coordinates the answer would depend
    # on the units. The cones are invariant to positive scaling, so A z + s' = (b − A c)/L describes
    # the same set.
    centre, extent = _normalisation(W, b, constraints)
    c_vec = np.repeat(centre, n)  # stacked axis-major, like γ
    P_full = P + sp.triu(P, 1, format="csc").T
    curvature = max(float(np.max(np.abs(P.diagonal()))) if n * d else 1.0, 1e-300)
    q_z = (P_full @ c_vec + q) / (extent * curvature)
    b_z = (bvec - A @ c_vec) / extent
    sol = clarabel.DefaultSolver((P / curvature).tocsc(), q_z, A, b_z, cones, _clarabel_settings(tol)).solve()
    _raise_unless_solved(sol.status, constraints, extra)
    z = np.asarray(sol.x)
    if polish and n_ineq and constraints.max_step is None:
        rows = slice(n_eq, n_eq + n_ineq)
        polished = polish_active_set(
            P_full / curvature,
            q_z,
            A[:n_eq],
            b_z[:n_eq],
            A[rows],
            b_z[rows],
            np.asarray(sol.z)[rows] > np.asarray(sol.s)[rows],
        )
        if polished is not None:
            z = polished
    return (c_vec + extent * z).reshape(d, n).T.copy()


def _objective(W: Array, b: Array, S: float, lam: float, mu: float) -> tuple[sp.csc_matrix, Array]:
    """Clarabel's ``½ γᵀPγ + qᵀγ`` of the energy: P = 2·A (upper triangle, (N·d)²), q = −2·W b / S."""
    n, d = W.shape
    s0, s1, s2 = smoothness_bands(n, lam, mu)
    diag = (W * W / S + s0[:, None]).T.reshape(-1)
    off1 = np.zeros((d, n))
    off1[:, :-1] = s1
    off2 = np.zeros((d, n))
    if n >= 3:
        off2[:, :-2] = s2
    P = sp.diags(
        [2 * diag, 2 * off1.reshape(-1)[:-1], 2 * off2.reshape(-1)[:-2]],
        [0, 1, 2],
        shape=(n * d, n * d),
        format="csc",
    )
    return P, -2.0 * (W * b / S).T.reshape(-1)


def _conic_rows(
    rc: ResolvedConstraints, extra: InequalityRows | None, n: int, d: int
) -> tuple[sp.csc_matrix, Array, list, int, int]:
    """Every constraint as ``A γ + s = b``, s in the cones: equalities (zero cone), then the linear
    inequalities (non-negative cone), then the step bounds (one second-order cone per edge).
    Returns A, b, the cones, the number of equality rows and the number of inequality rows."""
    nv = n * d
    blocks = [_equality_rows(rc, n, d), _inequality_rows(rc, extra, n, d), _step_rows(rc, n, d)]
    rows = [m for block in blocks if block is not None for m in block[0]]
    rhs = [v for block in blocks if block is not None for v in block[1]]
    n_eq = sum(m.shape[0] for m in blocks[0][0]) if blocks[0] is not None else 0
    n_ineq = sum(m.shape[0] for m in blocks[1][0]) if blocks[1] is not None else 0
    cones: list = []
    if n_eq:
        cones.append(clarabel.ZeroConeT(n_eq))
    if n_ineq:
        cones.append(clarabel.NonnegativeConeT(n_ineq))
    if blocks[2] is not None:
        cones.extend(clarabel.SecondOrderConeT(d + 1) for _ in range(n - 1))
    if not rows:
        return sp.csc_matrix((0, nv)), np.zeros(0), cones, 0, 0
    return sp.vstack(rows, format="csc"), np.concatenate(rhs), cones, n_eq, n_ineq


def _equality_rows(rc: ResolvedConstraints, n: int, d: int) -> tuple[list, list] | None:
    """Fixed nodes: one row per fixed coordinate."""
    if not len(rc.fixed_index):
        return None
    cols = (np.arange(d)[None, :] * n + rc.fixed_index[:, None]).reshape(-1)
    A = sp.csc_matrix((np.ones(len(cols)), (np.arange(len(cols)), cols)), shape=(len(cols), n * d))
    return [A], [rc.fixed_value.reshape(-1)]


def _inequality_rows(
    rc: ResolvedConstraints, extra: InequalityRows | None, n: int, d: int
) -> tuple[list, list] | None:
    """Box bounds (upper then lower, axis by axis), half-spaces (every node), extra rows (one node each)."""
    nv = n * d
    node = np.arange(n)
    rows: list = []
    rhs: list = []
    if rc.box_lo is not None:
        for sign, bound in ((1.0, rc.box_hi), (-1.0, rc.box_lo)):
            for qa in range(d):
                if np.isfinite(bound[qa]):
                    rows.append(sp.csc_matrix((np.full(n, sign), (node, qa * n + node)), shape=(n, nv)))
                    rhs.append(np.full(n, sign * bound[qa]))
    for normal, offset in zip(rc.halfspace_normals, rc.halfspace_offsets, strict=True):
        r = np.repeat(node, d)
        c = (np.arange(d)[None, :] * n + node[:, None]).reshape(-1)
        rows.append(sp.csc_matrix((np.tile(normal, n), (r, c)), shape=(n, nv)))
        rhs.append(np.full(n, offset))
    if extra is not None and len(extra):
        k = len(extra)
        r = np.repeat(np.arange(k), d)
        c = (np.arange(d)[None, :] * n + extra.node[:, None]).reshape(-1)
        rows.append(sp.csc_matrix((-extra.normals.reshape(-1), (r, c)), shape=(k, nv)))
        rhs.append(-extra.lower)
    return (rows, rhs) if rows else None


def _step_rows(rc: ResolvedConstraints, n: int, d: int) -> tuple[list, list] | None:
    """Step-length bound: (max_step, y_{i+1} − y_i) in the second-order cone, per edge."""
    if rc.max_step is None or n < 2:
        return None
    ne = n - 1
    edge = np.arange(ne)
    r_base = edge * (d + 1)
    r = np.concatenate([(r_base[:, None] + 1 + np.arange(d)[None, :]).reshape(-1)] * 2)
    c_lo = (np.arange(d)[None, :] * n + edge[:, None]).reshape(-1)
    c = np.concatenate([c_lo, c_lo + 1])
    vals = np.concatenate([np.ones(len(c_lo)), -np.ones(len(c_lo))])
    b_soc = np.zeros(ne * (d + 1))
    b_soc[r_base] = rc.max_step
    return [sp.csc_matrix((vals, (r, c)), shape=(ne * (d + 1), n * d))], [b_soc]


#: what to change when Clarabel finds no solution, by the argument the failure is charged to
_REMEDIES = {
    "constraints": "loosen or remove nearly contradictory or nearly parallel inequalities, or express "
    "positions in units closer to 1",
    "force_limit": "raise force_limit or stiffness, or express positions in units closer to 1",
    "constraints and force_limit": "loosen the constraints, raise force_limit or stiffness, or express "
    "positions in units closer to 1",
    "solver": "use solver='auto' or 'banded' (no constraint needs Clarabel here), or express positions "
    "in units closer to 1",
}


def _raise_unless_solved(status: object, rc: ResolvedConstraints, extra: InequalityRows | None) -> None:
    """``ValueError`` naming the argument the failure is charged to, unless Clarabel solved the problem."""
    if status in (clarabel.SolverStatus.Solved, clarabel.SolverStatus.AlmostSolved):
        return
    limits = extra is not None and len(extra) > 0
    user = not rc.is_empty
    what = "constraints and force_limit" if user and limits else "force_limit" if limits else "constraints"
    if status in (clarabel.SolverStatus.PrimalInfeasible, clarabel.SolverStatus.AlmostPrimalInfeasible):
        fail(what, f"describe a feasible set of node positions, got Clarabel status {status} (infeasible)")
    if not (user or limits):
        what = "solver"
    fail(what, f"give the Clarabel M-step a problem it can solve ({_REMEDIES[what]}), got status {status}")


def polish_active_set(
    P: sp.csc_matrix,
    q: Array,
    E: sp.csc_matrix,
    e: Array,
    G: sp.csc_matrix,
    h: Array,
    active: NDArray[np.bool_],
    *,
    tol: float = 1e-9,
    max_rounds: int = 25,
) -> Array | None:
    """The exact minimiser of ``½xᵀPx + qᵀx`` s.t. ``Ex = e``, ``Gx <= h``, from an interior-point guess
    of its active rows ``active (m,)``; None when no active set within ``max_rounds`` passes the checks.

    Why: Clarabel stops at a duality-gap tolerance, and where the objective is nearly flat (empty
    clusters held only by the smoothness terms, e.g. a gripper at rest against a bound) that leaves
    nodes millimetres from the optimum. Each round solves the KKT system with the active rows as
    equalities and moves violated rows in and rows with negative multipliers out; a point is
    returned only when it satisfies every KKT condition to ``tol`` (feasible, multipliers >= 0,
    stationary), which for a convex QP makes it the optimum.
    """
    nv, k = P.shape[0], E.shape[0]
    parts = (P.tocoo(), E.tocoo(), G.tocoo())
    G = parts[2].tocsr()
    active = np.asarray(active, dtype=bool).copy()
    for _ in range(max_rounds):
        K = _kkt_matrix(*parts, active, nv, k)
        rhs = np.concatenate([-q, e, h[active]])
        sol = _solve_kkt(K, rhs, tol)
        if sol is None:
            return None
        x = sol[:nv]
        violated = (G @ x - h > tol) & ~active
        multipliers = np.zeros(len(h))
        multipliers[active] = sol[nv + k :]
        negative = active & (multipliers < -tol)
        if not violated.any() and not negative.any():
            return x
        active = (active | violated) & ~negative
    return None


def _kkt_matrix(
    Pc: sp.coo_matrix, Ec: sp.coo_matrix, Gc: sp.coo_matrix, active: NDArray[np.bool_], nv: int, k: int
) -> sp.csc_matrix:
    """KKT ``[[P, Cᵀ], [C, 0]]`` with C = [E; G_active], assembled from triplets: scipy.sparse's
    stacking costs more than the factorisation at these sizes."""
    row_of = np.cumsum(active) - 1 + nv + k  # KKT row of each active G row
    g = active[Gc.row]
    c_rows = np.concatenate([Ec.row + nv, row_of[Gc.row[g]]])
    c_cols = np.concatenate([Ec.col, Gc.col[g]])
    c_vals = np.concatenate([Ec.data, Gc.data[g]])
    size = nv + k + int(active.sum())
    return sp.csc_matrix(
        (
            np.concatenate([Pc.data, c_vals, c_vals]),
            (np.concatenate([Pc.row, c_rows, c_cols]), np.concatenate([Pc.col, c_cols, c_rows])),
        ),
        shape=(size, size),
    )


def _solve_kkt(K: sp.csc_matrix, rhs: Array, tol: float) -> Array | None:
    """The KKT solution, or None when K is singular (dependent active rows, e.g. a box bound and a
    half-space alike) or the solution misses stationarity or an active row by more than ``tol``."""
    from scipy.sparse.linalg import splu

    try:
        sol = splu(K).solve(rhs)
    except RuntimeError:
        return None
    if not (np.all(np.isfinite(sol)) and np.max(np.abs(K @ sol - rhs)) <= tol):
        return None
    return sol


def _normalisation(W: Array, b: Array, constraints: ResolvedConstraints) -> tuple[Array, float]:
    """Centre (d,) and extent (> 0) of the cluster means ``b / W`` and the fixed node values."""
    filled = W > 0
    means = np.where(filled, b / np.where(filled, W, 1.0), np.nan)
    points = [means]
    if len(constraints.fixed_index):
        points.append(np.asarray(constraints.fixed_value, dtype=float).reshape(-1, W.shape[1]))
    pts = np.concatenate(points, axis=0)
    if not np.isfinite(pts).any():
        return np.zeros(W.shape[1]), 1.0
    with np.errstate(invalid="ignore"):
        lo, hi = np.nanmin(pts, axis=0), np.nanmax(pts, axis=0)
    lo, hi = np.where(np.isfinite(lo), lo, 0.0), np.where(np.isfinite(hi), hi, 0.0)
    centre = 0.5 * (lo + hi)
    extent = float(np.max(hi - lo))
    if not extent > 0.0:  # every point in one place: any positive unit works
        extent = max(float(np.max(np.abs(centre))), 1.0)
    return centre, extent
