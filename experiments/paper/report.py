"""``results/experiments.json`` and ``results/experiments.md``: the experiments document and its report.

``experiments.json``: ``{"code_fingerprint", "protocol", "tuning", "records": [one per experiment x task x
method (x object)], "targets", "runtime"}``; a record has n, seeds, success rate (+ Wilson 95 %
interval), protective stops, ``{mean, std, ci95, min, max}`` of max / mean contact force (norm and per
axis x y z; per finger on the grasping tasks), the % change vs the demonstrations (per demonstration,
with the spread over demonstrations), failures by reason and wall times (``cells.aggregate``). Learned
baselines (ACT, Diffusion) are merged from ``results/learned/`` (``learned_rows.py``) and are
``"status": "pending"`` until those files exist. Non-finite numbers are written as null.

``experiments.md``: the prose of ``templates/experiments.md`` around the tables of ``tables.py``, the
figures of ``figures.py`` and the analysis of ``analysis.py``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from experiments.fragments import Fragments
from experiments.paper import tables
from experiments.paper.demos import demo_force_records
from lerobot_forcemap import layout
from lerobot_forcemap.evaluation.records import finite_or_none

__all__ = ["text", "write_json", "demos_by_task", "build_markdown"]

text = Fragments(Path(__file__).parent / "templates" / "experiments.md")


def write_json(doc: dict[str, Any], path: Path) -> None:
    """The document as indented JSON, non-finite numbers as null."""
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(finite_or_none(doc), indent=1))


def demos_by_task(tasks) -> dict[str, list[dict[str, Any]]]:
    """The demonstrations' records of the tasks whose shipped dataset has the recorder's statistics."""
    from .common import REPO

    out = {}
    for t in tasks:
        p = REPO / "datasets" / t
        if (p / "meta" / layout.EPISODES_FILE).is_file():
            out[t] = demo_force_records(p)
    return out


def build_markdown(doc: dict[str, Any], figures: dict[str, str], analysis: list[str]) -> str:
    """``results/experiments.md``: protocol, the tables with the paper's numbers, figures, analysis,
    tuning and runtime. ``figures``: ``{"table2" | "peg" | "profiles" | "paths": file name}`` of the
    figures that were drawn."""
    recs = doc["records"]
    lines = [_protocol(doc["protocol"]), ""]
    lines += tables.targets_md(doc["targets"])
    lines += ["", text("table2_heading"), ""]
    for task in ("press", "erase"):
        lines += tables.table2_md(recs, task) + [""]
    lines += _figure_line("table2_figure", figures.get("table2"))
    lines += [text("table3_heading"), ""]
    lines += tables.table3_md(recs) + [""]
    lines += _figure_line("peg_figure", figures.get("peg"))
    lines += [text("grasp_heading"), ""]
    lines += tables.grasp_md(recs) + [""]
    lines += [text("ablations_heading"), ""]
    for task in ("press", "erase"):
        if any(r["experiment"] == "ablation" and r["task"] == task for r in recs):
            lines += tables.ablation_md(recs, task) + [""]
    lines += [text("figures_heading"), ""]
    for key in ("profiles", "paths"):
        if figures.get(key):
            lines += [text("figure", name=key, file=figures[key]), ""]
    lines += [text("analysis_heading"), ""] + analysis + [""]
    lines += [text("tuning_heading"), ""] + tables.tuning_md(doc["tuning"])
    lines += _runtime(doc["runtime"])
    return "\n".join(lines)


def _protocol(p: dict[str, Any]) -> str:
    """The title and the protocol paragraph, from the document's protocol (seeds, demonstrations)."""
    return text(
        "protocol",
        first_seed=p["eval_seeds"][0],
        last_seed=p["eval_seeds"][-1],
        demos=p["demos"],
        n_full=len(p["demos"]) * len(p["eval_seeds"]),
        n_seeds=len(p["eval_seeds"]),
        n_demos=len(p["demos"]),
        tune_seeds=p["tune_seeds"],
        tune_demos=p["tune_demos"],
    )


def _figure_line(fragment: str, file: str | None) -> list[str]:
    return [text(fragment, file=file), ""] if file else []


def _runtime(rt: dict[str, Any]) -> list[str]:
    """The runtime section: the last run from an empty cache with this code version, and this run."""
    full = rt.get("last_full_run") or (rt if rt.get("cached_jobs") == 0 else None)
    lines = [text("runtime_heading"), ""]
    if full:
        machine = text("runtime_machine", workers=full["workers"], machine=full["machine"])
        if full.get("cpu_s"):
            machine += text("runtime_cpu", cpu_s=full["cpu_s"], cpu_note=full.get("cpu_note", ""))
        lines += [text("runtime_full"), ""] + tables.runtime_md(full) + ["", machine, ""]
    else:
        lines += [text("runtime_none"), ""]
    this_run = text("runtime_this_run", total_s=rt["total_s"], cached_jobs=rt["cached_jobs"], jobs=rt["jobs"])
    return lines + [this_run, ""]
