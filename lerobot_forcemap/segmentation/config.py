"""Inputs of the segmentation: named streams and the configuration (SPEC §2).

Pure NumPy (floor 1). A `Stream` checks itself when it is built (shape, finite values, finite and
non-decreasing times) so that a bad recording fails with the stream's name and the first bad frame.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

import numpy as np

Mode = Literal["product", "geometric", "linear"]
ChangepointMethod = Literal["sample", "peaks"]
Derivative = Literal["savgol", "difference"]
DuplicateTimes = Literal["merge", "raise"]

MODES: tuple[str, ...] = ("product", "geometric", "linear")
CHANGEPOINT_METHODS: tuple[str, ...] = ("sample", "peaks")
DERIVATIVES: tuple[str, ...] = ("savgol", "difference")
DUPLICATE_TIMES: tuple[str, ...] = ("merge", "raise")
#: largest stream weight accepted (weight × log-pmf must stay finite in the geometric combination)
MAX_STREAM_WEIGHT = 1e100
#: narrowest keypoint Gaussian, in samples (narrower is a spike on the keypoint's frame anyway, and its
#: 1/σ peak would leave float64's range)
MIN_SIGMA = 1e-3
#: most draws of sample mode (the paper draws 20; each draw is 8 bytes of memory)
MAX_SAMPLE_DRAWS = 1_000_000


def _first_bad_index(mask: np.ndarray) -> tuple[int, ...]:
    """Index (frame[, column]) of the first True entry of a boolean array."""
    flat = int(np.argmax(mask.reshape(-1)))
    return tuple(int(i) for i in np.unravel_index(flat, mask.shape))


def is_int(x: object) -> bool:
    """An int (Python or NumPy), not a bool."""
    return isinstance(x, int | np.integer) and not isinstance(x, bool)


def _real(value: object) -> float:
    """``float(value)``, or NaN for what is not a real number (so the caller's check names the field)."""
    if isinstance(value, (bool, str, bytes)):  # float("2") would pass, then fail as a str downstream
        return float("nan")
    if isinstance(value, np.ndarray) and value.ndim > 0:  # float() of a 1-element array is deprecated
        return float("nan")
    try:
        return float(value)
    except (TypeError, ValueError):
        return float("nan")


def _float_array(name: str, field: str, data: object, shape: str) -> np.ndarray:
    """``np.asarray(data, float64)``; numpy's conversion error (strings, ragged lists) names neither the
    stream nor the argument, so it is raised again under both."""
    try:
        array = np.asarray(data)
        if array.dtype.kind == "c":  # float64 would drop the imaginary part with only a ComplexWarning
            raise ValueError(f"got complex numbers ({array.dtype})")
        return array.astype(np.float64, copy=False)
    except (TypeError, ValueError) as err:
        raise ValueError(f"stream {name!r}: {field} must be numbers of shape {shape}; {err}") from None


@dataclass(frozen=True, eq=False)
class Stream:
    """One data stream of a demonstration.

    name:      unique name (used in errors, diagnostics and `SegmentationResult.keypoints`)
    values:    (T,) or (T, k) samples; stored as a float64 (T, k) array
    times:     (T,) sample times in seconds, non-decreasing (equal neighbours are duplicated
               samples: see `SegmentationConfig.duplicate_times`)
    weight:    importance v_i >= 0 (0 leaves the stream out of the combined pmf)
    threshold: keypoint threshold, a fraction in (0, 1] of the stream's own maximum smoothed jerk
    """

    name: str
    values: np.ndarray
    times: np.ndarray
    weight: float = 1.0
    threshold: float = 0.2

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"Stream name must be a non-empty string, got {self.name!r}")
        values = _float_array(self.name, "values", self.values, "(T,) or (T, k)")
        if values.ndim == 1:
            values = values[:, None]
        if values.ndim != 2 or values.shape[0] < 2 or values.shape[1] < 1:
            raise ValueError(
                f"stream {self.name!r}: values must have shape (T,) or (T, k) with T >= 2, got {np.shape(self.values)}"
            )
        times = _float_array(self.name, "times", self.times, "(T,)")
        if times.ndim == 2 and times.shape[1] == 1:
            times = times[:, 0]
        if times.shape != (values.shape[0],):
            raise ValueError(
                f"stream {self.name!r}: times must have shape ({values.shape[0]},) to match values, got {np.shape(self.times)}"
            )
        bad = ~np.isfinite(values)
        if bad.any():
            frame, col = _first_bad_index(bad)
            raise ValueError(
                f"stream {self.name!r}: non-finite value {values[frame, col]} at frame {frame}, column {col}"
                f" ({int(bad.any(axis=1).sum())} bad frames in all)"
            )
        bad_t = ~np.isfinite(times)
        if bad_t.any():
            (frame,) = _first_bad_index(bad_t)
            raise ValueError(f"stream {self.name!r}: non-finite time {times[frame]} at frame {frame}")
        dt = np.diff(times)
        if (dt < 0).any():
            (i,) = _first_bad_index(dt < 0)
            raise ValueError(
                f"stream {self.name!r}: times decrease at frame {i + 1} ({times[i]:.9f} s -> {times[i + 1]:.9f} s);"
                " sort the samples or fix the recording"
            )
        weight = _real(self.weight)
        if not np.isfinite(weight) or weight < 0:
            raise ValueError(f"stream {self.name!r}: weight must be finite and >= 0, got {self.weight!r}")
        if weight > MAX_STREAM_WEIGHT:
            # the geometric combination multiplies log-pmfs (down to about -745) by the weights
            raise ValueError(
                f"stream {self.name!r}: weight {weight:g} is above {MAX_STREAM_WEIGHT:g}; weights are relative "
                "importances (in the geometric mode their common scale acts as a temperature)"
            )
        threshold = _real(self.threshold)
        if not (0.0 < threshold <= 1.0):
            raise ValueError(
                f"stream {self.name!r}: threshold is a fraction of the stream's maximum, in (0, 1], got {self.threshold!r}"
            )
        # Read-only copies: the stream cannot be edited through itself, and a later edit of the caller's
        # arrays (a NaN, a decreasing time) cannot slip past the checks above.
        values = values.copy()
        times = times.copy()
        values.setflags(write=False)
        times.setflags(write=False)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "times", times)
        object.__setattr__(self, "weight", weight)
        object.__setattr__(self, "threshold", threshold)

    @property
    def n_frames(self) -> int:
        return int(self.values.shape[0])


