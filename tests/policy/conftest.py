"""Fixtures of the policy tests: the press demonstrations and a fitted one-shot checkpoint."""

from __future__ import annotations

from pathlib import Path

import pytest

from tests.conftest import REPO_ROOT

SHIPPED_PRESS = REPO_ROOT / "datasets" / "press"


def fit_and_save(dataset: Path, out: Path, **config_kwargs):
    """The lerobot-train code path in-process: make_policy(config, ds_meta) fits; save policy + processors."""
    from lerobot.datasets.lerobot_dataset import LeRobotDatasetMetadata
    from lerobot.policies.factory import make_policy, make_pre_post_processors

    from lerobot_policy_forcemap.configuration_forcemap import ForceMapConfig

    cfg = ForceMapConfig(device="cpu", **config_kwargs)
    meta = LeRobotDatasetMetadata("local/press", root=dataset)
    policy = make_policy(cfg, ds_meta=meta)
    pre, post = make_pre_post_processors(cfg, dataset_stats=meta.stats)
    out.mkdir(parents=True, exist_ok=True)
    policy.save_pretrained(out)
    pre.save_pretrained(out)
    post.save_pretrained(out)
    return policy


@pytest.fixture(scope="session")
def press_dataset(tmp_path_factory) -> Path:
    """The shipped press demonstrations (datasets/press), else 5 freshly recorded ones."""
    if (SHIPPED_PRESS / "meta" / "info.json").is_file():
        return SHIPPED_PRESS
    from lerobot_forcemap.envs.record import record_demonstrations

    out = tmp_path_factory.mktemp("press") / "press"
    record_demonstrations("press", 5, 0, out, progress=False)
    return out


@pytest.fixture(scope="session")
def press_checkpoint(press_dataset, tmp_path_factory) -> Path:
    """A one-shot (episode 0) forcemap checkpoint with default settings."""
    out = tmp_path_factory.mktemp("ckpt") / "pretrained_model"
    fit_and_save(press_dataset, out)
    return out
