"""LeRobot policy plugin `forcemap` (discovered by LeRobot through the distribution name).

Importing this package registers the ``forcemap`` policy config (``ForceMapConfig``) and also the env
types of `lerobot_env_forcemap` and the robot / teleoperator types of `lerobot_robot_forcemap`, which LeRobot's plugin discovery would not import on its own (it
imports distributions by name only). The policy class and the processors are resolved by LeRobot from
the config's module name (``configuration_forcemap`` -> ``modeling_forcemap`` / ``processor_forcemap``).
"""

import lerobot_env_forcemap  # noqa: F401  (registers forcemap_* EnvConfigs and gym ids)
import lerobot_robot_forcemap  # noqa: F401  (registers the forcemap_ur5e_sim robot, forcemap_scripted teleop)
from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

__all__ = ["ForceMapConfig", "ForceMapPolicy", "make_forcemap_pre_post_processors"]


def __getattr__(name: str):
    # The policy and processors import torch-heavy LeRobot modules: load them on first use only.
    if name == "ForceMapPolicy":
        from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

        return ForceMapPolicy
    if name == "make_forcemap_pre_post_processors":
        from lerobot_policy_forcemap.processor_forcemap import make_forcemap_pre_post_processors

        return make_forcemap_pre_post_processors
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
