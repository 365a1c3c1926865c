"""Force-constrained elastic map: the EM fit.

    fit = fit_force_elastic_map(positions, forces, n_nodes=100)
    fit.nodes            # (N, d) the reproduction path
    fit.position_at(t)   # query along the time law

A fit runs in four phases: the inputs are checked and stacked (:mod:`.inputs`), the initial map is
the first demo resampled by arc length with the equality constraints applied (:func:`initial_map`),
the EM loop alternates the E-step of :mod:`.estep` with an M-step of :mod:`.mstep` (banded, or Clarabel
when inequality constraints or ``force_limit`` are present), and the result carries the time law and
orientations of :mod:`.timing`. Force points are tied to the node of their source sample; their
weights are recomputed every iteration. The per-sample work (E-step, cluster sums, spring lengths)
runs in the compiled loops of :mod:`.kernel` when they are built, with the same arithmetic as the
NumPy code (bit-identical fits, tested); ``LEROBOT_FORCEMAP_NUMPY_EM=1`` selects the NumPy path.

Decisions where the method leaves a choice (``docs/elmap.md`` gives the reasons at length):

- ``S`` (the approximation-energy normaliser) sums the norms of the *demo* point weights only.
  Force-point weights change every iteration; counting them in S would couple the axes (a force on z
  would change the fit on x) and make the force's effect scale down with its own size.
- The spring length ``Δ_j`` is under-relaxed, ``Δ ← (1−ω_j)Δ + ω_j·max(‖p_j − y‖, δ)``. The fixed
  point is the same as plain recomputation (ω = 1), but plain recomputation is the map
  ``Δ ↦ δΔ/(Δ − |f|/k)`` for a cluster in steady contact, whose slope at the fixed point
  ``Δ* = δ + |f|/k`` is ``−a`` with ``a = |f|/(kδ)``: it converges slowly for a near 1 and oscillates
  between two placements for a > 1. ``spring_relaxation="auto"`` uses ``ω_j = 1/(1 + a_j)``, which
  zeroes that slope (one-step convergence for uniform contact, a contraction for every force the
  ``rho_max`` cap leaves uncapped); a float sets one ω for all points.
- Stop reasons: ``"converged"`` (assignments unchanged, and nodes and spring lengths moved less
  than ``xtol`` times the data scale), ``"energy_tol"`` (the assignment still changed but the relative
  energy change fell below ``tol``), ``"cycle"`` (the assignment repeats with a period of 2 to 8
  iterations), ``"max_iter"``. Without force points an unchanged assignment gives identical nodes, so
  the fit stops there; with force points the spring lengths keep converging after the assignment
  settles, so "converged" also waits for the nodes to stop.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_int, fail
from ..geometry import slerp_sequence
from .constraints import Constraints, ResolvedConstraints, resolve_constraints
from .estep import NumpyEMSteps
from .inputs import MAX_COORDINATE, MAX_NODES, DemoData, FitParams, check_fit_params, stack_demos
from .kernel import EMKernel, load_em_kernel
from .mstep import BandedMStep, EnergyTerms, InequalityRows, clarabel_m_step, energy_terms
from .timing import node_orientations, node_time_law
from .weights import ForceNodeSums, ForcePoints, make_force_points, row_norms

__all__ = [
    "ElasticMapFit",
    "fit_force_elastic_map",
    "InitialMap",
    "initial_map",
    "arc_length",
    "arc_length_resample",
    "DEFAULT_LAMBDA",
    "DEFAULT_MU",
    "DEFAULT_DELTA",
    "DEFAULT_F_CONTACT",
    "DEFAULT_STIFFNESS",
]

Array = NDArray[np.float64]

DEFAULT_LAMBDA = 0.01
DEFAULT_MU = 0.01
#: m — offset of a force point behind the demonstrated contact
DEFAULT_DELTA = 0.01
#: N — force norm above which a sample counts as contact (after tare and low-pass)
DEFAULT_F_CONTACT = 2.0
#: N/m — chosen so that r = F/(k·δ) stays below rho_max = 0.75 up to F = 100 N at δ = 1 cm
#: (100 / (15000 · 0.01) = 0.67); a node in steady contact then lifts by F/k (6.7 mm at 100 N).
DEFAULT_STIFFNESS = 15000.0


@dataclass(frozen=True)
class ElasticMapFit:
    """Result of :func:`fit_force_elastic_map`.

    nodes (N, d) in the positions' units; node_times (N,) seconds from the segment start (samples
    without ``times``); orientations (N, 4) w-first or None; labels (M,) node of every stacked demo
    sample; capped_nodes (C, 2) rows (node, axis) whose force weights were scaled down by the rho_max
    cap in the last iteration; last_step the largest change of a node coordinate in the last M-step
    (0 when the assignment repeated without force points) and last_spring_step the largest change of a
    force point's spring length Δ in that iteration (0 without force points): how far from a fixed
    point a fit stopped at ``max_iter`` still is, against step_tolerance (``xtol`` times the data's
    extent, or its largest magnitude (at least 1) for data at rest), the bound both must meet for
    ``"converged"``.
    """

    nodes: Array
    node_times: Array
    n_iter: int
    stop_reason: str
    energy: EnergyTerms
    capped_nodes: NDArray[np.intp]
    orientations: Array | None
    labels: NDArray[np.intp]
    duration: float
    n_force_points: int
    n_force_limit_rows: int
    solver: str
    energy_history: tuple[float, ...] = field(repr=False, default=())
    last_step: float = 0.0
    last_spring_step: float = 0.0
    step_tolerance: float = 0.0

    @property
    def n_nodes(self) -> int:
        return self.nodes.shape[0]

    @property
    def dim(self) -> int:
        return self.nodes.shape[1]

    def position_at(self, t: ArrayLike) -> Array:
        """Positions (len(t), d) along the time law (linear between nodes, clamped at the ends);
        ``t`` a number or (n,) seconds from the segment start."""
        t = _query_times(t)
        return np.stack([np.interp(t, self.node_times, self.nodes[:, q]) for q in range(self.dim)], axis=1)

    def orientation_at(self, t: ArrayLike) -> Array:
        """Quaternions (len(t), 4), w first, along the time law (SLERP between nodes)."""
        if self.orientations is None:
            raise ValueError("orientation_at: this map was fitted without orientations")
        return slerp_sequence(self.node_times, self.orientations, _query_times(t))


def _query_times(t: ArrayLike) -> Array:
    """Query times as a finite (n,) float array (a number is one query)."""
    return np.atleast_1d(check_array("t", t, ndim=(0, 1), axes=("index",)))


# ----------------------------------------------------------------------------------------------
# the initial map


def arc_length(path: Array) -> Array:
    """Cumulative arc length (T,) along ``path (T, d)``, starting at 0; the sample index when it has no
    length."""
    s = np.empty(len(path))
    s[0] = 0.0
    np.cumsum(row_norms(path[1:] - path[:-1]), out=s[1:])
    return s if s[-1] > 0 else np.arange(len(path), dtype=float)


def arc_length_resample(path: ArrayLike, n: int) -> Array:
    """``n`` points (n, d) equally spaced in arc length along ``path (T, d)``; by index when it has no
    length. T >= 1, d >= 1, |coordinates| <= MAX_COORDINATE; n in [1, MAX_NODES]."""
    path = check_array("path", path, ndim=2, min_len=1)
    if path.shape[1] < 1 or np.max(np.abs(path)) > MAX_COORDINATE:
        fail(
            "path",
            f"have shape (T, d) with d >= 1 and |coordinates| <= {MAX_COORDINATE:g}, got shape {path.shape}",
        )
    return _resample(path, check_int("n", n, low=1, high=MAX_NODES), arc_length(path))


def _resample(path: Array, n: int, s: Array) -> Array:
    """:func:`arc_length_resample` for a checked path with its arc length ``s (T,)``."""
    keep = np.empty(len(s), dtype=bool)
    keep[0] = True
    np.greater(s[1:], s[:-1], out=keep[1:])  # interp needs strictly increasing abscissae
    s, p = s[keep], path[keep]
    target = np.linspace(0.0, s[-1], n)
    return np.stack([np.interp(target, s, p[:, q]) for q in range(path.shape[1])], axis=1)


@dataclass(frozen=True)
class ForceLimitRows:
    """The force-limit half-spaces of the contact samples ``src (K,)``: the node of sample ``src[k]``
    must satisfy ``normal[k] · y >= lower[k]`` (normal (K, d) the unit force direction)."""

    src: NDArray[np.intp]
    normal: Array
    lower: Array

    def rows(self, labels: NDArray[np.intp]) -> InequalityRows:
        """The rows for the current assignment ``labels (M,)``."""
        return InequalityRows(labels[self.src], self.normal, self.lower)


@dataclass(frozen=True)
class InitialMap:
    """Everything the EM loop starts from: nodes (N, d), the resolved constraints, the M-step
    (``banded`` is None on the Clarabel path), the force points with their spring relaxation ω (K,)
    and their per-node sums (all None without contact samples), and the force-limit rows (None without
    ``force_limit`` or without samples above it)."""

    nodes: Array
    constraints: ResolvedConstraints
    banded: BandedMStep | None
    force_points: ForcePoints | None
    omega: Array | None
    force_sums: ForceNodeSums | None
    limits: ForceLimitRows | None

    @property
    def solver(self) -> str:
        return "banded" if self.banded is not None else "clarabel"


def initial_map(data: DemoData, params: FitParams, constraints: Constraints | None) -> InitialMap:
    """The first demo resampled by arc length to N nodes, with the equality constraints applied, and
    the parts of the problem that stay fixed through the EM."""
    n_nodes, dim = params.n_nodes, data.dim
    arc = arc_length(data.first)
    nodes = _resample(data.first, n_nodes, arc)
    rc = resolve_constraints(
        constraints, n_nodes, dim, _time_fraction_to_node(data.norm_times[0], arc / arc[-1], n_nodes)
    )
    if len(rc.fixed_index):
        nodes[rc.fixed_index] = rc.fixed_value
    use_clarabel = params.solver == "clarabel" or rc.has_inequalities or params.force_limit is not None
    if params.solver == "banded" and use_clarabel:
        fail(
            "solver",
            "be 'auto' or 'clarabel' with inequality constraints or force_limit (the banded M-step "
            "handles equalities only)",
            params.solver,
        )
    banded = (
        None
        if use_clarabel
        else BandedMStep(n_nodes, dim, params.lam, params.mu, rc.fixed_index, rc.fixed_value)
    )
    fp, omega = _force_points(data, params)
    sums = None if fp is None else ForceNodeSums(fp, n_nodes, params.stiffness, params.rho_max)
    return InitialMap(nodes, rc, banded, fp, omega, sums, _force_limit_rows(data, params))


def _time_fraction_to_node(norm_times: Array, arc_fraction: Array, n_nodes: int) -> Callable[[float], int]:
    """The node of a via point given as a time fraction: the first demo's arc-length fraction at that
    time (first sample of a repeated time), interpolated between samples so that a sparse demo does
    not snap the via point to its next sample. Sorting happens only when a via point asks."""

    def to_node(frac: float) -> int:
        times, first_at = np.unique(norm_times, return_index=True)
        return int(round(float(np.interp(frac, times, arc_fraction[first_at])) * (n_nodes - 1)))

    return to_node


def _force_points(data: DemoData, params: FitParams) -> tuple[ForcePoints | None, Array | None]:
    """The force points of the contact samples and their spring relaxation ω (K,); (None, None) without."""
    if data.f is None:
        return None, None
    fp = make_force_points(data.x, data.f, params.delta, params.f_contact)
    if len(fp) == 0:
        return None, None
    if params.spring_relaxation == "auto":
        return fp, 1.0 / (1.0 + fp.norm / (params.stiffness * max(params.delta, 1e-300)))
    return fp, np.full(len(fp), params.spring_relaxation)


def _force_limit_rows(data: DemoData, params: FitParams) -> ForceLimitRows | None:
    """Half-spaces keeping the node of every contact sample whose force exceeds ``force_limit`` at least
    ``(|f| − force_limit)/k`` behind the demonstrated contact along the force direction."""
    if data.f is None or params.force_limit is None:
        return None
    f, x = data.f, data.x
    fn = np.linalg.norm(f, axis=1)
    # contact samples only: a touch below f_contact is no contact, whatever force_limit is
    src = np.flatnonzero((fn > params.force_limit) & (fn > max(params.f_contact, 0.0)))
    if not len(src):
        return None
    normal = f[src] / fn[src, None]
    lower = np.einsum("ij,ij->i", normal, x[src]) + (fn[src] - params.force_limit) / params.stiffness
    return ForceLimitRows(src, normal, lower)


# ----------------------------------------------------------------------------------------------
# the EM loop


@dataclass
class EMState:
    """The EM loop's state after each iteration (see :class:`ElasticMapFit` for the reported fields)."""

    nodes: Array
    capped: NDArray[np.bool_]
    labels_prev: NDArray[np.intp] | None = None
    demo_sums: tuple[Array, Array] | None = None
    energy: EnergyTerms = EnergyTerms(0.0, 0.0, 0.0)  # replaced by the first M-step
    history: list[float] = field(default_factory=list)
    hashes: list[int] = field(default_factory=list)
    n_iter: int = 0
    reason: str = "max_iter"
    last_step: float = 0.0
    spring_moved: float = 0.0
    n_rows: int = 0


