"""Force feedback at execution: the demonstration's contact profile (fit time) and a bounded
admittance correction of the target along the contact normal (each control step). Pure NumPy.

Fit time (:func:`force_profile`, from one demonstration):

* the contact normal n: the unit sum of the demonstrated reaction over its contact frames
  (``|f| > f_contact``), pointing away from the surface (a wipe's friction tilts it a few degrees);
* the expected force ``expected (T,)``: the reaction along n, ``max(f . n, 0)``, as a running max
  over +-``dilate_s`` (a contact a little earlier or later is still expected);
* the demonstration's stiffness ``K_demo`` (N/m): the median over contact frames of
  ``f . n / ((x_measured - x_commanded) . n)``, i.e. the controller the demonstration was recorded
  with, read from its data (NaN without a measured pose or contact);
* the demonstration's depth ``depth (T,)``: how far its measured TCP had gone along -n past the
  contact's origin by each frame. The origin is where the straight force-position line through the
  crossings of ``f_contact`` and ``2 f_contact`` (interpolated between frames) reaches zero force:
  unlike the first frame in contact, it does not move with the contact's stiffness, its preload or
  where the frames fell.

Each control step (:class:`ForceFeedback`, one state per batch row; ``f`` the measured reaction minus
a self-tare of the first ``tare_steps`` observations, ``F_ref(t) = min(budget, expected(t))``,
``v`` the target's own speed along n, negative towards the surface)::

    e = f . n - F_ref
    e >  deadband:               lift   u += min(lift_gain (e - deadband), v_max) dt
    e < -deadband and u > 0:     undo the lift (faster of the gain and u / tau)
    e < -deadband and may_push:  push   u -= (max(v, 0) + min(push_gain (-e - deadband), v_push)) dt
    target = map target + u n,   u in [-max_push, max_lift]

``may_push``: contact is expected (``F_ref > f_touch``) and felt (``f . n > f_touch``), and the map
itself is nearly still along n (``-hold_speed <= v <= ratchet_speed``): the push never adds to the
map's own approach, never chases a surface that is not there, and lets a deliberate lift-off go.
A push no longer wanted decays with ``tau``. In steady contact the force settles within
``F_ref +- deadband`` whatever the controller's stiffness, as long as the bounds are not reached.

The depth law (``depth_gain`` > 0, with the measured TCP positions and a demonstration whose
depth is known) makes the depth, not the force, the target while pressing in: ``depth_ref`` is
how deep the demonstration was when its force reached the budget. A demonstration that went more
than ``max_push`` past the contact's origin before that moved the object (a push, a slide), and
that travel is no compliance to reproduce: the law stays off (``depth_ref`` NaN). A contact's origin is found
at run time as at fit time; while the contact is expected and held (the map not leaving faster
than ``ratchet_speed``, or ``depth_ref`` not yet reached in this contact):

    depth < depth_ref:   the target moves along n at v = depth_gain (depth - depth_ref) (at most
                         v_push in, whatever the map does), never less pushed in than the force
                         law's u, lifting only above the demonstrated force expected(t)
    depth > depth_ref:   the map's own approach along n is cancelled (no deeper with the map)

A stiffer object than the demonstration's is pressed as deep as the demonstration was at the
budget, with the force that takes (up to the demonstrated force); a softer one gets the budget,
as before. Units: m, s, N; gains m/(N s), ``depth_gain`` 1/s.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

__all__ = ["ForceProfile", "FeedbackGains", "ForceFeedback", "force_profile", "dilate"]

Array = NDArray[np.float64]


def dilate(x: Array, half_width: int) -> Array:
    """Running max over +- ``half_width`` samples."""
    if half_width <= 0:
        return np.array(x, dtype=np.float64)
    pad = np.pad(x, half_width, mode="edge")
    return np.lib.stride_tricks.sliding_window_view(pad, 2 * half_width + 1).max(axis=1)


def _crossing(x0: Array, x1: Array, f0: Array, f1: Array, level: float) -> Array:
    """Where the force passed ``level`` between two samples (linear in between; ``x1`` if it did
    not rise)."""
    w = np.clip((level - f0) / np.where(f1 > f0, f1 - f0, 1.0), 0.0, 1.0)
    return np.where(f1 > f0, x0 + w * (x1 - x0), x1)


@dataclass(frozen=True)
class ForceProfile:
    """``expected (T,)`` N at frame times k / fps; ``normal (3,)`` unit, base frame of the
    demonstration; ``stiffness`` K_demo N/m (NaN when the data cannot tell); ``along (T,)`` N, the
    demonstrated reaction along n (not dilated); ``depth (T,)`` m, how far the measured TCP had gone
    along -n past the contact's origin by each frame (module docstring; the crossings of
    ``contact_force`` N and twice that), 0 before, NaN without a measured pose or when the force
    never reached ``2 contact_force``."""

    expected: Array
    normal: Array
    stiffness: float
    along: Array
    depth: Array
    contact_force: float

    def depth_at(self, force: float) -> float:
        """The demonstration's depth (m) when its force along n first reached ``min(force, its max)``,
        interpolated between the frames around that crossing (a contact stiffening within one frame
        jumps past the level); NaN when its depth is unknown or still 0 there."""
        level = min(force, float(self.along.max()))
        k = int(np.argmax(self.along >= level))
        depth = float(self.depth[k])
        if k > 0 and self.along[k] > self.along[k - 1]:
            w = (level - self.along[k - 1]) / (self.along[k] - self.along[k - 1])
            depth = float(self.depth[k - 1] + min(max(w, 0.0), 1.0) * (self.depth[k] - self.depth[k - 1]))
        return depth if depth > 0 else float("nan")


def _contact_origin(x_lo: Array, x_hi: Array) -> Array:
    """Where the straight force-position line through the crossings of a level (at ``x_lo``) and
    twice that level (at ``x_hi``) reaches zero force: a depth origin that does not move with the
    contact's stiffness or preload, nor with how the first samples fell."""
    return x_lo + (x_lo - x_hi)


