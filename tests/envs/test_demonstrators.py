"""Scripted demonstrators: >= 19/20 successes per task, and the force habits they are meant to show."""

import numpy as np
import pytest

from lerobot_forcemap.envs.demonstrators import (
    PathPlan,
    Segment,
    SmoothNoise,
    make_demonstrator,
    min_jerk,
    run_demonstration,
)
from lerobot_forcemap.envs.tasks.erase import ERASE_FORCE, EraseTask
from lerobot_forcemap.envs.tasks.press import PressTask

from .conftest import N_DEMO_SEEDS, TASK_NAMES


@pytest.mark.parametrize("task", TASK_NAMES)
def test_demonstrator_succeeds_in_19_of_20_seeds(task, demo_rollouts):
    rollouts = demo_rollouts(task)
    assert len(rollouts) == N_DEMO_SEEDS
    successes = sum(r["info"]["is_success"] for r in rollouts)
    assert successes >= 19, [(r["seed"], r["info"]["termination_reason"]) for r in rollouts]
    assert not any(r["info"]["protective_stop"] for r in rollouts)
    assert all(r["info"]["n_clipped_steps"] == 0 for r in rollouts)  # demonstrations stay inside the limits


def test_press_demonstrations_overshoot(demo_rollouts):
    """VR teleoperation without haptics: far more force than the 8 N the button needs, below the stop."""
    maxima = np.array([r["info"]["max_contact_force"] for r in demo_rollouts("press")])
    assert maxima.min() > 3 * 8.0
    assert maxima.max() < PressTask.force_limit
    # the excess grows with the demonstrator's intended overshoot (the commanded depth past the stop)
    intended = np.array([r["params"]["excess_force_target_N"] for r in demo_rollouts("press")])
    assert np.corrcoef(intended, maxima)[0, 1] > 0.8


def test_erase_demonstrations_hold_a_steady_excess_force(demo_rollouts):
    for r in demo_rollouts("erase"):
        wipe = r["force"][r["phase"] == "wipe"][:, 2]
        steady = wipe[len(wipe) // 5 :]  # after the first fifth (contact transient)
        assert steady.mean() > 3 * ERASE_FORCE  # higher than needed
        assert steady.std() < 0.25 * steady.mean()  # but steady
        assert r["info"]["max_contact_force"] < EraseTask.force_limit
        assert r["info"]["coverage"] >= 0.9


def test_peg_demonstrations_bump_the_peg(demo_rollouts):
    rollouts = demo_rollouts("peg_in_hole")
    bumped = [r for r in rollouts if r["params"]["bumped"]]
    assert len(bumped) >= N_DEMO_SEEDS // 2
    assert np.median([r["info"]["max_contact_force"] for r in bumped]) > 10.0
    assert all(r["info"]["insertion_depth"] >= 0.02 for r in rollouts if r["info"]["is_success"])


def test_demonstrators_are_seeded(demo_rollouts):
    from .helpers import roll_demos

    again = roll_demos("press", [3])[0]
    first = demo_rollouts("press")[3]
    np.testing.assert_array_equal(again["actions"], first["actions"])


@pytest.mark.parametrize("task", [*TASK_NAMES, "grasp_push", "grasp_flip"])
def test_the_demonstrator_draws_its_noise_from_its_own_generator(task):
    """Same scene (env seed 0), two demonstrator seeds: the first 30 commands differ by millimetres."""
    import lerobot_forcemap.envs as E

    env = E.make(task)
    names = env.unwrapped.state_names["environment_state"]
    actions = []
    for seed in (1, 2, 1):
        episode = run_demonstration(env, make_demonstrator(task, seed, state_names=names), 0, max_steps=30)
        assert episode.steps == 30
        actions.append(np.array([f.action for f in episode.trace]))
    env.close()
    np.testing.assert_array_equal(actions[0], actions[2])
    assert np.abs(actions[0] - actions[1]).max() > 1e-3


@pytest.mark.parametrize("rng", [None, 1.5, "0", True])
def test_a_demonstrator_needs_a_generator_or_a_seed(rng):
    # None used to draw OS entropy: a demonstration nobody could record again
    with pytest.raises(ValueError, match="rng: must be a numpy Generator or an int seed, got"):
        make_demonstrator("press", rng)


def test_an_int_seed_is_the_generator_it_seeds():
    a, b = make_demonstrator("press", 7), make_demonstrator("press", np.random.default_rng(7))
    assert a.rng.uniform() == b.rng.uniform()


def test_path_plan_and_noise_helpers():
    plan = PathPlan(
        np.zeros(3),
        [Segment(np.array([1.0, 0, 0]), 2.0, "a"), Segment(np.array([1.0, 1.0, 0]), 1.0, "b", gripper=0.5)],
        1.0,
    )
    p, g, i = plan.sample(1.0)
    np.testing.assert_allclose(p, [0.5, 0, 0])
    assert (g, i) == (1.0, 0)
    p, g, i = plan.sample(2.5)
    np.testing.assert_allclose(p, [1.0, 0.5, 0])
    assert (g, i) == (0.5, 1)
    np.testing.assert_allclose(plan.sample(10.0)[0], [1, 1, 0])
    assert min_jerk(0.0) == 0 and min_jerk(1.0) == 1 and min_jerk(0.5) == pytest.approx(0.5)
    noise = SmoothNoise(np.random.default_rng(0), [0.001, 0.002])
    samples = np.array([noise(t) for t in np.arange(0, 200, 0.05)])
    np.testing.assert_allclose(samples.std(axis=0), [0.001, 0.002], rtol=0.25)
