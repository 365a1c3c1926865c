"""A corrupted or mismatched checkpoint fails with the file and the field named; loading never unpickles."""

from __future__ import annotations

import json
import pickle
import shutil
from unittest import mock

import numpy as np
import pytest


@pytest.fixture
def ckpt(press_checkpoint, tmp_path):
    out = tmp_path / "ckpt"
    shutil.copytree(press_checkpoint, out)
    return out


def _config(path):
    return json.loads((path / "config.json").read_text())


def _edit_config(path, **changes):
    data = json.loads((path / "config.json").read_text())
    data.update(changes)
    (path / "config.json").write_text(json.dumps(data))
    return data


def _drop_config_keys(path, *names):
    data = json.loads((path / "config.json").read_text())
    for name in names:
        del data[name]
    (path / "config.json").write_text(json.dumps(data))


def test_loading_never_unpickles(ckpt):
    import torch

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    boom = mock.Mock(side_effect=AssertionError("unpickling during load"))
    with (
        mock.patch.object(pickle, "load", boom),
        mock.patch.object(pickle, "loads", boom),
        mock.patch.object(torch, "load", boom),
    ):
        policy = ForceMapPolicy.from_pretrained(ckpt)
    assert policy.config.is_fitted
    assert not [p for p in ckpt.iterdir() if p.suffix in (".pt", ".pth", ".bin", ".pkl")]


def test_truncated_safetensors(ckpt):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    path = ckpt / "model.safetensors"
    path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(ValueError, match=r"model\.safetensors: not a readable safetensors file"):
        ForceMapPolicy.from_pretrained(ckpt)


def test_config_and_tensors_that_do_not_belong_together(ckpt):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    data = json.loads((ckpt / "config.json").read_text())
    n = list(data["segment_n_nodes"])
    n[0] += 1
    _edit_config(ckpt, segment_n_nodes=n)
    with pytest.raises(
        ValueError,
        match=r"model\.safetensors: tensor 'nodes' has shape and dtype .* implies .* segment_n_nodes",
    ):
        ForceMapPolicy.from_pretrained(ckpt)


def test_absurd_node_count_is_refused_before_the_policy_is_built(ckpt):
    """The buffers are sized from config.json: a tampered count must fail on the weights' header, not allocate."""
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    data = json.loads((ckpt / "config.json").read_text())
    _edit_config(ckpt, segment_n_nodes=[10**10] + list(data["segment_n_nodes"])[1:])
    with (
        mock.patch.object(ForceMapPolicy, "__init__", side_effect=AssertionError("policy built")),
        pytest.raises(
            ValueError, match=r"model\.safetensors: tensor 'nodes' has shape .* segment_n_nodes=\[10000000000"
        ),
    ):
        ForceMapPolicy.from_pretrained(ckpt)


def test_missing_tensor(ckpt):
    from safetensors.torch import load_file, save_file

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    tensors = load_file(ckpt / "model.safetensors")
    del tensors["durations"]
    save_file(tensors, ckpt / "model.safetensors")
    with pytest.raises(
        ValueError,
        match=r"model\.safetensors: missing tensor\(s\) \['durations'\], unexpected tensor\(s\) \[\]",
    ):
        ForceMapPolicy.from_pretrained(ckpt)


def test_wrong_dtype(ckpt):
    from safetensors.torch import load_file, save_file

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    tensors = load_file(ckpt / "model.safetensors")
    tensors["nodes"] = tensors["nodes"].float()
    save_file(tensors, ckpt / "model.safetensors")
    with pytest.raises(
        ValueError,
        match=r"tensor 'nodes' has shape and dtype \(\(\d+, 3\), 'F32'\), config.json implies \(\(\d+, 3\), 'F64'\)",
    ):
        ForceMapPolicy.from_pretrained(ckpt)


def test_non_finite_values(ckpt):
    from safetensors.torch import load_file, save_file

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    tensors = load_file(ckpt / "model.safetensors")
    tensors["node_times"][3] = float("nan")
    save_file(tensors, ckpt / "model.safetensors")
    with pytest.raises(ValueError, match=r"model\.safetensors: tensor 'node_times' has 1 non-finite"):
        ForceMapPolicy.from_pretrained(ckpt)


def test_values_beyond_a_robots_reach_are_refused_by_file(ckpt):
    """Nodes multiplied by 1e300 loaded, then failed at the first select_action naming no file."""
    from safetensors.torch import load_file, save_file

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    tensors = load_file(ckpt / "model.safetensors")
    tensors["nodes"] = tensors["nodes"] * 1e300
    save_file(tensors, ckpt / "model.safetensors")
    with pytest.raises(
        ValueError,
        match=r"model\.safetensors: tensor 'nodes' has \d+ beyond ±1e\+06 value\(s\), first at \[0, 0\]",
    ):
        ForceMapPolicy.from_pretrained(ckpt)


