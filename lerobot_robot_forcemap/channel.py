"""What the simulated robot last observed, for the scripted teleoperator in the same process.

LeRobot's ``record_loop`` calls ``robot.get_observation()`` then ``teleop.get_action()`` without
handing the observation to the teleoperator; a scripted demonstrator needs it. The sim robot
publishes each observation here under its id and the scripted teleoperator reads it back.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

__all__ = ["SceneFrame", "publish", "latest"]


@dataclass(frozen=True)
class SceneFrame:
    """One observation of a simulated scene: ``obs`` (raw env keys), the scene's ``episode`` count,
    its ``task`` name, ``state_names`` and ``control_hz``, and whether its episode has ``ended``."""

    obs: dict[str, Any]
    episode: int
    task: str
    state_names: dict[str, tuple[str, ...]]
    control_hz: float
    ended: bool


_FRAMES: dict[str | None, SceneFrame] = {}


def publish(robot_id: str | None, frame: SceneFrame) -> None:
    _FRAMES[robot_id] = frame


def latest(robot_id: str | None) -> SceneFrame:
    """The last frame of the robot ``robot_id``; ``ValueError`` when that robot has not observed yet."""
    if robot_id not in _FRAMES:
        have = sorted(str(k) for k in _FRAMES) or "none"
        raise ValueError(
            f"forcemap_scripted: no forcemap_ur5e_sim robot with id {robot_id!r} has observed in this process "
            f"(robots: {have}); the scripted teleoperator drives the simulated robot only (--teleop.robot_id)"
        )
    return _FRAMES[robot_id]
