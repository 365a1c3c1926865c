"""ForceMapPolicy in LeRobot: closed-form fit in the constructor, acting, save/load round trip."""

from __future__ import annotations

import numpy as np
import pytest

from tests.conftest import fit_and_save


def _scene(button=(0.5, 0.0, 0.027), tcp=(0.42, 0.0, 0.15), batch=1):
    """A LeRobot-style observation batch of the press task (tool pointing down)."""
    import torch

    q = [0.0, 1.0, 0.0, 0.0]
    obs = {
        "observation.ee_pose": torch.tensor([[*tcp, *q]] * batch, dtype=torch.float32),
        "observation.environment_state": torch.tensor(
            [[*button, 1.0, 0.0, 0.0, 0.0, 0.0]] * batch, dtype=torch.float32
        ),
        "observation.state": torch.zeros(batch, 7),
        "observation.force": torch.zeros(batch, 6),
    }
    return obs


#: a contact normal 53 degrees off the press's vertical touch-down (the peg's): the rules' slanted case
TILTED = np.array([-0.76, 0.24, 0.60]) / np.linalg.norm([-0.76, 0.24, 0.60])


def _tilted(policy):
    """``policy`` with its demonstrated contact normal set to ``TILTED``."""
    import torch

    normal = policy.get_buffer("force_normal")
    normal.copy_(torch.as_tensor(TILTED, dtype=normal.dtype))
    return policy


@pytest.fixture(scope="module")
def policy(press_checkpoint):
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    return ForceMapPolicy.from_pretrained(press_checkpoint)


def test_fit_fills_the_config_and_buffer_shapes(policy):
    import torch

    cfg = policy.config
    assert cfg.is_fitted and cfg.fps == 20.0 and cfg.episodes == [0]
    assert len(cfg.segment_n_nodes) == cfg.n_segments == len(cfg.segment_anchors)
    assert "button" in cfg.segment_anchors and cfg.env_state_names[:3] == ["button_x", "button_y", "button_z"]
    n = sum(cfg.segment_n_nodes)
    assert (
        policy.nodes.shape == (n, 3)
        and policy.orientations.shape == (n, 4)
        and policy.nodes.dtype == torch.float64
    )
    assert [p.numel() for p in policy.get_optim_params()] == [1]


def test_select_action_streams_the_reproduction_and_matches_chunks(policy):
    import torch

    obs = _scene()
    policy.reset()
    chunk = policy.predict_action_chunk(obs)
    assert chunk.shape == (1, policy.config.chunk_size, 8) and chunk.dtype == torch.float32
    steps = torch.stack([policy.select_action(obs) for _ in range(policy.config.chunk_size)], dim=1)
    torch.testing.assert_close(steps, chunk, rtol=0, atol=0)
    # the first target is the robot's current pose (start re-anchoring)
    np.testing.assert_allclose(steps[0, 0, :3].numpy(), [0.42, 0.0, 0.15], atol=1e-6)
    # after the demonstration's duration the final pose is held (the clock on calls alone: the press
    # touches down along its normal, which the approach rule leaves at the map's pace)
    policy.reset()
    n = int(round(sum(policy.durations.tolist()) * policy.config.fps)) + 5
    acts = torch.stack([policy.select_action(obs) for _ in range(n + 3)])
    torch.testing.assert_close(acts[-1], acts[-3], rtol=0, atol=0)


