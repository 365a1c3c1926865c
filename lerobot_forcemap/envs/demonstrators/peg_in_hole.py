"""``peg_in_hole`` demonstrator: misjudges the peg position, bumps, re-centres, inserts.

It sees the peg with a 2-4 mm lateral error, descends at 3-4 cm/s, bumps the peg top (reacting after
0.2-0.35 s, so the force builds up to 10-35 N), lifts a little, re-centres and inserts, releases the
disc, retreats.
"""

from __future__ import annotations

import numpy as np

from ...layout import EE_POS, EE_QUAT, ENV_EE_POSE, ENV_FORCE
from ..tasks.peg_in_hole import RING_HALF_THICK
from .base import PathPlan, ScriptedDemonstrator, Segment, SmoothNoise, move_duration


class PegInHoleDemonstrator(ScriptedDemonstrator):
    """Misjudges the peg position by a few mm, bumps the peg top, lifts, re-centres, inserts, releases."""

    task = "peg_in_hole"
    phases = ("approach", "descend", "recover", "insert", "release", "retreat", "done")

    def __init__(
        self,
        rng,
        *,
        control_hz: float = 20.0,
        state_names=None,
        lateral_error: tuple[float, float] = (0.002, 0.004),
        bump_force: float = 4.0,
        reaction_time: tuple[float, float] = (0.2, 0.35),
        descend_speed: tuple[float, float] = (0.03, 0.04),
        insert_speed: float = 0.02,
        insert_depth: float = 0.03,
        tremor: float = 0.0003,
    ):
        super().__init__(rng, control_hz=control_hz, state_names=state_names)
        self.lateral_error = lateral_error
        self.bump_force = bump_force
        self.reaction_time = reaction_time
        self.descend_speed = descend_speed
        self.insert_speed = insert_speed
        self.insert_depth = insert_depth
        self.tremor = tremor

    def reset(self, obs: dict) -> None:
        r = self.rng
        self.t = 0.0
        tcp = np.asarray(obs[ENV_EE_POSE][EE_POS], float)
        self.quat = np.asarray(obs[ENV_EE_POSE][EE_QUAT], float)
        self.peg = np.array([self.state(obs, n) for n in ("peg_x", "peg_y", "peg_z")])
        disc = np.array([self.state(obs, n) for n in ("disc_x", "disc_y", "disc_z")])
        # TCP target = where the disc centre should be, minus the disc's offset in the hand
        self.offset = disc - tcp
        self.half_thick = RING_HALF_THICK
        angle = r.uniform(0, 2 * np.pi)
        self.error = r.uniform(*self.lateral_error) * np.array([np.cos(angle), np.sin(angle), 0.0])
        self.residual = np.append(np.clip(r.normal(0, 0.0003, 2), -0.0008, 0.0008), 0.0)
        self.delay = float(r.uniform(*self.reaction_time))
        self.bump_t = None
        aim = self.peg + self.error
        above = self._tcp_for_disc_bottom(aim, self.peg[2] + r.uniform(0.025, 0.035))
        deep = self._tcp_for_disc_bottom(aim, self.peg[2] - self.insert_depth)
        speed = float(r.uniform(*self.descend_speed))
        self.plan = PathPlan(
            tcp,
            [
                Segment(above, move_duration(tcp, above, r.uniform(1.5, 2.0)), "approach"),
                Segment(deep, float(np.linalg.norm(deep - above)) / speed, "descend"),
            ],
            gripper=1.0,
        )
        self.plan_t0 = 0.0
        self.noise = SmoothNoise(r, [self.tremor] * 3)
        self.recovered = False
        self.finishing = False
        self.phase = self.phases[0]
        self.last_pos = tcp

    def describe(self) -> dict[str, float]:
        return {
            "aim_error_m": float(np.linalg.norm(self.error)),
            "reaction_time_s": self.delay,
            "bumped": float(self.bump_t is not None),
        }

    def _tcp_for_disc_bottom(self, xy: np.ndarray, bottom_z: float) -> np.ndarray:
        disc_centre = np.array([xy[0], xy[1], bottom_z + self.half_thick])
        return disc_centre - self.offset

    def _replan(self, segments: list[Segment], gripper: float) -> None:
        self.plan = PathPlan(self.last_pos, segments, gripper=gripper)
        self.plan_t0 = self.t

    def _sample(self) -> tuple[np.ndarray, float]:
        pos, grip, i = self.plan.sample(self.t - self.plan_t0)
        self.phase = self.plan.segments[i].phase
        return pos, grip

    def act(self, obs: dict) -> np.ndarray:
        self.t += self.dt
        self._feel_bump(obs)
        if self.phase == "descend" and not self.recovered and self.bump_t is not None:
            if self.t - self.bump_t >= self.delay:
                self._plan_recovery(obs)
        pos, grip = self._sample()
        at_end = self.t - self.plan_t0 >= self.plan.duration
        if at_end and not self.finishing and self.phase in ("descend", "insert"):
            pos, grip = self._plan_release(pos)
        self.last_pos = pos
        return self._action(pos + self.noise(self.t), self.quat, grip)

    def _feel_bump(self, obs: dict) -> None:
        """Note the time the descending disc is felt to hit the peg top (the hand reacts after a delay)."""
        force = float(np.linalg.norm(np.asarray(obs[ENV_FORCE][:3], float)))
        # measured (not commanded) disc height: the target runs ahead of the disc when it is blocked
        disc_bottom = float(obs[ENV_EE_POSE][2]) + self.offset[2] - self.half_thick
        if (
            self.phase == "descend"
            and self.bump_t is None
            and force > self.bump_force
            and disc_bottom > self.peg[2] - 0.006
        ):
            self.bump_t = self.t  # keeps pushing until the reaction

    def _plan_recovery(self, obs: dict) -> None:
        """Lift a little, re-centre on the (now felt) axis, insert slowly."""
        r = self.rng
        self.recovered = True
        lifted = np.asarray(obs[ENV_EE_POSE][EE_POS], float) + [0, 0, 0.002]
        centred = self._tcp_for_disc_bottom(
            self.peg + self.residual, lifted[2] + self.offset[2] - self.half_thick
        )
        deep = self._tcp_for_disc_bottom(self.peg + self.residual, self.peg[2] - self.insert_depth)
        self._replan(
            [
                Segment(lifted, r.uniform(0.25, 0.4), "recover"),
                Segment(centred, r.uniform(0.5, 0.8), "recover"),
                Segment(deep, float(np.linalg.norm(deep - centred)) / self.insert_speed, "insert"),
            ],
            gripper=1.0,
        )

    def _plan_release(self, pos: np.ndarray) -> tuple[np.ndarray, float]:
        """At the bottom: open the hand, retreat; returns this step's target and gripper command."""
        r = self.rng
        self.finishing = True
        up = pos + [0, 0, r.uniform(0.08, 0.1)]
        self.last_pos = pos
        self._replan(
            [
                Segment(pos, r.uniform(0.6, 0.9), "release", gripper=0.0),
                Segment(up, r.uniform(1.2, 1.6), "retreat"),
                Segment(up, 100.0, "done"),
            ],
            gripper=0.0,
        )
        return self._sample()
