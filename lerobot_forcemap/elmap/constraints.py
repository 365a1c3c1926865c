"""User constraints on elastic-map nodes (SPEC §1 "Constraints").

Equalities (start, end, via points) are *eliminated* from the banded M-step, which keeps the
O(N) fast path. Inequalities (workspace box, half-spaces, step-length bound, and the force-limit
half-spaces built inside the EM loop) send the M-step to Clarabel with the same objective.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["Constraints", "ResolvedConstraints", "resolve_constraints"]


@dataclass(frozen=True)
class Constraints:
    """Constraints on the nodes ``y (N, d)`` of an elastic map.

    start, end:  ``(d,)`` points the first / last node must equal.
    via:         ``(key, point)`` pairs. ``key`` an ``int`` is a node index (negative counts from the
                 end); a ``float`` in [0, 1] is a fraction of the first demo's duration, mapped to the
                 node at the same arc-length fraction of the initial map (the first demo resampled by
                 arc length), so ``0.5`` means "where the demonstrator was half-way through in time".
    box:         ``(lo (d,), hi (d,))``: every node inside; ``±inf`` entries are unbounded.
    halfspaces:  ``(normal (d,), offset)`` pairs meaning ``normal · y_i <= offset`` for every node i.
    max_step:    upper bound on ``||y_{i+1} - y_i||`` (a second-order cone per edge).
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
    """Constraints mapped onto node indices and validated against ``(N, d)``.

    fixed_index (K,) sorted unique node indices; fixed_value (K, d).
    box_lo / box_hi (d,) or None; halfspace_normals (H, d), halfspace_offsets (H,); max_step or None.
    """

    n_nodes: int
    dim: int
    fixed_index: NDArray[np.intp] = field(default_factory=lambda: np.zeros(0, dtype=np.intp))
    fixed_value: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    box_lo: NDArray[np.float64] | None = None
    box_hi: NDArray[np.float64] | None = None
    halfspace_normals: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 0)))
    halfspace_offsets: NDArray[np.float64] = field(default_factory=lambda: np.zeros(0))
    max_step: float | None = None

    @property
    def has_inequalities(self) -> bool:
        return self.box_lo is not None or len(self.halfspace_offsets) > 0 or self.max_step is not None


