"""The benchmark and experiment scripts under ``scripts/`` still run, at their smallest size.

They are not timed here (timings are what the scripts report, never test assertions); this only keeps
them from rotting when a library signature changes (a changed return value once broke
``bench_policy_fit.py`` without any test noticing).
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from lerobot_forcemap.shared_data import find_shared_data
from tests.conftest import REPO_ROOT

pytestmark = pytest.mark.slow

#: script -> (arguments, a line fragment its output must hold, the real recording it reads or None)
RUNS = {
    "bench_policy_fit": (["--runs", "1", "--no-train"], "one-shot total", None),
    "bench_segmentation": (["--runs", "20"], "target: default segment_streams", "ur5e/three_button_press.h5"),
    "bench_envs": (["--episodes", "1", "--no-render"], "| grasp_flip |", None),
    "bench_elmap": (
        ["--repeats", "1", "--baseline-repeats", "1", "--quick"],
        "| fold | 2730 | 100 | yes |",
        None,
    ),
    "elmap_realdata": (
        ["--out", "{tmp}"],
        "normal reaction, k = 2000 N/m",
        "ur5e/erase_2024-09-09_153311.h5",
    ),
    "gbti_segmentation": (
        ["--limit", "2", "--seeds", "1", "--out", "{tmp}"],
        "segment_streams calls",
        "gbti/Grasping_Demos.h5",
    ),
    "grasp_unseen_objects": (["--seeds", "1"], "| grasp_flip | banana |", None),
}


@pytest.mark.parametrize("script", sorted(RUNS))
def test_script_runs(script, tmp_path):
    args, expected, recording = RUNS[script]
    if recording is not None and find_shared_data(recording) is None:
        pytest.skip(f"{recording} not found (set FORCEMAP_SHARED_DATA)")
    env = {**os.environ, "OPENBLAS_NUM_THREADS": "1", "HF_HUB_OFFLINE": "1", "MUJOCO_GL": "egl"}
    run = subprocess.run(
        [
            sys.executable,
            str(REPO_ROOT / "scripts" / f"{script}.py"),
            *(a.format(tmp=tmp_path) for a in args),
        ],
        cwd=REPO_ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, f"{script} failed:\n{run.stdout[-2000:]}\n{run.stderr[-4000:]}"
    assert expected in run.stdout
