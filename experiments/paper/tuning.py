"""Stage 0: choose the settings of the reported variants on tuning seeds and tuning demonstrations only.

Every grid point runs the tuning demonstrations (0..4) on the tuning seeds (2000, 2001): 10 episodes.
A grid point is *eligible* when all its tuning episodes succeed with no protective stop
(success >= 95 % of 10 episodes means all 10).

Table II (press, erase), three variants of ours (force limits compared with the weights alone):

- ``weights``: stiffness k from ``STIFFNESS_GRID``; choose the eligible k with the lowest mean
  contact force (mean over tuning demonstrations of the per-demonstration % change).
- ``weights + limit``: k from ``weights`` plus ``force_limit`` L from ``LIMIT_GRID`` (the half-spaces
  share k with the weights); same criterion; "no limit" competes too, so the limit is only used
  when it helps.
- ``limit alone``: no force weights (delta = 0), k = the contact stiffness of the task
  (``CONTACT_STIFFNESS``), L from ``LIMIT_GRID``; same criterion.

Table III (peg_in_hole):

- hybrid control: threshold from ``HYBRID_THRESHOLDS`` x normal (fixed +z, or the measured force
  direction); choose the eligible one with the lowest *normalised six-number sum*
  sum_axis (max_axis / demo max_axis + mean_axis / demo mean_axis) — the baseline gets its best setting.
- ours: ``force_limit`` = the chosen hybrid threshold (the paper: the same threshold for both);
  stiffness from ``PEG_STIFFNESS_GRID`` x ``f_contact`` from ``PEG_F_CONTACT_GRID``; choose the eligible
  point that beats the tuned hybrid on the most of the six per-axis numbers (on the tuning
  episodes), ties broken by the normalised six-number sum.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from experiments.paper.demos import demo_force_records
from experiments.paper.jobs import run_jobs
from lerobot_forcemap.evaluation.stats import demo_change, summarize

from .common import CONTACT_STIFFNESS, REPO, Settings, hybrid_kwargs, make_jobs

T2_TASKS = ("press", "erase")
PEG = "peg_in_hole"
#: the figures of a grid row
XYZ_KEYS = ("max_contact_force_xyz", "mean_contact_force_xyz")


def _records(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [r for res in results for r in res["records"]]


def grid_row(
    label: str, params: dict[str, Any], records: list[dict[str, Any]], demos: list[dict[str, Any]]
) -> dict[str, Any]:
    """Tuning figures of one grid point: success, stops, % change of max / mean force (mean and std over demos),
    mean per-axis max / mean force, and eligibility (every episode succeeds, no protective stop)."""
    s = summarize(records, XYZ_KEYS, clipped=False)
    d_max = demo_change(records, demos, "max_contact_force")
    d_mean = demo_change(records, demos, "mean_contact_force")
    return {
        "label": label,
        "params": params,
        "n": s["n"],
        "success_rate": s["success_rate"],
        "protective_stops": s["protective_stops"],
        "eligible": s["success_rate"] >= 0.95 and s["protective_stops"] == 0,
        "max_change_pct": d_max["mean"],
        "max_change_std": d_max["std"],  # over the tuning demonstrations, ddof 1
        "mean_change_pct": d_mean["mean"],
        "mean_change_std": d_mean["std"],
        "max_xyz": s["max_contact_force_xyz"]["mean"],
        "mean_xyz": s["mean_contact_force_xyz"]["mean"],
    }


def _pick_lowest_mean(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    eligible = [r for r in rows if r["eligible"]]
    return min(eligible, key=lambda r: r["mean_change_pct"]) if eligible else None


def six_numbers(row: dict[str, Any]) -> np.ndarray:
    return np.concatenate([row["max_xyz"], row["mean_xyz"]])


def normalised_sum(row: dict[str, Any], demo_six: np.ndarray) -> float:
    return float(np.sum(six_numbers(row) / demo_six))


class _Batch:
    """Grid points queued as jobs, run together (one pool pass), then read back by name."""

    def __init__(self, s: Settings):
        self.s = s
        self.jobs: dict[str, list] = {}
        self.results: dict[str, list[dict[str, Any]]] = {}

    def add(self, name: str, task: str, kind: str, overrides=(), hybrid=None) -> None:
        s = self.s
        self.jobs[name] = make_jobs(
            task, f"tune_{name}", kind, s.tune_demos, s.tune_seeds, overrides=overrides, hybrid=hybrid
        )

    def run(self, desc: str) -> None:
        flat = [j for js in self.jobs.values() for j in js]
        s = self.s
        out = run_jobs(flat, s.workdir, s.executor, force=s.force, desc=desc, stats=s.stats)
        by_key = {r["key"]: r for r in out}
        self.results = {n: _records([by_key[j.key()] for j in js]) for n, js in self.jobs.items()}


def tune_all(s: Settings) -> dict[str, Any]:
    """Both phases for press, erase and peg_in_hole (module docstring); returns the tuning document."""
    demos = {t: demo_force_records(REPO / "datasets" / t) for t in (*T2_TASKS, PEG)}
    # phase 1: stiffness of the weights, limit alone, hybrid threshold
    b1 = _phase1_batch(s)
    b1.run("tuning 1/2")
    out: dict[str, Any] = {}
    best_w: dict[str, dict[str, Any] | None] = {}
    for task in T2_TASKS:
        out[task], best_w[task] = _weights_and_limit_alone(task, s, b1, demos[task])
    k_star = {
        task: best_w[task]["params"]["stiffness"] if best_w[task] else max(s.stiffness_grid[task])
        for task in T2_TASKS
    }
    used = [d for d in demos[PEG] if d["episode"] in s.tune_demos]
    demo_six = np.concatenate(
        [
            np.mean([d["max_contact_force_xyz"] for d in used], axis=0),
            np.mean([d["mean_contact_force_xyz"] for d in used], axis=0),
        ]
    )
    hybrid_rows = _hybrid_rows(s, b1, demos[PEG], demo_six)
    best_h = min([r for r in hybrid_rows if r["eligible"]] or hybrid_rows, key=lambda r: r["normalised_sum"])
    thr_star = best_h["params"]["force_threshold"]
    # phase 2: the force limit on top of the chosen weights; ours on peg at the chosen threshold
    b2 = _phase2_batch(s, k_star, thr_star)
    b2.run("tuning 2/2")
    for task in T2_TASKS:
        first = best_w[task] or out[task]["weights"]["grid"][-1]
        out[task]["weights_limit"] = _weights_limit(task, s, b2, demos[task], first, k_star[task])
    out[PEG] = _peg_tuning(s, b2, demos[PEG], demo_six, hybrid_rows, best_h)
    return out


def _phase1_batch(s: Settings) -> _Batch:
    """Phase 1's grid points: stiffness of the weights and the limit alone (press, erase), hybrid
    threshold x normal (peg)."""
    b = _Batch(s)
    for task in T2_TASKS:
        for k in s.stiffness_grid[task]:
            b.add(f"{task}_k{k:g}", task, "forcemap", (f"stiffness={k:g}",))
        kc = CONTACT_STIFFNESS[task]
        for lim in s.limit_grid[task]:
            b.add(
                f"{task}_d0k{kc:g}L{lim:g}",
                task,
                "forcemap",
                ("delta=0", f"stiffness={kc:g}", f"force_limit={lim:g}"),
            )
    for thr in s.hybrid_thresholds:
        for normal in s.hybrid_normals:
            b.add(f"peg_hyb{thr:g}{normal}", PEG, "hybrid", hybrid=hybrid_kwargs(thr, normal))
    return b


def _weights_and_limit_alone(
    task: str, s: Settings, b1: _Batch, demos: list[dict[str, Any]]
) -> tuple[dict[str, Any], dict[str, Any] | None]:
    """A task's tuning entry with the weights' and the limit-alone grids and choices, and the best
    weights row (None when no grid point is eligible)."""
    weights = [
        grid_row(f"k={k:g}", {"stiffness": k}, b1.results[f"{task}_k{k:g}"], demos)
        for k in s.stiffness_grid[task]
    ]
    best_w = _pick_lowest_mean(weights)
    kc = CONTACT_STIFFNESS[task]
    alone = [
        grid_row(
            f"delta=0, k={kc:g}, L={lim:g}",
            {"delta": 0.0, "stiffness": kc, "force_limit": lim},
            b1.results[f"{task}_d0k{kc:g}L{lim:g}"],
            demos,
        )
        for lim in s.limit_grid[task]
    ]
    best_a = _pick_lowest_mean(alone)
    entry = {
        "task": task,
        "seeds": list(s.tune_seeds),
        "demos": list(s.tune_demos),
        "criterion": "eligible (all tuning episodes succeed, no protective stop); lowest mean-force change",
        "weights": {"grid": weights, "chosen": best_w["params"] if best_w else None},
        "limit_alone": {"grid": alone, "chosen": best_a["params"] if best_a else None},
    }
    return entry, best_w


def _hybrid_rows(
    s: Settings, b1: _Batch, demos: list[dict[str, Any]], demo_six: np.ndarray
) -> list[dict[str, Any]]:
    rows = []
    for thr in s.hybrid_thresholds:
        for normal in s.hybrid_normals:
            row = grid_row(
                f"T={thr:g} N, normal {normal}",
                {"force_threshold": thr, "normal": normal},
                b1.results[f"peg_hyb{thr:g}{normal}"],
                demos,
            )
            row["normalised_sum"] = normalised_sum(row, demo_six)
            rows.append(row)
    return rows


def _phase2_batch(s: Settings, k_star: dict[str, float], thr_star: float) -> _Batch:
    """Phase 2's grid points: the force limit on the chosen weights; ours on peg with the chosen
    hybrid threshold as its limit, stiffness x f_contact."""
    b = _Batch(s)
    for task in T2_TASKS:
        for lim in s.limit_grid[task]:
            b.add(
                f"{task}_k{k_star[task]:g}L{lim:g}",
                task,
                "forcemap",
                (f"stiffness={k_star[task]:g}", f"force_limit={lim:g}"),
            )
    for k in s.peg_stiffness_grid:
        for fc in s.peg_f_contact_grid:
            b.add(
                f"peg_k{k:g}fc{fc:g}L{thr_star:g}",
                PEG,
                "forcemap",
                (f"stiffness={k:g}", f"force_limit={thr_star:g}", f"f_contact={fc:g}"),
            )
    return b


def _weights_limit(
    task: str,
    s: Settings,
    b2: _Batch,
    demos: list[dict[str, Any]],
    no_limit: dict[str, Any],
    k: float,
) -> dict[str, Any]:
    """The weights + limit grid and its choice; ``no_limit`` (the chosen weights' row) competes as
    "no limit"."""
    first = dict(no_limit, label=f"k={k:g}, no limit")
    first["params"] = {"stiffness": k, "force_limit": None}
    combined = [first] + [
        grid_row(
            f"k={k:g}, L={lim:g}",
            {"stiffness": k, "force_limit": lim},
            b2.results[f"{task}_k{k:g}L{lim:g}"],
            demos,
        )
        for lim in s.limit_grid[task]
    ]
    best_c = _pick_lowest_mean(combined)
    return {"grid": combined, "chosen": best_c["params"] if best_c else None}


def _peg_tuning(
    s: Settings,
    b2: _Batch,
    demos: list[dict[str, Any]],
    demo_six: np.ndarray,
    hybrid_rows: list[dict[str, Any]],
    best_h: dict[str, Any],
) -> dict[str, Any]:
    """peg_in_hole's entry: the hybrid grid and choice, and ours at the chosen threshold, chosen by how
    many of the six numbers it gets below the tuned hybrid's."""
    thr = best_h["params"]["force_threshold"]
    ref = six_numbers(best_h)
    ours_rows = []
    for k in s.peg_stiffness_grid:
        for fc in s.peg_f_contact_grid:
            row = grid_row(
                f"k={k:g}, f_contact={fc:g}, L={thr:g}",
                {"stiffness": k, "f_contact": fc, "force_limit": thr},
                b2.results[f"peg_k{k:g}fc{fc:g}L{thr:g}"],
                demos,
            )
            row["normalised_sum"] = normalised_sum(row, demo_six)
            row["below_hybrid"] = int(np.sum(six_numbers(row) < ref))
            ours_rows.append(row)
    best_o = min(
        [r for r in ours_rows if r["eligible"]] or ours_rows,
        key=lambda r: (-r["below_hybrid"], r["normalised_sum"]),
    )
    return {
        "task": PEG,
        "seeds": list(s.tune_seeds),
        "demos": list(s.tune_demos),
        "demo_six": demo_six.tolist(),
        "hybrid": {
            "grid": hybrid_rows,
            "chosen": best_h["params"],
            "criterion": "eligible; lowest sum of the six per-axis numbers normalised by the demonstrations'",
        },
        "ours": {
            "grid": ours_rows,
            "chosen": best_o["params"],
            "criterion": "eligible; most of the six per-axis numbers below the tuned hybrid's, then lowest normalised sum",
        },
    }
