"""The task's scripted demonstrator as a LeRobot ``Teleoperator`` of the simulated robot.

It reads what the ``forcemap_ur5e_sim`` robot of the same process last observed (``channel.py``),
starts the task's demonstrator (``lerobot_forcemap.envs.demonstrators``) on each new scene episode and
returns its absolute Cartesian action, so ``lerobot-record --teleop.type=forcemap_scripted`` records
the demonstrations ``forcemap record`` would, through LeRobot's own recorder. After the scene's
episode ended it keeps returning the demonstrator's last action.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from lerobot.teleoperators.teleoperator import Teleoperator

from lerobot_forcemap import layout
from lerobot_forcemap.envs.demonstrators import make_demonstrator
from lerobot_robot_forcemap import channel
from lerobot_robot_forcemap.cartesian import action_dict, action_features
from lerobot_robot_forcemap.config_scripted_teleop import ScriptedTeleopConfig
from lerobot_robot_forcemap.simulated import SimulatedDevice

__all__ = ["ScriptedTeleop"]


class ScriptedTeleop(SimulatedDevice, Teleoperator):
    """Replays the scripted demonstrator against the simulated robot's observation (module docstring)."""

    config_class = ScriptedTeleopConfig
    name = "forcemap_scripted"

    def __init__(self, config: ScriptedTeleopConfig):
        super().__init__(config)
        self.config = config
        self._episode = -1
        self._demo = None
        self._last: dict[str, float] | None = None

    @property
    def action_features(self) -> dict[str, type]:
        return action_features()

    @property
    def feedback_features(self) -> dict[str, type]:
        return {}

    def get_action(self) -> dict[str, float]:
        frame = channel.latest(self.config.robot_id)
        if frame.episode != self._episode:
            self._start(frame)
        if frame.ended and self._last is not None:
            return self._last
        self._last = action_dict(self._demo.act(frame.obs))
        return self._last

    def _start(self, frame: channel.SceneFrame) -> None:
        seed = self.config.seed + frame.episode
        rng = np.random.default_rng(np.random.SeedSequence(seed).spawn(1)[0])
        names = frame.state_names[layout.ENV_STATE]
        self._demo = make_demonstrator(frame.task, rng, state_names=names, control_hz=frame.control_hz)
        self._demo.reset(frame.obs)
        self._episode, self._last = frame.episode, None

    def send_feedback(self, feedback: dict[str, Any]) -> None:
        """No feedback to a script."""
