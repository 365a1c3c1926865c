"""Cells (task x method [x object]) of the experiment stages, and how they are run and aggregated.

A :class:`Cell` is one row of one table: its jobs (one per demonstration) and a description of the
settings. ``run_cells`` runs the jobs of many cells in one pool (cached under
``outputs/experiments/raw``) and ``aggregate`` turns a cell's episode records into the record that
goes into ``results/experiments.json``.
"""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from experiments.paper.jobs import (
    Job,
    demo_change,
    demo_force_records,
    demo_phase_switches,
    run_jobs,
    segmentation_score,
    summarize_records,
)

from .common import Settings


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
    results = run_jobs(jobs, s.workdir, workers=s.workers, force=s.force, desc=desc, runner=s.runner)
    by_key = {r["key"]: r for r in results}
    for c in cells:
        c.results = [by_key[j.key()] for j in c.jobs]


def aggregate(cell: Cell, tune_demos: tuple[int, ...] = ()) -> dict[str, Any]:
    """The ``results/experiments.json`` record of a cell."""
    recs = cell.records
    summary = summarize_records(recs)
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
        **summary,
        "failures": dict(Counter(r["termination_reason"] for r in recs if not r["success"])),
        "wall_time_s": float(sum(res["wall_s"] for res in cell.results)),
        "episode_wall_time_s": float(np.median([r["wall_s"] for r in recs])) if recs else None,
    }
    phases = phase_summary(recs)
    if phases:
        out["force_by_gripper_phase"] = phases
    fits = [res["fit"] for res in cell.results if res.get("fit")]
    if fits:
        out["fit_s_median"] = float(np.median([f["fit_s"] for f in fits]))
        out["fit_s_max"] = float(np.max([f["fit_s"] for f in fits]))
        out["n_segments"] = sorted({int(f["n_segments"]) for f in fits})
        out["force_limit_rows_mean"] = float(np.mean([f.get("n_force_limit_rows", 0) for f in fits]))
        out["capped_nodes_mean"] = float(
            np.mean([sum(s["capped_nodes"] for s in f["segments"]) for f in fits])
        )
        score = segmentation_score(fits, demo_phase_switches(cell.jobs[0].dataset_path))
        if score is not None:
            out["changepoints_vs_demo_phase"] = score
    if cell.experiment != "grasp" or cell.object is None or _is_demo_object(cell):
        demos = demo_force_records(cell.jobs[0].dataset_path) if cell.jobs else []
        if demos and recs:
            out["change_vs_demo"] = {
                k: demo_change(recs, demos, k) for k in ("max_contact_force", "mean_contact_force")
            }
            held = [r for r in recs if r["demo"] not in tune_demos]
            if tune_demos and held and len(held) < len(recs):
                out["change_vs_demo_held_out"] = {
                    k: demo_change(held, demos, k) for k in ("max_contact_force", "mean_contact_force")
                }
                out["success_rate_held_out"] = float(np.mean([r["success"] for r in held]))
                out["n_held_out"] = len(held)
    return out


def phase_summary(recs: list[dict[str, Any]]) -> dict[str, Any]:
    """Per gripper phase (closed / moving / open): episodes in it, mean of their per-axis max |F| (20 Hz
    samples), and per axis the share of episodes whose largest |F| fell in that phase."""
    recs = [r for r in recs if r.get("force_by_gripper_phase")]
    if not recs:
        return {}
    from experiments.paper.jobs import GRIPPER_PHASES

    per = np.array(
        [[r["force_by_gripper_phase"][p]["max_xyz"] for p in GRIPPER_PHASES] for r in recs]
    )  # (n, 3, 3)
    steps = np.array([[r["force_by_gripper_phase"][p]["steps"] for p in GRIPPER_PHASES] for r in recs])
    where = np.argmax(per, axis=1)  # (n, 3): phase of each axis' peak
    out = {}
    for i, p in enumerate(GRIPPER_PHASES):
        used = steps[:, i] > 0
        out[p] = {
            "episodes": int(used.sum()),
            "max_xyz_mean": per[used, i].mean(axis=0).tolist() if used.any() else [0.0, 0.0, 0.0],
            "peak_share_xyz": (where == i).mean(axis=0).tolist(),
        }
    return out


def _is_demo_object(cell: Cell) -> bool:
    from .common import GRASP_TASKS

    return cell.task in GRASP_TASKS and cell.object == GRASP_TASKS[cell.task][0]


def demonstration_record(experiment: str, task: str, demos: tuple[int, ...]) -> dict[str, Any]:
    """The demonstrations' own figures (env statistics recorded with the dataset) as a row."""
    from .common import REPO

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
        **summarize_records(recs),
        # the same keys as every other record: recorded with the dataset, not run by this pipeline
        "failures": dict(Counter(d.get("termination_reason") or "failed" for d in recs if not d["success"])),
        "wall_time_s": None,
    }
