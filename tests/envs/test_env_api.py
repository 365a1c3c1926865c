import importlib
import re

import gymnasium as gym
import numpy as np
import pytest

import lerobot_forcemap.envs as E
from lerobot_forcemap.envs.registration import TASKS
from lerobot_forcemap.layout import ACTION_DIM, ENV_PIXELS

from .conftest import TASK_NAMES
from .helpers import assert_seed_determinism, check_task_env


def test_gym_ids_registered_from_the_task_specs():
    for name, spec in TASKS.items():
        assert spec.name == name and spec.gym_id in gym.registry
        module, cls = spec.entry_point.split(":")
        assert getattr(importlib.import_module(module), cls).task_class.spec is spec
        assert gym.spec(spec.gym_id).max_episode_steps == spec.max_episode_steps
        assert gym.spec(spec.gym_id).entry_point == spec.entry_point
    assert {"lerobot_forcemap/Press-v0", "lerobot_forcemap/Erase-v0", "lerobot_forcemap/PegInHole-v0"} <= set(
        gym.registry
    )


@pytest.mark.parametrize("task", TASK_NAMES)
def test_check_env(task):
    check_task_env(task)


@pytest.mark.parametrize("task", TASK_NAMES)
def test_same_seed_same_observations(task):
    env = E.make(task)
    assert_seed_determinism(env, seed=7)


def test_observation_layout_matches_state_names():
    env = E.make("peg_in_hole", obs_type="pixels_state", image_size=64)
    obs, info = env.reset(seed=0)
    names = env.unwrapped.state_names
    for key, n in names.items():
        assert obs[key].shape == (len(n),) and obs[key].dtype == np.float32
    assert obs[ENV_PIXELS]["front"].shape == (64, 64, 3) and obs[ENV_PIXELS]["front"].dtype == np.uint8
    assert obs in env.observation_space
    frame = env.render()
    assert frame.shape == (256, 256, 3) and frame.dtype == np.uint8 and frame.std() > 5
    # the disc starts in the hand, above the peg, nothing inserted
    st = dict(zip(names["environment_state"], obs["environment_state"], strict=True))
    assert st["disc_z"] > st["peg_z"] + 0.05 and st["insertion_depth"] == 0.0
    env.close()


def test_bad_actions_and_options_raise():
    env = E.make("press")
    obs, _ = env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action: must have shape \(8,\) .* got shape \(7,\)"):
        env.step(np.zeros(7))
    a = np.concatenate([obs["ee_pose"], [1.0]])
    for shape in [(2, 4), (8, 1), (1, 8)]:  # eight numbers, but not an action: not flattened silently
        with pytest.raises(
            ValueError, match=rf"action: must have shape \(8,\).*got shape {re.escape(str(shape))}"
        ):
            env.step(a.reshape(shape))
    a[2] = np.nan
    with pytest.raises(ValueError, match=r"action\[2\]: must be a finite number .*\(step 0\), got nan"):
        env.step(a)
    with pytest.raises(ValueError, match="unknown options"):
        env.reset(seed=0, options={"bogus": 1})
    env.reset(seed=0, options={"lerobot_new_rollout": True})  # LeRobot's rollout option is accepted
    for size in (0, -5, 2.5, True, 20000):  # True gave 1-pixel images, 20000 a MuJoCo error at reset
        with pytest.raises(ValueError, match=r"image_size: must be an integer >= 1 and <= 4096, got"):
            E.make("press", obs_type="pixels_state", image_size=size)
    with pytest.raises(ValueError, match=r"randomize: must be one of \['none', 'paper', 'wide'\], got 'no'"):
        E.make("press", randomize="no")  # a truthy string: it randomised
    for cutoff in (float("nan"), 0.0, -1.0, float("inf"), True, "10"):
        # NaN used to pass: NaN forces, no protective stop, max_contact_force 0
        with pytest.raises(ValueError, match="force_cutoff_hz: must be a finite number > 0 Hz, got"):
            E.make("press", force_cutoff_hz=cutoff)


def test_an_action_beyond_the_magnitude_bound_is_refused_naming_its_entry():
    """An entry of magnitude >= 1e300 made info["clip_distance"] inf; an action is refused like a NaN
    beyond MAX_ACTION_MAGNITUDE (1e6), and the largest accepted one keeps every clip report finite."""
    env = E.make("press")
    obs, _ = env.reset(seed=0)
    a = np.concatenate([obs["ee_pose"], [1.0]]).astype(float)
    for i, value in ((0, 1e300), (2, -1e300), (4, 1e7), (7, np.inf)):
        bad = a.copy()
        bad[i] = value
        with pytest.raises(
            ValueError,
            match=rf"action\[{i}\]: must be a finite number of magnitude <= 1e\+06 \(step 0\), got",
        ):
            env.step(bad)
    edge = a.copy()
    edge[:3] = [-1e6, 1e6, -1e6]
    edge[3:7] = [1e6, -1e6, 1e6, 1e6]
    _, _, _, _, info = env.step(edge)
    assert info["clip_workspace"] and np.isfinite(info["clip_distance"]) and np.isfinite(info["clip_angle"])
    assert info["clip_distance"] > 1e6
    env.close()


def test_an_object_for_a_task_without_objects_is_a_value_error_naming_object():
    """gym.make(press, object=...) was a bare TypeError (an unexpected keyword argument)."""
    with pytest.raises(
        ValueError,
        match=r"^object: must be None: task 'press' has no objects \(tasks with objects: grasp_push, "
        r"grasp_flip\), got 'apple'$",
    ):
        gym.make("lerobot_forcemap/Press-v0", object="apple")
    env = gym.make("lerobot_forcemap/Press-v0", object=None)  # None: no object chosen
    assert env.unwrapped.object_name is None
    env.close()


