"""Per-stream changepoint pmfs and their weighted combination (``docs/segmentation.md``).

Per stream: p_i(t) ∝ floor / T + Σ_k N(t; k, σ²) over its keypoints k, t = 0 .. T-1 (frames),
each Gaussian cut at ±8σ.
Each Gaussian has unit mass (before edge truncation) and the uniform floor has mass `floor`, so
floor = 1 reproduces the authors' `ones + pdf` in normalised time for any T.

Combination over streams i with weights v_i:
- "product":   p ∝ Π_{v_i > 0} p_i. The paper's formula Π v_i p_i read literally: after normalising,
               the v_i cancel, so only which streams have v_i > 0 matters (scale of the weights and
               their ratios are ignored). The authors' code (no weights) is this with all v_i > 0.
- "geometric": log p = Σ v_i log p_i + const (a weighted geometric pool). Equals "product" when all
               v_i = 1; scaling all v_i by c raises p to the power c (sharper for c > 1), so the
               weights' scale acts as an inverse temperature. Weights that sum to 1 (as in the
               paper's Table I) give a weighted geometric mean of the stream pmfs.
- "linear":    p = Σ v_i p_i / Σ v_i (a mixture). Invariant to the weights' scale; a keypoint seen by a
               single stream keeps a bump of mass v_i / Σ v instead of being vetoed by the others' floors.
Streams with v_i = 0 are left out in every mode; all v_i = 0 is an error. Products are taken in the
log domain (no underflow for many streams).

The floor level of the combined pmf (its value where no stream has a keypoint nearby) is returned
with it: peaks mode measures peaks against it.

`stream_pmf` and `combine_pmfs` check their inputs; `segment_streams` calls the unchecked cores.
"""

from __future__ import annotations

import math

import numpy as np

from .._validation import check_array, check_choice, check_int, check_int_array, check_real, fail
from .config import MAX_FRAMES, MIN_SIGMA, MODES, Mode

GAUSS_RADIUS_SIGMAS = 8.0  # Gaussians are cut at ±8σ: the dropped tail is below 1.3e-14 of the peak


def stream_pmf(keypoints: np.ndarray, n_frames: int, sigma: float, floor: float) -> tuple[np.ndarray, float]:
    """pmf (T,) of one stream's changepoints and its floor level (the pmf value far from keypoints).

    keypoints (K,) frames in [0, T); n_frames T in [1, MAX_FRAMES]; sigma >= MIN_SIGMA samples; floor > 0.
    """
    n_frames = check_int("n_frames", n_frames, low=1, high=MAX_FRAMES)
    sigma = check_real("sigma", sigma, low=MIN_SIGMA, unit="samples")
    floor = check_real("floor", floor, low=0.0, low_open=True)
    keypoints = check_int_array("keypoints", keypoints)
    if keypoints.size and (keypoints.min() < 0 or keypoints.max() >= n_frames):
        fail("keypoints", f"be frames in [0, {n_frames}), got {keypoints.min()}..{keypoints.max()}")
    return _stream_pmf(keypoints, n_frames, sigma, floor)


def _stream_pmf(keypoints: np.ndarray, n_frames: int, sigma: float, floor: float) -> tuple[np.ndarray, float]:
    """:func:`stream_pmf` of checked inputs. Vectorised over keypoints and frames: every keypoint's
    Gaussian (cut at ±8σ, and at T frames: no frame lies further from a keypoint) is scattered into the
    frame axis with one np.bincount."""
    raw = np.full(n_frames, floor / n_frames)
    if keypoints.size:
        radius = min(int(math.ceil(GAUSS_RADIUS_SIGMAS * sigma)), n_frames)
        offsets = np.arange(-radius, radius + 1)
        bump = np.exp(-0.5 * (offsets / sigma) ** 2) / (sigma * math.sqrt(2.0 * math.pi))
        frames = keypoints[:, None] + offsets[None, :]  # (K, 2r+1)
        inside = (frames >= 0) & (frames < n_frames)
        raw += np.bincount(
            frames[inside], weights=np.broadcast_to(bump, frames.shape)[inside], minlength=n_frames
        )
    total = float(raw.sum())
    return raw / total, floor / n_frames / total


def combine_pmfs(
    pmfs: np.ndarray, floor_levels: np.ndarray, weights: np.ndarray, mode: Mode
) -> tuple[np.ndarray, float]:
    """Combine stream pmfs (n, T) with weights (n,) -> (pmf (T,), floor level of the combined pmf).

    pmfs and floor_levels (n,) > 0 (as `stream_pmf` makes them); weights >= 0, at least one > 0;
    streams with weight 0 are left out. mode one of MODES.
    """
    pmfs = check_array("pmfs", pmfs, ndim=2, min_len=1, finite=False)
    n = pmfs.shape[0]
    floor_levels = check_array("floor_levels", floor_levels, shape=(n,), axes=("stream",))
    weights = check_array("weights", weights, shape=(n,), axes=("stream",))
    if not (weights >= 0).all():
        fail("weights", "be >= 0", weights.tolist())
    if not (weights > 0).any():
        fail(
            "weights",
            "give at least one stream a weight > 0 (a stream of weight 0 is left out), got all zero",
        )
    # two reductions instead of element masks (NaN fails the first): the values go through log()
    low, high = float(pmfs.min()), float(pmfs.max())
    if not (low > 0 and math.isfinite(high) and (floor_levels > 0).all()):
        fail(
            "pmfs",
            "hold finite values > 0 with floor_levels > 0 (as stream_pmf makes them), got values in "
            f"[{low:g}, {high:g}]",
        )
    return _combine(pmfs, floor_levels, weights, check_choice("mode", mode, MODES))


def _combine(
    pmfs: np.ndarray, floor_levels: np.ndarray, weights: np.ndarray, mode: Mode
) -> tuple[np.ndarray, float]:
    """:func:`combine_pmfs` of checked inputs; products in the log domain."""
    active = weights > 0
    p = pmfs[active]
    f = floor_levels[active]
    w = weights[active]
    if mode == "linear":
        total = float(w.sum())
        return (w @ p) / total, float(w @ f) / total
    if mode == "product":
        w = np.ones_like(w)
    log_p = w @ np.log(p)
    log_floor = float(w @ np.log(f))
    top = float(log_p.max())
    unnormalised = np.exp(log_p - top)
    total = float(unnormalised.sum())
    return unnormalised / total, math.exp(log_floor - top) / total
