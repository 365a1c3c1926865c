"""One-shot fit per episode from disk against its compute, for this checkout and an older one, in one run.

    .venv/bin/python -m benchmarks.bench_fit_e2e [--datasets datasets/press ...]
        [--episodes 3] [--runs 5] [--baseline DIR] [--json out.json]

Per dataset (default: every task's dataset under ``datasets/``; when none is there, 3 scripted
demonstrations per task recorded into a temporary folder) and per episode 0..``--episodes``-1:

- end to end: ``forcemap fit --dataset D --episodes E`` in-process (``cli.fit.fit_policy``): the
  dataset's metadata, reading the episode's columns, segmentation, the maps, the processors and saving
  the checkpoint (config, tensors, processor files, ``fit_report.json``);
- the compute alone: segmentation + maps (``fit_skill``) on the episode's arrays already in memory.

Each run times every chosen episode both ways (end to end, then compute, one after the other, so that
both see the same machine load); a row gives the medians over runs of the mean time per episode, in wall
time, and end to end / compute. Each code path runs in a subprocess of its own (``PYTHONPATH`` = its
checkout; imports and a warm-up fit excluded): this checkout, and with ``--baseline DIR`` an older
checkout of the project (an earlier version whose fit reads through ``LeRobotDataset``), in the same run
on the same datasets. The checkpoints the two write are compared: every tensor of every
``*.safetensors`` file, and the files' bytes.
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

REPO = Path(__file__).resolve().parents[1]
TASKS = ("press", "erase", "peg_in_hole", "grasp_push", "grasp_flip")
TARGET = 5.0  # end to end within this multiple of the compute


# ---- the worker: one code path, in its own process -----------------------------------------------------


def _code_path():
    """``(fit_policy, make_config, load, compute)`` of the checkout on ``sys.path``: this layout, or the
    earlier one (``experiments.fit``, ``lerobot_policy_forcemap.episodes`` / ``.fitting``)."""
    try:
        from lerobot_forcemap.cli.fit import fit_policy, make_config
        from lerobot_forcemap.skill.fit import fit_skill
        from lerobot_policy_forcemap.modeling_forcemap import load_episodes

        def load(dataset, cfg):
            return load_episodes(dataset, cfg)

        def compute(episodes, cfg, fps, names):
            return fit_skill(episodes, cfg.skill_params(), fps, names)

    except ImportError:
        from lerobot_forcemap.experiments.fit import fit_policy, make_config
        from lerobot_policy_forcemap.episodes import load_episodes
        from lerobot_policy_forcemap.fitting import fit_skill

        def load(dataset, cfg):
            return load_episodes(f"local/{Path(dataset).name}", str(dataset), cfg)

        def compute(episodes, cfg, fps, names):
            return fit_skill(episodes, cfg, fps, names)

    return fit_policy, make_config, load, compute


def _time_dataset(dataset: Path, episodes: int, runs: int, out: Path, path) -> dict:
    """Per run, the mean wall time (s) per episode end to end and of the compute; the last run's
    checkpoints stay in ``out/<episode>``."""
    fit_policy, make_config, load, compute = path
    memory = []
    for e in range(episodes):
        cfg = make_config([e])
        eps, features, fps, _tasks = load(dataset, cfg)
        names = list(features.get(cfg.env_state_key, {}).get("names") or [])
        memory.append((eps, cfg, fps, names))
    fit_policy(dataset, out / "warmup", episodes=[0], overwrite=True)
    e2e, fit = [], []
    for _ in range(runs):
        t_e2e = t_fit = 0.0
        for e, args in enumerate(memory):
            t0 = time.perf_counter()
            fit_policy(dataset, out / str(e), episodes=[e], overwrite=True)
            t1 = time.perf_counter()
            compute(*args)
            t2 = time.perf_counter()
            t_e2e, t_fit = t_e2e + t1 - t0, t_fit + t2 - t1
        e2e.append(t_e2e / episodes)
        fit.append(t_fit / episodes)
    return {"e2e_s": e2e, "compute_s": fit, "frames": [int(m[0][0].n_frames) for m in memory]}


def worker(spec: dict) -> dict:
    """Times every dataset of ``spec`` with the code on ``sys.path`` (see :func:`_time_dataset`)."""
    from lerobot_forcemap.lerobot_logs import quiet_torchcodec_warning

    quiet_torchcodec_warning()
    path = _code_path()
    out = Path(spec["out"])
    return {
        name: _time_dataset(Path(d), spec["episodes"], spec["runs"], out / name, path)
        for name, d in spec["datasets"].items()
    }


# ---- the driver ----------------------------------------------------------------------------------------


def _run_worker(checkout: Path, spec: dict) -> dict:
    """The worker run as a script, by its path: ``python -m`` would import this checkout's package. The
    environment the ``benchmarks`` package set (one BLAS thread, offline Hub) is inherited."""
    env = {**os.environ, "PYTHONPATH": str(checkout)}
    proc = subprocess.run(
        [sys.executable, __file__, "--worker", json.dumps(spec)],
        cwd=spec["out"],  # neither checkout's folder: PYTHONPATH alone says whose code runs
        env=env,
        capture_output=True,
        text=True,
    )
    if proc.returncode != 0:
        raise SystemExit(f"the worker for {checkout} failed:\n{proc.stderr[-4000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _datasets(args, tmp: Path) -> dict[str, Path]:
    """``{name: folder}``: the ``--datasets``, else the shipped ones, else small recorded ones."""
    if args.datasets:
        return {Path(d).name: Path(d).resolve() for d in args.datasets}
    shipped = {
        t: REPO / "datasets" / t for t in TASKS if (REPO / "datasets" / t / "meta/info.json").is_file()
    }
    if shipped:
        return shipped
    from lerobot_forcemap.envs.record import record_demonstrations

    print("no shipped datasets: recording 3 demonstrations per task", file=sys.stderr)
    for t in TASKS:
        record_demonstrations(t, max(3, args.episodes), 0, tmp / "datasets" / t, progress=False)
    return {t: tmp / "datasets" / t for t in TASKS}


def _same_checkpoint(a: Path, b: Path) -> tuple[bool, bool]:
    """(every tensor of every ``*.safetensors`` file equal bit for bit, those files equal byte for byte)."""
    from safetensors.numpy import load_file

    files = sorted(p.name for p in a.glob("*.safetensors"))
    if files != sorted(p.name for p in b.glob("*.safetensors")) or not files:
        return False, False
    tensors = True
    for f in files:
        ta, tb = load_file(a / f), load_file(b / f)
        tensors &= ta.keys() == tb.keys() and all(
            ta[k].dtype == tb[k].dtype and ta[k].shape == tb[k].shape and ta[k].tobytes() == tb[k].tobytes()
            for k in ta
        )
    return tensors, all((a / f).read_bytes() == (b / f).read_bytes() for f in files)


def _row(name: str, times: dict) -> dict:
    e2e, fit = statistics.median(times["e2e_s"]), statistics.median(times["compute_s"])
    return {"dataset": name, "e2e_ms": 1e3 * e2e, "compute_ms": 1e3 * fit, "ratio": e2e / fit}


def _print_table(
    rows: dict[str, dict], base: dict[str, dict] | None, same: dict[str, tuple[bool, bool]]
) -> None:
    head = "| dataset | frames per episode | end to end (ms/episode) | compute (ms/episode) | end to end / compute |"
    sep = "|---|---|---|---|---|"
    if base is not None:
        head += " baseline end to end (ms) | baseline compute (ms) | baseline ratio | end to end speed-up | tensors identical | bytes identical |"
        sep += "---|---|---|---|---|---|"
    print(head + "\n" + sep)
    for name, r in rows.items():
        line = f"| {name} | {', '.join(map(str, r['frames']))} | {r['e2e_ms']:.1f} | {r['compute_ms']:.1f} | {r['ratio']:.2f}x |"
        if base is not None:
            b = base[name]
            t, y = same[name]
            line += (
                f" {b['e2e_ms']:.1f} | {b['compute_ms']:.1f} | {b['ratio']:.1f}x | "
                f"{b['e2e_ms'] / r['e2e_ms']:.1f}x | {'yes' if t else 'NO'} | {'yes' if y else 'no'} |"
            )
        print(line)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--datasets", nargs="+", default=None, help="dataset folders (default: datasets/<task>)"
    )
    parser.add_argument("--episodes", type=int, default=3, help="episodes 0..N-1 of each dataset (>= 1)")
    parser.add_argument("--runs", type=int, default=5, help="timed runs (>= 1)")
    parser.add_argument("--baseline", default=None, help="an older checkout of the project to compare with")
    parser.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    parser.add_argument("--worker", default=None, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker is not None:  # the worker imports only what both layouts have (see _code_path)
        print(json.dumps(worker(json.loads(args.worker))))
        return 0
    from lerobot_forcemap._validation import check_int, usage_errors

    with usage_errors(parser):
        check_int("--runs", args.runs, low=1)
        check_int("--episodes", args.episodes, low=1)
    if args.baseline is not None and not (Path(args.baseline) / "lerobot_forcemap").is_dir():
        parser.error(f"--baseline {args.baseline}: not a checkout of the project (no lerobot_forcemap/)")
    for d in args.datasets or ():
        if not (Path(d) / "meta/info.json").is_file():
            parser.error(f"--datasets {d}: not a LeRobot dataset (no meta/info.json)")
        total = json.loads((Path(d) / "meta/info.json").read_text())["total_episodes"]
        if total < args.episodes:
            parser.error(f"--episodes {args.episodes}: {d} has only {total} episode(s)")
    with tempfile.TemporaryDirectory(prefix="bench_fit_e2e_") as tmp_dir:
        return _bench(args, Path(tmp_dir))


def _bench(args, tmp: Path) -> int:
    datasets = _datasets(args, tmp)
    spec = {
        "datasets": {k: str(v) for k, v in datasets.items()},
        "episodes": args.episodes,
        "runs": args.runs,
    }
    results = {}
    for label, checkout in [("this", REPO)] + (
        [("baseline", Path(args.baseline).resolve())] if args.baseline else []
    ):
        print(f"timing {label} ({checkout})", file=sys.stderr)
        (tmp / label).mkdir()
        results[label] = _run_worker(checkout, {**spec, "out": str(tmp / label)})
    rows = {n: {**_row(n, t), "frames": t["frames"]} for n, t in results["this"].items()}
    base = {n: _row(n, t) for n, t in results["baseline"].items()} if args.baseline else None
    same = (
        {
            n: tuple(
                all(flags)
                for flags in zip(
                    *(
                        _same_checkpoint(tmp / "this" / n / str(e), tmp / "baseline" / n / str(e))
                        for e in range(args.episodes)
                    ),
                    strict=True,
                )
            )
            for n in rows
        }
        if args.baseline
        else {}
    )
    print(
        f"episodes 0..{args.episodes - 1} of each dataset, {args.runs} runs, medians over runs of the mean wall "
        f"time per episode; OPENBLAS_NUM_THREADS={os.environ['OPENBLAS_NUM_THREADS']}\n"
    )
    _print_table(rows, base, same)
    worst = max(r["ratio"] for r in rows.values())
    print(
        f"\nend to end / compute: at most {worst:.2f}x: {'meets' if worst <= TARGET else 'MISSES'} the {TARGET:g}x target"
    )
    if args.json:
        Path(args.json).write_text(
            json.dumps({"rows": rows, "baseline": base, "same": same, "raw": results}, indent=1)
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
