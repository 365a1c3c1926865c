"""The yield rule: in an expected contact, the map's own motion into a measured force slanted from
the demonstrated normal is held back once that force builds up, so the force no longer grows with
the controller's stiffness. Pure NumPy.

After a touch-down the map goes on at the demonstration's pace. Where the object does not give way at
once (a peg resting on the hole's rim until the map's sideways motion brings it over the hole), the
target runs ahead of the TCP by the map's step each control step, and the force grows by the
controller's stiffness times that step: one or two steps at 20 Hz, before the force feedback (a rate
law along the demonstration's normal n) can answer. The measured force's direction, not n, tells
which part of the map's step presses into the object: the demonstrated n can be tilted far from it
(the peg's, 53 degrees, by the sideways rubbing summed into it).

Each control step, per batch row (``f`` the measured reaction as the force feedback tared it: less
the mean of its first observations, away from the surface; ``f_side = |f - (f . n) n|`` its part across the
demonstrated normal n; ``s`` the map's own target step, m; ``F_ref`` the force feedback's reference;
``slanted``: the contact at hand was met at a slant, ``lerobot_forcemap.skill.approach``)::

    p = f_side + max(f_side - f_side_prev, 0)   across n, a step ahead at its current rise
    hold where slanted, F_ref > f_touch, |f| > f_touch, f_side > SLANT (f . n) and p > level F_ref:
        w -= min(s . f^, 0) f^                  the step's part into the force is not taken,
                                                if s goes into the surface (s . n < -INTO |s|)
    elsewhere: w decays with TAU                the target rejoins the map
    target = map target + feedback's correction + w,   |w| <= max_offset

A force along n (within 27 degrees: a press) is the feedback's to hold, and it is left to it, as is a
contact met along n: a real press whose kinesthetic n is tilted from the button's axis reads slanted
forces too. The step's part along the surface (the sideways motion that centres a peg) is kept, and so
is what the feedback itself pushes in or takes back (the map's step counts only as far as the corrected
target's step goes into the force). A step that does not go into the surface (a wipe's sliding, whose
friction can tilt the reaction well past 27 degrees and stall the tool for a moment) holds nothing new
back.
Units: m, s, N.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap.skill.approach import SLANT

__all__ = ["ContactYield", "TAU", "SLANT", "INTO"]

Array = NDArray[np.float64]

#: s, how fast a held-back offset returns to the map once the force allows it
TAU = 0.3
#: the least share of the map's step along -n for it to go into the surface (17 degrees below it)
INTO = 0.3


class ContactYield:
    """The rule for ``n`` batch rows stepped every ``dt`` s: ``normal (3,)`` the demonstration's
    contact normal (unit, base frame), ``level`` (fraction of F_ref, 0: off), ``max_offset`` m,
    ``f_touch`` N (module docstring)."""

    def __init__(
        self,
        normal: Array,
        level: float,
        max_offset: float,
        f_touch: float,
        dt: float,
        n: int,
    ):
        self.normal = np.asarray(normal, dtype=np.float64).reshape(3)
        self.level, self.max_offset, self.f_touch = float(level), float(max_offset), float(f_touch)
        self.dt = float(dt)
        self.w = np.zeros((n, 3))  # m, the offset held back, base frame
        self._prev_target: tuple[Array, Array] | None = None  # the planned and corrected targets
        self._prev_force = np.zeros(n)

    def step(self, planned: Array, corrected: Array, force: Array, f_ref: Array, slanted: Array) -> Array:
        """The offset ``(n, 3)`` m to add to the ``corrected (n, 3)`` targets (the map's ``planned
        (n, 3)`` ones with the force feedback's correction; m, base frame) from the tared reaction
        ``force (n, >= 3)`` (N, base frame: ``ForceFeedback.force``), the feedback's reference ``f_ref
        (n,)`` N and ``slanted (n,)`` bool (``ApproachLimit.slanted_at``); advances one control step."""
        planned, corrected = np.asarray(planned, dtype=np.float64), np.asarray(corrected, dtype=np.float64)
        f = np.asarray(force, dtype=np.float64)[:, :3]
        mag = np.linalg.norm(f, axis=1)
        unit = f / np.maximum(mag, 1e-12)[:, None]
        prev = (planned, corrected) if self._prev_target is None else self._prev_target
        self._prev_target = (planned.copy(), corrected.copy())
        into = _into(planned - prev[0], corrected - prev[1], unit, self.normal)
        along = f @ self.normal
        side = np.linalg.norm(f - along[:, None] * self.normal, axis=1)
        ahead = side + np.maximum(side - self._prev_force, 0.0)
        self._prev_force = side
        hold = (
            (self.level > 0) & np.asarray(slanted, dtype=bool) & (f_ref > self.f_touch) & (mag > self.f_touch)
            & (ahead > self.level * f_ref) & (side > SLANT * along)
        )  # fmt: skip
        held = self.w - into[:, None] * unit
        size = np.linalg.norm(held, axis=1, keepdims=True)
        held *= np.minimum(1.0, self.max_offset / np.maximum(size, 1e-12))
        self.w = np.where(hold[:, None], held, self.w * (1.0 - min(1.0, self.dt / TAU)))
        return self.w.copy()


def _into(map_step: Array, corrected_step: Array, unit: Array, normal: Array) -> Array:
    """(n,) m <= 0: the map's step ``(n, 3)`` along the force's unit ``unit``, no more than the
    corrected target's step (what the feedback already took back is not held back twice; its own push
    is not held back at all); 0 where the map's step does not go into the surface (module docstring)."""
    along_map = np.einsum("nk,nk->n", map_step, unit)
    along_corrected = np.einsum("nk,nk->n", corrected_step, unit)
    into_surface = map_step @ normal < -INTO * np.linalg.norm(map_step, axis=1)
    return np.where(into_surface, np.minimum(np.maximum(along_map, along_corrected), 0.0), 0.0)
