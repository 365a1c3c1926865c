"""``make experiments``: the paper's experiments (§IV) in simulation, end to end.

    .venv/bin/python -m experiments.paper [--workers 2] [--ray | --ray-address ADDR] [--only tune table2 peg grasp ablations]
                                                    [--quick --out /tmp/x] [--force]

Stages (each module's docstring has the details and the protocol is in ``common.py``):

0. ``tune``       settings chosen on tuning seeds / demonstrations (``tuning.py``)
1. ``table2``     force reduction, press and erase (``force_reduction.py``)
2. ``peg``        peg-in-hole vs hybrid force/position control (``peg_in_hole.py``)
3. ``grasp``      grasp_push / grasp_flip, seen and unseen objects (``grasping.py``)
4. ``ablations``  forces off, rho_max cap off, 3-D map, segmentations (``ablations.py``)
5. report: ``results/experiments.json``, ``results/experiments.md``, PNGs (``report.py``), with the
   learned baselines merged from ``results/learned/`` (trained by ``python -m experiments.learned``).

Every episode's record is cached in ``outputs/experiments/raw/<code fingerprint>/<job>.json``: a
second run only re-aggregates (that is how to refresh the report once the learned baselines land);
a run removes the caches (records and checkpoints) of other code versions and says so. ``--force``
re-runs everything; ``--quick`` is the smoke-test size (2 demonstrations, 2 seeds, tiny grids) and
must be given ``--out`` (it never writes ``results/``), as must ``--only`` with some of the stages.
The repo's ``configs/`` is rewritten only by a full run into ``results/``; other runs write theirs
under ``<out>/configs``.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import platform
import resource
import shutil
import sys
import time
from dataclasses import replace
from pathlib import Path

from experiments.paper.targets import targets
from lerobot_forcemap import executor
from lerobot_forcemap._validation import check_int, usage_errors

from .common import GRASP_TASKS, RESULTS, WORKDIR, Settings

logging.getLogger("lerobot.utils.import_utils").setLevel(logging.ERROR)

STAGES = ("tune", "table2", "peg", "grasp", "ablations")
#: the stages that evaluate cells, in the order of the report
EVALUATION_STAGES = ("table2", "peg", "grasp", "ablations")


def run(settings: Settings, stages: tuple[str, ...] = STAGES) -> dict:
    """Run the stages and write the report; returns the experiments document. Uses
    ``settings.executor`` or makes one for the run (``settings.workers``, ``ray``, ``ray_address``)."""
    from experiments.paper.jobs import JobStats

    if settings.stats is None:
        settings = replace(settings, stats=JobStats())
    if settings.executor is not None:
        return _run(settings, stages)
    with executor.make_executor(settings.workers, ray=settings.ray, ray_address=settings.ray_address) as ex:
        return _run(replace(settings, executor=ex), stages)


def _run(settings: Settings, stages: tuple[str, ...]) -> dict:
    """The stages (module docstring) with ``settings.executor``; returns the experiments document."""
    from experiments.paper.jobs import code_fingerprint, prune_stale_caches

    s = settings
    s.workdir.mkdir(parents=True, exist_ok=True)
    if s.force:  # refit every checkpoint of this code version too (jobs share fits)
        shutil.rmtree(s.workdir / "checkpoints" / code_fingerprint(), ignore_errors=True)
    clock = _Clock()
    tuning = _tuning(s, stages, clock)
    cells = _run_cells(tuning, s, stages, clock)
    records = _records(cells, s)
    doc = {
        "code_fingerprint": code_fingerprint(),
        "protocol": {
            "eval_seeds": list(s.eval_seeds),
            "tune_seeds": list(s.tune_seeds),
            "demos": list(s.demos),
            "tune_demos": list(s.tune_demos),
            "quick": s.quick,
        },
        "tuning": tuning,
        "records": records,
        "targets": targets(records),
        "runtime": _runtime(clock, s, stages),
    }
    _write_report(doc, cells, s)
    _write_configs(doc, s, stages)
    rt = doc["runtime"]
    print(f"total wall time {rt['total_s']:.0f} s ({rt['cached_jobs']} of {rt['jobs']} jobs cached)")
    stale, size = prune_stale_caches(s.workdir)
    if stale:  # each code change leaves ~40 MB of records and checkpoints no later run can reuse
        print(
            f"removed the caches of {len({d.name for d in stale})} earlier code version(s) under {s.workdir} "
            f"({size / 1e6:.0f} MB)"
        )
    return doc


class _Clock:
    """Wall time per stage (``runtime["stages"]``), and the run's wall and CPU time from its start."""

    def __init__(self) -> None:
        self.stages: dict[str, dict] = {}
        self.t0 = time.perf_counter()
        start = resource.getrusage(resource.RUSAGE_SELF)
        self.cpu0 = start.ru_utime + start.ru_stime

    def timed(self, name: str, fn, episodes=None):
        """``fn()``, its wall time and ``episodes(result)`` recorded under ``name``."""
        t0 = time.perf_counter()
        out = fn()
        self.stages[name] = {
            "wall_s": time.perf_counter() - t0,
            "episodes": episodes(out) if episodes else None,
        }
        return out

    def cpu_s(self) -> float:
        own = resource.getrusage(resource.RUSAGE_SELF)
        return own.ru_utime + own.ru_stime - self.cpu0


