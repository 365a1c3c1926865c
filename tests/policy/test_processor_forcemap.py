"""Pre/post-processors: found by LeRobot's naming convention, identity in SI units, saved with the checkpoint."""

from __future__ import annotations


def _obs():
    import torch

    return {
        "observation.ee_pose": torch.tensor([0.42, 0.01, 0.15, 0.0, 1.0, 0.0, 0.0]),
        "observation.environment_state": torch.tensor([0.5, 0.0, 0.027, 1.0, 0.0, 0.0, 0.0, 0.0]),
        "observation.state": torch.arange(7, dtype=torch.float32),
        "observation.force": torch.tensor([0.0, 0.0, 12.5, 0.0, 0.0, 0.0]),
    }


def test_resolved_by_lerobot_and_identity(press_checkpoint):
    import torch
    from lerobot.policies.factory import make_pre_post_processors

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    policy = ForceMapPolicy.from_pretrained(press_checkpoint)
    pre, post = make_pre_post_processors(policy.config)  # no path: imports processor_forcemap by convention
    names = [type(s).__name__ for s in pre.steps]
    assert names[:3] == [
        "RenameObservationsProcessorStep",
        "AddBatchDimensionProcessorStep",
        "DeviceProcessorStep",
    ]
    out = pre(_obs())
    for k, v in _obs().items():
        torch.testing.assert_close(out[k].reshape(-1), v, rtol=0, atol=0)  # values untouched (SI units)
    assert out["observation.state"].shape == (1, 7)
    # LeRobot batches state / environment_state only; the policy reads the 1-D ee_pose as one row
    policy.reset()
    first = policy.select_action(out)
    assert first.shape == (1, 8)
    # the reproduction starts where the robot is (start re-anchored to observation.ee_pose)
    torch.testing.assert_close(
        first[0, :3].double(), _obs()["observation.ee_pose"][:3].double(), atol=1e-6, rtol=0
    )
    action = torch.tensor([[0.5, 0.0, 0.02, 0.0, 1.0, 0.0, 0.0, 1.0]])
    torch.testing.assert_close(post(action), action, rtol=0, atol=0)


def test_saved_processors_load_with_lerobot_eval_overrides(press_checkpoint):
    import torch
    from lerobot.processor import PolicyProcessorPipeline
    from lerobot.processor.converters import (
        batch_to_transition,
        policy_action_to_transition,
        transition_to_batch,
        transition_to_policy_action,
    )

    pre = PolicyProcessorPipeline.from_pretrained(
        press_checkpoint,
        config_filename="policy_preprocessor.json",
        overrides={
            "device_processor": {"device": "cpu"},
            "rename_observations_processor": {"rename_map": {"observation.wrench": "observation.force"}},
        },
        to_transition=batch_to_transition,
        to_output=transition_to_batch,
    )
    post = PolicyProcessorPipeline.from_pretrained(
        press_checkpoint,
        config_filename="policy_postprocessor.json",
        to_transition=policy_action_to_transition,
        to_output=transition_to_policy_action,
    )
    # the overrides reached the loaded steps: a robot's "wrench" arrives as the policy's force
    obs = _obs()
    obs["observation.wrench"] = obs.pop("observation.force")
    out = pre(obs)
    assert "observation.wrench" not in out
    torch.testing.assert_close(
        out["observation.force"].reshape(-1), _obs()["observation.force"], rtol=0, atol=0
    )
    assert str(pre.steps[2].device) == "cpu"
    action = torch.tensor([[0.5, 0.0, 0.02, 0.0, 1.0, 0.0, 0.0, 1.0]])
    torch.testing.assert_close(post(action), action, rtol=0, atol=0)
