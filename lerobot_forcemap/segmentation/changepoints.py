"""Changepoints from the combined pmf: "sample", "peaks", and the minimum segment length.

- `sample_changepoints` (the paper / authors' code): draw n_samples frames from the pmf with a
  numpy Generator, sort them, group them greedily (a group holds the draws within `window` frames
  of its first draw; the first group is anchored at frame 0), and a group of >= n_pass draws gives
  a changepoint at the floor of its mean.
- `peak_changepoints` (deterministic): local maxima of the pmf of height >= peak_ratio x floor
  level, at least `window` frames apart (the higher peak wins; scipy.signal.find_peaks).
- `enforce_min_segment_length`: interior changepoints are accepted strongest-first (by pmf value,
  ties to the earlier frame) when they are at least `min_length` frames from 0, from T and from
  every accepted one. Returns the sorted changepoints with 0 and T and the rejected candidates.

The three functions check their inputs; `segment_streams` calls the unchecked cores.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import find_peaks

from .._validation import check_array, check_int, check_int_array, check_real, fail
from .config import MAX_SAMPLE_DRAWS

#: how far the sum of a pmf may be from 1 (numpy's own test in Generator.choice is sqrt(eps))
PMF_SUM_TOLERANCE = 1e-8


def _check_pmf(pmf: object, normalised: bool) -> np.ndarray:
    """A finite (T,) array with T >= 1; with ``normalised`` also >= 0 and summing to 1."""
    pmf = check_array("pmf", pmf, ndim=1, min_len=1, axes=("frame",))
    if normalised and ((pmf < 0).any() or abs(float(pmf.sum()) - 1.0) > PMF_SUM_TOLERANCE):
        fail("pmf", f"hold probabilities >= 0 that sum to 1, got a sum of {float(pmf.sum())!r}")
    return pmf


def sample_changepoints(
    pmf: np.ndarray, rng: np.random.Generator, n_samples: int, n_pass: int, window: int
) -> tuple[np.ndarray, np.ndarray]:
    """(candidate changepoints, sorted draws) of the paper's sampling consensus: pmf (T,) a pmf, rng a
    numpy Generator (advanced by the call), n_samples in [1, MAX_SAMPLE_DRAWS], n_pass and window >= 1."""
    pmf = _check_pmf(pmf, normalised=True)
    if not isinstance(rng, np.random.Generator):
        fail("rng", f"be a numpy.random.Generator, got {type(rng).__name__}")
    n_samples = check_int("n_samples", n_samples, low=1, high=MAX_SAMPLE_DRAWS)
    return _sample(
        pmf, rng, n_samples, check_int("n_pass", n_pass, low=1), check_int("window", window, low=1)
    )


def _sample(
    pmf: np.ndarray, rng: np.random.Generator, n_samples: int, n_pass: int, window: int
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`sample_changepoints` of checked inputs."""
    draws = np.sort(rng.choice(pmf.size, size=n_samples, replace=True, p=pmf))
    candidates: list[int] = []
    anchor = 0
    group: list[int] = []
    for d in draws.tolist():  # n_samples draws (20), not time samples
        if d <= anchor + window:
            group.append(d)
            continue
        if len(group) >= n_pass:
            candidates.append(int(np.mean(group)))
        anchor = d
        group = [d]
    if len(group) >= n_pass:
        candidates.append(int(np.mean(group)))
    return np.asarray(candidates, dtype=np.int64), draws.astype(np.int64)


def peak_changepoints(pmf: np.ndarray, floor_level: float, peak_ratio: float, window: int) -> np.ndarray:
    """Frames of the local maxima of pmf (T,) with height >= peak_ratio * floor_level, >= window apart
    (floor_level >= 0, peak_ratio >= 1, window >= 1)."""
    pmf = _check_pmf(pmf, normalised=False)
    floor_level = check_real("floor_level", floor_level, low=0.0)
    peak_ratio = check_real("peak_ratio", peak_ratio, low=1.0)
    return _peaks(pmf, floor_level, peak_ratio, check_int("window", window, low=1))


def _peaks(pmf: np.ndarray, floor_level: float, peak_ratio: float, window: int) -> np.ndarray:
    """:func:`peak_changepoints` of checked inputs."""
    peaks, _ = find_peaks(pmf, height=peak_ratio * floor_level, distance=window)
    return peaks.astype(np.int64)


def enforce_min_segment_length(
    candidates: np.ndarray, strength: np.ndarray, n_frames: int, min_length: int
) -> tuple[np.ndarray, np.ndarray]:
    """(changepoints [0, ..., T] sorted, rejected candidates sorted); see module doc.

    candidates (C,) frames (any order), strength (C,) finite, n_frames T >= 1, min_length >= 1 (what
    keeps every segment non-empty: 0 would accept T and repeated candidates).
    """
    n_frames = check_int("n_frames", n_frames, low=1)
    min_length = check_int("min_length", min_length, low=1)
    candidates = check_int_array("candidates", candidates)
    strength = check_array("strength", strength, shape=candidates.shape, axes=("candidate",))
    return _min_segment_length(candidates, strength, n_frames, min_length)


def _min_segment_length(
    candidates: np.ndarray, strength: np.ndarray, n_frames: int, min_length: int
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`enforce_min_segment_length` of checked inputs."""
    order = np.lexsort((candidates, -strength))
    accepted: list[int] = []
    rejected: list[int] = []
    for c in candidates[order].tolist():  # a handful of candidates
        ok = min_length <= c <= n_frames - min_length and all(abs(c - a) >= min_length for a in accepted)
        (accepted if ok else rejected).append(c)
    changepoints = np.array([0, *sorted(accepted), n_frames], dtype=np.int64)
    return changepoints, np.array(sorted(rejected), dtype=np.int64)
