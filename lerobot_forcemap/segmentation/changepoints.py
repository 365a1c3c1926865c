"""Changepoints from the combined pmf (SPEC §2): "sample", "peaks", and the minimum segment length.

- `sample_changepoints` (the paper / authors' code): draw n_samples frames from the pmf with a
  numpy Generator, sort them, group them greedily (a group holds the draws within `window` frames
  of its first draw; the first group is anchored at frame 0), and a group of >= n_pass draws gives
  a changepoint at the floor of its mean.
- `peak_changepoints` (deterministic): local maxima of the pmf of height >= peak_ratio x floor
  level, at least `window` frames apart (the higher peak wins; scipy.signal.find_peaks).
- `enforce_min_segment_length`: interior changepoints are accepted strongest-first (by pmf value,
  ties to the earlier frame) when they are at least `min_length` frames from 0, from T and from
  every accepted one. Returns the sorted changepoints with 0 and T and the rejected candidates.
"""

from __future__ import annotations

import numpy as np
from scipy.signal import find_peaks

from .config import is_int


def sample_changepoints(
    pmf: np.ndarray, rng: np.random.Generator, n_samples: int, n_pass: int, window: int
) -> tuple[np.ndarray, np.ndarray]:
    """(candidate changepoints, sorted draws) of the paper's sampling consensus."""
    _check_counts(n_samples=n_samples, n_pass=n_pass, window=window)
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
    """Frames of the local maxima of pmf with height >= peak_ratio * floor_level, >= window apart."""
    _check_counts(window=window)
    peaks, _ = find_peaks(pmf, height=peak_ratio * floor_level, distance=window)
    return peaks.astype(np.int64)


def enforce_min_segment_length(
    candidates: np.ndarray, strength: np.ndarray, n_frames: int, min_length: int
) -> tuple[np.ndarray, np.ndarray]:
    """(changepoints [0, ..., T] sorted, rejected candidates sorted); see module doc."""
    # min_length >= 1 is what keeps every segment non-empty (0 would accept T and repeated candidates)
    _check_counts(n_frames=n_frames, min_length=min_length)
    candidates = np.asarray(candidates, dtype=np.int64).reshape(-1)
    if np.shape(strength) != candidates.shape:
        raise ValueError(
            f"strength must have one value per candidate {candidates.shape}, got {np.shape(strength)}"
        )
    order = np.lexsort((candidates, -np.asarray(strength, dtype=np.float64)))
    accepted: list[int] = []
    rejected: list[int] = []
    for c in candidates[order].tolist():  # a handful of candidates
        ok = min_length <= c <= n_frames - min_length and all(abs(c - a) >= min_length for a in accepted)
        (accepted if ok else rejected).append(c)
    changepoints = np.array([0, *sorted(accepted), n_frames], dtype=np.int64)
    return changepoints, np.array(sorted(rejected), dtype=np.int64)


def _check_counts(**counts: object) -> None:
    """ValueError naming the first of ``counts`` that is not an int >= 1."""
    for name, value in counts.items():
        if not (is_int(value) and value >= 1):
            raise ValueError(f"{name} must be an int >= 1, got {value!r}")
