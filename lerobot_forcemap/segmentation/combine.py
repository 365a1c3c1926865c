"""Per-stream changepoint pmfs and their weighted combination (SPEC §2, paper eq. prob-comb).

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
"""

from __future__ import annotations

import math

import numpy as np

from .config import MIN_SIGMA, Mode, is_int

GAUSS_RADIUS_SIGMAS = 8.0  # Gaussians are cut at ±8σ: the dropped tail is below 1.3e-14 of the peak


def stream_pmf(keypoints: np.ndarray, n_frames: int, sigma: float, floor: float) -> tuple[np.ndarray, float]:
    """pmf (T,) of one stream's changepoints and its floor level (the pmf value far from keypoints).

    Vectorised over keypoints and frames: every keypoint's Gaussian (cut at ±8σ, and at T frames: no
    frame lies further from a keypoint) is scattered into the frame axis with one np.bincount.
    """
    if not (is_int(n_frames) and n_frames >= 1):
        raise ValueError(f"n_frames must be an int >= 1, got {n_frames!r}")
    if not (np.isfinite(sigma) and sigma >= MIN_SIGMA):
        raise ValueError(f"sigma must be >= {MIN_SIGMA:g} samples, got {sigma!r}")
    if not (np.isfinite(floor) and floor > 0):
        raise ValueError(f"floor must be > 0, got {floor!r}")
    keypoints = np.asarray(keypoints, dtype=np.int64).reshape(-1)
    if keypoints.size and (keypoints.min() < 0 or keypoints.max() >= n_frames):
        raise ValueError(
            f"keypoints must be frames in [0, {n_frames}), got {keypoints.min()}..{keypoints.max()}"
        )
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

    Streams with weight 0 are left out; raises ValueError when no weight is positive.
    """
    pmfs = np.asarray(pmfs, dtype=np.float64)
    weights = np.asarray(weights, dtype=np.float64)
    floor_levels = np.asarray(floor_levels, dtype=np.float64)
    if pmfs.ndim != 2 or weights.shape != (pmfs.shape[0],) or floor_levels.shape != (pmfs.shape[0],):
        raise ValueError(
            f"pmfs (n, T), floor_levels (n,) and weights (n,) must agree, got {pmfs.shape}, "
            f"{floor_levels.shape} and {weights.shape}"
        )
    if not (np.isfinite(weights).all() and (weights >= 0).all()):
        raise ValueError(f"weights must be finite and >= 0, got {weights.tolist()}")
    active = weights > 0
    if not active.any():
        raise ValueError("all stream weights are zero: at least one stream needs a weight > 0")
    p = pmfs[active]
    f = floor_levels[active]
    w = weights[active]
    if mode == "linear":
        total = float(w.sum())
        return (w @ p) / total, float(w @ f) / total
    if mode == "product":
        w = np.ones_like(w)
    elif mode != "geometric":
        raise ValueError(f"mode must be 'product', 'geometric' or 'linear', got {mode!r}")
    log_p = w @ np.log(p)
    log_floor = float(w @ np.log(f))
    top = float(log_p.max())
    unnormalised = np.exp(log_p - top)
    total = float(unnormalised.sum())
    return unnormalised / total, math.exp(log_floor - top) / total
