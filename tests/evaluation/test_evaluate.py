"""``forcemap eval``: per-episode records, the demonstrations' figures, summaries and % change."""

from __future__ import annotations

import json

import numpy as np
import pytest

from lerobot_forcemap.cli import main
from lerobot_forcemap.evaluation.demonstrations import demonstration_records
from lerobot_forcemap.evaluation.stats import percent_change, summarize
from tests.conftest import REPO_ROOT


def test_cli_eval_writes_records_and_demonstrations(press_checkpoint, press_dataset, tmp_path, capsys):
    out = tmp_path / "eval.json"
    args = [
        "eval",
        "--policy",
        str(press_checkpoint),
        "--task",
        "press",
        "--episodes",
        "2",
        "--seed",
        "7",
        "--json",
        str(out),
        "--dataset",
        str(press_dataset),
        "--trace",
        "--video-dir",
        str(tmp_path / "v"),
    ]
    assert main(args) == 0
    assert "success" in capsys.readouterr().out
    doc = json.loads(out.read_text())
    assert [r["seed"] for r in doc["episodes"]] == [7, 8]
    assert doc["summary"]["clipped_steps"] == sum(r["metrics"]["n_clipped_steps"] for r in doc["episodes"])
    rec = doc["episodes"][0]
    for key in (
        "success",
        "protective_stop",
        "max_contact_force",
        "mean_contact_force",
        "max_contact_force_xyz",
        "mean_contact_force_xyz",
        "steps",
        "trace",
    ):
        assert key in rec
    assert len(rec["max_contact_force_xyz"]) == 3
    rows = np.asarray(rec["trace"]["rows"])
    assert rows.shape == (rec["steps"], len(rec["trace"]["columns"]))
    # the record's max force is the env's (physics-rate) statistic: at least the per-step samples
    assert rec["max_contact_force"] >= np.linalg.norm(rows[:, 1:4], axis=1).max() - 1e-9
    assert (tmp_path / "v" / "eval_episode_0.mp4").stat().st_size > 1000
    demos = doc["demonstrations"]
    assert demos["fitted_episodes"] == [0] and demos["summary_fitted"]["n"] == 1
    d0 = demos["episodes"][0]["max_contact_force"]
    r = doc["summary"]["max_contact_force"]["mean"]
    assert doc["comparison"]["max_contact_force_change_pct"] == pytest.approx(100 * (r - d0) / d0)


def test_demonstration_records_fall_back_to_the_dataset_columns(press_dataset, tmp_path):
    import shutil

    copy = tmp_path / "press"
    shutil.copytree(press_dataset, copy)
    meta, source_meta = demonstration_records(copy)
    (copy / "meta" / "forcemap_episodes.json").unlink()
    cols, source = demonstration_records(copy)
    assert "forcemap_episodes.json" in source_meta and "contact_force" in source
    assert len(cols) == len(meta)
    for a, b in zip(meta, cols, strict=True):
        # frame-rate samples of the same low-passed force: the max is at most the physics-rate max
        assert b["max_contact_force"] <= a["max_contact_force"] + 1e-6
        assert b["max_contact_force"] > 0.7 * a["max_contact_force"]


def test_summaries_and_change():
    recs = [
        {
            "success": True,
            "protective_stop": False,
            "max_contact_force": 10.0,
            "mean_contact_force": 2.0,
            "max_contact_force_xyz": [1.0, 1.0, 10.0],
            "mean_contact_force_xyz": [0.1, 0.1, 2.0],
        },
        {
            "success": False,
            "protective_stop": True,
            "max_contact_force": 30.0,
            "mean_contact_force": 4.0,
            "max_contact_force_xyz": [3.0, 1.0, 30.0],
            "mean_contact_force_xyz": [0.3, 0.1, 4.0],
        },
    ]
    s = summarize(recs)
    assert s["n"] == 2 and s["success_rate"] == 0.5 and s["protective_stops"] == 1
    # the sample std (ddof 1), as results/experiments.md and the README give it
    assert s["max_contact_force"]["mean"] == 20.0 and s["max_contact_force"]["std"] == pytest.approx(
        10.0 * 2**0.5
    )
    assert summarize(recs[:1])["max_contact_force"]["std"] == 0.0
    assert s["max_contact_force_xyz"]["mean"] == [2.0, 1.0, 20.0]
    c = percent_change(summarize(recs[:1]), s)
    assert c["max_contact_force_change_pct"] == pytest.approx(-50.0)
    assert c["mean_contact_force_xyz_change_pct"] == pytest.approx([-50.0, 0.0, -33.333333])