def _numbers(value: ArrayLike, what: str) -> NDArray[np.float64]:
    try:
        return np.asarray(value, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise ValueError(f"constraints.{what}: expected numbers, got {value!r}") from None


def _point(value: ArrayLike, dim: int, what: str) -> NDArray[np.float64]:
    p = _numbers(value, what)
    if p.shape != (dim,):
        raise ValueError(f"constraints.{what}: expected a point of shape ({dim},), got {np.shape(value)}")
    if not np.all(np.isfinite(p)):
        raise ValueError(f"constraints.{what}: non-finite value {p.tolist()}")
    return p


def resolve_constraints(
    constraints: Constraints | None,
    n_nodes: int,
    dim: int,
    time_fraction_to_node: callable | None = None,
) -> ResolvedConstraints:
    """Validate ``constraints`` and map them to node indices.

    ``time_fraction_to_node(frac) -> int`` maps a via key given as a float time fraction to a node.
    Conflicting equalities on the same node raise ``ValueError`` (an infeasible set).
    """
    if constraints is None:
        return ResolvedConstraints(
            n_nodes, dim, fixed_value=np.zeros((0, dim)), halfspace_normals=np.zeros((0, dim))
        )
    if not isinstance(constraints, Constraints):
        raise ValueError(f"constraints: expected a Constraints instance, got {type(constraints).__name__}")

    fixed: dict[int, NDArray[np.float64]] = {}

    def add_fixed(index: int, value: NDArray[np.float64], what: str) -> None:
        if index in fixed and not np.allclose(fixed[index], value, rtol=0, atol=1e-12):
            raise ValueError(
                f"constraints.{what}: node {index} is already fixed to {fixed[index].tolist()}; "
                f"the equality constraints are infeasible"
            )
        fixed[index] = value

    if constraints.start is not None:
        add_fixed(0, _point(constraints.start, dim, "start"), "start")
    if constraints.end is not None:
        add_fixed(n_nodes - 1, _point(constraints.end, dim, "end"), "end")
    for k, item in enumerate(constraints.via):
        try:
            key, value = item
        except (TypeError, ValueError):
            raise ValueError(
                f"constraints.via[{k}]: expected a (node_index_or_time_fraction, point) pair"
            ) from None
        if isinstance(key, bool):
            raise ValueError(f"constraints.via[{k}]: key must be an int node index or a float time fraction")
        if isinstance(key, (int, np.integer)):
            index = int(key)
            if not -n_nodes <= index < n_nodes:
                raise ValueError(f"constraints.via[{k}]: node index {index} out of range for {n_nodes} nodes")
            index %= n_nodes
        elif isinstance(key, (float, np.floating)):
            if not 0.0 <= float(key) <= 1.0:
                raise ValueError(f"constraints.via[{k}]: time fraction {key} outside [0, 1]")
            if time_fraction_to_node is None:
                raise ValueError(f"constraints.via[{k}]: time fractions need demo times")
            index = int(time_fraction_to_node(float(key)))
        else:
            raise ValueError(f"constraints.via[{k}]: key must be an int node index or a float time fraction")
        add_fixed(index, _point(value, dim, f"via[{k}]"), f"via[{k}]")

    order = sorted(fixed)
    fixed_index = np.asarray(order, dtype=np.intp)
    fixed_value = np.array([fixed[i] for i in order]).reshape(len(order), dim)

    box_lo = box_hi = None
    if constraints.box is not None:
        try:
            lo, hi = constraints.box
        except (TypeError, ValueError):
            raise ValueError("constraints.box: expected a (lo, hi) pair") from None
        box_lo, box_hi = _numbers(lo, "box lo"), _numbers(hi, "box hi")
        if box_lo.shape != (dim,) or box_hi.shape != (dim,):
            raise ValueError(
                f"constraints.box: lo and hi must have shape ({dim},), got {box_lo.shape}, {box_hi.shape}"
            )
        if np.any(np.isnan(box_lo)) or np.any(np.isnan(box_hi)):
            raise ValueError("constraints.box: NaN bound")
        if np.any(box_lo == np.inf) or np.any(box_hi == -np.inf):
            bad = int(np.argmax((box_lo == np.inf) | (box_hi == -np.inf)))
            raise ValueError(
                f"constraints.box: lo[{bad}]={box_lo[bad]}, hi[{bad}]={box_hi[bad]} leave no room; infeasible"
            )
        if np.any(box_lo > box_hi):
            bad = int(np.argmax(box_lo > box_hi))
            raise ValueError(
                f"constraints.box: lo[{bad}]={box_lo[bad]} > hi[{bad}]={box_hi[bad]}; infeasible"
            )
        outside = (fixed_value < box_lo - 1e-12) | (fixed_value > box_hi + 1e-12)
        if outside.any():
            row = int(np.argmax(outside.any(axis=1)))
            raise ValueError(
                f"constraints.box: fixed node {int(fixed_index[row])} at {fixed_value[row].tolist()} lies outside the box; infeasible"
            )

    normals = np.zeros((len(constraints.halfspaces), dim))
    offsets = np.zeros(len(constraints.halfspaces))
    for k, item in enumerate(constraints.halfspaces):
        try:
            normal, offset = item
        except (TypeError, ValueError):
            raise ValueError(f"constraints.halfspaces[{k}]: expected a (normal, offset) pair") from None
        normals[k] = _point(normal, dim, f"halfspaces[{k}].normal")
        try:
            offset = float(offset)
        except (TypeError, ValueError):
            raise ValueError(
                f"constraints.halfspaces[{k}]: offset must be a number, got {offset!r}"
            ) from None
        if not np.isfinite(offset):
            raise ValueError(f"constraints.halfspaces[{k}]: non-finite offset {offset}")
        if np.linalg.norm(normals[k]) == 0:
            raise ValueError(f"constraints.halfspaces[{k}]: zero normal")
        offsets[k] = float(offset)
    if len(offsets) and len(fixed_index):
        viol = fixed_value @ normals.T - offsets[None, :]
        if np.any(viol > 1e-12):
            r, c = np.unravel_index(int(np.argmax(viol)), viol.shape)
            raise ValueError(
                f"constraints.halfspaces[{c}]: fixed node {int(fixed_index[r])} violates it by {viol[r, c]:.3g}; infeasible"
            )

    max_step = constraints.max_step
    if max_step is not None:
        try:
            max_step = float(max_step)
        except (TypeError, ValueError):
            raise ValueError(f"constraints.max_step: expected a number > 0, got {max_step!r}") from None
        if not (np.isfinite(max_step) and max_step > 0):
            raise ValueError(
                f"constraints.max_step: must be a positive finite length, got {constraints.max_step}"
            )

    return ResolvedConstraints(
        n_nodes=n_nodes,
        dim=dim,
        fixed_index=fixed_index,
        fixed_value=fixed_value,
        box_lo=box_lo,
        box_hi=box_hi,
        halfspace_normals=normals,
        halfspace_offsets=offsets,
        max_step=max_step,
    )
