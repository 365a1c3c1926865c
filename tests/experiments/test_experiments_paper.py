"""``experiments.paper``: seed dealing, re-anchoring, demonstration figures, jobs and their cache."""

from __future__ import annotations

import json

import numpy as np
import pytest

from experiments.paper import force_reduction, grasping, peg_in_hole
from experiments.paper.common import PAPER_LAW, Settings, split_seeds
from experiments.paper.demos import (
    DemoEpisode,
    demo_force_records,
    demo_phase_switches,
    reanchor_actions,
    segmentation_score,
)
from experiments.paper.jobs import FINGERPRINTED_CODE, Job, JobStats, code_fingerprint, run_jobs
from experiments.paper.rollouts import fit_key
from lerobot_forcemap import layout
from lerobot_forcemap.executor import make_executor
from lerobot_forcemap.geometry import quat_multiply, quat_rotate
from lerobot_forcemap.segmentation import DEFAULT_TIMING
from tests.conftest import REPO_ROOT


def test_split_seeds_deals_every_seed_once_over_every_demo():
    out = split_seeds(range(1000, 1020), range(10))
    assert sorted(s for v in out.values() for s in v) == list(range(1000, 1020))
    assert all(len(v) == 2 for v in out.values()) and set(out) == set(range(10))
    assert out[3] == (1003, 1013)
    assert split_seeds([5, 6], [0, 1, 2]) == {0: (5,), 1: (6,)}
    with pytest.raises(ValueError, match="split_seeds: no demos"):
        split_seeds([1], [])


def test_only_the_package_defaults_rows_run_without_the_paper_law():
    s = Settings(demos=(0,), eval_seeds=(1000,))
    chosen = {"stiffness": 1800.0, "force_limit": 3.0}
    tuning = {
        t: {p: {"chosen": chosen} for p in ("weights", "weights_limit", "limit_alone")}
        for t in ("press", "erase")
    }
    tuning["peg_in_hole"] = {
        "hybrid": {"chosen": {"force_threshold": 3.0, "normal": "fixed"}},
        "ours": {"chosen": {**chosen, "f_contact": 0.5}},
    }
    cells = force_reduction.cells(tuning, s) + peg_in_hole.cells(tuning["peg_in_hole"], s) + grasping.cells(s)
    for c in cells:
        for j in c.jobs:
            if j.kind != "forcemap":
                continue
            if c.method == "ours_default":
                assert j.overrides == (), (c.experiment, c.task)
            else:
                assert j.overrides[: len(PAPER_LAW)] == PAPER_LAW, (c.experiment, c.task, c.method)
    assert {c.experiment for c in cells if c.method == "ours_default"} == {"table2", "peg", "grasp"}


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
    with pytest.raises(
        ValueError, match=r"Job.kind: must be one of \['forcemap', 'hybrid', 'replay'\], got 'magic'"
    ):
        Job("press", "x", "magic", 0, (1,))
    with pytest.raises(ValueError, match=r"Job.seeds: must be a non-empty list of integers, got \(\)"):
        Job("press", "x", "hybrid", 0, ())
    assert len(code_fingerprint()) == 10


def test_the_fingerprint_covers_the_compiled_loops_sources():
    """A C-only change re-runs the cached jobs too (the extension is rebuilt from these sources)."""
    hashed = {
        p.relative_to(REPO_ROOT).as_posix() for pattern in FINGERPRINTED_CODE for p in REPO_ROOT.glob(pattern)
    }
    assert {"lerobot_forcemap/elmap/_emkernel.c", "lerobot_forcemap/envs/_stepkernel.c"} <= hashed


def test_demo_force_records_match_the_recorder_file():
    recs = demo_force_records(REPO_ROOT / "datasets" / "press")
    raw = json.loads((REPO_ROOT / "datasets" / "press" / "meta" / "forcemap_episodes.json").read_text())[
        "episodes"
    ]
    assert len(recs) == len(raw) and recs[3]["max_contact_force"] == raw[3]["max_contact_force"]


def test_segmentation_is_scored_against_the_demonstrators_phase_switches():
    """Changepoint precision/recall/F1 within the window against the scripted phase switches."""
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
    stats = JobStats()
    with make_executor(1) as ex:
        out = run_jobs([hybrid, ours, ours_again, hybrid], tmp_path, ex, desc="test", stats=stats)
        assert (stats.n_jobs, stats.n_cached) == (3, 0)  # the repeated job ran once
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
        # the policy's default window at the press dataset's 20 fps (0.3 s: 6 frames)
        window = DEFAULT_TIMING.config(20.0).window
        assert (
            fit["demo"] == 0
            and fit["changepoints"][0] == 0
            and fit["segmentation_window_frames"] == window == 6
        )
        again = run_jobs([ours], tmp_path, ex, desc="test", stats=stats)[0]
        assert (stats.n_jobs, stats.n_cached) == (4, 1)
        assert again["cached"] and again["records"] == out[1]["records"]
