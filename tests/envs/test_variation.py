"""randomize="none" | "paper" | "wide": what each level draws, reproducibly from the seed."""

from __future__ import annotations

import numpy as np
import pytest

import lerobot_forcemap.envs as E
from lerobot_forcemap.envs.variation import WIDE


def _scene(task: str, level, seed: int, **kwargs):
    env = E.make(task, randomize=level, render_mode=None, **kwargs)
    obs, info = env.reset(seed=seed)
    base = env.unwrapped
    out = (obs, info, base.model.jnt_stiffness.copy(), base.gains.stiffness_pos)
    env.close()
    return out


def test_paper_is_the_earlier_default_and_none_is_nominal():
    paper, flag = _scene("press", "paper", 7), _scene("press", True, 7)
    np.testing.assert_array_equal(paper[0]["environment_state"], flag[0]["environment_state"])
    none = _scene("press", "none", 7)
    np.testing.assert_allclose(none[0]["environment_state"][:3], [0.5, 0.0, 0.027], atol=1e-9)
    assert "variation" not in paper[1] and "variation" not in none[1]


@pytest.mark.parametrize("task", ["press", "erase", "grasp_push"])
def test_wide_draws_per_seed_and_repeats_a_seed(task):
    a, b, c = _scene(task, "wide", 3), _scene(task, "wide", 3), _scene(task, "wide", 4)
    np.testing.assert_array_equal(a[0]["environment_state"], b[0]["environment_state"])
    np.testing.assert_array_equal(a[0]["force"], b[0]["force"])
    assert a[1]["variation"] == b[1]["variation"] != c[1]["variation"]
    d = a[1]["variation"]
    assert abs(d["shift"][0]) <= WIDE.shift_xy and abs(d["shift"][2]) <= WIDE.dz and abs(d["yaw"]) <= WIDE.yaw
    assert WIDE.stiffness_scale[0] <= d["stiffness_scale"] <= WIDE.stiffness_scale[1]
    nominal = _scene(task, "paper", 3)
    np.testing.assert_allclose(np.asarray(a[3]) / np.asarray(nominal[3]), d["stiffness_scale"])
    # the F/T bias is in the observation (the arm is at rest after the tare: only bias and noise)
    assert np.linalg.norm(a[0]["force"][:3] - d["ft_bias"]) < 5 * WIDE.ft_noise


def test_wide_writes_from_the_nominal_model_every_episode():
    env = E.make("press", randomize="wide", render_mode=None)
    base = env.unwrapped
    spring = base.model.joint("button_slide").id
    nominal = float(base.model.jnt_stiffness[spring])
    for seed in (1, 2, 3):
        _, info = env.reset(seed=seed)
        assert base.model.jnt_stiffness[spring] == pytest.approx(nominal * info["variation"]["spring_scale"])
    env.close()


def test_stiffness_scale_and_the_level_are_checked():
    _, _, _, k = _scene("press", "none", 0, stiffness_scale=2.0)
    np.testing.assert_allclose(k, [4000.0] * 3)
    for bad in (0.0, -1.0, float("nan")):
        with pytest.raises(ValueError, match="stiffness_scale: must be"):
            E.make("press", stiffness_scale=bad)
    with pytest.raises(ValueError, match=r"randomize: must be one of \['none', 'paper', 'wide'\]"):
        E.make("press", randomize="wider")


def test_a_static_part_is_turned_from_its_nominal_orientation_every_episode():
    """The press button's body is turned by this episode's yaw alone, whatever the env ran before."""
    env = E.make("press", randomize="wide", render_mode=None)
    model = env.unwrapped.model
    for seed in (3, 4, 5):
        _, info = env.reset(seed=seed)
        yaw = info["variation"]["yaw"]
        q = model.body_quat[model.body("button_base").id]
        np.testing.assert_allclose(q, [np.cos(yaw / 2), 0.0, 0.0, np.sin(yaw / 2)], atol=1e-9)
    env.close()


def test_the_peg_top_follows_the_scene_every_episode():
    """peg_in_hole reads its peg's top once per placement: the state and the success test see the peg
    where this episode's draw (task's own, then "wide") put it."""
    from lerobot_forcemap.envs.tasks.peg_in_hole import PEG_HEIGHT

    env = E.make("peg_in_hole", randomize="wide", render_mode=None)
    base = env.unwrapped
    tops = []
    for seed in (3, 4):
        obs, _ = env.reset(seed=seed)
        top = base.model.body_pos[base.model.body("peg").id] + [0.0, 0.0, PEG_HEIGHT]
        np.testing.assert_array_equal(base.task_impl.peg_top_world(), top)
        np.testing.assert_array_equal(obs["environment_state"][:3], top.astype(np.float32))
        tops.append(top)
    assert not np.allclose(tops[0], tops[1])
    env.close()
