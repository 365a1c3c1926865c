"""Force-constrained elastic map: EM fit (paper §III-B/C, SPEC §1).

    fit = fit_force_elastic_map(positions, forces, n_nodes=100)
    fit.nodes            # (N, d) the reproduction path
    fit.position_at(t)   # query along the time law

E-step: every demo sample goes to its exact nearest node (:class:`NearestNodeAssigner`: bounds that
skip most distances). M-step: the banded solve of :mod:`.solve` (Clarabel when inequality constraints
are present). Force points are tied to the node of their source sample; their weights are recomputed
every iteration. The per-sample work (E-step, cluster sums, spring lengths) runs in the compiled loops
of :mod:`.kernel` when they are built, with the same arithmetic as the NumPy code here (bit-identical
fits, tested); ``LEROBOT_FORCEMAP_NUMPY_EM=1`` selects the NumPy path.

Decisions where the paper is silent (documented in the README too):
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
  than ``xtol`` times the data scale), ``"energy_tol"`` (the assignment still changed but the relative energy change
  fell below ``tol``), ``"cycle"`` (the assignment repeats with a period of 2 to 8 iterations),
  ``"max_iter"``. Without force points an unchanged assignment gives identical nodes, which is the
  authors' stop rule; with force points the spring lengths keep converging after the assignment
  settles, so "converged" also waits for the nodes to stop.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..geometry import slerp_sequence
from .constraints import Constraints, ResolvedConstraints, resolve_constraints
from .kernel import EMKernel, load_em_kernel
from .solve import BandedMStep, EnergyTerms, InequalityRows, energy_terms, solve_m_step_clarabel
from .timing import node_orientations, node_time_law
from .weights import ForceNodeSums, ForcePoints, cluster_sums, make_force_points, row_norms

__all__ = [
    "ElasticMapFit",
    "fit_force_elastic_map",
    "assign_nearest",
    "exact_nearest",
    "NearestNodeAssigner",
    "NumpyEMSteps",
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
#: largest |coordinate| (and δ) accepted: squared distances of 1e150 stay finite in float64
MAX_COORDINATE = 1e150
#: smallest non-zero extent of the data accepted: squared distances of 1e-200 stay normal floats
MIN_EXTENT = 1e-100
#: accepted range of demo weights: the M-step squares the cluster weights, which must stay normal floats
WEIGHT_RANGE = (1e-100, 1e100)


@dataclass(frozen=True)
class ElasticMapFit:
    """Result of :func:`fit_force_elastic_map`.

    nodes (N, d); node_times (N,) seconds from the segment start; orientations (N, 4) w-first or None;
    labels (M,) node of every stacked demo sample; capped_nodes (C, 2) rows (node, axis) whose force
    weights were scaled down by the rho_max cap in the last iteration; last_step the largest change of a
    node coordinate in the last M-step (positions' units; 0 when the assignment repeated without force
    points) and last_spring_step the largest change of a force point's spring length Δ in that iteration
    (0 without force points): how far from a fixed point a fit stopped at ``max_iter`` still is, against
    step_tolerance (``xtol`` times the data's extent, or its largest magnitude (at least 1) for data at
    rest), the bound both must meet for ``"converged"``.
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
        """Positions (len(t), d) along the time law (linear between nodes, clamped at the ends)."""
        t = _query_times(t, "position_at")
        return np.stack([np.interp(t, self.node_times, self.nodes[:, q]) for q in range(self.dim)], axis=1)

    def orientation_at(self, t: ArrayLike) -> Array:
        """Quaternions (len(t), 4) along the time law (SLERP between nodes)."""
        if self.orientations is None:
            raise ValueError("orientation_at: this map was fitted without orientations")
        return slerp_sequence(self.node_times, self.orientations, _query_times(t, "orientation_at"))


def _query_times(t: ArrayLike, caller: str) -> Array:
    """Query times as a finite (n,) float array; a (2, 2) array gave (2, d, 2) positions, NaN gave NaN rows."""
    t = np.atleast_1d(np.asarray(t, dtype=float))
    if t.ndim != 1:
        raise ValueError(f"{caller}: t must be a number or a 1-D array of seconds, got shape {t.shape}")
    if not np.all(np.isfinite(t)):
        raise ValueError(f"{caller}: t[{int(np.argmax(~np.isfinite(t)))}] is not finite")
    return t


# ----------------------------------------------------------------------------------------------
# E-step and initialisation


