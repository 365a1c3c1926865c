"""`segment_streams`: keypoints per stream -> pmfs -> combined pmf -> changepoints.

The public functions here (`segment_streams`, `analyse_stream`) check their arguments once; the
stages below them (keypoints, pmfs, combination, changepoints) run their unchecked cores.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._validation import fail
from .changepoints import _min_segment_length, _peaks, _sample
from .combine import _combine, _stream_pmf
from .config import EventStream, SegmentationConfig, Stream, check_config, stream_list
from .keypoints import _keypoints
from .timebase import (
    TimeRepair,
    check_shared_time_base,
    repair_duplicate_times,
    warn_short_steps,
    warn_uneven_spacing,
)


@dataclass(frozen=True, eq=False)
class StreamResult:
    """Per-stream outcome and diagnostics.

    keypoints:   (K,) frame indices (original frames, after any time repair), sorted
    pmf:         (T,) the stream's changepoint pmf (computed for zero-weight streams too)
    floor_level: value of `pmf` far from keypoints
    signal:      normalised moving-average jerk on the samples the derivative used (empty for an
                 `EventStream`, whose threshold is NaN)
    flat:        the smoothed jerk was zero everywhere (so no keypoints); an `EventStream` without events
    time_repair: what the duplicated-timestamp repair did, or None
    used:        weight > 0, so the stream entered the combined pmf
    """

    name: str
    weight: float
    threshold: float
    keypoints: np.ndarray
    pmf: np.ndarray
    floor_level: float
    signal: np.ndarray
    flat: bool
    time_repair: TimeRepair | None
    used: bool


@dataclass(frozen=True, eq=False)
class SegmentationResult:
    """Outcome of `segment_streams`.

    changepoints:   sorted frame indices, first 0 and last T; segment i is frames
                    [changepoints[i], changepoints[i+1])
    pmf:            (T,) combined changepoint pmf
    floor_level:    value of `pmf` where no used stream has a keypoint nearby
    keypoints:      stream name -> (K,) keypoint frames
    streams:        stream name -> StreamResult (per-stream pmfs and diagnostics)
    candidates:     changepoints proposed by sample/peaks before `min_segment_length`
    rejected:       candidates removed by `min_segment_length`
    draws:          sample mode: the sorted draws from `pmf`; peaks mode: None
    time_tolerance: seconds within which the streams' sample times had to agree
    config:         the configuration used
    """

    changepoints: np.ndarray
    pmf: np.ndarray
    floor_level: float
    keypoints: dict[str, np.ndarray]
    streams: dict[str, StreamResult]
    candidates: np.ndarray
    rejected: np.ndarray
    draws: np.ndarray | None
    time_tolerance: float
    config: SegmentationConfig

    @property
    def n_frames(self) -> int:
        return int(self.pmf.size)

    @property
    def n_segments(self) -> int:
        return int(self.changepoints.size - 1)

    @property
    def stream_pmfs(self) -> dict[str, np.ndarray]:
        return {name: s.pmf for name, s in self.streams.items()}

    @property
    def segments(self) -> list[tuple[int, int]]:
        """[(start, stop)) frame ranges of the segments."""
        cp = self.changepoints.tolist()
        return list(zip(cp[:-1], cp[1:], strict=True))

    def labels(self) -> np.ndarray:
        """(T,) int64 segment index of every frame."""
        return np.repeat(np.arange(self.n_segments, dtype=np.int64), np.diff(self.changepoints))


@dataclass(frozen=True, eq=False)
class StreamAnalysis:
    """Keypoint frames (original frame indices), normalised jerk signal, flatness and time repair of one stream."""

    keypoints: np.ndarray
    signal: np.ndarray
    flat: bool
    time_repair: TimeRepair | None


def analyse_stream(stream: Stream, config: SegmentationConfig | None = None) -> StreamAnalysis:
    """Keypoints of one stream on its own (duplicated timestamps repaired per `config.duplicate_times`).

    Raises ValueError naming the stream when it is shorter than the derivative needs, or its third
    derivative leaves float64's range."""
    if not isinstance(stream, Stream):
        fail("analyse_stream(stream=...)", f"be a Stream, got {type(stream).__name__}")
    return _analyse(stream, check_config(config, "analyse_stream"))


