"""LeRobot ``EnvConfig`` per forcemap task, derived from the task specs: ``lerobot-eval
--env.type=forcemap_press --policy.path=...``. Every registered task gets a dataclass registered as
``TaskSpec.env_type`` (``forcemap_<task>``) whose ``task`` and ``episode_length`` default to the spec's
``env_id`` and ``max_episode_steps``; a task with objects also has the ``object`` field.

Raw env keys map to LeRobot keys as ``lerobot.envs.utils.preprocess_observation`` does in 0.6.1:
``agent_pos`` -> ``observation.state``, ``environment_state`` -> ``observation.environment_state``,
``pixels[cam]`` -> ``observation.images.<cam>``, and any other array key ``k`` -> ``observation.k``
(``force`` -> ``observation.force``, ``ee_pose`` -> ``observation.ee_pose``, ``finger_force`` ->
``observation.finger_force``). ``features`` / ``features_map`` below declare the same mapping
(``lerobot_forcemap.layout.ENV_TO_FEATURE``) so a policy built from the env config sees the force.

Defaults render videos (``render_mode="rgb_array"``, 256 px front camera, no shadows); ``obs_type=
"pixels_state"`` adds 128 px camera observations. fps = the task's control rate (not configurable).

``--env.env_state_extras=ee_pose,force`` (default empty) adds an env processor that appends those
observations to ``observation.environment_state`` — how force reaches ACT / Diffusion, which read only
state, environment state and images (``env_state.py``; the training side is a derived dataset,
``experiments.learned.baselines.derive_env_state_dataset``).
"""

from __future__ import annotations

from dataclasses import dataclass, field, make_dataclass
from typing import ClassVar

from lerobot.configs import FeatureType, PolicyFeature
from lerobot.envs.configs import EnvConfig

from lerobot_forcemap import layout
from lerobot_forcemap._validation import check_choice, check_int, fail
from lerobot_forcemap.envs.base_env import OBS_TYPES
from lerobot_forcemap.envs.registration import NAMESPACE, TASKS, TaskSpec, env_class, task_spec
from lerobot_forcemap.envs.variation import check_level

__all__ = ["ENV_TYPES", "ForcemapEnvConfig", "ForcemapGraspEnvConfig", "env_config_class", "task_features"]

_FEATURE_TYPES = {
    layout.ENV_AGENT_POS: FeatureType.STATE,
    layout.ENV_EE_POSE: FeatureType.STATE,
    layout.ENV_FORCE: FeatureType.STATE,
    layout.ENV_FINGER_FORCE: FeatureType.STATE,
    layout.ENV_STATE: FeatureType.ENV,
}


def task_features(task: str, *, obs_type: str = "state", image_size: int = 128, robot: str | None = None):
    """(features, features_map) of a task's env, from its task class and robot (imports MuJoCo)."""
    from lerobot_forcemap.envs.robots import get_robot

    task_class = env_class(task).task_class
    robot_spec = get_robot(robot or task_spec(task).robot)
    task_class(robot_spec, randomize=False)  # the task's own robot checks (peg_in_hole's gripper)
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
    """Shared fields of the forcemap tasks; :func:`env_config_class` derives one subclass per task."""

    forcemap_task: ClassVar[str] = ""
    task: str | None = None
    fps: int = 20
    episode_length: int = 200
    obs_type: str = "state"
    render_mode: str = "rgb_array"
    image_size: int = 128
    render_size: int = 256
    robot: str | None = None
    # "none" | "paper" | "wide" (lerobot_forcemap/envs/variation.py); true / false read as "paper" / "none"
    randomize: str = "paper"
    features: dict[str, PolicyFeature] = field(default_factory=dict)
    features_map: dict[str, str] = field(default_factory=dict)
    # Comma-separated observation keys appended to environment_state by an env processor, for
    # policies that read only state / environment_state / images (ACT, Diffusion): e.g.
    # "ee_pose,force". See lerobot_env_forcemap/env_state.py. Empty: no env processor.
    env_state_extras: str = ""

    def __post_init__(self):
        spec = task_spec(self.forcemap_task)
        if self.task != spec.env_id:
            # another task's env would run under this config's features, fps and episode length
            fail(
                "task",
                f"be {spec.env_id!r}: --env.type={self.type} runs that task (pick the task with --env.type, "
                "e.g. forcemap_erase)",
                self.task,
            )
        for name in ("episode_length", "image_size", "render_size"):
            check_int(name, getattr(self, name), low=1)
        check_choice("obs_type", self.obs_type, OBS_TYPES)
        self.randomize = check_level("randomize", self.randomize)
        if self.render_mode != "rgb_array":
            # lerobot-eval always writes videos from env.render(); without frames eval_info.json would
            # list videos that were never written
            fail("render_mode", "be 'rgb_array' (LeRobot's eval renders videos from it)", self.render_mode)
        if self.fps != spec.control_hz:  # LeRobot writes eval videos at fps; the simulation steps at its rate
            fail("fps", f"be {spec.control_hz:g}: the {spec.name} task runs at its control rate", self.fps)
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


@dataclass
class ForcemapGraspEnvConfig(ForcemapEnvConfig):
    """A task with objects adds ``object`` (None: the task's demonstration object), e.g. ``lerobot-eval
    --env.type=forcemap_grasp_push --env.object=apple``."""

    object: str | None = None

    def __post_init__(self):
        super().__post_init__()
        task_spec(self.forcemap_task).check_object(self.object)  # else only make_env would say so

    @property
    def gym_kwargs(self) -> dict:
        kwargs = super().gym_kwargs
        if self.object is not None:
            kwargs["object"] = self.object
        return kwargs


def env_config_class(spec: TaskSpec) -> type[ForcemapEnvConfig]:
    """The ``EnvConfig`` dataclass of a task, registered as ``spec.env_type`` (``ForcemapPressEnv`` ...)."""
    name = "Forcemap" + "".join(part.title() for part in spec.name.split("_")) + "Env"
    cls = make_dataclass(
        name,
        [
            ("task", "str | None", field(default=spec.env_id)),
            ("episode_length", "int", field(default=spec.max_episode_steps)),
        ],
        bases=(ForcemapGraspEnvConfig if spec.objects else ForcemapEnvConfig,),
        namespace={
            "forcemap_task": spec.name,
            "__module__": __name__,
            "__doc__": f"``--env.type={spec.env_type}``: {spec.description}",
        },
    )
    globals()[name] = cls  # importable by name (pickle, draccus' error messages)
    return EnvConfig.register_subclass(spec.env_type)(cls)


#: task name -> LeRobot env type
ENV_TYPES: dict[str, str] = {}
for _spec in TASKS.values():
    env_config_class(_spec)
    ENV_TYPES[_spec.name] = _spec.env_type
