"""lerobot_forcemap: one-shot, force-aware Learning from Demonstration for LeRobot.

Floors (a module imports only from its own floor or floors below it):
  0. ``layout``, ``geometry``, ``_validation`` and the other top-level helpers
  1. ``elmap`` (force-constrained elastic maps), ``segmentation`` — NumPy/SciPy only
  2. ``skill`` (pure NumPy) and ``data`` (LeRobot datasets, the episode reader, converters, Hub)
  3. ``envs`` (MuJoCo tasks, controllers, demonstrators, the episode loop); the policy plugin
  4. ``evaluation`` (records, statistics, reports; policies loaded through LeRobot) and the env plugin
  5. ``cli`` (the ``forcemap`` command)
"""

__version__ = "0.1.0"
