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
