"""Per-stream keypoints, vectorised (``docs/segmentation.md``).

For one stream (samples x (n, k), times t (n,)):

1. third time derivative, one of
   - "savgol": Savitzky–Golay third derivative (polyorder 4, window `window`, dt = median time step),
     full length n; identical to `scipy.signal.savgol_filter(x, window, polyorder, deriv=3,
     delta=dt, axis=0, mode="interp")`, computed with cached kernels;
   - "difference": three forward differences with the real per-sample dt (the authors' code),
     length n - 3, sample j standing for frame j;
2. L2 norm over columns, moving average of width `window` (valid part: entry r averages jerk
   r .. r+window-1), divided by its maximum -> the signal s in [0, 1];
3. runs of s >= threshold, where dips below threshold of at most `grace` samples do not end a run;
   a run that lasts at least `min_run` samples (from its first to its last sample at or above
   threshold) gives one keypoint at its start, shifted by window // 2 to the window's centre.
   One keypoint per run: a new keypoint needs the signal to fall below threshold for more than
   `grace` samples first. A run that starts at the first sample gives no keypoint (the signal was
   already high when the recording began: frame 0 is a changepoint anyway).

Where keypoints land: for a jerk onset (jerk switching on and staying on), within ±window/2 of
the onset (tested). For an impulsive jerk event (a step in acceleration) the smoothed jerk is a bump
about two windows wide and the run starts on its leading edge, so the keypoint leads the event by
about 0.6 window (36–43 frames at window 64, threshold 0.2, measured on synthetic steps).

Differences from the authors' `count_thresh` (brenhertel/Probabilistic-Segmentation), all by one
sample: they tolerate dips of grace + 1 samples, require min_run + 1 samples, drop the last moving-
average sample, and count up to grace + 1 leading below-threshold samples into a first run.

A stream whose smoothed jerk is zero everywhere (a gripper that never moves), or no larger than
floating-point round-off could make it (an exactly linear ramp), is flat: s = 0, no keypoints, no
division by zero (`roundoff_jerk`).

The public functions check their inputs; `analyse_stream` (segment.py) calls the unchecked cores
(`_keypoints`, `_savgol_third_derivative`, `_threshold_runs`) on a checked `Stream`.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.signal import savgol_coeffs

from .._validation import check_array, check_real, fail
from .config import Derivative, SegmentationConfig

# A stream whose smoothed jerk stays below this fraction of the largest jerk its value range could
# produce is flat (round-off only). Real signals sit many orders of magnitude above it.
FLAT_RELATIVE = 1e-10


@lru_cache(maxsize=32)
def savgol_third_derivative_kernels(window: int, polyorder: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit-dt kernels of the Savitzky–Golay third derivative in scipy's "interp" mode.

    Returns (conv (window,), left (window//2, window), right (window//2, window)): `conv` is the
    interior kernel for `np.convolve(x, conv, "valid")` (output r sits at sample r + (window-1)//2);
    `left` / `right` map the first / last `window` samples to the first / last window//2 outputs
    (third derivative of the least-squares polynomial fitted to that edge window).
    """
    conv = savgol_coeffs(window, polyorder, deriv=3, delta=1.0)
    half = window // 2
    # Centred positions keep the Vandermonde matrix well conditioned (derivatives are shift-invariant).
    pos = np.arange(window, dtype=np.float64) - (window - 1) / 2.0
    powers = np.arange(polyorder + 1)
    fit = np.linalg.pinv(pos[:, None] ** powers)  # (p+1, window): samples -> ascending poly coeffs
    # d3/dx3 x^m = m (m-1) (m-2) x^(m-3)
    falling = powers * (powers - 1) * (powers - 2)

    def third_derivative_rows(at: np.ndarray) -> np.ndarray:
        safe = np.maximum(powers - 3, 0)
        return np.where(powers >= 3, falling * at[:, None] ** safe, 0.0)

    left = third_derivative_rows(pos[:half]) @ fit
    right = third_derivative_rows(pos[window - half :]) @ fit
    for a in (conv, left, right):
        a.setflags(write=False)
    return conv, left, right


