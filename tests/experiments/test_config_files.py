"""``configs/``: the experiments' settings as ``lerobot-train`` / ``lerobot-eval`` ``--config_path`` files."""

from __future__ import annotations

import importlib
import json
import os
import subprocess
import sys
from pathlib import Path

import draccus
import pytest

from tests.conftest import REPO_ROOT

CONFIGS = REPO_ROOT / "configs"
RESULTS = REPO_ROOT / "results"
BIN = Path(sys.executable).parent


@pytest.fixture(scope="module")
def config_files():
    return importlib.import_module("experiments.paper.config_files")


@pytest.fixture(scope="module")
def experiments_doc():
    return json.loads((RESULTS / "experiments.json").read_text())


def _shipped() -> dict[str, dict]:
    return {str(p.relative_to(CONFIGS)): json.loads(p.read_text()) for p in sorted(CONFIGS.glob("*/*.json"))}


def test_shipped_configs_are_what_the_results_say(config_files, experiments_doc):
    built = config_files.build_configs(experiments_doc, config_files.load_learned(RESULTS / "learned"))
    shipped = _shipped()
    assert sorted(shipped) == sorted(built), "configs/ is stale: run python -m experiments.paper.config_files"
    for rel, cfg in built.items():
        assert shipped[rel] == json.loads(json.dumps(cfg)), rel
    tasks = ("press", "erase", "peg_in_hole", "grasp_push", "grasp_flip")
    assert {f"train/forcemap_{t}.json" for t in tasks} | {f"eval/forcemap_{t}.json" for t in tasks} <= set(
        built
    )


def test_forcemap_configs_carry_the_tuned_settings(experiments_doc):
    tuning = experiments_doc["tuning"]
    policy = {
        t: json.loads((CONFIGS / f"train/forcemap_{t}.json").read_text())["policy"]
        for t in ("press", "erase", "peg_in_hole", "grasp_push")
    }
    for task in ("press", "erase"):
        assert policy[task]["stiffness"] == tuning[task]["weights"]["chosen"]["stiffness"]
    for key, value in tuning["peg_in_hole"]["ours"]["chosen"].items():
        assert policy["peg_in_hole"][key] == value
    assert policy["grasp_push"]["anchor_by_moved_object"] is True
    assert policy["grasp_push"]["anchor_radius"] == 0.15


def test_headline_lookup_rejects_an_ambiguous_document(config_files):
    rec = {"experiment": "table2", "task": "press", "method": "ours"}
    doc = {
        "records": [
            {**rec, "settings": {"overrides": ["stiffness=1800"]}},
            {**rec, "settings": {"overrides": ["stiffness=2000"]}},
        ]
    }
    with pytest.raises(ValueError, match="table2/press/ours"):
        config_files.headline_overrides(doc, "press")
    with pytest.raises(ValueError, match="not a ForceMapConfig field"):
        config_files.forcemap_policy_fields(["stifness=1800"])


def test_train_configs_parse_as_lerobot_train_configs():
    import lerobot.policies  # noqa: F401  (registers act, diffusion, ...)
    from lerobot.configs.train import TrainPipelineConfig

    import lerobot_policy_forcemap  # noqa: F401  (registers --policy.type=forcemap)

    paths = sorted(CONFIGS.glob("train/*.json"))
    assert paths
    for path in paths:
        raw = json.loads(path.read_text())
        cfg = TrainPipelineConfig.from_pretrained(path)
        assert cfg.policy.type == raw["policy"]["type"], path.name
        assert cfg.policy.push_to_hub is False and cfg.policy.device == "cpu", path.name
        for key, value in raw["policy"].items():
            if key not in ("type", "normalization_mapping"):
                got = getattr(cfg.policy, key)
                assert (list(got) if isinstance(got, tuple) else got) == value, (path.name, key)
        if raw["policy"]["type"] == "forcemap":
            assert (REPO_ROOT / cfg.dataset.root / "meta" / "info.json").is_file(), path.name
            assert cfg.steps == 1


def test_eval_configs_name_a_forcemap_env_and_the_train_checkpoint():
    from lerobot.envs.configs import EnvConfig

    import lerobot_env_forcemap  # noqa: F401  (registers --env.type=forcemap_*)

    for path in sorted(CONFIGS.glob("eval/*.json")):
        raw = json.loads(path.read_text())
        env = draccus.decode(EnvConfig, raw["env"])
        assert env.type == raw["env"]["type"], path.name
        train = json.loads((CONFIGS / "train" / path.name).read_text())
        assert raw["policy"]["path"] == f"{train['output_dir']}/checkpoints/last/pretrained_model"


@pytest.mark.slow
def test_press_configs_run_through_lerobot_train_and_eval(tmp_path):
    env = {**os.environ, "HF_HUB_OFFLINE": "1", "MUJOCO_GL": "egl", "OPENBLAS_NUM_THREADS": "1"}
    train_out, eval_out = tmp_path / "train", tmp_path / "eval"
    for argv in (
        [
            str(BIN / "lerobot-train"),
            "--config_path=configs/train/forcemap_press.json",
            f"--output_dir={train_out}",
        ],
        [
            str(BIN / "lerobot-eval"),
            "--config_path=configs/eval/forcemap_press.json",
            f"--policy.path={train_out}/checkpoints/last/pretrained_model",
            f"--output_dir={eval_out}",
            "--eval.n_episodes=2",
        ],
    ):
        run = subprocess.run(argv, cwd=REPO_ROOT, env=env, capture_output=True, text=True, timeout=600)
        assert run.returncode == 0, f"{argv[0]} failed:\n{run.stdout[-2000:]}\n{run.stderr[-4000:]}"
    saved = json.loads((train_out / "checkpoints/last/pretrained_model/config.json").read_text())
    assert (
        saved["stiffness"]
        == json.loads((CONFIGS / "train/forcemap_press.json").read_text())["policy"]["stiffness"]
    )
    info = json.loads((eval_out / "eval_info.json").read_text())
    assert info["overall"]["n_episodes"] == 2
    assert info["overall"]["pc_success"] == 100.0