def _tuning(s: Settings, stages: tuple[str, ...], clock: _Clock) -> dict:
    """Stage 0: run the tuning (or read the last one from the work folder when it is not asked for)."""
    from . import tuning as tuning_mod

    path = s.workdir / ("tuning_quick.json" if s.quick else "tuning.json")
    if "tune" in stages or not path.is_file():
        tuning = clock.timed("tune", lambda: tuning_mod.tune_all(s), episodes=lambda _: None)
        path.write_text(json.dumps(tuning, indent=1))
        return tuning
    return json.loads(path.read_text())


def _run_cells(tuning: dict, s: Settings, stages: tuple[str, ...], clock: _Clock) -> list:
    """Stages 1-4: every stage's cells, run in one pass (it keeps the workers busy), then each stage's
    share of the jobs' wall time."""
    from . import ablations, force_reduction, grasping, peg_in_hole
    from .cells import run_cells

    makers = {
        "table2": lambda: force_reduction.cells(tuning, s),
        "peg": lambda: peg_in_hole.cells(tuning["peg_in_hole"], s),
        "grasp": lambda: grasping.cells(s),
        "ablations": lambda: ablations.cells(tuning, s),
    }
    by_stage = {name: makers[name]() for name in EVALUATION_STAGES if name in stages}
    cells = [c for stage_cells in by_stage.values() for c in stage_cells]
    clock.timed(
        "evaluation (all stages)",
        lambda: run_cells(cells, s, "evaluation"),
        episodes=lambda _: sum(len(j.seeds) for c in cells for j in c.jobs),
    )
    for name, mine in by_stage.items():
        if mine:
            clock.stages[f"  {name} (sum of its jobs' wall times, over the workers)"] = {
                "wall_s": float(sum(r["wall_s"] for c in mine for r in c.results if not r.get("cached"))),
                "episodes": sum(len(j.seeds) for c in mine for j in c.jobs),
            }
    return cells


def _records(cells: list, s: Settings) -> list[dict]:
    """The document's records: the demonstrations' rows, one per cell, the learned baselines' rows."""
    from lerobot_forcemap.evaluation.stats import metric_stats

    from .cells import aggregate, demonstration_record
    from .learned_rows import learned_records
    from .report import demos_by_task

    records = []
    for exp, task in (("table2", "press"), ("table2", "erase"), ("peg", "peg_in_hole")):
        if any(c.experiment == exp and c.task == task for c in cells):
            records.append(demonstration_record(exp, task, s.demos))
    for c in cells:
        rec = aggregate(c, s.tune_demos)
        metrics = metric_stats(c.records)
        rec["metric_means"] = {k: v["mean"] for k, v in metrics.items()}
        rec["metric_stds"] = {k: v["std"] for k, v in metrics.items()}
        if c.experiment == "grasp":
            rec["seen"] = c.object == GRASP_TASKS[c.task][0]
        records.append(rec)
    if not s.quick:
        learned = learned_records(s.learned_dir, demos_by_task(("press", "erase", "peg_in_hole")))
        # learned rows go after the forcemap rows of their table
        records.extend(r for r in learned if any(x["experiment"] == r["experiment"] for x in records))
    return _ordered(records)


def _runtime(clock: _Clock, s: Settings, stages: tuple[str, ...]) -> dict:
    """Wall and CPU time of this run; a run from an empty cache is kept as the code version's
    ``last_full_run`` (what `make experiments` costs), which cached re-runs report too."""
    from experiments.paper.jobs import code_fingerprint

    stats = s.stats
    runtime: dict = {
        "stages": clock.stages,
        "cpu_s": clock.cpu_s() + (stats.cpu_s if s.executor.kind != "serial" else 0.0),
        "cpu_note": "CPU of the main process plus the CPU the workers spent on the jobs they ran",
        "total_s": time.perf_counter() - clock.t0,
        "workers": s.workers,
        "machine": f"{platform.machine()}, {os.cpu_count()} CPUs (shared), Python {platform.python_version()}",
        "jobs": stats.n_jobs,
        "cached_jobs": stats.n_cached,
    }
    full_path = s.workdir / ("last_full_run_quick.json" if s.quick else "last_full_run.json")
    if runtime["jobs"] and runtime["cached_jobs"] == 0 and set(stages) == set(STAGES):
        full_path.write_text(
            json.dumps({"code_fingerprint": code_fingerprint(), "runtime": runtime}, indent=1)
        )
    last_full = json.loads(full_path.read_text()) if full_path.is_file() else None
    if last_full and last_full.get("code_fingerprint") == code_fingerprint():
        runtime["last_full_run"] = last_full["runtime"]
    return runtime


