"""Reference events of a grasp demonstration, read off its gripper and finger-force arrays.

Used to score changepoints (`evaluation.py`) on the GBTI grasping demonstrations, where no
hand-labelled segmentation exists but the grasp itself leaves unambiguous marks. Pure NumPy (floor 1).
All inputs live on one time base of T frames (`times` (T,) s, strictly increasing).

Event kinds:

- ``"close"`` — the gripper starts to close. The opening g (0 open .. 1 closed) is normalised per demo,
  g_n = (g − open level) / (closed level − open level), with open / closed levels the 1st / 99th
  percentiles of g. The gripper is *closed* while g_n >= ``closed_fraction`` (0.5); closed intervals
  shorter than ``min_hold_s`` are ignored (debounce). The event is the last frame before the rising
  crossing with g_n <= ``onset_fraction`` (0.1): where the closing motion starts, not where it ends.
- ``"open"`` — the gripper starts to open: the last frame of the closed interval with
  g_n >= (plateau − ``onset_fraction``), plateau = the median g_n over that interval (the fingers
  stop at the object, so the plateau differs per object: 0.40–0.45 of full scale for the cube,
  0.68–0.99 for the plate). A closed interval that lasts to the end of the recording gives no open event.
- ``"contact"`` — finger contact onset: the first frame, searched from the end of the previous closed
  interval (or frame 0) to the end of this one, that starts a run of at least ``min_hold_s`` with the
  finger force at or above baseline + max(``contact_fraction`` · rise, ``noise_multiple`` · noise).
  baseline = median finger force over the frames where the gripper is open; noise = 1.4826 · MAD over
  the same frames; rise = median over the closed frames − baseline. Only when the finger force shows
  a grasp at all: rise >= ``min_contrast`` · noise (and rise > 0). Otherwise the demo has no contact
  events and `ReferenceEvents.finger_force_ok` is False, with the contrast in `contact_contrast`.
  The sensor reads raw counts of either sign: a grasp that *lowers* the reading is not a contact here.

Why these thresholds (measured on the 60 GBTI demos resampled to 1000 points,
`python -m experiments.gbti_segmentation` records the per-demo events, gripper span and contrast in
`results/segmentation.json`):
- Gripper: counts are integers 0..100, exactly 1 at rest, the closing ramp lasts 10–30 frames.
  ``onset_fraction`` 0.05 instead of 0.1 moves close / open onsets by 0 to −6 frames, 0.3 by +2 to
  +14 (median 6); 0.1 leaves 2 counts of margin over the quantisation for the cube (span 40–45 counts).
- Finger force contrast rise/noise is bimodal: 0 for the five Mug/User4 demos (the reading sits at a
  constant −645 counts with sparse spikes up to ~27000: an unusable channel), 3.4 for
  Cube/User1/Position5 (a 5-count rise: presumably the sensing finger did not touch the cube), and 12 or
  more for the other 54. ``min_contrast`` = 8 sits in the gap.
- Contact onset at 0.2 of the rise (and at least 4 noise std): the force steps up within 5–15 frames,
  so ``contact_fraction`` 0.1 moves the onset by 0 to −5 frames and 0.5 by 0 to +10; 0.2 marks the
  start of the step. ``min_contrast`` 4–11 and ``min_hold_s`` 0.1–0.5 s give the same events. The onset
  follows the gripper's close onset by 9–50 frames (median 24) in 53 of the 54 demos with contact, i.e.
  it is the moment the closing fingers reach the object; in Plate/User1/Position4 the force builds
  slowly during the hold and 0.2 of the rise is reached 116 frames after the close onset.

Closely spaced events (close and contact are usually < 64 frames apart) are kept as separate events
here; `merge_events` groups them when one changepoint is meant to explain both.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import check_array, check_choice, check_int_array, check_real, fail

EVENT_KINDS: tuple[str, ...] = ("close", "open", "contact")


@dataclass(frozen=True)
class EventThresholds:
    """Thresholds of `reference_events` (see the module doc for how each was chosen).

    closed_fraction:  g_n at or above this means closed (0.5)
    onset_fraction:   close onset: g_n <= this; open onset: g_n >= plateau − this (0.1)
    min_hold_s:       a closed interval / a finger-force run above level must last this long (0.25 s)
    min_span:         gripper events need (closed − open level) >= this, in units of full scale (0.05)
    min_contrast:     finger force needs rise >= min_contrast · noise to give contact events (8.0)
    contact_fraction: contact level = baseline + this · rise ... (0.2)
    noise_multiple:   ... but at least baseline + this · noise (4.0)
    """

    closed_fraction: float = 0.5
    onset_fraction: float = 0.1
    min_hold_s: float = 0.25
    min_span: float = 0.05
    min_contrast: float = 8.0
    contact_fraction: float = 0.2
    noise_multiple: float = 4.0

    def __post_init__(self) -> None:
        name = "EventThresholds."
        closed = check_real(
            name + "closed_fraction", self.closed_fraction, low=0.0, high=1.0, low_open=True, high_open=True
        )
        check_real(
            name + "onset_fraction", self.onset_fraction, low=0.0, high=closed, low_open=True, high_open=True
        )
        check_real(name + "min_hold_s", self.min_hold_s, low=0.0, unit="s")
        check_real(name + "min_span", self.min_span, low=0.0, low_open=True)
        check_real(name + "min_contrast", self.min_contrast, low=0.0, low_open=True)
        check_real(
            name + "contact_fraction", self.contact_fraction, low=0.0, high=1.0, low_open=True, high_open=True
        )
        check_real(name + "noise_multiple", self.noise_multiple, low=0.0)


@dataclass(frozen=True, eq=False)
class GripperIntervals:
    """Closed intervals of the gripper: [start, stop) frames where g_n >= closed_fraction (debounced).

    starts, stops: (K,) int64; close_onsets (K,) frames where closing began; open_onsets (K,) frames where
    opening began, -1 for an interval that lasts to the end; span: closed − open level; ok: span >= min_span.
    """

    starts: np.ndarray
    stops: np.ndarray
    close_onsets: np.ndarray
    open_onsets: np.ndarray
    normalised: np.ndarray
    span: float
    ok: bool


@dataclass(frozen=True, eq=False)
class ReferenceEvents:
    """Reference events of one demo.

    frames:  (E,) int64 event frames, sorted (ties ordered by kind as in EVENT_KINDS)
    kinds:   (E,) str event kinds, one of EVENT_KINDS
    times:   (E,) s, `times[frames]`
    gripper_ok, finger_force_ok: whether each signal could give events (see EventThresholds)
    gripper_span:     closed − open level of the gripper (fraction of full scale)
    contact_contrast: finger-force rise / noise (0.0 when the noise is zero and there is no rise)
    closed_intervals: (K, 2) [start, stop) frames where the gripper is closed
    """

    frames: np.ndarray
    kinds: np.ndarray
    times: np.ndarray
    gripper_ok: bool
    finger_force_ok: bool
    gripper_span: float
    contact_contrast: float
    closed_intervals: np.ndarray

    def of_kind(self, kind: str) -> np.ndarray:
        """Frames of the events of one kind."""
        check_choice("kind", kind, EVENT_KINDS)
        return self.frames[self.kinds == kind]


def _check_series(name: str, values: object, n: int) -> np.ndarray:
    """A finite (n,) float series ((n, 1) reads as (n,))."""
    v = check_array(name, values, finite=False)
    if v.ndim == 2 and v.shape[1] == 1:
        v = v[:, 0]
    if v.shape != (n,):
        fail(name, f"have shape ({n},) to match times, got shape {np.shape(values)}")
    return check_array(name, v, axes=("frame",))


def _check_times(times: object) -> np.ndarray:
    """Finite, strictly increasing (T,) seconds with T >= 2."""
    t = check_array("times", times, ndim=1, min_len=2, axes=("frame",))
    dt = np.diff(t)
    if (dt <= 0).any():
        i = int(np.argmax(dt <= 0)) + 1
        fail("times", f"be strictly increasing, got {t[i - 1]:.6f} s -> {t[i]:.6f} s at frame {i}")
    return t


def _thresholds(thresholds: object) -> EventThresholds:
    if thresholds is None:
        return EventThresholds()
    if not isinstance(thresholds, EventThresholds):
        fail("thresholds", f"be EventThresholds or None, got {type(thresholds).__name__}")
    return thresholds


def runs(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """[start, stop) frames of the runs of True in a boolean (T,) array; two (R,) int64 arrays."""
    edges = np.diff(np.concatenate(([False], np.asarray(mask, dtype=bool), [False])).astype(np.int8))
    return np.flatnonzero(edges == 1).astype(np.int64), np.flatnonzero(edges == -1).astype(np.int64)


def _last_true_before(mask: np.ndarray, frames: np.ndarray) -> np.ndarray:
    """For each frame f: the largest i < f with mask[i] (or -1 when none)."""
    idx = np.where(mask, np.arange(mask.size), -1)
    last = np.maximum.accumulate(idx)
    f = np.asarray(frames, dtype=np.int64)
    return np.where(f > 0, last[np.maximum(f - 1, 0)], -1)


def _hold_frames(times: np.ndarray, hold_s: float) -> int:
    """`hold_s` in frames at the median frame period (at least 1)."""
    return max(1, int(round(hold_s / float(np.median(np.diff(times))))))


def gripper_intervals(
    times: np.ndarray, gripper: np.ndarray, thresholds: EventThresholds | None = None
) -> GripperIntervals:
    """Closed intervals and close / open onsets of the gripper opening (T,) (0 open .. 1 closed) at
    times (T,) s, strictly increasing."""
    t = _check_times(times)
    return _gripper_intervals(t, _check_series("gripper", gripper, t.size), _thresholds(thresholds))


def _gripper_intervals(t: np.ndarray, g: np.ndarray, th: EventThresholds) -> GripperIntervals:
    """:func:`gripper_intervals` of checked inputs."""
    lo, hi = np.percentile(g, [1.0, 99.0])
    span = float(hi - lo)
    empty = np.zeros(0, dtype=np.int64)
    if span < th.min_span:
        return GripperIntervals(empty, empty, empty, empty, np.zeros_like(g), span, False)
    gn = (g - lo) / span
    starts, stops = runs(gn >= th.closed_fraction)
    hold = _hold_frames(t, th.min_hold_s)
    keep = (stops - starts) >= hold
    starts, stops = starts[keep], stops[keep]
    # Close onset: last open-ish frame before the rising crossing (0 when it was never open before).
    close = _last_true_before(gn <= th.onset_fraction, starts)
    close = np.where(close < 0, 0, close)
    # Open onset: last frame of the interval at its plateau level (interval ending at T: none).
    # (Loops below run over closed intervals, a handful per demo, not over samples.)
    plateau = np.array([np.median(gn[a:b]) for a, b in zip(starts, stops, strict=True)])
    open_ = np.full(starts.size, -1, dtype=np.int64)
    for k, (a, b) in enumerate(zip(starts.tolist(), stops.tolist(), strict=True)):
        if b >= g.size:
            continue
        at_plateau = np.flatnonzero(gn[a:b] >= plateau[k] - th.onset_fraction)
        open_[k] = a + int(at_plateau[-1]) if at_plateau.size else a
    return GripperIntervals(starts, stops, close.astype(np.int64), open_, gn, span, True)


def contact_onsets(
    times: np.ndarray,
    finger_force: np.ndarray,
    intervals: GripperIntervals,
    thresholds: EventThresholds | None = None,
) -> tuple[np.ndarray, bool, float]:
    """Finger contact onsets, one per closed interval at most: (frames (C,), finger_force_ok, contrast).

    times (T,) s strictly increasing; finger_force (T,) raw reading; intervals from `gripper_intervals`
    of the same times."""
    t = _check_times(times)
    f = _check_series("finger_force", finger_force, t.size)
    if not isinstance(intervals, GripperIntervals) or intervals.normalised.shape != t.shape:
        fail("intervals", f"be the GripperIntervals of these {t.size} frames (see gripper_intervals)")
    return _contact_onsets(t, f, intervals, _thresholds(thresholds))


def _contact_onsets(
    t: np.ndarray, f: np.ndarray, intervals: GripperIntervals, th: EventThresholds
) -> tuple[np.ndarray, bool, float]:
    """:func:`contact_onsets` of checked inputs."""
    empty = np.zeros(0, dtype=np.int64)
    if not intervals.ok or intervals.starts.size == 0:
        return empty, False, 0.0
    closed = np.zeros(f.size, dtype=bool)
    for a, b in zip(intervals.starts.tolist(), intervals.stops.tolist(), strict=True):
        closed[a:b] = True
    if closed.all():
        return empty, False, 0.0
    open_f = f[~closed]
    baseline = float(np.median(open_f))
    noise = 1.4826 * float(np.median(np.abs(open_f - baseline)))
    rise = float(np.median(f[closed])) - baseline
    contrast = rise / noise if noise > 0 else (np.inf if rise > 0 else 0.0)
    if not (rise > 0 and contrast >= th.min_contrast):
        return empty, False, float(contrast)
    level = baseline + max(th.contact_fraction * rise, th.noise_multiple * noise)
    hold = _hold_frames(t, th.min_hold_s)
    run_starts, run_stops = runs(f >= level)
    long_enough = (run_stops - run_starts) >= hold
    run_starts = run_starts[long_enough]
    onsets = []
    search_from = 0
    for b in intervals.stops.tolist():  # grasps, not samples
        hit = run_starts[(run_starts >= search_from) & (run_starts < b)]
        if hit.size:
            onsets.append(int(hit[0]))
        search_from = b
    return np.asarray(onsets, dtype=np.int64), True, float(contrast)


def reference_events(
    times: np.ndarray,
    gripper: np.ndarray,
    finger_force: np.ndarray | None = None,
    thresholds: EventThresholds | None = None,
) -> ReferenceEvents:
    """Close, open and contact-onset events of one demo (see the module doc).

    times (T,) s strictly increasing; gripper (T,) opening 0 open .. 1 closed; finger_force (T,) raw
    reading or None. Raises ValueError naming the array for a wrong shape, NaN/inf or non-increasing times.
    """
    th = _thresholds(thresholds)
    t = _check_times(times)
    iv = _gripper_intervals(t, _check_series("gripper", gripper, t.size), th)
    frames = [iv.close_onsets, iv.open_onsets[iv.open_onsets >= 0]]
    kinds = [np.full(frames[0].size, "close"), np.full(frames[1].size, "open")]
    finger_ok, contrast = False, 0.0
    if finger_force is not None:
        f = _check_series("finger_force", finger_force, t.size)
        contact, finger_ok, contrast = _contact_onsets(t, f, iv, th)
        frames.append(contact)
        kinds.append(np.full(contact.size, "contact"))
    all_frames = np.concatenate(frames).astype(np.int64)
    all_kinds = np.concatenate(kinds).astype("<U8") if all_frames.size else np.zeros(0, dtype="<U8")
    rank = np.array([EVENT_KINDS.index(k) for k in all_kinds], dtype=np.int64)
    order = np.lexsort((rank, all_frames))
    all_frames, all_kinds = all_frames[order], all_kinds[order]
    return ReferenceEvents(
        frames=all_frames,
        kinds=all_kinds,
        times=t[all_frames],
        gripper_ok=iv.ok,
        finger_force_ok=finger_ok,
        gripper_span=iv.span,
        contact_contrast=float(contrast),
        closed_intervals=np.stack([iv.starts, iv.stops], axis=1)
        if iv.starts.size
        else np.zeros((0, 2), np.int64),
    )


def merge_events(frames: np.ndarray, within: float) -> np.ndarray:
    """Group sorted event frames whose consecutive gaps are <= `within` frames; each group -> the
    rounded mean of its frames. (E,) -> (E',) int64 sorted.

    A grasp's close onset and contact onset lie 9–53 frames apart on the GBTI demos: a segmentation
    that puts one boundary at the grasp has found that event, and should not be asked for two
    boundaries closer than its own resolution.
    """
    within = check_real("within", within, low=0.0)
    f = np.sort(check_int_array("frames", frames))
    if f.size == 0:
        return f
    group = np.concatenate(([0], np.cumsum(np.diff(f) > within)))
    sums = np.bincount(group, weights=f.astype(np.float64))
    counts = np.bincount(group)
    return np.floor(sums / counts + 0.5).astype(np.int64)
