"""Time-base checks and the duplicated-timestamp repair (a guard against zero time steps).

A zero time step makes a finite-difference jerk infinite/NaN and distorts a Savitzky–Golay jerk
(the filter assumes evenly spaced samples). One GBTI demo, upsampled from 941 to 1000 points,
repeats its first sample 59 times. The repair: a sample whose time equals the previous sample's is
dropped before the derivative is taken (the first of each run of equal times is kept), keypoints
found on the remaining samples are mapped back to original frame indices, and the repair is
reported (`TimeRepair` in the result and a `TimeRepairWarning`). Decreasing times are an error
(raised by `Stream`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from .._validation import fail
from .config import SegmentationConfig, Stream


class TimeRepairWarning(UserWarning):
    """Samples with duplicated timestamps were merged before taking derivatives."""


class UnevenTimeWarning(UserWarning):
    """Gaps in a stream's sample times: the Savitzky–Golay jerk takes the samples as evenly spaced."""


#: a time step this many times the median is a gap (dropped samples), not recorder jitter: the lab
#: recordings and the GBTI demos have single late samples (up to 2.3x) but none at 3x
GAP_RATIO = 3.0


def _odd_steps(
    times: np.ndarray, frames: np.ndarray | None, ratio: float, longer: bool
) -> tuple[int, float, float, int] | None:
    """Time steps longer (or shorter) than ``ratio`` times the median: (how many, the median, the most
    extreme step, the original frame after it), or None when there are none.

    times (n,) increasing; frames (n,) their original frame indices (None: 0..n-1)."""
    dt = np.diff(times)
    median = float(np.median(dt))
    odd = np.flatnonzero(dt > ratio * median if longer else dt < ratio * median)
    if not odd.size:
        return None
    worst = int(odd[np.argmax(dt[odd]) if longer else np.argmin(dt[odd])])
    frame = int(worst + 1 if frames is None else frames[worst + 1])
    return int(odd.size), median, float(dt[worst]), frame


def warn_uneven_spacing(name: str, times: np.ndarray, frames: np.ndarray | None = None) -> None:
    """A `UnevenTimeWarning` when a time step exceeds `GAP_RATIO` times the median one.

    times (n,) increasing; frames (n,) their original frame indices (None: 0..n-1)."""
    found = _odd_steps(times, frames, GAP_RATIO, longer=True)
    if found is None:
        return
    count, median, step, frame = found
    warnings.warn(
        f"stream {name!r}: {count} time step(s) longer than {GAP_RATIO:g}x the median"
        f" ({median * 1e3:.3g} ms), the longest {step / median:.1f}x before frame {frame}; the"
        " Savitzky-Golay jerk (derivative='savgol') takes samples as evenly spaced, so the jerk across a"
        " gap is wrong: resample the stream onto an even time base, or use derivative='difference'",
        UnevenTimeWarning,
        stacklevel=3,
    )


#: a time step below this fraction of the median is a near-duplicate timestamp: not merged (the
#: samples are distinct), but its finite differences dwarf the rest of the jerk
SHORT_STEP_RATIO = 1e-3


def warn_short_steps(name: str, times: np.ndarray, frames: np.ndarray | None = None) -> None:
    """A `UnevenTimeWarning` when a (non-zero) time step is below `SHORT_STEP_RATIO` times the median.

    times (n,) increasing; frames (n,) their original frame indices (None: 0..n-1)."""
    found = _odd_steps(times, frames, SHORT_STEP_RATIO, longer=False)
    if found is None:
        return
    count, median, step, frame = found
    warnings.warn(
        f"stream {name!r}: {count} time step(s) shorter than {SHORT_STEP_RATIO:g}x the median"
        f" ({median * 1e3:.3g} ms), the shortest {step:.3g} s before frame {frame}; a near-duplicate"
        " timestamp makes the jerk there spike and can move the keypoints: fix the recording's clock, or"
        " give both samples the same time (merged as a duplicate)",
        UnevenTimeWarning,
        stacklevel=3,
    )


@dataclass(frozen=True, eq=False)
class TimeRepair:
    """What the duplicated-timestamp repair did to one stream.

    kept_frames:      (T',) original frame indices of the samples the derivative used
    dropped_frames:   (T - T',) original frame indices that repeated the previous sample's time
    max_value_change: largest |value difference| between a dropped sample and the kept sample it
                      repeats (0.0 when the duplicates are exact copies, as in the GBTI demo)
    """

    kept_frames: np.ndarray
    dropped_frames: np.ndarray
    max_value_change: float

    @property
    def n_dropped(self) -> int:
        return int(self.dropped_frames.size)


def repair_duplicate_times(stream: Stream, config: SegmentationConfig) -> TimeRepair | None:
    """Find samples whose time equals the previous sample's; None when there are none.

    Raises ValueError (naming the stream and frame) when `config.duplicate_times == "raise"`.
    Emits a `TimeRepairWarning` when it merges.
    """
    duplicate = np.diff(stream.times) == 0.0  # (T-1,): frame i+1 repeats frame i's time
    if not duplicate.any():
        return None
    dropped = np.flatnonzero(duplicate) + 1
    if config.duplicate_times == "raise":
        fail(
            f"Stream({stream.name!r}).times",
            "hold no duplicated timestamp with SegmentationConfig.duplicate_times='raise', got one at "
            f"frame {int(dropped[0])} (t = {stream.times[dropped[0]]:.9f} s, {dropped.size} duplicated "
            "frames in all)",
        )
    keep = np.ones(stream.n_frames, dtype=bool)
    keep[dropped] = False
    kept = np.flatnonzero(keep)
    # The kept sample each dropped one repeats: the last kept frame at or before it.
    source = kept[np.searchsorted(kept, dropped, side="right") - 1]
    max_change = float(np.abs(stream.values[dropped] - stream.values[source]).max())
    warnings.warn(
        f"stream {stream.name!r}: {dropped.size} samples repeat the previous sample's timestamp"
        f" (first at frame {int(dropped[0])}); they were left out of the derivative"
        f" (largest value change among them {max_change:.3g})",
        TimeRepairWarning,
        stacklevel=3,
    )
    return TimeRepair(kept_frames=kept, dropped_frames=dropped, max_value_change=max_change)


def check_shared_time_base(streams: Sequence[Stream], config: SegmentationConfig) -> float:
    """All streams must have the same T and the same sample times (within the tolerance).

    Returns the tolerance used, in seconds. Raises ValueError naming the stream and first frame.
    """
    ref = streams[0]
    if config.time_tolerance is not None:
        tolerance = float(config.time_tolerance)
    else:
        dt = np.diff(ref.times)
        positive = dt[dt > 0]
        tolerance = 2.0 * float(np.median(positive)) if positive.size else 0.0
    for s in streams[1:]:
        name = f"Stream({s.name!r}).times"
        share = f"share the time base of Stream({ref.name!r}) (interpolate the streams onto one)"
        if s.n_frames != ref.n_frames:
            fail(name, f"{share}, got {s.n_frames} samples against {ref.n_frames}")
        off = np.abs(s.times - ref.times)
        if (off > tolerance).any():
            frame = int(np.argmax(off > tolerance))
            fail(
                name,
                f"{share}, got a sample time at frame {frame} that differs by {off[frame]:.6f} s (tolerance "
                f"{tolerance:.6f} s)",
            )
    return tolerance