def test_the_approach_rule_slows_the_touch_down_and_only_it(press_checkpoint):
    """Met at a slant from the demonstrated normal, near the demonstrated contact the target comes down
    at most approach_speed; the skill ends the same, later (no force is felt: the rule holds through
    the whole zone). Met along the normal (the press as demonstrated), the rule leaves it alone."""
    import torch

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    obs = _scene()
    as_fitted, plain = (ForceMapPolicy.from_pretrained(press_checkpoint) for _ in range(2))
    plain.config.approach_speed = 0.0
    assert as_fitted.config.approach_speed == 0.01  # the default
    n = int(round(sum(plain.durations.tolist()) * plain.config.fps)) + 5
    a = torch.stack([plain.select_action(obs) for _ in range(n)])
    torch.testing.assert_close(
        torch.stack([as_fitted.select_action(obs) for _ in range(n)]), a, rtol=0, atol=0
    )
    ruled, plain = (_tilted(ForceMapPolicy.from_pretrained(press_checkpoint)) for _ in range(2))
    plain.config.approach_speed = 0.0
    a = torch.stack([plain.select_action(obs) for _ in range(n)])[:, 0].numpy()
    b = torch.stack([ruled.select_action(obs) for _ in range(n + 80)])[:, 0].numpy()
    dt = 1.0 / ruled.clock_hz
    down_a, down_b = -np.diff(a[:, 2]) / dt, -np.diff(b[:, 2]) / dt  # m/s, descent of the target
    assert down_a.max() > 0.02  # the map itself touches down faster than the rule allows
    # the contact: the press's lowest target; its zone is 1 cm either side along the vertical
    near_b = np.abs(b[1:, 2] - a[:, 2].min()) < ruled.config.approach_zone - 0.002
    # along the touch-down's direction (a few degrees off the vertical) at most approach_speed
    assert near_b.sum() > 10 and down_b[near_b].max() <= 1.01 * ruled.config.approach_speed
    np.testing.assert_allclose(b[-1], a[-1], atol=1e-6)  # the same skill, just later
    assert len(b) - np.argmax(np.all(np.abs(b - b[-1]) < 1e-9, axis=1)) < 80


def test_a_demonstration_that_moved_its_object_gets_neither_rule(press_checkpoint):
    """With feedback_max_push below the press's depth at the budget the demonstration counts as having
    moved its object (grasp_push's book): even met at a slant, the touch-down keeps the map's pace."""
    import torch

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    obs = _scene()
    moved, plain = (_tilted(ForceMapPolicy.from_pretrained(press_checkpoint)) for _ in range(2))
    for p in (moved, plain):
        p.config.feedback_max_push = 0.001
    plain.config.approach_speed = plain.config.contact_yield = 0.0
    n = int(round(sum(plain.durations.tolist()) * plain.config.fps)) + 5
    a = torch.stack([plain.select_action(obs) for _ in range(n)])
    torch.testing.assert_close(torch.stack([moved.select_action(obs) for _ in range(n)]), a, rtol=0, atol=0)
    assert moved._feedback.moved_object and moved._approach is None


def test_batch_elements_are_placed_in_their_own_scenes(policy):
    import torch

    a, b = _scene(button=(0.49, -0.01, 0.027)), _scene(button=(0.52, 0.015, 0.027), tcp=(0.41, 0.004, 0.152))
    both = {k: torch.cat([a[k], b[k]]) for k in a}
    policy.reset()
    out = torch.stack([policy.select_action(both) for _ in range(70)], dim=1)
    for i, single in enumerate((a, b)):
        policy.reset()
        ref = torch.stack([policy.select_action(single) for _ in range(70)], dim=1)
        torch.testing.assert_close(out[i : i + 1], ref, rtol=0, atol=0)
    # the press happens over each batch element's own button
    low = out[:, :, 2].argmin(dim=1)
    for i, button in enumerate(((0.49, -0.01), (0.52, 0.015))):
        np.testing.assert_allclose(out[i, low[i], :2].numpy(), button, atol=4e-3)


def test_save_load_round_trip_is_bit_exact(policy, tmp_path):
    import torch

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig
    from lerobot_policy_forcemap.modeling_forcemap import SKILL_TENSORS, ForceMapPolicy

    policy.save_pretrained(tmp_path)
    back = ForceMapPolicy.from_pretrained(tmp_path)
    for name in SKILL_TENSORS:
        assert torch.equal(getattr(back, name), getattr(policy, name)), name
    for name in ForceMapConfig.field_names():
        if name not in ("pretrained_path",):
            assert getattr(back.config, name) == getattr(policy.config, name), name
    obs = _scene(button=(0.51, 0.01, 0.027))
    policy.reset()
    back.reset()
    for _ in range(100):
        assert torch.equal(policy.select_action(obs), back.select_action(obs))


