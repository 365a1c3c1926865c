"""Benchmark `segment_streams` on the real 4099-sample three-button UR5e demo with 5 streams.

    .venv/bin/python -m benchmarks.bench_segmentation [--runs 50] [--loop-runs 20] [--plot PNG] [--data H5]

Streams (interpolated onto the joint time base where a group's times differ): joints (6, unwrapped),
Cartesian position (3), wrist force (3), wrist torque (3), gripper (1); thresholds as the authors'
UR5e script (torque like force), weights force-heavy as the paper's custom row. For each
configuration it times `segment_streams` (median of --runs) and, in the same run, the per-sample-loop
reference of the same algorithm (`lerobot_forcemap.segmentation.reference`, median of --loop-runs),
checks that both give the same changepoints and keypoints, and prints a markdown table.
"""

from __future__ import annotations

import argparse
import gc
import os
import time
from collections.abc import Callable
from pathlib import Path

import h5py
import numpy as np

from lerobot_forcemap._validation import check_int, usage_errors
from lerobot_forcemap.segmentation import (
    SegmentationConfig,
    Stream,
    analyse_stream,
    auto_weights,
    combine_pmfs,
    reweighted,
    segment_streams,
    stream_pmf,
)
from lerobot_forcemap.segmentation.reference import loop_segment_streams
from lerobot_forcemap.shared_data import find_shared_data

TARGET_MS = 5.0
THRESHOLDS = {"joints": 0.20, "cartesian": 0.25, "wrist_force": 0.15, "wrist_torque": 0.15, "gripper": 0.10}
WEIGHTS = {"joints": 0.10, "cartesian": 0.10, "wrist_force": 0.35, "wrist_torque": 0.35, "gripper": 0.10}


#: the recording, relative to the real-data folder (``lerobot_forcemap.shared_data``)
DEMO = "ur5e/three_button_press.h5"


def default_demo_path() -> Path | None:
    """The recording in the real-data folder, None when that folder is not found."""
    root = find_shared_data(DEMO)
    return root / DEMO if root is not None else None


def seconds(rows: np.ndarray) -> np.ndarray:
    """Recorder times are [sec, nsec] rows."""
    return rows[:, 0] + rows[:, 1] * 1e-9


#: the datasets of a UR5e recorder file (``ur5e/*.h5``) this benchmark reads
RECORDER_DATASETS = (
    "joint_state_info/joint_time",
    "joint_state_info/joint_positions",
    "transform_info/transform_positions",
    "transform_info/transform_time",
    "wrench_info/wrench_force",
    "wrench_info/wrench_torque",
    "wrench_info/wrench_time",
    "gripper_info/gripper_position",
    "gripper_info/gripper_time",
)


def load_streams(path: Path) -> list[Stream]:
    """The five streams of a UR5e recorder file; ValueError naming the file and what it lacks otherwise."""
    try:
        f = h5py.File(path, "r")
    except OSError as err:
        raise ValueError(f"{path}: not a readable HDF5 file ({err})") from err
    with f:
        missing = [k for k in RECORDER_DATASETS if k not in f]
        if missing:
            top = sorted(f.keys())
            raise ValueError(
                f"{path}: not a UR5e recorder file like ur5e/three_button_press.h5: it lacks "
                f"{', '.join(missing[:3])}{' ...' if len(missing) > 3 else ''} (top-level groups found: "
                f"{', '.join(top[:6]) + (' ...' if len(top) > 6 else '') if top else 'none'})"
            )
        return _read_streams(f)


