"""LeRobot habits the policy honours under ``lerobot-train``: ``--dataset.episodes`` chooses the
demonstrations (or is refused with the reason), and ``--steps`` above 1 ends after the fit."""

from __future__ import annotations

import json

import pytest

from tests.policy.test_lerobot_cli import BIN, ENV


@pytest.fixture(scope="module")
def hooks():
    """lerobot_policy_forcemap.train_hooks, imported when a test needs it (it imports LeRobot)."""
    from lerobot_policy_forcemap import train_hooks

    return train_hooks


def test_dataset_episodes_choose_the_demonstrations(hooks):
    episodes_to_fit = hooks.episodes_to_fit
    assert episodes_to_fit([0], None) == [0]
    assert episodes_to_fit([0], [3]) == [3]  # the policy's default follows --dataset.episodes
    assert episodes_to_fit([0], [4, 2]) == [4, 2]
    assert episodes_to_fit([2], [4, 2]) == [2]  # asked for one of those loaded
    with pytest.raises(
        ValueError, match=r"ForceMapConfig.episodes: must be among --dataset.episodes=\[3\].*\[1\]"
    ):
        episodes_to_fit([1], [3])


def test_steps_end_after_the_fit(hooks, caplog):
    class Run:
        steps = 100_000

    run = Run()
    hooks.end_after_fit(run)
    assert run.steps == 1 and "ends after step 1" in caplog.text
    assert hooks.running_train_config() is None  # outside lerobot-train nothing is found


@pytest.mark.slow
def test_lerobot_train_honours_dataset_episodes_and_steps(press_dataset, tmp_path):
    import subprocess

    def train(*flags):
        args = [
            str(BIN / "lerobot-train"), "--policy.type=forcemap", "--policy.device=cpu",
            "--dataset.repo_id=local/press", f"--dataset.root={press_dataset}", "--batch_size=4",
            "--num_workers=0", f"--output_dir={tmp_path / 'run'}", *flags,
        ]  # fmt: skip
        return subprocess.run(args, capture_output=True, text=True, timeout=600, env=ENV, cwd=tmp_path)

    refused = train("--dataset.episodes=[3]", "--policy.episodes=[1]")
    assert refused.returncode != 0
    assert "ForceMapConfig.episodes: must be among --dataset.episodes=[3]" in refused.stdout + refused.stderr
    done = train("--dataset.episodes=[3]", "--steps=500")
    assert done.returncode == 0, done.stderr[-3000:]
    assert "lerobot-train ends after step 1" in done.stdout + done.stderr
    checkpoints = sorted(p.name for p in (tmp_path / "run" / "checkpoints").iterdir())
    assert checkpoints == ["000001", "last"]
    saved = tmp_path / "run" / "checkpoints" / "last" / "pretrained_model"
    assert json.loads((saved / "config.json").read_text())["episodes"] == [3]
    assert json.loads((saved / "train_config.json").read_text())["steps"] == 1
