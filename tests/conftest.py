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

REPO_ROOT = Path(__file__).resolve().parents[1]


def find_shared_data() -> Path | None:
    """The real UR5e / GBTI recordings: $FORCEMAP_SHARED_DATA, else ../shared/data next to the checkout."""
    candidates = [os.environ.get("FORCEMAP_SHARED_DATA"), REPO_ROOT.parent / "shared" / "data", "/work/shared/data"]
    for c in candidates:
        if c and (Path(c) / "ur5e").is_dir():
            return Path(c)
    return None


@pytest.fixture(scope="session")
def shared_data() -> Path:
    path = find_shared_data()
    if path is None:
        pytest.skip("real recordings not found (set FORCEMAP_SHARED_DATA or place them in ../shared/data)")
    return path