@pytest.mark.parametrize(
    "edit, message",
    [
        (lambda p: (p / "config.json").write_text("{not json"), r"config\.json: not valid JSON"),
        (lambda p: _edit_config(p, type="act"), r"config\.json: field 'type' is 'act', expected 'forcemap'"),
        # types: draccus' own parse, named under the file
        (
            lambda p: _edit_config(p, n_segments="three"),
            r"config\.json: cannot read the policy config: `n_segments`: Couldn't parse 'three' into an int",
        ),
        (
            lambda p: _edit_config(p, segment_n_nodes=[1.5, 2]),
            r"config\.json: cannot read the policy config: `segment_n_nodes\.0`: Couldn't parse '1\.5'",
        ),
        (
            lambda p: _edit_config(p, n_segments=7),
            r"config\.json: cannot read the policy config: .*segment_n_nodes",
        ),
        (
            lambda p: _edit_config(p, stiffness=-1),
            r"config\.json: cannot read the policy config: .*stiffness",
        ),
        (
            lambda p: _edit_config(p, segment_anchors=[*_config(p)["segment_anchors"][:-1], "knob"]),
            r"config\.json: cannot read the policy config: .*segment_anchors.*\['knob'\]",
        ),
        (
            lambda p: _drop_config_keys(p, "lam"),
            r"config\.json: field 'lam' is missing \(not a complete fitted forcemap checkpoint\)",
        ),
        (
            lambda p: _drop_config_keys(p, "dataset_tasks"),
            r"config\.json: field 'dataset_tasks' is missing",
        ),
        (
            lambda p: _drop_config_keys(p, "output_features"),
            r"config\.json: field 'output_features' is missing",
        ),
        (
            lambda p: (p / "policy_postprocessor.json").write_text("{oops"),
            r"policy_postprocessor\.json: not valid JSON",
        ),
        (lambda p: (p / "config.json").unlink(), r"config\.json: file not found"),
        (lambda p: (p / "model.safetensors").unlink(), r"model\.safetensors: file not found"),
    ],
)
def test_bad_config_json(ckpt, edit, message):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    edit(ckpt)
    with pytest.raises(ValueError, match=message):
        ForceMapPolicy.from_pretrained(ckpt)


def test_overrides_of_segments_the_fit_does_not_have_are_named(ckpt):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    last = _config(ckpt)["n_segments"] - 1
    _edit_config(ckpt, segment_overrides={"7": {"stiffness": 4000.0}})
    message = (
        r"config\.json: cannot read the policy config: .*segment_overrides: must name segments of the fit "
        rf"\(0\.\.{last}\), got \[7\]"
    )
    with pytest.raises(ValueError, match=message):
        ForceMapPolicy.from_pretrained(ckpt)


@pytest.mark.parametrize("name", ["anchor_poses", "anchor_initial_poses"])
def test_anchor_poses_need_unit_quaternions(ckpt, name):
    from safetensors.torch import load_file, save_file

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    tensors = load_file(ckpt / "model.safetensors")
    tensors[name][0] = 0.0
    save_file(tensors, ckpt / "model.safetensors")
    with pytest.raises(
        ValueError, match=rf"model\.safetensors: tensor '{name}' row 0 is not a unit quaternion"
    ):
        ForceMapPolicy.from_pretrained(ckpt)


def test_value_checks_name_the_field():
    from lerobot_forcemap.skill.model import check_flat_arrays

    arrays = {
        "nodes": np.zeros((3, 3)),
        "node_times": np.array([0.0, 0.2, 0.1]),
        "orientations": np.tile([1.0, 0, 0, 0], (3, 1)),
        "gripper_nodes": np.zeros((3, 1)),
        "gripper_node_times": np.array([0.0, 0.1, 0.2]),
        "durations": np.array([1.0]),
        "anchor_poses": np.zeros((1, 7)),
    }
    with pytest.raises(ValueError, match="src: tensor 'node_times' decreases within segment 0"):
        check_flat_arrays(arrays, [3], [3], "src")


