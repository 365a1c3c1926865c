"""LeRobot robot and teleoperator plugins of forcemap: the simulated scenes as a robot.

Importing this package registers the robot type ``forcemap_ur5e_sim`` (``ForceMapSimConfig``) and the
teleoperator type ``forcemap_scripted`` (``ScriptedTeleopConfig``); ``lerobot_policy_forcemap``
imports it, so LeRobot's plugin discovery registers them with the policy. LeRobot finds the robot
and teleoperator classes from the config modules' names (``config_forcemap_sim`` ->
``forcemap_sim.ForceMapSim``). ``cartesian.py`` holds what a real forcemap robot shares with the
simulated one (``docs/robots.md``).
"""

from lerobot_robot_forcemap.config_forcemap_sim import ForceMapSimConfig
from lerobot_robot_forcemap.config_scripted_teleop import ScriptedTeleopConfig

__all__ = ["ForceMapSimConfig", "ScriptedTeleopConfig"]
