"""``grasp_push`` demonstrator: the fist pushes the book against the wall until it stands upright,
then the shared grasp."""

from __future__ import annotations

import numpy as np

from ..robots.three_finger_gripper import PAD_RADIUS, TCP_Z, pad_position
from .base import Segment, move_duration
from .grasping import GraspDemonstrator


class GraspPushDemonstrator(GraspDemonstrator):
    """Pushes the book against the wall until it stands upright, then grasps it.

    The closed hand (a fist) pushes with its thumb pad, closed-loop on the book's observed pose (a person
    watching the book): ``slide`` pushes the rear face horizontally (3-4.5 cm/s) until the book meets the
    wall; ``tip`` keeps the pad on the book's rear-top edge and leads it by 4-6 mm along a direction
    between the face normal and the edge's circle about the pivot (the book's front-bottom edge at the
    wall): the pad's normal force lifts the edge while pressing the book against the wall (10-16 N on the
    thumb pad). At 83-86 degrees of tilt the hand backs off, then opens; the book stands upright. Objects
    that are not long and flat in the push direction (the unseen apple and banana) are only slid to the wall.
    """

    task = "grasp_push"
    pregrasp_phases = ("approach", "slide", "tip", "retreat")
    phases = (*pregrasp_phases, *GraspDemonstrator.GRASP_PHASES)

    def reset_pregrasp(self, obs: dict) -> None:
        r = self.rng
        p = pad_position("thumb", 1.0)
        self.pad = np.array([p[0], -p[1], TCP_Z - p[2]])  # thumb pad centre relative to the TCP, tool down
        self.pad_radius = PAD_RADIUS
        self.lead = float(r.uniform(0.004, 0.006))
        self.face_offset = 0.008  # m below the rear-top edge (slide phase)
        self.slide_speed = float(r.uniform(0.03, 0.045))
        self.tip_speed = 0.08
        self.stop_angle = float(np.deg2rad(r.uniform(83.0, 86.0)))
        self.wall = np.array([self.state(obs, n) for n in ("wall_x", "wall_y", "wall_z")])
        c, rot, h = self.object_pose(obs)
        extent = 2 * np.abs(rot) @ h  # world-axis extents
        self.tippable = extent[0] > 2.5 * extent[2]
        edge = self._rear_edge(obs)
        first = edge + [-self.pad_radius - 0.025, 0.0, -0.008] - self.pad
        over = first + [0.0, 0.0, 0.06]
        self._replan(
            [
                Segment(over, move_duration(self.start, over, r.uniform(1.3, 1.7), self.speed * 1.5), "approach", 1.0),
                Segment(first, r.uniform(0.7, 0.9), "approach"),
            ],
            gripper=1.0,
        )  # fmt: skip
        self.mode = "approach"
        self.target = None
        self.prev_front = None
        self.still_steps = 0
        self.max_tilt = 0.0

    def describe(self) -> dict[str, float]:
        return {
            **super().describe(),
            "push_lead_m": self.lead,
            "max_tilt_deg": float(np.rad2deg(self.max_tilt)),
        }

    def _rear_edge(self, obs: dict) -> np.ndarray:
        """Top of the object's rear (robot-side) face, at its centre (base frame)."""
        c, rot, h = self.object_pose(obs)
        if self.tippable:  # the book: local -x end, top face (local +z, or whichever points up)
            up = np.sign(rot[2, 2]) if abs(rot[2, 2]) > 1e-6 else 1.0
            return c + rot @ np.array([-h[0], 0.0, up * h[2]])
        extent = np.abs(rot) @ h
        return np.array([c[0] - extent[0], c[1], c[2] + 0.6 * extent[2]])

    def _tilt(self, obs: dict) -> float:
        _, rot, _ = self.object_pose(obs)
        return float(np.arcsin(np.clip(-rot[2, 0], -1.0, 1.0)))  # the book's rear end (local -x) up

    def _step_toward(self, goal: np.ndarray, speed: float) -> np.ndarray:
        step = goal - self.target
        dist = float(np.linalg.norm(step))
        limit = speed * self.dt
        self.target = self.target + (step if dist <= limit else step * (limit / dist))
        return self.target

    def act_pregrasp(self, obs: dict):
        # one mode per call, except that a finished approach slides and a finished tip retreats at once
        if self.mode == "approach":
            out = self._approach()
            if out is not None:
                return out
        if self.mode == "slide":
            return self._slide(obs)
        if self.mode == "tip":
            out = self._tip(obs)
            if out is not None:
                return out
        if self.mode == "retreat":
            return self._retreat()
        return self.target, 1.0

    def _approach(self) -> tuple[np.ndarray, float] | None:
        pos, grip, phase = self._sample()
        self.phase = phase
        if self.t - self.plan_t0 < self.plan.duration:
            return pos + self.noise(self.t), grip
        self.mode = self.phase = "slide"
        self.target = pos
        return None

    def _slide(self, obs: dict) -> tuple[np.ndarray, float]:
        """Push the rear face horizontally until the book stops at the wall."""
        edge = self._rear_edge(obs)
        c, rot, h = self.object_pose(obs)
        front = c[0] + (np.abs(rot[0]) @ h)
        moved = self.prev_front is not None and abs(front - self.prev_front) > 2e-4
        self.still_steps = 0 if moved or self.prev_front is None else self.still_steps + 1
        self.prev_front = front
        goal = edge + [-self.pad_radius + self.lead, 0.0, -self.face_offset] - self.pad
        pos = self._step_toward(goal, self.slide_speed)
        at_wall = front >= self.wall[0] - 0.003 or self.still_steps >= 6
        if at_wall and self.tippable:
            # pushing on horizontally would only press the book into the wall: the pad's friction
            # holds its rear face down; from here the pad rides up with the edge
            self.mode = self.phase = "tip"
        elif at_wall and self.still_steps >= 6:
            self.mode = "retreat"
            self._plan_retreat(self.rng)
        return pos, 1.0

    def _tip(self, obs: dict) -> tuple[np.ndarray, float] | None:
        """Ride the rear-top edge up about the pivot; None once the book is tilted far enough."""
        c, rot, h = self.object_pose(obs)
        tilt = self._tilt(obs)
        self.max_tilt = max(self.max_tilt, tilt)
        if tilt >= self.stop_angle:
            self.mode = "retreat"
            self._plan_retreat(self.rng)
            return None
        edge = self._rear_edge(obs)
        pivot = c + rot @ np.array([h[0], 0.0, -np.sign(rot[2, 2]) * h[2]])
        arm = edge - pivot
        # the edge's motion for a rear-up rotation about +y (about the pivot)
        tangent = np.array([arm[2], 0.0, -arm[0]])
        tangent /= np.linalg.norm(tangent)
        into = rot[:, 0]  # local +x: into the rear face
        u = into + 1.5 * tangent
        u /= np.linalg.norm(u)
        # the pad presses on the edge from below-behind (its normal force lifts the edge), leading by
        # `lead` along u
        goal = edge - (self.pad_radius - self.lead) * u - self.pad
        return self._step_toward(goal, self.tip_speed), 1.0

    def _retreat(self) -> tuple[np.ndarray, float] | None:
        pos, grip, phase = self._sample()
        self.phase = phase
        if self.t - self.plan_t0 < self.plan.duration:
            return pos, grip
        return None

    def _plan_retreat(self, r: np.random.Generator) -> None:
        self.phase = "retreat"
        self.last_pos = self.target.copy()
        back = self.target + [-r.uniform(0.03, 0.045), 0.0, r.uniform(0.02, 0.03)]
        up = back + [0.0, 0.0, r.uniform(0.03, 0.05)]
        # back off with the fist closed; open only when clear (the fingers swing out as they open)
        self._replan(
            [
                Segment(back, r.uniform(0.6, 0.8), "retreat", 1.0),
                Segment(up, r.uniform(0.5, 0.7), "retreat", 0.0),
                Segment(up, r.uniform(0.2, 0.4), "retreat"),
            ],
            gripper=1.0,
        )
