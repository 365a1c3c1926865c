"""Force feedback at execution: the demonstration's contact profile (fit time) and a bounded
admittance correction of the target along the contact normal (each control step). Pure NumPy.

Fit time (:func:`force_profile`, from one demonstration):

* the contact normal n: the unit sum of the demonstrated reaction over its contact frames
  (``|f| > f_contact``), pointing away from the surface (a wipe's friction tilts it a few degrees);
* the expected force ``expected (T,)``: the reaction along n, ``max(f . n, 0)``, as a running max
  over +-``dilate_s`` (a contact a little earlier or later is still expected);
* the demonstration's stiffness ``K_demo`` (N/m): the median over contact frames of
  ``f . n / ((x_measured - x_commanded) . n)``, i.e. the controller the demonstration was recorded
  with, read from its data (NaN without a measured pose or contact).

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
Units: m, s, N; gains m/(N s).
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


@dataclass(frozen=True)
class ForceProfile:
    """``expected (T,)`` N at frame times k / fps; ``normal (3,)`` unit, base frame of the
    demonstration; ``stiffness`` K_demo N/m and ``depth`` m, how far the measured TCP went along
    -n after the first contact (NaN when the data cannot tell)."""

    expected: Array
    normal: Array
    stiffness: float
    depth: float = float("nan")


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
    stiffness = depth = float("nan")
    if measured is not None:
        x = np.asarray(measured, dtype=np.float64) @ normal
        lag = x - np.asarray(commanded, dtype=np.float64) @ normal
        ok = contact & (lag > 1e-4)
        if ok.any():
            stiffness = float(np.median(along[ok] / lag[ok]))
            first = int(np.argmax(contact))
            depth = float(np.max(x[first] - x[first:]))
    return ForceProfile(expected=expected, normal=normal, stiffness=stiffness, depth=depth)


@dataclass(frozen=True)
class FeedbackGains:
    """The law's settings (module docstring): N, m, s; gains m/(N s). ``depth_ratio`` > 0 raises the
    budget by ``escalation_rate`` N/s while, in a hold (the map nearly still, in contact), the TCP has
    gone less than ``depth_ratio`` x the demonstration's depth past its first contact (a stiffer
    object than the demonstration's needs more force to move as far); never above the
    demonstrated force, and back to ``budget`` once that depth is reached. 0: a fixed budget."""

    budget: float = 7.0
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
    depth_ratio: float = 0.0
    escalation_rate: float = 10.0


class ForceFeedback:
    """The run-time law for ``n`` batch rows, stepped at ``control_hz`` (module docstring)."""

    def __init__(self, profile: ForceProfile, gains: FeedbackGains, fps: float, control_hz: float, n: int):
        self.profile, self.gains, self.fps, self.dt = profile, gains, fps, 1.0 / control_hz
        self.k = 0
        self.u = np.zeros(n)
        self.budget = np.full(n, gains.budget)
        self._contact_at = np.full(n, np.nan)  # the TCP along n at the first contact
        self._reached = np.zeros(n, dtype=bool)  # went the demonstration's depth fraction
        self._tare_sum = np.zeros((n, 3))
        self._prev: Array | None = None

    def expected(self, t: float) -> float:
        """The demonstrated force along n around ``t`` (N; the last frame's value after its end)."""
        e = self.profile.expected
        return float(e[min(int(round(t * self.fps)), len(e) - 1)])

    def reference(self, t: float) -> Array:
        """``F_ref(t)`` per row, N: ``min(budget, expected(t))``."""
        return np.minimum(self.budget, self.expected(t))

    def offset(self) -> Array:
        """The current correction ``(n, 3)`` m added to the targets."""
        return self.u[:, None] * self.profile.normal

    def step(self, targets: Array, force: Array, measured: Array | None = None) -> Array:
        """Corrected target positions ``(n, 3)`` from the map's ``targets (n, 3)``, the measured
        reaction ``force (n, >= 3)`` (N, base frame) and the measured TCP positions ``(n, 3)`` (m;
        only read with ``depth_ratio`` > 0); advances one control step."""
        g, n_vec = self.gains, self.profile.normal
        f = self._tared(np.asarray(force, dtype=np.float64)[:, :3])
        f_ref = self.reference(self.k * self.dt)
        f_n = f @ n_vec
        e = f_n - f_ref
        speed = np.zeros(len(targets)) if self._prev is None else (targets - self._prev) @ n_vec / self.dt
        self._prev = np.array(targets, dtype=np.float64)
        may_push = (
            (g.max_push > 0) & (f_ref > g.f_touch) & (f_n > g.f_touch)
            & (speed >= -g.hold_speed) & (speed <= g.ratchet_speed)
        )  # fmt: skip
        if measured is not None and self.gains.depth_ratio > 0:
            self._escalate(np.asarray(measured, dtype=np.float64) @ n_vec, f_n, may_push)
        self.u = self._advance(e, speed, may_push)
        self.k += 1
        return targets + self.offset()

    def _escalate(self, x: Array, f_n: Array, holding: Array) -> None:
        """Raise the budget of the rows holding short of the demonstration's depth."""
        g = self.gains
        touching = f_n > g.f_touch
        self._contact_at = np.where(np.isnan(self._contact_at) & touching, x, self._contact_at)
        self._reached |= (self._contact_at - x) >= g.depth_ratio * self.profile.depth
        grow = holding & ~self._reached & (self.expected(self.k * self.dt) > self.budget)
        self.budget = np.where(grow, self.budget + g.escalation_rate * self.dt, self.budget)
        self.budget = np.where(self._reached, g.budget, self.budget)

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
