"""Configuration of the simulated forcemap robot, registered as LeRobot robot type ``forcemap_ur5e_sim``."""

from __future__ import annotations

from dataclasses import dataclass

from lerobot.robots.config import RobotConfig

from lerobot_forcemap._validation import check_bool, check_int, check_real, check_str

__all__ = ["ForceMapSimConfig"]


@RobotConfig.register_subclass("forcemap_ur5e_sim")
@dataclass
class ForceMapSimConfig(RobotConfig):
    """A forcemap MuJoCo scene driven as a robot (``ForceMapSim``).

    task: the scene (``press``, ``erase``, ``peg_in_hole``, ...; its robot is the task's, the UR5e for
    the UR5e tasks). seed: scene of episode k is drawn with seed ``seed + k``. episode_time_s: the
    scene runs this long, then the operator (the simulator) resets it: give ``lerobot-record`` the same
    ``--dataset.episode_time_s`` and ``--dataset.reset_time_s=0``. randomize: False keeps the nominal
    scene. results_path: a JSON-lines file receiving one line per finished episode (success, max and
    mean contact force in N, termination reason); empty: none.
    """

    task: str = "press"
    seed: int = 0
    episode_time_s: float = 6.0
    randomize: bool = True
    results_path: str = ""

    def __post_init__(self) -> None:
        super().__post_init__()
        check_str("ForceMapSimConfig.task", self.task, empty_ok=False)
        check_int("ForceMapSimConfig.seed", self.seed, low=0)
        check_real("ForceMapSimConfig.episode_time_s", self.episode_time_s, low=0.0, low_open=True, unit="s")
        check_bool("ForceMapSimConfig.randomize", self.randomize)
        check_str("ForceMapSimConfig.results_path", self.results_path)