def _read_streams(f: h5py.File) -> list[Stream]:
    t = seconds(f["joint_state_info/joint_time"][()])

    def on_joint_time(values_key: str, time_key: str) -> np.ndarray:
        values = f[values_key][()]
        ts = seconds(f[time_key][()])
        if ts.shape == t.shape and np.allclose(ts, t, rtol=0, atol=1e-3):
            return values
        return np.stack([np.interp(t, ts, column) for column in values.T], axis=1)

    values = {
        "joints": np.unwrap(f["joint_state_info/joint_positions"][()], axis=0),
        "cartesian": on_joint_time("transform_info/transform_positions", "transform_info/transform_time"),
        "wrist_force": on_joint_time("wrench_info/wrench_force", "wrench_info/wrench_time"),
        "wrist_torque": on_joint_time("wrench_info/wrench_torque", "wrench_info/wrench_time"),
        "gripper": on_joint_time("gripper_info/gripper_position", "gripper_info/gripper_time"),
    }
    t = t - t[0]
    return [Stream(k, v, t, weight=WEIGHTS[k], threshold=THRESHOLDS[k]) for k, v in values.items()]


def median_ms(fn: Callable[[], object], runs: int) -> tuple[float, float, float]:
    """(median, 25th, 75th percentile) wall time in ms over `runs` calls after one warm-up call."""
    fn()
    times = []
    gc.collect()
    for _ in range(runs):
        t0 = time.perf_counter()
        fn()
        times.append((time.perf_counter() - t0) * 1e3)
    q25, q50, q75 = np.percentile(times, [25, 50, 75])
    return float(q50), float(q25), float(q75)


def stage_breakdown(streams: list[Stream], config: SegmentationConfig, runs: int) -> list[tuple[str, float]]:
    n = streams[0].n_frames
    found = [analyse_stream(s, config) for s in streams]
    pmfs = np.array([stream_pmf(f.keypoints, n, config.sigma_frames, config.floor)[0] for f in found])
    floors = np.array([stream_pmf(f.keypoints, n, config.sigma_frames, config.floor)[1] for f in found])
    weights = np.array([s.weight for s in streams])
    return [
        (
            "keypoints, 5 streams (derivative, moving average, runs)",
            median_ms(lambda: [analyse_stream(s, config) for s in streams], runs)[0],
        ),
        (
            "stream pmfs",
            median_ms(
                lambda: [stream_pmf(f.keypoints, n, config.sigma_frames, config.floor) for f in found], runs
            )[0],
        ),
        ("combination", median_ms(lambda: combine_pmfs(pmfs, floors, weights, config.mode), runs)[0]),
    ]


def plot(streams: list[Stream], seg, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(len(streams) + 1, 1, figsize=(11, 2 * (len(streams) + 1)), sharex=True)
    for ax, s in zip(axes, streams, strict=False):
        ax.plot(s.values, lw=0.8)
        ax.set_ylabel(f"{s.name}\nv={s.weight:g}", fontsize=8)
        for k in seg.keypoints[s.name]:
            ax.axvline(k, color="r", ls="--", lw=0.8)
    axes[-1].plot(seg.pmf, color="k")
    axes[-1].axhline(seg.floor_level * seg.config.peak_ratio, color="grey", ls=":", lw=0.8)
    axes[-1].set_ylabel("combined pmf", fontsize=8)
    for ax in axes:
        for c in seg.changepoints:
            ax.axvline(c, color="b", lw=0.6)
    axes[-1].set_xlabel("frame")
    fig.suptitle("three_button_press: keypoints (red), changepoints (blue)")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=90)


#: the configurations timed against the loop reference
CONFIGS = {
    "default: geometric, peaks, savgol": SegmentationConfig(),
    "product, sample (paper), savgol": SegmentationConfig(mode="product", changepoints="sample", seed=0),
    "linear, peaks, savgol": SegmentationConfig(mode="linear"),
    "geometric, peaks, difference (authors' derivative)": SegmentationConfig(derivative="difference"),
}