def run_em(data: DemoData, params: FitParams, start: InitialMap, steps: NumpyEMSteps | EMKernel) -> EMState:
    """Alternate E- and M-steps from ``start`` until a stop rule holds (see the module doc)."""
    state = EMState(nodes=start.nodes, capped=np.zeros((params.n_nodes, data.dim), dtype=bool))
    for it in range(1, params.max_iter + 1):
        state.n_iter = it
        labels = steps.assign(state.nodes)
        same = state.labels_prev is not None and np.array_equal(labels, state.labels_prev)  # cheap: M ints
        if same and start.force_points is None:
            # Same assignment, nothing else that moves: the M-step would return these nodes again.
            state.reason, state.last_step = "converged", 0.0
            break
        W, b = _cluster_sums(data, params, steps, state, same, start.force_sums)
        new = _m_step(data, params, start, state, W, b, labels)
        state.energy = energy_terms(new, W, b, data.S, params.lam, params.mu)
        state.history.append(state.energy.total)
        state.last_step = float(np.max(np.abs(new - state.nodes)))
        state.nodes = new
        reason = _stop_reason(state, labels, same, params, data.step_scale)
        if reason is not None:
            state.reason = reason
            break
        state.labels_prev = labels
    return state


def _cluster_sums(
    data: DemoData,
    params: FitParams,
    steps: NumpyEMSteps | EMKernel,
    state: EMState,
    same: bool,
    force_sums: ForceNodeSums | None,
) -> tuple[Array, Array]:
    """``W, b (N, d)`` of the last assignment: the demo sums (recomputed only when the assignment
    changed) plus the force points' sums for the current spring lengths, capped by rho_max."""
    if not same:
        state.demo_sums = steps.cluster_sums(data.demo_w)
    W, b = state.demo_sums
    if force_sums is not None:
        sums, state.spring_moved = steps.force_sums(
            delta=params.delta, stiffness=params.stiffness, init=state.n_iter == 1
        )
        Wf, bf, state.capped = force_sums.finish(sums, state.demo_sums[0])
        W = W + Wf
        b = b + bf
    return W, b


