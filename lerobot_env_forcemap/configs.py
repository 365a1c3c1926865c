"""LeRobot ``EnvConfig`` per forcemap task: ``lerobot-eval --env.type=forcemap_press --policy.path=...``.

Raw env keys map to LeRobot keys as ``lerobot.envs.utils.preprocess_observation`` does in 0.6.1:
``agent_pos`` -> ``observation.state``, ``environment_state`` -> ``observation.environment_state``,
``pixels[cam]`` -> ``observation.images.<cam>``, and any other array key ``k`` -> ``observation.k``
(``force`` -> ``observation.force``, ``ee_pose`` -> ``observation.ee_pose``, ``finger_force`` ->
``observation.finger_force``). ``features`` / ``features_map`` below declare the same mapping
(``lerobot_forcemap.layout.ENV_TO_FEATURE``) so a policy built from the env config sees the force.

Defaults render videos (``render_mode="rgb_array"``, 256 px front camera, no shadows); ``obs_type=
"pixels_state"`` adds 128 px camera observations. fps = the task's control rate (20 Hz).

``--env.env_state_extras=ee_pose,force`` (default empty) adds an env processor that appends those
observations to ``observation.environment_state`` — how force reaches ACT / Diffusion, which read only
state, environment state and images (``env_state.py``; the training side is a derived dataset,
``experiments.learned.baselines.derive_env_state_dataset``).
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


def _task_class(task: str):
    """The ``ForceTask`` subclass of a registered task (imports its module, hence MuJoCo)."""
    import importlib

    module, cls = task_entry(task).entry_point.split(":")
    return getattr(importlib.import_module(module), cls).task_class


def task_features(task: str, *, obs_type: str = "state", image_size: int = 128, robot: str | None = None):
    """(features, features_map) of a task's env, from its task class and robot (imports MuJoCo)."""
    from lerobot_forcemap.envs.robots import get_robot

    task_class = _task_class(task)
    robot_spec = get_robot(robot or task_class.robot_name)
    # the task's own robot checks (peg_in_hole needs the parallel gripper), when the config is built: the
    # features of an impossible pairing used to be made and the env refused only in make_env
    task_class(robot_spec, randomize=False)
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


def _extend_env_state_feature(
    features: dict[str, PolicyFeature], extras_spec: str
) -> dict[str, PolicyFeature]:
    """The env's features as the policy sees them after the env processor (environment_state grown
    by the extras' sizes); unchanged when ``extras_spec`` is empty."""
    from .env_state import ENV_STATE_EXTRA_KEYS, parse_env_state_extras

    extras = parse_env_state_extras(extras_spec)
    if not extras:
        return features
    raw = {layout.ENV_TO_FEATURE[k]: k for k in features if k in layout.ENV_TO_FEATURE}
    size = features[layout.ENV_STATE].shape[0]
    for e in extras:
        raw_key = raw.get(ENV_STATE_EXTRA_KEYS[e])
        if raw_key is None:
            raise ValueError(f"env_state_extras: {e!r} needs {ENV_STATE_EXTRA_KEYS[e]}, which this env lacks")
        size += features[raw_key].shape[0]
    out = dict(features)
    out[layout.ENV_STATE] = PolicyFeature(type=FeatureType.ENV, shape=(size,))
    return out


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
    # Comma-separated observation keys appended to environment_state by an env processor, for
    # policies that read only state / environment_state / images (ACT, Diffusion): e.g.
    # "ee_pose,force". See lerobot_env_forcemap/env_state.py. Empty: no env processor.
    env_state_extras: str = ""

    def __post_init__(self):
        gym_id = task_entry(self.forcemap_task).gym_id
        if self.task is None or f"{NAMESPACE}/{self.task}" != gym_id:
            # another task's env would run under this config's features, fps and episode length
            raise ValueError(
                f"task: --env.type={self.type} runs {gym_id.split('/', 1)[1]!r}, got task={self.task!r} "
                "(pick the task with --env.type, e.g. forcemap_erase)"
            )
        for name in ("episode_length", "image_size", "render_size"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{name} must be a positive integer, got {value!r}")
        if self.obs_type not in ("state", "pixels_state"):
            raise ValueError(f"obs_type must be 'state' or 'pixels_state', got {self.obs_type!r}")
        if self.render_mode != "rgb_array":
            # lerobot-eval always writes videos from env.render(); without frames eval_info.json would
            # list videos that were never written
            raise ValueError(
                f"render_mode must be 'rgb_array' (LeRobot's eval renders videos from it), got {self.render_mode!r}"
            )
        rate = task_entry(self.forcemap_task).control_hz
        if self.fps != rate:  # LeRobot writes eval videos at fps; the simulation always steps at its rate
            raise ValueError(
                f"fps: the {self.forcemap_task} task runs at its control rate, {rate:g} Hz, which is not "
                f"configurable; got fps={self.fps!r}"
            )
        if not self.features:
            self.features, self.features_map = task_features(
                self.forcemap_task, obs_type=self.obs_type, image_size=self.image_size, robot=self.robot
            )
            self.features = _extend_env_state_feature(self.features, self.env_state_extras)

    def get_env_processors(self):
        """(pre, post) env processors: appends ``env_state_extras`` to environment_state when set."""
        from lerobot.processor import PolicyProcessorPipeline

        from .env_state import EnvStateExtrasProcessorStep, parse_env_state_extras

        extras = parse_env_state_extras(self.env_state_extras)
        steps = [EnvStateExtrasProcessorStep(extras=extras)] if extras else []
        return PolicyProcessorPipeline(steps=steps), PolicyProcessorPipeline(steps=[])

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


@dataclass
class ForcemapGraspEnvConfig(ForcemapEnvConfig):
    """The Gen3 grasping tasks add ``object`` (None: the task's demonstration object; or ``apple``,
    ``banana``), e.g. ``lerobot-eval --env.type=forcemap_grasp_push --env.object=apple``."""

    object: str | None = None

    def __post_init__(self):
        super().__post_init__()
        objects = _task_class(self.forcemap_task).objects
        if self.object is not None and self.object not in objects:  # else only make_env would say so
            raise ValueError(
                f"object: {self.forcemap_task} has no object {self.object!r}; choose one of {list(objects)}"
            )

    @property
    def gym_kwargs(self) -> dict:
        kwargs = super().gym_kwargs
        if self.object is not None:
            kwargs["object"] = self.object
        return kwargs


@EnvConfig.register_subclass("forcemap_grasp_push")
@dataclass
class ForcemapGraspPushEnv(ForcemapGraspEnvConfig):
    forcemap_task: ClassVar[str] = "grasp_push"
    task: str | None = "GraspPush-v0"
    episode_length: int = task_entry("grasp_push").max_episode_steps


@EnvConfig.register_subclass("forcemap_grasp_flip")
@dataclass
class ForcemapGraspFlipEnv(ForcemapGraspEnvConfig):
    forcemap_task: ClassVar[str] = "grasp_flip"
    task: str | None = "GraspFlip-v0"
    episode_length: int = task_entry("grasp_flip").max_episode_steps


ENV_TYPES = {
    "press": "forcemap_press",
    "erase": "forcemap_erase",
    "peg_in_hole": "forcemap_peg_in_hole",
    "grasp_push": "forcemap_grasp_push",
    "grasp_flip": "forcemap_grasp_flip",
}