def assign_nearest(points: Array, nodes: Array) -> NDArray[np.intp]:
    """Index of the nearest node for every point: points (M, d), nodes (N, d) -> (M,); ties to the
    lowest index.

    ``‖x − y‖² = ‖x‖² − 2x·y + ‖y‖²`` and ``‖x‖²`` is the same for every node of a row, so one matrix
    product (M, N) on centred coordinates and an argmin give the assignment. The expansion rounds
    differently from summing squared differences, so rows whose two nearest nodes are within its
    rounding error are decided again by :func:`exact_nearest` (the compiled E-step's arithmetic).
    """
    origin = points.mean(axis=0)
    c, cy = points - origin, nodes - origin
    ysq = np.einsum("ij,ij->i", cy, cy)
    d2 = c @ (-2.0 * cy.T) + ysq  # squared distances minus ‖x‖²
    labels = np.argmin(d2, axis=1)
    if nodes.shape[0] > 1:
        best, second = np.partition(d2, 1, axis=1)[:, :2].T
        close = np.flatnonzero(second - best <= expansion_tolerance(np.einsum("ij,ij->i", c, c), ysq))
        if len(close):
            labels[close] = exact_nearest(points.T, nodes.T, close)[0]
    return labels


def expansion_tolerance(point_sq: Array, node_sq: Array) -> Array:
    """Per point, a bound on the rounding error of ``−2x·y + ‖y‖²`` (centred ``‖x‖²`` point_sq (m,),
    ``‖y‖²`` node_sq (N,)): two nodes closer than this in the expansion may be in either order."""
    d_eps = 64.0 * np.finfo(np.float64).eps
    return d_eps * (point_sq + 2.0 * float(np.max(node_sq)))


def exact_nearest(
    point_columns: Array, node_columns: Array, idx: NDArray[np.intp]
) -> tuple[NDArray[np.intp], Array]:
    """Nearest node of the points ``idx (m,)`` by distances summed axis by axis (as the compiled E-step
    computes them, so near-ties go the same way), ties to the lowest index: point_columns (d, M),
    node_columns (d, N) -> labels (m,), distances to every node (N, m)."""
    n = node_columns.shape[1]
    every = np.broadcast_to(np.arange(n)[:, None], (n, len(idx)))
    dist = point_node_distances(point_columns, node_columns, every, idx)
    return np.argmin(dist, axis=0), dist


def point_node_distances(
    point_columns: Array, node_columns: Array, which: NDArray[np.intp], idx: NDArray[np.intp] | None = None
) -> Array:
    """Distances from points to given nodes, axis-major: point_columns (d, M), node_columns (d, N).

    ``which`` holds a node per point, (M,) — or per selected point ``idx (m,)``, (m,) or (k, m) for
    k candidate nodes each. One gather per axis on contiguous rows: with d small this beats
    ``np.linalg.norm(points - nodes[which], axis=1)`` on (M, d) arrays severalfold.
    """
    acc = None
    for q in range(len(node_columns)):
        dq = np.take(node_columns[q], which)
        dq -= point_columns[q] if idx is None else point_columns[q, idx]
        dq *= dq
        acc = dq if acc is None else acc + dq
    return np.sqrt(acc, out=acc)