def _depth_curve(x: Array, along: Array, level: float) -> Array:
    """``depth (T,)`` of :class:`ForceProfile` from the TCP along n ``x (T,)`` and the force along n
    (NaN when the force never reached ``2 level``)."""
    k_lo, k_hi = int(np.argmax(along > level)), int(np.argmax(along > 2 * level))
    if along[k_hi] <= 2 * level or k_lo == 0:
        return np.full(len(x), np.nan)
    x_lo = _crossing(x[k_lo - 1], x[k_lo], along[k_lo - 1], along[k_lo], level)
    x_hi = _crossing(x[k_hi - 1], x[k_hi], along[k_hi - 1], along[k_hi], 2 * level)
    went = np.where(np.arange(len(x)) >= k_lo, _contact_origin(x_lo, x_hi) - x, 0.0)
    return np.maximum.accumulate(np.maximum(went, 0.0))


def force_profile(
    force: Array,
    commanded: Array,
    measured: Array | None,
    fps: float,
    *,
    f_contact: float = 2.0,
    dilate_s: float = 0.5,
) -> ForceProfile:
    """The profile of one demonstration: ``force (T, 3)`` reaction on the robot (N, base frame),
    ``commanded (T, 3)`` target positions, ``measured (T, 3)`` TCP positions or None (m)."""
    f = np.asarray(force, dtype=np.float64)[:, :3]
    contact = np.linalg.norm(f, axis=1) > f_contact
    total = f[contact].sum(axis=0)
    norm = np.linalg.norm(total)
    normal = total / norm if contact.any() and norm > 1e-9 else np.array([0.0, 0.0, 1.0])
    along = np.maximum(f @ normal, 0.0)
    expected = dilate(along, int(round(dilate_s * fps)))
    stiffness = float("nan")
    depth = np.full(len(f), np.nan)
    if measured is not None:
        x = np.asarray(measured, dtype=np.float64) @ normal
        lag = x - np.asarray(commanded, dtype=np.float64) @ normal
        ok = contact & (lag > 1e-4)
        if ok.any():
            stiffness = float(np.median(along[ok] / lag[ok]))
        depth = _depth_curve(x, along, f_contact)
    return ForceProfile(expected, normal, stiffness, along, depth, float(f_contact))


