"""LeRobot env types of the grasping tasks: finger forces reach the policy, ``object`` reaches the env."""

import numpy as np
import pytest

from lerobot_forcemap import layout


@pytest.fixture(autouse=True, scope="module")
def _registered():
    """Imported here, not at the top: LeRobot's env factory is slow to import at collection."""
    import lerobot_env_forcemap  # noqa: F401  (registers the env types)


def test_grasp_env_types_and_features():
    from lerobot.configs import FeatureType
    from lerobot.envs.configs import EnvConfig
    from lerobot.envs.factory import make_env_config
    from lerobot.envs.utils import env_to_policy_features

    known = EnvConfig.get_known_choices()
    assert {"forcemap_grasp_push", "forcemap_grasp_flip"} <= set(known)
    cfg = make_env_config("forcemap_grasp_flip")
    feats = env_to_policy_features(cfg)
    assert feats[layout.OBS_FINGER_FORCE].type is FeatureType.STATE and feats[
        layout.OBS_FINGER_FORCE
    ].shape == (9,)
    assert feats[layout.OBS_STATE].shape == (8,) and feats[layout.ACTION].shape == (8,)
    assert cfg.gym_id == "lerobot_forcemap/GraspFlip-v0" and cfg.episode_length == 400
    assert "object" not in cfg.gym_kwargs  # default: the demonstration object


def test_make_env_passes_the_object_and_delivers_finger_force():
    from lerobot.envs.factory import make_env, make_env_config
    from lerobot.envs.utils import preprocess_observation

    cfg = make_env_config("forcemap_grasp_push", object="apple")
    vec = make_env(cfg, n_envs=1)["forcemap_grasp_push"][0]
    try:
        obs, info = vec.reset(seed=[0])
        assert vec.call("object_name") == ("apple",)
        action = np.concatenate([obs["ee_pose"], np.ones((1, 1))], axis=1).astype(np.float32)
        obs, *_ = vec.step(action)
        batch = preprocess_observation(obs)
        assert tuple(batch[layout.OBS_FINGER_FORCE].shape) == (1, 9)
        assert vec.call("_max_episode_steps") == (500,)
        frame = vec.call("render")[0]
        assert frame.dtype == np.uint8 and frame.shape == (256, 256, 3)
    finally:
        vec.close()