class NearestNodeAssigner:
    """The E-step across EM iterations: exact nearest nodes, with bounds that skip most of the work.

    Each sample is scored against a window: the ``window_size`` nodes nearest to a centre node (its
    nearest node when its distances were last computed in full; the neighbourhoods are taken from
    the nodes of the first call, so on a straight stretch of the map they are the centre and its
    neighbours along it, and where the path folds back on itself they take in the other leg too).
    Three bounds, in the spirit of Hamerly's and Elkan's exact k-means:

    - ``upper``: the distance to its node, plus how far that node moved since;
    - ``lower_in``: the distance to the nearest *other* window node, minus the largest move in the
      window since. EM moves a few nodes at a time (after the first iterations most nodes barely
      move while a handful move by a fraction of a millimetre), so this bound stays tight where
      nothing moves;
    - ``lower_out``: the distance to the nearest node outside the window, minus the largest move of
      any node since; outside nodes lie farther than the window's, so it lasts many iterations.

    A sample keeps its node while ``upper < min(lower_in, lower_out)``. Otherwise its window
    distances are computed and decide when the window's nearest node beats ``lower_out``; when
    even that fails, the triangle inequality gives a fresh ``lower_out`` from the nodes' own
    distances, and only what is still undecided gets a full row of distances. The result equals
    :func:`assign_nearest` up to exact ties.
    """

    def __init__(self, points: Array, *, window_size: int = 7, scale: float | None = None) -> None:
        """points (M, d); window_size: nodes per window (centre included); scale: the data's extent
        (sets the slack against rounding)."""
        self.points = points
        self.columns = np.ascontiguousarray(points.T)  # (d, M): per-axis gathers are contiguous
        # the expansion of _full runs on centred coordinates: a far origin would cost it digits
        self.origin = points.mean(axis=0)
        centred = points - self.origin
        self.augmented = np.hstack([centred, np.ones((len(points), 1))])
        self.sq = np.einsum("ij,ij->i", centred, centred)
        self.window_size = window_size
        self.labels: NDArray[np.intp] | None = None
        self.nodes: Array | None = None
        if scale is None:
            scale = float(np.max(np.ptp(self.columns, axis=1)))
        # slack against rounding in the bounds: a sample is re-examined unless clearly decided
        self.slack = 1e-9 * max(scale, 1e-12)

    def _start(self, nodes: Array) -> None:
        m, n = len(self.points), nodes.shape[0]
        self.labels = np.empty(m, dtype=np.intp)
        self.center = np.empty(m, dtype=np.intp)
        self.upper, self.lower_in, self.lower_out = np.empty(m), np.empty(m), np.empty(m)
        # windows (k, N): column c holds c itself (row 0) and the k − 1 nodes nearest to it
        k = min(self.window_size, n)
        c = nodes - nodes.mean(axis=0)  # centred: the expansion loses nothing to a far origin
        sq = np.einsum("ij,ij->i", c, c)
        d2 = sq[:, None] + sq[None, :] - 2.0 * (c @ c.T)
        np.fill_diagonal(d2, np.inf)
        others = np.argpartition(d2, k - 2, axis=1)[:, : k - 1] if k > 1 else np.empty((n, 0), np.intp)
        self.windows = np.ascontiguousarray(np.column_stack([np.arange(n), others]).T)

    def _full(self, idx: NDArray[np.intp] | slice, nodes: Array) -> None:
        """Exact nodes and fresh bounds for the samples ``idx`` from all (M', N) distances."""
        rhs = np.empty((nodes.shape[1] + 1, nodes.shape[0]))
        centred = nodes - self.origin
        np.multiply(centred.T, -2.0, out=rhs[:-1])
        rhs[-1] = np.einsum("ij,ij->i", centred, centred)
        d2 = self.augmented[idx] @ rhs  # squared distances minus ‖x‖²
        # Row minima by argmin + gather: numpy's argmin over short rows is about twice as fast as min.
        rows = np.arange(d2.shape[0])
        first = np.argmin(d2, axis=1)
        best = d2[rows, first]
        win = np.take(self.windows, first, axis=1)  # (k, m), C-ordered (fancy indexing would give F)
        flat = win + (rows * d2.shape[1])  # (k, m) C-ordered, so the gathers below are too
        near = np.take(d2, flat)
        near[win == first] = np.inf
        np.put(d2, flat, np.inf)
        outside = d2[rows, np.argmin(d2, axis=1)]  # inf where the window holds every node
        sq = self.sq[idx]
        near = np.min(near, axis=0)
        self.labels[idx] = first
        self.center[idx] = first
        self.upper[idx] = np.sqrt(np.maximum(best + sq, 0.0))
        self.lower_in[idx] = np.sqrt(np.maximum(near + sq, 0.0))
        self.lower_out[idx] = np.sqrt(np.maximum(outside + sq, 0.0))
        close = np.minimum(near, outside) - best <= expansion_tolerance(sq, rhs[-1])
        if close.any():
            self._exact(np.arange(len(self.points))[idx][close], nodes)

    def _exact(self, idx: NDArray[np.intp], nodes: Array) -> None:
        """Labels and bounds of samples whose two nearest nodes the expansion cannot tell apart, from
        :func:`exact_nearest` (how the compiled E-step decides them)."""
        labels, dist = exact_nearest(self.columns, np.ascontiguousarray(nodes.T), idx)
        cols = np.arange(len(idx))
        in_window = np.zeros(dist.shape, dtype=bool)
        in_window[np.take(self.windows, labels, axis=1), cols] = True
        self.labels[idx] = labels
        self.center[idx] = labels
        self.upper[idx] = dist[labels, cols]
        self.lower_out[idx] = np.min(np.where(in_window, np.inf, dist), axis=0)
        in_window[labels, cols] = False
        self.lower_in[idx] = np.min(np.where(in_window, dist, np.inf), axis=0)

    def __call__(self, nodes: Array) -> NDArray[np.intp]:
        if self.labels is None or self.nodes is None or self.nodes.shape != nodes.shape:
            self._start(nodes)
            self._full(slice(None), nodes)
        else:
            move = row_norms(nodes - self.nodes)
            self.labels = self.labels.copy()  # callers keep the previous assignment
            self.upper += move[self.labels]
            self.lower_in -= np.max(move[self.windows], axis=0)[self.center]
            self.lower_out -= move.max()
            lower = np.minimum(self.lower_in, self.lower_out)
            idx = np.flatnonzero(self.upper + self.slack >= lower)
            if len(idx):
                node_columns = np.ascontiguousarray(nodes.T)
                self.upper[idx] = point_node_distances(self.columns, node_columns, self.labels[idx], idx)
                idx = idx[self.upper[idx] + self.slack >= lower[idx]]
                if len(idx):
                    self._decide_in_window(idx, nodes, node_columns)
        self.nodes = nodes.copy()
        return self.labels

    def _decide_in_window(self, idx: NDArray[np.intp], nodes: Array, node_columns: Array) -> None:
        """Samples whose bounds cross: the window decides when its nearest node beats ``lower_out``."""
        center = self.center[idx]
        # (k, m) layout: reductions over the k window nodes run along contiguous rows
        win = np.take(self.windows, center, axis=1)
        near = point_node_distances(self.columns, node_columns, win, idx)
        cols = np.arange(len(idx))
        j = np.argmin(near, axis=0)
        best = near[j, cols]
        undecided = best + self.slack >= self.lower_out[idx]
        if undecided.any():
            # triangle inequality: ‖x − y_i‖ >= ‖y_i − y_c‖ − ‖x − y_c‖ for every node i outside c's window
            u = idx[undecided]
            centers, which = np.unique(center[undecided], return_inverse=True)
            gap = nodes[None, :, :] - nodes[centers][:, None, :]
            gap = np.sqrt(np.einsum("cnd,cnd->cn", gap, gap))
            gap[np.arange(len(centers)), self.windows[:, centers]] = np.inf
            reach = np.min(gap, axis=1)  # distance from each centre to the nearest node outside its window
            c_dist = near[0, cols[undecided]]  # row 0 of a window is its centre
            fresh = reach[which] - c_dist
            self.lower_out[u] = np.maximum(self.lower_out[u], fresh)
            undecided[undecided] = best[undecided] + self.slack >= self.lower_out[u]
        # exact ties go to the lowest node index (window rows are not in index order)
        label = np.min(np.where(near == best, win, nodes.shape[0]), axis=0)
        near[win == label] = np.inf
        decided = ~undecided
        ok = idx[decided]
        self.labels[ok] = label[decided]
        self.upper[ok] = best[decided]
        self.lower_in[ok] = np.min(near, axis=0)[decided]
        if undecided.any():
            self._full(idx[undecided], nodes)


