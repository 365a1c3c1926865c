"""Changepoint precision / recall / F1 against reference events (segmentation/evaluation.py)."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from lerobot_forcemap.segmentation.evaluation import (
    hit_rate,
    match_changepoints,
    pooled_score,
    prf,
    score_changepoints,
)


def brute_force_max_matching(pred: np.ndarray, ref: np.ndarray, tol: float) -> int:
    """Maximum number of one-to-one pairs within tolerance, by an assignment solver."""
    if pred.size == 0 or ref.size == 0:
        return 0
    within = np.abs(pred[:, None] - ref[None, :]) <= tol
    rows, cols = linear_sum_assignment(-within.astype(float))
    return int(within[rows, cols].sum())


@pytest.mark.parametrize("method", ["optimal", "greedy"])
def test_perfect_prediction(method: str) -> None:
    ref = np.array([120, 400, 780])
    s = score_changepoints(ref[::-1], ref, tolerance=10, method=method)
    assert (s.precision, s.recall, s.f1) == (1.0, 1.0, 1.0)
    assert s.n_matched == 3
    np.testing.assert_array_equal(s.errors, 0.0)
    np.testing.assert_array_equal(s.pairs, [[0, 0], [1, 1], [2, 2]])


@pytest.mark.parametrize("method", ["optimal", "greedy"])
def test_shift_at_and_beyond_tolerance(method: str) -> None:
    ref = np.array([100, 500, 900])
    at = score_changepoints(ref + 64, ref, tolerance=64, method=method)
    assert at.f1 == 1.0  # the tolerance is inclusive
    np.testing.assert_array_equal(at.errors, 64)
    early = score_changepoints(ref - 64, ref, tolerance=64, method=method)
    np.testing.assert_array_equal(early.errors, -64)  # signed: predicted - reference
    beyond = score_changepoints(ref + 65, ref, tolerance=64, method=method)
    assert (beyond.n_matched, beyond.precision, beyond.recall, beyond.f1) == (0, 0.0, 0.0, 0.0)


@pytest.mark.parametrize("method", ["optimal", "greedy"])
def test_duplicates_count_once(method: str) -> None:
    s = score_changepoints([10, 10, 50], [10, 50], tolerance=5, method=method)
    assert (s.n_predicted, s.n_reference, s.n_matched) == (3, 2, 2)
    assert s.precision == pytest.approx(2 / 3)
    assert s.recall == 1.0
    assert s.f1 == pytest.approx(0.8)
    dup_ref = score_changepoints([10], [10, 10], tolerance=5, method=method)
    assert (dup_ref.precision, dup_ref.recall) == (1.0, 0.5)
    # Two changepoints around one event: one is a false positive.
    around = score_changepoints([95, 105], [100], tolerance=10, method=method)
    assert (around.n_matched, around.precision, around.recall) == (1, 0.5, 1.0)


def test_empty_sets() -> None:
    both = score_changepoints([], [], tolerance=10)
    assert (both.precision, both.recall, both.f1) == (1.0, 1.0, 1.0)
    no_pred = score_changepoints([], [100, 200], tolerance=10)
    assert (no_pred.precision, no_pred.recall, no_pred.f1) == (1.0, 0.0, 0.0)
    no_ref = score_changepoints([100], np.zeros(0), tolerance=10)
    assert (no_ref.precision, no_ref.recall, no_ref.f1) == (0.0, 1.0, 0.0)
    assert no_ref.pairs.shape == (0, 2) and no_ref.errors.shape == (0,)


def test_greedy_can_lose_a_pair_that_optimal_keeps() -> None:
    """The module doc's example: closest-pair-first takes (4, 5) and strands 0 and 9."""
    pred, ref = np.array([4, 9]), np.array([0, 5])
    assert match_changepoints(pred, ref, 4, "optimal").shape[0] == 2
    assert match_changepoints(pred, ref, 4, "greedy").shape[0] == 1
    np.testing.assert_array_equal(match_changepoints(pred, ref, 4, "greedy"), [[0, 1]])


def test_optimal_matches_an_assignment_solver_and_greedy_never_beats_it() -> None:
    rng = np.random.default_rng(7)
    for _ in range(400):
        pred = np.sort(rng.integers(0, 200, rng.integers(0, 9)))
        ref = np.sort(rng.integers(0, 200, rng.integers(0, 9)))
        tol = float(rng.integers(0, 40))
        best = brute_force_max_matching(pred.astype(float), ref.astype(float), tol)
        opt = match_changepoints(pred, ref, tol, "optimal")
        greedy = match_changepoints(pred, ref, tol, "greedy")
        assert opt.shape[0] == best
        assert greedy.shape[0] <= best
        for pairs in (opt, greedy):  # one-to-one and within tolerance
            assert np.unique(pairs[:, 0]).size == pairs.shape[0]
            assert np.unique(pairs[:, 1]).size == pairs.shape[0]
            assert np.all(np.abs(pred[pairs[:, 0]] - ref[pairs[:, 1]]) <= tol)


def test_input_order_does_not_matter() -> None:
    rng = np.random.default_rng(3)
    pred, ref = rng.integers(0, 1000, 12), rng.integers(0, 1000, 7)
    a = score_changepoints(pred, ref, 40)
    b = score_changepoints(rng.permutation(pred), rng.permutation(ref), 40)
    assert (a.n_matched, a.f1) == (b.n_matched, b.f1)


def test_f1_is_the_harmonic_mean_and_pooling_sums_counts() -> None:
    s1 = score_changepoints([10, 300, 600], [12, 590], 20)  # 2 of 3, 2 of 2
    s2 = score_changepoints([100], [400, 800], 20)  # 0 of 1, 0 of 2
    assert s1.f1 == pytest.approx(2 * s1.precision * s1.recall / (s1.precision + s1.recall))
    assert pooled_score([s1, s2]) == pytest.approx(prf(2, 4, 4))
    assert pooled_score([s1, s2])[2] == pytest.approx(0.5)


def test_hit_rate_is_not_one_to_one() -> None:
    np.testing.assert_array_equal(hit_rate([100], [90, 110, 300], 10), [True, True, False])
    np.testing.assert_array_equal(hit_rate([], [5], 10), [False])


def test_bad_input_raises() -> None:
    with pytest.raises(
        ValueError,
        match=r"^predicted: must hold finite values only \(the first bad one is at index 1\), got nan",
    ):
        score_changepoints([1.0, np.nan], [1.0], 5)
    with pytest.raises(
        ValueError,
        match=r"^reference: must hold finite values only \(the first bad one is at index 0\), got inf",
    ):
        score_changepoints([1.0], [np.inf], 5)
    with pytest.raises(ValueError, match="^tolerance: must be a finite number >= 0, got -1"):
        score_changepoints([1.0], [1.0], -1)
    with pytest.raises(ValueError, match=r"^method: must be one of \['greedy', 'optimal'\], got 'hungarian'"):
        score_changepoints([1.0], [1.0], 5, method="hungarian")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match=r"^predicted: must be a 1-D array .* got shape \(2, 2\)"):
        score_changepoints(np.zeros((2, 2)), [1.0], 5)
    with pytest.raises(ValueError, match=r"^n_matched: must be an integer >= 0 and <= 2, got 3"):
        prf(3, 2, 5)
