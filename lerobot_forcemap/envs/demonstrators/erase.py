"""``erase`` demonstrator: kinesthetic teaching.

It presses the eraser with a steady force of 12-20 N, where 3 N erases, and wipes the S at
3.5-4.5 cm/s, then lifts and retreats.
"""

from __future__ import annotations

import numpy as np

from ...layout import EE_POS, EE_QUAT, ENV_EE_POSE
from ..tasks.erase import ERASER_STIFFNESS, s_path_base
from .base import PathPlan, ScriptedDemonstrator, Segment, SmoothNoise, move_duration


class EraseDemonstrator(ScriptedDemonstrator):
    """Kinesthetic teaching: steady but higher-than-needed contact force along the S."""

    task = "erase"
    phases = ("approach", "descend", "wipe", "lift", "retreat", "done")

    def __init__(
        self,
        rng,
        *,
        control_hz: float = 20.0,
        state_names=None,
        stiffness: float = 2000.0,
        hold_force: tuple[float, float] = (12.0, 20.0),
        speed: tuple[float, float] = (0.035, 0.045),
        lateral_noise: float = 0.0015,
        depth_noise: float = 0.0015,
    ):
        super().__init__(rng, control_hz=control_hz, state_names=state_names)
        self.stiffness = stiffness
        self.hold_force = hold_force
        self.speed = speed
        self.lateral_noise = lateral_noise
        self.depth_noise = depth_noise

    def reset(self, obs: dict) -> None:
        r = self.rng
        self.t = 0.0
        start = np.asarray(obs[ENV_EE_POSE][EE_POS], float)
        self.quat = np.asarray(obs[ENV_EE_POSE][EE_QUAT], float)
        board = np.array([self.state(obs, n) for n in ("board_x", "board_y", "board_z")])
        bquat = np.array([self.state(obs, n) for n in ("board_qw", "board_qx", "board_qy", "board_qz")])
        path = s_path_base(board, bquat, 200)
        self.target_force = float(r.uniform(*self.hold_force))
        series = 1.0 / (1.0 / self.stiffness + 1.0 / ERASER_STIFFNESS)
        depth = self.target_force / series
        down = np.array([0.0, 0.0, depth])
        seg_len = np.linalg.norm(np.diff(path, axis=0), axis=1)
        v = float(r.uniform(*self.speed))
        self.wipe_speed = v
        above = path[0] + [0, 0, r.uniform(0.04, 0.06)]
        segments = [
            Segment(above, move_duration(start, above, r.uniform(1.4, 2.0)), "approach"),
            Segment(path[0] - down, r.uniform(1.0, 1.4), "descend"),
        ]
        segments += [
            Segment(p - down, float(seg) / v, "wipe") for p, seg in zip(path[1:], seg_len, strict=True)
        ]
        segments += [
            Segment(path[-1] + [0, 0, 0.03], r.uniform(0.8, 1.2), "lift"),
            Segment(path[-1] + [0, 0, r.uniform(0.08, 0.1)], r.uniform(0.8, 1.2), "retreat"),
            Segment(path[-1] + [0, 0, 0.1], 100.0, "done"),
        ]
        # Wipe segments are short straight pieces: min-jerk on each would stop at every piece, so the
        # wipe is sampled with constant speed along the polyline instead (see act()).
        self.plan = PathPlan(start, segments, gripper=0.6)
        self.noise = SmoothNoise(
            r, [self.lateral_noise, self.lateral_noise, self.depth_noise], freq_hz=(0.1, 0.8)
        )
        self.phase = self.phases[0]

    def describe(self) -> dict[str, float]:
        return {"hold_force_target_N": self.target_force, "wipe_speed_m_per_s": self.wipe_speed}

    def act(self, obs: dict) -> np.ndarray:
        self.t += self.dt
        pos, grip, i = self.plan.sample(self.t)
        seg = self.plan.segments[i]
        if seg.phase == "wipe":  # constant speed inside wipe pieces (no stop-and-go)
            a, b = self.plan.seg_start[i], seg.target
            s = (self.t - self.plan.t_start[i]) / seg.duration
            pos = a + np.clip(s, 0, 1) * (b - a)
        self.phase = seg.phase
        noise = self.noise(self.t) if seg.phase in ("descend", "wipe") else np.zeros(3)
        return self._action(pos + noise, self.quat, grip)