class NumpyEMSteps:
    """The EM's per-sample work in NumPy — the reference for :class:`~.kernel.EMKernel`, same interface.

    The state is the last E-step: :meth:`assign` keeps the labels and the nodes; :meth:`cluster_sums`
    and :meth:`force_sums` work on them.
    """

    def __init__(self, points: Array, scale: float) -> None:
        self.x = points
        self.assigner = NearestNodeAssigner(points, scale=scale)

    def assign(self, nodes: Array) -> NDArray[np.intp]:
        """Nearest node (M,) of every sample for ``nodes (N, d)``."""
        self.labels = self.assigner(nodes)
        self.nodes = nodes
        return self.labels

    def cluster_sums(self, w: Array | None) -> tuple[Array, Array]:
        """``W, b (N, d)`` of the last assignment (``w`` (M, d) or ``None`` for unit weights)."""
        return cluster_sums(self.labels, w, self.x, self.nodes.shape[0])

    def set_force_points(self, fp: ForcePoints, sums: ForceNodeSums, omega: Array) -> None:
        """The force points, their :class:`ForceNodeSums` and spring relaxation ω (K,)."""
        self.fp, self.sums, self.omega = fp, sums, omega
        self.fp_columns = np.ascontiguousarray(fp.points.T)
        self.spring: Array | None = None

    def force_sums(self, *, delta: float, stiffness: float, init: bool) -> tuple[Array, float]:
        """For the last assignment and nodes: spring lengths relaxed towards ``max(‖p − y_tied‖, δ)``
        (set when ``init``); returns the raw per-node sums (N, 2d) and the largest spring change."""
        tied = self.labels[self.fp.source]
        target = point_node_distances(self.fp_columns, np.ascontiguousarray(self.nodes.T), tied)
        target = np.maximum(target, delta)
        moved = 0.0
        if init or self.spring is None:
            self.spring = target
        else:
            new_spring = self.spring + self.omega * (target - self.spring)
            moved = float(np.max(np.abs(new_spring - self.spring)))
            self.spring = new_spring
        return self.sums.raw(tied, self.spring), moved


def arc_length(path: Array) -> Array:
    """Cumulative arc length (T,) along ``path (T, d)``, starting at 0; the sample index when it has no length."""
    s = np.empty(len(path))
    s[0] = 0.0
    np.cumsum(row_norms(path[1:] - path[:-1]), out=s[1:])
    return s if s[-1] > 0 else np.arange(len(path), dtype=float)


