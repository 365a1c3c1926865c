"""LeRobot env plugin: ``EnvConfig``s ``forcemap_press``, ``forcemap_erase``, ``forcemap_peg_in_hole``,
``forcemap_grasp_push`` and ``forcemap_grasp_flip`` (the latter two take ``--env.object=apple|banana``),
and ``forcemap_twin`` (the twin of a recording: ``--env.twin=<forcemap twin folder>``).

Importing it registers the gym ids (``import lerobot_forcemap.envs``, no MuJoCo import) and, when
LeRobot is installed, the env types (``configs.py``). ``lerobot_policy_forcemap`` imports this package,
so LeRobot's plugin discovery (which imports distributions by name) finds the env types too.
"""

from __future__ import annotations

import importlib.util

import lerobot_forcemap.envs  # noqa: F401  (gym ids; sets MUJOCO_GL=egl unless set)

if importlib.util.find_spec("lerobot") is not None:
    from . import configs, twin  # noqa: F401
    from .configs import ENV_TYPES, ForcemapEnvConfig
    from .twin import ForcemapTwinEnvConfig

    __all__ = ["ENV_TYPES", "ForcemapEnvConfig", "ForcemapTwinEnvConfig", "configs", "twin"]
