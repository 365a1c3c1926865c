"""From a raw :class:`~lerobot_forcemap.data.recorder.Recording` to aligned, tared, base-frame arrays.

Steps, in this order (each a pure function on arrays):

1. :func:`clean_times` per stream: consecutive samples with the *same* timestamp are collapsed to one
   (their mean), counted in the diagnostics and warned about; a timestamp that goes *backwards*
   raises ``ValueError`` naming the stream and the sample index.
2. :func:`tare_wrench` in the **tool frame**: subtract the free-space sensor bias, estimated as the
   per-axis median over a quiet window of ``window_s`` (0.2 s) at the start or the end of the
   recording (``method="auto"`` takes the start window when it is quiet, else the end window when that
   is quiet, else the quieter one: a guiding hand shakes, 0.5–6 N std, a free sensor shows only its
   0.1–0.4 N noise; when start and end disagree by more than 2 N a warning says so — on the GBTI
   demos they differ by up to 17 N, which a payload-gravity model does not explain, so it is drift or
   a resting hand). Why the tool frame: on the press and erase
   recordings the rest readings at start and end agree to 0.1–1.6 N in the tool frame but differ by
   2–4 N in the base frame, while the tool turned 12–19° between them, so the bias rides with the
   sensor (UR compensates the payload itself). Kinesthetic recordings also carry the guiding hand's
   force while the robot moves: one wrist sensor cannot tell it from contact, so it stays in the
   signal (documented in the dataset card); only a hand resting on the robot in the tare window is
   avoided by the window choice.
3. :func:`wrench_to_base`: rotate force and torque with the recorded tool orientation (tool -> base,
   torque about the sensor origin, expressed in base axes), then multiply by ``sign``. The lab
   recorder already reports the wrench the environment exerts on the robot (checked on
   ``press_2023-07-27_160905.h5``: tared base-frame fz peaks at +30.6 N while the tool presses down
   on the button), so ``LAB_WRENCH_SIGN = +1``.
4. Optional zero-phase low-pass of the base-frame wrench at the source rate (anti-aliasing before
   downsampling).
5. :func:`align_recording`: every stream interpolated onto one time base inside the interval all
   streams cover (linear for vectors, SLERP for orientations).
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.signal import butter, sosfiltfilt

from lerobot_forcemap._validation import check_choice, check_int, check_real
from lerobot_forcemap.data.recorder import Recording
from lerobot_forcemap.geometry import quat_rotate, slerp_sequence

__all__ = [
    "LAB_WRENCH_SIGN",
    "GRIPPER_FULL_SCALE",
    "TARE_QUIET_STD_N",
    "STREAM_RATE_RANGE_HZ",
    "TRIM_NOTE_S",
    "TareMethod",
    "WrenchBias",
    "TimeCleaning",
    "AlignedRecording",
    "clean_times",
    "describe_gaps",
    "estimate_wrench_bias",
    "tare_wrench",
    "wrench_to_base",
    "lowpass",
    "interp_linear",
    "align_recording",
]

F64 = NDArray[np.float64]

# Sign that turns the recorder's base-frame wrench into the project's convention (reaction on the robot).
LAB_WRENCH_SIGN = 1.0
# Raw gripper reading that means fully closed (counts 0 = open .. 100 = closed; GBTI max 100, lab 90).
GRIPPER_FULL_SCALE = 100.0
# Rest windows at the start and the end whose force medians differ by more than this get a warning.
TARE_DISAGREEMENT_WARN_N = 2.0
# A rest window is "quiet" (free sensor, no hand) when its largest per-axis force std is below this.
TARE_QUIET_STD_N = 0.5
# Plausible sensor rates: a median step outside this range means timestamps in other units than seconds
# (ms, ns, µs in the nsec column), which would otherwise resample to 1000x too many or too few frames.
STREAM_RATE_RANGE_HZ = (1.0, 1e5)
# Streams that start later or end earlier than the others trim the recording to their overlap; a trim
# longer than this is reported.
TRIM_NOTE_S = 0.1

TareMethod = Literal["auto", "start", "end", "none"]
DuplicatePolicy = Literal["merge", "raise"]


@dataclass(frozen=True)
class WrenchBias:
    """Free-space bias of the wrist sensor in the tool frame and how it was estimated.

    force (3,) N, torque (3,) N·m: the subtracted bias. window: "start", "end" or "none".
    index: (first, stop) sample range used. force_std (3,): per-axis std of the force in that window.
    other_force (3,) | None: the median of the window not chosen ("auto" only); disagreement_n: the
    norm of the difference between both windows' force medians (NaN when only one was looked at).
    """

    force: F64
    torque: F64
    window: str
    index: tuple[int, int]
    force_std: F64
    other_force: F64 | None = None
    disagreement_n: float = float("nan")


@dataclass(frozen=True)
class TimeCleaning:
    """What :func:`clean_times` did to one stream: samples in, samples out, collapsed duplicates."""

    stream: str
    n_in: int
    n_out: int
    duplicates_collapsed: int
    first_duplicate_index: int | None


@dataclass(frozen=True)
class AlignedRecording:
    """All streams of one recording on one time base. T frames.

    times (T,) s from the first frame; source_times (T,) the same instants on the recorder's clock
    (s since the epoch); fps: the resampling rate or None (``n_samples`` or native time base).
    joint_positions (T, 6) rad; positions (T, 3) m; orientations (T, 4) w x y z (sign-continuous);
    force (T, 3) N and torque (T, 3) N·m: base frame, tared, reaction on the robot;
    gripper (T,) 0 open .. 1 closed (raw / ``gripper_full_scale``) or None;
    finger_force (T,) raw finger-force counts (GBTI, uncalibrated, not tared) or None.
    Diagnostics: bias (the tare), time_cleaning (one per stream), trimmed_s (time dropped at the start
    and end so that every stream covers every frame), source_rate_hz (median per stream),
    force_lowpass_hz, warnings (every message also issued with ``warnings.warn``).
    """

    name: str
    times: F64
    source_times: F64
    fps: float | None
    joint_positions: F64
    positions: F64
    orientations: F64
    force: F64
    torque: F64
    gripper: F64 | None
    finger_force: F64 | None
    bias: WrenchBias
    time_cleaning: tuple[TimeCleaning, ...] = ()
    trimmed_s: tuple[float, float] = (0.0, 0.0)
    source_rate_hz: dict[str, float] = field(default_factory=dict)
    force_lowpass_hz: float | None = None
    warnings: tuple[str, ...] = ()

    def __len__(self) -> int:
        return len(self.times)

    @property
    def wrench(self) -> F64:
        """(T, 6) fx fy fz tx ty tz (layout.FORCE_NAMES order)."""
        return np.concatenate([self.force, self.torque], axis=1)

    @property
    def ee_pose(self) -> F64:
        """(T, 7) x y z qw qx qy qz (layout.EE_POSE_NAMES order)."""
        return np.concatenate([self.positions, self.orientations], axis=1)


# ---- timestamps -----------------------------------------------------------------------------------


def clean_times(
    stream: str,
    times: ArrayLike,
    values: ArrayLike,
    *,
    on_duplicate: DuplicatePolicy = "merge",
    quaternion_columns: slice | None = None,
) -> tuple[F64, F64, TimeCleaning]:
    """Collapse runs of equal timestamps (mean of their values); reject timestamps going backwards.

    times (T,), values (T, k) -> (times (T',), values (T', k), TimeCleaning). ``quaternion_columns``:
    the columns holding a unit quaternion; within a run each is flipped to the sign of the run's first
    before the mean (q and −q are one rotation, and a recorder's sign flip would average them to ~0),
    and the mean is renormalised. Raises ``ValueError`` naming ``stream`` and the sample index for
    NaN/inf times, a decreasing time, fewer than 2 distinct times, or any repeated time when
    ``on_duplicate="raise"``.
    """
    t = np.asarray(times, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    if t.ndim != 1 or v.ndim != 2 or len(v) != len(t):
        raise ValueError(
            f"stream {stream!r}: times (T,) and values (T, k) expected, got {t.shape} and {v.shape}"
        )
    bad = ~np.isfinite(t)
    if bad.any():
        raise ValueError(f"stream {stream!r}: timestamp is not finite at sample {int(np.argmax(bad))}")
    dt = np.diff(t)
    if np.any(dt < 0):
        i = int(np.argmax(dt < 0)) + 1
        raise ValueError(
            f"stream {stream!r}: timestamp goes backwards at sample {i} ({t[i]:.6f} s after {t[i - 1]:.6f} s)"
        )
    dup = dt == 0
    n_dup = int(dup.sum())
    if n_dup and on_duplicate == "raise":
        i = int(np.argmax(dup)) + 1
        raise ValueError(
            f"stream {stream!r}: sample {i} repeats the timestamp of sample {i - 1} ({n_dup} repeats in all)"
        )
    check_choice("on_duplicate", on_duplicate, ("merge", "raise"))
    t_out, v_out = _merge_runs(t, v, dup, quaternion_columns) if n_dup else (t, v)
    if len(t_out) < 2:
        raise ValueError(f"stream {stream!r}: fewer than 2 distinct timestamps ({len(t)} samples)")
    info = TimeCleaning(stream, len(t), len(t_out), n_dup, int(np.argmax(dup)) + 1 if n_dup else None)
    return t_out, v_out, info


def _merge_runs(t: F64, v: F64, dup: np.ndarray, quaternion_columns: slice | None) -> tuple[F64, F64]:
    """One sample per run of equal times (``dup[i]``: sample i+1 repeats sample i's time): the mean of
    the run's values, quaternions sign-aligned to the run's first before averaging and renormalised."""
    starts = np.concatenate([[True], ~dup])  # first sample of each run of equal times
    group = np.cumsum(starts) - 1
    counts = np.bincount(group).astype(np.float64)
    if quaternion_columns is not None:
        v = v.copy()
        q = v[:, quaternion_columns]
        first = q[np.flatnonzero(starts)][group]  # each sample's run-first quaternion
        q[np.einsum("ij,ij->i", q, first) < 0] *= -1.0
        v[:, quaternion_columns] = q
    sums = np.zeros((group[-1] + 1, v.shape[1]))
    np.add.at(sums, group, v)
    t_out, v_out = t[starts], sums / counts[:, None]
    if quaternion_columns is not None:
        q = v_out[:, quaternion_columns]
        v_out[:, quaternion_columns] = q / np.linalg.norm(q, axis=1, keepdims=True)
    return t_out, v_out


# ---- wrench -----------------------------------------------------------------------------------------


def _window(times: F64, window_s: float, at: str) -> tuple[int, int]:
    if at == "start":
        stop = int(np.searchsorted(times, times[0] + window_s, side="right"))
        return 0, max(stop, min(5, len(times)))
    first = int(np.searchsorted(times, times[-1] - window_s, side="left"))
    return min(first, max(len(times) - 5, 0)), len(times)


def estimate_wrench_bias(
    force_tool: ArrayLike,
    torque_tool: ArrayLike,
    times: ArrayLike,
    *,
    method: TareMethod = "auto",
    window_s: float = 0.2,
    quiet_std_n: float = TARE_QUIET_STD_N,
) -> WrenchBias:
    """Tool-frame sensor bias: per-axis median of force and torque over a rest window.

    force_tool, torque_tool (T, 3), times (T,) s. ``method``: "start" / "end" = the first / last
    ``window_s`` seconds; "auto" = the start window if it is quiet (largest per-axis force std below
    ``quiet_std_n``), else the end window if that is quiet, else the quieter of the two (a hand on the
    robot shows 0.5–6 N std, a free sensor 0.1–0.4 N); "none" = zero bias.
    """
    f = np.asarray(force_tool, dtype=np.float64)
    tq = np.asarray(torque_tool, dtype=np.float64)
    t = np.asarray(times, dtype=np.float64)
    if f.shape != tq.shape or f.ndim != 2 or f.shape[1] != 3 or t.shape != (len(f),):
        raise ValueError(
            f"force (T, 3), torque (T, 3), times (T,) expected, got {f.shape}, {tq.shape}, {t.shape}"
        )
    if window_s <= 0:
        raise ValueError(f"window_s must be > 0, got {window_s}")
    if method == "none":
        z = np.zeros(3)
        return WrenchBias(z, z.copy(), "none", (0, 0), z.copy())
    if method not in ("auto", "start", "end"):
        raise ValueError(f"tare method must be 'auto', 'start', 'end' or 'none', got {method!r}")

    def stats(at: str) -> tuple[tuple[int, int], F64, F64, F64]:
        a, b = _window(t, window_s, at)
        return (a, b), np.median(f[a:b], axis=0), np.median(tq[a:b], axis=0), f[a:b].std(axis=0)

    if method in ("start", "end"):
        idx, fb, tb, sd = stats(method)
        return WrenchBias(fb, tb, method, idx, sd)
    cands = {at: stats(at) for at in ("start", "end")}
    quiet = [at for at in ("start", "end") if float(cands[at][3].max()) < quiet_std_n]
    chosen = quiet[0] if quiet else min(cands, key=lambda at: float(cands[at][3].max()))
    other = "end" if chosen == "start" else "start"
    idx, fb, tb, sd = cands[chosen]
    return WrenchBias(
        fb,
        tb,
        chosen,
        idx,
        sd,
        other_force=cands[other][1],
        disagreement_n=float(np.linalg.norm(fb - cands[other][1])),
    )


def tare_wrench(
    force_tool: ArrayLike,
    torque_tool: ArrayLike,
    times: ArrayLike,
    *,
    method: TareMethod = "auto",
    window_s: float = 0.2,
    bias: WrenchBias | None = None,
) -> tuple[F64, F64, WrenchBias]:
    """Subtract the tool-frame bias (estimated by :func:`estimate_wrench_bias` unless ``bias`` is given).

    Returns ``(force (T, 3), torque (T, 3), bias)``; still in the tool frame.
    """
    if bias is None:
        bias = estimate_wrench_bias(force_tool, torque_tool, times, method=method, window_s=window_s)
    f = np.asarray(force_tool, dtype=np.float64) - bias.force
    tq = np.asarray(torque_tool, dtype=np.float64) - bias.torque
    return f, tq, bias


def wrench_to_base(
    force_tool: ArrayLike, torque_tool: ArrayLike, orientations: ArrayLike, *, sign: float = LAB_WRENCH_SIGN
) -> tuple[F64, F64]:
    """Rotate a tool-frame wrench into the base frame: ``sign · R(q) f``, ``sign · R(q) τ``.

    force_tool, torque_tool (T, 3); orientations (T, 4) w x y z of the tool in the base frame (the
    recorder's transform at the wrench timestamps). ``sign`` maps the source's convention onto the
    reaction on the robot (+1 for the lab recorder, see the module docstring).
    """
    q = np.asarray(orientations, dtype=np.float64)
    f = np.asarray(force_tool, dtype=np.float64)
    tq = np.asarray(torque_tool, dtype=np.float64)
    if q.ndim != 2 or q.shape[1] != 4 or f.shape != (len(q), 3) or tq.shape != (len(q), 3):
        raise ValueError(
            f"force (T, 3), torque (T, 3), orientations (T, 4) expected, got {f.shape}, {tq.shape}, {q.shape}"
        )
    return sign * quat_rotate(q, f), sign * quat_rotate(q, tq)


def lowpass(values: ArrayLike, rate_hz: float, cutoff_hz: float, order: int = 2) -> F64:
    """Zero-phase Butterworth low-pass along axis 0 (``sosfiltfilt``); values (T, k) sampled at rate_hz."""
    v = np.asarray(values, dtype=np.float64)
    if not 0 < cutoff_hz < 0.5 * rate_hz:
        raise ValueError(f"cutoff {cutoff_hz} Hz must lie in (0, {0.5 * rate_hz}) for a {rate_hz} Hz signal")
    sos = butter(order, cutoff_hz, btype="low", fs=rate_hz, output="sos")
    padlen = min(3 * (2 * len(sos) + 1), len(v) - 1)
    return sosfiltfilt(sos, v, axis=0, padlen=padlen)


def interp_linear(times: F64, values: F64, query: F64) -> F64:
    """Piecewise-linear interpolation of (T, k) values at ``query (Q,)`` (times strictly increasing)."""
    hi = np.clip(np.searchsorted(times, query, side="right"), 1, len(times) - 1)
    lo = hi - 1
    frac = ((query - times[lo]) / (times[hi] - times[lo]))[:, None]
    return values[lo] + frac * (values[hi] - values[lo])


# ---- alignment -----------------------------------------------------------------------------------


#: a time step this many times the median is a gap (dropped samples); real recordings stay below 4.1x
GAP_FACTOR = 5.0


def describe_gaps(times: F64, factor: float = GAP_FACTOR) -> str:
    """A description of the steps of ``times`` longer than ``factor`` × the median step ('' if none)."""
    step = np.diff(times)
    if len(step) == 0:
        return ""
    median = float(np.median(step))
    big = np.flatnonzero(step > factor * median)
    if len(big) == 0:
        return ""
    i = int(big[np.argmax(step[big])])
    return (
        f"{len(big)} gap(s) in time longer than {factor:g}x the median step ({median * 1e3:.2f} ms); the "
        f"longest, {step[i]:.3f} s, after sample {i} ({times[i] - times[0]:.3f} s from the stream's start)"
    )


def align_recording(
    rec: Recording,
    *,
    fps: float | None = None,
    n_samples: int | None = None,
    tare: TareMethod = "auto",
    tare_window_s: float = 0.2,
    wrench_sign: float = LAB_WRENCH_SIGN,
    gripper_full_scale: float = GRIPPER_FULL_SCALE,
    force_lowpass_hz: float | None = None,
    on_duplicate: DuplicatePolicy = "merge",
) -> AlignedRecording:
    """Tare, rotate to base and interpolate every stream of ``rec`` onto one time base.

    Time base: inside ``[max of stream starts, min of stream ends]`` (no extrapolation; the trimmed
    seconds are reported). ``fps``: frames at ``start + k/fps``; ``n_samples``: that many frames
    evenly spaced over the interval (the authors' "resample to 1000 points", without repeated
    samples); neither: the joint stream's own timestamps inside the interval. Vectors interpolate
    linearly, orientations by SLERP (``geometry.slerp_sequence``). The wrench is tared and rotated at
    the source rate (orientation SLERPed to the wrench timestamps), optionally low-passed at
    ``force_lowpass_hz``, then interpolated. Repeated timestamps: ``on_duplicate="merge"`` collapses them
    (warning + ``time_cleaning``), ``"raise"`` rejects them. Gripper -> raw / ``gripper_full_scale`` (0 open .. 1 closed);
    a reading outside ``[0, gripper_full_scale]`` raises ``ValueError`` with its index.
    """
    if fps is not None and n_samples is not None:
        raise ValueError("give fps or n_samples, not both")
    check_real("fps", fps, low=0, low_open=True, none_ok=True)
    check_int("n_samples", n_samples, low=2, none_ok=True)
    check_real("gripper_full_scale", gripper_full_scale, low=0, low_open=True)
    notes = _Notes(rec.name)
    cleaned, cleaning = _clean_streams(rec, on_duplicate, notes)
    rates = _stream_rates(rec.name, cleaned, notes)
    start, stop, trimmed = _overlap(rec, cleaned, notes)
    rel, query = _time_base(rec.name, cleaned, start, stop, fps, n_samples)
    tw = cleaned["wrench"][0]
    wrench_base, bias = _base_wrench(cleaned, tare, tare_window_s, wrench_sign, notes)
    if force_lowpass_hz is not None:
        wrench_base = lowpass(wrench_base, rates["wrench"], force_lowpass_hz)
    wrench_q = interp_linear(tw, wrench_base, query)
    tp, pose = cleaned["pose"]
    tj, joints = cleaned["joint"]
    return AlignedRecording(
        name=rec.name,
        times=rel,
        source_times=query,
        fps=float(fps) if fps is not None else None,
        joint_positions=interp_linear(tj, joints, query),
        positions=interp_linear(tp, pose[:, :3], query),
        orientations=slerp_sequence(tp, pose[:, 3:], query),
        force=wrench_q[:, :3],
        torque=wrench_q[:, 3:],
        gripper=_gripper(rec, cleaned, query, gripper_full_scale),
        finger_force=interp_linear(*cleaned["finger_force"], query)[:, 0]
        if "finger_force" in cleaned
        else None,
        bias=bias,
        time_cleaning=tuple(cleaning),
        trimmed_s=trimmed,
        source_rate_hz=rates,
        force_lowpass_hz=force_lowpass_hz,
        warnings=tuple(notes.messages),
    )


class _Notes:
    """What :func:`align_recording` says about a recording: kept for ``AlignedRecording.warnings`` and
    issued as warnings naming the recording (pointing at ``align_recording``'s caller)."""

    def __init__(self, name: str):
        self.name = name
        self.messages: list[str] = []

    def __call__(self, msg: str) -> None:
        self.messages.append(msg)
        warnings.warn(f"{self.name}: {msg}", stacklevel=4)


def _clean_streams(
    rec: Recording, on_duplicate: DuplicatePolicy, notes: _Notes
) -> tuple[dict[str, tuple[F64, F64]], list[TimeCleaning]]:
    """Every stream through :func:`clean_times` (the pose's quaternion columns kept unit and signed)."""
    cleaned: dict[str, tuple[F64, F64]] = {}
    cleaning: list[TimeCleaning] = []
    for stream, (t, v) in rec.streams.items():
        tc, vc, info = clean_times(
            f"{rec.name}/{stream}",
            t,
            v,
            on_duplicate=on_duplicate,
            quaternion_columns=slice(3, 7) if stream == "pose" else None,  # x y z | quaternion (4)
        )
        cleaned[stream] = (tc, vc)
        cleaning.append(info)
        if info.duplicates_collapsed:
            notes(
                f"stream {stream!r}: {info.duplicates_collapsed} sample(s) repeat the previous timestamp "
                f"(first at sample {info.first_duplicate_index}); collapsed to their mean"
            )
    return cleaned, cleaning


def _stream_rates(name: str, cleaned: dict[str, tuple[F64, F64]], notes: _Notes) -> dict[str, float]:
    """Median sample rate per stream (one outside :data:`STREAM_RATE_RANGE_HZ` means other time units);
    gaps in a stream are noted."""
    rates = {s: float(1.0 / np.median(np.diff(t))) for s, (t, _) in cleaned.items()}
    lo_hz, hi_hz = STREAM_RATE_RANGE_HZ
    for stream, rate in rates.items():
        if not lo_hz <= rate <= hi_hz:
            raise ValueError(
                f"recording {name!r}: stream {stream!r} has a median sample step of "
                f"{1.0 / rate:.3g} s ({rate:.3g} Hz), outside the plausible {lo_hz:g} Hz .. {hi_hz:g} Hz; "
                "timestamps must be seconds (plain) or [sec, nsec] rows: are they ms, µs or ns?"
            )
    for stream, (t, _) in cleaned.items():
        gap = describe_gaps(t)
        if gap:
            notes(f"stream {stream!r}: {gap}; the frames across it are interpolated")
    return rates


def _overlap(
    rec: Recording, cleaned: dict[str, tuple[F64, F64]], notes: _Notes
) -> tuple[float, float, tuple[float, float]]:
    """``(start, stop)`` of the span every stream covers, and the seconds trimmed at each end (noted when
    longer than :data:`TRIM_NOTE_S`)."""
    start = max(t[0] for t, _ in cleaned.values())
    stop = min(t[-1] for t, _ in cleaned.values())
    if stop <= start:
        raise ValueError(
            f"recording {rec.name!r}: the streams do not overlap in time ({start:.3f} >= {stop:.3f})"
        )
    t0 = rec.start_time
    trimmed = (float(start - t0), float(max(t[-1] for t, _ in cleaned.values()) - stop))
    if max(trimmed) > TRIM_NOTE_S:
        late = [s for s, (t, _) in cleaned.items() if t[0] == start]
        early = [s for s, (t, _) in cleaned.items() if t[-1] == stop]
        dropped = [
            f"{seconds:.3f} s at the {end} (stream(s) {names} {verb})"
            for seconds, end, names, verb in (
                (trimmed[0], "start", late, "start last"),
                (trimmed[1], "end", early, "end first"),
            )
            if seconds > 0
        ]
        notes(
            f"the streams cover different time spans; kept their overlap {start - t0:.3f}..{stop - t0:.3f} s, "
            f"dropping {' and '.join(dropped)}"
        )
    return start, stop, trimmed


def _time_base(
    name: str,
    cleaned: dict[str, tuple[F64, F64]],
    start: float,
    stop: float,
    fps: float | None,
    n_samples: int | None,
) -> tuple[F64, F64]:
    """``(rel, query)``: frame times from the first frame, and the same on the recorder's clock."""
    # Relative frame times are computed directly (not as query - start): epoch seconds in float64
    # carry only ~2e-7 s resolution.
    if fps is not None:
        n = int(np.floor((stop - start) * fps + 1e-9)) + 1
        rel = np.arange(n) / fps
        query = start + rel
    elif n_samples is not None:
        rel = np.linspace(0.0, stop - start, int(n_samples))
        query = start + rel
    else:
        tj = cleaned["joint"][0]
        query = tj[(tj >= start) & (tj <= stop)]
        rel = query - query[0]
    if len(query) < 2:
        raise ValueError(f"recording {name!r}: only {len(query)} frame(s) in {stop - start:.3f} s")
    return rel, query


def _base_wrench(
    cleaned: dict[str, tuple[F64, F64]], tare: TareMethod, window_s: float, sign: float, notes: _Notes
) -> tuple[F64, WrenchBias]:
    """The wrench tared in the tool frame and rotated to the base at its own timestamps: (Tw, 6)."""
    tw, w = cleaned["wrench"]
    f_tared, tq_tared, bias = tare_wrench(w[:, :3], w[:, 3:], tw, method=tare, window_s=window_s)
    if bias.window != "none" and bias.disagreement_n > TARE_DISAGREEMENT_WARN_N:
        notes(
            f"tare: rest windows at start and end disagree by {bias.disagreement_n:.1f} N; used the "
            f"'{bias.window}' window (force std {np.round(bias.force_std, 2).tolist()} N)"
        )
    if bias.window != "none" and float(bias.force_std.max()) >= TARE_QUIET_STD_N:
        notes(
            f"tare: no quiet rest window (largest force std {float(bias.force_std.max()):.2f} N in the "
            f"'{bias.window}' window); the bias may include a hand's force"
        )
    tp, pose = cleaned["pose"]
    q_at_wrench = slerp_sequence(tp, pose[:, 3:], tw)
    f_base, tq_base = wrench_to_base(f_tared, tq_tared, q_at_wrench, sign=sign)
    return np.concatenate([f_base, tq_base], axis=1), bias


def _gripper(
    rec: Recording, cleaned: dict[str, tuple[F64, F64]], query: F64, full_scale: float
) -> F64 | None:
    """Gripper opening at the frames, raw / ``full_scale``; a raw reading outside [0, full_scale] is refused."""
    if "gripper" not in cleaned:
        return None
    raw = rec.gripper
    bad = (raw < 0) | (raw > full_scale)
    if bad.any():
        i = int(np.argmax(bad))
        raise ValueError(
            f"recording {rec.name!r}: gripper reading {raw[i]} at sample {i} outside [0, {full_scale}] "
            f"(set gripper_full_scale)"
        )
    return interp_linear(*cleaned["gripper"], query)[:, 0] / full_scale
