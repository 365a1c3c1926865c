"""Learned baselines: force in environment_state (derived dataset == env processor), configs, records."""

from __future__ import annotations

import json

import numpy as np
import pytest

from experiments.learned import run as learned_run
from experiments.learned.baselines import (
    ENV_STATE_META_FILE,
    derive_env_state_dataset,
    policy_config,
    result_document,
    train_command,
)
from lerobot_forcemap import layout
from tests.conftest import REPO_ROOT

SHIPPED = REPO_ROOT / "datasets"


# ---- extras and the processor step ---------------------------------------------------------------------


def test_parse_env_state_extras():
    from lerobot_env_forcemap.env_state import (
        parse_env_state_extras,
    )

    assert parse_env_state_extras("ee_pose, force") == ("ee_pose", "force")
    assert parse_env_state_extras(["force"]) == ("force",)
    assert parse_env_state_extras("") == () and parse_env_state_extras(None) == ()
    with pytest.raises(ValueError, match="torque"):
        parse_env_state_extras("force,torque")
    with pytest.raises(ValueError, match="repeated"):
        parse_env_state_extras("force,force")


def test_extended_names_order():
    from lerobot_env_forcemap.env_state import (
        extended_env_state_names,
    )

    names = extended_env_state_names(
        ["a", "b"], ("force", "ee_pose"), {"force": ["fx"], "ee_pose": ["x", "y"]}
    )
    assert names == ["a", "b", "force_fx", "ee_pose_x", "ee_pose_y"]


@pytest.mark.parametrize("batched", [False, True])
def test_processor_concatenates_in_order(batched):
    import torch

    from lerobot_env_forcemap.env_state import (
        EnvStateExtrasProcessorStep,
    )

    rng = np.random.default_rng(0)
    shape = (3,) if batched else ()
    env_state = torch.tensor(rng.normal(size=(*shape, 8)), dtype=torch.float32)
    ee = torch.tensor(rng.normal(size=(*shape, 7)), dtype=torch.float32)
    force = torch.tensor(rng.normal(size=(*shape, 6)), dtype=torch.float32)
    obs = {layout.OBS_ENV_STATE: env_state, layout.OBS_EE_POSE: ee, layout.OBS_FORCE: force}
    out = EnvStateExtrasProcessorStep(extras=("force", "ee_pose")).observation(obs)
    got = out[layout.OBS_ENV_STATE]
    assert got.shape == (*shape, 21)
    assert torch.equal(got[..., :8], env_state)
    assert torch.equal(got[..., 8:14], force)
    assert torch.equal(got[..., 14:], ee)
    assert torch.equal(out[layout.OBS_FORCE], force)  # the source key stays
    assert torch.equal(obs[layout.OBS_ENV_STATE], env_state)  # input not modified


def test_processor_missing_key_and_features():
    import torch
    from lerobot.configs import FeatureType, PipelineFeatureType, PolicyFeature

    from lerobot_env_forcemap.env_state import (
        EnvStateExtrasProcessorStep,
    )

    step = EnvStateExtrasProcessorStep(extras=("force",))
    with pytest.raises(ValueError, match=r"observation\.force"):
        step.observation({layout.OBS_ENV_STATE: torch.zeros(8)})
    feats = {
        PipelineFeatureType.OBSERVATION: {
            layout.OBS_ENV_STATE: PolicyFeature(type=FeatureType.ENV, shape=(8,)),
            layout.OBS_FORCE: PolicyFeature(type=FeatureType.STATE, shape=(6,)),
        }
    }
    out = step.transform_features(feats)
    assert out[PipelineFeatureType.OBSERVATION][layout.OBS_ENV_STATE].shape == (14,)
    assert step.get_config() == {"extras": ["force"]}
    assert EnvStateExtrasProcessorStep(**step.get_config()).extras == ("force",)


def test_env_config_field_features_and_processors():
    from lerobot.envs.configs import EnvConfig

    import lerobot_env_forcemap  # noqa: F401
    from lerobot_env_forcemap.env_state import (
        EnvStateExtrasProcessorStep,
    )

    cls = EnvConfig.get_choice_class("forcemap_press")
    plain = cls()
    pre, _ = plain.get_env_processors()
    assert len(pre.steps) == 0
    assert plain.features[layout.ENV_STATE].shape == (8,)
    cfg = cls(env_state_extras="ee_pose,force")
    assert cfg.features[layout.ENV_STATE].shape == (8 + layout.EE_POSE_DIM + layout.FORCE_DIM,)
    pre, post = cfg.get_env_processors()
    assert [type(s) for s in pre.steps] == [EnvStateExtrasProcessorStep] and len(post.steps) == 0
    assert pre.steps[0].extras == ("ee_pose", "force")
    with pytest.raises(ValueError, match="finger_force"):
        cls(env_state_extras="finger_force")  # the UR5e has no finger sensors


# ---- derived dataset == env-processed observation --------------------------------------------------------


