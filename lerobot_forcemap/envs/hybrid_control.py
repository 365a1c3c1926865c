"""Hybrid force/position control baseline (paper §IV-D, after Raibert & Craig 1981).

The policy replays a demonstration's actions (absolute TCP targets, one per control step) in
position control until the measured contact force along the contact normal exceeds
``force_threshold``; it then regulates that force instead (PI on the force error, acting on the
impedance target along the normal) while the tangential motion, orientation and gripper keep
following the demonstration. It returns to position control when the demonstration's target
withdraws from the surface past the force-controlled target, or when the force drops below
``release_fraction * force_threshold`` (contact lost).

Force control through the impedance controller: along the normal ``n`` (unit, pointing away from the
surface, base frame) the reaction force is ``F = K (x_tcp - x_target) . n``; so the target
``x_target.n = x_tcp.n - (F_set + u_I) / K`` with the integral ``u_I += k_I (F_set - F) dt``.

``n`` is either fixed (``normal=(0, 0, 1)`` for a horizontal surface) or the direction of the measured
force when force control engages (``normal=None``), then frozen until position control resumes.
The policy reads the ``force`` and ``ee_pose`` observations (``lerobot_forcemap.layout`` keys).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validation import check_array, check_real, fail
from ..layout import ACTION_DIM, EE_POS, ENV_EE_POSE, ENV_FORCE, FORCE_LINEAR

POSITION = "position"
FORCE = "force"


@dataclass(frozen=True)
class HybridConfig:
    force_threshold: float = 10.0  # N: engage force control above this normal force
    force_setpoint: float | None = None  # N: regulated normal force (default: the threshold)
    stiffness: float = 2000.0  # N/m: the impedance controller's stiffness along the normal
    integral_gain: float = 2.0  # 1/s: integral action on the force error
    normal: tuple[float, float, float] | None = (0.0, 0.0, 1.0)  # None: from the measured force
    release_fraction: float = 0.3  # back to position control when the force drops below this * threshold
    control_hz: float = 20.0

    def __post_init__(self):
        # NaN passes a `<= 0` test and then never engages force control (or returns NaN targets)
        for name, unit in (("force_threshold", "N"), ("stiffness", "N/m"), ("control_hz", "Hz")):
            check_real(f"HybridConfig.{name}", getattr(self, name), low=0.0, low_open=True, unit=unit)
        check_real(
            "HybridConfig.force_setpoint", self.force_setpoint, low=0.0, low_open=True, unit="N", none_ok=True
        )
        check_real("HybridConfig.integral_gain", self.integral_gain, low=0.0, unit="1/s")
        check_real("HybridConfig.release_fraction", self.release_fraction, low=0.0, high=1.0, high_open=True)
        if self.normal is not None:
            n = np.asarray(self.normal, dtype=float)
            if n.shape != (3,) or not np.all(np.isfinite(n)) or np.linalg.norm(n) < 1e-9:
                fail("HybridConfig.normal", "be a finite non-zero 3-vector (or None: measured)", self.normal)


class HybridForcePositionPolicy:
    """``act(obs) -> action``: replay ``demo_actions (T, 8)``, switching to force control above a threshold.

    ``reset(offset=...)`` restarts the replay; ``offset (3,)`` translates the demonstration (e.g. by the
    difference between the object's position now and in the demonstration). ``modes`` records the
    mode used at each step.
    """

    def __init__(self, demo_actions: np.ndarray, config: HybridConfig = HybridConfig()):
        self.demo = check_array(
            "demo_actions", demo_actions, shape=(None, ACTION_DIM), min_len=1, axes=("step", "column")
        )
        self.config = config
        self.reset()

    @property
    def setpoint(self) -> float:
        c = self.config
        return c.force_threshold if c.force_setpoint is None else c.force_setpoint

    def reset(self, offset: np.ndarray | None = None) -> None:
        self.offset = np.zeros(3) if offset is None else np.asarray(offset, dtype=float).reshape(3)
        self.step = 0
        self.mode = POSITION
        self.normal = None
        self.integral = 0.0
        self.modes: list[str] = []

    def act(self, obs: dict) -> np.ndarray:
        c = self.config
        demo = self.demo[min(self.step, len(self.demo) - 1)].copy()
        demo[:3] += self.offset
        self.step += 1
        force = np.asarray(obs[ENV_FORCE], dtype=float)[FORCE_LINEAR]
        tcp = np.asarray(obs[ENV_EE_POSE], dtype=float)[EE_POS]
        if self.mode == POSITION:
            n = self._normal(force)
            if n is not None and float(force @ n) > c.force_threshold:
                self.mode, self.normal, self.integral = FORCE, n, 0.0
        action = demo
        if self.mode == FORCE:
            n = self.normal
            f_n = float(force @ n)
            self.integral += c.integral_gain * (self.setpoint - f_n) / c.control_hz
            target_n = float(tcp @ n) - (self.setpoint + self.integral) / c.stiffness
            demo_n = float(demo[:3] @ n)
            if demo_n >= target_n or f_n < c.release_fraction * c.force_threshold:
                self.mode, self.normal = POSITION, None  # the demonstration withdraws, or contact is lost
            else:
                action = demo.copy()
                action[:3] = demo[:3] + (target_n - demo_n) * n
        self.modes.append(self.mode)
        return action.astype(np.float32)

    def _normal(self, force: np.ndarray) -> np.ndarray | None:
        if self.config.normal is not None:
            n = np.asarray(self.config.normal, dtype=float)
            return n / np.linalg.norm(n)
        norm = float(np.linalg.norm(force))
        return force / norm if norm > 1e-9 else None
