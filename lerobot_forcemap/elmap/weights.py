"""Force points and their per-axis weights.

For every sample whose force norm exceeds ``f_contact`` a force point ``p_j = x_j − δ·f̂_j`` is
added just behind the contact surface (forces are the reaction on the robot, pointing away from
the surface). Its per-axis weight is

    w_jq = −|f_jq| / (k · Δ_j),      Δ_j = max(‖p_j − y_a(j)‖, δ),

recomputed every EM iteration from the node ``y_a(j)`` the source sample is assigned to. The
negative weight pushes that node away from the surface. With ``k`` (stiffness, N/m) the push is
Hooke's law: for a cluster of contact samples all pressing with force F along one axis the fixed
point of this update lifts the node by exactly ``F / k`` (as long as the cap below does not bind).

Well-posedness: ignoring smoothness a node sits at ``x̄ + r/(1−r)·(x̄ − p̄)`` with
``r = Σ|w_force| / Σ w_demo`` over its cluster — unbounded as r → 1 and pulled *into* the surface for
r > 1. We cap r at ``rho_max`` per node and axis by scaling that node's force weights, and report it.

The functions here are the fit's building blocks and trust their inputs (the fit checked them);
:func:`project_on_contact_normal`, a preprocessing step users call themselves, checks its own.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, fail

__all__ = [
    "ForcePoints",
    "ForceWeights",
    "make_force_points",
    "force_point_weights",
    "ForceNodeSums",
    "cluster_sums",
    "row_norms",
    "project_on_contact_normal",
]

Array = NDArray[np.float64]


def row_norms(a: Array) -> Array:
    """Euclidean norm of every row of ``a (M, d)``; faster than ``np.linalg.norm(a, axis=1)`` for small d."""
    return np.sqrt(np.einsum("ij,ij->i", a, a))


@dataclass(frozen=True)
class ForcePoints:
    """Force points of the stacked demo samples.

    source (K,) index of the source sample in the stacked data; points (K, d) = x − δ·f̂;
    magnitude (K, d) = |f| per axis; direction (K, d) = f̂; norm (K,) = ‖f‖.
    """

    source: NDArray[np.intp]
    points: Array
    magnitude: Array
    direction: Array
    norm: Array

    def __len__(self) -> int:
        return len(self.source)


@dataclass(frozen=True)
class ForceWeights:
    """Per-iteration force-point weights: weights (K, d) (<= 0); capped (N, d) mask of capped node axes;
    ratio (N, d) = r before capping (0 where a node has no force point)."""

    weights: Array
    capped: NDArray[np.bool_]
    ratio: Array


def make_force_points(x: Array, f: Array, delta: float, f_contact: float) -> ForcePoints:
    """Force points for samples ``x, f (M, d)`` with ``‖f‖ > f_contact``; none when ``delta == 0``."""
    d = x.shape[1]
    norm = row_norms(f)
    if delta == 0.0:
        sel = np.zeros(len(x), dtype=bool)
    else:
        sel = norm > max(f_contact, 0.0)
        sel &= norm > 0.0
    src = np.flatnonzero(sel)
    direction = f[src] / norm[src, None] if len(src) else np.zeros((0, d))
    return ForcePoints(
        source=src,
        points=x[src] - delta * direction,
        magnitude=np.abs(f[src]),
        direction=direction,
        norm=norm[src],
    )


def cluster_sums(
    labels: NDArray[np.intp], w: Array | None, values: Array, n_nodes: int
) -> tuple[Array, Array]:
    """``W_i = Σ_{j∈κ_i} w_j`` and ``b_i = Σ_{j∈κ_i} w_j ⊙ ζ_j`` (each (N, d)); ``w=None`` means unit weights.

    One ``bincount`` per axis (d is small; the samples are never looped over in Python).
    """
    d = values.shape[1]
    W = np.empty((n_nodes, d))
    b = np.empty((n_nodes, d))
    # bincount wants contiguous weights: one (d, M) copy beats d strided column reads
    if w is None:
        W[:] = np.bincount(labels, minlength=n_nodes)[:, None]
        columns = np.ascontiguousarray(values.T)
    else:
        W[:] = np.stack(
            [np.bincount(labels, weights=c, minlength=n_nodes) for c in np.ascontiguousarray(w.T)], 1
        )
        columns = np.ascontiguousarray((w * values).T)
    for q in range(d):
        b[:, q] = np.bincount(labels, weights=columns[q], minlength=n_nodes)
    return W, b


def _cap(
    push: Array, demo_weight_sum: Array, rho_max: float | None
) -> tuple[Array, NDArray[np.bool_], Array]:
    """The rho_max cap per node and axis: (scale (N, d) for the force weights, capped mask, ratio r).

    A force point's source sample sits in its node's cluster, so a node with a push has demo weight
    > 0; the floor on the denominator only keeps 0/0 at 0.
    """
    ratio = push / np.maximum(demo_weight_sum, 1e-300)
    if rho_max is None:
        return np.ones_like(ratio), np.zeros(ratio.shape, dtype=bool), ratio
    # rho/max(r, rho) is exactly 1 where r <= rho and rho/r where the cap binds
    return rho_max / np.maximum(ratio, rho_max), ratio > rho_max, ratio


def force_point_weights(
    fp: ForcePoints,
    tied_node: NDArray[np.intp],
    nodes: Array,
    demo_weight_sum: Array,
    *,
    delta: float,
    stiffness: float,
    rho_max: float | None,
    spring_length: Array | None = None,
) -> ForceWeights:
    """Weights of the force points for the current nodes.

    tied_node (K,): node of each force point (its source sample's cluster); nodes (N, d);
    demo_weight_sum (N, d): Σ w_demo per node and axis. ``rho_max=None`` disables the cap (ablation).
    spring_length (K,): Δ_j when the caller relaxes it; default ``max(‖p_j − y_a(j)‖, δ)``.
    """
    n, d = nodes.shape
    if spring_length is None:
        spring = np.maximum(row_norms(fp.points - nodes[tied_node]), delta)
    else:
        spring = np.maximum(spring_length, delta)
    w = -fp.magnitude / (stiffness * spring[:, None])
    push = np.stack([np.bincount(tied_node, weights=-w[:, q], minlength=n) for q in range(d)], axis=1)
    scale, capped, ratio = _cap(push, demo_weight_sum, rho_max)
    return ForceWeights(w * scale[tied_node], capped, ratio)


class ForceNodeSums:
    """The force points' cluster sums straight from the spring lengths, for the EM loop.

    Equal to ``cluster_sums(tied, force_point_weights(...).weights, fp.points, N)`` (tested), but the
    per-point weights are never formed: every point's weight on axis q is ``−|f_q|/(k·Δ)`` and the
    cap scales whole node axes, so ``W_f = −scale ⊙ Σ |f|/(kΔ)`` and ``b_f = −scale ⊙ Σ |f| p/(kΔ)``
    come from one ``bincount`` over the (K, 2d) ``moments = [|f|, |f|⊙p]`` divided by ``kΔ``
    (:meth:`raw`; the compiled loops of :mod:`.kernel` fill the same (N, 2d) sums), then the cap
    (:meth:`finish`). The ``bincount`` index is rebuilt only when the assignment changes.
    """

    def __init__(self, fp: ForcePoints, n_nodes: int, stiffness: float, rho_max: float | None) -> None:
        self.n, self.d = n_nodes, fp.points.shape[1]
        self.stiffness, self.rho_max = stiffness, rho_max
        self.moments = np.hstack([fp.magnitude, fp.magnitude * fp.points])  # (K, 2d)
        self._tied: NDArray[np.intp] | None = None
        self._flat: NDArray[np.intp] | None = None

    def raw(self, tied_node: NDArray[np.intp], spring_length: Array) -> Array:
        """Per-node sums (N, 2d) of ``moments / (k·Δ)`` for tied_node (K,) and spring lengths Δ (K,)."""
        n, d = self.n, self.d
        if self._tied is None or not np.array_equal(tied_node, self._tied):
            self._tied = tied_node
            self._flat = (tied_node[:, None] * (2 * d) + np.arange(2 * d)).ravel()
        inv = 1.0 / (self.stiffness * spring_length)
        sums = np.bincount(self._flat, weights=(self.moments * inv[:, None]).ravel(), minlength=n * 2 * d)
        return sums.reshape(n, 2 * d)

    def finish(self, sums: Array, demo_weight_sum: Array) -> tuple[Array, Array, NDArray[np.bool_]]:
        """W_f, b_f (N, d) and the capped mask (N, d) from the raw sums (N, 2d)."""
        d = self.d
        scale, capped, _ = _cap(sums[:, :d], demo_weight_sum, self.rho_max)
        return -scale * sums[:, :d], -scale * sums[:, d:], capped

    def __call__(
        self, tied_node: NDArray[np.intp], spring_length: Array, demo_weight_sum: Array
    ) -> tuple[Array, Array, NDArray[np.bool_]]:
        """W_f, b_f (N, d) and the capped mask (N, d) for tied_node (K,) and spring lengths Δ (K,) >= δ."""
        return self.finish(self.raw(tied_node, spring_length), demo_weight_sum)


def project_on_contact_normal(forces: ArrayLike, normal: ArrayLike) -> Array:
    """The size of each force's component along a known contact normal, as a reaction along ``+normal``.

    forces (T, d) finite, normal (d,) pointing away from the surface (any non-zero length) -> (T, d).
    For recordings whose sensor also sees other forces (a kinesthetic teacher's hand on the tool,
    drag): it keeps what a sensor between the contact and the arm would report along the normal,
    pointing away from the surface as the force points assume, and drops the tangential part.
    """
    n = check_array("normal", normal, ndim=1, min_len=1, axes=("axis",))
    forces = check_array("forces", forces, shape=(None, len(n)), axes=("frame", "axis"))
    norm = np.linalg.norm(n)
    if norm == 0 or not np.isfinite(norm):
        fail("normal", "be a non-zero vector of finite length", n.tolist())
    n = n / norm
    return np.abs(forces @ n)[:, None] * n[None, :]