def stream_list(streams: Iterable[Stream], caller: str) -> list[Stream]:
    """The streams of one call to `caller` as a list; ValueError when there are none or an item is not a
    `Stream` (a bare array would fail later with an AttributeError)."""
    if isinstance(streams, Stream):
        raise ValueError(
            f"{caller} takes a list of Streams (all of one demonstration), got one Stream: [stream]"
        )
    try:
        streams = list(streams)
    except TypeError:
        raise ValueError(f"{caller} takes a list of Streams, got {type(streams).__name__}") from None
    if not streams:
        raise ValueError(f"{caller} needs at least one stream")
    for s in streams:
        if not isinstance(s, Stream):
            raise ValueError(f"{caller} takes Stream objects, got {type(s).__name__}")
    return streams


#: the authors' lab recorder rate (~166 Hz) and their window = min_run = 64 samples at it (0.385 s): the
#: defaults below count samples of such a recording; at another rate the same time span is other counts
AUTHORS_RATE_HZ = 166.0
AUTHORS_WINDOW_S = 64 / AUTHORS_RATE_HZ


@dataclass(frozen=True, eq=False)
class SegmentationConfig:
    """Parameters of `segment_streams` (SPEC §2; defaults are the authors' UR5e values where they exist).

    window:       moving-average width of the jerk, in samples (64); also the Savitzky–Golay window,
                  the default Gaussian sigma, the sample-mode grouping window and the minimum peak distance
    min_run:      samples a run above threshold must last to give a keypoint (64)
    grace:        dips below threshold of up to `grace` samples do not end a run (4)
    sigma:        std of the Gaussian put at each keypoint, in samples; None -> `window`
    floor:        mass of each stream pmf's uniform floor relative to the unit mass of one keypoint
                  Gaussian (1.0 = the authors' code: `ones + pdf` in normalised time). Must be > 0 so
                  that `product`/`geometric` never take log(0).
    mode:         "product" (Π p_i over streams with v_i > 0; weight scale cancels), "geometric"
                  (log p = Σ v_i log p_i, default), "linear" (Σ v_i p_i / Σ v_i)
    changepoints: "peaks" (default, deterministic: local maxima of the combined pmf at least
                  `peak_ratio` times its floor level and at least `window` apart) or "sample" (the
                  paper: draw `n_samples` frames from the pmf, a window of `window` frames holding
                  >= `n_pass` draws gives a changepoint at their mean)
    n_samples, n_pass: sample mode (20, 3)
    seed:         int or numpy Generator for sample mode (a Generator is advanced by each call)
    min_segment_length: no segment shorter than this many frames; None -> window // 2 (changepoints
                  are only localised to about ±window/2, so closer ones are one event). Changepoints
                  are kept strongest-first (by combined pmf value).
    derivative:   "savgol" (Savitzky–Golay third derivative, polyorder `polyorder`, window `window`,
                  dt = the stream's median time step) or "difference" (the authors' forward differences
                  with the real per-sample dt)
    polyorder:    Savitzky–Golay polynomial order (4)
    peak_ratio:   peaks mode: a peak must reach this multiple of the combined pmf's floor level (2.0)
    duplicate_times: "merge" (default: samples whose time equals the previous sample's are dropped
                  before the derivative, keypoints are mapped back to original frames, a
                  `TimeRepairWarning` is issued and the repair is reported per stream) or "raise"
    time_tolerance: streams of one call must share their sample times up to this many seconds;
                  None -> 2 median sample periods (recorder topics differ by a few ms; a different
                  sample rate drifts by seconds and is caught)
    """

    window: int = 64
    min_run: int = 64
    grace: int = 4
    sigma: float | None = None
    floor: float = 1.0
    mode: Mode = "geometric"
    changepoints: ChangepointMethod = "peaks"
    n_samples: int = 20
    n_pass: int = 3
    seed: int | np.random.Generator = 0
    min_segment_length: int | None = None
    derivative: Derivative = "savgol"
    polyorder: int = 4
    peak_ratio: float = 2.0
    duplicate_times: DuplicateTimes = "merge"
    time_tolerance: float | None = None

    def __post_init__(self) -> None:
        def need(ok: bool, what: str) -> None:
            if not ok:
                raise ValueError(f"SegmentationConfig: {what}")

        need(is_int(self.window) and self.window >= 5, f"window must be an int >= 5, got {self.window!r}")
        need(is_int(self.min_run) and self.min_run >= 1, f"min_run must be an int >= 1, got {self.min_run!r}")
        need(is_int(self.grace) and self.grace >= 0, f"grace must be an int >= 0, got {self.grace!r}")
        sigma, floor = _real(self.sigma), _real(self.floor)
        need(
            self.sigma is None or (np.isfinite(sigma) and sigma >= MIN_SIGMA),
            f"sigma must be None or >= {MIN_SIGMA:g} samples, got {self.sigma!r}",
        )
        need(np.isfinite(floor) and floor > 0, f"floor must be > 0, got {self.floor!r}")
        need(self.mode in MODES, f"mode must be one of {MODES}, got {self.mode!r}")
        need(
            self.changepoints in CHANGEPOINT_METHODS,
            f"changepoints must be one of {CHANGEPOINT_METHODS}, got {self.changepoints!r}",
        )
        need(
            is_int(self.n_samples) and 1 <= self.n_samples <= MAX_SAMPLE_DRAWS,
            f"n_samples must be an int in [1, {MAX_SAMPLE_DRAWS}], got {self.n_samples!r}",
        )
        need(is_int(self.n_pass) and self.n_pass >= 1, f"n_pass must be an int >= 1, got {self.n_pass!r}")
        need(
            self.changepoints != "sample" or self.n_pass <= self.n_samples,
            f"n_pass={self.n_pass} is above n_samples={self.n_samples}: no window can hold that many draws,"
            " so sample mode could never give a changepoint",
        )
        need(
            isinstance(self.seed, np.random.Generator) or (is_int(self.seed) and self.seed >= 0),
            f"seed must be an int >= 0 or a numpy.random.Generator, got {self.seed!r}",
        )
        need(
            self.min_segment_length is None
            or (is_int(self.min_segment_length) and self.min_segment_length >= 1),
            f"min_segment_length must be None or an int >= 1, got {self.min_segment_length!r}",
        )
        need(
            self.derivative in DERIVATIVES,
            f"derivative must be one of {DERIVATIVES}, got {self.derivative!r}",
        )
        need(
            is_int(self.polyorder) and 3 <= self.polyorder < self.window,
            f"polyorder must be an int with 3 <= polyorder < window, got {self.polyorder!r}",
        )
        need(
            np.isfinite(_real(self.peak_ratio)) and _real(self.peak_ratio) >= 1.0,
            f"peak_ratio must be >= 1, got {self.peak_ratio!r}",
        )
        need(
            self.duplicate_times in DUPLICATE_TIMES,
            f"duplicate_times must be one of {DUPLICATE_TIMES}, got {self.duplicate_times!r}",
        )
        need(
            self.time_tolerance is None
            or (np.isfinite(_real(self.time_tolerance)) and _real(self.time_tolerance) >= 0),
            f"time_tolerance must be None or >= 0 seconds, got {self.time_tolerance!r}",
        )

    @property
    def sigma_frames(self) -> float:
        """Gaussian std in samples (`sigma`, else `window`)."""
        return float(self.window if self.sigma is None else self.sigma)

    @property
    def min_segment_frames(self) -> int:
        """Shortest allowed segment in frames (`min_segment_length`, else window // 2)."""
        return int(self.window // 2 if self.min_segment_length is None else self.min_segment_length)

    def rng(self) -> np.random.Generator:
        """The generator for sample mode: the given Generator itself, or a fresh one from the int seed."""
        return self.seed if isinstance(self.seed, np.random.Generator) else np.random.default_rng(self.seed)


def check_config(config: object, caller: str) -> SegmentationConfig:
    """``config`` (None: the defaults) if it is a `SegmentationConfig`; a dict of settings would fail
    later with an AttributeError that names neither."""
    if config is None:
        return SegmentationConfig()
    if not isinstance(config, SegmentationConfig):
        hint = " (build one: SegmentationConfig(**settings))" if isinstance(config, dict) else ""
        raise ValueError(f"{caller}: config must be a SegmentationConfig, got {type(config).__name__}{hint}")
    return config
