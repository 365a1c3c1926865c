"""Smoothed derivatives and short transients of evenly sampled signals (pure NumPy/SciPy).

Every window is given in seconds and converted to samples at the signal's rate, so the same settings
mean the same thing at 20 Hz and at 500 Hz. The signals are taken as evenly spaced (their rate is the
median step): recorder streams resampled onto one time base, or native streams with a few percent of
jitter.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy.ndimage import median_filter
from scipy.signal import savgol_filter

__all__ = ["sample_rate", "odd_window", "smooth_derivatives", "transient", "delayed", "active_span"]

F64 = NDArray[np.float64]


def sample_rate(times: F64) -> float:
    """Frames per second (Hz) of ``times (T,)`` s from their median step."""
    return float(1.0 / np.median(np.diff(times)))


def odd_window(seconds: float, rate_hz: float, minimum: int = 5) -> int:
    """An odd number of samples covering about ``seconds`` at ``rate_hz`` (at least ``minimum``)."""
    n = max(int(round(seconds * rate_hz)), minimum)
    return n if n % 2 else n + 1


def smooth_derivatives(times: F64, x: F64, window_s: float, polyorder: int = 3) -> tuple[F64, F64]:
    """Velocity and acceleration of ``x (T, k)`` sampled at ``times (T,)`` s.

    Savitzky-Golay derivatives over ``window_s`` seconds (at least 5 samples: at 20 Hz a 0.06 s window
    becomes 0.25 s). Returns ``(v (T, k) units/s, a (T, k) units/s²)``.
    """
    rate = sample_rate(times)
    n = odd_window(window_s, rate)
    p = min(polyorder, n - 2)
    v = savgol_filter(x, n, p, deriv=1, delta=1.0 / rate, axis=0, mode="interp")
    a = savgol_filter(x, n, p, deriv=2, delta=1.0 / rate, axis=0, mode="interp")
    return v, a


def transient(times: F64, x: F64, window_s: float) -> F64:
    """``x (T,)`` minus its running median over ``window_s`` s: pulses shorter than half the window
    survive, slow changes (a hand's force) do not."""
    n = odd_window(window_s, sample_rate(times), minimum=3)
    return x - median_filter(x, size=n, mode="nearest")


def delayed(x: F64, frames: int) -> F64:
    """``x`` delayed by ``frames`` (> 0: ``y[t] = x[t - frames]``; < 0: advanced), edges held."""
    if frames == 0:
        return x
    index = np.clip(np.arange(len(x)) - frames, 0, len(x) - 1)
    return x[index]


def active_span(times: F64, positions: F64, min_speed: float, window_s: float) -> NDArray[np.bool_]:
    """``(T,)`` bool: from the first to the last frame whose speed exceeds ``min_speed`` m/s (velocity
    smoothed over ``window_s``), the part of a kinesthetic recording where the hand is on the robot."""
    v, _ = smooth_derivatives(times, positions, window_s)
    moving = np.flatnonzero(np.linalg.norm(v, axis=1) > min_speed)
    mask = np.zeros(len(times), dtype=bool)
    if len(moving):
        mask[moving[0] : moving[-1] + 1] = True
    return mask
