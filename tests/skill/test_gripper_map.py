"""The gripper map in space-time: a step command stays a step, finger force still opens the squeeze."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.skill.episodes import EpisodeArrays
from lerobot_forcemap.skill.fit import fit_skill
from lerobot_forcemap.skill.placement import place_skill

from .helpers import OBJECT_NAMES, TOOL_DOWN, params

FPS = 20.0


def _gripper_episode(gripper: np.ndarray, finger_force: np.ndarray | None = None) -> EpisodeArrays:
    """A still arm (no contact) with the gripper command ``gripper (T,)`` and the reaction of the finger
    force on the gripper coordinate ``finger_force (T,)`` (negative: towards open)."""
    T = len(gripper)
    x = np.column_stack([np.linspace(0.40, 0.45, T), np.zeros(T), np.full(T, 0.15)])
    env = np.tile(np.array([0.9, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0]), (T, 1))  # an object far away
    return EpisodeArrays(
        episode=0,
        times=np.arange(T) / FPS,
        pose=np.column_stack([x, np.tile(TOOL_DOWN, (T, 1))]),
        force=np.zeros((T, 3)),
        gripper=np.asarray(gripper, float),
        gripper_force=None if finger_force is None else np.asarray(finger_force, float),
        env_state=env,
        joints=None,
        finger_force=None,
        segment_labels=np.zeros(T, dtype=np.int64),
    )


def _reproduce(ep: EpisodeArrays, **kw) -> np.ndarray:
    """The reproduced gripper command at every control period of the demonstration."""
    cfg = params(segments="none", **kw)
    skill, _ = fit_skill([ep], cfg, FPS, OBJECT_NAMES)
    rep = place_skill(skill, cfg, robot_pose=None, object_pose={})
    return rep.actions_at(ep.times)[:, 7]


@pytest.mark.parametrize("step_at", [33, 48])
@pytest.mark.parametrize("direction", ["close", "open"])
def test_a_step_command_is_reproduced_as_a_step(step_at, direction):
    g = (np.arange(80) >= step_at).astype(float)
    if direction == "open":
        g = 1.0 - g
    out = _reproduce(_gripper_episode(g))
    closing = out if direction == "close" else 1.0 - out
    # within one or two control periods from <= 5 % to >= 95 % of the step
    between = np.flatnonzero((closing > 0.05) & (closing < 0.95))
    assert len(between) <= 1, np.round(closing[step_at - 4 : step_at + 4], 3)
    # at the demonstrated time (within one period), and flat elsewhere
    crossing = int(np.argmax(closing >= 0.5))
    assert abs(crossing - step_at) <= 1
    np.testing.assert_allclose(closing[: step_at - 2], 0.0, atol=0.02)
    np.testing.assert_allclose(closing[step_at + 2 :], 1.0, atol=0.02)


def test_the_1d_gripper_map_ramps_a_step_over_many_periods():
    """The defect the space-time map fixes: nodes between the open and closed clusters are empty and
    take times interpolated between the two clusters' mean times."""
    g = (np.arange(80) >= 40).astype(float)
    out = _reproduce(_gripper_episode(g), gripper_time_scale=0.0, gripper_nodes_per_second=10.0)
    assert np.count_nonzero((out > 0.05) & (out < 0.95)) > 10


def test_finger_force_lifts_the_squeeze_by_force_over_stiffness():
    """A hold with a steady finger force f: the reproduced closure is lower by f / k (a node
    in steady contact is lifted by F/k), and unchanged without force points."""
    T = 100
    t = np.arange(T) / FPS
    g = np.clip(0.5 * (t - 1.0), 0.0, 0.7)  # close at 0.5 / s from t = 1 s, hold 0.7 from t = 2.4 s
    f = np.where(g >= 0.7, -20.0, 0.0)  # the object pushes the fingers open while squeezed
    hold = slice(60, 90)
    k = 400.0
    with_force = _reproduce(_gripper_episode(g, f), gripper_stiffness=k)
    without = _reproduce(_gripper_episode(g, f), gripper_delta=0.0)
    np.testing.assert_allclose(without[hold], 0.7, atol=2e-3)
    lift = 0.7 - with_force[hold]
    np.testing.assert_allclose(lift, 20.0 / k, rtol=0.1)
    # before any finger force the two agree
    np.testing.assert_allclose(with_force[:20], without[:20], atol=2e-3)
