"""Scoring changepoints against reference events: one-to-one matching within a tolerance. Pure NumPy.

A predicted changepoint c and a reference event e *match* when |c − e| <= tolerance (frames, or any
unit as long as both use it). Each changepoint matches at most one event and each event at most one
changepoint, so a duplicated changepoint, or two changepoints around one event, count once as a true
positive and otherwise as false positives. With M matches, P predictions and E events:

    precision = M / P,   recall = M / E,   F1 = 2 M / (P + E)

Conventions for empty sets (documented because averages over demos depend on them): P = 0 gives
precision 1 (no false alarm was raised), E = 0 gives recall 1 (nothing was missed), and F1 = 2M/(P+E)
is 1 when both are empty, 0 when exactly one is. Pass only *interior* changepoints (a segmentation's
first 0 and last T are boundaries of the recording, not detections).

Matching methods:
- ``"optimal"`` (default): a maximum-cardinality one-to-one matching. On a line with a symmetric
  tolerance this is found exactly by one sweep over both sorted lists: take the events in order and
  give each the earliest unused changepoint that is within tolerance, skipping changepoints that lie
  more than `tolerance` before the current event (no later event can use them). Exchange argument:
  any maximum matching can be rewritten, pair by pair from the left, into the sweep's matching without
  losing a pair. Among maximum matchings it does not minimise the total distance; the distances it
  reports are those of its own pairs.
- ``"greedy"``: the classic closest-pair-first matching (sort every pair within tolerance by distance,
  accept a pair when both ends are still free). Never more matches than "optimal", sometimes fewer
  (c = 4 between e = 0 and e = 5 with another c = 9, tolerance 4: greedy takes (4, 5) and leaves 0
  and 9 unmatched; optimal matches (4, 0) and (9, 5)).

Micro ("pooled") scores over many demos sum M, P, E first (`pooled_score`); macro scores average the
per-demo values (what `python -m experiments.gbti_segmentation` reports with a spread over demos).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .._validation import check_array, check_choice, check_finite, check_int, check_real, fail

MatchMethod = Literal["optimal", "greedy"]
MATCH_METHODS: tuple[str, ...] = ("optimal", "greedy")


@dataclass(frozen=True, eq=False)
class ChangepointScore:
    """Outcome of `score_changepoints`.

    pairs:        (M, 2) int64 indices (into the sorted predicted, sorted reference arrays) of matched pairs
    errors:       (M,) predicted − reference of each matched pair (signed, in the inputs' unit)
    n_predicted, n_reference, n_matched: P, E, M
    precision, recall, f1: see the module doc (empty-set conventions included)
    """

    pairs: np.ndarray
    errors: np.ndarray
    n_predicted: int
    n_reference: int
    n_matched: int
    precision: float
    recall: float
    f1: float


def _as_sorted_points(name: str, values: Iterable[float] | np.ndarray) -> np.ndarray:
    """Finite frames or times, any order, as a sorted (n,) float array (a (n, 1) array reads as (n,))."""
    try:
        values = values if isinstance(values, np.ndarray) else list(values)
    except TypeError:
        fail(name, f"be a 1-D array of frames or times, got {type(values).__name__}")
    x = check_array(name, values, finite=False)
    if x.ndim > 1 and np.squeeze(x).ndim > 1:
        fail(name, f"be a 1-D array of frames or times, got shape {x.shape}")
    return np.sort(check_finite(name, x.reshape(-1), axes=("index",)), kind="stable")


def _match_optimal(pred: np.ndarray, ref: np.ndarray, tolerance: float) -> np.ndarray:
    pairs: list[tuple[int, int]] = []
    i = 0
    for j, e in enumerate(ref.tolist()):  # events (a handful per demo), not samples
        while i < pred.size and pred[i] < e - tolerance:
            i += 1
        if i < pred.size and pred[i] <= e + tolerance:
            pairs.append((i, j))
            i += 1
    return np.asarray(pairs, dtype=np.int64).reshape(-1, 2)


def _match_greedy(pred: np.ndarray, ref: np.ndarray, tolerance: float) -> np.ndarray:
    dist = np.abs(pred[:, None] - ref[None, :])  # (P, E)
    ii, jj = np.nonzero(dist <= tolerance)
    order = np.lexsort((jj, ii, dist[ii, jj]))  # by distance, ties to the earlier prediction, then event
    used_p = np.zeros(pred.size, dtype=bool)
    used_r = np.zeros(ref.size, dtype=bool)
    pairs: list[tuple[int, int]] = []
    for i, j in zip(ii[order].tolist(), jj[order].tolist(), strict=True):  # candidate pairs, not samples
        if not used_p[i] and not used_r[j]:
            used_p[i] = used_r[j] = True
            pairs.append((i, j))
    pairs.sort(key=lambda p: p[1])
    return np.asarray(pairs, dtype=np.int64).reshape(-1, 2)


def match_changepoints(
    predicted: Iterable[float] | np.ndarray,
    reference: Iterable[float] | np.ndarray,
    tolerance: float,
    method: MatchMethod = "optimal",
) -> np.ndarray:
    """(M, 2) index pairs into (sorted predicted, sorted reference) matched one-to-one within tolerance
    (>= 0, in the points' unit) by ``method`` (one of MATCH_METHODS)."""
    tolerance = check_real("tolerance", tolerance, low=0.0)
    method = check_choice("method", method, MATCH_METHODS)
    return _match(
        _as_sorted_points("predicted", predicted),
        _as_sorted_points("reference", reference),
        tolerance,
        method,
    )


def _match(pred: np.ndarray, ref: np.ndarray, tolerance: float, method: str) -> np.ndarray:
    """:func:`match_changepoints` of sorted, checked points."""
    if pred.size == 0 or ref.size == 0:
        return np.zeros((0, 2), dtype=np.int64)
    return (
        _match_optimal(pred, ref, tolerance) if method == "optimal" else _match_greedy(pred, ref, tolerance)
    )


def prf(n_matched: int, n_predicted: int, n_reference: int) -> tuple[float, float, float]:
    """(precision, recall, F1) from counts, with the module's empty-set conventions."""
    n_predicted = check_int("n_predicted", n_predicted, low=0)
    n_reference = check_int("n_reference", n_reference, low=0)
    check_int("n_matched", n_matched, low=0, high=min(n_predicted, n_reference))
    return _prf(n_matched, n_predicted, n_reference)


def _prf(n_matched: int, n_predicted: int, n_reference: int) -> tuple[float, float, float]:
    """:func:`prf` of checked counts."""
    precision = n_matched / n_predicted if n_predicted else 1.0
    recall = n_matched / n_reference if n_reference else 1.0
    total = n_predicted + n_reference
    f1 = 2.0 * n_matched / total if total else 1.0
    return float(precision), float(recall), float(f1)


def score_changepoints(
    predicted: Iterable[float] | np.ndarray,
    reference: Iterable[float] | np.ndarray,
    tolerance: float,
    method: MatchMethod = "optimal",
) -> ChangepointScore:
    """Precision, recall and F1 of interior changepoints against reference events (see module doc).

    predicted (P,), reference (E,): frames (or times), any order, duplicates allowed; tolerance >= 0 in
    the same unit. Raises ValueError for NaN/inf entries, a negative tolerance or an unknown method.
    """
    pred = _as_sorted_points("predicted", predicted)
    ref = _as_sorted_points("reference", reference)
    tolerance = check_real("tolerance", tolerance, low=0.0)
    pairs = _match(pred, ref, tolerance, check_choice("method", method, MATCH_METHODS))
    errors = pred[pairs[:, 0]] - ref[pairs[:, 1]] if pairs.size else np.zeros(0)
    m = int(pairs.shape[0])
    precision, recall, f1 = _prf(m, pred.size, ref.size)
    return ChangepointScore(
        pairs=pairs,
        errors=errors,
        n_predicted=int(pred.size),
        n_reference=int(ref.size),
        n_matched=m,
        precision=precision,
        recall=recall,
        f1=f1,
    )


def pooled_score(scores: Iterable[ChangepointScore]) -> tuple[float, float, float]:
    """Micro (pooled) precision, recall, F1: counts summed over all `ChangepointScore` first."""
    m = p = e = 0
    for i, s in enumerate(scores):
        if not isinstance(s, ChangepointScore):
            fail(f"scores[{i}]", f"be a ChangepointScore, got {type(s).__name__}")
        m, p, e = m + s.n_matched, p + s.n_predicted, e + s.n_reference
    return _prf(m, p, e)


def hit_rate(predicted: np.ndarray, reference: np.ndarray, tolerance: float) -> np.ndarray:
    """(E,) bool: is there any predicted point within tolerance (>= 0) of each reference event (not
    one-to-one)? Events in the given order."""
    pred = _as_sorted_points("predicted", predicted)
    ref = check_finite(
        "reference", check_array("reference", reference, finite=False).reshape(-1), axes=("index",)
    )
    tolerance = check_real("tolerance", tolerance, low=0.0)
    if pred.size == 0:
        return np.zeros(ref.size, dtype=bool)
    lo = np.searchsorted(pred, ref - tolerance, side="left")
    hi = np.searchsorted(pred, ref + tolerance, side="right")
    return hi > lo
