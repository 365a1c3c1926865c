"""The E-step: every demo sample goes to its exact nearest node.

:func:`assign_nearest` is the one-shot version (one matrix product and an argmin);
:class:`NearestNodeAssigner` is the version the EM loop keeps across iterations, with bounds that
skip most distances; :class:`NumpyEMSteps` bundles it with the cluster sums and the spring lengths of
the force points. ``NumpyEMSteps`` is the reference for the compiled loops of :mod:`.kernel`
(``EMKernel``, same interface, same arithmetic, bit-identical results).

Ties (a sample exactly as far from two nodes) go to the lowest node index everywhere.
Layout: samples ``points (M, d)``, nodes ``(N, d)``; "columns" are the transposed ``(d, M)`` copies on
which per-axis gathers are contiguous.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, fail
from .weights import ForceNodeSums, ForcePoints, cluster_sums, row_norms

__all__ = [
    "assign_nearest",
    "expansion_tolerance",
    "exact_nearest",
    "point_node_distances",
    "NearestNodeAssigner",
    "NumpyEMSteps",
]

Array = NDArray[np.float64]


def assign_nearest(points: ArrayLike, nodes: ArrayLike) -> NDArray[np.intp]:
    """Index of the nearest node for every point: points (M, d), nodes (N, d), finite -> (M,); ties to
    the lowest index.

    ``‖x − y‖² = ‖x‖² − 2x·y + ‖y‖²`` and ``‖x‖²`` is the same for every node of a row, so one matrix
    product (M, N) on centred coordinates and an argmin give the assignment. The expansion rounds
    differently from summing squared differences, so rows whose two nearest nodes are within its
    rounding error are decided again by :func:`exact_nearest` (the compiled E-step's arithmetic).
    """
    points = check_array("points", points, ndim=2, min_len=1, axes=("row", "axis"))
    if points.shape[1] < 1:
        fail("points", f"have at least 1 coordinate, got shape {points.shape}")
    nodes = check_array("nodes", nodes, shape=(None, points.shape[1]), min_len=1, axes=("row", "axis"))
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