def arc_length_resample(path: Array, n: int, s: Array | None = None) -> Array:
    """``n`` points equally spaced in arc length along ``path (T, d)``; by index when it has no length.

    ``s``: :func:`arc_length` of ``path`` when the caller has it.
    """
    if s is None:
        s = arc_length(path)
    keep = np.empty(len(s), dtype=bool)
    keep[0] = True
    np.greater(s[1:], s[:-1], out=keep[1:])  # interp needs strictly increasing abscissae
    s, p = s[keep], path[keep]
    target = np.linspace(0.0, s[-1], n)
    return np.stack([np.interp(target, s, p[:, q]) for q in range(path.shape[1])], axis=1)


# ----------------------------------------------------------------------------------------------
# input checks


def _is_array(v: object) -> bool:
    """An array object (numpy, or one that converts itself: pandas, torch), not a nested Python list."""
    return isinstance(v, np.ndarray) or (hasattr(v, "__array__") and not isinstance(v, (list, tuple)))


def _as_demo_list(value: object, name: str) -> list[Array]:
    """``value`` as a list of (T, d) float arrays: one array (numpy, pandas, nested lists) is one demo,
    a list or tuple of array objects is several. ``times`` may be datetimes (converted to seconds)."""
    if _is_array(value):
        items = [value]
    elif isinstance(value, (list, tuple)) and len(value) and all(_is_array(v) for v in value):
        items = list(value)
        shapes = {np.shape(v) for v in items}
        if (
            name == "positions"
            and len(shapes) == 1
            and len(s := next(iter(shapes))) == 1
            and len(items) > s[0] <= 4
        ):
            # list(x) of a (T, d) array reads as T one-dimensional demos of d samples: say so, not fit that
            raise ValueError(
                f"positions: a list of {len(items)} one-dimensional arrays of {s[0]} samples each reads as "
                f"{len(items)} demos; for one ({len(items)}, {s[0]}) demo pass np.asarray(...) of them"
            )
    else:
        items = [value]
    out = []
    for k, a in enumerate(items):
        where = f"{name}[{k}]"
        try:
            a = np.asarray(a)
        except (TypeError, ValueError):  # ragged nested lists
            a = None
        if a is None or a.dtype == object:
            raise ValueError(
                f"{where}: not a rectangular numeric array (several demos of different lengths go in a "
                "list of (T, d) numpy arrays)"
            )
        if a.dtype.kind in "Mm":  # datetimes and durations: seconds, as documented
            if name != "times":
                raise ValueError(f"{where}: got {a.dtype} values; expected numbers")
            a = (a - a.reshape(-1)[0]) / np.timedelta64(1, "s") if a.size else a.astype(float)
        if a.dtype.kind not in "biuf":
            raise ValueError(f"{where}: expected real numbers, got dtype {a.dtype}")
        a = a.astype(float)
        if a.ndim == 1:
            a = a[:, None]
        if a.ndim != 2:
            hint = "; several demos go in a list of (T, d) arrays" if a.ndim == 3 else ""
            raise ValueError(f"{where}: expected shape (T, d), got {a.shape}{hint}")
        out.append(a)
    return out


def _check_finite(arrays: Sequence[Array], name: str) -> None:
    for k, a in enumerate(arrays):
        bad = ~np.isfinite(a)
        if bad.any():
            t, q = np.argwhere(bad)[0] if a.ndim == 2 else (np.argwhere(bad)[0][0], 0)
            raise ValueError(
                f"{name}[{k}]: non-finite value {a[t, q] if a.ndim == 2 else a[t]} at frame {t}, axis {q}"
            )


