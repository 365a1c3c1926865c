"""Cells (task x method [x object]) of the experiment stages, and how they are run and aggregated.

A :class:`Cell` is one row of one table: its jobs (one per demonstration) and a description of the
settings. :func:`run_cells` runs the jobs of many cells in one pool (cached under
``outputs/experiments/raw``) and :func:`aggregate` turns a cell's episode records into the record that
goes into ``results/experiments.json`` (the statistics are ``lerobot_forcemap.evaluation.stats``').
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from experiments.paper.demos import demo_force_records, demo_phase_switches, segmentation_score
from experiments.paper.jobs import Job, run_jobs
from lerobot_forcemap.evaluation.records import ALL_FIGURES
from lerobot_forcemap.evaluation.stats import demo_change, failure_counts, gripper_phase_summary, summarize

from .common import GRASP_TASKS, REPO, Settings

__all__ = ["Cell", "run_cells", "aggregate", "demonstration_record", "summary_of"]

#: the figures whose change against the demonstrations a record reports
CHANGE_KEYS = ("max_contact_force", "mean_contact_force")


@dataclass
class Cell:
    """One row: ``experiment`` (table2 | peg | grasp | ablation), task, method id, label, jobs."""

    experiment: str
    task: str
    method: str
    label: str
    jobs: list[Job]
    settings: dict[str, Any] = field(default_factory=dict)
    object: str | None = None
    design: str = "full"  # full: every demo x every seed; split: seeds dealt over the demos
    results: list[dict[str, Any]] = field(default_factory=list)

    @property
    def key(self) -> str:
        return f"{self.experiment}/{self.task}/{self.method}" + (f"/{self.object}" if self.object else "")

    @property
    def records(self) -> list[dict[str, Any]]:
        return [r for res in self.results for r in res["records"]]


def run_cells(cells: list[Cell], s: Settings, desc: str) -> None:
    """Run every cell's jobs (one shared pool, cached) and attach the results to the cells."""
    jobs: list[Job] = []
    seen: set[str] = set()
    for c in cells:
        for j in c.jobs:
            if j.key() not in seen:
                seen.add(j.key())
                jobs.append(j)
    results = run_jobs(jobs, s.workdir, s.executor, force=s.force, desc=desc, stats=s.stats)
    by_key = {r["key"]: r for r in results}
    for c in cells:
        c.results = [by_key[j.key()] for j in c.jobs]


def summary_of(records: list[dict[str, Any]]) -> dict[str, Any]:
    """The experiments' summary of episode records: every force and finger figure, no clip counts."""
    return summarize(records, ALL_FIGURES, clipped=False)


def aggregate(cell: Cell, tune_demos: tuple[int, ...] = ()) -> dict[str, Any]:
    """The ``results/experiments.json`` record of a cell."""
    recs = cell.records
    out: dict[str, Any] = {
        "experiment": cell.experiment,
        "task": cell.task,
        "method": cell.method,
        "label": cell.label,
        "object": cell.object,
        "kind": cell.jobs[0].kind if cell.jobs else None,
        "settings": cell.settings,
        "design": cell.design,
        "demos": sorted({j.demo for j in cell.jobs}),
        **summary_of(recs),
        "failures": failure_counts(recs),
        "wall_time_s": float(sum(res["wall_s"] for res in cell.results)),
        "episode_wall_time_s": float(np.median([r["wall_s"] for r in recs])) if recs else None,
    }
    phases = gripper_phase_summary(recs)
    if phases:
        out["force_by_gripper_phase"] = phases
    out.update(_fit_figures(cell))
    if cell.experiment != "grasp" or cell.object is None or _is_demo_object(cell):
        out.update(_change_vs_demos(cell, recs, tune_demos))
    return out


def _fit_figures(cell: Cell) -> dict[str, Any]:
    """Fit times, segment counts, force-limit rows, capped nodes and the changepoints' score against the
    demonstrator's phases, over the cell's one-shot fits (``{}`` for baselines)."""
    fits = [res["fit"] for res in cell.results if res.get("fit")]
    if not fits:
        return {}
    out = {
        "fit_s_median": float(np.median([f["fit_s"] for f in fits])),
        "fit_s_max": float(np.max([f["fit_s"] for f in fits])),
        "n_segments": sorted({int(f["n_segments"]) for f in fits}),
        "force_limit_rows_mean": float(np.mean([f.get("n_force_limit_rows", 0) for f in fits])),
        "capped_nodes_mean": float(np.mean([sum(s["capped_nodes"] for s in f["segments"]) for f in fits])),
    }
    score = segmentation_score(fits, demo_phase_switches(cell.jobs[0].dataset_path))
    if score is not None:
        out["changepoints_vs_demo_phase"] = score
    return out


def _change_vs_demos(cell: Cell, recs: list[dict[str, Any]], tune_demos: tuple[int, ...]) -> dict[str, Any]:
    """The % change against each record's own demonstration, and on the demonstrations held out of tuning."""
    demos = demo_force_records(cell.jobs[0].dataset_path) if cell.jobs else []
    if not (demos and recs):
        return {}
    out: dict[str, Any] = {"change_vs_demo": {k: demo_change(recs, demos, k) for k in CHANGE_KEYS}}
    held = [r for r in recs if r["demo"] not in tune_demos]
    if tune_demos and held and len(held) < len(recs):
        out["change_vs_demo_held_out"] = {k: demo_change(held, demos, k) for k in CHANGE_KEYS}
        out["success_rate_held_out"] = float(np.mean([r["success"] for r in held]))
        out["n_held_out"] = len(held)
    return out


def _is_demo_object(cell: Cell) -> bool:
    return cell.task in GRASP_TASKS and cell.object == GRASP_TASKS[cell.task][0]


def demonstration_record(experiment: str, task: str, demos: tuple[int, ...]) -> dict[str, Any]:
    """The demonstrations' own figures (env statistics recorded with the dataset) as a row."""
    recs = [d for d in demo_force_records(REPO / "datasets" / task) if d["episode"] in demos]
    return {
        "experiment": experiment,
        "task": task,
        "method": "demonstration",
        "label": "demonstrations (scripted, recorded)",
        "object": recs[0].get("object") if recs else None,
        "kind": "demonstration",
        "settings": {"source": f"datasets/{task}/meta/forcemap_episodes.json"},
        "design": "recorded",
        "demos": [d["episode"] for d in recs],
        **summary_of(recs),
        # the same keys as every other record: recorded with the dataset, not run by this pipeline
        "failures": failure_counts(recs),
        "wall_time_s": None,
    }
