"""``forcemap fit``: dataset -> checkpoint that LeRobot loads; the same maps as the in-process lerobot-train path."""

from __future__ import annotations

import json

import pytest

from lerobot_forcemap.cli import main
from lerobot_forcemap.cli.fit import make_config


def test_cli_fit_writes_a_loadable_checkpoint(press_dataset, press_checkpoint, tmp_path, capsys):
    import torch

    from lerobot_policy_forcemap.modeling_forcemap import SKILL_TENSORS, ForceMapPolicy

    out = tmp_path / "policy"
    assert main(["fit", "--dataset", str(press_dataset), "--out", str(out)]) == 0
    assert "checkpoint:" in capsys.readouterr().out
    files = {p.name for p in out.iterdir()}
    assert {
        "config.json",
        "model.safetensors",
        "policy_preprocessor.json",
        "policy_postprocessor.json",
        "fit_report.json",
    } <= files
    a, b = ForceMapPolicy.from_pretrained(out), ForceMapPolicy.from_pretrained(press_checkpoint)
    for name in SKILL_TENSORS:
        assert torch.equal(getattr(a, name), getattr(b, name)), name
    report = json.loads((out / "fit_report.json").read_text())
    assert report["episodes"] == [0] and len(report["segments"]) == a.config.n_segments
    fps = report["fps"]
    assert report["changepoints_s"][0] == pytest.approx([c / fps for c in report["changepoints"][0]])
    assert report["boundary_gaps_m"] == pytest.approx([0.0] * (a.config.n_segments - 1), abs=1e-9)
    assert {"contact_intervals_s", "guiding_force_share", "contacts"} <= set(report)
    assert report["dataset_repo_id"] == f"local/{press_dataset.name}"  # no --repo-id: not a Hub dataset
    with pytest.raises(ValueError, match="exists and is not empty"):
        main(["fit", "--dataset", str(press_dataset), "--out", str(out)])

    # forcemap eval compares with the fitted dataset without being told (README: fit, eval, report)
    capsys.readouterr()
    doc_path = tmp_path / "eval.json"
    assert (
        main(["eval", "--policy", str(out), "--task", "press", "--episodes", "1", "--json", str(doc_path)])
        == 0
    )
    assert "vs " in capsys.readouterr().out
    doc = json.loads(doc_path.read_text())
    assert "comparison" in doc and doc["demonstrations"]["fitted_episodes"] == [0]


def test_cli_fit_settings_and_episodes(press_dataset, tmp_path):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    out = tmp_path / "multi"
    args = [
        "fit",
        "--dataset",
        str(press_dataset),
        "--out",
        str(out),
        "--episodes",
        "0",
        "1",
        "2",
        "--set",  # several settings after one --set, and --set repeated
        "segments=dataset",
        "segment_column=demo_phase",
        "--set",
        "stiffness=2500",
        "--repo-id",
        "lab/press-demos",
    ]
    assert main(args) == 0
    assert json.loads((out / "fit_report.json").read_text())["dataset_repo_id"] == "lab/press-demos"
    cfg = ForceMapPolicy.from_pretrained(out).config
    assert cfg.episodes == [0, 1, 2] and cfg.stiffness == 2500.0 and cfg.segments == "dataset"


def test_bad_settings_are_named():
    with pytest.raises(ValueError, match="--set stifness: not a ForceMapConfig field"):
        make_config(overrides=["stifness=1"])
    with pytest.raises(ValueError, match="expected FIELD=VALUE"):
        make_config(overrides=["stiffness"])


def test_not_a_dataset(tmp_path):
    with pytest.raises(ValueError, match="not a LeRobot dataset"):
        main(["fit", "--dataset", str(tmp_path), "--out", str(tmp_path / "o")])


def test_episodes_given_twice_are_refused():
    # `--set episodes=[3] --episodes 5` used to fit episode 5 without a word
    with pytest.raises(ValueError, match=r"--set 'episodes=\[3\]' and --episodes both choose the episodes"):
        make_config([5], ["episodes=[3]"])
    assert make_config(None, ["episodes=[3]"]).episodes == [3]
