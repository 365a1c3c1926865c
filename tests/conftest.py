"""Shared test set-up: offline Hub, headless MuJoCo, single-threaded BLAS, and the real-data fixture."""

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


@pytest.fixture(scope="session")
def shared_data() -> Path:
    path = find_shared_data()
    if path is None:
        pytest.skip("real recordings not found (set FORCEMAP_SHARED_DATA or place them in ../shared/data)")
    return path
