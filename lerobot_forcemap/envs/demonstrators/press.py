"""``press`` demonstrator: VR teleoperation without haptics.

It descends onto the button and keeps pushing past the hard stop: the commanded depth is chosen so
that the excess force is 35-75 N (below the 100 N protective stop), then holds, retreats.
"""

from __future__ import annotations

import numpy as np

from ...layout import EE_POS, EE_QUAT, ENV_EE_POSE
from ..tasks.press import TRAVEL
from .base import PathPlan, ScriptedDemonstrator, Segment, SmoothNoise, move_duration


class PressDemonstrator(ScriptedDemonstrator):
    """VR teleoperation without haptics: overshoots the button's travel (excess force, below the stop)."""

    task = "press"
    phases = ("approach", "descend", "press", "hold", "retreat", "done")

    def __init__(
        self,
        rng,
        *,
        control_hz: float = 20.0,
        state_names=None,
        stiffness: float = 2000.0,
        excess_force: tuple[float, float] = (35.0, 75.0),
        lateral_error: float = 0.0015,
        tremor: float = 0.0008,
    ):
        super().__init__(rng, control_hz=control_hz, state_names=state_names)
        self.stiffness = stiffness
        self.excess_force = excess_force
        self.lateral_error = lateral_error
        self.tremor = tremor

    def reset(self, obs: dict) -> None:
        r = self.rng
        self.t = 0.0
        start = np.asarray(obs[ENV_EE_POSE][EE_POS], float)
        self.quat = np.asarray(obs[ENV_EE_POSE][EE_QUAT], float)
        p = np.array([self.state(obs, "button_x"), self.state(obs, "button_y"), self.state(obs, "button_z")])
        self.aim_error = np.clip(
            r.normal(0, self.lateral_error, 2), -2.5 * self.lateral_error, 2.5 * self.lateral_error
        )
        p[:2] += self.aim_error
        self.target_excess = float(r.uniform(*self.excess_force))
        # Cap bottoms out ~TRAVEL below the press point; beyond it the force grows with the stiffness.
        depth = TRAVEL + self.target_excess / self.stiffness
        above = p + [0, 0, r.uniform(0.04, 0.06)]
        contact = p + [0, 0, 0.002]
        approach_time = move_duration(start, above, r.uniform(1.4, 2.0))
        bottom = p - [0, 0, depth]
        retreat = p + [0, 0, r.uniform(0.06, 0.09)]
        self.plan = PathPlan(
            start,
            [
                Segment(above, approach_time, "approach"),
                Segment(contact, r.uniform(0.8, 1.2), "descend"),
                Segment(bottom, r.uniform(0.5, 0.8), "press"),
                Segment(bottom, r.uniform(0.3, 0.6), "hold"),
                Segment(retreat, r.uniform(1.0, 1.5), "retreat"),
                Segment(retreat, 100.0, "done"),
            ],
            gripper=1.0,
        )
        self.noise = SmoothNoise(r, [self.tremor] * 3)
        self.phase = self.phases[0]

    def describe(self) -> dict[str, float]:
        return {
            "excess_force_target_N": self.target_excess,
            "aim_error_m": float(np.linalg.norm(self.aim_error)),
        }

    def act(self, obs: dict) -> np.ndarray:
        self.t += self.dt
        pos, grip, i = self.plan.sample(self.t)
        self.phase = self.plan.segments[i].phase
        return self._action(pos + self.noise(self.t), self.quat, grip)