def _write_report(doc: dict, cells: list, s: Settings) -> None:
    """The figures, ``experiments.json`` and ``experiments.md`` into ``s.results``."""
    from . import analysis, figures, report

    s.results.mkdir(parents=True, exist_ok=True)
    drawn = {}
    for key, fn, arg in (
        ("profiles", figures.plot_force_profiles, cells),
        ("paths", figures.plot_paths, cells),
        ("table2", figures.plot_table2, doc["records"]),
        ("peg", figures.plot_peg, doc["records"]),
    ):
        p = fn(arg, s.results / f"experiments_{key}.png")
        if p is not None:
            drawn[key] = p.name
    md = report.build_markdown(doc, drawn, analysis.analysis(doc, cells))
    report.write_json(doc, s.results / "experiments.json")
    (s.results / "experiments.md").write_text(md)
    print(f"wrote {s.results / 'experiments.json'}, {s.results / 'experiments.md'} and {len(drawn)} figures")


def _write_configs(doc: dict, s: Settings, stages: tuple[str, ...]) -> None:
    """The chosen settings as lerobot-train / lerobot-eval --config_path files: the repo's configs/ only
    from a full run into results/ (write_configs removes the files a run does not produce), else
    ``<out>/configs``."""
    from . import config_files

    full = not s.quick and set(stages) == set(STAGES) and s.results.resolve() == RESULTS.resolve()
    config_dir = config_files.REPO / "configs" if full else s.results / "configs"
    learned_docs = [] if s.quick else config_files.load_learned(s.learned_dir)
    written = config_files.write_configs(config_files.build_configs(doc, learned_docs), config_dir)
    print(f"wrote {len(written)} configs under {config_dir}")


ORDER = {"table2": 0, "peg": 1, "grasp": 2, "ablation": 3}
METHOD_ORDER = [
    "demonstration", "replay", "elmap", "hybrid", "act", "diffusion", "ours_default", "ours_k3000", "ours", "ours_limit",
    "limit_alone",
]  # fmt: skip


def _ordered(records: list[dict]) -> list[dict]:
    """The table rows by experiment, task, object and method (``METHOD_ORDER``), then the ablation rows in
    their listed order."""

    def key(r):
        m = r["method"]
        return (
            ORDER.get(r["experiment"], 9),
            r["task"],
            r.get("object") or "",
            METHOD_ORDER.index(m) if m in METHOD_ORDER else len(METHOD_ORDER),
        )

    table = [r for r in records if r["experiment"] != "ablation"]
    abl = [r for r in records if r["experiment"] == "ablation"]
    return sorted(table, key=key) + abl


def main(argv: list[str] | None = None) -> int:
    """``python -m experiments.paper`` (module docstring)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    executor.add_arguments(parser, workers=2)
    parser.add_argument("--only", nargs="+", choices=STAGES, default=list(STAGES), help="stages to run")
    parser.add_argument("--quick", action="store_true", help="smoke-test size (needs --out)")
    parser.add_argument("--out", default=None, help="results folder (default results/)")
    parser.add_argument("--workdir", default=None, help="cache folder (default outputs/experiments)")
    parser.add_argument("--force", action="store_true", help="re-run cached jobs")
    args = parser.parse_args(argv)
    with usage_errors(parser):
        check_int("--workers", args.workers, low=1)
    if args.quick and args.out is None:
        parser.error("--quick writes a smoke-test report: give --out (results/ holds the real one)")
    if set(args.only) != set(STAGES) and args.out is None:
        # the report holds only the stages run: it would replace results/ and configs/ with a part of them
        parser.error(
            f"--only {' '.join(args.only)} writes a partial report: give --out (results/ holds the full one)"
        )
    s = Settings(
        workers=args.workers,
        ray=args.ray,
        ray_address=args.ray_address,
        force=args.force,
        results=Path(args.out) if args.out else RESULTS,
        workdir=Path(args.workdir)
        if args.workdir
        else (WORKDIR if not args.quick else Path(args.out) / "work"),
    )
    if args.quick:
        s = s.quick_version()
    run(s, tuple(args.only))
    return 0


if __name__ == "__main__":
    sys.exit(main())
