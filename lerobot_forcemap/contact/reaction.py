"""The contact reaction of a recording with one wrist force sensor, and the surfaces it touched.

**Kinesthetic recordings** (a hand guides the tool, below the sensor). The sensor reads hand + contact
reaction, and their sum is what moves the arm, so no model of force against motion can tell the two
apart while the tool is in contact; it can only carry over what it learned in free space. The estimator:

1. contacts: :func:`~lerobot_forcemap.contact.events.detect_contacts` (impact + dwell, from the
   kinematics and the measured force's transients);
2. the hand: the guiding-force model (:mod:`~lerobot_forcemap.contact.guiding`) fitted on the frames
   where the hand is on the robot (the active span) away from every contact (± ``exclude_pad_s``);
3. the reaction: zero outside the contacts; inside contact k, the part of (measured − hand model) along
   the surface normal n_k that points away from the surface, clipped at 0: ``max(0, n_k·(F − G)) n_k``.

It is a lower bound. It keeps the impact transient and any reaction beyond what the hand model explains,
and it never points into the surface. Where it fails, and how the data says so:

- a static press: with the tool at rest the model predicts only its bias, so the estimate is the
  measured wrench minus a constant; the reaction of a steady press is not observable (the sensor above
  the hand reads hand + reaction, which at rest equals what the arm's joints hold). On the UR5e
  presses the mean tared force over a contact points *into* the button in 7 of 10 contacts: the
  estimate is then 0 for most of the dwell, and only the impact survives;
- the hand model itself explains only part of the hand's force (held-out residual 0.5-0.8 of the
  measured wrench in free space); in contact that residual is projected on n and clipped, so a hand
  pulling up during a press reads as no reaction, and a hand pushing down harder than the model
  predicts reads as a reaction;
- grippers: a held object's weight and the grasp forces are not a surface contact (and lifting an object
  is no impact); the detector finds no contact there unless the object is set down with an impact;
- short recordings: fewer than ``min_free_s`` of free motion fit a poor model (the fit then falls back to
  every active frame, contacts included);
- teleoperated recordings and simulation have no hand (``kinesthetic=False``): the model is skipped, the
  reaction is the measured (tared) wrench and the contacts are where its norm exceeds a threshold.

Normals (:func:`contact_surfaces`): the reverse of the approach direction at touch-down (a press), with the
directions the tool travelled along in contact removed (a wipe along a line), or the plane of the contact
(a wipe over an area), oriented against the approach.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap._validation import check_bool, check_fields, check_real, fail
from lerobot_forcemap.contact.events import (
    ContactEvents,
    DetectorSettings,
    _detect,
    check_motion,
    check_signals,
    force_intervals,
    intervals_to_mask,
)
from lerobot_forcemap.contact.guiding import (
    GuidingModel,
    GuidingSettings,
    fit_guiding_force,
    predict_guiding_force,
)
from lerobot_forcemap.contact.kinematics import active_span, sample_rate, smooth_derivatives

__all__ = [
    "ReactionSettings",
    "ContactSurface",
    "ReactionEstimate",
    "contact_surfaces",
    "estimate_reaction",
    "rms_ratio",
    "guiding_share",
]

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class ReactionSettings:
    """Settings of :func:`estimate_reaction` and :func:`contact_surfaces` (SI units).

    active_speed (m/s), active_window_s: the hand is on the robot from the first to the last frame moving
    faster than this (velocity smoothed over the window); exclude_pad_s: the hand model is fitted away
    from every contact by this margin; min_free_s: fewer free seconds fit on every active frame instead;
    approach_s: the approach direction is the mean velocity over this time before touch-down;
    travel_m: a direction along which the tool moved more than this in contact lies in the surface;
    threshold_n, min_contact_s, merge_gap_s: contacts of a recording without a hand
    (:func:`~lerobot_forcemap.contact.events.force_intervals`).
    """

    active_speed: float = 0.02
    active_window_s: float = 0.06
    exclude_pad_s: float = 0.3
    min_free_s: float = 0.5
    approach_s: float = 0.15
    travel_m: float = 0.02
    threshold_n: float = 2.0
    min_contact_s: float = 0.05
    merge_gap_s: float = 0.1

    def __post_init__(self) -> None:
        rule = partial(check_real, low=0.0, low_open=True)
        check_fields(type(self).__name__, self, dict.fromkeys(self.__dataclass_fields__, rule))


@dataclass(frozen=True)
class ContactSurface:
    """The surface of one contact: ``interval (2,)`` [touch-down, lift-off] s; ``normal (3,)`` unit,
    pointing away from the surface (the direction of a reaction on the robot); ``offset`` m: the
    demonstrated surface is the plane ``normal · x = offset`` through the deepest contact sample (a
    point with ``normal · x < offset`` lies below anything the tool reached there); ``kind``:
    "approach" (no travel in contact), "line" or "plane" (travel along one or two directions)."""

    interval: F64
    normal: F64
    offset: float
    kind: str

    def depth_below(self, points: F64) -> F64:
        """How far ``points (N, 3)`` lie below the surface (m, > 0 below, <= 0 on or above)."""
        return self.offset - np.asarray(points, dtype=np.float64) @ self.normal


@dataclass(frozen=True)
class ReactionEstimate:
    """Outcome of :func:`estimate_reaction` on T frames.

    reaction (T, 3) N: the contact reaction estimate (base frame, on the robot); guiding (T, 3) N: the
    hand model's force (zeros without a hand); contacts: the detected events; surfaces: one per contact;
    free (T,) bool: the frames the hand model was fitted on; model: the hand model (None without a hand);
    kinesthetic: whether a hand was modelled.
    """

    reaction: F64
    guiding: F64
    contacts: ContactEvents
    surfaces: tuple[ContactSurface, ...]
    free: NDArray[np.bool_]
    model: GuidingModel | None
    kinesthetic: bool


def estimate_reaction(
    times: object,
    positions: object,
    force: object,
    *,
    kinesthetic: bool = True,
    settings: ReactionSettings | None = None,
    detector: DetectorSettings | None = None,
    guiding: GuidingSettings | None = None,
) -> ReactionEstimate:
    """The contact reaction of one recording (module docstring).

    times (T,) s strictly increasing, at the source rate (not resampled: impacts last 20-50 ms);
    positions (T, 3) m, the tool (flange) in the base frame, +z up; force (T, >= 3) N, tared, base frame,
    reaction on the robot (only the first 3 columns are used). ``kinesthetic=False``: no hand on the
    tool (simulation, teleoperation).
    """
    t, p, f = check_signals(times, positions, force)
    kinesthetic = check_bool("kinesthetic", kinesthetic)
    for name, value, kind in (
        ("settings", settings, ReactionSettings),
        ("detector", detector, DetectorSettings),
        ("guiding", guiding, GuidingSettings),
    ):
        if value is not None and not isinstance(value, kind):
            fail(name, f"be a {kind.__name__} or None", type(value).__name__)
    s = settings or ReactionSettings()
    if not kinesthetic:
        return _without_hand(t, p, f, s)
    contacts = _detect(t, p[:, 2], f[:, 2], detector or DetectorSettings())
    surfaces = _surfaces(t, p, contacts.intervals, s)
    free = _free_frames(t, p, contacts, s)
    model = fit_guiding_force(t, p, f, free, guiding or GuidingSettings())
    hand = predict_guiding_force(model, t, p)
    reaction = _along_normals(t, f - hand, surfaces)
    return ReactionEstimate(reaction, hand, contacts, surfaces, free, model, True)


def _without_hand(t: F64, p: F64, f: F64, s: ReactionSettings) -> ReactionEstimate:
    """No hand: the wrench is the reaction; contacts where its norm exceeds ``threshold_n``."""
    contacts = force_intervals(
        t, f, threshold_n=s.threshold_n, min_duration_s=s.min_contact_s, merge_gap_s=s.merge_gap_s
    )
    surfaces = _surfaces(t, p, contacts.intervals, s)
    none = np.zeros(len(t), dtype=bool)
    return ReactionEstimate(f.copy(), np.zeros_like(f), contacts, surfaces, none, None, False)


def _free_frames(t: F64, p: F64, contacts: ContactEvents, s: ReactionSettings) -> NDArray[np.bool_]:
    """The frames the hand model is fitted on: active, away from contacts (or, if too few, active;
    if still too few, all)."""
    active = active_span(t, p, s.active_speed, s.active_window_s)
    free = active & ~intervals_to_mask(t, contacts.intervals, s.exclude_pad_s)
    least = s.min_free_s * sample_rate(t)
    for mask in (free, active):
        if mask.sum() >= least:
            return mask
    return np.ones(len(t), dtype=bool)


def _along_normals(t: F64, residual: F64, surfaces: tuple[ContactSurface, ...]) -> F64:
    """Inside each contact, the residual's component along the normal, clipped at 0; zero elsewhere."""
    out = np.zeros_like(residual)
    for surface in surfaces:  # a handful of contacts
        inside = (t >= surface.interval[0]) & (t <= surface.interval[1])
        along = np.maximum(residual[inside] @ surface.normal, 0.0)
        out[inside] = along[:, None] * surface.normal[None, :]
    return out


