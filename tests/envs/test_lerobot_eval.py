"""End to end: lerobot-train (a tiny ACT, 2 steps) on a recorded dataset, then lerobot-eval on the env.

Checks the env plugin contract with LeRobot's own scripts: ``--env.type=forcemap_press`` with no extra
flags, episodes run, videos are written (render_fps must be an int for PyAV). Not a policy test.
"""

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from lerobot_forcemap.envs.record import record_demonstrations

pytestmark = pytest.mark.slow

BIN = Path(sys.executable).parent


def run(cmd, cwd):
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.run(cmd, cwd=cwd, env=env, capture_output=True, text=True, timeout=600)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    return proc


def test_lerobot_train_and_eval_on_forcemap_press(tmp_path):
    ds = tmp_path / "press"
    record_demonstrations("press", 2, 0, ds, progress=False)
    out = tmp_path / "act"
    run(
        [
            str(BIN / "lerobot-train"),
            "--policy.type=act",
            "--dataset.repo_id=local/forcemap_press",
            f"--dataset.root={ds}",
            "--steps=2",
            "--batch_size=2",
            "--policy.device=cpu",
            "--policy.push_to_hub=false",
            "--policy.dim_model=32",
            "--policy.n_heads=2",
            "--policy.dim_feedforward=64",
            "--policy.n_encoder_layers=1",
            "--policy.n_decoder_layers=1",
            "--policy.chunk_size=10",
            "--policy.n_action_steps=10",
            "--policy.use_vae=false",
            f"--output_dir={out}",
            "--save_freq=2",
            "--wandb.enable=false",
            "--num_workers=0",
        ],  # fmt: skip
        tmp_path,
    )
    ckpt = out / "checkpoints" / "last" / "pretrained_model"
    evaluation = tmp_path / "eval"
    run(
        [
            str(BIN / "lerobot-eval"),
            f"--policy.path={ckpt}",
            "--env.type=forcemap_press",
            "--eval.n_episodes=1",
            "--eval.batch_size=1",
            "--policy.device=cpu",
            f"--output_dir={evaluation}",
        ],  # fmt: skip
        tmp_path,
    )
    info = json.loads((evaluation / "eval_info.json").read_text())
    assert info["overall"]["n_episodes"] == 1
    videos = list((evaluation / "videos").rglob("*.mp4"))
    assert videos and videos[0].stat().st_size > 10_000
