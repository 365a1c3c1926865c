"""``--env.type=forcemap_twin``: the twin of a recording (``forcemap twin``) as a LeRobot env.

    lerobot-eval --policy.path=<ckpt> --env.type=forcemap_twin --env.twin=outputs/press_twin \\
        --eval.n_episodes=1 --policy.device=cpu

``twin``: the folder ``forcemap twin`` wrote (or its ``twin.json``). ``episode_length`` 0 (default):
the scene's own limit (the recording's length plus one second). Features as the task env types'.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

from lerobot.configs import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig

from lerobot_forcemap import layout
from lerobot_forcemap._validation import check_choice, check_int, check_path, fail
from lerobot_forcemap.envs.base_env import OBS_TYPES
from lerobot_forcemap.envs.registration import TWIN_GYM_ID

__all__ = ["ForcemapTwinEnvConfig", "read_twin_scene"]

#: raw observation sizes of the twin (UR5e joints + gripper, pose, wrench, its environment_state)
_SIZES = {
    layout.ENV_AGENT_POS: (7, FeatureType.STATE),
    layout.ENV_EE_POSE: (layout.EE_POSE_DIM, FeatureType.STATE),
    layout.ENV_FORCE: (layout.FORCE_DIM, FeatureType.STATE),
    layout.ENV_STATE: (9, FeatureType.ENV),
}


def read_twin_scene(path: str | Path) -> dict:
    """The scene dict of a ``forcemap twin`` folder or its ``twin.json``."""
    p = check_path("twin", path)
    p = p / "twin.json" if p.is_dir() else p
    if not p.is_file():
        fail("twin", "be a `forcemap twin` output folder (holding twin.json) or a twin.json", str(path))
    return json.loads(p.read_text())


@EnvConfig.register_subclass("forcemap_twin")
@dataclass
class ForcemapTwinEnvConfig(EnvConfig):
    """``--env.type=forcemap_twin`` (module docstring)."""

    twin: str = ""
    task: str | None = TWIN_GYM_ID.split("/")[1]
    fps: int = 20
    episode_length: int = 0
    obs_type: str = "state"
    render_mode: str = "rgb_array"
    image_size: int = 128
    render_size: int = 256
    features: dict[str, PolicyFeature] = field(default_factory=dict)
    features_map: dict[str, str] = field(default_factory=dict)

    def __post_init__(self):
        self._scene = read_twin_scene(self.twin)
        check_int("episode_length", self.episode_length, low=0)
        self.episode_length = self.episode_length or int(self._scene["max_steps"])
        check_choice("obs_type", self.obs_type, OBS_TYPES)
        if self.render_mode != "rgb_array":
            fail("render_mode", "be 'rgb_array' (LeRobot's eval renders videos from it)", self.render_mode)
        if self.fps != 20:
            fail("fps", "be 20: the twin runs at the tasks' control rate", self.fps)
        if not self.features:
            self.features = {
                layout.ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(layout.ACTION_DIM,))
            }
            self.features_map = {layout.ACTION: layout.ACTION}
            for key, (size, kind) in _SIZES.items():
                self.features[key] = PolicyFeature(type=kind, shape=(size,))
                self.features_map[key] = layout.ENV_TO_FEATURE[key]

    @property
    def package_name(self) -> str:
        return "lerobot_forcemap.envs"

    @property
    def gym_id(self) -> str:
        return TWIN_GYM_ID

    @property
    def gym_kwargs(self) -> dict:
        return {
            "twin": self._scene,
            "obs_type": self.obs_type,
            "render_mode": self.render_mode,
            "image_size": self.image_size,
            "render_size": self.render_size,
            "max_episode_steps": self.episode_length,
        }
