"""Shared test set-up: offline Hub, headless MuJoCo, single-threaded BLAS, the real-data fixture, and the
press demonstrations with a fitted one-shot checkpoint."""

from __future__ import annotations

import os

# Before anything imports huggingface_hub, mujoco or numpy.
os.environ["HF_HUB_OFFLINE"] = "1"
os.environ["HF_DATASETS_OFFLINE"] = "1"
os.environ.setdefault("MUJOCO_GL", "egl")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("OMP_NUM_THREADS", "1")

from pathlib import Path  # noqa: E402

import pytest  # noqa: E402

from lerobot_forcemap.shared_data import find_shared_data  # noqa: E402

REPO_ROOT = Path(__file__).resolve().parents[1]
SHIPPED_PRESS = REPO_ROOT / "datasets" / "press"


@pytest.fixture(scope="session")
def shared_data() -> Path:
    path = find_shared_data()
    if path is None:
        pytest.skip("real recordings not found (set FORCEMAP_SHARED_DATA or place them in ../shared/data)")
    return path


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
