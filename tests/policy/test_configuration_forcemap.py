"""ForceMapConfig: registration, LeRobot defaults, validation, JSON round trip."""

from __future__ import annotations

import os

import pytest


def test_registered_and_lerobot_defaults():
    from lerobot.configs import NormalizationMode, PreTrainedConfig

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    assert PreTrainedConfig.get_choice_class("forcemap") is ForceMapConfig
    cfg = ForceMapConfig(device="cpu")
    assert cfg.type == "forcemap"
    assert cfg.push_to_hub is False  # LeRobot's True would fail validation without a repo_id
    assert cfg.n_obs_steps == 1
    assert set(cfg.normalization_mapping.values()) == {NormalizationMode.IDENTITY}
    opt = cfg.get_optimizer_preset()
    assert opt.lr == 0.0 and opt.grad_clip_norm == 0.0
    assert cfg.get_scheduler_preset() is None
    assert cfg.episodes == [0] and not cfg.is_fitted


@pytest.mark.parametrize(
    "kwargs, field",
    [
        ({"stiffness": 0.0}, "stiffness"),
        ({"segments": "magic"}, "segments"),
        ({"episodes": []}, "episodes"),
        ({"episodes": [1, 1]}, "episodes"),
        ({"rho_max": 1.5}, "rho_max"),
        ({"stream_weights": {"position": 1.0, "voice": 2.0}}, "stream_weights"),
        ({"stream_weights": {"position": float("nan")}}, "stream_weights"),
        ({"stream_weights": {"position": "x"}}, "stream_weights"),
        ({"stream_thresholds": {"position": -1.0}}, "stream_thresholds"),
        ({"stream_thresholds": {"position": float("nan")}}, "stream_thresholds"),
        ({"stream_thresholds": {"position": "x"}}, "stream_thresholds"),
        ({"segment_overrides": {1: {"stifness": 2.0}}}, "segment_overrides"),
        ({"n_nodes": 2}, "n_nodes"),
        # a fraction used to pass as its int(), a string to fail in int() without the field's name
        ({"n_nodes": "abc"}, "n_nodes"),
        ({"n_nodes": 4.5}, "n_nodes"),
        ({"episodes": ["a"]}, "episodes"),
        ({"episodes": [1.5]}, "episodes"),
        ({"chunk_size": 2.5}, "chunk_size"),
        ({"max_iter": 2.5}, "max_iter"),
        ({"min_nodes": "5"}, "min_nodes"),
        # infinite map parameters were refused only at fit time
        ({"lam": float("inf")}, "lam"),
        ({"stiffness": float("inf")}, "stiffness"),
        ({"force_limit": float("inf")}, "force_limit"),
        ({"gripper_delta": float("-inf")}, "gripper_delta"),
        ({"time_scale": -1.0}, "time_scale"),
        ({"gripper_time_scale": -1.0}, "gripper_time_scale"),
        ({"gripper_nodes_per_second": 0.0}, "gripper_nodes_per_second"),
        ({"reanchor_tolerance": -0.001}, "reanchor_tolerance"),
        ({"reanchor_blend_s": 0.0}, "reanchor_blend_s"),
        ({"segmentation_mode": "sum"}, "segmentation_mode"),
        ({"changepoints": "random"}, "changepoints"),
        ({"segmentation_seed": -1}, "segmentation_seed"),
        ({"segmentation_window_s": float("inf")}, "segmentation_window_s"),
        ({"min_segment_s": float("nan")}, "min_segment_s"),
        ({"nodes_per_second": float("inf")}, "nodes_per_second"),
        ({"path_tolerance_m": 0.0}, "path_tolerance_m: must be a finite number > 0 m or None, got 0.0"),
        ({"path_tolerance_m": "4 mm"}, "path_tolerance_m"),
        ({"gripper_nodes_per_second": float("inf")}, "gripper_nodes_per_second"),
        ({"segment_overrides": {1: {"time_scale": -0.05}}}, r"segment_overrides\[1\]\['time_scale'\]"),
        ({"segment_overrides": {0: {"stiffness": "stiff"}}}, r"segment_overrides\[0\]\['stiffness'\]"),
        ({"segment_overrides": {0: {"n_nodes": 2}}}, r"segment_overrides\[0\]\['n_nodes'\]"),
        # nulls of a hand-edited config.json passed as "off", or failed naming no field
        ({"reanchor": None}, "reanchor: must be true or false"),
        ({"check_task": None}, "check_task: must be true or false"),
        ({"pose_key": None}, "pose_key: must be a string, got None"),
        ({"anchor_radius": None}, "anchor_radius: must be a finite number > 0 m, got None"),
        ({"anchor_radius": float("inf")}, "anchor_radius: must be a finite number > 0 m, got inf"),
        ({"static_tolerance": float("inf")}, "static_tolerance"),
        ({"reanchor_tolerance": float("inf")}, "reanchor_tolerance: must be a finite number >= 0 m"),
        ({"reanchor_blend_s": float("inf")}, "reanchor_blend_s: must be a finite number > 0 s or None"),
        ({"chunk_size": 10**7}, r"chunk_size: must be an integer >= 1 and <= 360000"),
        ({"control_fps": "x"}, "control_fps: must be a finite number >= 0.001 Hz or None"),
        # the skill never advanced
        ({"control_fps": 1e-300}, "control_fps: must be a finite number >= 0.001 Hz or None"),
        ({"gripper_index": 7.5}, "gripper_index: must be an integer"),
        # the maps act on raw values: a normalising processor fed them other units (2.5 m off)
        ({"normalization_mapping": {"STATE": "MEAN_STD"}}, "normalization_mapping: must be IDENTITY"),
        (
            {
                "n_segments": 2,
                "segment_n_nodes": [5],
                "segment_n_gripper_nodes": [5, 5],
                "segment_anchors": ["", ""],
                "fps": 20.0,
            },
            "segment_n_nodes",
        ),
        (
            {
                "n_segments": 1,
                "segment_n_nodes": [5],
                "segment_n_gripper_nodes": [5],
                "segment_anchors": ["button"],
                "fps": 20.0,
            },
            "env_state_names",
        ),
    ],
)
def test_bad_settings_name_the_field(kwargs, field):
    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    with pytest.raises(ValueError, match=f"ForceMapConfig.{field}"):
        ForceMapConfig(device="cpu", **kwargs)


