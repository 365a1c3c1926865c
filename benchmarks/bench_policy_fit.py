"""Benchmark the forcemap policy's one-shot fit: dataset on disk -> saved checkpoint (imports excluded).

    .venv/bin/python -m benchmarks.bench_policy_fit [--dataset datasets/press] [--runs 9] [--no-train]

Times (median of --runs, after one warm-up run that also pays every import):
- total: ``forcemap fit``'s code path, i.e. ``lerobot-train --policy.type=forcemap --steps=1`` without
  its data loader / optimiser: the dataset's metadata (``lerobot_forcemap.data.reader.read_meta``) +
  ``make_policy`` (reads the episode, segments, fits one arm and one gripper map per segment) +
  processors + ``save_pretrained`` of all files;
- reading episode 0 alone (``load_episodes``: the reader's metadata and columns, into arrays): timed in
  the same loop as the total, alternating (read, fit, read, fit, ...) so that both see the same load;
- the total's other parts: metadata, segmentation + maps (``fit_skill``: the compute), saving.
  Every row is also given as a multiple of the compute: what reading and saving add on top of it;
- the same total for a fit on all the dataset's episodes (``meta/info.json`` ``total_episodes``;
  ``segments=dataset`` on the recorder's ``demo_phase``; skipped, with a note, when the dataset lacks it).
The repo id is ``local/<dataset folder name>``. With ``--no-train`` omitted, one real
``lerobot-train --steps=1`` subprocess is timed too (imports included), for scale. Target: total < 1 s.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from lerobot_forcemap._validation import check_int, usage_errors
from lerobot_forcemap.data.schema import require_dataset_root

REPO = Path(__file__).resolve().parents[1]
TARGET_S = 1.0
#: the recorder's phase column, for the every-episode fit
SEGMENT_COLUMN = "demo_phase"


def median_ms(fn, runs: int, label: str = "") -> tuple[float, object]:
    times, out = [], None
    if label:  # progress on stderr: the whole script takes ~40 s
        print(f"timing {label} ({runs} runs)", file=sys.stderr, flush=True)
    for _ in range(runs):
        t0 = time.perf_counter()
        out = fn()
        times.append(time.perf_counter() - t0)
    return 1e3 * statistics.median(times), out


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--dataset", default=str(REPO / "datasets" / "press"))
    parser.add_argument("--runs", type=int, default=9, help="timed runs of each step (>= 1)")
    parser.add_argument("--no-train", action="store_true", help="skip the lerobot-train subprocess")
    args = parser.parse_args(argv)
    with usage_errors(parser):
        check_int("--runs", args.runs, low=1)
        dataset = require_dataset_root(args.dataset, "--dataset")

    t_import = time.perf_counter()
    # timed apart (excluded from the figures): the modules the timings use, imported once here
    import lerobot.datasets.lerobot_dataset  # noqa: F401

    import lerobot_forcemap.cli.fit  # noqa: F401
    import lerobot_policy_forcemap.modeling_forcemap  # noqa: F401
    from lerobot_forcemap.lerobot_logs import quiet_torchcodec_warning

    t_import = time.perf_counter() - t_import
    quiet_torchcodec_warning()
    with tempfile.TemporaryDirectory(prefix="bench_policy_fit_") as tmp_dir:
        return _bench(args, dataset, Path(tmp_dir), t_import)


def _bench(args, dataset: Path, tmp: Path, t_import: float) -> int:
    """Every timing (module docstring), then the table."""
    from lerobot_forcemap.cli.fit import fit_policy

    repo_id = f"local/{dataset.resolve().name}"
    info = json.loads((dataset / "meta" / "info.json").read_text())
    n_episodes = int(info["total_episodes"])
    print("warm-up fit (imports, caches)", file=sys.stderr, flush=True)
    fit_policy(dataset, tmp / "warmup", repo_id=repo_id, overwrite=True)
    read_ms, total, loaded, res = _fit_against_reading(dataset, repo_id, tmp, args.runs)
    rows, fit_ms, report = _parts(dataset, repo_id, tmp, args.runs, total, read_ms, loaded, res)
    notes: list[str] = []
    total_all = _all_episodes(dataset, repo_id, tmp, args.runs, n_episodes, set(info["features"]))
    if total_all is None:
        notes.append(
            f"skipped the {n_episodes}-episode fit (segments=dataset): the dataset has no '{SEGMENT_COLUMN}' column"
        )
    else:
        rows.append((f"{n_episodes}-episode fit (segments=dataset), dataset -> checkpoint", total_all))
        rows.append((f"  per episode ({n_episodes}-episode fit / {n_episodes})", total_all / n_episodes))
    episodes, _, fps, _ = loaded
    print(
        f"dataset {dataset} ({repo_id}, {n_episodes} episodes): episode 0 has {episodes[0].n_frames} frames "
        f"at {fps:g} fps; segments {report.changepoints[0].tolist()}; imports {t_import:.1f} s (excluded)"
    )
    print(f"median of {args.runs} runs, OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}\n")
    print("| step | median ms | ratio to the compute (fit_skill) |")
    print("|---|---|---|")
    for name, ms in rows:
        print(f"| {name} | {ms:.1f} | {ms / fit_ms:.2f} |")
    if not args.no_train:
        _time_lerobot_train(dataset, repo_id, tmp, fit_ms)
    for note in notes:
        print(f"note: {note}")
    verdict = "meets" if total / 1e3 < TARGET_S else "MISSES"
    print(
        f"\none-shot fit / compute: {total:.0f} ms / {fit_ms:.1f} ms = {total / fit_ms:.1f}x; reading the "
        f"episode {read_ms:.1f} ms (medians of {args.runs})"
    )
    print(f"one-shot total {total:.0f} ms {verdict} the {TARGET_S:.0f} s target")
    return 0


def _fit_against_reading(dataset: Path, repo_id: str, tmp: Path, runs: int):
    """Reading episode 0 and the one-shot fit, alternating in one loop so that a change of
    machine load hits both: (median read ms, median fit ms, the episodes read, the last fit)."""
    from lerobot_forcemap.cli.fit import fit_policy, make_config
    from lerobot_policy_forcemap.modeling_forcemap import load_episodes

    cfg = make_config([0])
    print(
        f"timing reading episode 0 and the one-shot fit, alternating ({runs} runs each)",
        file=sys.stderr,
        flush=True,
    )
    read_times, fit_times = [], []
    for _ in range(runs):
        t0 = time.perf_counter()
        loaded = load_episodes(dataset, cfg)
        t1 = time.perf_counter()
        res = fit_policy(dataset, tmp / "one", repo_id=repo_id, overwrite=True)
        t2 = time.perf_counter()
        read_times.append(t1 - t0)
        fit_times.append(t2 - t1)
    return 1e3 * statistics.median(read_times), 1e3 * statistics.median(fit_times), loaded, res


def _parts(dataset: Path, repo_id: str, tmp: Path, runs: int, total: float, read_ms: float, loaded, res):
    """The table's rows of the total and its parts (metadata, segmentation + maps, saving), the median
    ms of the compute (``fit_skill``) and its segmentation report."""
    from lerobot_forcemap.cli.fit import make_config
    from lerobot_forcemap.data.reader import read_meta
    from lerobot_forcemap.skill.fit import fit_skill
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    meta_ms, _ = median_ms(lambda: read_meta(dataset, repo_id=repo_id), runs, "metadata")
    episodes, features, fps, _tasks = loaded
    names = list(features.get("observation.environment_state", {}).get("names") or []) or None
    params = make_config([0]).skill_params()
    fit_ms, (skill, report) = median_ms(lambda: fit_skill(episodes, params, fps, names), runs, "fit_skill")
    policy = res.policy
    save_ms, _ = median_ms(lambda: policy.save_pretrained(tmp / "save"), runs, "save_pretrained")
    assert isinstance(policy, ForceMapPolicy)
    rows = [
        ("one-shot fit, dataset -> saved checkpoint (total)", total),
        ("  dataset metadata (read_meta)", meta_ms),
        ("  read episode 0 (load_episodes: metadata + columns) [same loop as the total]", read_ms),
        (f"  segmentation + {skill.n_segments} arm + {skill.n_segments} gripper maps (fit_skill)", fit_ms),
        ("  save_pretrained (config.json + model.safetensors)", save_ms),
    ]
    return rows, fit_ms, report


def _all_episodes(
    dataset: Path, repo_id: str, tmp: Path, runs: int, n_episodes: int, columns: set[str]
) -> float | None:
    """Median ms of a fit on every episode (``segments=dataset`` on the recorder's phases), None when
    the dataset lacks them."""
    from lerobot_forcemap.cli.fit import fit_policy

    if SEGMENT_COLUMN not in columns:
        return None
    every = dict(
        episodes=list(range(n_episodes)),
        overrides=["segments=dataset", f"segment_column={SEGMENT_COLUMN}"],
    )
    ms, _ = median_ms(
        lambda: fit_policy(dataset, tmp / "all", repo_id=repo_id, overwrite=True, **every),
        runs,
        f"{n_episodes}-episode fit",
    )
    return ms


def _time_lerobot_train(dataset: Path, repo_id: str, tmp: Path, fit_ms: float) -> None:
    """One real ``lerobot-train --steps=1`` subprocess, imports included, for scale (ratio to the
    compute ``fit_ms``)."""
    print("timing one lerobot-train --steps=1 subprocess", file=sys.stderr, flush=True)
    t0 = time.perf_counter()
    out = subprocess.run(
        [
            str(Path(sys.executable).parent / "lerobot-train"),
            "--policy.type=forcemap",
            "--policy.device=cpu",
            f"--dataset.repo_id={repo_id}",
            f"--dataset.root={dataset}",
            "--steps=1",
            "--save_freq=1",
            "--batch_size=4",
            "--num_workers=0",
            f"--output_dir={tmp / 'train'}",
        ],
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - t0
    status = "ok" if out.returncode == 0 else f"failed ({out.returncode})"
    print(
        f"| lerobot-train --steps=1 subprocess, imports included (1 run, {status}) | {1e3 * wall:.0f} | "
        f"{1e3 * wall / fit_ms:.1f} |"
    )


if __name__ == "__main__":
    sys.exit(main())