def savgol_third_derivative(x: np.ndarray, dt: float, window: int, polyorder: int) -> np.ndarray:
    """Savitzky–Golay third derivative of x (n, k) with sample spacing dt > 0; returns (n, k).

    Equals scipy.signal.savgol_filter(x, window, polyorder, deriv=3, delta=dt, axis=0, mode="interp").
    Requires n >= window, window >= 5 and 3 <= polyorder < window.
    """
    SegmentationConfig(window=window, polyorder=polyorder)  # checks both, naming the field
    x = check_array("x", x, ndim=2)
    if x.shape[0] < window or x.shape[1] < 1:
        fail("x", f"have shape (n, k) with n >= window={window} and k >= 1, got shape {x.shape}")
    dt = check_real("dt", dt, low=0.0, low_open=True, unit="s")
    try:
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            out = _savgol_third_derivative(x, dt, window, polyorder)
    except OverflowError:  # dt**3 of a Python float
        out = None
    if out is None or not np.isfinite(out).all():
        fail("x", f"have a third derivative within float64's range at dt={dt:g} s (choose other units)")
    return out


def _savgol_third_derivative(x: np.ndarray, dt: float, window: int, polyorder: int) -> np.ndarray:
    """:func:`savgol_third_derivative` of checked inputs."""
    n, k = x.shape
    conv, left, right = savgol_third_derivative_kernels(window, polyorder)
    out = np.empty((n, k))
    lo = (window - 1) // 2
    for j in range(k):  # columns (a handful), not samples
        out[lo : lo + n - window + 1, j] = np.convolve(x[:, j], conv, mode="valid")
    half = window // 2
    out[:half] = left @ x[:window]
    out[n - half :] = right @ x[n - window :]
    out /= dt**3
    return out


