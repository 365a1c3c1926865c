"""``python -m experiments.paper`` end to end at the smallest size: tuning, Table II, the report."""

from __future__ import annotations

import json

import pytest

from experiments.paper import run_all
from experiments.paper.common import Settings


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("experiments")
    s = Settings(
        eval_seeds=(1000,),
        tune_seeds=(2000,),
        demos=(0,),
        tune_demos=(0,),
        stiffness_grid={"press": (2000.0,), "erase": (1200.0,)},
        limit_grid={"press": (8.0,), "erase": (5.0,)},
        hybrid_thresholds=(5.0,),
        hybrid_normals=("fixed",),
        peg_stiffness_grid=(2000.0,),
        peg_f_contact_grid=(2.0,),
        quick=True,
        workdir=out / "work",
        results=out / "results",
        workers=1,
    )
    doc = run_all.run(s, ("tune", "table2"))
    return s, doc


def test_tiny_run_writes_json_markdown_and_figures(tiny_run):
    s, doc = tiny_run
    saved = json.loads((s.results / "experiments.json").read_text())
    assert saved["protocol"]["eval_seeds"] == [1000] and saved["code_fingerprint"] == doc["code_fingerprint"]
    rows = [r for r in saved["records"] if r["experiment"] == "table2"]
    methods = {(r["task"], r["method"]) for r in rows}
    for task in ("press", "erase"):
        for m in (
            "demonstration",
            "elmap",
            "ours_default",
            "ours_k3000",
            "ours",
            "ours_limit",
            "limit_alone",
        ):
            assert (task, m) in methods
        assert (task, "hybrid") in methods
    for r in rows:
        if r["method"] == "demonstration":
            assert r["n"] == 1 and r["max_contact_force"]["mean"] > 0
            continue
        assert r["n"] == 1 and r["seeds"] == [1000] and r["demos"] == [0]
        assert 0.0 <= r["success_rate"] <= 1.0 and len(r["max_contact_force_xyz"]["mean"]) == 3
        assert set(r["change_vs_demo"]["max_contact_force"]["per_demo"]) == {"0"}
    # forces off reproduces the demonstration's force; ours is below it
    press = {r["method"]: r for r in rows if r["task"] == "press"}
    assert abs(press["elmap"]["change_vs_demo"]["max_contact_force"]["mean"]) < 10.0
    assert press["ours"]["change_vs_demo"]["max_contact_force"]["mean"] < -40.0
    md = (s.results / "experiments.md").read_text()
    assert "Table II" in md and "-84.35%" in md and "## Where we miss, and why" in md and "## Runtime" in md
    assert (s.results / "experiments_profiles.png").stat().st_size > 10_000
    assert (s.results / "experiments_table2.png").stat().st_size > 10_000
    assert {t["method"] for t in saved["targets"]} >= {"ours", "ours_limit"}
    # the chosen settings as --config_path files, next to the quick results (only the tasks it ran)
    configs = sorted(
        str(p.relative_to(s.results / "configs")) for p in (s.results / "configs").glob("*/*.json")
    )
    assert configs == [
        f"{kind}/forcemap_{task}.json" for kind in ("eval", "train") for task in ("erase", "press")
    ]
    press_cfg = json.loads((s.results / "configs" / "train" / "forcemap_press.json").read_text())
    assert press_cfg["policy"]["stiffness"] == doc["tuning"]["press"]["weights"]["chosen"]["stiffness"]


def test_tuning_records_its_grid_and_choices(tiny_run):
    s, doc = tiny_run
    t = doc["tuning"]
    assert t["press"]["weights"]["chosen"] == {"stiffness": 2000.0}
    assert len(t["press"]["weights_limit"]["grid"]) == 2  # "no limit" and L = 8
    assert t["peg_in_hole"]["hybrid"]["chosen"] == {"force_threshold": 5.0, "normal": "fixed"}
    assert t["peg_in_hole"]["ours"]["chosen"]["force_limit"] == 5.0  # the hybrid's threshold
    assert (s.workdir / "tuning_quick.json").is_file()


def test_second_run_is_served_from_the_cache_and_drops_other_code_versions(tiny_run, capsys):
    from experiments.paper.jobs import code_fingerprint

    s, _ = tiny_run
    stale = [s.workdir / kind / "0123456789" for kind in ("raw", "checkpoints")]
    for d in stale:
        d.mkdir(parents=True)
        (d / "old.json").write_bytes(b"x" * 2_000_000)
    mine = s.workdir / "raw" / "notes"  # not a fingerprint: left alone
    mine.mkdir()
    doc = run_all.run(s, ("tune", "table2"))
    assert doc["runtime"]["cached_jobs"] == doc["runtime"]["jobs"] > 0
    assert not any(d.exists() for d in stale) and mine.is_dir()
    assert any((s.workdir / "raw" / code_fingerprint()).iterdir())
    out = " ".join(capsys.readouterr().out.split())
    assert f"removed the caches of 1 earlier code version(s) under {s.workdir} (4 MB)" in out
