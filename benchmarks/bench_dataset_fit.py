"""Benchmark the dataset-wide fit (``forcemap fit --all-episodes``): episodes per second per core.

    .venv/bin/python -m benchmarks.bench_dataset_fit [--dataset datasets/press] [--episodes 1000]
                                                     [--fit 1000] [--workers 1 2]

Writes a synthetic dataset of ``--episodes`` episodes into a temporary folder with the project's own
writer (``schema.dataset_features`` + ``schema.add_episode`` on ``LeRobotDataset.create``): episode i
is episode ``i % n`` of the shipped ``--dataset`` (its lengths, fps and features: observation state,
pose, force, environment state, action) with every position shifted by a small deterministic offset,
so no two fits are the same. Then fits its first ``--fit`` episodes (``cli.fit_dataset.fit_dataset``:
read, segment, fit, save one checkpoint per episode) once per ``--workers`` value: 1 runs in this
process, more on a process pool. Imports and the pool's start are paid by a warm-up before the clock
starts. Prints one row per worker count: wall time, episodes/s, episodes/s per worker, speed-up over
the first row.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from lerobot_forcemap._validation import check_int, check_int_list, fail, usage_errors
from lerobot_forcemap.data.schema import require_dataset_root

REPO = Path(__file__).resolve().parents[1]
#: the largest offset (m) added to the positions of a synthetic episode
SHIFT_M = 0.01


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", type=Path, default=REPO / "datasets" / "press")
    parser.add_argument("--episodes", type=int, default=1000, help="episodes of the synthetic dataset")
    parser.add_argument("--fit", type=int, default=None, help="episodes fitted per run (default: all)")
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="worker counts to time")
    parser.add_argument(
        "--keep", type=Path, default=None,
        help="write the synthetic dataset to this folder and keep it; a later run with the same folder and "
        "--episodes reuses it (writing is LeRobot's per-episode save, slower than the fits)",
    )  # fmt: skip
    args = parser.parse_args(argv)
    with usage_errors(parser):
        dataset = require_dataset_root(args.dataset, "--dataset")
        check_int("--episodes", args.episodes, low=1)
        args.fit = args.episodes if args.fit is None else args.fit
        check_int("--fit", args.fit, low=1, high=args.episodes)
        check_int_list("--workers", args.workers, low=1)
    with tempfile.TemporaryDirectory() as tmp:
        synthetic = args.keep or Path(tmp) / "synthetic"
        with usage_errors(parser):
            frames = synthetic_dataset(dataset, synthetic, args.episodes)
        rows = [(w, time_fit(synthetic, Path(tmp) / f"lib_{w}", args.fit, w)) for w in args.workers]
    _print_table(rows, args, dataset, frames)
    return 0


def synthetic_dataset(source: Path, out: Path, n_episodes: int) -> int:
    """The synthetic dataset at ``out``: written, or reused when ``out`` holds one of ``n_episodes``
    episodes; returns its number of frames."""
    if (out / "meta" / "info.json").is_file():
        from lerobot_forcemap.data.reader import read_meta

        meta = read_meta(out)
        if meta.total_episodes != n_episodes:
            fail(
                "--keep",
                f"hold a synthetic dataset of {n_episodes} episodes (--episodes)",
                meta.total_episodes,
            )
        frames = sum(e.length for e in meta.episodes)
        print(f"reusing {n_episodes} episodes ({frames} frames) in {out}", file=sys.stderr)
        return frames
    t0 = time.perf_counter()
    frames = write_synthetic(source, out, n_episodes)
    print(
        f"wrote {n_episodes} episodes ({frames} frames, from {source.name}) in {time.perf_counter() - t0:.1f} s",
        file=sys.stderr,
    )
    return frames


def write_synthetic(source: Path, out: Path, n_episodes: int) -> int:
    """The synthetic dataset (module docstring) at ``out``; returns its number of frames."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset

    import datasets
    from lerobot_forcemap import layout
    from lerobot_forcemap.data.reader import read_episodes, read_meta
    from lerobot_forcemap.data.schema import add_episode, dataset_features

    meta = read_meta(source)
    keys = [layout.OBS_STATE, layout.OBS_EE_POSE, layout.OBS_FORCE, layout.OBS_ENV_STATE, layout.ACTION]
    shipped = [read_episodes(meta, [e], [*keys, "task_index"]) for e in range(meta.total_episodes)]
    features = dataset_features(
        meta.features[layout.OBS_STATE]["names"], env_state_names=meta.features[layout.OBS_ENV_STATE]["names"]
    )
    ds = LeRobotDataset.create(
        f"local/{out.name}", fps=int(meta.fps), features=features, root=out, use_videos=False
    )
    datasets.disable_progress_bars()  # one "Map" bar per saved episode
    rng = np.random.default_rng(0)
    frames = 0
    for i in range(n_episodes):
        ep = shipped[i % len(shipped)]
        arrays = {k: np.array(ep.columns[k], dtype=np.float64) for k in keys}
        shift = rng.uniform(-SHIFT_M, SHIFT_M, 3)
        arrays[layout.OBS_EE_POSE][:, layout.ACTION_POS] += shift
        arrays[layout.ACTION][:, layout.ACTION_POS] += shift
        frames += add_episode(ds, arrays, ep.tasks[0], episode=i)
    ds.finalize()
    return frames


def _warm(_: int) -> None:
    """A warm-up job: the fit's imports, and long enough that every worker of the pool takes one."""
    import lerobot.policies.factory  # noqa: F401

    import lerobot_forcemap.cli.fit  # noqa: F401
    import lerobot_policy_forcemap  # noqa: F401

    time.sleep(1.0)


def time_fit(dataset: Path, out: Path, n_fit: int, workers: int) -> float:
    """Wall seconds of fitting the first ``n_fit`` episodes with ``workers`` workers (warm)."""
    from lerobot_forcemap.cli.fit_dataset import fit_dataset
    from lerobot_forcemap.executor import make_executor

    with make_executor(workers) as ex:
        ex.map(_warm, range(workers), progress=False)
        t0 = time.perf_counter()
        index = fit_dataset(dataset, out, ex, episodes=list(range(n_fit)), progress=False)
        wall = time.perf_counter() - t0
    bad = n_fit - index["counts"]["ok"]
    print(f"{workers} worker(s): {n_fit} episodes in {wall:.1f} s ({bad} not fitted)", file=sys.stderr)
    return wall


def _print_table(rows: list[tuple[int, float]], args, dataset: Path, frames: int) -> None:
    print(
        f"synthetic dataset: {args.episodes} episodes, {frames} frames ({frames / args.episodes:.0f} per "
        f"episode, from {dataset.name}); {args.fit} fitted per run\n"
    )
    print("| workers | wall s | episodes/s | episodes/s per worker | speed-up |")
    print("|---|---|---|---|---|")
    base = args.fit / rows[0][1]
    for workers, wall in rows:
        rate = args.fit / wall
        print(f"| {workers} | {wall:.1f} | {rate:.2f} | {rate / workers:.2f} | {rate / base:.2f}x |")


if __name__ == "__main__":
    sys.exit(main())
