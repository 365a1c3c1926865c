"""lerobot_forcemap: one-shot, force-aware Learning from Demonstration for LeRobot.

Floors (a module imports only from floors below it):
  1. ``elmap`` (force-constrained elastic maps), ``segmentation``, ``layout``, ``geometry`` — NumPy/SciPy only
  2. ``data`` (LeRobot datasets, converters, Hub) and the policy plugin ``lerobot_policy_forcemap``
  3. ``envs`` (MuJoCo tasks, controllers, demonstrators, hybrid control baseline)
  4. ``cli``, ``experiments`` and the env plugin ``lerobot_env_forcemap``
"""

__version__ = "0.1.0"