def difference_third_derivative(x: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Three forward differences with the real dt (the authors' calc_jerk_in_time); (n-3, k).

    Level m divides by t[i+1] - t[i] for its i = 0 .. n-m-1, as the authors' code does.
    """
    dt = np.diff(t)
    d = x
    for _ in range(3):
        d = np.diff(d, axis=0) / dt[: d.shape[0] - 1, None]
    return d


def jerk_norm(
    x: np.ndarray, t: np.ndarray, derivative: Derivative, window: int, polyorder: int
) -> np.ndarray:
    """L2 norm over columns of the third derivative: (n,) for savgol, (n-3,) for difference."""
    if derivative == "savgol":
        dt = float(np.median(np.diff(t)))
        d3 = _savgol_third_derivative(x, dt, window, polyorder)
    else:
        d3 = difference_third_derivative(x, t)
    if d3.shape[1] == 1:
        return np.abs(d3[:, 0])
    return np.sqrt(np.einsum("ij,ij->i", d3, d3))


def roundoff_jerk(x: np.ndarray, t: np.ndarray, derivative: Derivative, window: int, polyorder: int) -> float:
    """A jerk level below which a stream counts as flat: FLAT_RELATIVE x the largest jerk the
    stream's value range could produce through the derivative filter.

    Without it, a stream that is constant or exactly linear (a scripted gripper ramp) would have its
    floating-point round-off jerk divided by its own maximum and thresholded into keypoints.
    """
    value_range = float(np.abs(x - x[0]).max())
    if derivative == "savgol":
        dt = float(np.median(np.diff(t)))
        gain = float(np.abs(savgol_third_derivative_kernels(window, polyorder)[1]).sum(axis=1).max())
    else:
        dt = float(np.diff(t).min())
        gain = 8.0
    return FLAT_RELATIVE * value_range * gain * np.sqrt(x.shape[1]) / dt**3


def moving_average_valid(x: np.ndarray, window: int) -> np.ndarray:
    """Entry r is mean(x[r : r + window]); shape (n - window + 1,)."""
    c = np.concatenate(([0.0], np.cumsum(x)))
    return (c[window:] - c[:-window]) / window


def normalised_signal(jerk: np.ndarray, window: int, flat_below: float = 0.0) -> np.ndarray:
    """Moving average of the jerk norm divided by its maximum (all zeros when the maximum is <= flat_below)."""
    ma = moving_average_valid(jerk, window)
    peak = float(ma.max())
    if not peak > flat_below:
        return np.zeros_like(ma)
    return ma / peak


def threshold_runs(signal: np.ndarray, threshold: float, min_run: int, grace: int) -> np.ndarray:
    """Start indices of the runs of `signal >= threshold` that give keypoints (see module doc).

    signal (m,) finite; threshold a number; min_run >= 1 and grace >= 0 samples. Returns an int64
    array of run starts (indices into `signal`), sorted.
    """
    signal = check_array("signal", signal, ndim=1, axes=("index",))
    threshold = check_real("threshold", threshold)
    config = SegmentationConfig(min_run=min_run, grace=grace)  # checks both, naming the field
    return _threshold_runs(signal, threshold, config.min_run, config.grace)


def _threshold_runs(signal: np.ndarray, threshold: float, min_run: int, grace: int) -> np.ndarray:
    """:func:`threshold_runs` of checked inputs. Vectorised: runs of above-threshold samples from
    np.diff of the padded mask, gaps of at most `grace` samples merged, then filtered by length and
    by "not starting at sample 0"."""
    above = signal >= threshold
    edges = np.diff(np.concatenate(([False], above, [False])).astype(np.int8))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1)  # exclusive
    if starts.size == 0:
        return starts.astype(np.int64)
    gaps = starts[1:] - ends[:-1]
    breaks = gaps > grace  # a dip longer than grace ends the run
    run_starts = starts[np.concatenate(([True], breaks))]
    run_ends = ends[np.concatenate((breaks, [True]))]
    keep = (run_ends - run_starts >= min_run) & (run_starts > 0)
    return run_starts[keep].astype(np.int64)


@dataclass(frozen=True, eq=False)
class StreamKeypoints:
    """Keypoints of one stream and the signal they came from.

    keypoints: (K,) frame indices (into the stream's samples), sorted
    signal:    (m,) normalised moving-average jerk; entry r covers derivative samples r .. r+window-1
    flat:      True when the smoothed jerk is zero everywhere (no keypoints possible)
    """

    keypoints: np.ndarray
    signal: np.ndarray
    flat: bool


def stream_keypoints(
    x: np.ndarray,
    t: np.ndarray,
    *,
    threshold: float,
    window: int,
    min_run: int,
    grace: int,
    derivative: Derivative = "savgol",
    polyorder: int = 4,
) -> StreamKeypoints:
    """Keypoints of one stream, x (n, k) finite at strictly increasing times t (n,) in seconds, as
    sample indices (see module doc). threshold in (0, 1]; window, min_run, grace, derivative and
    polyorder as in `SegmentationConfig` (which checks them here, naming its fields)."""
    SegmentationConfig(
        window=window, min_run=min_run, grace=grace, derivative=derivative, polyorder=polyorder
    )
    threshold = check_real("threshold", threshold, low=0.0, high=1.0, low_open=True)
    x = check_array("x", x, axes=("frame", "column"))
    needed = window + (3 if derivative == "difference" else 0)
    if x.ndim != 2 or x.shape[0] < needed or x.shape[1] < 1:
        fail(
            "x",
            f"have shape (n, k) with n >= {needed} (window={window}, derivative={derivative!r}), got "
            f"shape {x.shape}",
        )
    t = check_array("t", t, shape=(x.shape[0],), axes=("frame",))
    if not (np.diff(t) > 0).all():
        fail("t", f"be strictly increasing, got a step <= 0 after frame {int(np.argmax(np.diff(t) <= 0))}")
    return _keypoints("x", x, t, threshold, window, min_run, grace, derivative, polyorder)


def _keypoints(
    name: str,
    x: np.ndarray,
    t: np.ndarray,
    threshold: float,
    window: int,
    min_run: int,
    grace: int,
    derivative: Derivative,
    polyorder: int,
) -> StreamKeypoints:
    """:func:`stream_keypoints` of checked inputs; ``name`` is what a third derivative outside float64's
    range is blamed on."""
    x = x - x[0]  # exact zeros for a constant stream; better conditioned differences
    try:
        with np.errstate(over="ignore", divide="ignore", invalid="ignore"):
            jerk = jerk_norm(x, t, derivative, window, polyorder)
            flat_below = roundoff_jerk(x, t, derivative, window, polyorder)
    except OverflowError:  # dt**3 of a Python float
        jerk, flat_below = None, float("inf")
    if jerk is None or not np.isfinite(flat_below) or not np.isfinite(jerk).all():
        # an infinite jerk would make the stream look flat (or everywhere active) without saying so
        steps = np.diff(t)
        fail(
            name,
            "have a third derivative within float64's range (choose other units), got values changing by "
            f"up to {float(np.abs(x).max()):.3g} over time steps of {float(np.min(steps)):.3g}.."
            f"{float(np.max(steps)):.3g} s",
        )
    signal = normalised_signal(jerk, window, flat_below)
    starts = _threshold_runs(signal, threshold, min_run, grace)
    keypoints = np.minimum(starts + window // 2, x.shape[0] - 1)
    return StreamKeypoints(keypoints=keypoints, signal=signal, flat=not signal.any())
