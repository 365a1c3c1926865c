"""``grasp_flip`` demonstrator: a fist pushes the standing carton over, then the shared grasp."""

from __future__ import annotations

import numpy as np

from ..robots.three_finger_gripper import PAD_RADIUS, TCP_Z, pad_position
from .base import PathPlan, Segment, move_duration
from .grasping import GraspDemonstrator


class GraspFlipDemonstrator(GraspDemonstrator):
    """Flips the standing carton: a fist pushes its upper part sideways (+y) until it falls, then grasps."""

    task = "grasp_flip"
    pregrasp_phases = ("approach", "flip", "retreat")
    phases = (*pregrasp_phases, *GraspDemonstrator.GRASP_PHASES)

    def reset_pregrasp(self, obs: dict) -> None:
        r = self.rng
        c, rot, h = self.object_pose(obs)
        extent = np.abs(rot) @ h  # half extents along the base axes
        top = c[2] + extent[2]
        half_y = extent[1]
        self.push_depth = 0.0
        if extent[2] < 1.5 * extent[:2].min():  # not a standing object (the unseen apple, banana): just grasp
            self.plan = PathPlan(self.start, [Segment(self.start, 0.2, "retreat")], gripper=0.0)
            self.plan_t0 = self.t
            return
        # the fist's +y pad pushes: finger 2 (the tool-down hand maps gripper -y to world +y)
        p = pad_position("finger2", 1.0)
        pad = np.array([p[0], -p[1], TCP_Z - p[2]])  # pad centre relative to the TCP (world, tool down)
        z = float(np.clip(top * r.uniform(0.72, 0.82), 0.03, None))
        contact_y = c[1] - half_y
        first = np.array([c[0], contact_y - PAD_RADIUS - 0.03, z]) - pad
        over = first + [0.0, 0.0, 0.08]
        self.push_depth = float(r.uniform(0.08, 0.1))
        end = first + [0.0, self.push_depth + 0.03, 0.0]
        up = end + [0.0, -0.02, r.uniform(0.1, 0.13)]
        self._replan(
            [
                Segment(over, move_duration(self.start, over, r.uniform(1.3, 1.7), self.speed * 1.5), "approach", 1.0),
                Segment(first, r.uniform(0.7, 0.9), "approach"),
                Segment(end, float(np.linalg.norm(end - first)) / r.uniform(0.04, 0.06), "flip"),
                Segment(up, r.uniform(1.0, 1.3), "retreat", 0.0),
                Segment(up, r.uniform(0.4, 0.6), "retreat"),
            ],
            gripper=1.0,
        )  # fmt: skip

    def describe(self) -> dict[str, float]:
        return {**super().describe(), "push_depth_m": self.push_depth}

    def act_pregrasp(self, obs: dict):
        pos, grip, phase = self._sample()
        if self.t - self.plan_t0 >= self.plan.duration:
            return None
        self.phase = phase
        noise = self.noise(self.t) if phase == "approach" else np.zeros(3)
        return pos + noise, grip