def contact_surfaces(
    times: object, positions: object, intervals: object, settings: ReactionSettings | None = None
) -> tuple[ContactSurface, ...]:
    """The surface of each contact ``intervals (K, 2)`` [touch-down, lift-off] s of a recording
    (times (T,) s, positions (T, 3) m, base frame): normal and deepest level (module docstring)."""
    t, p = check_motion(times, positions)
    iv = np.asarray(intervals, dtype=np.float64).reshape(-1, 2)
    if not np.isfinite(iv).all() or (iv[:, 1] < iv[:, 0]).any():
        fail("intervals", "hold finite [start, stop] rows with start <= stop", iv.tolist())
    return _surfaces(t, p, iv, settings or ReactionSettings())


def _surfaces(t: F64, p: F64, intervals: F64, s: ReactionSettings) -> tuple[ContactSurface, ...]:
    v, _ = smooth_derivatives(t, p, s.active_window_s)
    return tuple(_surface(t, p, v, start, stop, s) for start, stop in intervals)


def _surface(t: F64, p: F64, v: F64, start: float, stop: float, s: ReactionSettings) -> ContactSurface:
    """One contact's surface: the reverse approach direction without its components along the contact's
    travel directions; +z when the approach is not known (no descent before the contact)."""
    before = (t >= start - s.approach_s) & (t < start)
    approach = v[before].mean(axis=0) if before.any() else np.zeros(3)
    normal = -approach if np.linalg.norm(approach) > 1e-9 else np.array([0.0, 0.0, 1.0])
    inside = p[(t >= start) & (t <= stop)]
    if len(inside) == 0:
        inside = p[[int(np.argmin(np.abs(t - start)))]]
    centred = inside - inside.mean(axis=0)
    _, _, axes = np.linalg.svd(centred, full_matrices=False) if len(inside) > 1 else (None, None, np.eye(3))
    travel = [a for a in axes if np.ptp(centred @ a) > s.travel_m]
    for a in travel:
        normal = normal - (normal @ a) * a
    if np.linalg.norm(normal) < 1e-6 * (np.linalg.norm(approach) + 1.0):
        # approached along the travel: the normal is the direction the contact does not spread in
        normal = axes[-1] * (1.0 if axes[-1][2] >= 0 else -1.0)
    normal = normal / np.linalg.norm(normal)
    kind = ("approach", "line", "plane")[min(len(travel), 2)]
    return ContactSurface(np.array([start, stop]), normal, float((inside @ normal).min()), kind)


def rms_ratio(part: object, whole: object, mask: object = None) -> float:
    """RMS of ``|part|`` over RMS of ``|whole|`` (rows (T, 3)) on the frames of ``mask (T,)`` (all when
    None); NaN when ``whole`` is zero there."""
    a = np.linalg.norm(np.asarray(part, dtype=np.float64), axis=1)
    b = np.linalg.norm(np.asarray(whole, dtype=np.float64), axis=1)
    if mask is not None:
        a, b = a[np.asarray(mask, dtype=bool)], b[np.asarray(mask, dtype=bool)]
    denominator = float(np.sqrt(np.mean(b**2))) if len(b) else 0.0
    return float(np.sqrt(np.mean(a**2))) / denominator if denominator > 0 else float("nan")


def guiding_share(measured: object, reaction: object) -> float:
    """The share of a measured wrench (T, 3) N not explained by the contact reaction (T, 3): RMS of
    ``|measured − reaction|`` over RMS of ``|measured|`` (0: all reaction, 1: all hand)."""
    measured = np.asarray(measured, dtype=np.float64)
    return rms_ratio(measured - np.asarray(reaction, dtype=np.float64), measured)