def test_node_times_must_lie_in_their_segment():
    from lerobot_forcemap.skill.model import check_flat_arrays

    arrays = {
        "nodes": np.zeros((3, 3)),
        "node_times": np.array([0.0, 0.5, 1.0]),
        "orientations": np.tile([1.0, 0, 0, 0], (3, 1)),
        "gripper_nodes": np.zeros((3, 1)),
        "gripper_node_times": np.array([0.0, 0.5, 1.0]),
        "durations": np.array([1.0]),
        "anchor_poses": np.tile([0, 0, 0, 1.0, 0, 0, 0], (1, 1)),
        "anchor_initial_poses": np.tile([0, 0, 0, 1.0, 0, 0, 0], (1, 1)),
    }
    check_flat_arrays(arrays, [3], [3], "src")  # consistent: passes
    arrays["gripper_node_times"] = np.array([0.0, 0.5, 4.0])
    with pytest.raises(
        ValueError,
        match=r"src: tensor 'gripper_node_times' in segment 0 spans \[0, 4\] s, outside .*\[0, 1\] s",
    ):
        check_flat_arrays(arrays, [3], [3], "src")


@pytest.mark.parametrize(
    "step, message",
    [
        ({"class": "subprocess.Popen", "config": {"args": ["touch", "{marker}"]}}, "subprocess.Popen"),
        (
            {"class": "lerobot.configs.default.DatasetConfig", "config": {}},
            "lerobot.configs.default.DatasetConfig",
        ),
    ],
)
def test_processor_steps_must_be_lerobot_processors(ckpt, tmp_path, step, message):
    """LeRobot imports and calls a step's "class" before checking it is a processor step: a pipeline
    file could run any callable. Refused before anything is built, for every loader."""
    from lerobot_forcemap.evaluation.evaluate import load_policy
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    marker = tmp_path / "ran"
    step = json.loads(json.dumps(step).replace("{marker}", str(marker)))
    pipeline = json.loads((ckpt / "policy_postprocessor.json").read_text())
    pipeline["steps"].insert(1, step)
    (ckpt / "policy_postprocessor.json").write_text(json.dumps(pipeline))
    for load in (ForceMapPolicy.from_pretrained, load_policy):
        with pytest.raises(
            ValueError,
            match=rf"policy_postprocessor\.json: steps\[1\]\.class: must name a ProcessorStep of lerobot .*{message}",
        ):
            load(ckpt)
    assert not marker.exists()


def test_a_normalising_processor_step_is_refused_by_file(ckpt):
    """norm_map MEAN_STD in the saved pipeline gave a silent 23 mm error: the maps act on raw values."""
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    pipeline = json.loads((ckpt / "policy_preprocessor.json").read_text())
    norm = next(
        i for i, st in enumerate(pipeline["steps"]) if st.get("registry_name") == "normalizer_processor"
    )
    pipeline["steps"][norm]["config"]["norm_map"]["STATE"] = "MEAN_STD"
    (ckpt / "policy_preprocessor.json").write_text(json.dumps(pipeline))
    with pytest.raises(
        ValueError,
        match=rf"policy_preprocessor\.json: steps\[{norm}\]\.config\.norm_map: must map every feature type",
    ):
        ForceMapPolicy.from_pretrained(ckpt)


def test_a_non_finite_fps_or_dummy_is_refused(ckpt):
    """fps inf used to load and freeze the arm (clock at inf Hz); a NaN dummy made lerobot-train's loss NaN."""
    import torch
    from safetensors.torch import load_file, save_file

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    fitted_fps = json.loads((ckpt / "config.json").read_text())["fps"]
    _edit_config(ckpt, fps=float("inf"))
    with pytest.raises(ValueError, match=r"ForceMapConfig.fps: must be a finite number > 0 Hz, got inf"):
        ForceMapPolicy.from_pretrained(ckpt)
    _edit_config(ckpt, fps=fitted_fps)
    tensors = load_file(ckpt / "model.safetensors")
    tensors["closed_form_dummy"] = torch.tensor([float("nan")])
    save_file(tensors, ckpt / "model.safetensors")
    with pytest.raises(ValueError, match="'closed_form_dummy' has 1 non-finite"):
        ForceMapPolicy.from_pretrained(ckpt)


def test_a_policy_loads_without_its_processors_with_a_warning(ckpt, caplog):
    """from_pretrained alone does not need them; lerobot-eval would call the checkpoint 'requiring
    migration' without naming the file, so the loader names it."""
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    (ckpt / "policy_preprocessor.json").unlink()
    with caplog.at_level("WARNING", logger="lerobot_policy_forcemap.checkpoint"):
        assert ForceMapPolicy.from_pretrained(ckpt).config.is_fitted
    assert "policy_preprocessor.json: file not found; lerobot-eval needs it" in caplog.text


def test_eval_loader_refuses_a_foreign_config_and_missing_processors(ckpt):
    """forcemap eval's loader: a checkpoint without its processor pipelines is named (LeRobot's own
    message calls it a checkpoint 'requiring migration')."""
    from lerobot_forcemap.evaluation.evaluate import load_policy

    (ckpt / "policy_preprocessor.json").unlink()
    with pytest.raises(ValueError, match=r"policy_preprocessor\.json: file not found"):
        load_policy(ckpt)