def test_settle_seconds_must_be_a_finite_non_negative_duration():
    # -1 used to become the 2-step minimum silently; NaN crashed in int() with numpy's message
    for settle in (float("nan"), -1.0, float("inf"), True, "0.3", None):
        with pytest.raises(ValueError, match=r"settle_seconds: must be a finite number >= 0 s, got"):
            E.make("press", settle_seconds=settle)
    env = E.make("press", settle_seconds=0)  # 0: the shortest settle the reset needs (2 physics steps)
    assert env.unwrapped.settle_steps == 2
    env.close()


def test_clipping_is_reported_not_silent():
    env = E.make("press")
    obs, info = env.reset(seed=0)
    assert not info["target_clipped"] and info["n_clipped_steps"] == 0
    far = np.concatenate([obs["ee_pose"][:3] + [0.2, 0, 0], obs["ee_pose"][3:], [1.0]])
    obs2, _, _, _, info = env.step(far)
    assert info["target_clipped"] and info["clip_speed"] and not info["clip_workspace"]
    assert info["clip_distance"] == pytest.approx(0.2 - 0.25 * 0.05, abs=1e-4)  # obs is float32, TCP ~ target
    assert info["clip_angle"] == pytest.approx(0.0, abs=1e-6)
    # half a turn about the tool axis in one step: the 1 rad/s speed limit lets 0.05 rad through
    qw, qx, qy, qz = (float(v) for v in obs2["ee_pose"][3:])
    turned = np.array([-qz, -qy, qx, qw])  # (0, 0, 0, 1) * q: pi about base z
    _, _, _, _, info = env.step(np.concatenate([obs2["ee_pose"][:3], turned, [1.0]]))
    assert info["clip_speed"] and not info["clip_workspace"]
    assert info["clip_angle"] == pytest.approx(np.pi - 0.05, abs=0.01)
    outside = np.concatenate([[0.0, 0.0, 0.2], obs["ee_pose"][3:], [1.5]])
    _, _, _, _, info = env.step(outside)
    assert info["clip_workspace"] and info["clip_gripper"] and info["n_clipped_steps"] == 3
    # a new episode starts with no clip reports left over from the last one
    _, info = env.reset(seed=0)
    assert not (info["target_clipped"] or info["clip_gripper"] or info["clip_workspace"])
    assert info["n_clipped_steps"] == 0
    assert env.action_space.shape == (ACTION_DIM,)


def test_stepping_after_the_episode_ended_warns_once():
    """A protective stop ends the episode; stepping on is simulated but said, once per episode."""
    import warnings

    env = E.make("press")
    obs, _ = env.reset(seed=0)
    down = np.concatenate([obs["ee_pose"], [1.0]])
    for _ in range(200):
        down[2] -= 0.01
        obs, _, terminated, _, info = env.step(down)
        if terminated:
            break
    assert terminated and info["protective_stop"]
    with pytest.warns(UserWarning, match=r"step\(\) after the episode ended \(protective_stop\)"):
        env.step(down)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env.step(down)  # said once
        env.reset(seed=0)
        env.step(np.concatenate([env.unwrapped.tcp_pose()[0], env.unwrapped.tcp_pose()[1], [1.0]]))


@pytest.mark.parametrize("task", sorted(TASKS))
def test_physics_options_are_the_specs(task):
    """The physics settings: 2 ms timestep, implicitfast integrator, elliptic friction cones (contact forces depend on them)."""
    import mujoco

    env = E.make(task, render_mode=None)
    opt = env.unwrapped.model.opt
    assert opt.timestep == 0.002
    assert opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    env.close()


def test_free_space_tracking_error_is_reported():
    """The TCP-to-target distance is in info: the UR5e tracks free-space targets exactly; the Gen3's posture
    springs pull its TCP off targets far from home (measured 21 mm at (0.7, -0.3, 0.05)), which no clip flagged."""
    for env_id, target, bound in (
        ("lerobot_forcemap/Press-v0", (0.7, -0.3, 0.05), 1e-4),
        ("lerobot_forcemap/GraspPush-v0", (0.42, 0.0, 0.25), 1e-3),
    ):
        env = gym.make(env_id, randomize=False)
        obs, _ = env.reset(seed=0)
        action = np.r_[target, obs["ee_pose"][3:], 0.0]
        for _ in range(100):
            obs, _, _, _, info = env.step(action)
        assert 0.0 <= info["tracking_error"] < bound, (env_id, info["tracking_error"])
        assert not info["target_clipped"]
        env.close()


def _render_in_forked_child(out):
    env = gym.make("lerobot_forcemap/Press-v0", render_mode="rgb_array")
    env.reset(seed=0)
    try:
        env.render()
        out.put("rendered")
    except RuntimeError as err:
        out.put(str(err))


def test_rendering_in_a_process_forked_after_rendering_is_refused_not_hung():
    """fork() after the parent rendered left the child's GL context dead: AsyncVectorEnv(context='fork')
    hung forever in render()."""
    import multiprocessing as mp

    env = gym.make("lerobot_forcemap/Press-v0", render_mode="rgb_array")
    env.reset(seed=0)
    assert env.render().shape[2] == 3  # the parent renders first
    ctx = mp.get_context("fork")
    out = ctx.Queue()
    child = ctx.Process(target=_render_in_forked_child, args=(out,))
    child.start()
    child.join(timeout=120)
    assert not child.is_alive(), "the forked child hung"
    assert "forked from one that had already rendered" in out.get(timeout=5)
    env.close()
