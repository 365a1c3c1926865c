"""User constraints on elastic-map nodes.

Equalities (start, end, via points) are *eliminated* from the banded M-step, which keeps the O(N)
fast path. Inequalities (workspace box, half-spaces, step-length bound, and the force-limit
half-spaces built inside the EM loop) send the M-step to Clarabel with the same objective.
:func:`resolve_constraints` checks a :class:`Constraints` once and maps it onto node indices; sets that
are infeasible on their face (a node fixed twice, a fixed node outside the box) are refused there,
the rest is left to the solver.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from .._validation import check_array, check_finite, check_int, check_real, fail, is_int

__all__ = ["Constraints", "ResolvedConstraints", "resolve_constraints"]

Array = NDArray[np.float64]

#: how far (in the positions' units) a fixed node may lie outside a box or half-space before the set
#: counts as infeasible
FIXED_SLACK = 1e-12


@dataclass(frozen=True)
class Constraints:
    """Constraints on the nodes ``y (N, d)`` of an elastic map, in the positions' units.

    start, end:  ``(d,)`` points the first / last node must equal.
    via:         ``(key, point)`` pairs. ``key`` an ``int`` is a node index (negative counts from the
                 end); a ``float`` in [0, 1] is a fraction of the first demo's duration, mapped to the
                 node at the same arc-length fraction of the initial map (the first demo resampled by
                 arc length), so ``0.5`` means "where the demonstrator was half-way through in time".
    box:         ``(lo (d,), hi (d,))``: every node inside; ``±inf`` entries are unbounded.
    halfspaces:  ``(normal (d,), offset)`` pairs meaning ``normal · y_i <= offset`` for every node i.
    max_step:    upper bound > 0 on ``||y_{i+1} - y_i||`` (a second-order cone per edge).
    """

    start: ArrayLike | None = None
    end: ArrayLike | None = None
    via: Sequence[tuple[int | float, ArrayLike]] = ()
    box: tuple[ArrayLike, ArrayLike] | None = None
    halfspaces: Sequence[tuple[ArrayLike, float]] = ()
    max_step: float | None = None

    @property
    def has_inequalities(self) -> bool:
        return self.box is not None or len(self.halfspaces) > 0 or self.max_step is not None


@dataclass(frozen=True)
class ResolvedConstraints:
    """Constraints mapped onto node indices and checked against ``(N, d)``.

    fixed_index (K,) sorted unique node indices; fixed_value (K, d).
    box_lo / box_hi (d,) or None; halfspace_normals (H, d), halfspace_offsets (H,); max_step or None.
    """

    n_nodes: int
    dim: int
    fixed_index: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    fixed_value: Array = field(default_factory=lambda: np.zeros((0, 0)))
    box_lo: Array | None = None
    box_hi: Array | None = None
    halfspace_normals: Array = field(default_factory=lambda: np.zeros((0, 0)))
    halfspace_offsets: Array = field(default_factory=lambda: np.zeros(0))
    max_step: float | None = None

    @property
    def has_inequalities(self) -> bool:
        return self.box_lo is not None or len(self.halfspace_offsets) > 0 or self.max_step is not None

    @property
    def is_empty(self) -> bool:
        """No user constraint at all (the force-limit rows are not part of this set)."""
        return not (len(self.fixed_index) or self.has_inequalities)


def resolve_constraints(
    constraints: Constraints | None,
    n_nodes: int,
    dim: int,
    time_fraction_to_node: Callable[[float], int] | None = None,
) -> ResolvedConstraints:
    """Check ``constraints`` for a map of ``n_nodes`` nodes in ``dim`` dimensions and map them to node
    indices.

    ``time_fraction_to_node(frac) -> int`` maps a via key given as a float time fraction to a node.
    Raises ``ValueError`` naming the field (``"constraints.via[2]"``) for a malformed entry and for sets
    that are infeasible on their face: one node fixed to two points, a fixed node outside the box or
    a half-space.
    """
    n_nodes = check_int("n_nodes", n_nodes, low=1)
    dim = check_int("dim", dim, low=1)
    if constraints is None:
        return ResolvedConstraints(
            n_nodes, dim, fixed_value=np.zeros((0, dim)), halfspace_normals=np.zeros((0, dim))
        )
    if not isinstance(constraints, Constraints):
        fail("constraints", f"be a Constraints instance or None, got {type(constraints).__name__}")
    fixed_index, fixed_value = _fixed_nodes(constraints, n_nodes, dim, time_fraction_to_node)
    box_lo, box_hi = _box(constraints.box, dim, fixed_index, fixed_value)
    normals, offsets = _halfspaces(constraints.halfspaces, dim, fixed_index, fixed_value)
    return ResolvedConstraints(
        n_nodes=n_nodes,
        dim=dim,
        fixed_index=fixed_index,
        fixed_value=fixed_value,
        box_lo=box_lo,
        box_hi=box_hi,
        halfspace_normals=normals,
        halfspace_offsets=offsets,
        max_step=check_real(
            "constraints.max_step", constraints.max_step, low=0.0, low_open=True, none_ok=True
        ),
    )


def _point(name: str, value: object, dim: int) -> Array:
    """``value`` as a finite point (d,)."""
    p = check_array(name, value, finite=False).reshape(-1)
    if p.shape != (dim,):
        fail(name, f"be a point of {dim} coordinates, got shape {np.shape(value)}")
    return check_finite(name, p, axes=("axis",))


def _pair(name: str, item: object, what: str) -> tuple[object, object]:
    """A 2-item entry of a constraint list (``what`` names its parts for the message)."""
    try:
        first, second = item
    except (TypeError, ValueError):
        fail(name, f"be a ({what}) pair", item)
    return first, second


def _fixed_nodes(
    constraints: Constraints, n_nodes: int, dim: int, to_node: Callable[[float], int] | None
) -> tuple[NDArray[np.intp], Array]:
    """The equality constraints as (sorted node indices (K,), points (K, d))."""
    fixed: dict[int, Array] = {}

    def add(index: int, name: str, value: object) -> None:
        point = _point(name, value, dim)
        if index in fixed and not np.allclose(fixed[index], point, rtol=0, atol=FIXED_SLACK):
            fail(
                name,
                f"not fix node {index} to a second point (it is already fixed to {fixed[index].tolist()}: "
                "the equality constraints are infeasible)",
                point.tolist(),
            )
        fixed[index] = point

    if constraints.start is not None:
        add(0, "constraints.start", constraints.start)
    if constraints.end is not None:
        add(n_nodes - 1, "constraints.end", constraints.end)
    for k, item in enumerate(constraints.via):
        name = f"constraints.via[{k}]"
        key, value = _pair(name, item, "node index or time fraction, point")
        add(_via_node(name, key, n_nodes, to_node), name, value)
    order = sorted(fixed)
    return np.asarray(order, dtype=np.intp), np.array([fixed[i] for i in order]).reshape(len(order), dim)


def _via_node(name: str, key: object, n_nodes: int, to_node: Callable[[float], int] | None) -> int:
    """The node a via key names: an int index (negative from the end) or a float time fraction."""
    if is_int(key):
        if not -n_nodes <= int(key) < n_nodes:
            fail(name, f"have a node index in [-{n_nodes}, {n_nodes})", int(key))
        return int(key) % n_nodes
    if not isinstance(key, float | np.floating):
        fail(name, "have an int node index or a float time fraction as its key", key)
    frac = check_real(name, key, low=0.0, high=1.0)
    if to_node is None:
        fail(name, "have an int node index without demo times (a time fraction needs them)", key)
    return int(to_node(frac))


def _box(
    box: object, dim: int, fixed_index: NDArray[np.intp], fixed_value: Array
) -> tuple[Array | None, Array | None]:
    """The box as (lo (d,), hi (d,)) or (None, None)."""
    if box is None:
        return None, None
    lo, hi = _pair("constraints.box", box, "lo, hi")
    lo, hi = (_bound(f"constraints.box.{which}", v, dim) for which, v in (("lo", lo), ("hi", hi)))
    empty = (lo == np.inf) | (hi == -np.inf) | (lo > hi)
    if empty.any():
        i = int(np.argmax(empty))
        fail(
            "constraints.box",
            f"leave room on every axis (lo <= hi, lo < inf, hi > -inf), got lo[{i}]={lo[i]}, hi[{i}]={hi[i]}",
        )
    outside = (fixed_value < lo - FIXED_SLACK) | (fixed_value > hi + FIXED_SLACK)
    if outside.any():
        row = int(np.argmax(outside.any(axis=1)))
        fail(
            "constraints.box",
            f"contain the fixed node {int(fixed_index[row])} (the constraints are infeasible)",
            fixed_value[row].tolist(),
        )
    return lo, hi


def _bound(name: str, value: object, dim: int) -> Array:
    """One corner of the box: (d,) numbers, ±inf allowed, NaN not."""
    v = check_array(name, value, finite=False).reshape(-1)
    if v.shape != (dim,):
        fail(name, f"hold {dim} bounds, got shape {np.shape(value)}")
    if np.isnan(v).any():
        fail(name, "hold numbers or ±inf, not NaN", v.tolist())
    return v


def _halfspaces(
    halfspaces: Sequence[object], dim: int, fixed_index: NDArray[np.intp], fixed_value: Array
) -> tuple[Array, Array]:
    """The half-spaces as (normals (H, d), offsets (H,))."""
    normals = np.zeros((len(halfspaces), dim))
    offsets = np.zeros(len(halfspaces))
    for k, item in enumerate(halfspaces):
        normal, offset = _pair(f"constraints.halfspaces[{k}]", item, "normal, offset")
        normals[k] = _point(f"constraints.halfspaces[{k}].normal", normal, dim)
        offsets[k] = check_real(f"constraints.halfspaces[{k}].offset", offset)
        if np.linalg.norm(normals[k]) == 0:
            fail(f"constraints.halfspaces[{k}].normal", "be non-zero", normals[k].tolist())
    if len(offsets) and len(fixed_index):
        violation = fixed_value @ normals.T - offsets[None, :]
        if np.any(violation > FIXED_SLACK):
            r, c = np.unravel_index(int(np.argmax(violation)), violation.shape)
            fail(
                f"constraints.halfspaces[{c}]",
                f"hold at the fixed node {int(fixed_index[r])} (the constraints are infeasible), got a "
                f"violation of {violation[r, c]:.3g}",
            )
    return normals, offsets
