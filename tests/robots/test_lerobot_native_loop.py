"""The LeRobot-native loop on the simulated robot: ``lerobot-record`` with the scripted teleoperator,
``lerobot-train --policy.type=forcemap --steps=1``, then ``lerobot-rollout --policy.path=...``.

LeRobot 0.6.1's ``lerobot-record`` only records (it has no ``--policy``); its deployment tool is
``lerobot-rollout``. Real subprocesses, a real MuJoCo scene paced in real time (slow)."""

from __future__ import annotations

import json
import subprocess

import pytest

from tests.policy.test_lerobot_cli import BIN, ENV

pytestmark = pytest.mark.slow

TASK = "Press the red button until it clicks, then let go."
EPISODE_S = "6"


def _run(args, cwd):
    out = subprocess.run(args, capture_output=True, text=True, timeout=600, env=ENV, cwd=cwd)
    assert out.returncode == 0, f"{args[0]} failed:\n{out.stdout[-3000:]}\n{out.stderr[-5000:]}"
    return out


def _results(path):
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_record_train_deploy_through_lerobot(tmp_path):
    dataset, recorded = tmp_path / "press_sim", tmp_path / "recorded.jsonl"
    _run(
        [
            str(BIN / "lerobot-record"), "--robot.type=forcemap_ur5e_sim", f"--robot.episode_time_s={EPISODE_S}",
            f"--robot.results_path={recorded}", "--teleop.type=forcemap_scripted",
            "--dataset.repo_id=local/press_sim", f"--dataset.root={dataset}", f"--dataset.single_task={TASK}",
            "--dataset.num_episodes=2", f"--dataset.episode_time_s={EPISODE_S}", "--dataset.reset_time_s=0",
            "--dataset.fps=20", "--dataset.push_to_hub=false", "--dataset.video=false", "--play_sounds=false",
        ],
        tmp_path,
    )  # fmt: skip
    assert [r["is_success"] for r in _results(recorded)] == [True, True]
    info = json.loads((dataset / "meta" / "info.json").read_text())
    assert info["total_episodes"] == 2
    state_names = info["features"]["observation.state"]["names"]
    assert [n for n in state_names if n.startswith("force.")] == [
        f"force.{a}.pos" for a in ("fx", "fy", "fz", "tx", "ty", "tz")
    ]

    _run(
        [
            str(BIN / "lerobot-train"), "--policy.type=forcemap", "--policy.device=cpu",
            "--dataset.repo_id=local/press_sim", f"--dataset.root={dataset}", "--steps=1", "--batch_size=4",
            "--num_workers=0", f"--output_dir={tmp_path / 'train'}",
        ],
        tmp_path,
    )  # fmt: skip
    checkpoint = tmp_path / "train" / "checkpoints" / "last" / "pretrained_model"
    config = json.loads((checkpoint / "config.json").read_text())
    assert config["n_segments"] >= 2 and "button" in config["segment_anchors"]
    assert set(config["packed_features"]) >= {
        "observation.ee_pose",
        "observation.force",
        "observation.environment_state",
    }

    deployed = tmp_path / "deployed.jsonl"
    _run(
        [
            str(BIN / "lerobot-rollout"), "--strategy.type=base", f"--policy.path={checkpoint}",
            "--robot.type=forcemap_ur5e_sim", "--robot.seed=7", "--robot.episode_time_s=60",
            f"--robot.results_path={deployed}", f"--task={TASK}", "--duration=10", "--fps=20",
            "--device=cpu", "--play_sounds=false", "--return_to_initial_position=false",
        ],
        tmp_path,
    )  # fmt: skip
    (result,) = _results(deployed)
    assert result["is_success"], result
    assert result["max_contact_force"] > 0
