"""The LeRobot env plugin: env types registered, observation keys mapped, force reaches a policy."""

import numpy as np
import pytest

from lerobot_forcemap import layout


@pytest.fixture(autouse=True, scope="module")
def _registered():
    """Imported here, not at the top: LeRobot's env factory is slow to import at collection."""
    import lerobot_policy_forcemap  # noqa: F401  (the plugin entry point LeRobot imports; it registers the env types)


def test_env_types_registered():
    from lerobot.envs.configs import EnvConfig

    known = EnvConfig.get_known_choices()
    for name in ("forcemap_press", "forcemap_erase", "forcemap_peg_in_hole"):
        assert name in known


def test_policy_features_include_force():
    from lerobot.configs import FeatureType
    from lerobot.envs.factory import make_env_config
    from lerobot.envs.utils import env_to_policy_features

    cfg = make_env_config("forcemap_erase")
    feats = env_to_policy_features(cfg)
    assert feats[layout.OBS_FORCE].type is FeatureType.STATE and feats[layout.OBS_FORCE].shape == (6,)
    assert feats[layout.OBS_STATE].shape == (7,) and feats[layout.ACTION].shape == (8,)
    assert feats[layout.OBS_ENV_STATE].type is FeatureType.ENV
    assert cfg.fps == 20 and cfg.episode_length == 600 and cfg.gym_id == "lerobot_forcemap/Erase-v0"
    pix = make_env_config("forcemap_press", obs_type="pixels_state", image_size=64)
    assert env_to_policy_features(pix)["observation.images.front"].shape == (3, 64, 64)


@pytest.mark.parametrize("env_type", ["forcemap_press", "forcemap_grasp_flip"])
def test_an_fps_other_than_the_control_rate_is_refused(env_type):
    # --env.fps used to be accepted and ignored: the simulation steps at 20 Hz whatever it says
    from lerobot.envs.factory import make_env_config

    with pytest.raises(ValueError, match=r"fps: must be 20: the \w+ task runs at its control rate, got 10"):
        make_env_config(env_type, fps=10)
    assert make_env_config(env_type, fps=20).fps == 20
    with pytest.raises(ValueError, match="render_mode: must be 'rgb_array'.*got None"):
        make_env_config(env_type, render_mode=None)  # videos listed in eval_info.json were never written


def test_env_config_fields_are_checked_when_the_config_is_made():
    # task used to pick another task's env under this config's features, fps and episode length
    from lerobot.envs.factory import make_env_config

    with pytest.raises(
        ValueError, match="task: must be 'Press-v0': --env.type=forcemap_press runs that task.*got 'Erase-v0'"
    ):
        make_env_config("forcemap_press", task="Erase-v0")
    with pytest.raises(ValueError, match="task: must be 'Press-v0'.*got None"):
        make_env_config("forcemap_press", task=None)
    for name in ("episode_length", "image_size", "render_size"):
        for bad in (0, -5, 1.5, True):
            with pytest.raises(ValueError, match=f"{name}: must be an integer >= 1, got {bad!r}"):
                make_env_config("forcemap_press", **{name: bad})
    with pytest.raises(
        ValueError,
        match=r"object: must be one of \['book', 'apple', 'banana'\] \(the objects of grasp_push\), got 'pear'",
    ):
        make_env_config("forcemap_grasp_push", object="pear")
    assert make_env_config("forcemap_grasp_flip", object="banana").gym_kwargs["object"] == "banana"
    # the Gen3's three-finger hand cannot hold the disc: said when the config is made, not in make_env
    with pytest.raises(ValueError, match="peg_in_hole: robot 'gen3' has the three_finger_gripper"):
        make_env_config("forcemap_peg_in_hole", robot="gen3")


def test_make_env_and_preprocess_observation_deliver_force():
    from lerobot.envs.factory import make_env, make_env_config
    from lerobot.envs.utils import preprocess_observation

    cfg = make_env_config("forcemap_press")
    envs = make_env(cfg, n_envs=2)
    vec = envs["forcemap_press"][0]
    try:
        obs, _ = vec.reset(seed=[0, 1])
        target = np.concatenate(
            [obs["ee_pose"][:, :2], np.full((2, 1), -0.015), obs["ee_pose"][:, 3:], np.ones((2, 1))], axis=1
        )
        for _ in range(25):  # press the table 15 mm deep: about 30 N
            obs, reward, term, trunc, info = vec.step(target.astype(np.float32))
        batch = preprocess_observation(obs)
        assert set(batch) == {layout.OBS_STATE, layout.OBS_EE_POSE, layout.OBS_FORCE, layout.OBS_ENV_STATE}
        assert tuple(batch[layout.OBS_FORCE].shape) == (2, 6)
        np.testing.assert_allclose(batch[layout.OBS_FORCE].numpy(), obs["force"], rtol=1e-6)
        assert obs["force"][:, 2].min() > 20.0  # reaction on the robot: up
        assert vec.call("_max_episode_steps") == (200, 200)
        assert vec.call("task_description")[0].startswith("Press")
        assert vec.metadata["render_fps"] == 20 and isinstance(
            vec.metadata["render_fps"], int
        )  # PyAV needs an int
        frame = vec.call("render")[0]
        assert frame.dtype == np.uint8 and frame.shape == (256, 256, 3)
        assert "is_success" in info and "max_contact_force" in info
    finally:
        vec.close()