def test_forward_is_a_diagnostic_loss_without_gradient_effect(policy):
    """The loss is the distance (m) from each sample's target position to the path placed in its scene."""
    import torch

    button = np.array([0.5, 0.0, 0.027])
    seg = next(s for s in policy.skill.segments if s.anchor == "button")  # nodes in the button's frame
    on_path = button + seg.nodes[len(seg.nodes) // 2]
    moved = button + [0.03, 0.02, 0.0]
    batch = _scene(batch=4)
    batch["observation.environment_state"][2, :3] = torch.tensor(moved)
    targets = [on_path, on_path + [0.0, 0.0, 1.0], moved - button + on_path, [2.5, 0.0, 0.04]]
    batch["action"] = torch.tensor([[*t, 0.0, 1.0, 0.0, 0.0, 1.0] for t in targets], dtype=torch.float32)
    policy.train()
    per_sample, _ = policy.forward(batch, reduction="none")
    assert per_sample.shape == (4,)
    assert per_sample[0].item() < 1e-6  # on the path (float32 batch)
    assert per_sample[1].item() > 0.8  # 1 m above the pressed point, the path rises at most ~0.15 m
    assert per_sample[2].item() < 1e-6  # the same point carried along with its sample's moved button
    assert per_sample[3].item() > 1.9  # 2 m beyond the workspace
    loss, info = policy.forward(batch)
    assert loss.ndim == 0 and loss.item() == pytest.approx(per_sample.mean().item(), rel=1e-6)
    loss.backward()
    assert policy.closed_form_dummy.grad is not None and policy.closed_form_dummy.grad.abs().sum() == 0
    assert info["map_distance_mm"] == pytest.approx(loss.item() * 1e3, rel=1e-5)
    policy.eval()


def test_a_second_training_step_says_it_changes_nothing(press_checkpoint, caplog):
    import torch

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    fitted = ForceMapPolicy.from_pretrained(press_checkpoint)  # a fresh one: it counts its forward calls
    batch = _scene()
    batch["action"] = torch.tensor([[0.5, 0.0, 0.04, 0.0, 1.0, 0.0, 0.0, 1.0]])
    fitted.train()
    with caplog.at_level("WARNING"):
        fitted.forward(batch)
        assert "--steps=1 is enough" not in caplog.text  # the one step lerobot-train needs
        fitted.forward(batch)
        fitted.forward(batch)
    assert caplog.text.count("lerobot-train --steps=1 is enough") == 1
    fitted.eval()


def test_missing_observation_and_unfitted_policy_are_clear_errors(policy):
    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    obs = _scene()
    del obs["observation.environment_state"]
    policy.reset()
    with pytest.raises(ValueError, match="observation 'observation.environment_state' is missing"):
        policy.select_action(obs)
    obs = _scene(batch=2)
    obs["observation.ee_pose"][1, 3:7] = 0.0
    policy.reset()
    with pytest.raises(
        ValueError, match=r"observation 'observation.ee_pose': zero quaternion .* at batch row 1"
    ):
        policy.select_action(obs)
    empty = ForceMapPolicy(ForceMapConfig(device="cpu"))
    with pytest.raises(ValueError, match="not fitted"):
        empty.select_action(_scene())


def test_a_pose_of_the_wrong_shape_or_dtype_is_refused(policy):
    # a stacked (batch, steps, 7) pose used to be flattened and its first step read as the robot pose,
    # an (batch, 8) one cut to 7, an integer one read as whole metres
    import torch

    obs = _scene()
    bad = {
        "stacked": (
            obs["observation.ee_pose"][:, None].repeat(1, 2, 1),
            r"must have shape \(1, any\), got shape \(1, 2, 7\)",
        ),
        "wide": (
            torch.cat([obs["observation.ee_pose"], torch.zeros(1, 1)], dim=1),
            "needs \\[x y z qw qx qy qz\\], got width 8",
        ),
        "integer": (
            obs["observation.ee_pose"].round().long(),
            r"must hold floating-point values, got dtype\('int64'\)",
        ),
        "tiny quaternion": (
            obs["observation.ee_pose"].clone().index_fill_(1, torch.arange(3, 7), 1e-7),
            "zero quaternion",
        ),
    }
    for pose, message in bad.values():
        policy.reset()
        with pytest.raises(ValueError, match=f"observation 'observation.ee_pose': {message}"):
            policy.select_action({**obs, "observation.ee_pose": pose})
    policy.reset()
    assert policy.select_action(
        {**obs, "observation.ee_pose": obs["observation.ee_pose"].double()}
    ).shape == (1, 8)


def test_an_env_of_another_task_is_refused(policy):
    """Erase's environment_state has press's width (8): only the task string tells the scenes apart."""
    press = "Press the red button until it clicks, then let go."
    assert policy.config.dataset_tasks == [press]
    obs = _scene()
    policy.reset()
    policy.select_action({**obs, "task": [press]})  # LeRobot's eval passes the env's task_description
    policy.reset()
    with pytest.raises(ValueError, match=r"asks for task\(s\) \['Wipe the blue S off.*check_task=false"):
        policy.select_action({**obs, "task": ["Wipe the blue S off the whiteboard with the eraser."]})
    policy.config.check_task = False
    try:
        policy.reset()
        with pytest.warns(UserWarning, match=r"check_task=false: .* set control_fps"):
            policy.select_action({**obs, "task": ["Wipe the blue S off the whiteboard with the eraser."]})
    finally:
        policy.config.check_task = True


def test_control_fps_sets_the_rate_at_which_the_skill_advances(press_checkpoint):
    """A skill fitted at 20 fps, called at 40 Hz: the 2k-th call is where the k-th call at 20 Hz was
    (a real 50 fps demonstration in the 20 Hz sim is the same case, the other way round)."""
    import torch

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    obs = _scene()
    plain = ForceMapPolicy.from_pretrained(press_checkpoint)
    fast = ForceMapPolicy.from_pretrained(press_checkpoint)
    fast.config.control_fps = 40.0
    assert plain.clock_hz == 20.0 and fast.clock_hz == 40.0
    plain.reset(), fast.reset()
    a = torch.stack([plain.select_action(obs) for _ in range(30)])
    b = torch.stack([fast.select_action(obs) for _ in range(60)])
    torch.testing.assert_close(b[::2], a, rtol=0, atol=1e-6)
    assert not torch.allclose(b[:30], a, atol=1e-4)  # the first 30 calls cover only half the time
    fast.reset()
    np.testing.assert_allclose(
        fast.predict_action_chunk(obs)[0, 1].numpy(), b[1, 0].numpy(), atol=1e-6
    )  # chunks follow the same clock
    with pytest.raises(ValueError, match="control_fps: must be a finite number >= 0.001 Hz or None, got 0.0"):
        ForceMapConfig(control_fps=0.0)
    assert "control_fps" in type(plain.config).__dataclass_fields__


def test_a_checkpoint_is_not_refitted_on_another_tasks_dataset(press_checkpoint, press_dataset):
    """``lerobot-train --policy.path=CKPT --dataset.root=datasets/erase`` would re-save the press maps."""
    from lerobot.configs.policies import PreTrainedConfig
    from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy
    from tests.conftest import REPO_ROOT

    cfg = PreTrainedConfig.from_pretrained(press_checkpoint)
    cfg.pretrained_path = press_checkpoint
    ForceMapPolicy(
        cfg, dataset_meta=LeRobotDatasetMetadata("local/press", root=press_dataset)
    )  # same task: fine
    erase = LeRobotDatasetMetadata("local/erase", root=REPO_ROOT / "datasets" / "erase")
    with pytest.raises(
        ValueError, match=r"fitted on demonstrations of \['Press.*holds \['Wipe.*--policy.type=forcemap"
    ):
        ForceMapPolicy(cfg, dataset_meta=erase)


@pytest.mark.parametrize(
    ("field", "value"),
    [("fps", 50.0), ("env_state_names", ["button_x"]), ("dataset_tasks", ["Press the red button."])],
)
def test_a_fitted_field_given_before_the_fit_is_refused(press_dataset, field, value):
    """``lerobot-train --policy.fps=50`` used to be overwritten by the fit without a word."""
    from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    cfg = ForceMapConfig(**{field: value})
    with pytest.raises(
        ValueError,
        match=rf"ForceMapConfig.{field}: must be left at its default .* filled in by the fit .* got",
    ):
        ForceMapPolicy(cfg, dataset_meta=LeRobotDatasetMetadata("local/press", root=press_dataset))


def test_multi_episode_fit_with_dataset_phases(press_dataset, tmp_path):
    import torch

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    pol = fit_and_save(
        press_dataset,
        tmp_path / "multi",
        episodes=[0, 1, 2, 3, 4],
        segments="dataset",
        segment_column="demo_phase",
    )
    assert pol.fit_report.episodes == (0, 1, 2, 3, 4)
    assert pol.config.n_segments == len(pol.fit_report.changepoints[0]) - 1 >= 4
    back = ForceMapPolicy.from_pretrained(tmp_path / "multi")
    assert torch.equal(back.nodes, pol.nodes)


def test_multi_episode_auto_segments_must_agree(press_dataset, tmp_path):
    # different auto segment counts between demonstrations are reported, not silently aligned
    counts = []
    for e in range(4):
        pol = fit_and_save(press_dataset, tmp_path / f"one{e}", episodes=[e])
        counts.append(pol.config.n_segments)
    if len(set(counts)) == 1:  # test_fitting's synthetic single/double press covers the law regardless
        pytest.skip(f"the first 4 demonstrations all segment into {counts[0]} segments")
    a, b = next((i, j) for i in range(4) for j in range(4) if counts[i] != counts[j])
    with pytest.raises(ValueError, match="segment counts differ"):
        fit_and_save(press_dataset, tmp_path / "bad", episodes=[a, b])


def test_forward_rows_and_reduction_are_checked(policy):
    """An (4, 8) action with (2, ...) observations was reshaped to (2, 16) and read as two targets."""
    import torch

    batch = _scene(batch=2)
    batch["action"] = torch.zeros(4, 8)
    with pytest.raises(ValueError, match=r"forward: 'action' has 4 rows, the observations \[2\]"):
        policy.forward(batch)
    batch["action"] = torch.zeros(2, 2)
    with pytest.raises(ValueError, match=r"needs \[x y z ...\] per row, got 2 entries"):
        policy.forward(batch)
    batch["action"] = torch.tensor([[0.5, 0.0, 0.04, 0.0, 1.0, 0.0, 0.0, 1.0]] * 2)
    with pytest.raises(ValueError, match="reduction must be 'mean' or 'none', got 'sum'"):
        policy.forward(batch, reduction="sum")  # silently returned the mean
    wide = {**batch, "observation.environment_state": torch.zeros(2, 7)}
    with pytest.raises(
        ValueError, match=r"'observation.environment_state' has 7 entries, but the policy was fitted on 8"
    ):
        policy.forward(wide)
    assert policy.forward({"action": batch["action"]}, reduction="none")[0].shape == (2,)  # actions alone


def test_odd_tensors_are_read_or_refused_by_name(policy):
    import torch

    obs = _scene()
    policy.reset()
    ref = policy.select_action(obs)
    policy.reset()
    half = {k: v.to(torch.bfloat16) if k == "observation.force" else v for k, v in obs.items()}
    assert torch.equal(policy.select_action(half), ref)  # bfloat16 has no NumPy type: read as float32
    policy.reset()
    meta = {**obs, "observation.ee_pose": torch.empty(1, 7, device="meta")}
    with pytest.raises(ValueError, match="observation 'observation.ee_pose': a tensor on the 'meta' device"):
        policy.select_action(meta)
    policy.reset()
    with pytest.raises(ValueError, match=r"batch 'task': must be .* one per batch row \(1\), got \['press"):
        policy.select_action({**obs, "task": ["press the button", "press the button"]})
    for task in (5, [5], None):  # a bare TypeError (len() of an int) before
        policy.reset()
        if task is None:
            policy.select_action({**obs, "task": task})  # no task asked: nothing to check
            continue
        with pytest.raises(
            ValueError, match=r"batch 'task': must be a string, or a list of strings with one per"
        ):
            policy.select_action({**obs, "task": task})


def test_the_maps_stay_float64_and_load_state_dict_checks_them(press_checkpoint):
    import torch

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    fitted = ForceMapPolicy.from_pretrained(press_checkpoint)
    nodes = fitted.get_buffer("nodes").clone()
    fitted.half()  # cast the maps to float16 silently (0.2 mm), and the saved file failed to load
    assert fitted.get_buffer("nodes").dtype == torch.float64 and torch.equal(
        fitted.get_buffer("nodes"), nodes
    )
    state = fitted.state_dict()
    state["nodes"] = state["nodes"].clone()
    state["nodes"][0, 0] = float("nan")
    with pytest.raises(ValueError, match=r"^load_state_dict: tensor 'nodes' has 1 non-finite value"):
        fitted.load_state_dict(state)  # NaN actions followed
    assert torch.equal(fitted.get_buffer("nodes"), nodes)  # refused before anything was replaced


def test_a_refused_observation_at_a_segment_start_still_reanchors_on_retry(press_checkpoint):
    """The segment counter advanced before the observation was checked: a NaN at a segment start,
    retried with a good observation, skipped that segment's re-anchoring for the rest of the episode."""
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    fitted = ForceMapPolicy.from_pretrained(press_checkpoint)
    starts = np.cumsum([0.0, *fitted.skill.durations])[1:-1]
    anchored = [s + 1 for s, t in enumerate(starts) if fitted.skill.segments[s + 1].anchor]
    assert anchored
    first = int(np.ceil(starts[anchored[0] - 1] * fitted.clock_hz))  # the step that starts the segment
    moved = _scene(button=(0.52, 0.0, 0.027))
    fitted.reset()
    for _ in range(first):
        fitted.select_action(_scene())
    bad = _scene(button=(0.52, 0.0, 0.027))
    bad["observation.environment_state"][0, 0] = float("nan")
    with pytest.raises(
        ValueError, match=r"environment_state': must hold finite values only \(.* batch row 0, entry 0\)"
    ):
        fitted.select_action(bad)
    fitted.select_action(moved)
    assert [e["segment"] for e in fitted.reanchor_log] == [anchored[0]]
    assert fitted.reanchor_log[0]["shift"][0] == pytest.approx(0.02, abs=1e-6)


def test_the_yield_rule_holds_back_the_maps_press_into_a_slanted_force(press_checkpoint):
    """With a steady 10 N reaction 51 degrees off a contact normal that is itself 53 degrees off the
    press's vertical touch-down (the peg's case), the targets in the demonstrated contact are moved back
    along that force from the plain policy's (the map's step into it held back, at most
    contact_yield_max); chunks carry the offset too. With the press's own normal (its touch-down
    along it) nothing is held back."""
    import torch

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    obs = _scene()
    unit = np.array([0.0, 0.6, 0.8])
    pressed = {**obs, "observation.force": torch.tensor([[*(10.0 * unit), 0.0, 0.0, 0.0]])}
    along_n, plain = (ForceMapPolicy.from_pretrained(press_checkpoint) for _ in range(2))
    plain.config.contact_yield = 0.0
    n = int(round(sum(plain.durations.tolist()) * plain.config.fps))
    steps = [obs, obs] + [pressed] * (n - 2)  # the first two observations tare the sensor
    assert along_n.config.contact_yield == 0.25  # the default
    torch.testing.assert_close(
        torch.stack([along_n.select_action(o) for o in steps]),
        torch.stack([plain.select_action(o) for o in steps]),
        rtol=0,
        atol=0,
    )
    ruled, plain = (_tilted(ForceMapPolicy.from_pretrained(press_checkpoint)) for _ in range(2))
    for p in (ruled, plain):
        p.config.approach_speed = 0.0
    plain.config.contact_yield = 0.0
    a = torch.stack([plain.select_action(o) for o in steps])[:, 0, :3].numpy()
    b = torch.stack([ruled.select_action(o) for o in steps])[:, 0, :3].numpy()
    back = (b - a) @ unit
    np.testing.assert_allclose(b - a, back[:, None] * unit, atol=1e-6)  # along the force only
    assert back.min() >= -1e-6 and 1e-3 < back.max() <= ruled.config.contact_yield_max + 1e-6
    k = int(np.argmax(back))  # where the most is held back: the next chunks differ by that offset
    for p in (ruled, plain):
        p.reset()
        for o in steps[: k + 1]:
            p.select_action(o)
    chunks = [p.predict_action_chunk(pressed)[0, 0, :3].numpy() for p in (ruled, plain)]
    np.testing.assert_allclose(chunks[0] - chunks[1], back[k] * unit, atol=1e-6)
