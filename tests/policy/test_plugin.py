"""LeRobot's plugin discovery finds the forcemap policy (and the env types) by distribution name."""

from __future__ import annotations

import importlib.metadata
import subprocess
import sys

DISCOVER = """
import sys
from lerobot.utils.import_utils import register_third_party_plugins
assert "lerobot_policy_forcemap" not in sys.modules
register_third_party_plugins()
from lerobot.configs.policies import PreTrainedConfig
from lerobot.envs.configs import EnvConfig
from lerobot.policies.factory import get_policy_class
print(PreTrainedConfig.get_choice_class("forcemap").__name__)
print(get_policy_class("forcemap").__name__)
print(EnvConfig.get_choice_class("forcemap_press").__name__)
"""


def test_distribution_name_matches_lerobot_prefix():
    dist = importlib.metadata.distribution("lerobot_policy_forcemap")
    assert dist.metadata["Name"] == "lerobot_policy_forcemap"  # underscores: what discovery imports


def test_register_third_party_plugins_finds_forcemap():
    out = subprocess.run([sys.executable, "-c", DISCOVER], capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.split() == ["ForceMapConfig", "ForceMapPolicy", "ForcemapPressEnv"]
