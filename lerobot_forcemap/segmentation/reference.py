"""Per-sample-loop reference of the segmentation algorithm, for tests and benchmarks only.

The obvious Python-loop version of what `segment_streams` computes with array operations: the
derivative, norm, moving average, thresholding with grace, the pmfs, their combination and the
peak picking all loop over samples. The Savitzky–Golay kernel comes from `scipy.signal.savgol_coeffs`
and the edge windows are fitted with `np.polyfit`, as `savgol_filter(mode="interp")` does.
Sample mode shares the draw-and-group code (it loops over the 20 draws, not over samples).
Never used by the library itself.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.signal import savgol_coeffs

from .changepoints import enforce_min_segment_length, sample_changepoints
from .config import SegmentationConfig, Stream
from .keypoints import roundoff_jerk


def loop_third_derivative(
    x: np.ndarray, t: np.ndarray, derivative: str, window: int, polyorder: int
) -> np.ndarray:
    """Third derivative, one sample at a time: (n, k) for savgol, (n-3, k) for difference."""
    n, k = x.shape
    if derivative == "difference":
        d = x
        for _ in range(3):
            m = d.shape[0]
            nxt = np.zeros((m - 1, k))
            for i in range(m - 1):
                nxt[i] = (d[i + 1] - d[i]) / (t[i + 1] - t[i])
            d = nxt
        return d
    dt = float(np.median(np.diff(t)))
    kernel = savgol_coeffs(window, polyorder, deriv=3, delta=dt)[::-1]  # as a dot product
    out = np.zeros((n, k))
    lo = (window - 1) // 2
    for i in range(n - window + 1):
        for j in range(k):
            out[lo + i, j] = float(np.dot(kernel, x[i : i + window, j]))
    half = window // 2
    pos = np.arange(window)
    for j in range(k):
        for start, at in ((0, pos[:half]), (n - window, pos[window - half :])):
            coeffs = np.polyder(np.polyfit(pos, x[start : start + window, j], polyorder), 3)
            for a in at:
                out[start + a, j] = np.polyval(coeffs, a) / dt**3
    return out


def loop_signal(x: np.ndarray, t: np.ndarray, derivative: str, window: int, polyorder: int) -> np.ndarray:
    """Normalised moving-average jerk norm, one sample at a time (same flatness rule as the library)."""
    x = x - x[0]
    d3 = loop_third_derivative(x, t, derivative, window, polyorder)
    jerk = [math.sqrt(sum(v * v for v in row)) for row in d3.tolist()]
    ma = [float(np.mean(jerk[i : i + window])) for i in range(len(jerk) - window + 1)]
    peak = max(ma)
    flat_below = roundoff_jerk(x, t, derivative, window, polyorder)
    return np.array([v / peak if peak > flat_below else 0.0 for v in ma])


def loop_run_starts(signal: Sequence[float], threshold: float, min_run: int, grace: int) -> list[int]:
    """Streaming thresholding with grace: a run starts at an above-threshold sample that follows a
    dip of more than `grace` samples (or nothing); it gives a keypoint once it has lasted `min_run`
    samples from its start to an above-threshold sample, unless it started at sample 0."""
    starts: list[int] = []
    in_run = False
    start = 0
    last_above = -1
    emitted = False
    for i, v in enumerate(signal):
        if v >= threshold:
            if not in_run or i - last_above - 1 > grace:
                in_run, start, emitted = True, i, False
            last_above = i
            if not emitted and i - start + 1 >= min_run and start > 0:
                starts.append(start)
                emitted = True
    return starts


def loop_stream_keypoints(stream: Stream, config: SegmentationConfig) -> list[int]:
    """Keypoint frames of one stream (with the same duplicated-timestamp merge as the library)."""
    kept = [0]
    for i in range(1, stream.n_frames):
        if stream.times[i] != stream.times[i - 1]:
            kept.append(i)
    x = stream.values[kept]
    t = stream.times[kept]
    signal = loop_signal(x, t, config.derivative, config.window, config.polyorder)
    starts = loop_run_starts(signal.tolist(), stream.threshold, config.min_run, config.grace)
    return [kept[min(s + config.window // 2, len(kept) - 1)] for s in starts]


def loop_stream_pmf(
    keypoints: Sequence[int], n_frames: int, sigma: float, floor: float
) -> tuple[np.ndarray, float]:
    raw = []
    for t in range(n_frames):
        v = floor / n_frames
        for k in keypoints:
            if abs(t - k) <= math.ceil(8.0 * sigma):
                v += math.exp(-0.5 * ((t - k) / sigma) ** 2) / (sigma * math.sqrt(2 * math.pi))
        raw.append(v)
    total = sum(raw)
    return np.array([v / total for v in raw]), floor / n_frames / total


def loop_combine(
    pmfs: list[np.ndarray], floors: list[float], weights: list[float], mode: str
) -> tuple[np.ndarray, float]:
    used = [i for i, w in enumerate(weights) if w > 0]
    n_frames = len(pmfs[0])
    if mode == "linear":
        total_w = sum(weights[i] for i in used)
        p = [sum(weights[i] * pmfs[i][t] for i in used) / total_w for t in range(n_frames)]
        return np.array(p), sum(weights[i] * floors[i] for i in used) / total_w
    w = {i: (1.0 if mode == "product" else weights[i]) for i in used}
    logp = [sum(w[i] * math.log(pmfs[i][t]) for i in used) for t in range(n_frames)]
    top = max(logp)
    un = [math.exp(v - top) for v in logp]
    total = sum(un)
    log_floor = sum(w[i] * math.log(floors[i]) for i in used)
    return np.array([v / total for v in un]), math.exp(log_floor - top) / total


def loop_peaks(pmf: np.ndarray, floor_level: float, peak_ratio: float, window: int) -> list[int]:
    height = peak_ratio * floor_level
    cands = []
    i = 1
    while i < len(pmf) - 1:
        if pmf[i] > pmf[i - 1]:
            # a flat top counts as one peak at its middle (lower middle when even), as scipy's find_peaks
            end = i
            while end + 1 < len(pmf) - 1 and pmf[end + 1] == pmf[i]:
                end += 1
            if pmf[end + 1] < pmf[i] and pmf[i] >= height:
                cands.append((i + end) // 2)
            i = end + 1
        else:
            i += 1
    accepted: list[int] = []
    for i in sorted(cands, key=lambda c: -pmf[c]):
        if all(abs(i - a) >= window for a in accepted):
            accepted.append(i)
    return sorted(accepted)


def loop_segment_streams(streams: Sequence[Stream], config: SegmentationConfig) -> dict[str, object]:
    """Changepoints, pmf and keypoints by the per-sample loops (same results as `segment_streams`)."""
    n_frames = streams[0].n_frames
    keypoints = {s.name: loop_stream_keypoints(s, config) for s in streams}
    pmfs, floors = [], []
    for s in streams:
        p, f = loop_stream_pmf(keypoints[s.name], n_frames, config.sigma_frames, config.floor)
        pmfs.append(p)
        floors.append(f)
    pmf, floor_level = loop_combine(pmfs, floors, [s.weight for s in streams], config.mode)
    if config.changepoints == "sample":
        cands, _ = sample_changepoints(pmf, config.rng(), config.n_samples, config.n_pass, config.window)
        cands = cands.tolist()
    else:
        cands = loop_peaks(pmf, floor_level, config.peak_ratio, config.window)
    strength = [pmf[min(max(c, 0), n_frames - 1)] for c in cands]
    changepoints, _ = enforce_min_segment_length(
        np.array(cands, dtype=np.int64), np.array(strength), n_frames, config.min_segment_frames
    )
    return {"changepoints": changepoints, "pmf": pmf, "keypoints": keypoints, "floor_level": floor_level}
