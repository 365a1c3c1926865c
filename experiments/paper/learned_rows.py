"""The learned baselines' rows of the experiments document, merged from ``results/learned/``.

One record per task x learned method: from ``<learned_dir>/<task>__<method>.json`` (written by
``python -m experiments.learned``), else ``"status": "pending"``. A ``--smoke`` run's file (a few
training steps) is not a baseline and stays pending.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from experiments.paper.jobs import REPO_ROOT
from lerobot_forcemap.evaluation.records import FORCE_KEYS
from lerobot_forcemap.evaluation.stats import failure_counts

__all__ = ["LEARNED_METHODS", "LEARNED_TASKS", "learned_records"]

LEARNED_METHODS = {"act": "ACT", "diffusion": "Diffusion"}
LEARNED_TASKS = ("press", "erase", "peg_in_hole")


def learned_records(
    learned_dir: Path, demos_by_task: dict[str, list[dict[str, Any]]]
) -> list[dict[str, Any]]:
    """One record per task x learned method (module docstring); ``demos_by_task``: the demonstrations'
    records, for the % change against their mean."""
    out = []
    for task in LEARNED_TASKS:
        for method, name in LEARNED_METHODS.items():
            exp = "peg" if task == "peg_in_hole" else "table2"
            path = Path(learned_dir) / f"{task}__{method}.json"
            base = {"experiment": exp, "task": task, "method": method, "kind": "learned", "object": None}
            pending = {
                **base,
                "label": f"{name} (lerobot-train)",
                "status": "pending",
                "source": _shown(path),
            }
            if not path.is_file():
                out.append(pending)
                continue
            doc = json.loads(path.read_text())
            if (doc.get("config") or {}).get("smoke"):  # a few training steps: not a baseline
                print(f"warning: {path} is a --smoke run's result; left out of the report (pending)")
                out.append(pending)
                continue
            out.append(_done_record(base, name, path, doc, demos_by_task.get(task) or []))
    return out


def _shown(path: Path) -> str:
    """``path`` relative to the checkout where it lies in it: the results read the same from any clone."""
    try:
        return str(path.resolve().relative_to(REPO_ROOT))
    except ValueError:
        return str(path)


def _done_record(
    base: dict[str, Any], name: str, path: Path, doc: dict[str, Any], demos: list[dict[str, Any]]
) -> dict[str, Any]:
    """The row of one learned result document."""
    from experiments.paper.cells import summary_of

    eps = doc.get("episodes") or []
    if eps and all("success" in e and "max_contact_force" in e for e in eps):
        summary = summary_of(eps)
    else:  # a document without its episodes: its own summary
        summary = {
            k: doc[k] for k in ("n", "seeds", "success_rate", "protective_stops", *FORCE_KEYS) if k in doc
        }
    ran = doc.get("lerobot_eval") or {}
    checked = (
        f"; lerobot-eval {100 * ran['success_rate']:.0f}%" if ran.get("success_rate") is not None else ""
    )
    rec = {
        **base,
        "label": f"{name} (lerobot-train, {doc.get('train_steps', '?')} steps, all 10 demos{checked})",
        "status": "done",
        "source": _shown(path),
        **summary,
        "train_steps": doc.get("train_steps"),
        "train_wall_time_s": doc.get("train_wall_time_s"),
        "eval_wall_time_s": doc.get("eval_wall_time_s"),
        "wall_time_s": doc.get("wall_time_s"),
        "lerobot_eval": ran or None,
        "lerobot_eval_disagreeing_seeds": _disagreeing_seeds(eps, ran),
        "force_inputs": doc.get("force_inputs"),
        "failures": failure_counts(eps),
    }
    if demos and "max_contact_force" in summary:
        rec["change_vs_demo"] = {
            k: {
                "pooled": 100.0 * (summary[k]["mean"] / np.mean([d[k] for d in demos]) - 1.0),
                "against": "all 10 demonstrations",
            }
            for k in ("max_contact_force", "mean_contact_force")
        }
    return rec


def _disagreeing_seeds(eps: list[dict[str, Any]], ran: dict[str, Any]) -> list[int] | None:
    """The seeds whose success ``lerobot-eval`` judged otherwise than our evaluation (None: not comparable)."""
    ours = {e["seed"]: bool(e["success"]) for e in eps if "seed" in e and "success" in e}
    seeds, successes = ran.get("seeds"), ran.get("successes")
    if not ours or not seeds or not successes or any(s not in ours for s in seeds):
        return None
    return [s for s, ok in zip(seeds, successes, strict=True) if ours[s] != bool(ok)]