def test_a_partial_stream_dict_keeps_the_other_streams_defaults():
    """draccus replaces a dict flag whole: ``--policy.stream_weights='{"wrist_force": 2}'`` must not drop
    the other streams (weight 0 does that, explicitly)."""
    from lerobot_policy_forcemap.configuration_forcemap import (
        DEFAULT_STREAM_THRESHOLDS,
        DEFAULT_STREAM_WEIGHTS,
        ForceMapConfig,
    )

    cfg = ForceMapConfig(
        device="cpu", stream_weights={"wrist_force": 2.0}, stream_thresholds={"position": 0.3}
    )
    assert cfg.stream_weights == {**DEFAULT_STREAM_WEIGHTS, "wrist_force": 2.0}
    assert cfg.stream_thresholds == {**DEFAULT_STREAM_THRESHOLDS, "position": 0.3}
    assert ForceMapConfig(device="cpu", stream_weights={"joints": 0.0}).stream_weights["joints"] == 0.0


def test_default_stream_thresholds_are_the_authors():
    """The authors' UR5e thresholds: joints 0.20, Cartesian 0.25, wrist force 0.15, gripper 0.10."""
    from lerobot_forcemap.data.segment import STREAM_THRESHOLDS
    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    want = {"position": 0.25, "wrist_force": 0.15, "joints": 0.20, "gripper": 0.10, "finger_force": 0.15}
    assert ForceMapConfig(device="cpu").stream_thresholds == want  # finger force takes the wrist force's
    assert STREAM_THRESHOLDS == want  # the library's defaults for segment_dataset agree


def test_fit_settings_are_every_setting_but_the_runtime_ones():
    from lerobot_policy_forcemap.configuration_forcemap import RUNTIME_FIELDS, ForceMapConfig

    fit = set(ForceMapConfig.fit_field_names())
    assert {"stiffness", "episodes", "stream_weights", "segment_overrides", "anchor_radius"} <= fit
    assert not fit & set(RUNTIME_FIELDS) and "device" not in fit and "fps" not in fit
    a, b = (
        ForceMapConfig(device="cpu"),
        ForceMapConfig(device="cuda", stiffness=5000.0, reanchor_online=False),
    )
    assert b.changed_fit_settings(a) == {"stiffness": (3000.0, 5000.0)}


def test_skill_params_apply_overrides_to_one_segment():
    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    cfg = ForceMapConfig(
        device="cpu",
        stiffness=3000.0,
        segment_overrides={1: {"stiffness": 5000.0, "n_nodes": 7, "gripper_lam": 0.5}},
    )
    params = cfg.skill_params()
    assert params.segment(0).arm.stiffness == 3000.0 and params.segment(0).arm.n_nodes is None
    assert params.segment(1).arm.stiffness == 5000.0 and params.segment(1).arm.n_nodes == 7
    assert params.segment(0).gripper.gripper_lam == 0.001 and params.segment(1).gripper.gripper_lam == 0.5


