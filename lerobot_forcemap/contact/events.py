"""Contact events of a tool pressing on surfaces below it: touch-down and lift-off times.

Two detectors, one per kind of recording:

- :func:`detect_contacts` (kinesthetic recordings, where a hand on the tool makes the force useless as
  a contact test): from the kinematics and the short transients of the force. Touch-down is an impact:
  the surface stops the descending tool (an upward deceleration) and the force jumps upward within a
  few tens of milliseconds; the tool then dwells at that height. Lift-off is the last sample within
  ``lift_m`` of the dwell height before the tool rises more than ``leave_m`` above it for good (it has
  no force signature: the hand unloads the contact gradually).
- :func:`force_intervals` (no hand on the tool: simulation, teleoperation): the force's norm above a
  threshold.

Frames: positions in the base frame with +z up (the surfaces are below the tool: tables, buttons,
boards); the force is the reaction on the robot, tared. Times are seconds on the recording's clock.
Both run at the recording's source rate: an impact lasts 20-50 ms and loses most of its height when the
signal is first resampled to 20-50 Hz.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import partial

import numpy as np
from numpy.typing import NDArray
from scipy.signal import find_peaks

from lerobot_forcemap._validation import check_array, check_fields, check_real, fail
from lerobot_forcemap.contact.kinematics import sample_rate, smooth_derivatives, transient

__all__ = [
    "DetectorSettings",
    "ContactEvents",
    "detect_contacts",
    "force_intervals",
    "intervals_to_mask",
    "mask_to_intervals",
    "event_errors",
    "check_motion",
    "check_signals",
]

F64 = NDArray[np.float64]
_POSITIVE = partial(check_real, low=0.0, low_open=True)


@dataclass(frozen=True)
class DetectorSettings:
    """Settings of :func:`detect_contacts` (SI units; every window in seconds).

    deriv_window_s: Savitzky-Golay window of the vertical velocity and acceleration;
    min_decel (m/s²): an impact decelerates the descending tool at least this much (upward a_z);
    min_force_n (N): ... while the force's z transient (minus its running median over
    ``force_window_s``) rises at least this much within ``coincide_s`` of it;
    peak_gap_s: impact candidates (peaks of a_z) at least this far apart;
    approach_speed (m/s), approach_s: the tool descended at least this fast in the ``approach_s`` before;
    dwell_s, dwell_band_m: after touch-down it stays within ``dwell_band_m`` of that height for ``dwell_s``
    (a surface, not the turning point of a free motion);
    settle_s: the dwell height is the median height from ``settle_s`` after touch-down until the tool
    leaves the dwell (rises ``leave_m`` above it); lift-off is the last sample within ``lift_m`` of it;
    below_m: the surface holds the tool: it never sinks more than this under the touch-down height;
    merge_s: impacts inside a contact or within this time after its lift-off are part of it.
    """

    deriv_window_s: float = 0.1
    min_decel: float = 0.75
    min_force_n: float = 12.0
    force_window_s: float = 0.2
    coincide_s: float = 0.06
    peak_gap_s: float = 0.05
    approach_speed: float = 0.02
    approach_s: float = 0.15
    dwell_s: float = 0.15
    dwell_band_m: float = 0.008
    settle_s: float = 0.05
    leave_m: float = 0.010
    lift_m: float = 0.002
    below_m: float = 0.010
    merge_s: float = 0.3

    def __post_init__(self) -> None:
        check_fields(type(self).__name__, self, dict.fromkeys(DETECTOR_FIELDS, _POSITIVE))


DETECTOR_FIELDS = tuple(DetectorSettings.__dataclass_fields__)


@dataclass(frozen=True)
class ContactEvents:
    """Contact intervals: ``touch_down (K,)`` and ``lift_off (K,)`` in s, sorted, ``touch_down[k] <
    lift_off[k] <= touch_down[k + 1]``; ``impacts``: every impact candidate that passed the deceleration
    and force tests (s), whether a dwell followed or not (diagnostics)."""

    touch_down: F64
    lift_off: F64
    impacts: F64 = field(default_factory=lambda: np.zeros(0))

    @property
    def intervals(self) -> F64:
        """``(K, 2)`` [touch-down, lift-off] rows, s."""
        return np.stack([self.touch_down, self.lift_off], axis=1).reshape(-1, 2)

    def __len__(self) -> int:
        return len(self.touch_down)


def check_motion(times: object, positions: object) -> tuple[F64, F64]:
    """``times (T,)`` s strictly increasing (T >= 5) and ``positions (T, 3)`` m as finite float64
    arrays; errors name the argument and frame."""
    t = check_array("times", times, ndim=1, axes=("frame",))
    if len(t) < 5:
        fail("times", "hold at least 5 samples", len(t))
    if not (np.diff(t) > 0).all():
        frame = int(np.argmax(np.diff(t) <= 0)) + 1
        fail("times", f"increase strictly (frame {frame} does not)", float(t[frame]))
    return t, check_array("positions", positions, shape=(len(t), 3))


def check_signals(times: object, positions: object, force: object) -> tuple[F64, F64, F64]:
    """:func:`check_motion` and ``force (T, k >= 3)`` N, finite (its first 3 columns returned)."""
    t, p = check_motion(times, positions)
    f = check_array("force", force, ndim=2)
    if f.shape[0] != len(t) or f.shape[1] < 3:
        fail("force", f"have shape ({len(t)}, >= 3)", f.shape)
    return t, p, f[:, :3]


def detect_contacts(
    times: object, positions: object, force: object, settings: DetectorSettings | None = None
) -> ContactEvents:
    """Touch-downs and lift-offs of a tool on surfaces below it (module docstring), from the
    kinematics and the measured force's short upward transients.

    times (T,) s, positions (T, 3) m (base frame, +z up), force (T, >= 3) N (reaction on the robot;
    only its z transients are used, so a guiding hand's slow force does not matter).
    """
    t, p, f = check_signals(times, positions, force)
    s = settings if settings is not None else DetectorSettings()
    if not isinstance(s, DetectorSettings):
        fail("settings", "be a DetectorSettings or None", type(s).__name__)
    return _detect(t, p[:, 2], f[:, 2], s)


def _detect(t: F64, z: F64, fz: F64, s: DetectorSettings) -> ContactEvents:
    """:func:`detect_contacts` of checked inputs (z, fz: the vertical position and force)."""
    rate = sample_rate(t)
    vel, acc = smooth_derivatives(t, z[:, None], s.deriv_window_s)
    vz, az = vel[:, 0], acc[:, 0]
    candidates = _impacts(t, az, fz, rate, s)
    n_dwell = max(1, int(round(s.dwell_s * rate)))
    n_approach = max(1, int(round(s.approach_s * rate)))
    settle = int(round(s.settle_s * rate))
    touch_down, lift_off = [], []
    end = -np.inf
    for i in candidates.tolist():  # a handful of impacts per recording
        if t[i] <= end + s.merge_s:
            continue
        dwell = z[i : i + n_dwell]
        if len(dwell) < n_dwell or np.abs(dwell - z[i]).max() > s.dwell_band_m:
            continue
        if vz[max(i - n_approach, 0) : i + 1].min() > -s.approach_speed:
            continue
        j = _lift_off_index(z, i, n_dwell, settle, s)
        if z[i : j + 1].min() < z[i] - s.below_m:
            continue
        touch_down.append(t[i])
        lift_off.append(t[j])
        end = t[j]
    return ContactEvents(np.asarray(touch_down), np.asarray(lift_off), t[candidates])


def _impacts(t: F64, az: F64, fz: F64, rate: float, s: DetectorSettings) -> NDArray[np.int64]:
    """Frames of the upward-acceleration peaks >= ``min_decel`` that have an upward force transient
    >= ``min_force_n`` within ``coincide_s``."""
    jump = transient(t, fz, s.force_window_s)
    near = max(1, int(round(s.coincide_s * rate)))
    padded = np.pad(jump, near, mode="edge")
    jump_near = np.lib.stride_tricks.sliding_window_view(padded, 2 * near + 1).max(axis=1)
    peaks, _ = find_peaks(az, height=s.min_decel, distance=max(1, int(round(s.peak_gap_s * rate))))
    return peaks[jump_near[peaks] >= s.min_force_n].astype(np.int64)


def _lift_off_index(z: F64, i: int, n_dwell: int, settle: int, s: DetectorSettings) -> int:
    """The lift-off frame of the contact that touched down at frame ``i``.

    The dwell height and the frame where the tool leaves it depend on each other: start from the median
    over the dwell test's window and refine three times (it settles in one or two)."""
    height = float(np.median(z[min(i + settle, len(z) - 1) : i + n_dwell]))
    leave = len(z) - 1
    for _ in range(3):
        above = np.flatnonzero(z[i:] > height + s.leave_m)
        leave = i + int(above[0]) if len(above) else len(z) - 1
        height = float(np.median(z[min(i + settle, leave - 1) : leave]))
    low = np.flatnonzero(z[i:leave] <= height + s.lift_m)
    return i + (int(low[-1]) if len(low) else 0)


def force_intervals(
    times: object,
    force: object,
    *,
    threshold_n: float = 2.0,
    min_duration_s: float = 0.05,
    merge_gap_s: float = 0.1,
) -> ContactEvents:
    """Contacts of a recording without a hand on the tool: runs of ``|force| > threshold_n`` N lasting
    at least ``min_duration_s``, gaps shorter than ``merge_gap_s`` bridged. times (T,) s, force (T, >= 3)."""
    t = check_array("times", times, ndim=1, axes=("frame",))
    f = check_array("force", force, ndim=2)
    if f.shape[0] != len(t) or f.shape[1] < 3:
        fail("force", f"have shape ({len(t)}, >= 3)", f.shape)
    check_real("threshold_n", threshold_n, low=0.0, unit="N")
    check_real("min_duration_s", min_duration_s, low=0.0, unit="s")
    check_real("merge_gap_s", merge_gap_s, low=0.0, unit="s")
    iv = mask_to_intervals(t, np.linalg.norm(f[:, :3], axis=1) > threshold_n)
    if len(iv) > 1:
        gap = iv[1:, 0] - iv[:-1, 1]
        keep = np.concatenate([[True], gap >= merge_gap_s])
        starts = iv[keep, 0]
        stops = iv[np.concatenate([keep[1:], [True]]), 1]
        iv = np.stack([starts, stops], axis=1)
    iv = iv[iv[:, 1] - iv[:, 0] >= min_duration_s]
    return ContactEvents(iv[:, 0].copy(), iv[:, 1].copy())


def intervals_to_mask(times: F64, intervals: F64, pad_s: float = 0.0) -> NDArray[np.bool_]:
    """``(T,)`` bool: True at the times inside any ``[start - pad_s, stop + pad_s]`` of ``intervals (K, 2)``."""
    times = np.asarray(times, dtype=np.float64)
    mask = np.zeros(len(times), dtype=bool)
    for start, stop in np.asarray(intervals, dtype=np.float64).reshape(-1, 2):  # a handful of contacts
        mask |= (times >= start - pad_s) & (times <= stop + pad_s)
    return mask


def mask_to_intervals(times: F64, mask: NDArray[np.bool_]) -> F64:
    """``(K, 2)`` [first, last] times of the runs of True in ``mask (T,)`` (inverse of
    :func:`intervals_to_mask` on the same times)."""
    edges = np.diff(np.concatenate([[False], np.asarray(mask, dtype=bool), [False]]).astype(np.int8))
    starts = np.flatnonzero(edges == 1)
    stops = np.flatnonzero(edges == -1) - 1
    times = np.asarray(times, dtype=np.float64)
    return np.stack([times[starts], times[stops]], axis=1).reshape(-1, 2)


def event_errors(found: object, wanted: object) -> F64:
    """For each wanted event time ``(E,)`` s, the signed time of the nearest found one minus it (NaN when
    none is found)."""
    found = np.asarray(found, dtype=np.float64).reshape(-1)
    wanted = np.asarray(wanted, dtype=np.float64).reshape(-1)
    if found.size == 0:
        return np.full(wanted.shape, np.nan)
    d = found[None, :] - wanted[:, None]
    return d[np.arange(len(wanted)), np.argmin(np.abs(d), axis=1)]