@pytest.fixture(scope="module")
def derived_press(tmp_path_factory):
    out = tmp_path_factory.mktemp("learned") / "press"
    return derive_env_state_dataset(SHIPPED / "press", out, ("ee_pose", "force"))


def _columns(root, keys):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    table = LeRobotDataset("local/t", root=root).hf_dataset.with_format("numpy")
    return {k: np.asarray(table[k]).reshape(len(table), -1) for k in keys}


def test_derived_dataset_columns_names_and_stats(derived_press):
    keys = [layout.OBS_ENV_STATE, layout.OBS_EE_POSE, layout.OBS_FORCE, layout.ACTION, "episode_index"]
    src = _columns(SHIPPED / "press", keys)
    new = _columns(derived_press, keys)
    expected = np.concatenate(
        [src[layout.OBS_ENV_STATE], src[layout.OBS_EE_POSE], src[layout.OBS_FORCE]], axis=1
    )
    np.testing.assert_array_equal(new[layout.OBS_ENV_STATE], expected)
    for k in (layout.ACTION, "episode_index", layout.OBS_FORCE):
        np.testing.assert_array_equal(new[k], src[k])
    info = json.loads((derived_press / "meta" / "info.json").read_text())
    names = info["features"][layout.OBS_ENV_STATE]["names"]
    assert (
        len(names) == 21
        and names[8] == "ee_pose_x"
        and names[-6:] == [f"force_{n}" for n in layout.FORCE_NAMES]
    )
    stats = json.loads((derived_press / "meta" / "stats.json").read_text())[layout.OBS_ENV_STATE]
    np.testing.assert_allclose(stats["mean"], expected.astype(float).mean(axis=0), rtol=1e-5, atol=1e-7)
    np.testing.assert_allclose(stats["max"], expected.max(axis=0), rtol=1e-6)
    import pandas as pd

    eps = pd.read_parquet(next((derived_press / "meta" / "episodes").glob("*/*.parquet")))
    ep0 = expected[new["episode_index"][:, 0] == 0]
    np.testing.assert_allclose(
        eps["stats/observation.environment_state/mean"].iloc[0], ep0.mean(axis=0), rtol=1e-5, atol=1e-7
    )
    meta = json.loads((derived_press / "meta" / ENV_STATE_META_FILE).read_text())
    assert meta["extras"] == ["ee_pose", "force"] and meta["names"] == names
    assert (derived_press / "meta" / "forcemap_episodes.json").is_file()


def test_round_trip_replayed_demo_equals_derived_frames(derived_press):
    """Replaying demonstration 0 (its recorded seed and actions) through the env and the env processor
    reproduces the derived dataset's environment_state frame by frame, to float32 rounding: the shipped
    dataset was recorded on another CPU, and MuJoCo's results can differ there in the last bit (3 of
    1806 values differed by one float32 ulp, 4.5e-13 absolute, on an AMD EPYC)."""
    from lerobot.envs.configs import EnvConfig
    from lerobot.envs.utils import preprocess_observation

    import lerobot_env_forcemap  # noqa: F401
    from lerobot_forcemap.envs import make

    seed = json.loads((derived_press / "meta" / "forcemap_episodes.json").read_text())["episodes"][0]["seed"]
    cols = _columns(derived_press, [layout.OBS_ENV_STATE, layout.ACTION, "episode_index"])
    rows = cols["episode_index"][:, 0] == 0
    frames, actions = cols[layout.OBS_ENV_STATE][rows], cols[layout.ACTION][rows]
    pre, _ = EnvConfig.get_choice_class("forcemap_press")(
        env_state_extras="ee_pose,force"
    ).get_env_processors()
    env = make("press", render_mode=None)
    try:
        obs, _ = env.reset(seed=seed)
        got = []
        for a in actions:
            batch = preprocess_observation(obs)
            batch["task"] = ["press"]
            got.append(pre(batch)[layout.OBS_ENV_STATE].numpy()[0])
            obs, *_ = env.step(a)
    finally:
        env.close()
    got = np.asarray(got)
    assert got.shape == frames.shape == (len(actions), 21)
    np.testing.assert_allclose(got, frames, rtol=2e-6, atol=1e-9)
    assert np.abs(frames[:, -6:-3]).max() > 10.0  # the force part is live (press reaches tens of N)


def test_derive_rejects_missing_feature_and_existing_out(tmp_path, derived_press):
    with pytest.raises(ValueError, match="finger_force"):
        derive_env_state_dataset(SHIPPED / "press", tmp_path / "x", ("finger_force",))
    with pytest.raises(ValueError, match="exists"):
        derive_env_state_dataset(SHIPPED / "press", derived_press, ("force",))
    with pytest.raises(ValueError, match="empty"):
        derive_env_state_dataset(SHIPPED / "press", tmp_path / "y", ())


# ---- configs and records ---------------------------------------------------------------------------------