def _analyse(stream: Stream, config: SegmentationConfig) -> StreamAnalysis:
    """:func:`analyse_stream` of a checked stream and config."""
    repair = repair_duplicate_times(stream, config)
    x, t = stream.values, stream.times
    kept = None if repair is None else repair.kept_frames
    if repair is not None:
        x, t = x[kept], t[kept]
    if config.derivative == "savgol":
        warn_uneven_spacing(stream.name, t, kept)
    if len(t) >= 2:
        warn_short_steps(stream.name, t, kept)
    needed = config.window + (3 if config.derivative == "difference" else 0)
    if x.shape[0] < needed:
        extra = f" after dropping {repair.n_dropped} duplicated-timestamp samples" if repair else ""
        fail(
            f"Stream({stream.name!r}).values",
            f"hold at least {needed} samples for window={config.window} with derivative="
            f"{config.derivative!r}, got {x.shape[0]}{extra}",
        )
    found = _keypoints(
        f"Stream({stream.name!r}).values",
        x,
        t,
        stream.threshold,
        config.window,
        config.min_run,
        config.grace,
        config.derivative,
        config.polyorder,
    )
    keypoints = found.keypoints if kept is None else kept[found.keypoints]
    return StreamAnalysis(keypoints=keypoints, signal=found.signal, flat=found.flat, time_repair=repair)


def checked_streams(
    streams: object, config: SegmentationConfig, caller: str, *, events_ok: bool = False
) -> tuple[list[Stream], float]:
    """The streams of one call to `caller`: a non-empty list of uniquely named `Stream` objects (and
    `EventStream` objects when ``events_ok``) on one time base. Returns them and the time tolerance
    used (s)."""
    streams = stream_list(streams, caller, events_ok=events_ok)
    names = [s.name for s in streams]
    if len(set(names)) != len(names):
        dup = sorted({n for n in names if names.count(n) > 1})
        fail(f"{caller}(streams=...)", f"hold streams of unique names, got {dup} more than once")
    return streams, check_shared_time_base(streams, config)


def segment_streams(
    streams: Sequence[Stream | EventStream], config: SegmentationConfig | None = None
) -> SegmentationResult:
    """Segment one demonstration from its named streams (all sharing one time base of T frames):
    `Stream` objects give keypoints from their jerk, `EventStream` objects at their given events.

    Raises ValueError for: no streams, duplicate names, differing T or sample times, all weights 0,
    streams shorter than the window, duplicated timestamps with duplicate_times="raise" (NaN/inf and
    decreasing times are caught when each `Stream` is built).
    """
    config = check_config(config, "segment_streams")
    streams, tolerance = checked_streams(streams, config, "segment_streams", events_ok=True)
    weights = np.array([s.weight for s in streams])
    if not (weights > 0).any():
        fail(
            "segment_streams(streams=...)",
            f"give at least one stream a weight > 0, got all weights 0 ({[s.name for s in streams]})",
        )
    per_stream, pmfs, floors = _stream_results(streams, config)
    pmf, floor_level = _combine(pmfs, floors, weights, config.mode)
    n_frames = pmf.size
    draws = None
    if config.changepoints == "sample":
        candidates, draws = _sample(pmf, config.rng(), config.n_samples, config.n_pass, config.window)
    else:
        candidates = _peaks(pmf, floor_level, config.peak_ratio, config.window)
    strength = pmf[np.clip(candidates, 0, n_frames - 1)]
    changepoints, rejected = _min_segment_length(candidates, strength, n_frames, config.min_segment_frames)
    return SegmentationResult(
        changepoints=changepoints,
        pmf=pmf,
        floor_level=floor_level,
        keypoints={name: r.keypoints for name, r in per_stream.items()},
        streams=per_stream,
        candidates=candidates,
        rejected=rejected,
        draws=draws,
        time_tolerance=tolerance,
        config=config,
    )


def _stream_results(
    streams: list[Stream | EventStream], config: SegmentationConfig
) -> tuple[dict[str, StreamResult], np.ndarray, np.ndarray]:
    """Per stream: keypoints, pmf and diagnostics; the pmfs (n, T) and their floor levels (n,)."""
    n_frames = streams[0].n_frames
    per_stream: dict[str, StreamResult] = {}
    pmfs = np.empty((len(streams), n_frames))
    floors = np.empty(len(streams))
    for i, s in enumerate(streams):  # streams, not samples
        if isinstance(s, EventStream):
            keypoints = s.keypoints()
            found = StreamAnalysis(keypoints, np.zeros(0), keypoints.size == 0, None)
            sigma, threshold = s.sigma_frames(config.sigma_frames), float("nan")
        else:
            found = _analyse(s, config)
            sigma, threshold = config.sigma_frames, s.threshold
        pmfs[i], floors[i] = _stream_pmf(found.keypoints, n_frames, sigma, config.floor)
        per_stream[s.name] = StreamResult(
            name=s.name,
            weight=s.weight,
            threshold=threshold,
            keypoints=found.keypoints,
            pmf=pmfs[i],
            floor_level=float(floors[i]),
            signal=found.signal,
            flat=found.flat,
            time_repair=found.time_repair,
            used=bool(s.weight > 0),
        )
    return per_stream, pmfs, floors
