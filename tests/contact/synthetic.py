"""Synthetic kinesthetic recordings with a known guiding hand and a known contact (no MuJoCo).

A hand guides a tool down onto a table at ``SURFACE_Z``: the tool descends at ``V_IMPACT``, the table
stops it within 20 ms (touch-down), it dwells there, then rises (lift-off). The wrist sensor reads the
hand's force, which follows the guiding-force model exactly (bias, viscous and Coulomb drag, no
inertia; motion 0.05 s behind the force), plus the table's reaction: an impact spike and a steady push
during the dwell. Everything in the base frame, +z up; the force is the reaction on the robot.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SURFACE_Z = 0.10
V_IMPACT = 0.15
HAND_BIAS = np.array([1.0, -2.0, -5.0])
HAND_DAMPING = 30.0  # N s/m
HAND_COULOMB = 3.0  # N
HAND_LAG_S = 0.05
IMPACT_N = 35.0
STEADY_N = 12.0


@dataclass
class Recording:
    """times (T,) s, positions (T, 3) m, force (T, 3) N measured, hand (T, 3) N and reaction (T, 3) N
    (their sum is ``force`` without noise), touch_down / lift_off s (lift-off by the detector's rule:
    the last sample within 2 mm of the dwell height), the dwell height."""

    times: np.ndarray
    positions: np.ndarray
    force: np.ndarray
    hand: np.ndarray
    reaction: np.ndarray
    touch_down: float
    lift_off: float


def min_jerk(s: np.ndarray) -> np.ndarray:
    s = np.clip(s, 0.0, 1.0)
    return s**3 * (10 - 15 * s + 6 * s**2)


def _z_path(t: np.ndarray, dt: float) -> tuple[np.ndarray, float, float]:
    """Height (T,), touch-down and the start of the rise: rest, descent (velocity ramping to -V_IMPACT
    over 0.6 s, then constant), a stop within 20 ms at the table, a 0.6 s dwell, a 1.2 s rise."""
    ramp = 0.6
    t1 = 0.5
    travel = 0.30 - SURFACE_Z
    td = t1 + ramp + (travel - V_IMPACT * ramp / 2) / V_IMPACT
    v = -V_IMPACT * min_jerk((t - t1) / ramp)
    v = np.where(t >= td, -V_IMPACT * (1 - min_jerk((t - td) / 0.02)), v)
    z = 0.30 + np.cumsum(v) * dt
    z = np.maximum(z, SURFACE_Z)  # the table
    rise = td + 0.6
    z = np.where(t >= rise, SURFACE_Z + 0.2 * min_jerk((t - rise) / 1.2), z)
    return z, float(td), float(rise)


def kinesthetic_press(
    rate: float = 500.0, seed: int = 0, push_into: float = 0.0, wipe: float = 0.0, noise: float = 0.2
) -> Recording:
    """The press (module docstring) at ``rate`` Hz. ``push_into`` (N): the hand also pushes this much
    down during the dwell, beyond its model (an unobservable static press); ``wipe`` (m): the tool
    circles with this radius on the table during the dwell (a wipe)."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate
    t = np.arange(int(round(4.6 * rate))) * dt
    z, td, rise = _z_path(t, dt)
    # sideways while the descent starts and while the rise ends: the approach itself is vertical
    x = 0.40 + 0.10 * min_jerk((t - 0.5) / 0.6) - 0.10 * min_jerk((t - rise - 0.2) / 1.0)
    y = 0.03 * min_jerk((t - 0.5) / 0.8) - 0.03 * min_jerk((t - rise - 0.4) / 0.8)
    dwell = (t >= td) & (t < rise)
    if wipe:
        phase = 2 * np.pi * np.clip((t - td - 0.05) / (rise - td - 0.1), 0.0, 1.0)
        x = x + wipe * np.sin(phase) * dwell
        y = y + wipe * (1 - np.cos(phase)) * dwell
    p = np.stack([x, y, z], axis=1)
    hand = _hand(t, p, dt, active=(t > 0.45) & (t < rise + 1.5))
    hand[dwell, 2] -= push_into
    reaction = np.zeros_like(p)
    spike = np.maximum(0.0, 1.0 - np.abs(t - td - 0.015) / 0.015)  # 30 ms triangle
    reaction[:, 2] = IMPACT_N * spike + STEADY_N * dwell * np.clip((rise - t) / 0.1, 0.0, 1.0)
    force = hand + reaction + noise * rng.standard_normal(p.shape)
    above = np.flatnonzero((t >= td) & (z <= SURFACE_Z + 0.002))
    return Recording(t, p, force, hand, reaction, td, float(t[above[-1]]))


def _hand(t: np.ndarray, p: np.ndarray, dt: float, active: np.ndarray) -> np.ndarray:
    """The guiding hand's force: the model's bias, drag and Coulomb terms on the motion HAND_LAG_S later,
    while the hand is on the robot."""
    v = np.gradient(p, dt, axis=0)
    lag = int(round(HAND_LAG_S / dt))
    ahead = np.clip(np.arange(len(t)) + lag, 0, len(t) - 1)
    v = v[ahead]
    force = HAND_BIAS + HAND_DAMPING * v + HAND_COULOMB * np.tanh(v / 0.02)
    return force * active[:, None]


def free_motion(rate: float = 500.0, seed: int = 1) -> Recording:
    """A hand tracing a circle in the air (no contact): the wrench is the hand's force alone."""
    rng = np.random.default_rng(seed)
    dt = 1.0 / rate
    t = np.arange(int(round(5.0 * rate))) * dt
    s = min_jerk((t - 0.5) / 4.0)
    angle = 2 * np.pi * s
    p = np.stack([0.5 + 0.1 * np.cos(angle), 0.1 * np.sin(angle), 0.3 + 0.05 * np.sin(2 * angle)], axis=1)
    hand = _hand(t, p, dt, active=(t > 0.45) & (t < 4.55))
    force = hand + 0.2 * rng.standard_normal(p.shape)
    return Recording(t, p, force, hand, np.zeros_like(p), float("nan"), float("nan"))