def test_rollout_keeps_per_finger_force_metrics():
    """Short vector metrics (the Gen3's per-finger max/mean forces) reach the record."""
    import gymnasium as gym
    import torch

    import lerobot_forcemap.envs  # noqa: F401
    from lerobot_forcemap import layout
    from lerobot_forcemap.evaluation.evaluate import rollout

    class HoldPose:
        """Holds the TCP where it starts and closes the gripper."""

        def reset(self):
            pass

        def select_action(self, batch):
            pose = batch[layout.OBS_EE_POSE].reshape(-1)[: layout.EE_POSE_DIM]
            return torch.cat([pose, torch.ones(1, dtype=pose.dtype)])[None]

    env = gym.make("lerobot_forcemap/GraspPush-v0", max_episode_steps=10)
    try:
        rec = rollout(env, HoldPose(), lambda b: b, lambda a: a, seed=0)
    finally:
        env.close()
    assert rec["steps"] == 10
    assert len(rec["metrics"]["max_finger_force"]) == 3
    assert len(rec["metrics"]["mean_finger_force"]) == 3
    assert all(np.isfinite(rec["metrics"]["max_finger_force"]))


def test_a_checkpoint_config_that_does_not_read_is_named(press_checkpoint, tmp_path):
    """Broken JSON, or a config whose fitted sizes disagree: one ValueError naming the file and the field."""
    import shutil

    from lerobot_forcemap.evaluation.evaluate import load_policy

    ckpt = tmp_path / "ckpt"
    shutil.copytree(press_checkpoint, ckpt)
    data = json.loads((ckpt / "config.json").read_text())
    (ckpt / "config.json").write_text(json.dumps({**data, "n_segments": data["n_segments"] + 1}))
    with pytest.raises(
        ValueError, match=r"config.json: cannot read the policy config: .*ForceMapConfig.segment_n_nodes"
    ):
        load_policy(ckpt)
    (ckpt / "config.json").write_text("{bad json")
    with pytest.raises(
        ValueError, match=r"config.json: cannot read the policy config: Expecting property name"
    ):
        load_policy(ckpt)
    if not __import__("torch").cuda.is_available():
        with pytest.raises(ValueError, match="--device cuda: no CUDA device"):
            load_policy(press_checkpoint, device="cuda")


def test_cli_eval_on_an_unseen_object(tmp_path, capsys):
    """``--object apple``: the grasping task with an unseen object, recorded in the document; refused by
    name (before any loading) on a task without objects."""
    dataset = REPO_ROOT / "datasets" / "grasp_push"
    if not (dataset / "meta" / "info.json").is_file():
        pytest.skip("datasets/grasp_push not shipped")
    ckpt = tmp_path / "grasp"
    settings = ["anchor_radius=0.15", "static_tolerance=0.02", "anchor_by_moved_object=true"]
    assert (
        main(
            [
                "fit",
                "--dataset",
                str(dataset),
                "--out",
                str(ckpt),
                *[a for s in settings for a in ("--set", s)],
            ]
        )
        == 0
    )
    out = tmp_path / "apple.json"
    args = ["eval", "--policy", str(ckpt), "--task", "grasp_push", "--object", "apple", "--episodes", "1"]
    assert main([*args, "--seed", "1000", "--json", str(out)]) == 0
    doc = json.loads(out.read_text())
    assert doc["object"] == "apple" and doc["episodes"][0]["success"]
    assert "grasp_push (apple): success 100% of 1" in capsys.readouterr().out
    assert {d["object"] for d in doc["demonstrations"]["episodes"]} == {"book"}  # what it is compared with
    with pytest.raises(ValueError, match="--object: must be None: task 'press' has no objects"):
        main(
            [
                "eval",
                "--policy",
                str(tmp_path / "missing"),
                "--task",
                "press",
                "--object",
                "apple",
                "--json",
                str(out),
            ]
        )


def test_a_relative_fitted_dataset_is_found_from_elsewhere_or_named(tmp_path, monkeypatch, capsys):
    from lerobot_forcemap.evaluation.evaluate import default_dataset

    repo = tmp_path / "repo"
    (repo / "datasets" / "press" / "meta").mkdir(parents=True)
    (repo / "datasets" / "press" / "meta" / "info.json").write_text("{}")
    ckpt = repo / "outputs" / "train" / "checkpoints" / "last" / "pretrained_model"
    ckpt.mkdir(parents=True)
    # lerobot-train stores dataset.root as typed: relative to where training ran (the repo)
    (ckpt / "train_config.json").write_text(json.dumps({"dataset": {"root": "datasets/press"}}))
    monkeypatch.chdir(tmp_path)  # not the repo: the path is found from the checkpoint's parents
    assert default_dataset(ckpt) == repo / "datasets" / "press"
    (ckpt / "train_config.json").write_text(json.dumps({"dataset": {"root": "datasets/gone"}}))
    capsys.readouterr()
    assert default_dataset(ckpt) is None
    assert (
        "note: the fitted dataset 'datasets/gone' (train_config.json) was not found"
        in capsys.readouterr().err
    )


