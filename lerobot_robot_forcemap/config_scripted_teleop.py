"""Configuration of the scripted teleoperator, registered as LeRobot teleoperator type ``forcemap_scripted``."""

from __future__ import annotations

from dataclasses import dataclass

from lerobot.teleoperators.config import TeleoperatorConfig

from lerobot_forcemap._validation import check_int

__all__ = ["ScriptedTeleopConfig"]


@TeleoperatorConfig.register_subclass("forcemap_scripted")
@dataclass
class ScriptedTeleopConfig(TeleoperatorConfig):
    """The task's scripted demonstrator as a teleoperator of the simulated robot (``ScriptedTeleop``).

    robot_id: the ``--robot.id`` of the ``forcemap_ur5e_sim`` robot it follows (default: none given).
    seed: the demonstrator of scene episode k is seeded with ``seed + k``.
    """

    robot_id: str | None = None
    seed: int = 0

    def __post_init__(self) -> None:
        check_int("ScriptedTeleopConfig.seed", self.seed, low=0)
