"""A forcemap MuJoCo scene as a LeRobot ``Robot``: ``lerobot-record`` / ``lerobot-rollout`` drive it.

Each ``send_action`` steps the scene one control period of its task (``TaskSpec.control_hz``); the
caller's loop paces it in real time (``--dataset.fps`` / ``--fps`` = the task's control rate). The
observation is the forcemap layout, flattened (``cartesian.py``): joints and gripper, ``ee_pose.*``,
``force.*`` (N, N·m, base frame, tared, the reaction on the robot), ``finger_force.*`` on grippers with
fingertip sensors, ``environment_state.*`` (the objects). The scene's episode ends when its task
succeeds or fails (the arm then holds still) and is reset ``episode_time_s`` after it started, at the
next observation, with the next seed: the simulator plays the operator who resets the scene between
``lerobot-record`` episodes.
"""

from __future__ import annotations

import json
import logging
import time
from pathlib import Path
from typing import Any

import numpy as np
from lerobot.robots.robot import Robot

from lerobot_forcemap.envs.registration import make, task_spec
from lerobot_robot_forcemap import channel
from lerobot_robot_forcemap.cartesian import (
    action_dict,
    action_features,
    action_vector,
    observation_names,
    pack_observation,
)
from lerobot_robot_forcemap.config_forcemap_sim import ForceMapSimConfig
from lerobot_robot_forcemap.simulated import SimulatedDevice

__all__ = ["ForceMapSim"]

logger = logging.getLogger(__name__)


class ForceMapSim(SimulatedDevice, Robot):
    """The simulated robot of ``ForceMapSimConfig.task`` (module docstring)."""

    config_class = ForceMapSimConfig
    name = "forcemap_ur5e_sim"

    def __init__(self, config: ForceMapSimConfig):
        super().__init__(config)
        self.config = config
        self.spec = task_spec(config.task)  # ValueError naming the known tasks
        self.env = make(config.task, render_mode=None, randomize=config.randomize)
        self.state_names: dict[str, tuple[str, ...]] = dict(self.env.unwrapped.state_names)
        self.cameras: dict[str, Any] = {}  # lerobot-record sizes its image writers by it
        self._episode = -1
        self._obs: dict[str, Any] = {}
        self._info: dict[str, Any] = {}
        self._ended = False
        self._started_at = 0.0

    # ---- LeRobot's Robot interface -------------------------------------------------------------------
    @property
    def observation_features(self) -> dict[str, type]:
        return dict.fromkeys(observation_names(self.state_names), float)

    @property
    def action_features(self) -> dict[str, type]:
        return action_features()

    def connect(self, calibrate: bool = True) -> None:
        super().connect(calibrate)
        self._reset_scene()

    def get_observation(self) -> dict[str, float]:
        self._require_connected()
        if time.perf_counter() - self._started_at >= self.config.episode_time_s:
            self._reset_scene()
        self._publish()
        return pack_observation(self._obs, self.state_names)

    def send_action(self, action: dict[str, Any]) -> dict[str, float]:
        """Step the scene with the absolute Cartesian target (the scene clips it to its workspace box
        and speed limit and says so in its info). After the episode ended the arm holds still and the
        action is ignored."""
        self._require_connected()
        target = action_vector(action)
        if not self._ended:
            self._obs, _, terminated, truncated, self._info = self.env.step(target.astype(np.float32))
            if terminated or truncated:
                self._end_episode()
        return action_dict(target)

    def disconnect(self) -> None:
        if self._connected and not self._ended and self._episode >= 0:
            self._end_episode()
        super().disconnect()
        self.env.close()

    # ---- the scene's episodes ------------------------------------------------------------------------
    def _require_connected(self) -> None:
        if not self._connected:
            raise ConnectionError(f"{self}: not connected (call connect() first)")

    def _reset_scene(self) -> None:
        if self._episode >= 0 and not self._ended:
            self._end_episode()
        self._episode += 1
        self._obs, self._info = self.env.reset(seed=self.config.seed + self._episode)
        self._ended = False
        self._started_at = time.perf_counter()

    def _end_episode(self) -> None:
        self._ended = True
        result = {
            "episode": self._episode,
            "seed": self.config.seed + self._episode,
            "is_success": bool(self._info.get("is_success", False)),
            "termination_reason": self._info.get("termination_reason"),
            "max_contact_force": float(self._info.get("max_contact_force", 0.0)),
            "mean_contact_force": float(self._info.get("mean_contact_force", 0.0)),
            "steps": int(round(float(self._info.get("elapsed_s", 0.0)) * self.spec.control_hz)),
        }
        logger.info("forcemap_ur5e_sim episode %d: %s", self._episode, result)
        if self.config.results_path:
            with Path(self.config.results_path).open("a") as f:
                f.write(json.dumps(result) + "\n")

    def _publish(self) -> None:
        frame = channel.SceneFrame(
            self._obs, self._episode, self.spec.name, self.state_names, self.spec.control_hz, self._ended
        )
        channel.publish(self.config.id, frame)