def test_train_command_flags():
    argv = train_command(
        "diffusion", "/d/press", "/o", steps=400, config=policy_config("diffusion"), batch_size=64
    )
    for flag in (
        "--policy.type=diffusion",
        "--dataset.root=/d/press",
        "--steps=400",
        "--save_freq=400",
        "--batch_size=64",
        "--num_workers=0",
        "--policy.device=cpu",
        "--policy.push_to_hub=false",
        "--policy.down_dims=[64,128,256]",
        "--policy.num_inference_steps=10",
        "--policy.scheduler_warmup_steps=20",
    ):
        assert flag in argv
    norm = next(a for a in argv if a.startswith("--policy.normalization_mapping="))
    assert json.loads(norm.split("=", 1)[1])["ENV"] == "MIN_MAX"
    act = train_command("act", "/d", "/o", steps=10, config=policy_config("act"))
    assert (
        json.loads(next(a for a in act if "normalization_mapping" in a).split("=", 1)[1])["ENV"] == "MEAN_STD"
    )
    assert not any("warmup" in a for a in act)
    with pytest.raises(ValueError, match="steps must be >= 1, got 0"):
        train_command("act", "/d", "/o", steps=0, config={})
    with pytest.raises(ValueError, match=r"method must be one of \['act', 'diffusion'\], got 'pi0'"):
        policy_config("pi0")


def _record(seed, success, stop, fmax, fmean):
    return {
        "seed": seed,
        "success": success,
        "protective_stop": stop,
        "max_contact_force": fmax,
        "mean_contact_force": fmean,
        "max_contact_force_xyz": [fmax / 2, 0.0, fmax],
        "mean_contact_force_xyz": [fmean / 2, 0.0, fmean],
    }


def test_result_document_schema_and_numbers():
    recs = [
        _record(1000, True, False, 10.0, 2.0),
        _record(1001, False, True, 30.0, 4.0),
        _record(1002, True, False, 20.0, 3.0),
    ]
    doc = result_document(
        "press", "act", recs, [1000, 1001, 1002], train_steps=5, train_wall_time_s=1.5, eval_wall_time_s=0.5,
        config={"k": 1}, force_inputs="env state",
    )  # fmt: skip
    assert set(doc) == {
        "task", "method", "n", "seeds", "success_rate", "protective_stops", "max_contact_force",
        "mean_contact_force", "max_contact_force_xyz", "mean_contact_force_xyz", "train_steps",
        "train_wall_time_s", "eval_wall_time_s", "wall_time_s", "lerobot_eval", "config", "force_inputs",
        "episodes",
    }  # fmt: skip
    assert doc["n"] == 3 and doc["seeds"] == [1000, 1001, 1002]
    assert doc["success_rate"] == pytest.approx(2 / 3) and doc["protective_stops"] == 1
    assert doc["max_contact_force"] == {
        "mean": pytest.approx(20.0),
        "std": pytest.approx(np.std([10, 30, 20], ddof=1)),
    }
    assert doc["wall_time_s"] == pytest.approx(2.0) and doc["lerobot_eval"] is None
    assert doc["mean_contact_force_xyz"]["mean"] == pytest.approx([1.5, 0.0, 3.0])
    assert len(doc["max_contact_force_xyz"]["std"]) == 3
    json.dumps(doc)
    with pytest.raises(ValueError, match="seeds"):
        result_document(
            "press",
            "act",
            recs,
            [1, 2, 3],
            train_steps=1,
            train_wall_time_s=0,
            eval_wall_time_s=0,
            config={},
            force_inputs="",
        )
    with pytest.raises(ValueError, match="no episode"):
        result_document(
            "press",
            "act",
            [],
            [],
            train_steps=1,
            train_wall_time_s=0,
            eval_wall_time_s=0,
            config={},
            force_inputs="",
        )


def test_script_parse_steps(capsys):
    mod = learned_run
    assert mod.parse_steps(["300"], ["act", "diffusion"]) == {"act": 300, "diffusion": 300}
    assert mod.parse_steps(["act=5", "diffusion=7"], ["act", "diffusion"]) == {"act": 5, "diffusion": 7}
    with pytest.raises(ValueError, match="diffusion"):
        mod.parse_steps(["act=5"], ["act", "diffusion"])
    with pytest.raises(ValueError, match=r"--batch-size: unknown method 'actt'"):
        mod.parse_steps(["actt=5"], ["act"], "--batch-size")
    with pytest.raises(ValueError, match=r"--steps: 'act=abc' is not N or method=N"):
        mod.parse_steps(["act=abc"], ["act"])
    # a smoke run must not replace the trained checkpoints or the results the report merges
    with pytest.raises(SystemExit) as exc:
        mod.main(["--smoke", "--tasks", "press", "--out", "/tmp/never"])
    assert exc.value.code == 2
    assert (
        "--smoke needs --out and --work outside results/learned and outputs/learned"
        in capsys.readouterr().err
    )