def _m_step(
    data: DemoData,
    params: FitParams,
    start: InitialMap,
    state: EMState,
    W: Array,
    b: Array,
    labels: NDArray[np.intp],
) -> Array:
    """New nodes (N, d) for the cluster sums ``W, b``."""
    if start.banded is not None:
        new = start.banded.solve(W, b, data.S, previous=state.nodes)
    else:
        extra = None if start.limits is None else start.limits.rows(labels)
        state.n_rows = 0 if extra is None else len(extra)
        try:
            new = clarabel_m_step(W, b, data.S, params.lam, params.mu, start.constraints, extra)
        except ValueError as err:
            raise ValueError(f"{err} (EM iteration {state.n_iter})") from None
    if not np.all(np.isfinite(new)):  # the input checks bound each input, not every combination
        f_max = np.max(np.abs(data.f)) if data.f is not None else 0
        fail(
            "positions/forces/weights",
            f"have scales that keep the M-step within float64 (M-step {state.n_iter} overflowed float64 "
            f"to non-finite nodes: |forces| up to {f_max:.3g}, weights in [{np.min(data.w):.3g}, "
            f"{np.max(data.w):.3g}], stiffness {params.stiffness:g}, delta {params.delta:g}; choose other "
            "units, or keep rho_max set)",
        )
    return new


