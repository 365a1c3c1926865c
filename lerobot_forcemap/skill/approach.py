"""The approach rule: near where the demonstration made contact, the skill's clock slows so that the
target moves into the contact at most ``speed``, until a force is felt. Pure NumPy.

A touch-down at the demonstration's speed (several cm/s) is over within one control step: the
target is already past the surface when the TCP gets there, so the impact force grows with the
controller's stiffness, and the force feedback acts a step too late to undo it.

Contacts are those of the demonstration's profile (``ForceProfile.along``): the frames where its
force along n first exceeds ``level``. For each contact and batch row, ``p`` is the placed map's
target at that time and ``a`` the unit direction the map moved into it over the ``LEAD_S`` before
(``-n`` when it moved less than ``MIN_LEAD``): the touch-down's direction, which for a contact met
at a slant (a chamfer, a rim) is not the normal of the demonstrated reaction. A contact's zone is
the stretch within ``zone`` m of ``p`` along ``a``, before or past it (the demonstrated target lags
the TCP, so the surface lies before ``p``). While the target's step touches a zone and would carry
it more than ``speed * dt`` along ``a``, the clock advances less than ``dt`` (``dt * speed / v`` for a
map moving steadily at ``v``): the whole skill slows (gripper and sideways motion too), so its parts
stay in step. A row that feels a force in a zone (``felt``) is done with that contact: the skill
resumes its own pace and the force feedback takes over. The rows share one clock: the slowest row's
rate holds for all. A contact makes the episode longer by up to ``2 zone / speed`` (no force felt;
about half that when the touch comes at ``p``) less the map's own time in the zone. Units: m, s.

Only a *slanted* touch-down is slowed: ``a`` more than 27 degrees (tan ``SLANT``) from ``-n``. A
touch-down along n is the force feedback's (its depth law holds a press whatever the controller's
stiffness), and there the slower touch would only take away the force a stiff real button needs. A
slanted one (the peg's disc meeting the peg's top while its demonstrated n is tilted about 50 degrees
by the chamfer's sideways reaction) is one the feedback's correction along n cannot undo. Which
contacts are slanted (``slanted``, per row) also tells the yield rule where it may act.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from numpy.typing import NDArray

__all__ = ["ApproachLimit", "contact_starts", "LEAD_S", "MIN_LEAD", "REFINE", "SLANT"]

Array = NDArray[np.float64]

#: s, the map's motion over this long before a contact gives the touch-down's direction
LEAD_S = 0.25
#: m, less motion than this over LEAD_S: the direction is -n
MIN_LEAD = 1e-3
#: the most times a step is shortened to keep within the speed (the map's speed varies within it)
REFINE = 4
#: the least tan of the angle from the demonstrated normal that makes a touch-down, or a force, slanted
#: (27 degrees)
SLANT = 0.5
#: a touch-down direction ``a`` is slanted where ``-a . n`` is below this (the cos of that angle)
_ALONG_N_COS = 1.0 / np.sqrt(1.0 + SLANT**2)


def contact_starts(along: Array, fps: float, level: float) -> Array:
    """Times ``(E,)`` s of the frames where ``along (T,)`` (N, the force along n at ``fps``) first
    exceeds ``level`` after a frame at or below it (a contact from the first frame counts too)."""
    on = np.asarray(along, dtype=np.float64) > level
    first = on & ~np.concatenate([[False], on[:-1]])
    return np.flatnonzero(first) / float(fps)


class ApproachLimit:
    """The rule for ``n`` batch rows: ``starts (E,)`` s (:func:`contact_starts`), ``normal (3,)``
    unit, base frame, away from the surface; ``speed`` m/s (0: the clock is never slowed, the
    touch-downs are still classified), ``zone`` m (module docstring)."""

    def __init__(self, starts: Array, normal: Array, speed: float, zone: float, n: int):
        self.starts = np.asarray(starts, dtype=np.float64).reshape(-1)
        self.normal = np.asarray(normal, dtype=np.float64).reshape(3)
        self.speed, self.zone = float(speed), float(zone)
        self.done = np.zeros((n, len(self.starts)), dtype=bool)  # felt in that contact's zone
        self.slanted = np.zeros((n, len(self.starts)), dtype=bool)  # the touch-down is slanted from -n

    def slanted_at(self, t: float) -> NDArray[np.bool_]:
        """``(n,)``: the rows whose contact nearest in time to skill time ``t`` (s) has a slanted
        touch-down (as of the last :meth:`rate`); all False without contacts."""
        if len(self.starts) == 0:
            return np.zeros(len(self.done), dtype=bool)
        return self.slanted[:, int(np.argmin(np.abs(self.starts - t)))]

    def rate(self, positions_at: Callable[[Array], Array], t: float, dt: float, felt: Array) -> float:
        """The clock's rate in (0, 1] for the step from skill time ``t`` (s) of length ``dt`` (s);
        ``positions_at(times (K,))`` gives the placed targets ``(n, K, 3)`` (m, base frame);
        ``felt (n,)``: the rows that feel a force now. Updates :attr:`slanted` (the placement may
        have moved since the last call)."""
        if len(self.starts) == 0:
            return 1.0
        e = len(self.starts)
        p = positions_at(np.concatenate([[t, t + dt], self.starts, self.starts - LEAD_S]))
        at, before = p[:, 2 : 2 + e], p[:, 2 + e :]  # (n, E, 3)
        into = at - before
        norm = np.linalg.norm(into, axis=-1, keepdims=True)
        into = np.where(norm > MIN_LEAD, into / np.maximum(norm, 1e-12), -self.normal)
        self.slanted = -(into @ self.normal) < _ALONG_N_COS
        if self.speed <= 0:
            return 1.0
        to_go = np.einsum("nek,nek->ne", at - p[:, None, 0], into)  # (n, E) m still to go
        to_go_next = np.einsum("nek,nek->ne", at - p[:, None, 1], into)
        near = (np.minimum(to_go, to_go_next) <= self.zone) & (np.maximum(to_go, to_go_next) >= -self.zone)
        self.done |= near & np.asarray(felt, dtype=bool).reshape(-1, 1)
        watch = near & ~self.done & self.slanted
        return self._shortened(positions_at, p[:, 0], into, watch, t, dt)

    def _shortened(self, positions_at, now: Array, into: Array, watch: Array, t: float, dt: float) -> float:
        """The largest rate <= 1 at which no watched contact's target moves in more than
        ``speed * dt`` (``now (n, 3)``: the targets at ``t``; ``into (n, E, 3)``; ``watch (n, E)``)."""
        step = self.speed * dt  # m, the most the target may move in per call
        r = 1.0
        for _ in range(REFINE):  # the map's speed varies within a step: shorten it until it fits
            ahead = positions_at(np.array([t + r * dt]))[:, 0]
            moved = np.einsum("nek,nek->ne", np.broadcast_to(ahead[:, None] - now[:, None], into.shape), into)
            worst = float(np.max(moved[watch], initial=0.0))
            if worst <= step * (1 + 1e-6):
                break
            r *= step / worst
        return r
