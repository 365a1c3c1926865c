"""``forcemap fit --all-episodes``: a library of one checkpoint per episode, with its index."""

from __future__ import annotations

import json
import sys

import pytest

from lerobot_forcemap.cli import cli, main
from lerobot_forcemap.cli.fit_dataset import EpisodeJob, fit_episode


def test_all_episodes_writes_one_checkpoint_per_episode(press_dataset, press_checkpoint, tmp_path, capsys):
    out = tmp_path / "skills"
    assert main(["fit", "--dataset", str(press_dataset), "--all-episodes", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    index = json.loads((out / "index.json").read_text())
    n = index["total_episodes"]
    assert index["counts"] == {"ok": n, "refused": 0, "failed": 0} and f"{n} of {n} episode(s)" in printed
    rows = index["episodes"]
    assert [r["episode"] for r in rows] == list(range(n))
    assert all(r["status"] == "ok" and r["reason"] is None and r["events"] for r in rows)
    # changepoints: the segment boundaries, first frame and end included
    assert all(len(r["segments"]) == r["n_segments"] == len(r["changepoints"]) - 1 for r in rows)
    assert "episode 0: ok" in printed
    # episode 0's skill is what `forcemap fit --episodes 0` fits
    import torch

    from lerobot_policy_forcemap.modeling_forcemap import SKILL_TENSORS, ForceMapPolicy

    a = ForceMapPolicy.from_pretrained(out / rows[0]["folder"])
    b = ForceMapPolicy.from_pretrained(press_checkpoint)
    for name in SKILL_TENSORS:
        assert torch.equal(getattr(a, name), getattr(b, name)), name
    assert not list(tmp_path.glob(".*partial"))  # the work folder is gone

    with pytest.raises(ValueError, match="exists; give --overwrite"):
        main(["fit", "--dataset", str(press_dataset), "--all-episodes", "--out", str(out)])
    other = tmp_path / "other"
    other.mkdir()
    (other / "notes.txt").write_text("mine")
    with pytest.raises(ValueError, match=r"not a skill library \(no index.json\)"):
        main(["fit", "--dataset", str(press_dataset), "--all-episodes", "--out", str(other), "--overwrite"])
    assert (other / "notes.txt").read_text() == "mine"


def test_a_refused_episode_is_a_row_with_its_reason(press_dataset, tmp_path):
    row = fit_episode(EpisodeJob(str(press_dataset), "local/press", 999, (), str(tmp_path / "e999")))
    assert row["status"] == "refused" and row["folder"] is None
    assert "999" in row["reason"] and not (tmp_path / "e999").exists()


def test_episodes_and_all_episodes_exclude_each_other(press_dataset, tmp_path, capsys):
    with pytest.raises(SystemExit):
        main(["fit", "--dataset", str(press_dataset), "--all-episodes", "--episodes", "0", "--out", "x"])
    assert "not allowed with argument" in capsys.readouterr().err


def test_ray_flag_without_ray_is_one_error_line(press_dataset, tmp_path, monkeypatch, capsys):
    monkeypatch.setitem(sys.modules, "ray", None)  # import ray raises ImportError
    out = tmp_path / "skills"
    args = ["fit", "--dataset", str(press_dataset), "--all-episodes", "--ray", "--out", str(out)]
    assert cli(args) == 2
    assert 'pip install "lerobot_forcemap[ray]"' in capsys.readouterr().err.splitlines()[0]
    assert not out.exists()