def _stop_reason(
    state: EMState, labels: NDArray[np.intp], same: bool, params: FitParams, step_scale: float
) -> str | None:
    """The stop rule that holds after an M-step, or None to go on."""
    if same and max(state.last_step, state.spring_moved) <= params.xtol * step_scale:
        return "converged"
    # The energy test is the fallback for assignments that keep changing; with an unchanged
    # assignment only the spring lengths still move, and that iteration contracts to xtol.
    history = state.history
    if (
        not same
        and len(history) >= 2
        and abs(history[-1] - history[-2]) <= params.tol * max(abs(history[-2]), 1e-300)
    ):
        return "energy_tol"
    # A limit cycle: the last two assignments both repeat those p >= 2 iterations earlier.
    hashes = state.hashes
    hashes.append(hash(labels.tobytes()))
    if not same and any(
        hashes[-1] == hashes[-1 - p] and hashes[-2] == hashes[-2 - p]
        for p in range(2, min(9, len(hashes) - 1))
    ):
        return "cycle"
    return None


# ----------------------------------------------------------------------------------------------


def fit_force_elastic_map(
    positions: ArrayLike | Sequence[ArrayLike],
    forces: ArrayLike | Sequence[ArrayLike] | None = None,
    *,
    n_nodes: int = 100,
    lam: float = DEFAULT_LAMBDA,
    mu: float = DEFAULT_MU,
    delta: float = DEFAULT_DELTA,
    f_contact: float = DEFAULT_F_CONTACT,
    stiffness: float = DEFAULT_STIFFNESS,
    rho_max: float | None = 0.75,
    force_limit: float | None = None,
    constraints: Constraints | None = None,
    max_iter: int = 100,
    tol: float = 1e-9,
    xtol: float = 1e-9,
    times: ArrayLike | Sequence[ArrayLike] | None = None,
    orientations: ArrayLike | Sequence[ArrayLike] | None = None,
    weights: ArrayLike | Sequence[ArrayLike] | None = None,
    spring_relaxation: float | str = "auto",
    solver: str = "auto",
) -> ElasticMapFit:
    """Fit a force-constrained elastic map to one or more demos of one segment.

    positions: (T, d) array or a list of them (several demos, same d; d = 1 for a gripper map), T >= 2,
        in metres (any unit works; delta, stiffness and force_limit are in the same length unit).
    forces: same shapes or None — the reaction force on the robot on the same axes (points away from
        the contact surface), tared and low-passed, N; ``None``, ``delta=0`` or zero forces give the
        plain elastic map.
    n_nodes N in [3, MAX_NODES]; lam, mu >= 0 stretching / bending; delta (m) >= 0 force-point offset;
    f_contact (N) >= 0; stiffness k (N/m) > 0; rho_max in (0, 1) caps r = Σ|w_force|/Σw_demo per node and
    axis (None: off); force_limit (N) > 0: half-space constraints keeping the nodes of contact samples
    (‖f‖ > f_contact) above it at least (|f| − force_limit)/k behind the demonstrated contact along the
    force direction (Clarabel). max_iter >= 1; tol, xtol >= 0 (see the module doc's stop rules).
    times: per-demo timestamps (T,) in seconds (or datetimes), non-decreasing, default the sample index;
    orientations: per-demo (T, 4) w-first quaternions; weights: per-sample demo weights (T,) or (T, d),
    in [1e-100, 1e100]. spring_relaxation "auto" or ω in (0, 1]; solver "auto", "banded", "clarabel".
    ``ValueError`` names the bad argument (demo, frame, axis), or what to change when Clarabel fails.
    """
    params = check_fit_params(
        n_nodes=n_nodes,
        lam=lam,
        mu=mu,
        delta=delta,
        f_contact=f_contact,
        stiffness=stiffness,
        rho_max=rho_max,
        force_limit=force_limit,
        max_iter=max_iter,
        tol=tol,
        xtol=xtol,
        spring_relaxation=spring_relaxation,
        solver=solver,
        has_forces=forces is not None,
    )
    data = stack_demos(positions, forces, times, orientations, weights)
    start = initial_map(data, params, constraints)
    steps = _em_steps(data, params, start)
    state = run_em(data, params, start, steps)
    return _result(data, params, start, state, steps.assign(state.nodes))