def test_eval_clocks_a_skill_of_another_rate_at_the_envs_rate(press_checkpoint, capsys):
    from lerobot_forcemap.evaluation.evaluate import _match_control_rate, load_policy

    policy, _, _ = load_policy(press_checkpoint)
    _match_control_rate(policy, "press")  # fitted in the 20 Hz sim: nothing to do
    assert policy.config.control_fps is None and capsys.readouterr().err == ""
    policy.config.fps = 50.0  # as a real 50 fps demonstration's checkpoint
    _match_control_rate(policy, "press")
    assert policy.config.control_fps == 20.0 and policy.clock_hz == 20.0
    assert "fitted at 50 fps and press steps at 20 Hz: control_fps=20" in capsys.readouterr().err


def test_a_bad_dataset_or_seed_is_refused_before_any_rollout(press_checkpoint, tmp_path, monkeypatch):
    """A typo in --dataset used to surface after every episode had run, with no JSON written."""
    import lerobot_forcemap.evaluation.evaluate as evaluate

    def no_rollouts(*args, **kwargs):
        raise AssertionError("the policy was loaded and rolled out before the arguments were checked")

    monkeypatch.setattr(evaluate, "load_policy", no_rollouts)
    base = ["eval", "--policy", str(press_checkpoint), "--task", "press", "--json", str(tmp_path / "e.json")]
    with pytest.raises(ValueError, match=r"--dataset .*nope: not a LeRobot dataset \(no meta/info.json\)"):
        main([*base, "--dataset", str(tmp_path / "nope")])
    with pytest.raises(ValueError, match="--seed: must be an integer >= 0, got -1"):
        main([*base, "--seed", "-1"])
    # --videos without --video-dir filmed nothing and said nothing
    with pytest.raises(ValueError, match=r"--videos 2: give --video-dir too"):
        main([*base, "--videos", "2"])
    # more videos than episodes filmed fewer than asked, silently
    with pytest.raises(ValueError, match=r"--videos 4: more than --episodes 3"):
        main([*base, "--episodes", "3", "--videos", "4", "--video-dir", str(tmp_path / "v")])


def test_a_wrong_comparison_or_output_path_is_refused_before_any_rollout(
    press_checkpoint, tmp_path, monkeypatch
):
    """Demonstrations of another task, NaN demonstration figures, a --json under a file: said first,
    not after every episode has run (or, for the first two, printed as "+1%" and "+nan%")."""
    import shutil

    import lerobot_forcemap.evaluation.evaluate as evaluate

    def no_rollouts(*args, **kwargs):
        raise AssertionError("the policy was rolled out before the arguments were checked")

    monkeypatch.setattr(evaluate, "evaluate_policy", no_rollouts)
    base = ["eval", "--policy", str(press_checkpoint), "--task", "press", "--json", str(tmp_path / "e.json")]
    with pytest.raises(
        ValueError,
        match=r"--dataset .*erase: demonstrations of task 'erase' .*not of the evaluated task 'press'",
    ):
        main([*base, "--dataset", str(REPO_ROOT / "datasets" / "erase")])
    nan = tmp_path / "press"
    shutil.copytree(REPO_ROOT / "datasets" / "press", nan)
    meta = nan / "meta" / "forcemap_episodes.json"
    doc = json.loads(meta.read_text())
    doc["episodes"][2]["max_contact_force"] = float("nan")
    meta.write_text(json.dumps(doc))
    with pytest.raises(
        ValueError,
        match=r"forcemap_episodes.json: episodes\[2\].max_contact_force: must be a finite number, got nan",
    ):
        main([*base, "--dataset", str(nan)])
    meta.write_text("{not json")
    with pytest.raises(ValueError, match=r"forcemap_episodes.json: not valid JSON"):
        main([*base, "--dataset", str(nan)])
    (tmp_path / "afile").write_text("x")
    for flag in ("--json", "--video-dir"):
        args = [*base, "--dataset", str(REPO_ROOT / "datasets" / "press")]
        target = str(tmp_path / "afile" / ("x.json" if flag == "--json" else "videos"))
        args = [a if a != str(tmp_path / "e.json") or flag != "--json" else target for a in args]
        if flag == "--video-dir":
            args += ["--video-dir", target]
        with pytest.raises(ValueError, match=rf"{flag} {target}: .*afile is a file, not a folder"):
            main(args)


def test_a_device_that_is_not_one_is_named(press_checkpoint):
    from lerobot_forcemap.evaluation.evaluate import load_policy

    with pytest.raises(ValueError, match=r"--device foo: not a torch device"):
        load_policy(press_checkpoint, "foo")