def test_eval_loader_refuses_an_act_config_beside_forcemap_tensors(ckpt):
    """Not loaded with random weights (LeRobot's default strict=False only logs the key mismatch)."""
    from lerobot.configs.types import FeatureType, PolicyFeature
    from lerobot.policies.act.configuration_act import ACTConfig

    from lerobot_forcemap.evaluation.evaluate import load_policy

    act = ACTConfig(
        input_features={
            "observation.state": PolicyFeature(FeatureType.STATE, (7,)),
            "observation.environment_state": PolicyFeature(FeatureType.ENV, (8,)),
        },
        output_features={"action": PolicyFeature(FeatureType.ACTION, (8,))},
        device="cpu",
        push_to_hub=False,
    )
    (ckpt / "config.json").unlink()
    act._save_pretrained(ckpt)
    with pytest.raises(ValueError, match=r"model\.safetensors: its tensors do not fit the 'act' policy"):
        load_policy(ckpt)


def test_fit_settings_given_at_load_are_refused_runtime_ones_apply(press_checkpoint):
    """``lerobot-eval --policy.path=CKPT --policy.stiffness=...``: LeRobot applies the flag to the config, but
    the stored maps were fitted with another stiffness; loading them under it would report a setting that
    was never used. Settings read only while acting apply."""
    from lerobot.configs.policies import PreTrainedConfig
    from lerobot.policies.factory import make_policy

    def load(*overrides):
        cfg = PreTrainedConfig.from_pretrained(press_checkpoint, cli_overrides=list(overrides))
        cfg.pretrained_path = press_checkpoint
        return make_policy(cfg, env_cfg=EnvConfig.get_choice_class("forcemap_press")())

    from lerobot.envs.configs import EnvConfig

    with pytest.raises(
        ValueError,
        match=r"config\.json: the checkpoint was fitted with other settings than asked "
        r"for \(episodes \[0\] -> \[1\], stiffness 3000\.0 -> 100000\.0\).*forcemap fit --set",
    ):
        load("--stiffness=100000", "--episodes=[1]")
    policy = load("--reanchor_online=false", "--chunk_size=4")
    assert policy.config.reanchor_online is False and policy.config.chunk_size == 4
    # lerobot-train --policy.path=CKPT with a fit setting: refused the same way (the maps would be re-saved
    # under a config.json that misdescribes them)
    from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata

    from tests.conftest import SHIPPED_PRESS

    cfg = PreTrainedConfig.from_pretrained(press_checkpoint, cli_overrides=["--lam=0.5"])
    cfg.pretrained_path = press_checkpoint
    if (SHIPPED_PRESS / "meta" / "info.json").is_file():
        with pytest.raises(ValueError, match=r"lam 0\.01 -> 0\.5"):
            make_policy(cfg, ds_meta=LeRobotDatasetMetadata("local/press", root=SHIPPED_PRESS))


def test_a_missing_local_folder_is_named_as_such(tmp_path):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    with pytest.raises(ValueError, match=r"nope/ckpt/x: no such checkpoint folder"):
        ForceMapPolicy.from_pretrained(tmp_path / "nope" / "ckpt" / "x")
    with pytest.raises(ValueError, match=r"\./ckpt: no such checkpoint folder"):
        ForceMapPolicy.from_pretrained("./ckpt")
    # two parts but not a Hub name either (a space, a trailing slash): named here, not sent to the Hub
    for name in ("outputs/run 1", "outputs/train/"):
        with pytest.raises(ValueError, match=f"{name}: no such checkpoint folder"):
            ForceMapPolicy.from_pretrained(name)
    # a mistyped folder shaped like a Hub id (outputs/policy): looked up on the Hub, and said missing here
    with pytest.raises(
        ValueError,
        match=r"outputs/polcy: config\.json is not in the local .* no local folder 'outputs/polcy'",
    ):
        ForceMapPolicy.from_pretrained("outputs/polcy")


def test_a_config_edited_after_it_was_built_is_checked_at_load(ckpt):
    import copy

    from lerobot.configs import NormalizationMode

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    config = copy.deepcopy(ForceMapPolicy.from_pretrained(ckpt).config)
    config.normalization_mapping["STATE"] = NormalizationMode.MEAN_STD  # no __post_init__ runs
    with pytest.raises(ValueError, match="ForceMapConfig.normalization_mapping: must be IDENTITY"):
        ForceMapPolicy.from_pretrained(ckpt, config=config)
