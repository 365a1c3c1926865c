"""Real ``lerobot-train --steps=1`` and ``lerobot-eval`` subprocess runs (slow: LeRobot imports take seconds)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

BIN = Path(sys.executable).parent
ENV = {
    **os.environ,
    "HF_HUB_OFFLINE": "1",
    "HF_DATASETS_OFFLINE": "1",
    "MUJOCO_GL": "egl",
    "OPENBLAS_NUM_THREADS": "1",
}


def _run(args, cwd):
    out = subprocess.run(args, capture_output=True, text=True, timeout=600, env=ENV, cwd=cwd)
    assert out.returncode == 0, f"{args[0]} failed:\n{out.stdout[-3000:]}\n{out.stderr[-5000:]}"
    return out


@pytest.fixture(scope="module")
def trained(press_dataset, tmp_path_factory):
    out = tmp_path_factory.mktemp("train") / "run"
    _run(
        [
            str(BIN / "lerobot-train"),
            "--policy.type=forcemap",
            "--policy.device=cpu",
            "--dataset.repo_id=local/press",
            f"--dataset.root={press_dataset}",
            "--steps=1",
            "--save_freq=1",
            "--batch_size=4",
            "--num_workers=0",
            "--log_freq=1",
            f"--output_dir={out}",
        ],
        cwd=out.parent,
    )
    return out / "checkpoints" / "last" / "pretrained_model"


def test_lerobot_train_fits_and_saves_the_same_maps(trained, press_checkpoint):
    import torch

    from lerobot_policy_forcemap.modeling_forcemap import SKILL_TENSORS, ForceMapPolicy

    assert {"config.json", "model.safetensors", "policy_preprocessor.json", "train_config.json"} <= {
        p.name for p in trained.iterdir()
    }
    a = ForceMapPolicy.from_pretrained(trained)
    b = ForceMapPolicy.from_pretrained(press_checkpoint)  # the in-process fit
    for name in SKILL_TENSORS:
        assert torch.equal(getattr(a, name), getattr(b, name)), name
    assert a.config.segment_anchors == b.config.segment_anchors


def test_lerobot_eval_runs_the_checkpoint(trained, tmp_path):
    out = tmp_path / "eval"
    _run(
        [
            str(BIN / "lerobot-eval"),
            f"--policy.path={trained}",
            "--env.type=forcemap_press",
            "--eval.n_episodes=2",
            "--eval.batch_size=2",
            "--policy.device=cpu",
            f"--output_dir={out}",
        ],
        cwd=tmp_path,
    )
    info = json.loads((out / "eval_info.json").read_text())
    assert info["overall"]["n_episodes"] == 2
    assert info["overall"]["pc_success"] == 100.0
    assert all(Path(p).is_file() for p in info["overall"]["video_paths"])
