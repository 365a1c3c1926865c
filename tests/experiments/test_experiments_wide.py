"""``python -m experiments.wide`` end to end at the smallest size, on one task."""

from __future__ import annotations

import json

import pytest

from experiments import wide


def test_quick_run_of_one_task_writes_its_tables(tmp_path):
    out = tmp_path / "wide"
    assert wide.main(["--quick", "--out", str(out), "--tasks", "press", "--workers", "1"]) == 0
    doc = json.loads((out / "wide.json").read_text())
    assert {r["task"] for r in doc["records"]} == {"press"}
    assert {r["experiment"] for r in doc["records"]} == {"wide", "stiffness"}
    assert list(doc["learned"]) == ["press"]
    report = (out / "wide.md").read_text()
    assert "## press" in report and "## erase" not in report


def test_workers_below_one_is_a_usage_error(capsys):
    with pytest.raises(SystemExit):
        wide.main(["--quick", "--out", "unused", "--workers", "0"])
    assert "--workers" in capsys.readouterr().err


def test_set_runs_the_defaults_rows_with_the_settings(tmp_path):
    extra = ("approach_speed=0.01",)
    cells = wide.force_task_cells("press", 2, 1, (0,), extra) + wide.stiffness_cells(1, extra)
    defaults = [c for c in cells if c.method == "defaults"]
    assert defaults and all(j.overrides == extra for c in defaults for j in c.jobs)
    assert all("--set approach_speed=0.01" in c.label for c in defaults if c.experiment == "wide")
    no_feedback = next(c for c in cells if c.method == "defaults_no_feedback")
    assert all(j.overrides == (*extra, "force_feedback=false") for j in no_feedback.jobs)
    assert all(j.overrides == () for c in wide.force_task_cells("press", 2, 1, (0,)) if c.method == "defaults"
               for j in c.jobs)  # fmt: skip


@pytest.mark.parametrize(
    ("argv", "message"),
    [
        (["--set", "approach_speed=0.01"], "--set runs the defaults rows with other settings: give --out"),
        (
            ["--set", "approach_sped=0.01", "--out", "unused"],
            "--set approach_sped: not a ForceMapConfig field",
        ),
    ],
)
def test_set_needs_out_and_known_fields(argv, message, capsys):
    with pytest.raises(SystemExit):
        wide.main(argv)
    assert message in capsys.readouterr().err


def test_a_quick_run_with_set_names_the_settings_on_its_page(tmp_path):
    out = tmp_path / "wide"
    argv = ["--quick", "--out", str(out), "--tasks", "press", "--workers", "1"]
    argv += ["--set", "approach_speed=0.01"]
    assert wide.main(argv) == 0
    report = (out / "wide.md").read_text()
    assert "## Targets (package defaults + --set approach_speed=0.01)" in report
    assert "| press | defaults + --set approach_speed=0.01 |" in report  # the stiffness table's law
    assert "| press | k3000 |" in report
    assert json.loads((out / "wide.json").read_text())["set"] == ["approach_speed=0.01"]
