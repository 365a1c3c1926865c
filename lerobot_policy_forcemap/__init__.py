"""LeRobot policy plugin `forcemap` (discovered by LeRobot through the distribution name, SPEC §5).

Importing this package also registers the env types of `lerobot_env_forcemap`, which LeRobot's
plugin discovery would not import on its own (it imports distributions by name only).
"""

import lerobot_env_forcemap  # noqa: F401  (registers forcemap_* EnvConfigs and gym ids)
