"""The shared part of the Gen3 grasping demonstrators (``grasp_push``, ``grasp_flip``).

Teleoperation with a three-finger hand: a pre-grasp manipulation (the subclass's: push the book
upright, flip the carton), then grasp, lift and hold.
"""

from __future__ import annotations

import abc
from typing import ClassVar

import numpy as np

from ...geometry import quat_to_matrix
from ...layout import EE_POS, EE_QUAT, ENV_EE_POSE, ENV_FINGER_FORCE
from ..robots.three_finger_gripper import PAD_RADIUS, PALM_LENGTH, TCP_Z
from .base import PathPlan, ScriptedDemonstrator, Segment, SmoothNoise, move_duration


class GraspDemonstrator(ScriptedDemonstrator):
    """Teleoperation with a three-finger hand: a pre-grasp manipulation, then grasp, lift and hold.

    The pre-grasp part is the subclass's (push the book upright / flip the carton); the rest is shared:
    from the object's observed pose (``environment_state``) it picks a grasp point (the object's centre,
    raised along its most vertical axis until the palm clears the object's top), reaches above it with
    the hand open, descends, closes the hand at a constant rate until the largest fingertip force reaches
    its target — 18-30 N where 1-2 N hold the object: squeezing harder than needed — holds that command,
    lifts 10-13 cm and holds. Hand noise: smooth tremor of ~1 mm in free motion, a 0-3 mm aim error.
    """

    phases: ClassVar[tuple[str, ...]]
    pregrasp_phases: ClassVar[tuple[str, ...]]
    GRASP_PHASES: ClassVar[tuple[str, ...]] = ("reach", "descend", "grasp", "lift", "hold")

    def __init__(
        self,
        rng,
        *,
        control_hz: float = 20.0,
        state_names=None,
        squeeze_force: tuple[float, float] = (18.0, 30.0),
        close_rate: tuple[float, float] = (0.4, 0.6),
        lift_height: tuple[float, float] = (0.10, 0.13),
        tremor: float = 0.001,
        aim_error: float = 0.003,
    ):
        super().__init__(rng, control_hz=control_hz, state_names=state_names)
        self.squeeze_force = squeeze_force
        self.close_rate = close_rate
        self.lift_height = lift_height
        self.tremor = tremor
        self.aim_error = aim_error

    # ---- observation helpers -------------------------------------------------------------------------
    def object_pose(self, obs: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centre (3,), rotation matrix (3, 3) and half extents (3,) of the object (base frame)."""
        c = np.array([self.state(obs, n) for n in ("obj_x", "obj_y", "obj_z")])
        q = np.array([self.state(obs, n) for n in ("obj_qw", "obj_qx", "obj_qy", "obj_qz")])
        h = np.array([self.state(obs, n) for n in ("obj_hx", "obj_hy", "obj_hz")])
        return c, quat_to_matrix(q), h

    def grasp_point(self, obs: dict) -> tuple[np.ndarray, float]:
        """TCP grasp target (3,) and the object's top height (m), from its oriented bounding box."""
        c, rot, h = self.object_pose(obs)
        top = c[2] + np.abs(rot[2]) @ h
        axis = rot[:, int(np.argmax(np.abs(rot[2]) * h))]
        axis = axis if axis[2] >= 0 else -axis
        reach = TCP_Z - PALM_LENGTH  # TCP to the palm's face
        z = max(c[2], top - reach + 0.012)  # as low as the palm allows: a stable grasp
        point = c + axis * (z - c[2]) / max(axis[2], 0.3)
        point[2] = max(z, PAD_RADIUS + 0.006) + 0.004  # pads sit ~4 mm below the TCP when closing
        return point, float(top)

    def max_finger_force(self, obs: dict) -> float:
        f = np.asarray(obs[ENV_FINGER_FORCE], float).reshape(-1, 3)
        return float(np.linalg.norm(f, axis=1).max())

    # ---- episode -----------------------------------------------------------------------------------------
    def reset(self, obs: dict) -> None:
        if ENV_FINGER_FORCE not in obs:  # it squeezes until the fingertips feel the target force
            raise ValueError(
                f"{type(self).__name__}: the observation has no {ENV_FINGER_FORCE!r}; the grasp demonstrators "
                "need a gripper with fingertip force sensors (the Gen3's three-finger gripper)"
            )
        r = self.rng
        self.t = 0.0
        self.start = np.asarray(obs[ENV_EE_POSE][EE_POS], float)
        self.quat = np.asarray(obs[ENV_EE_POSE][EE_QUAT], float)
        self.target_force = float(r.uniform(*self.squeeze_force))
        self.rate = float(r.uniform(*self.close_rate))
        self.lift = float(r.uniform(*self.lift_height))
        angle = r.uniform(0, 2 * np.pi)
        self.aim = r.uniform(0, self.aim_error) * np.array([np.cos(angle), np.sin(angle), 0.0])
        self.noise = SmoothNoise(r, [self.tremor] * 3)
        self.speed = float(r.uniform(0.10, 0.13))
        self.last_pos = self.start.copy()
        self.grip = 0.0
        self.plan = None
        self.plan_t0 = 0.0
        self.squeeze_done_t = None
        self.achieved_force = 0.0
        self.phase = self.phases[0]
        self.reset_pregrasp(obs)

    def describe(self) -> dict[str, float]:
        return {
            "squeeze_force_target_N": self.target_force,
            "squeeze_force_reached_N": self.achieved_force,
            "grip_command": self.grip,
            "close_rate_per_s": self.rate,
            "lift_height_m": self.lift,
        }

    @abc.abstractmethod
    def reset_pregrasp(self, obs: dict) -> None: ...

    @abc.abstractmethod
    def act_pregrasp(self, obs: dict) -> tuple[np.ndarray, float] | None:
        """Target and gripper command during the pre-grasp phases; None once they are over."""

    def _replan(self, segments: list[Segment], gripper: float) -> None:
        self.plan = PathPlan(self.last_pos, segments, gripper=gripper)
        self.plan_t0 = self.t

    def _sample(self) -> tuple[np.ndarray, float, str]:
        pos, grip, i = self.plan.sample(self.t - self.plan_t0)
        return pos, grip, self.plan.segments[i].phase

    def _plan_grasp(self, obs: dict) -> None:
        r = self.rng
        point, top = self.grasp_point(obs)
        self.grasp_target = point + self.aim
        above = self.grasp_target.copy()
        above[2] = max(point[2] + 0.06, top + 0.05)
        self._replan(
            [
                Segment(above, move_duration(self.last_pos, above, r.uniform(1.2, 1.6), self.speed * 1.5), "reach", 0.0),
                Segment(self.grasp_target, move_duration(above, self.grasp_target, r.uniform(1.0, 1.3), self.speed), "descend"),
            ],
            gripper=0.0,
        )  # fmt: skip
        self.grip = 0.0

    def act(self, obs: dict) -> np.ndarray:
        self.t += self.dt
        if self.phase in self.pregrasp_phases:
            out = self.act_pregrasp(obs)
            if out is not None:
                pos, grip = out
                self.last_pos = pos
                return self._action(pos, self.quat, grip)
            self._plan_grasp(obs)
        if self.phase in ("reach", "descend"):
            pos, grip, phase = self._sample()
            self.phase = phase
            if self.t - self.plan_t0 >= self.plan.duration:
                self.phase = "grasp"
        if self.phase == "grasp":
            return self._squeeze(obs)
        pos, _, phase = self._sample()
        self.phase = phase
        self.last_pos = pos
        noise = self.noise(self.t) if self.phase in ("reach", "lift", "hold") else np.zeros(3)
        grip = self.grip if self.phase in ("lift", "hold") else 0.0
        return self._action(pos + noise, self.quat, grip)

    def _squeeze(self, obs: dict) -> np.ndarray:
        """At the grasp point: close until the target fingertip force, hold 0.3 s, then plan the lift."""
        pos = self.grasp_target
        force = self.max_finger_force(obs)
        if self.squeeze_done_t is None:
            if force >= self.target_force or self.grip >= 1.0:
                self.squeeze_done_t = self.t
                self.achieved_force = force
            else:
                self.grip = min(1.0, self.grip + self.rate * self.dt)
        elif self.t - self.squeeze_done_t >= 0.3:
            up = self.grasp_target + [0.0, 0.0, self.lift]
            self._replan(
                [
                    Segment(up, move_duration(pos, up, self.rng.uniform(1.2, 1.6), self.speed), "lift"),
                    Segment(up, 100.0, "hold"),
                ],
                gripper=self.grip,
            )
            self.phase = "lift"
        self.last_pos = pos
        return self._action(pos, self.quat, self.grip)
