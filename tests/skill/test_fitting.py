"""Segment -> anchor -> per-segment force-constrained maps, on synthetic presses with known forces."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from lerobot_forcemap.geometry import polyline_distances
from lerobot_forcemap.segmentation import AUTHORS_WINDOW_S
from lerobot_forcemap.skill.episodes import EpisodeArrays
from lerobot_forcemap.skill.fit import (
    NODE_REFINEMENTS,
    episode_streams,
    fit_skill,
    segment_episode,
    segmentation_config,
)
from lerobot_forcemap.skill.placement import place_skill

from .helpers import OBJECT_NAMES, TOOL_DOWN, params, press_episode

K_DEMO = 2000.0  # the controller stiffness behind the synthetic demonstrations
DEPTH = 0.02  # target depth below the surface while holding: F = K_DEMO * DEPTH = 40 N


def _fit(episodes, **kw):
    cfg = params(**{"segments": "dataset", **kw})
    return fit_skill(episodes, cfg, 20.0, OBJECT_NAMES) + (cfg,)


@pytest.mark.parametrize("k", [2500.0, 3000.0, 5000.0])
def test_contact_nodes_lift_by_force_over_stiffness(k):
    skill, report, _ = _fit([press_episode(0, depth=DEPTH, K=K_DEMO)], stiffness=k)
    ref, _, _ = _fit([press_episode(0, depth=DEPTH, K=K_DEMO)], stiffness=1e12)
    hold = 2  # approach, descend, hold, retreat
    lift = skill.segments[hold].nodes[:, 2].min() - ref.segments[hold].nodes[:, 2].min()
    assert lift == pytest.approx(K_DEMO * DEPTH / k, rel=0.02)
    assert report.summary()[hold]["capped_nodes"] == 0
    # the approach never touched: bit-identical with and without force points, but for its last node,
    # the junction it shares with the descend (which touches)
    np.testing.assert_array_equal(skill.segments[0].nodes[:-1], ref.segments[0].nodes[:-1])


def test_segments_near_the_object_are_stored_in_its_frame():
    obj = np.array([0.55, -0.02, 0.04])
    skill, report, _ = _fit([press_episode(0, obj=obj)], stiffness=1e12, anchor_radius=0.04)
    assert report.anchors == ("", "box", "box", "box")  # the approach ends 5 cm above the box
    hold = skill.segments[2]
    # object frame: the hold sits DEPTH below the object's origin, right above it
    np.testing.assert_allclose(hold.nodes[:, :2], 0.0, atol=1e-9)
    assert hold.nodes[:, 2].min() == pytest.approx(-DEPTH, abs=1e-4)
    np.testing.assert_allclose(hold.anchor_pose[:3], obj)
    # the free approach is in the base frame and starts at the demonstrated start
    np.testing.assert_allclose(skill.segments[0].nodes[0], [0.4, 0.0, 0.15], atol=2e-3)


def test_several_demonstrations_are_mapped_together_in_the_object_frame():
    a = press_episode(0, obj=(0.50, 0.00, 0.03), depth=0.015)
    b = press_episode(1, obj=(0.53, 0.02, 0.03), depth=0.025)
    skill, report, _ = _fit([a, b], stiffness=1e12)
    assert report.episodes == (0, 1) and len(report.changepoints) == 2
    # object-relative holds at -15 and -25 mm, at different base positions: one map in the box frame,
    # on its axis and halfway between the two depths (each demonstration alone gives its own depth); the
    # first and last nodes are the junctions it shares with its neighbours
    hold = skill.segments[2].nodes[1:-1]
    np.testing.assert_allclose(hold[:, :2], 0.0, atol=1e-9)
    assert hold[:, 2].min() == pytest.approx(-0.020, abs=1e-4)
    for ep, depth in ((a, 0.015), (b, 0.025)):
        one, _, _ = _fit([ep], stiffness=1e12)
        assert one.segments[2].nodes[:, 2].min() == pytest.approx(-depth, abs=1e-4)
    # without anchors (base frame) the two holds, 36 mm apart, spread the map's hold sideways
    base, report, _ = _fit([a, b], stiffness=1e12, anchor_radius=1e-9)
    assert report.anchors == ("", "", "", "")
    xy = base.segments[2].nodes[:, :2]
    assert np.max(np.linalg.norm(xy - xy[0], axis=1)) > 0.02


def test_segment_counts_must_agree():
    a = press_episode(0)
    b = press_episode(1)
    b = type(b)(**{**b.__dict__, "segment_labels": np.minimum(b.segment_labels, 2)})
    with pytest.raises(ValueError, match=r"segment counts differ .*episode 0: 4, episode 1: 3"):
        _fit([a, b])


def test_auto_segment_counts_must_agree():
    """Segmented by the policy itself (segments='auto'): one press gives 3 segments, the same press done
    twice gives 5; mapping them together is refused by name, not silently aligned."""
    one = press_episode(0)
    twice = dataclasses.replace(
        one,
        episode=1,
        times=np.arange(2 * one.n_frames) / 20.0,
        **{f: np.concatenate([getattr(one, f)] * 2) for f in ("pose", "force", "gripper", "env_state")},
        segment_labels=None,
    )
    assert len(_fit([twice], segments="auto")[0].segments) == 5
    with pytest.raises(ValueError, match=r"segment counts differ .*episode 0: 3, episode 1: 5"):
        _fit([one, twice], segments="auto")


def test_per_segment_override_changes_that_segment_only():
    base, _, _ = _fit([press_episode(0)], stiffness=3000.0)
    over, _, _ = _fit([press_episode(0)], stiffness=3000.0, segment_overrides={2: {"stiffness": 6000.0}})
    # segment 1 ends at the junction it shares with segment 2, so that node follows segment 2's fit
    np.testing.assert_array_equal(base.segments[1].nodes[:-1], over.segments[1].nodes[:-1])
    lift_base = base.segments[2].nodes[:, 2].min() + DEPTH
    lift_over = over.segments[2].nodes[:, 2].min() + DEPTH
    assert lift_over == pytest.approx(lift_base / 2, rel=0.02)


def test_space_time_map_keeps_a_retracing_segment_in_order():
    """One segment that goes down and back up: the 3-D map mixes the passes, the space-time map does not."""
    ep = press_episode(0)
    err = {}
    for v in (0.0, 0.05):
        skill, _, cfg = _fit([ep], segments="none", stiffness=1e12, time_scale=v)
        rep = place_skill(skill, cfg, robot_pose=None, object_pose=skill.demo_object_poses())
        d = np.linalg.norm(rep.actions_at(ep.times)[:, :3] - ep.pose[:, :3], axis=1)
        err[v] = float(np.sqrt(np.mean(d**2)))
    assert err[0.05] < 0.003  # follows the demonstration within 3 mm RMS
    assert err[0.0] > 10 * err[0.05]


def test_dataset_labels_become_changepoints_and_bad_labels_are_named():
    ep = press_episode(0)
    cfg = params(segments="dataset")
    cp = segment_episode(ep, cfg, 20.0)
    np.testing.assert_array_equal(cp, [0, 40, 60, 80, ep.n_frames])
    bad = type(ep)(
        **{**ep.__dict__, "segment_labels": np.where(np.arange(ep.n_frames) == 50, 3, ep.segment_labels)}
    )
    with pytest.raises(ValueError, match="'segment_index', episode 0, frame 50"):
        segment_episode(bad, cfg, 20.0)
    none = type(ep)(**{**ep.__dict__, "segment_labels": None})
    with pytest.raises(ValueError, match="no 'segment_index' column"):
        segment_episode(none, cfg, 20.0)


def test_a_label_on_the_last_frame_only_ends_the_previous_segment(caplog):
    """A recorder that stops on success logs its "done" phase on the last frame only (the grasp datasets'
    ``demo_phase``): that frame closes the previous segment instead of being a 1-frame segment."""
    ep = press_episode(0)
    labels = ep.segment_labels.copy()
    labels[-1] = labels[-2] + 1
    last = type(ep)(**{**ep.__dict__, "segment_labels": labels})
    cfg = params(segments="dataset")
    with caplog.at_level("WARNING"):
        cp = segment_episode(last, cfg, 20.0)
    np.testing.assert_array_equal(cp, [0, 40, 60, 80, ep.n_frames])
    assert f"label 4 occurs on the last frame ({ep.n_frames - 1}) only" in caplog.text
    skill, _ = fit_skill([last], cfg, 20.0, OBJECT_NAMES)
    assert skill.n_segments == 4


def test_segmentation_window_scales_with_fps():
    cfg = params(segmentation_window_s=AUTHORS_WINDOW_S)
    assert segmentation_config(cfg, 166.0).window == 64  # the authors' setting at their rate
    assert segmentation_config(cfg, 166.0).grace == 4
    assert segmentation_config(cfg, 20.0).window == 8
    assert segmentation_config(cfg, 5.0).window == 5  # Savitzky-Golay order 4 needs >= 5
    default = params()  # 0.3 s: 15 frames at 50 fps, min_run the window, min segment half of it
    assert (segmentation_config(default, 50.0).window, segmentation_config(default, 50.0).min_run) == (15, 15)
    assert segmentation_config(default, 50.0).min_segment_frames == 7
    cp = segment_episode(press_episode(0), params(segments="auto"), 20.0)
    assert cp[0] == 0 and cp[-1] == press_episode(0).n_frames and len(cp) >= 2


def test_changepoints_dropped_by_min_segment_s_are_reported(caplog):
    ep = press_episode(0)
    found = segment_episode(ep, params(), 20.0)
    assert len(found) > 2  # the press demo has changepoints to lose
    with caplog.at_level("WARNING"):
        # longer than the demo (4.3 s): no changepoint can stay
        cp = segment_episode(ep, params(min_segment_s=2.5), 20.0)
    assert cp.tolist() == [0, ep.n_frames]
    assert (
        f"episode 0: min_segment_s=2.5 (50 frames) dropped the changepoint(s) at frame(s) {found[1:-1].tolist()}; "
        f"kept [0, {ep.n_frames}]" in caplog.text
    )


def test_a_set_weight_for_a_stream_the_dataset_lacks_is_reported(caplog):
    ep = press_episode(0)  # the press demonstrations have no finger forces
    assert ep.finger_force is None
    with caplog.at_level("WARNING"):
        episode_streams(ep, params())  # the default weight: skipped quietly
    assert "stream_weights" not in caplog.text
    with caplog.at_level("WARNING"):
        streams = episode_streams(ep, params(stream_weights={"finger_force": 5.0}))
    assert "finger_force" not in [s.name for s in streams]
    assert (
        "episode 0: stream_weights['finger_force']=5 is set, but the dataset has no 'observation.finger_force' "
        "feature for it" in caplog.text
    )


def test_a_fit_stopped_at_max_iter_is_reported(caplog):
    with caplog.at_level("WARNING"):
        _, report, _ = _fit([press_episode(0, depth=DEPTH, K=K_DEMO)], max_iter=1)
    stopped = [r["segment"] for r in report.summary() if r["stop_reason"] == "max_iter"]
    assert stopped  # one EM iteration does not converge on these segments
    for s in stopped:
        assert f"segment {s}: the arm map's EM stopped at max_iter=1 without converging" in caplog.text
        step, spring = report.summary()[s]["last_step"], report.summary()[s]["last_spring_step"]
        assert step > 0 and spring >= 0
        assert (
            f"nodes still moved up to {step:.3g} and spring lengths up to {spring:.3g} in the last"
            in caplog.text
        )
        assert "where the stop test needs both <= " in caplog.text
    caplog.clear()
    with caplog.at_level("WARNING"):
        _fit([press_episode(0, depth=DEPTH, K=K_DEMO)])
    assert "without converging" not in caplog.text


def test_contact_events_become_changepoints():
    """A dataset with a contact column adds the touch_down / lift_off event streams: both edges of the
    contact become changepoints, whatever the signal streams see."""
    ep = press_episode(0, depth=DEPTH, K=K_DEMO)
    pressing = ep.force[:, 2] > 0
    touching = dataclasses.replace(ep, contact=pressing)
    assert [s.name for s in episode_streams(touching, params())][-2:] == ["touch_down", "lift_off"]
    cp = segment_episode(touching, params(), 20.0)
    first, last = np.flatnonzero(pressing)[[0, -1]]
    for frame in (first, last):
        assert np.min(np.abs(cp - frame)) <= 1
    off = params(stream_weights={"touch_down": 0.0, "lift_off": 0.0})
    assert not {"touch_down", "lift_off"} & {s.name for s in episode_streams(touching, off)}


def test_a_set_event_weight_without_a_contact_column_is_reported(caplog):
    with caplog.at_level("WARNING"):
        streams = episode_streams(press_episode(0), params(stream_weights={"lift_off": 2.0}))
    assert "lift_off" not in [s.name for s in streams]
    assert "stream_weights['lift_off']=2 is set, but the dataset has no 'contact' feature" in caplog.text


# ---- node count from the path tolerance ------------------------------------------------------------

FPS = 50.0


def _free_path(x: np.ndarray) -> EpisodeArrays:
    """A demonstration without force along the positions ``x (T, 3)`` at ``FPS``."""
    T = len(x)
    return EpisodeArrays(
        episode=0,
        times=np.arange(T) / FPS,
        pose=np.column_stack([x, np.tile(TOOL_DOWN, (T, 1))]),
        force=np.zeros((T, 3)),
        gripper=np.zeros(T),
        gripper_force=None,
        env_state=None,
        joints=None,
        finger_force=None,
        segment_labels=None,
        has_force=False,
    )


def _arm_fit(x: np.ndarray, tolerance: float | None, *more: np.ndarray):
    episodes = [_free_path(p) for p in (x, *more)]
    _, report = fit_skill(episodes, params(segments="none", path_tolerance_m=tolerance), FPS)
    return report.arm_fits[0]


def test_a_sharp_corner_gets_more_nodes_until_the_map_meets_the_path_tolerance():
    s = np.arange(0.0, 2.0 + 1e-9, 1.0 / FPS)  # 0.2 m along x, then a right-angle turn at 0.2 m/s
    corner = np.column_stack([0.4 + 0.2 * np.minimum(s, 1.0), 0.2 * np.maximum(s - 1.0, 0.0), 0.2 + 0 * s])
    inner = corner[10:-10]  # the ends are the junctions' (fit.py, _free_samples)
    plain = _arm_fit(corner, None)
    assert plain.n_nodes == 21  # nodes_per_second=10 over 2 s
    assert polyline_distances(inner, plain.nodes[:, :3]).max() > 0.005
    refined = _arm_fit(corner, 0.005)
    assert 21 < refined.n_nodes <= 1 + NODE_REFINEMENTS[-1] * 20
    assert polyline_distances(inner, refined.nodes[:, :3]).max() <= 0.005
    # a tolerance no count meets: bounded by the last refinement
    assert _arm_fit(corner, 0.0005).n_nodes == 1 + NODE_REFINEMENTS[-1] * 20


def test_a_smooth_path_keeps_its_node_count_and_nodes():
    s = np.arange(0.0, 2.0 + 1e-9, 1.0 / FPS)
    arc = np.column_stack([0.4 + 0.3 * np.cos(0.5 * s), 0.3 * np.sin(0.5 * s), 0.2 + 0 * s])
    plain, checked = _arm_fit(arc, None), _arm_fit(arc, 0.001)
    assert checked.n_nodes == plain.n_nodes == 21
    np.testing.assert_array_equal(checked.nodes, plain.nodes)


def test_the_force_points_lift_is_no_path_error():
    """k = 0.8 K_demo lifts the contact nodes by 25 mm, past the demonstrated surface, on purpose: that,
    and the samples next to the contact it pulls the map away from, never ask for more nodes."""
    ep = press_episode(0, depth=DEPTH, K=K_DEMO)
    lifted, _, _ = _fit([ep], stiffness=0.8 * K_DEMO, path_tolerance_m=0.001)
    plain, _, _ = _fit([ep], stiffness=0.8 * K_DEMO, path_tolerance_m=None)
    assert [len(s.nodes) for s in lifted.segments] == [len(s.nodes) for s in plain.segments]


def test_demonstrations_apart_keep_the_first_fit():
    """Two demonstrations 12 mm apart: the map runs between them, 6 mm from each, and more nodes do not
    bring it closer, so the refits are dropped."""
    s = np.arange(0.0, 2.0 + 1e-9, 1.0 / FPS)
    arc = np.column_stack([0.4 + 0.3 * np.cos(0.5 * s), 0.3 * np.sin(0.5 * s), 0.2 + 0 * s])
    lower, upper = arc - [0.0, 0.0, 0.006], arc + [0.0, 0.0, 0.006]
    plain, checked = _arm_fit(lower, None, upper), _arm_fit(lower, 0.004, upper)
    assert polyline_distances(lower[10:-10], plain.nodes[:, :3]).max() > 0.005
    assert checked.n_nodes == plain.n_nodes
    np.testing.assert_array_equal(checked.nodes, plain.nodes)
