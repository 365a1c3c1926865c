"""The benchmarks (``python -m benchmarks.<name>``) and experiments (``python -m experiments.<name>``)
still run, at their smallest size.

They are not timed here (timings are what the scripts report, never test assertions); this only keeps
them from rotting when a library signature changes. The full runs are marked slow; the checks that a
bad flag value gives one ``argparse`` error line (exit 2, no traceback) are quick and run by default.
"""

from __future__ import annotations

import os
import subprocess
import sys

import pytest

from lerobot_forcemap.shared_data import find_shared_data
from tests.conftest import REPO_ROOT

#: script -> (arguments, a line fragment its output must hold, the real recording it reads or None)
RUNS = {
    "bench_structure": ([], "functions over 60 lines", None),
    "bench_dataset_fit": (["--episodes", "4", "--fit", "2"], "| 2 |", None),
    "bench_policy_fit": (["--runs", "1", "--no-train"], "one-shot total", None),
    "bench_fit_e2e": (["--runs", "1", "--episodes", "1", "--datasets", "datasets/press"], "| press | ", None),
    "bench_clarabel_polish": (
        ["--repeats", "1", "--episodes", "1"],
        "| demo at rest, box 1 cm above | 1 |",
        None,
    ),
    "bench_segmentation": (["--runs", "20"], "target: default segment_streams", "ur5e/three_button_press.h5"),
    "bench_envs": (["--episodes", "1", "--no-render"], "| grasp_flip |", None),
    "bench_env_step": (["--runs", "1", "--episodes", "1", "--tasks", "press"], "| press | ", None),
    "env_tracking_error": (["--steps", "80"], "| (0.7, -0.3, 0.05) |", None),
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
    # the same pooled score as the press ablation row "ours" in results/experiments.md
    "segmentation_vs_phases": (["--tasks", "press"], "pooled precision 0.80, recall 0.40, F1 0.53", None),
}


def _command(script: str) -> list[str]:
    """How a script is run: a module of ``benchmarks`` or of ``experiments``."""
    package = "benchmarks" if script.startswith("bench_") else "experiments"
    return [sys.executable, "-m", f"{package}.{script}"]


def _env() -> dict[str, str]:
    return {**os.environ, "OPENBLAS_NUM_THREADS": "1", "HF_HUB_OFFLINE": "1", "MUJOCO_GL": "egl"}


@pytest.mark.slow
@pytest.mark.parametrize("script", sorted(RUNS))
def test_script_runs(script, tmp_path):
    args, expected, recording = RUNS[script]
    if recording is not None and find_shared_data(recording) is None:
        pytest.skip(f"{recording} not found (set FORCEMAP_SHARED_DATA)")
    env = _env()
    run = subprocess.run(
        [*_command(script), *(a.format(tmp=tmp_path) for a in args)],
        cwd=REPO_ROOT,
        env=env,
        capture_output=True,
        text=True,
        timeout=600,
    )
    assert run.returncode == 0, f"{script} failed:\n{run.stdout[-2000:]}\n{run.stderr[-4000:]}"
    assert expected in run.stdout


#: script, arguments, a fragment of the one error line (all rejected right after parsing, before any work)
BAD_FLAGS = [
    ("bench_clarabel_polish", ["--episodes", "0"], "--episodes: must be an integer >= 1, got 0"),
    ("bench_elmap", ["--repeats", "0"], "--repeats: must be an integer >= 1, got 0"),
    ("bench_elmap", ["--baseline-repeats", "0"], "--baseline-repeats: must be an integer >= 1, got 0"),
    ("bench_envs", ["--episodes", "0"], "--episodes: must be an integer >= 1, got 0"),
    ("bench_env_step", ["--runs", "0"], "--runs: must be an integer >= 1, got 0"),
    ("bench_env_step", ["--block", "0"], "--block: must be an integer >= 1, got 0"),
    ("env_tracking_error", ["--steps", "0"], "--steps: must be an integer >= 1, got 0"),
    ("bench_envs", ["--cores", "-1"], "--cores: must be an integer >= 0 and <= "),
    (
        "bench_dataset_fit",
        ["--fit", "5", "--episodes", "4"],
        "--fit: must be an integer >= 1 and <= 4, got 5",
    ),
    ("bench_policy_fit", ["--runs", "0"], "--runs: must be an integer >= 1, got 0"),
    ("bench_policy_fit", ["--dataset", "{tmp}"], "not a LeRobot dataset"),
    ("bench_fit_e2e", ["--runs", "0"], "--runs: must be an integer >= 1, got 0"),
    ("bench_fit_e2e", ["--baseline", "{tmp}"], "not a checkout of the project"),
    ("bench_fit_e2e", ["--datasets", "{tmp}"], "not a LeRobot dataset"),
    ("bench_segmentation", ["--runs", "0"], "--runs: must be an integer >= 1, got 0"),
    ("bench_segmentation", ["--data", "{tmp}/gbti_like.h5"], "not a UR5e recorder file"),
    ("elmap_realdata", ["--n-nodes", "1"], "--n-nodes: must be an integer >= 2, got 1"),
    ("gbti_segmentation", ["--limit", "0", "--out", "{tmp}"], "--limit: must be an integer >= 1, got 0"),
    ("gbti_segmentation", ["--seeds", "0", "--out", "{tmp}"], "--seeds: must be an integer >= 1, got 0"),
    ("grasp_unseen_objects", ["--seeds", "0"], "--seeds: must be an integer >= 1, got 0"),
    ("segmentation_vs_phases", ["--datasets", "{tmp}"], "not a LeRobot dataset"),
]


def _run_bad(script: str, args: list[str]) -> subprocess.CompletedProcess:
    return subprocess.run(
        [*_command(script), *args],
        cwd=REPO_ROOT,
        env=_env(),
        capture_output=True,
        text=True,
        timeout=60,
    )


@pytest.mark.parametrize(
    ("script", "args", "expected"), BAD_FLAGS, ids=lambda v: " ".join(v) if isinstance(v, list) else None
)
def test_bad_flag_is_one_usage_error(script, args, expected, tmp_path):
    import h5py

    with h5py.File(
        tmp_path / "gbti_like.h5", "w"
    ) as f:  # a GBTI-style file: object groups, no recorder groups
        f.create_group("Plate/User1/Position1")
    run = _run_bad(script, [a.format(tmp=tmp_path) for a in args])
    assert run.returncode == 2, f"{script} {args}: rc {run.returncode}\n{run.stderr[-2000:]}"
    assert "Traceback" not in run.stderr, run.stderr[-2000:]
    assert expected in run.stderr.strip().splitlines()[-1], run.stderr[-2000:]


def test_gbti_unknown_figure_demo_lists_the_keys(tmp_path):
    if find_shared_data("gbti/Grasping_Demos.h5") is None:
        pytest.skip("gbti/Grasping_Demos.h5 not found (set FORCEMAP_SHARED_DATA)")
    run = _run_bad("gbti_segmentation", ["--figure-demo", "nope", "--out", str(tmp_path)])
    assert run.returncode == 2, run.stderr[-2000:]
    last = run.stderr.strip().splitlines()[-1]
    assert "--figure-demo 'nope'" in last and "Plate/User1/Position1" in last, last
    assert not any(tmp_path.iterdir()), "nothing is written before the flags are checked"