def parse_args(argv: list[str] | None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--data", type=Path, default=None, help=f"{DEMO} (default: in the real-data folder)")
    parser.add_argument(
        "--runs", type=int, default=50, help="timed runs of segment_streams and of each stage (>= 1)"
    )
    parser.add_argument(
        "--loop-runs", type=int, default=20, help="timed runs of the per-sample loop reference (>= 1)"
    )
    parser.add_argument(
        "--plot", type=Path, default=None, help="write a PNG of the default segmentation here"
    )
    args = parser.parse_args(argv)
    with usage_errors(parser):
        check_int("--runs", args.runs, low=1)
        check_int("--loop-runs", args.loop_runs, low=1)
        args.data = args.data or default_demo_path()
        if args.data is None or not args.data.is_file():
            raise ValueError(
                f"--data {args.data or DEMO}: not found (set FORCEMAP_SHARED_DATA or pass --data)"
            )
        try:
            args.streams = load_streams(args.data)
        except ValueError as err:
            raise ValueError(f"--data {err}") from None
    return args


def time_configurations(streams: list[Stream], args: argparse.Namespace) -> float:
    """The table of :data:`CONFIGS` (vectorised against the loop, same result); returns the default's ms."""
    print(
        "| configuration | segment_streams median ms (IQR) | per-sample loop median ms | loop / vectorised | same result | segments |"
    )
    print("|---|---|---|---|---|---|")
    default_ms = None
    for label, config in CONFIGS.items():
        fast = segment_streams(streams, config)
        ref = loop_segment_streams(streams, config)
        same = np.array_equal(fast.changepoints, ref["changepoints"]) and all(
            fast.keypoints[k].tolist() == ref["keypoints"][k] for k in fast.keypoints
        )
        ms, q25, q75 = median_ms(lambda c=config: segment_streams(streams, c), args.runs)
        loop_ms, _, _ = median_ms(lambda c=config: loop_segment_streams(streams, c), args.loop_runs)
        default_ms = ms if default_ms is None else default_ms
        print(
            f"| {label} | {ms:.2f} ({q25:.2f}–{q75:.2f}) | {loop_ms:.0f} | {loop_ms / ms:.0f}x | {'yes' if same else 'NO'} | {fast.n_segments} |"
        )
    return default_ms


def print_weights(streams: list[Stream], runs: int) -> None:
    """Hand weights against ``auto_weights``, and the changepoints of both."""
    hand = segment_streams(streams, SegmentationConfig())
    auto = auto_weights(streams, SegmentationConfig())
    auto_seg = segment_streams(reweighted(streams, auto), SegmentationConfig())
    print(
        "\nWeights (default configuration): hand (paper-style, force-heavy) vs auto_weights (jerk contrast)\n"
    )
    print("| stream | hand | auto |")
    print("|---|---|---|")
    for s in streams:
        print(f"| {s.name} | {s.weight:.2f} | {auto[s.name]:.3f} |")
    print(f"\nchangepoints, hand weights: {hand.changepoints.tolist()}")
    print(f"changepoints, auto weights: {auto_seg.changepoints.tolist()}")
    auto_ms = median_ms(lambda: auto_weights(streams, SegmentationConfig()), runs)[0]
    print(f"auto_weights: {auto_ms:.2f} ms median")


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    streams = args.streams
    n = streams[0].n_frames
    print(
        f"demo: {args.data.name}, {n} samples, {len(streams)} streams "
        f"({', '.join(f'{s.name}:{s.values.shape[1]}' for s in streams)}); "
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')}; "
        f"median of {args.runs} runs (vectorised) / {args.loop_runs} runs (loop)\n"
    )
    default_ms = time_configurations(streams, args)
    print("\nStages of the default configuration (median ms):\n")
    print("| stage | ms |")
    print("|---|---|")
    for stage, ms in stage_breakdown(streams, SegmentationConfig(), args.runs):
        print(f"| {stage} | {ms:.2f} |")
    print_weights(streams, args.runs)
    verdict = "PASS" if default_ms < TARGET_MS else "FAIL"
    print(
        f"\ntarget: default segment_streams under {TARGET_MS:.0f} ms median -> {default_ms:.2f} ms, {verdict}"
    )
    if args.plot is not None:
        plot(streams, segment_streams(streams, SegmentationConfig()), args.plot)
        print(f"figure: {args.plot}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
