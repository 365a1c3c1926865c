"""``make demo`` end to end, with 2 evaluation episodes (slow: ~10 s)."""

from __future__ import annotations

import json

import pytest

from lerobot_forcemap.cli.demo import main

pytestmark = pytest.mark.slow


def test_demo_writes_table_plots_and_video(press_dataset, tmp_path, capsys):
    out = tmp_path / "demo"
    assert main(["--out", str(out), "--dataset", str(press_dataset), "--episodes", "2"]) == 0
    text = capsys.readouterr().out
    assert "| max contact force (N) |" in text and "demo wall time" in text
    for name in (
        "report.md",
        "force_profile.png",
        "path3d.png",
        "forces.png",
        "eval.json",
        "videos/eval_episode_0.mp4",
        "policy/model.safetensors",
    ):
        assert (out / name).is_file(), name
    doc = json.loads((out / "eval.json").read_text())
    assert doc["summary"]["n"] == 2 and doc["summary"]["success_rate"] == 1.0
    assert doc["comparison"]["max_contact_force_change_pct"] < 0
