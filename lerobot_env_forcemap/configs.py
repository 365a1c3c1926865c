"""LeRobot ``EnvConfig`` per forcemap task: ``lerobot-eval --env.type=forcemap_press --policy.path=...``.

Raw env keys map to LeRobot keys as ``lerobot.envs.utils.preprocess_observation`` does in 0.6.1:
``agent_pos`` -> ``observation.state``, ``environment_state`` -> ``observation.environment_state``,
``pixels[cam]`` -> ``observation.images.<cam>``, and any other array key ``k`` -> ``observation.k``
(``force`` -> ``observation.force``, ``ee_pose`` -> ``observation.ee_pose``, ``finger_force`` ->
``observation.finger_force``). ``features`` / ``features_map`` below declare the same mapping
(``lerobot_forcemap.layout.ENV_TO_FEATURE``) so a policy built from the env config sees the force.

Defaults render videos (``render_mode="rgb_array"``, 256 px front camera, no shadows); ``obs_type=
"pixels_state"`` adds 128 px camera observations. fps = the task's control rate (20 Hz).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

from lerobot.configs import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig

from lerobot_forcemap import layout
from lerobot_forcemap.envs.registration import NAMESPACE, task_entry

_FEATURE_TYPES = {
    layout.ENV_AGENT_POS: FeatureType.STATE,
    layout.ENV_EE_POSE: FeatureType.STATE,
    layout.ENV_FORCE: FeatureType.STATE,
    layout.ENV_FINGER_FORCE: FeatureType.STATE,
    layout.ENV_STATE: FeatureType.ENV,
}


def task_features(task: str, *, obs_type: str = "state", image_size: int = 128, robot: str | None = None):
    """(features, features_map) of a task's env, from its task class and robot (imports MuJoCo)."""
    import importlib

    from lerobot_forcemap.envs.robots import get_robot

    module, cls = task_entry(task).entry_point.split(":")
    task_class = getattr(importlib.import_module(module), cls).task_class
    robot_spec = get_robot(robot or task_class.robot_name)
    sizes = {
        layout.ENV_AGENT_POS: len(robot_spec.joint_names) + 1,
        layout.ENV_EE_POSE: layout.EE_POSE_DIM,
        layout.ENV_FORCE: layout.FORCE_DIM,
        layout.ENV_STATE: len(task_class.state_names),
    }
    if robot_spec.gripper.finger_sensor_names:
        sizes[layout.ENV_FINGER_FORCE] = 3 * len(robot_spec.gripper.finger_sensor_names)
    features = {layout.ACTION: PolicyFeature(type=FeatureType.ACTION, shape=(layout.ACTION_DIM,))}
    features_map = {layout.ACTION: layout.ACTION}
    for key, size in sizes.items():
        features[key] = PolicyFeature(type=_FEATURE_TYPES[key], shape=(size,))
        features_map[key] = layout.ENV_TO_FEATURE[key]
    if obs_type == "pixels_state":
        from lerobot_forcemap.envs.scene import CAMERA

        key = f"{layout.ENV_PIXELS}/{CAMERA}"
        features[key] = PolicyFeature(type=FeatureType.VISUAL, shape=(image_size, image_size, 3))
        features_map[key] = layout.OBS_IMAGES_PREFIX + CAMERA
    return features, features_map


@dataclass
class ForcemapEnvConfig(EnvConfig):
    """Shared fields of the forcemap tasks (subclasses set ``forcemap_task``, ``task``, ``episode_length``)."""

    forcemap_task: ClassVar[str] = ""
    task: str | None = None
    fps: int = 20
    episode_length: int = 200
    obs_type: str = "state"
    render_mode: str = "rgb_array"
    image_size: int = 128
    render_size: int = 256
    robot: str | None = None
    randomize: bool = True
    features: dict[str, PolicyFeature] = field(default_factory=dict)
    features_map: dict[str, str] = field(default_factory=dict)

    def __post_init__(self):
        if self.obs_type not in ("state", "pixels_state"):
            raise ValueError(f"obs_type must be 'state' or 'pixels_state', got {self.obs_type!r}")
        if not self.features:
            self.features, self.features_map = task_features(
                self.forcemap_task, obs_type=self.obs_type, image_size=self.image_size, robot=self.robot
            )

    @property
    def package_name(self) -> str:
        return "lerobot_forcemap.envs"

    @property
    def gym_id(self) -> str:
        return f"{NAMESPACE}/{self.task}"

    @property
    def gym_kwargs(self) -> dict:
        return {
            "obs_type": self.obs_type,
            "render_mode": self.render_mode,
            "image_size": self.image_size,
            "render_size": self.render_size,
            "robot": self.robot,
            "randomize": self.randomize,
            "max_episode_steps": self.episode_length,
        }


@EnvConfig.register_subclass("forcemap_press")
@dataclass
class ForcemapPressEnv(ForcemapEnvConfig):
    forcemap_task: ClassVar[str] = "press"
    task: str | None = "Press-v0"
    episode_length: int = task_entry("press").max_episode_steps


@EnvConfig.register_subclass("forcemap_erase")
@dataclass
class ForcemapEraseEnv(ForcemapEnvConfig):
    forcemap_task: ClassVar[str] = "erase"
    task: str | None = "Erase-v0"
    episode_length: int = task_entry("erase").max_episode_steps


@EnvConfig.register_subclass("forcemap_peg_in_hole")
@dataclass
class ForcemapPegInHoleEnv(ForcemapEnvConfig):
    forcemap_task: ClassVar[str] = "peg_in_hole"
    task: str | None = "PegInHole-v0"
    episode_length: int = task_entry("peg_in_hole").max_episode_steps


ENV_TYPES = {"press": "forcemap_press", "erase": "forcemap_erase", "peg_in_hole": "forcemap_peg_in_hole"}