def _check_scalar(name: str, value: float, *, low: float = 0.0, strict: bool = False) -> float:
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a number, got {value!r}") from None
    if not np.isfinite(v) or (v <= low if strict else v < low):
        raise ValueError(f"{name}: must be {'>' if strict else '>='} {low} and finite, got {value!r}")
    return v


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

    positions: (T, d) array or a list of them (several demos, same d; d = 1 for a gripper map).
    forces: same shapes or None — the reaction force on the robot on the same axes (points away from
        the contact surface), tared and low-passed; ``None``, ``delta=0`` or zero forces give the
        plain elastic map.
    n_nodes (N >= 3); lam, mu >= 0 stretching / bending; delta (m) force-point offset; f_contact (N);
    stiffness k (N/m); rho_max in (0, 1) caps r = Σ|w_force|/Σw_demo per node and axis (None: off);
    force_limit (N): half-space constraints keeping nodes of contact samples (‖f‖ > f_contact) above it
    at least (|f| − force_limit)/k behind the demonstrated contact along the force direction (Clarabel).
    times: per-demo timestamps (T,), default uniform; orientations: per-demo (T, 4) w-first quaternions;
    weights: per-sample demo weights (T,) or (T, d), positive. solver: "auto", "banded", "clarabel".
    """
    # ---- validate
    demos = _as_demo_list(positions, "positions")
    _check_finite(demos, "positions")
    dim = demos[0].shape[1]
    if dim < 1:
        raise ValueError(f"positions: need at least 1 coordinate per sample, got shape {demos[0].shape}")
    for k, a in enumerate(demos):
        if a.shape[1] != dim:
            raise ValueError(f"positions[{k}]: dimension {a.shape[1]} differs from positions[0]'s {dim}")
        if a.shape[0] < 2:
            raise ValueError(f"positions[{k}]: need at least 2 samples, got {a.shape[0]}")
        if np.max(np.abs(a)) > MAX_COORDINATE:
            raise ValueError(
                f"positions[{k}]: |coordinate| up to {np.max(np.abs(a)):.3g}; above {MAX_COORDINATE:g} squared "
                "distances overflow float64 (choose other units)"
            )
    if isinstance(n_nodes, bool) or not isinstance(n_nodes, (int, np.integer)) or n_nodes < 3:
        raise ValueError(f"n_nodes: need an integer >= 3, got {n_nodes!r}")
    n_nodes = int(n_nodes)
    lam = _check_scalar("lam", lam)
    mu = _check_scalar("mu", mu)
    delta = _check_scalar("delta", delta)
    if delta > MAX_COORDINATE:
        raise ValueError(
            f"delta: {delta:g} is above {MAX_COORDINATE:g} (force points would overflow float64)"
        )
    f_contact = _check_scalar("f_contact", f_contact)
    stiffness = _check_scalar("stiffness", stiffness, strict=True)
    if rho_max is not None:
        rho_max = _check_scalar("rho_max", rho_max, strict=True)
        if rho_max >= 1.0:
            raise ValueError(f"rho_max: must be in (0, 1), got {rho_max}")
    if force_limit is not None:
        force_limit = _check_scalar("force_limit", force_limit, strict=True)
        if forces is None:
            raise ValueError("force_limit: needs forces (it limits the demonstrated force); got forces=None")
    if isinstance(max_iter, bool) or not isinstance(max_iter, (int, np.integer)) or max_iter < 1:
        raise ValueError(f"max_iter: need an integer >= 1, got {max_iter!r}")
    tol = _check_scalar("tol", tol)
    xtol = _check_scalar("xtol", xtol)
    if spring_relaxation != "auto":
        spring_relaxation = _check_scalar("spring_relaxation", spring_relaxation, strict=True)
        if spring_relaxation > 1.0:
            raise ValueError(f"spring_relaxation: must be 'auto' or in (0, 1], got {spring_relaxation}")
    if solver not in ("auto", "banded", "clarabel"):
        raise ValueError(f"solver: expected 'auto', 'banded' or 'clarabel', got {solver!r}")

    lengths = [len(a) for a in demos]

    def matching(value: object, name: str, width: int | None) -> list[Array]:
        arrs = _as_demo_list(value, name)
        if len(arrs) != len(demos):
            raise ValueError(f"{name}: {len(arrs)} demos given for {len(demos)} demos of positions")
        for k, a in enumerate(arrs):
            want = (lengths[k], width if width is not None else a.shape[1])
            if a.shape != want:
                raise ValueError(
                    f"{name}[{k}]: shape {a.shape} does not match positions[{k}] (expected {want})"
                )
        _check_finite(arrs, name)
        return arrs

    force_list = matching(forces, "forces", dim) if forces is not None else None
    for k, a in enumerate(force_list or ()):
        if np.any(big := np.abs(a) > MAX_COORDINATE):
            t, q = np.argwhere(big)[0]
            raise ValueError(
                f"forces[{k}]: {a[t, q]:.3g} at frame {t}, axis {q} is above {MAX_COORDINATE:g} (choose other units)"
            )
    if weights is not None:
        wl = _as_demo_list(weights, "weights")
        wl = [np.repeat(a, dim, axis=1) if a.shape[1] == 1 and dim > 1 else a for a in wl]
        weight_list = matching(wl, "weights", dim)
        for k, a in enumerate(weight_list):
            if np.any(a <= 0):
                t, q = np.argwhere(a <= 0)[0]
                raise ValueError(f"weights[{k}]: weights must be > 0, got {a[t, q]} at frame {t}, axis {q}")
            if np.any(out := (a < WEIGHT_RANGE[0]) | (a > WEIGHT_RANGE[1])):
                t, q = np.argwhere(out)[0]
                raise ValueError(
                    f"weights[{k}]: {a[t, q]:.3g} at frame {t}, axis {q} is outside [{WEIGHT_RANGE[0]:g}, "
                    f"{WEIGHT_RANGE[1]:g}] (squared cluster weights would leave float64's range; rescale them)"
                )
    else:
        weight_list = [np.ones((n, dim)) for n in lengths]
    if times is not None:
        time_list = [a[:, 0] for a in matching(times, "times", 1)]
        for k, t in enumerate(time_list):
            back = np.flatnonzero(np.diff(t) < 0)
            if len(back):
                raise ValueError(
                    f"times[{k}]: decreasing at frame {back[0] + 1} ({t[back[0]]} -> {t[back[0] + 1]})"
                )
            if t[-1] <= t[0]:
                raise ValueError(f"times[{k}]: the demo has zero duration")
    else:
        time_list = [np.arange(n, dtype=float) for n in lengths]
    quat_list = None
    if orientations is not None:
        quat_list = matching(orientations, "orientations", 4)
        for k, q in enumerate(quat_list):
            with np.errstate(over="ignore"):
                norms = np.linalg.norm(q, axis=1)
            if not np.all(np.isfinite(norms)):
                raise ValueError(
                    f"orientations[{k}]: quaternion norm overflows float64 at frame "
                    f"{int(np.argmax(~np.isfinite(norms)))} (expected unit quaternions, w first)"
                )
            if np.any(norms < 1e-9):
                raise ValueError(
                    f"orientations[{k}]: zero quaternion at frame {int(np.argmax(norms < 1e-9))}"
                )

    # ---- stack the data
    x = np.concatenate(demos, axis=0)
    w = np.concatenate(weight_list, axis=0)
    f = np.concatenate(force_list, axis=0) if force_list is not None else None
    norm_times = [(t - t[0]) / (t[-1] - t[0]) for t in time_list]
    u = np.concatenate(norm_times)
    duration = (
        float(np.mean([t[-1] - t[0] for t in time_list]))
        if times is not None
        else float(np.mean(lengths) - 1)
    )
    S = len(x) * float(np.sqrt(dim)) if weights is None else float(np.sum(row_norms(w)))
    # (d, M) copy: reductions along contiguous rows are many times faster than along axis 0 of (M, d)
    extent = float(np.max(np.ptp(np.ascontiguousarray(x.T), axis=1)))
    if 0.0 < extent < MIN_EXTENT:
        raise ValueError(
            f"positions: the data spans only {extent:.3g} (below {MIN_EXTENT:g} squared distances underflow "
            "float64; choose other units)"
        )
    scale = max(extent, 1e-12)
    # the stop test's unit: data at rest (a gripper held open) has no extent, and xtol·1e-12 is below
    # float64's resolution of the nodes, so such fits never "converged"; one unit of the data instead
    step_scale = extent if extent > 0.0 else max(float(np.max(np.abs(x))), 1.0)

    # ---- initial map and constraints
    first = demos[0]
    arc = arc_length(first)
    y = arc_length_resample(first, n_nodes, arc)
    arc = arc / arc[-1]

    def time_fraction_to_node(frac: float) -> int:
        # the first demo's arc fraction at that time (first sample of a repeated time), interpolated
        # between samples: a sparse demo must not snap the via point to its next sample. Only called for
        # via points given by time, so a fit without them does not pay for the sort.
        times, first_at = np.unique(norm_times[0], return_index=True)
        return int(round(float(np.interp(frac, times, arc[first_at])) * (n_nodes - 1)))

    rc: ResolvedConstraints = resolve_constraints(constraints, n_nodes, dim, time_fraction_to_node)
    if len(rc.fixed_index):
        y[rc.fixed_index] = rc.fixed_value
    use_clarabel = solver == "clarabel" or rc.has_inequalities or force_limit is not None
    if solver == "banded" and use_clarabel:
        raise ValueError(
            "solver: 'banded' cannot handle inequality constraints or force_limit; use 'auto' or 'clarabel'"
        )

    fp: ForcePoints | None = None
    if f is not None:
        fp = make_force_points(x, f, delta, f_contact)
        if len(fp) == 0:
            fp = None
        elif spring_relaxation == "auto":
            omega = 1.0 / (1.0 + fp.norm / (stiffness * max(delta, 1e-300)))
        else:
            omega = np.full(len(fp), spring_relaxation)
    limit_src = None
    if f is not None and force_limit is not None:
        fn = np.linalg.norm(f, axis=1)
        # contact samples only (SPEC §1): a touch below f_contact is no contact, whatever force_limit is
        limit_src = np.flatnonzero((fn > force_limit) & (fn > max(f_contact, 0.0)))
        limit_normal = f[limit_src] / fn[limit_src, None]
        limit_lower = (
            np.einsum("ij,ij->i", limit_normal, x[limit_src]) + (fn[limit_src] - force_limit) / stiffness
        )

    # ---- EM
    labels_prev: NDArray[np.intp] | None = None
    hashes: list[int] = []
    history: list[float] = []
    spring_moved = 0.0
    last_step = 0.0
    reason = "max_iter"
    capped = np.zeros((n_nodes, dim), dtype=bool)
    n_rows = 0
    energy = EnergyTerms(0.0, 0.0, 0.0)  # replaced by the first M-step
    it = 0
    banded = None if use_clarabel else BandedMStep(n_nodes, dim, lam, mu, rc.fixed_index, rc.fixed_value)
    demo_w = None if weights is None else w
    # The per-sample work: the compiled loops when they are built (same arithmetic), else NumPy.
    lib = load_em_kernel()
    steps = NumpyEMSteps(x, scale) if lib is None else EMKernel(lib, x, scale)
    if fp is not None:
        force_sums = ForceNodeSums(fp, n_nodes, stiffness, rho_max)
        steps.set_force_points(fp, force_sums, omega)
    for it in range(1, max_iter + 1):  # noqa: B007 (it is reported after the loop)
        labels = steps.assign(y)
        same = labels_prev is not None and np.array_equal(labels, labels_prev)  # cheap: M ints
        if same and fp is None:
            # Same assignment, nothing else that moves: the M-step would return these nodes again.
            reason = "converged"
            last_step = 0.0
            break
        if not same:
            W_demo, b_demo = steps.cluster_sums(demo_w)
        W, b = W_demo, b_demo
        if fp is not None:
            sums, spring_moved = steps.force_sums(delta=delta, stiffness=stiffness, init=it == 1)
            Wf, bf, capped = force_sums.finish(sums, W_demo)
            W = W + Wf
            b = b + bf
        extra = None
        if limit_src is not None and len(limit_src):
            extra = InequalityRows(labels[limit_src], limit_normal, limit_lower)
            n_rows = len(extra)
        if use_clarabel:
            y_new = solve_m_step_clarabel(W, b, S, lam, mu, rc, extra)
        else:
            y_new = banded.solve(W, b, S, previous=y)
        if not np.all(np.isfinite(y_new)):  # the input checks bound each input, not every combination
            raise ValueError(
                f"positions/forces/weights: M-step {it} overflowed float64 (non-finite nodes); the inputs' "
                f"scales combine badly: |forces| up to {np.max(np.abs(f)) if f is not None else 0:.3g}, "
                f"weights in [{np.min(w):.3g}, {np.max(w):.3g}], stiffness {stiffness:g}, delta {delta:g} "
                "(choose other units, or keep rho_max set)"
            )
        energy = energy_terms(y_new, W, b, S, lam, mu)
        history.append(energy.total)
        moved = float(np.max(np.abs(y_new - y)))
        last_step = moved
        y = y_new
        if same and max(moved, spring_moved) <= xtol * step_scale:
            reason = "converged"
            break
        # The energy test is the fallback for assignments that keep changing; with an unchanged
        # assignment only the spring lengths still move, and that iteration contracts to xtol.
        if (
            not same
            and len(history) >= 2
            and abs(history[-1] - history[-2]) <= tol * max(abs(history[-2]), 1e-300)
        ):
            reason = "energy_tol"
            break
        # A limit cycle: the last two assignments both repeat those p >= 2 iterations earlier.
        hashes.append(hash(labels.tobytes()))
        if not same and any(
            hashes[-1] == hashes[-1 - p] and hashes[-2] == hashes[-2 - p]
            for p in range(2, min(9, len(hashes) - 1))
        ):
            reason = "cycle"
            break
        labels_prev = labels

    labels = steps.assign(y)  # the assignment to the returned nodes (bounds make this cheap)
    node_t = node_time_law(labels, u, n_nodes, duration)
    quats = None
    if quat_list is not None:
        quats = node_orientations(node_t, norm_times, quat_list, duration)
    return ElasticMapFit(
        nodes=y,
        node_times=node_t,
        n_iter=it,
        stop_reason=reason,
        energy=energy,
        capped_nodes=np.argwhere(capped),
        orientations=quats,
        labels=labels,
        duration=duration,
        n_force_points=0 if fp is None else len(fp),
        n_force_limit_rows=n_rows,
        solver="clarabel" if use_clarabel else "banded",
        energy_history=tuple(history),
        last_step=last_step,
        last_spring_step=spring_moved,
        step_tolerance=xtol * step_scale,
    )
