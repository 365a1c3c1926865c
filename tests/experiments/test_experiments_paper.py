"""``experiments.paper.jobs``: statistics, seed dealing, re-anchoring, jobs and their cache."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from experiments.paper.jobs import (
    DemoEpisode,
    Job,
    JobRunner,
    code_fingerprint,
    demo_change,
    demo_force_records,
    demo_phase_switches,
    fit_key,
    reanchor_actions,
    segmentation_score,
    split_seeds,
    summarize_records,
    wilson_interval,
)
from lerobot_forcemap import layout
from lerobot_forcemap.geometry import quat_multiply, quat_rotate
from tests.conftest import REPO_ROOT


def test_wilson_interval_known_values_and_symmetry():
    lo, hi = wilson_interval(20, 20)
    assert lo == pytest.approx(0.8389, abs=1e-4) and hi == 1.0
    lo, hi = wilson_interval(10, 20)
    assert (lo + hi) / 2 == pytest.approx(0.5) and lo == pytest.approx(0.2993, abs=1e-4)
    a, b = wilson_interval(3, 17)
    c, d = wilson_interval(14, 17)
    assert a == pytest.approx(1 - d) and b == pytest.approx(1 - c)
    assert wilson_interval(0, 0) == (0.0, 1.0)


def _rec(seed, demo, fmax, fmean, ok=True, stop=False):
    return {
        "seed": seed,
        "demo": demo,
        "success": ok,
        "protective_stop": stop,
        "max_contact_force": fmax,
        "mean_contact_force": fmean,
        "max_contact_force_xyz": [fmax / 2, 0.0, fmax],
        "mean_contact_force_xyz": [fmean, fmean / 2, 0.0],
    }


def test_summarize_records_statistics():
    recs = [_rec(1, 0, 10.0, 2.0), _rec(2, 0, 12.0, 4.0), _rec(3, 1, 14.0, 6.0, ok=False, stop=True)]
    s = summarize_records(recs)
    assert s["n"] == 3 and s["seeds"] == [1, 2, 3]
    assert s["success_rate"] == pytest.approx(2 / 3) and s["protective_stops"] == 1
    m = s["max_contact_force"]
    assert m["mean"] == pytest.approx(12.0) and m["std"] == pytest.approx(2.0)  # ddof 1
    assert m["ci95"] == pytest.approx(4.302653 * 2.0 / math.sqrt(3), rel=1e-5)  # t(0.975, 2)
    assert m["min"] == 10.0 and m["max"] == 14.0
    np.testing.assert_allclose(s["mean_contact_force_xyz"]["mean"], [4.0, 2.0, 0.0])
    assert summarize_records([]) == {"n": 0}


def test_the_success_interval_counts_demonstrations_when_they_repeat():
    """20 seeds of one demonstration's policy share its outcome: 10 demonstrations x 20 seeds is 10
    units, not 200 (the interval of 8/10, not of 160/200)."""
    recs = [_rec(s, d, 1.0, 1.0, ok=d < 8) for d in range(10) for s in range(20)]
    s = summarize_records(recs)
    assert s["n"] == 200 and s["success_rate"] == pytest.approx(0.8)
    assert s["success_ci95_unit"] == "demonstration" and s["success_ci95_n"] == 10
    assert s["success_ci95"] == pytest.approx(list(wilson_interval(8, 10)))
    assert s["success_ci95"][0] == pytest.approx(0.4902, abs=1e-4)  # [49, 94] %, not [74, 85] %
    # one episode per demonstration (or no demonstration): each episode is a unit
    single = summarize_records([_rec(s, s, 1.0, 1.0, ok=s < 16) for s in range(20)])
    assert single["success_ci95_unit"] == "episode" and single["success_ci95"] == pytest.approx(
        list(wilson_interval(16, 20))
    )
    # a demonstration whose seeds disagree counts with its rate
    mixed = summarize_records([_rec(0, 0, 1.0, 1.0), _rec(1, 0, 1.0, 1.0, ok=False), _rec(2, 1, 1.0, 1.0)])
    assert mixed["success_ci95"] == pytest.approx(list(wilson_interval(1.5, 2)))


def test_demo_change_is_per_demonstration():
    demos = [{"episode": 0, "max_contact_force": 20.0}, {"episode": 1, "max_contact_force": 40.0}]
    recs = [_rec(1, 0, 10.0, 1.0), _rec(2, 0, 12.0, 1.0), _rec(3, 1, 30.0, 1.0)]
    c = demo_change(recs, demos, "max_contact_force")
    assert c["per_demo"] == {"0": pytest.approx(-45.0), "1": pytest.approx(-25.0)}
    assert c["mean"] == pytest.approx(-35.0) and c["std"] == pytest.approx(math.sqrt(200.0))
    assert c["pooled"] == pytest.approx(100 * ((52 / 3) / 30 - 1))
    with pytest.raises(ValueError, match="demonstrations \\[7\\]"):
        demo_change([_rec(1, 7, 1.0, 1.0)], demos, "max_contact_force")


def test_split_seeds_deals_every_seed_once_over_every_demo():
    out = split_seeds(range(1000, 1020), range(10))
    assert sorted(s for v in out.values() for s in v) == list(range(1000, 1020))
    assert all(len(v) == 2 for v in out.values()) and set(out) == set(range(10))
    assert out[3] == (1003, 1013)
    assert split_seeds([5, 6], [0, 1, 2]) == {0: (5,), 1: (6,)}
    with pytest.raises(ValueError, match="split_seeds: no demos"):
        split_seeds([1], [])


def _demo(actions, state):
    names = ("box_x", "box_y", "box_z", "box_qw", "box_qx", "box_qy", "box_qz")
    return DemoEpisode(0, np.asarray(actions, float), np.asarray([state] * len(actions), float), names, 20.0)


def test_reanchor_actions_moves_rigidly_with_the_object():
    acts = np.array([[0.6, 0.1, 0.2, 1, 0, 0, 0, 1.0], [0.5, 0.0, 0.05, 0, 1, 0, 0, 0.5]])
    before = [0.5, 0.0, 0.0, 1, 0, 0, 0]
    demo = _demo(acts, before)
    np.testing.assert_allclose(reanchor_actions(demo, np.array(before), "box"), acts, atol=1e-12)
    shifted = reanchor_actions(demo, np.array([0.52, -0.01, 0.0, 1, 0, 0, 0]), "box")
    np.testing.assert_allclose(shifted[:, :3], acts[:, :3] + [0.02, -0.01, 0.0], atol=1e-12)
    np.testing.assert_allclose(shifted[:, 3:], acts[:, 3:], atol=1e-12)
    yaw = np.array([np.cos(0.15), 0, 0, np.sin(0.15)])  # 0.3 rad about z
    turned = reanchor_actions(demo, np.array([0.5, 0.0, 0.0, *yaw]), "box")
    np.testing.assert_allclose(
        turned[:, :3], [0.5, 0, 0] + quat_rotate(yaw, acts[:, :3] - [0.5, 0, 0]), atol=1e-12
    )
    np.testing.assert_allclose(turned[:, 3:7], quat_multiply(yaw, acts[:, 3:7]), atol=1e-12)
    assert turned[1, layout.ACTION_GRIPPER] == 0.5
    with pytest.raises(ValueError, match="'peg' not in"):
        reanchor_actions(demo, np.array(before), "peg")


def test_job_keys_and_validation():
    a = Job("press", "ours", "forcemap", 0, (1000, 1001), overrides=("stiffness=2000",))
    assert a.key() == Job("press", "ours", "forcemap", 0, (1000, 1001), overrides=("stiffness=2000",)).key()
    assert a.key() != Job("press", "ours", "forcemap", 0, (1000,), overrides=("stiffness=2000",)).key()
    assert fit_key(a) == fit_key(Job("press", "other", "forcemap", 0, (7,), overrides=("stiffness=2000",)))
    assert fit_key(a) != fit_key(Job("press", "ours", "forcemap", 1, (1000,), overrides=("stiffness=2000",)))
    with pytest.raises(ValueError, match="Job.kind: expected forcemap, hybrid or replay, got 'magic'"):
        Job("press", "x", "magic", 0, (1,))
    with pytest.raises(ValueError, match="no seeds"):
        Job("press", "x", "hybrid", 0, ())
    assert len(code_fingerprint()) == 10


def test_demo_force_records_match_the_recorder_file():
    recs = demo_force_records(REPO_ROOT / "datasets" / "press")
    raw = json.loads((REPO_ROOT / "datasets" / "press" / "meta" / "forcemap_episodes.json").read_text())[
        "episodes"
    ]
    assert len(recs) == len(raw) and recs[3]["max_contact_force"] == raw[3]["max_contact_force"]


def test_segmentation_is_scored_against_the_demonstrators_phase_switches():
    """SPEC §2: changepoint precision/recall/F1 within the window against the scripted phase switches."""
    import pyarrow.parquet as pq

    switches = demo_phase_switches(REPO_ROOT / "datasets" / "press")
    table = pq.read_table(REPO_ROOT / "datasets" / "press" / "data" / "chunk-000" / "file-000.parquet")
    rows = table.filter(table["episode_index"].to_numpy() == 3).sort_by("frame_index")
    phase = rows[layout.DEMO_PHASE].to_numpy()
    assert sorted(switches) == list(range(10))
    assert len(switches[3]) == 4 and np.all(phase[switches[3]] != phase[switches[3] - 1])
    assert len(np.unique(phase)) == 5  # no other switches: 5 phases, 4 changes
    sw, T = switches[3].tolist(), len(phase)

    def fit(interior, demo=3, window=8):
        return {"demo": demo, "changepoints": [0, *interior, T], "segmentation_window_frames": window}

    assert segmentation_score([fit(sw)], switches)["f1"] == 1.0
    assert segmentation_score([fit([c + 8 for c in sw])], switches)["f1"] == 1.0  # within the window
    assert segmentation_score([fit([c + 9 for c in sw], window=8)], switches)["recall"] < 1.0
    none = segmentation_score([fit([])], switches)  # one segment: nothing found, nothing wrong
    assert (none["precision"], none["recall"], none["f1"]) == (1.0, 0.0, 0.0)
    # pooled over fits: 4 of 4, then 2 of 4 with one false alarm far from every switch
    assert sw[0] > 28  # so sw[0] - 20 is more than a window from every switch
    pooled = segmentation_score([fit(sw), fit([sw[0] - 20, sw[0], sw[1]])], switches)
    assert pooled["precision"] == pytest.approx(6 / 7) and pooled["recall"] == pytest.approx(6 / 8)
    assert pooled["n_fits"] == 2 and pooled["tolerance_frames"] == [8]
    assert segmentation_score([fit(sw, demo=99)], switches) is None  # no reference: not scored


def test_jobs_run_cache_and_share_one_fit(tmp_path):
    """A hybrid and a forcemap job on press (1 episode each): records, the cache, a shared checkpoint."""
    hybrid = Job(
        "press", "hybrid", "hybrid", 0, (1000,), hybrid=(("force_threshold", 8.0),), trace_first=True
    )
    ours = Job("press", "ours", "forcemap", 0, (1000,), overrides=("stiffness=2000",))
    ours_again = Job("press", "again", "forcemap", 0, (1001,), overrides=("stiffness=2000",))
    with JobRunner(1) as runner:
        out = runner.run([hybrid, ours, ours_again, hybrid], tmp_path, desc="test")
        assert [o["key"] for o in out] == [hybrid.key(), ours.key(), ours_again.key(), hybrid.key()]
        for o in out[:3]:
            rec = o["records"][0]
            assert rec["success"] and not rec["protective_stop"]
            assert (
                len(rec["max_contact_force_xyz"]) == 3 and rec["max_contact_force"] > 6.0
            )  # the button clicked
        # the hybrid baseline regulates near its 8 N threshold; the demonstration pressed 56 N
        assert out[0]["records"][0]["max_contact_force"] < 30.0
        assert out[0]["records"][0]["trace"]["rows"] and "trace" not in out[1]["records"][0]
        assert out[1]["fit"]["checkpoint"] == out[2]["fit"]["checkpoint"]  # one fit for both
        fit = out[1]["fit"]  # what segmentation_score reads: the demo's changepoints and the window
        assert fit["demo"] == 0 and fit["changepoints"][0] == 0 and fit["segmentation_window_frames"] == 8
        again = runner.run([ours], tmp_path, desc="test")[0]
        assert again["cached"] and again["records"] == out[1]["records"]


def test_force_by_gripper_phase_splits_the_peaks():
    from experiments.paper.jobs import force_by_gripper_phase

    forces = np.array([[1.0, 0, 5], [-3.0, 1, 2], [0.5, -2, 0], [2.0, 0, 1]])
    grip = np.array([1.0, 0.5, 0.0, 0.97])
    out = force_by_gripper_phase(forces, grip)
    assert out["closed"] == {"steps": 2, "max_xyz": [2.0, 0.0, 5.0]}
    assert out["moving"] == {"steps": 1, "max_xyz": [3.0, 1.0, 2.0]}
    assert out["open"] == {"steps": 1, "max_xyz": [0.5, 2.0, 0.0]}
    assert force_by_gripper_phase(np.zeros((0, 3)), np.zeros(0))["moving"]["steps"] == 0
    with pytest.raises(ValueError, match="3 force samples for 2"):
        force_by_gripper_phase(forces[:3], grip[:2])
