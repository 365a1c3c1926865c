"""Synthetic streams with known jerk events for the segmentation tests."""

from __future__ import annotations

import numpy as np
from scipy.signal import savgol_coeffs

DT = 0.006  # 166 Hz, as the UR5e recorder


def jerk_bursts(
    n_frames: int,
    onsets: np.ndarray,
    lengths: np.ndarray,
    jerks: np.ndarray,
    rng: np.random.Generator,
    *,
    n_cols: int = 1,
    rel_noise: float = 0.0,
    dt: float = DT,
    window: int = 64,
) -> tuple[np.ndarray, np.ndarray]:
    """Piecewise-cubic position whose jerk is `jerks[i]` on [onsets[i], onsets[i] + lengths[i]) and 0 elsewhere.

    Returns (values (T, n_cols), times (T,)). The position moves along a random unit direction; white
    noise is added with a std chosen so that the noise in the Savitzky–Golay jerk is `rel_noise` times
    the smallest |jerk|.
    """
    jerk = np.zeros(n_frames)
    for a, length, j in zip(onsets, lengths, jerks, strict=True):
        jerk[a : a + length] = j
    x = np.cumsum(np.cumsum(np.cumsum(jerk) * dt) * dt) * dt
    direction = rng.normal(size=n_cols)
    direction /= np.linalg.norm(direction)
    values = x[:, None] * direction[None, :]
    if rel_noise > 0:
        sigma = rel_noise * np.abs(jerks).min() * dt**3 / np.linalg.norm(savgol_coeffs(window, 4, deriv=3))
        values = values + sigma * rng.normal(size=values.shape)
    return values, np.arange(n_frames) * dt


def random_events(
    rng: np.random.Generator, n_frames: int = 2400
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Three well separated jerk bursts: (onsets, lengths, jerks)."""
    onsets = np.array([300, 900, 1600]) + rng.integers(-60, 60, 3)
    lengths = rng.integers(150, 350, 3)
    jerks = rng.uniform(0.5, 1.0, 3) * rng.choice([-1.0, 1.0], 3)
    return onsets, lengths, jerks


def random_stream_values(rng: np.random.Generator, n_frames: int, n_cols: int) -> np.ndarray:
    """A random walk position with a few random jerk bursts: generic input for agreement tests."""
    jerk = np.zeros(n_frames)
    for _ in range(rng.integers(0, 6)):
        a = int(rng.integers(0, n_frames - 10))
        jerk[a : a + int(rng.integers(5, 300))] = rng.normal()
    x = np.cumsum(np.cumsum(np.cumsum(jerk))) * 1e-6
    return x[:, None] * rng.normal(size=n_cols)[None, :] + 1e-4 * np.cumsum(
        rng.normal(size=(n_frames, n_cols)), axis=0
    )
