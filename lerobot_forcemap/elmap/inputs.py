"""The inputs of :func:`~.fit.fit_force_elastic_map`, checked once and stacked for the EM.

:func:`check_fit_params` checks the scalar settings, :func:`stack_demos` the per-demo arrays (positions,
forces, weights, times, orientations) and stacks them into one :class:`DemoData`. Errors name the
argument and, for arrays, the demo, frame and axis (``"positions[1]: must hold finite values only (the
first bad one is at frame 12, axis 2), got nan"``).

The bounds below keep every intermediate of the EM inside float64: squared distances of coordinates,
squared cluster weights, the mean of the demos' durations. They are far outside any physical unit
system (metres, millimetres, newtons), so a value beyond them is a units mistake.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from .._validation import (
    check_array,
    check_choice,
    check_finite,
    check_int,
    check_real,
    fail,
    first_bad_index,
    is_real,
)
from .weights import row_norms

__all__ = [
    "MAX_COORDINATE",
    "MIN_EXTENT",
    "WEIGHT_RANGE",
    "MAX_NODES",
    "SOLVERS",
    "FitParams",
    "DemoData",
    "check_fit_params",
    "stack_demos",
]

Array = NDArray[np.float64]

#: largest |coordinate| (and δ) accepted: squared distances of 1e300 stay finite in float64
MAX_COORDINATE = 1e150
#: smallest non-zero extent of the data accepted: squared distances of 1e-200 stay normal floats
MIN_EXTENT = 1e-100
#: accepted range of demo weights: the M-step squares the cluster weights, which must stay normal floats
WEIGHT_RANGE = (1e-100, 1e100)
#: most nodes a map may have: the E-step keeps the N×N node distances (8·N² bytes, 0.8 GB at the maximum)
MAX_NODES = 10_000
#: the M-step solvers ``solver`` may name
SOLVERS = ("auto", "banded", "clarabel")
#: smallest quaternion norm accepted in ``orientations`` (a zero quaternion has no rotation)
MIN_QUATERNION_NORM = 1e-9


@dataclass(frozen=True)
class FitParams:
    """The scalar settings of one fit, checked (see :func:`~.fit.fit_force_elastic_map` for meanings)."""

    n_nodes: int
    lam: float
    mu: float
    delta: float
    f_contact: float
    stiffness: float
    rho_max: float | None
    force_limit: float | None
    max_iter: int
    tol: float
    xtol: float
    spring_relaxation: float | str
    solver: str


def check_fit_params(
    *,
    n_nodes: object,
    lam: object,
    mu: object,
    delta: object,
    f_contact: object,
    stiffness: object,
    rho_max: object,
    force_limit: object,
    max_iter: object,
    tol: object,
    xtol: object,
    spring_relaxation: object,
    solver: object,
    has_forces: bool,
) -> FitParams:
    """The scalar arguments of the fit as a :class:`FitParams`; ``ValueError`` naming the first bad one."""
    if force_limit is not None and not has_forces:
        fail("force_limit", "be None when forces is None (it limits the demonstrated force)", force_limit)
    if not (isinstance(spring_relaxation, str) and spring_relaxation == "auto"):
        if not is_real(spring_relaxation) or not 0.0 < float(spring_relaxation) <= 1.0:
            fail("spring_relaxation", "be 'auto' or a number > 0 and <= 1", spring_relaxation)
        spring_relaxation = float(spring_relaxation)
    return FitParams(
        n_nodes=check_int("n_nodes", n_nodes, low=3, high=MAX_NODES),
        lam=check_real("lam", lam, low=0.0),
        mu=check_real("mu", mu, low=0.0),
        delta=check_real("delta", delta, low=0.0, high=MAX_COORDINATE, unit="m"),
        f_contact=check_real("f_contact", f_contact, low=0.0, unit="N"),
        stiffness=check_real("stiffness", stiffness, low=0.0, low_open=True, unit="N/m"),
        rho_max=check_real(
            "rho_max", rho_max, low=0.0, high=1.0, low_open=True, high_open=True, none_ok=True
        ),
        force_limit=check_real("force_limit", force_limit, low=0.0, low_open=True, none_ok=True, unit="N"),
        max_iter=check_int("max_iter", max_iter, low=1),
        tol=check_real("tol", tol, low=0.0),
        xtol=check_real("xtol", xtol, low=0.0),
        spring_relaxation=spring_relaxation,
        solver=check_choice("solver", solver, SOLVERS),
    )


@dataclass(frozen=True)
class DemoData:
    """The demos of one fit, stacked: M samples in all, d axes.

    x (M, d) positions; f (M, d) forces or None; w (M, d) demo weights (ones when none were given) and
    demo_w the same or None for unit weights (the EM's cheaper path); first (T_0, d) the first demo
    (the initial map); norm_times per demo (T_k,) in [0, 1] and u (M,) all of them stacked; duration
    (s, or samples without ``times``) the mean demo duration; quats per demo (T_k, 4) or None;
    S the approximation-energy normaliser; extent the largest per-axis range of x; step_scale the unit
    of the stop test (extent, or for data at rest its largest magnitude, at least 1).
    """

    x: Array
    f: Array | None
    w: Array
    demo_w: Array | None
    first: Array
    norm_times: list[Array]
    u: Array
    duration: float
    quats: list[Array] | None
    S: float
    extent: float
    step_scale: float

    @property
    def dim(self) -> int:
        return self.x.shape[1]


def stack_demos(
    positions: object, forces: object, times: object, orientations: object, weights: object
) -> DemoData:
    """Check the per-demo arrays of a fit against each other and stack them (see :class:`DemoData`)."""
    demos = _positions(positions)
    lengths = [len(a) for a in demos]
    dim = demos[0].shape[1]
    force_list = None if forces is None else _forces(forces, lengths, dim)
    weight_list = None if weights is None else _weights(weights, lengths, dim)
    time_list = None if times is None else _times(times, lengths)
    quats = None if orientations is None else _orientations(orientations, lengths)

    x = np.concatenate(demos, axis=0)
    w = np.concatenate(weight_list, axis=0) if weight_list is not None else np.ones((len(x), dim))
    if time_list is None:
        time_list = [np.arange(n, dtype=float) for n in lengths]
        duration = float(np.mean(lengths) - 1)
    else:
        with np.errstate(over="ignore"):  # refused below
            duration = float(np.mean([t[-1] - t[0] for t in time_list]))
        if not np.isfinite(duration):
            fail("times", "have a mean demo duration within float64's range (choose other units)", duration)
    norm_times = [(t - t[0]) / (t[-1] - t[0]) for t in time_list]
    # (d, M) copy: reductions along contiguous rows are many times faster than along axis 0 of (M, d)
    extent = float(np.max(np.ptp(np.ascontiguousarray(x.T), axis=1)))
    if 0.0 < extent < MIN_EXTENT:
        fail(
            "positions",
            f"span at least {MIN_EXTENT:g} (or not move at all): below it squared distances underflow "
            "float64 (choose other units)",
            extent,
        )
    return DemoData(
        x=x,
        f=np.concatenate(force_list, axis=0) if force_list is not None else None,
        w=w,
        demo_w=None if weights is None else w,
        first=demos[0],
        norm_times=norm_times,
        u=np.concatenate(norm_times),
        duration=duration,
        quats=quats,
        S=len(x) * float(np.sqrt(dim)) if weights is None else float(np.sum(row_norms(w))),
        extent=extent,
        # data at rest (a gripper held open) has no extent, and xtol·1e-12 is below float64's
        # resolution of the nodes: its stop test counts in units of the data's magnitude instead
        step_scale=extent if extent > 0.0 else max(float(np.max(np.abs(x))), 1.0),
    )


# ----------------------------------------------------------------------------------------------
# one argument each


def _positions(positions: object) -> list[Array]:
    demos = _demo_list(positions, "positions")
    dim = demos[0].shape[1]
    for k, a in enumerate(demos):
        where = f"positions[{k}]"
        if a.shape[1] < 1:
            fail(where, f"have at least 1 coordinate per sample, got shape {a.shape}")
        if a.shape[1] != dim:
            fail(where, f"have the {dim} coordinates of positions[0], got shape {a.shape}")
        if a.shape[0] < 2:
            fail(where, f"hold at least 2 samples, got shape {a.shape}")
        _check_entries(
            where,
            a,
            np.abs(a) <= MAX_COORDINATE,
            f"hold |coordinates| <= {MAX_COORDINATE:g}",
            "above it squared distances overflow float64: choose other units",
        )
    return demos


def _forces(forces: object, lengths: list[int], dim: int) -> list[Array]:
    arrays = _matching(forces, "forces", lengths, dim)
    for k, a in enumerate(arrays):
        _check_entries(
            f"forces[{k}]",
            a,
            np.abs(a) <= MAX_COORDINATE,
            f"hold |values| <= {MAX_COORDINATE:g}",
            "choose other units",
        )
    return arrays


def _weights(weights: object, lengths: list[int], dim: int) -> list[Array]:
    arrays = _demo_list(weights, "weights")
    arrays = [np.repeat(a, dim, axis=1) if a.shape[1] == 1 and dim > 1 else a for a in arrays]
    arrays = _matching(arrays, "weights", lengths, dim)
    low, high = WEIGHT_RANGE
    for k, a in enumerate(arrays):
        _check_entries(f"weights[{k}]", a, a > 0, "be > 0")
        _check_entries(
            f"weights[{k}]",
            a,
            (a >= low) & (a <= high),
            f"lie in [{low:g}, {high:g}]",
            "squared cluster weights must stay in float64's range: rescale them",
        )
    return arrays


def _times(times: object, lengths: list[int]) -> list[Array]:
    out = []
    for k, a in enumerate(_matching(times, "times", lengths, 1)):
        t = a[:, 0]
        with np.errstate(over="ignore"):  # a span beyond float64 is refused below, not warned about
            steps = np.diff(t)
            span = t[-1] - t[0]
        if np.any(steps < 0):
            frame = int(np.argmax(steps < 0)) + 1
            fail(
                f"times[{k}]", f"be non-decreasing, got {t[frame - 1]:g} s -> {t[frame]:g} s at frame {frame}"
            )
        if not span > 0:
            fail(f"times[{k}]", f"span a duration > 0, got {t[0]:g} s .. {t[-1]:g} s")
        if not np.isfinite(span):
            fail(
                f"times[{k}]",
                f"span a duration within float64's range (choose other units), got {t[0]:g} s .. {t[-1]:g} s",
            )
        out.append(t)
    return out


def _orientations(orientations: object, lengths: list[int]) -> list[Array]:
    arrays = _matching(orientations, "orientations", lengths, 4)
    for k, q in enumerate(arrays):
        with np.errstate(over="ignore"):
            norms = np.linalg.norm(q, axis=1)
        _check_entries(
            f"orientations[{k}]",
            norms,
            np.isfinite(norms) & (norms >= MIN_QUATERNION_NORM),
            f"hold quaternions (w first, unit length expected) of finite norm >= {MIN_QUATERNION_NORM:g}",
            noun="norm",
        )
    return arrays


def _check_entries(
    name: str, a: Array, ok: NDArray[np.bool_], what: str, why: str = "", noun: str = "one"
) -> None:
    """``fail`` naming the first entry of ``a`` (by frame and axis) where ``ok`` is False; ``why`` is
    added to the location in the message."""
    if not ok.all():
        index = first_bad_index(~ok)
        where = ", ".join(f"{axis} {i}" for axis, i in zip(("frame", "axis"), index, strict=False))
        fail(name, f"{what} (the first bad {noun} is at {where}{'; ' + why if why else ''})", float(a[index]))


def _matching(value: object, name: str, lengths: list[int], width: int) -> list[Array]:
    """``value`` as one (T_k, width) array per demo of positions."""
    arrays = _demo_list(value, name)
    if len(arrays) != len(lengths):
        fail(name, f"hold one array per demo of positions ({len(lengths)}), got {len(arrays)}")
    for k, a in enumerate(arrays):
        if a.shape != (lengths[k], width):
            fail(
                f"{name}[{k}]",
                f"have the shape of positions[{k}], {(lengths[k], width)}, got shape {a.shape}",
            )
    return arrays


# ----------------------------------------------------------------------------------------------
# one demo or several


def _is_array(v: object) -> bool:
    """An array object (numpy, or one that converts itself: pandas, torch), not a nested Python list."""
    return isinstance(v, np.ndarray) or (hasattr(v, "__array__") and not isinstance(v, (list, tuple)))


def _demo_list(value: object, name: str) -> list[Array]:
    """``value`` as a list of finite (T, d) float arrays: one array (numpy, pandas, nested lists) is one
    demo, a list or tuple of array objects is several; (T,) reads as (T, 1). ``times`` may be datetimes
    or durations (converted to seconds from the demo's first sample)."""
    if _is_array(value):
        items = [value]
    elif isinstance(value, (list, tuple)) and len(value) and all(_is_array(v) for v in value):
        items = list(value)
        if name == "positions":
            _refuse_split_demo(items)
    else:
        items = [value]
    return [_demo_array(f"{name}[{k}]", a, name == "times") for k, a in enumerate(items)]


def _refuse_split_demo(items: Sequence[object]) -> None:
    """``list(x)`` of one (T, d) array reads as T one-dimensional demos of d samples: say so, not fit that."""
    shapes = {np.shape(v) for v in items}
    if len(shapes) == 1 and len(s := next(iter(shapes))) == 1 and len(items) > s[0] <= 4:
        fail(
            "positions",
            f"be a (T, d) array or a list of (T, d) arrays (for one ({len(items)}, {s[0]}) demo pass "
            f"np.asarray(...) of them), got a list of {len(items)} one-dimensional arrays of {s[0]} "
            "samples each",
        )


def _demo_array(where: str, value: object, datetimes_ok: bool) -> Array:
    """One demo's array as a finite (T, d) float64 array."""
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):  # ragged nested lists
        a = None
    if a is None or a.dtype == object:
        fail(
            where,
            "be a rectangular array of numbers (several demos of different lengths go in a list of "
            "(T, d) numpy arrays)",
        )
    if a.dtype.kind in "Mm":  # datetimes and durations: seconds, as documented
        if not datetimes_ok:
            fail(where, f"be an array of numbers, got {a.dtype} values")
        a = (a - a.reshape(-1)[0]) / np.timedelta64(1, "s") if a.size else a.astype(float)
    a = check_array(where, a, finite=False)
    if a.ndim == 1:
        a = a[:, None]
    if a.ndim != 2:
        hint = "; several demos go in a list of (T, d) arrays" if a.ndim == 3 else ""
        fail(where, f"have shape (T, d) or (T,){hint}, got shape {a.shape}")
    return check_finite(where, a, axes=("frame", "axis"))