@dataclass(frozen=True)
class FeedbackGains:
    """The law's settings (module docstring): N, m, s; gains m/(N s), ``depth_gain`` 1/s (0: the
    force law alone, the budget a hard bound)."""

    budget: float = 6.25
    lift_gain: float = 2e-3
    push_gain: float = 1e-2
    deadband: float = 0.5
    max_push: float = 0.015
    max_lift: float = 0.03
    v_max: float = 0.05
    v_push: float = 0.02
    tau: float = 0.3
    f_touch: float = 1.0
    hold_speed: float = 0.005
    ratchet_speed: float = 0.01
    tare_steps: int = 2
    depth_gain: float = 4.0


class ForceFeedback:
    """The run-time law for ``n`` batch rows, stepped at ``control_hz`` (module docstring)."""

    def __init__(self, profile: ForceProfile, gains: FeedbackGains, fps: float, control_hz: float, n: int):
        self.profile, self.gains, self.fps, self.dt = profile, gains, fps, 1.0 / control_hz
        self.k = 0
        self.u = np.zeros(n)
        push_depth = profile.depth_at(gains.budget)
        # deeper than the feedback may press past the map: the object moved (module docstring)
        self.moved_object = bool(push_depth > gains.max_push)
        self.depth_ref = push_depth if gains.depth_gain > 0 and not self.moved_object else float("nan")
        self._lo_at = np.full(n, np.nan)  # the TCP along n where this contact passed contact_force
        self._contact_at = np.full(n, np.nan)  # this contact's depth origin (_contact_origin)
        self._reached = np.zeros(n, dtype=bool)  # this contact went depth_ref deep
        self._tare_sum = np.zeros((n, 3))
        self.force = np.zeros((n, 3))  # N, base frame: the last step's measured reaction, tared
        self.felt = np.zeros(n, dtype=bool)  # per row: that force exceeded f_touch
        self._prev: Array | None = None
        self._last: tuple[Array, Array] | None = None  # the TCP along n and the force, last step

    def expected(self, t: float) -> float:
        """The demonstrated force along n around ``t`` (N; the last frame's value after its end)."""
        e = self.profile.expected
        return float(e[min(int(round(t * self.fps)), len(e) - 1)])

    def reference(self, t: float) -> Array:
        """``F_ref(t)`` per row, N: ``min(budget, expected(t))``."""
        return np.minimum(self.gains.budget, np.full(len(self.u), self.expected(t)))

    def offset(self) -> Array:
        """The current correction ``(n, 3)`` m added to the targets."""
        return self.u[:, None] * self.profile.normal

    def step(
        self, targets: Array, force: Array, measured: Array | None = None, t: float | None = None
    ) -> Array:
        """Corrected target positions ``(n, 3)`` from the map's ``targets (n, 3)``, the measured
        reaction ``force (n, >= 3)`` (N, base frame) and the measured TCP positions ``(n, 3)`` (m;
        None: the force law alone) at the skill's time ``t`` (s; None: steps so far x dt);
        advances one control step."""
        g, n_vec = self.gains, self.profile.normal
        f = self.force = self._tared(np.asarray(force, dtype=np.float64)[:, :3])
        self.felt = np.linalg.norm(f, axis=1) > g.f_touch
        t = self.k * self.dt if t is None else float(t)
        f_ref = self.reference(t)
        f_n = f @ n_vec
        speed = np.zeros(len(targets)) if self._prev is None else (targets - self._prev) @ n_vec / self.dt
        self._prev = np.array(targets, dtype=np.float64)
        may_push = (
            (g.max_push > 0) & (f_ref > g.f_touch) & (f_n > g.f_touch)
            & (speed >= -g.hold_speed) & (speed <= g.ratchet_speed)
        )  # fmt: skip
        u = self._advance(f_n - f_ref, speed, may_push)
        if measured is not None and np.isfinite(self.depth_ref):
            u = self._depth_law(u, np.asarray(measured, dtype=np.float64) @ n_vec, f_n, speed, t)
        self.u = u
        self.k += 1
        return targets + self.offset()

    def _depth_law(self, u: Array, x: Array, f_n: Array, speed: Array, t: float) -> Array:
        """The force law's correction ``u`` overruled by the depth (module docstring): short of
        ``depth_ref``, never less push than the depth servo's; past it, no deeper with the map."""
        g = self.gains
        depth, held = self._depth(x, f_n, speed, t)
        depth = np.nan_to_num(depth)
        shallow = held & (depth < self.depth_ref)
        u = np.where(shallow, np.minimum(u, self._servo(depth, f_n - self.expected(t), speed)), u)
        deep = held & (depth > self.depth_ref) & (speed < -g.hold_speed) & (f_n > g.f_touch)
        return np.where(deep, np.minimum(np.maximum(u, self.u - speed * self.dt), g.max_lift), u)

    def _depth(self, x: Array, f_n: Array, speed: Array, t: float) -> tuple[Array, Array]:
        """(depth past this contact's origin, m, NaN before it is known; the rows whose depth is held):
        a contact starts where the demonstration expects one and the force passes the profile's
        contact force, its origin is known once the force passes twice that; it ends when the
        demonstration expects none and the force is gone. Held: in a contact while the map is not
        leaving the surface faster than ``ratchet_speed``, or ``depth_ref`` is not reached yet."""
        g = self.gains
        expected = self.expected(t) > g.f_touch
        level = self.profile.contact_force
        x0, f0 = (x, f_n) if self._last is None else self._last
        self._last = (x, f_n)
        start = np.isnan(self._lo_at) & expected & (f_n > level)
        self._lo_at = np.where(start, _crossing(x0, x, f0, f_n, level), self._lo_at)
        start = np.isnan(self._contact_at) & ~np.isnan(self._lo_at) & (f_n > 2 * level)
        origin = _contact_origin(self._lo_at, _crossing(x0, x, f0, f_n, 2 * level))
        self._contact_at = np.where(start, origin, self._contact_at)
        ended = (f_n < g.f_touch) & (not expected)
        self._lo_at = np.where(ended, np.nan, self._lo_at)
        self._contact_at = np.where(ended, np.nan, self._contact_at)
        depth = self._contact_at - x
        self._reached = ~ended & (self._reached | (depth >= self.depth_ref))
        held = ~np.isnan(self._contact_at) & expected & ((speed <= g.ratchet_speed) | ~self._reached)
        return depth, held

    def _servo(self, depth: Array, over: Array, speed: Array) -> Array:
        """The depth servo's correction: the target moves along n at ``depth_gain`` x (depth -
        depth_ref), whatever the map does, lifting while the force exceeds the demonstrated one
        (``over`` N above it)."""
        g = self.gains
        v = np.clip(g.depth_gain * (depth - self.depth_ref), -g.v_push, g.v_max)
        v = np.where(
            over > g.deadband, np.maximum(v, np.minimum(g.lift_gain * (over - g.deadband), g.v_max)), v
        )
        return np.clip(self.u + (v - speed) * self.dt, -g.max_push, g.max_lift)

    def _tared(self, f: Array) -> Array:
        if self.k < self.gains.tare_steps:
            self._tare_sum += f
        return f - self._tare_sum / max(1, min(self.k + 1, self.gains.tare_steps))

    def _advance(self, e: Array, speed: Array, may_push: Array) -> Array:
        g, u, dt = self.gains, self.u, self.dt
        over, under = e > g.deadband, e < -g.deadband
        lift = np.minimum(g.lift_gain * (e - g.deadband), g.v_max)
        undo = -np.minimum(np.maximum(g.lift_gain * (-e - g.deadband), u / g.tau), g.v_max)
        push = -(np.maximum(speed, 0.0) + np.minimum(g.push_gain * (-e - g.deadband), g.v_push))
        du = np.where(over, lift, np.where(under & (u > 0), undo, np.where(under & may_push, push, 0.0)))
        leave = (u < 0) & ~may_push & ~over
        du = np.where(leave, np.minimum(-u / g.tau, g.v_max), du)
        low = np.where(may_push, -g.max_push, np.minimum(0.0, u))
        return np.clip(u + du * dt, low, g.max_lift)