def _em_steps(data: DemoData, params: FitParams, start: InitialMap) -> NumpyEMSteps | EMKernel:
    """The per-sample work: the compiled loops when they are built (same arithmetic), else NumPy."""
    lib = load_em_kernel()
    scale = max(data.extent, 1e-12)
    steps = NumpyEMSteps(data.x, scale) if lib is None else EMKernel(lib, data.x, scale)
    if start.force_points is not None:
        steps.set_force_points(start.force_points, start.force_sums, start.omega)
    return steps


def _result(
    data: DemoData, params: FitParams, start: InitialMap, state: EMState, labels: NDArray[np.intp]
) -> ElasticMapFit:
    """The fit's result; ``labels`` the assignment to the returned nodes."""
    node_t = node_time_law(labels, data.u, params.n_nodes, data.duration)
    quats = None
    if data.quats is not None:
        quats = node_orientations(node_t, data.norm_times, data.quats, data.duration)
    return ElasticMapFit(
        nodes=state.nodes,
        node_times=node_t,
        n_iter=state.n_iter,
        stop_reason=state.reason,
        energy=state.energy,
        capped_nodes=np.argwhere(state.capped),
        orientations=quats,
        labels=labels,
        duration=data.duration,
        n_force_points=0 if start.force_points is None else len(start.force_points),
        n_force_limit_rows=state.n_rows,
        solver=start.solver,
        energy_history=tuple(state.history),
        last_step=state.last_step,
        last_spring_step=state.spring_moved,
        step_tolerance=params.xtol * data.step_scale,
    )
