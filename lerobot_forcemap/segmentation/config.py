"""Inputs of the segmentation: named streams and the configuration.

Pure NumPy (floor 1). A `Stream` checks itself when it is built (shape, finite values, finite and
non-decreasing times) so that a bad recording fails with the stream's name and the first bad frame;
a `SegmentationConfig` checks its fields. Everything downstream trusts both.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

import numpy as np

from .._validation import (
    check_array,
    check_choice,
    check_int,
    check_real,
    check_str,
    fail,
    first_bad_index,
    is_int,
)

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
#: most frames a pmf may have when asked for by count (`stream_pmf`): a day at 1 kHz, 0.8 GB per pmf
MAX_FRAMES = 100_000_000


@dataclass(frozen=True, eq=False)
class Stream:
    """One data stream of a demonstration.

    name:      unique name (used in errors, diagnostics and `SegmentationResult.keypoints`)
    values:    (T,) or (T, k) samples; stored as a float64 (T, k) array
    times:     (T,) sample times in seconds, non-decreasing (equal neighbours are duplicated
               samples: see `SegmentationConfig.duplicate_times`)
    weight:    importance v_i >= 0 (0 leaves the stream out of the combined pmf)
    threshold: keypoint threshold, a fraction in (0, 1] of the stream's own maximum smoothed jerk

    Errors name the stream and field (``"Stream('arm').times: ..."``) and the first bad frame.
    """

    name: str
    values: np.ndarray
    times: np.ndarray
    weight: float = 1.0
    threshold: float = 0.2

    def __post_init__(self) -> None:
        name = check_str("Stream.name", self.name, empty_ok=False)
        where = f"Stream({name!r})"
        values = _stream_values(f"{where}.values", self.values)
        times = _stream_times(f"{where}.times", self.times, values.shape[0])
        # Read-only copies: the stream cannot be edited through itself, and a later edit of the caller's
        # arrays (a NaN, a decreasing time) cannot slip past the checks.
        for field, array in (("values", values), ("times", times)):
            array = array.copy()
            array.setflags(write=False)
            object.__setattr__(self, field, array)
        # the geometric combination multiplies log-pmfs (down to about -745) by the weights
        weight = check_real(f"{where}.weight", self.weight, low=0.0, high=MAX_STREAM_WEIGHT)
        object.__setattr__(self, "weight", weight)
        threshold = check_real(f"{where}.threshold", self.threshold, low=0.0, high=1.0, low_open=True)
        object.__setattr__(self, "threshold", threshold)

    @property
    def n_frames(self) -> int:
        return int(self.values.shape[0])


def _stream_values(name: str, data: object) -> np.ndarray:
    """``data`` as a finite float64 (T, k) array with T >= 2, k >= 1 ((T,) reads as (T, 1))."""
    values = check_array(name, data, finite=False)
    if values.ndim == 1:
        values = values[:, None]
    if values.ndim != 2 or values.shape[0] < 2 or values.shape[1] < 1:
        fail(name, f"have shape (T,) or (T, k) with T >= 2, got shape {np.shape(data)}")
    bad = ~np.isfinite(values)
    if bad.any():
        frame, column = first_bad_index(bad)
        fail(
            name,
            f"hold finite values only (the first bad one is at frame {frame}, column {column}; "
            f"{int(bad.any(axis=1).sum())} bad frames in all)",
            float(values[frame, column]),
        )
    return values


def _stream_times(name: str, data: object, n_frames: int) -> np.ndarray:
    """``data`` as finite, non-decreasing (T,) float64 seconds ((T, 1) reads as (T,))."""
    times = check_array(name, data, finite=False)
    if times.ndim == 2 and times.shape[1] == 1:
        times = times[:, 0]
    if times.shape != (n_frames,):
        fail(name, f"have shape ({n_frames},) to match values, got shape {np.shape(data)}")
    times = check_array(name, times, axes=("frame",))
    back = np.diff(times) < 0
    if back.any():
        (i,) = first_bad_index(back)
        fail(
            name,
            f"be non-decreasing (sort the samples or fix the recording), got {times[i]:.9f} s -> "
            f"{times[i + 1]:.9f} s at frame {i + 1}",
        )
    return times


@dataclass(frozen=True, eq=False)
class EventStream:
    """A stream whose keypoints are given: events at known times (a contact's touch-downs, or its
    lift-offs), found by a detector that knows more than a jerk threshold can.

    name:    unique name among the streams of one call
    events:  (E,) event times in seconds, on the clock of ``times`` (E may be 0)
    times:   (T,) sample times in seconds, the demonstration's time base (shared with the other streams)
    weight:  importance v_i >= 0, as a `Stream`'s
    sigma_s: std of the Gaussian put at each event, in seconds (None: the config's ``sigma``)

    Its keypoints are the frames nearest to the events (`keypoints`), so its pmf has its Gaussians
    exactly there: no derivative, threshold or run is involved, and no lead to correct. Errors name
    the stream and field (``"EventStream('touch_down').events: ..."``).
    """

    name: str
    events: np.ndarray
    times: np.ndarray
    weight: float = 1.0
    sigma_s: float | None = None

    def __post_init__(self) -> None:
        name = check_str("EventStream.name", self.name, empty_ok=False)
        where = f"EventStream({name!r})"
        events = check_array(f"{where}.events", self.events, ndim=(0, 1), axes=("event",)).reshape(-1)
        times = _stream_times(f"{where}.times", self.times, np.size(self.times))
        if times.size < 2:
            fail(f"{where}.times", f"hold at least 2 samples, got {times.size}")
        for field, array in (("events", np.sort(events)), ("times", times)):
            array = array.copy()
            array.setflags(write=False)
            object.__setattr__(self, field, array)
        weight = check_real(f"{where}.weight", self.weight, low=0.0, high=MAX_STREAM_WEIGHT)
        object.__setattr__(self, "weight", weight)
        sigma = check_real(f"{where}.sigma_s", self.sigma_s, low=0.0, low_open=True, none_ok=True, unit="s")
        object.__setattr__(self, "sigma_s", sigma)

    @property
    def n_frames(self) -> int:
        return int(self.times.shape[0])

    def keypoints(self) -> np.ndarray:
        """(K,) sorted distinct frames nearest to the events (an event beyond either end: that end)."""
        t = self.times
        right = np.clip(np.searchsorted(t, self.events), 1, len(t) - 1)
        left = right - 1
        nearest = np.where(self.events - t[left] <= t[right] - self.events, left, right)
        return np.unique(nearest).astype(np.int64)

    def sigma_frames(self, default: float) -> float:
        """The Gaussians' std in frames: ``sigma_s`` at the median sample step (at least `MIN_SIGMA`),
        else ``default``."""
        if self.sigma_s is None:
            return float(default)
        return max(self.sigma_s / float(np.median(np.diff(self.times))), MIN_SIGMA)


def stream_list(streams: Iterable[Stream], caller: str, *, events_ok: bool = False) -> list[Stream]:
    """The streams of one call to `caller` as a non-empty list of `Stream` (and `EventStream` when
    ``events_ok``); a bare array would fail later with an AttributeError naming neither."""
    name = f"{caller}(streams=...)"
    kinds = (Stream, EventStream) if events_ok else (Stream,)
    if isinstance(streams, kinds):
        fail(name, "be a list of Streams (all of one demonstration), got one Stream: pass [stream]")
    try:
        streams = list(streams)
    except TypeError:
        fail(name, f"be a list of Streams, got {type(streams).__name__}")
    if not streams:
        fail(name, "hold at least one stream, got none")
    for i, s in enumerate(streams):
        if not isinstance(s, kinds):
            what = "Stream or EventStream" if events_ok else "Stream"
            fail(name, f"hold {what} objects, got {type(s).__name__} at [{i}]")
    return streams


#: the authors' lab recorder rate (~166 Hz) and their window = min_run = 64 samples at it (0.385 s): the
#: defaults below count samples of such a recording; at another rate the same time span is other counts
AUTHORS_RATE_HZ = 166.0
AUTHORS_WINDOW_S = 64 / AUTHORS_RATE_HZ
#: the authors' grace (4 samples) as a fraction of their window (64 samples)
AUTHORS_GRACE_FRACTION = 4 / 64


@dataclass(frozen=True, eq=False)
class SegmentationConfig:
    """Parameters of `segment_streams` (defaults are the authors' UR5e values where they exist; see
    ``docs/segmentation.md``). Errors name the field (``"SegmentationConfig.window: ..."``).

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
        self._check_sizes()
        self._check_methods()

    def _check_sizes(self) -> None:
        """The sample counts and the Gaussians' widths."""
        check_int("SegmentationConfig.window", self.window, low=5)
        check_int("SegmentationConfig.min_run", self.min_run, low=1)
        check_int("SegmentationConfig.grace", self.grace, low=0)
        check_real("SegmentationConfig.sigma", self.sigma, low=MIN_SIGMA, none_ok=True, unit="samples")
        check_real("SegmentationConfig.floor", self.floor, low=0.0, low_open=True)
        check_int("SegmentationConfig.min_segment_length", self.min_segment_length, low=1, none_ok=True)
        check_int("SegmentationConfig.polyorder", self.polyorder, low=3, high=self.window - 1)
        check_real("SegmentationConfig.time_tolerance", self.time_tolerance, low=0.0, none_ok=True, unit="s")

    def _check_methods(self) -> None:
        """The methods and their settings."""
        check_choice("SegmentationConfig.mode", self.mode, MODES)
        check_choice("SegmentationConfig.changepoints", self.changepoints, CHANGEPOINT_METHODS)
        check_int("SegmentationConfig.n_samples", self.n_samples, low=1, high=MAX_SAMPLE_DRAWS)
        check_int("SegmentationConfig.n_pass", self.n_pass, low=1)
        if self.changepoints == "sample" and self.n_pass > self.n_samples:
            fail(
                "SegmentationConfig.n_pass",
                f"be <= n_samples={self.n_samples} in sample mode (no window can hold more draws than "
                "there are, so sample mode could never give a changepoint)",
                self.n_pass,
            )
        if not (isinstance(self.seed, np.random.Generator) or (is_int(self.seed) and self.seed >= 0)):
            fail("SegmentationConfig.seed", "be an integer >= 0 or a numpy.random.Generator", self.seed)
        check_choice("SegmentationConfig.derivative", self.derivative, DERIVATIVES)
        check_real("SegmentationConfig.peak_ratio", self.peak_ratio, low=1.0)
        check_choice("SegmentationConfig.duplicate_times", self.duplicate_times, DUPLICATE_TIMES)

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


@dataclass(frozen=True)
class SegmentationTiming:
    """The segmentation's sample counts given in seconds, so that one setting means the same at 20, 50
    or 166 Hz; :meth:`config` converts them at a recording's rate. `DEFAULT_TIMING` is what the policy
    (``segmentation_window_s``, ``min_segment_s``) and ``forcemap segment`` use unless told otherwise.

    window_s:      moving average, Savitzky-Golay window, default Gaussian sigma, peak distance (0.3 s:
                   the shortest contacts of the UR5e presses last 0.34 s, and touch-down and lift-off
                   need two peaks a window apart; at least 5 samples)
    min_run_s:     a run above threshold lasts this long to give a keypoint (None: ``window_s``)
    grace_s:       dips below threshold this short do not end a run (None: the authors' 4/64 of the
                   window)
    min_segment_s: shortest segment (None: half the window)
    event_sigma_s: std of the Gaussian of an `EventStream` event (contact events are detected within a
                   few tens of milliseconds)
    """

    window_s: float = 0.3
    min_run_s: float | None = None
    grace_s: float | None = None
    min_segment_s: float | None = None
    event_sigma_s: float = 0.05

    def __post_init__(self) -> None:
        positive = {"low": 0.0, "low_open": True, "unit": "s"}
        check_real("SegmentationTiming.window_s", self.window_s, **positive)
        check_real("SegmentationTiming.min_run_s", self.min_run_s, none_ok=True, **positive)
        check_real("SegmentationTiming.grace_s", self.grace_s, low=0.0, none_ok=True, unit="s")
        check_real("SegmentationTiming.min_segment_s", self.min_segment_s, none_ok=True, **positive)
        check_real("SegmentationTiming.event_sigma_s", self.event_sigma_s, **positive)

    def config(self, fps: float, **settings: object) -> SegmentationConfig:
        """A `SegmentationConfig` at ``fps`` (Hz) with these counts and the other ``settings``
        (mode, changepoints, seed, ...)."""
        fps = check_real("fps", fps, low=0.0, low_open=True, unit="Hz")
        window = max(5, int(round(self.window_s * fps)))
        min_run = window if self.min_run_s is None else max(1, int(round(self.min_run_s * fps)))
        grace = (
            int(round(AUTHORS_GRACE_FRACTION * window))
            if self.grace_s is None
            else int(round(self.grace_s * fps))
        )
        shortest = None if self.min_segment_s is None else max(1, int(round(self.min_segment_s * fps)))
        return SegmentationConfig(
            window=window, min_run=min_run, grace=grace, min_segment_length=shortest, **settings
        )


DEFAULT_TIMING = SegmentationTiming()

#: the original authors' UR5e keypoint thresholds of the signal streams (fractions of a stream's largest
#: smoothed jerk: joints 0.20, Cartesian position 0.25, wrist force 0.15, gripper 0.10); finger force,
#: which they did not use, takes the wrist force's
SIGNAL_STREAM_THRESHOLDS: dict[str, float] = {
    "position": 0.25,
    "wrist_force": 0.15,
    "joints": 0.20,
    "gripper": 0.10,
    "finger_force": 0.15,
}
#: the event streams of a recording with contact intervals: touch-downs and lift-offs, one stream each
#: (two edges a few tenths of a second apart in one stream would merge into one peak)
EVENT_STREAMS: tuple[str, ...] = ("touch_down", "lift_off")
#: their default weight: 4 each against 1 for a signal stream, so that both edges of every contact
#: become changepoints even where the signal streams see nothing (measured on the UR5e presses and wipes)
EVENT_STREAM_WEIGHT = 4.0


def contact_event_streams(
    times: object,
    intervals: object,
    *,
    weights: dict[str, float] | None = None,
    timing: SegmentationTiming = DEFAULT_TIMING,
) -> list[EventStream]:
    """The ``touch_down`` and ``lift_off`` `EventStream` of contact ``intervals (K, 2)`` [touch-down,
    lift-off] s on ``times (T,)`` s; ``weights`` by stream name (default `EVENT_STREAM_WEIGHT`), Gaussians
    of ``timing.event_sigma_s``. A stream of weight 0 is left out."""
    iv = check_array("intervals", intervals, ndim=(1, 2), axes=("contact", "edge")).reshape(-1, 2)
    weights = {**dict.fromkeys(EVENT_STREAMS, EVENT_STREAM_WEIGHT), **(weights or {})}
    return [
        EventStream(name, iv[:, k], times, weight=weights[name], sigma_s=timing.event_sigma_s)
        for k, name in enumerate(EVENT_STREAMS)
        if weights[name] > 0
    ]


def check_config(config: object, caller: str) -> SegmentationConfig:
    """``config`` (None: the defaults) if it is a `SegmentationConfig`; a dict of settings would fail
    later with an AttributeError that names neither."""
    if config is None:
        return SegmentationConfig()
    if not isinstance(config, SegmentationConfig):
        hint = " (build one: SegmentationConfig(**settings))" if isinstance(config, dict) else ""
        fail(f"{caller}(config=...)", f"be a SegmentationConfig or None{hint}, got {type(config).__name__}")
    return config
