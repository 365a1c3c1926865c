"""The policy re-anchors an object-anchored segment when it starts, to the object observed then
(the synthetic push-then-grasp of ``tests/skill/helpers.push_grasp_episode``; the placement itself is
tested in ``tests/skill/test_reanchoring.py``)."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
import pytest

from tests.skill.helpers import GRASP_NAMES, TOOL_DOWN, push_grasp_episode

if TYPE_CHECKING:
    import torch

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

FPS = 20.0
BOX = np.array([0.45, 0.0, 0.02])
PUSH = 0.08
WALL = np.array([0.56, 0.0, 0.0])
APPROACH, PUSHING, REACH, GRASP, LIFT = range(5)


def _config(**kw) -> ForceMapConfig:
    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    return ForceMapConfig(device="cpu", **{"segments": "dataset", "anchor_by_moved_object": True, **kw})


def _batch(tcp, box) -> dict[str, torch.Tensor]:
    import torch

    return {
        "observation.ee_pose": torch.tensor([[*tcp, *TOOL_DOWN]], dtype=torch.float32),
        "observation.environment_state": torch.tensor(
            [[*box, 1.0, 0.0, 0.0, 0.0, *WALL]], dtype=torch.float32
        ),
    }


def _run_policy(policy: ForceMapPolicy, box_at_reset, box_after_push) -> tuple[np.ndarray, np.ndarray]:
    """Stream the reproduction; the observed box sits at ``box_at_reset`` until the reach segment
    starts and at ``box_after_push`` from then on. Returns (actions (K, 8), segment start times as
    placed at reset; a re-anchored provisional segment's lead-in delays the later ones)."""
    policy.reset()
    starts = None
    tcp = np.array([0.30, 0.02, 0.15])
    out = []
    for k in range(int(11.0 * FPS)):
        t = k / FPS
        box = box_at_reset if starts is None or t < starts[REACH] else box_after_push
        a = policy.select_action(_batch(tcp, box))[0].numpy().astype(float)
        starts = policy._run.placed[0].start_times if starts is None else starts
        tcp = a[:3]
        out.append(a)
    return np.array(out), starts


@pytest.mark.parametrize("online", [True, False])
def test_the_policy_reanchors_a_segment_when_it_starts(online):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    policy = ForceMapPolicy(_config(reanchor_online=online))
    policy.fit_episodes([push_grasp_episode(box=BOX, wall=WALL, push=PUSH)], FPS, GRASP_NAMES)
    skill = policy.skill
    at_reset = BOX + [0.01, -0.01, 0.0]
    after_push = BOX + [PUSH - 0.03, 0.04, 0.0]  # not where the demonstration's push would have left it
    acts, starts = _run_policy(policy, at_reset, after_push)
    k_reach = int(np.ceil(starts[REACH] * FPS - 1e-9))
    k_grasp = int(np.ceil(policy._run.placed[0].start_times[GRASP] * FPS - 1e-9))
    grasp_point = acts[k_grasp - 1, :3]  # the end of the reach, where the hand closes
    expected = after_push + skill.segments[REACH].nodes[-1]  # the demonstrated grasp, on the observed box
    if not online:  # anchored at reset only: the grasp goes where the box was predicted to be
        assert np.linalg.norm(grasp_point - expected) > 0.04
        assert policy.reanchor_log == []
        return
    np.testing.assert_allclose(grasp_point, expected, atol=2e-3)
    [entry] = [e for e in policy.reanchor_log if e["segment"] == REACH]
    np.testing.assert_allclose(entry["shift"], after_push - (at_reset + [PUSH, 0.0, 0.0]), atol=1e-6)
    # the reach was provisional (the push moves the box first): it travels to its shifted start first,
    # at REANCHOR_TRAVEL_SPEED, and the grasp starts that much later than placed at reset
    delay = policy._run.placed[0].start_times[GRASP] - starts[GRASP]
    assert entry["lead_in_s"] > 0 and delay == pytest.approx(entry["lead_in_s"], abs=1e-9)
    # the junction is smooth: no jump of the target when the reach starts
    steps = np.linalg.norm(np.diff(acts[:, :3], axis=0), axis=1)
    assert steps[k_reach - 1] < 0.012 and steps[k_reach - 1 : k_reach + 25].max() < 0.015
    # the hand closes on the box (a step within two control periods) and lifts it from there
    g = acts[k_grasp:, 7]
    assert np.count_nonzero((g > 0.05) & (g < 0.95)) <= 1 and g[-1] > 0.95
    np.testing.assert_allclose(acts[-1, :3], expected + [0.0, 0.0, 0.10], atol=3e-3)
