"""``python -m experiments.learned --smoke``: real lerobot-train runs (3 steps, tiny ACT and
Diffusion), 2 evaluation episodes, the result JSON schema, skipping, and ``lerobot-eval`` on the same
checkpoint through ``--env.env_state_extras``."""

from __future__ import annotations

import importlib.util
import json

import pytest

from experiments.learned import run as learned_run

pytestmark = pytest.mark.slow

KEYS = {
    "task", "method", "n", "seeds", "success_rate", "protective_stops", "max_contact_force",
    "mean_contact_force", "max_contact_force_xyz", "mean_contact_force_xyz", "train_steps",
    "train_wall_time_s", "eval_wall_time_s", "wall_time_s", "lerobot_eval", "config", "force_inputs",
    "episodes",
}  # fmt: skip


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    methods = ["act"] + (["diffusion"] if importlib.util.find_spec("diffusers") else [])
    root = tmp_path_factory.mktemp("learned_smoke")
    out, work = root / "out", root / "work"
    argv = ["--smoke", "--tasks", "press", "--methods", *methods, "--out", str(out), "--work", str(work)]
    assert learned_run.main(argv) == 0
    return out, work, methods


def test_smoke_writes_one_record_per_method(smoke_run):
    out, _, methods = smoke_run
    for method in methods:
        doc = json.loads((out / f"press__{method}.json").read_text())
        assert set(doc) == KEYS
        assert doc["task"] == "press" and doc["method"] == method
        assert doc["n"] == 2 and doc["seeds"] == [1000, 1001]
        assert [e["seed"] for e in doc["episodes"]] == [1000, 1001]
        assert doc["train_steps"] == 3 and doc["train_wall_time_s"] > 0 and doc["eval_wall_time_s"] > 0
        assert (
            len(doc["max_contact_force_xyz"]["mean"]) == 3 and len(doc["mean_contact_force_xyz"]["std"]) == 3
        )
        assert doc["success_rate"] == sum(e["success"] for e in doc["episodes"]) / 2
        env_state = doc["config"]["policy"]["input_features"]["observation.environment_state"]
        assert env_state["shape"] == [8 + 7 + 6]
        assert "force" in doc["force_inputs"]


def test_existing_results_are_skipped(smoke_run, capsys):
    out, work, methods = smoke_run
    before = {m: (out / f"press__{m}.json").stat().st_mtime_ns for m in methods}
    assert (
        learned_run.main(
            ["--smoke", "--tasks", "press", "--methods", *methods, "--out", str(out), "--work", str(work)]
        )
        == 0
    )
    assert "skip press/act" in capsys.readouterr().out
    assert {m: (out / f"press__{m}.json").stat().st_mtime_ns for m in methods} == before


def test_checkpoint_needs_the_env_state_extras(smoke_run):
    from lerobot_forcemap.evaluation.evaluate import evaluate_policy

    _, work, _ = smoke_run
    ckpt = work / "press__act" / "train" / "checkpoints" / "last" / "pretrained_model"
    with pytest.raises(ValueError, match="env-state-extras"):
        evaluate_policy(ckpt, "press", 1, 0, progress=False)


def test_lerobot_eval_runs_on_the_same_seeds(smoke_run):
    """The script runs lerobot-eval itself on the checkpoint, through --env.env_state_extras; for the
    deterministic ACT it agrees with the project's rollout episode by episode."""
    out, work, methods = smoke_run
    for method in methods:
        doc = json.loads((out / f"press__{method}.json").read_text())
        ran = doc["lerobot_eval"]
        assert ran["n"] == 2 and ran["seeds"] == [1000, 1001] and len(ran["successes"]) == 2
        assert "--env.env_state_extras=ee_pose,force" in ran["command"] and "--seed=1000" in ran["command"]
        assert doc["wall_time_s"] == pytest.approx(
            doc["train_wall_time_s"] + doc["eval_wall_time_s"] + ran["wall_time_s"]
        )
        info = json.loads((work / f"press__{method}" / "lerobot_eval" / "eval_info.json").read_text())
        assert info["overall"]["n_episodes"] == 2
    act = json.loads((out / "press__act.json").read_text())
    assert act["lerobot_eval"]["successes"] == [e["success"] for e in act["episodes"]]


@pytest.mark.skipif(not importlib.util.find_spec("diffusers"), reason="Diffusion needs diffusers")
def test_a_diffusion_episode_repeats_with_its_seed(smoke_run):
    """torch is seeded per episode: Diffusion's sampling noise no longer varies between runs."""
    from lerobot_forcemap.evaluation.evaluate import evaluate_policy

    _, work, _ = smoke_run
    ckpt = work / "press__diffusion" / "train" / "checkpoints" / "last" / "pretrained_model"
    runs = [
        evaluate_policy(ckpt, "press", 1, 1000, env_state_extras="ee_pose,force", progress=False)[0]
        for _ in range(2)
    ]
    assert runs[0]["max_contact_force"] == runs[1]["max_contact_force"]
    assert runs[0]["steps"] == runs[1]["steps"]


def test_forcemap_eval_cli_with_env_state_extras(smoke_run, tmp_path):
    from lerobot_forcemap.cli import main

    _, work, _ = smoke_run
    ckpt = work / "press__act" / "train" / "checkpoints" / "last" / "pretrained_model"
    out = tmp_path / "eval.json"
    args = ["eval", "--policy", str(ckpt), "--task", "press", "--episodes", "1", "--seed", "1000"]
    assert main([*args, "--json", str(out), "--env-state-extras", "ee_pose,force"]) == 0
    doc = json.loads(out.read_text())
    assert [r["seed"] for r in doc["episodes"]] == [1000]
    # the same checkpoint and seed through the script's evaluation gave the same episode
    smoke = json.loads((smoke_run[0] / "press__act.json").read_text())["episodes"][0]
    assert doc["episodes"][0]["max_contact_force"] == smoke["max_contact_force"]
    assert doc["episodes"][0]["steps"] == smoke["steps"]


def test_reevaluate_repeats_the_evaluations_without_training(smoke_run, tmp_path, capsys):
    out, work, _ = smoke_run
    old = json.loads((out / "press__act.json").read_text())
    (tmp_path / "press__act.json").write_text(json.dumps(old))
    argv = [
        "--reevaluate",
        "--tasks",
        "press",
        "--methods",
        "act",
        "--out",
        str(tmp_path),
        "--work",
        str(work),
    ]
    assert learned_run.main(argv) == 0
    new = json.loads((tmp_path / "press__act.json").read_text())
    assert new["config"]["reevaluated"] is True and new["train_wall_time_s"] == old["train_wall_time_s"]
    assert [(e["seed"], e["max_contact_force"]) for e in new["episodes"]] == [
        (e["seed"], e["max_contact_force"]) for e in old["episodes"]
    ]
    # a JSON whose training is not the checkpoint's is refused, naming both
    (tmp_path / "press__act.json").write_text(json.dumps({**old, "train_steps": 4000}))
    with pytest.raises(SystemExit) as exc:
        learned_run.main(argv)
    assert exc.value.code == 2
    assert "was trained 3 steps x batch 4, its JSON reports 4000 x 4" in capsys.readouterr().err
    (tmp_path / "press__act.json").unlink()
    with pytest.raises(SystemExit):
        learned_run.main(argv)
    assert "press__act.json not found" in capsys.readouterr().err