def test_skill_params_hold_every_fit_setting_of_the_config():
    """One name, default and check per setting: the config's fit settings are the skill layer's."""
    from dataclasses import fields

    from lerobot_forcemap.skill.params import RULES, SkillParams
    from lerobot_policy_forcemap.configuration_forcemap import RUNTIME_FIELDS, ForceMapConfig

    def flat(params: SkillParams) -> dict:
        groups = [getattr(params, f.name) for f in fields(SkillParams) if f.name != "segment_overrides"]
        return {f.name: getattr(g, f.name) for g in groups for f in fields(g)}

    cfg = ForceMapConfig(device="cpu", episodes=[2], lam=0.5, segments="none", anchor_radius=0.2)
    assert flat(cfg.skill_params()) == {name: getattr(cfg, name) for name in RULES}
    assert flat(SkillParams()) == {name: getattr(ForceMapConfig(device="cpu"), name) for name in RULES}
    # stiffness_from_demo is the policy's: it turns the fitted demo_stiffness into the skill's stiffness
    fit_settings = (set(RULES) | {"segment_overrides", "episodes", "stiffness_from_demo"}) - set(
        RUNTIME_FIELDS
    )
    assert set(ForceMapConfig.fit_field_names()) == fit_settings


def test_json_round_trip_keeps_every_field(tmp_path):
    from lerobot.configs import PreTrainedConfig

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    cfg = ForceMapConfig(
        device="cpu",
        episodes=[0, 3],
        stiffness=2500.0,
        force_limit=40.0,
        segment_overrides={1: {"stiffness": 4000.0}},
        gripper_time_scale=1.5,
        gripper_nodes_per_second=12.0,
        anchor_by_moved_object=True,
        reanchor_online=False,
        reanchor_blend_s=None,
        n_segments=2,
        segment_n_nodes=[5, 9],
        segment_n_gripper_nodes=[5, 9],
        segment_anchors=["", "button"],
        env_state_names=["button_x", "button_y", "button_z"],
        dataset_tasks=["Press the button."],
        check_task=False,
        fps=20.0,
    )
    cfg._save_pretrained(tmp_path)
    back = PreTrainedConfig.from_pretrained(tmp_path)
    assert isinstance(back, ForceMapConfig)
    for name in ForceMapConfig.field_names():
        assert getattr(back, name) == getattr(cfg, name), name


def test_lerobot_train_names_the_field_draccus_would_hide(tmp_path):
    """draccus turns the config's ValueError into "Couldn't instantiate class ForceMapConfig" and LeRobot
    prints only that; the field's message is logged before it, so ``lerobot-train --policy.n_nodes=-5``
    still says what is wrong."""
    import subprocess
    import sys

    argv = [sys.executable, "-m", "lerobot.scripts.lerobot_train", "--policy.type=forcemap",
            "--policy.n_nodes=-5", "--policy.push_to_hub=false", "--dataset.repo_id=local/x",
            f"--output_dir={tmp_path / 'out'}"]  # fmt: skip
    run = subprocess.run(argv, capture_output=True, text=True, env={**os.environ, "HF_HUB_OFFLINE": "1"})
    assert run.returncode != 0
    assert "Couldn't instantiate class ForceMapConfig" in run.stderr + run.stdout
    assert "ForceMapConfig.n_nodes: must be an integer >= 3 or None, got -5" in run.stderr + run.stdout


def test_a_bad_config_from_python_is_raised_and_logged_once(caplog):
    """The log line is what LeRobot's scripts show (they print only draccus' wrapper); from Python the
    raised error says the same once more."""
    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    with caplog.at_level("ERROR"), pytest.raises(ValueError, match="ForceMapConfig.n_nodes"):
        ForceMapConfig(device="cpu", n_nodes=-5)
    assert [r.getMessage() for r in caplog.records] == [
        "ForceMapConfig.n_nodes: must be an integer >= 3 or None, got -5"
    ]


def test_packed_features_are_positions_in_the_state():
    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    fitted = dict(
        n_segments=1, segment_n_nodes=[5], segment_n_gripper_nodes=[5], segment_anchors=[""], fps=20.0
    )
    ok = ForceMapConfig(**fitted, packed_features={"observation.force": [3, 4, 5], "observation.state": []})
    assert ok.packed_features["observation.force"] == [3, 4, 5]
    with pytest.raises(
        ValueError, match=r"ForceMapConfig.packed_features\['observation.force'\]: must hold distinct"
    ):
        ForceMapConfig(**fitted, packed_features={"observation.force": [3, 3, 5]})
