"""``forcemap twin`` on a press recorded in the simulator."""

from __future__ import annotations

import json
from pathlib import Path

import mujoco
import pytest

from lerobot_forcemap.cli import main

PRESS = Path(__file__).resolve().parents[2] / "datasets" / "press"


def test_twin_writes_scene_and_report(tmp_path, capsys):
    out = tmp_path / "twin"
    assert main(["twin", "--dataset", str(PRESS), "--episode", "1", "--out", str(out), "--no-hand"]) == 0
    assert sorted(p.name for p in out.iterdir()) == ["calibration.json", "scene.xml", "twin.json"]
    report = json.loads((out / "calibration.json").read_text())
    scene = json.loads((out / "twin.json").read_text())
    model = mujoco.MjModel.from_xml_path(str(out / "scene.xml"))
    assert model.jnt_stiffness[model.joint("twin_slide").id] == pytest.approx(scene["stiffness"], rel=1e-5)
    assert report["episode"] == "press[1]" and report["kind"] == "press"
    assert "press[1]: press" in capsys.readouterr().out


def test_twin_refuses_a_full_out_folder(tmp_path):
    (tmp_path / "keep.txt").write_text("x")
    with pytest.raises(ValueError, match="--out: must be a new or empty folder"):
        main(["twin", "--dataset", str(PRESS), "--out", str(tmp_path)])
    assert (tmp_path / "keep.txt").exists()
