"""Stage 0: choose the settings of the reported variants on tuning seeds and tuning demonstrations only.

Every grid point runs the tuning demonstrations (0..4) on the tuning seeds (2000, 2001): 10 episodes.
A grid point is *eligible* when all its tuning episodes succeed with no protective stop
(success >= 95 % of 10 episodes means all 10).

Table II (press, erase), three variants of ours (SPEC §1: force limits compared with the weights alone):

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

from experiments.paper.jobs import demo_change, demo_force_records, run_jobs

from .common import CONTACT_STIFFNESS, Settings, hybrid_kwargs, make_jobs

AXES = "xyz"


def _records(results: list[dict[str, Any]]) -> list[dict[str, Any]]:
    return [r for res in results for r in res["records"]]


def grid_row(
    label: str, params: dict[str, Any], records: list[dict[str, Any]], demos: list[dict[str, Any]]
) -> dict[str, Any]:
    """Tuning figures of one grid point: success, stops, % change of max / mean force (mean and std over demos),
    mean per-axis max / mean force, and eligibility."""
    n = len(records)
    ok = sum(r["success"] for r in records)
    stops = sum(r["protective_stop"] for r in records)
    d_max = demo_change(records, demos, "max_contact_force")
    d_mean = demo_change(records, demos, "mean_contact_force")
    row = {
        "label": label,
        "params": params,
        "n": n,
        "success_rate": ok / n if n else 0.0,
        "protective_stops": stops,
        "eligible": n > 0 and ok / n >= 0.95 and stops == 0,
        "max_change_pct": d_max["mean"],
        "max_change_std": d_max["std"],  # over the tuning demonstrations, ddof 1
        "mean_change_pct": d_mean["mean"],
        "mean_change_std": d_mean["std"],
        "max_xyz": np.mean([r["max_contact_force_xyz"] for r in records], axis=0).tolist(),
        "mean_xyz": np.mean([r["mean_contact_force_xyz"] for r in records], axis=0).tolist(),
    }
    return row


def _pick_lowest_mean(rows: list[dict[str, Any]]) -> dict[str, Any] | None:
    eligible = [r for r in rows if r["eligible"]]
    return min(eligible, key=lambda r: r["mean_change_pct"]) if eligible else None


def _dataset(task: str):
    from .common import REPO

    return REPO / "datasets" / task


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
        out = run_jobs(
            flat, self.s.workdir, force=self.s.force, desc=desc, runner=self.s.runner, workers=self.s.workers
        )
        by_key = {r["key"]: r for r in out}
        self.results = {n: _records([by_key[j.key()] for j in js]) for n, js in self.jobs.items()}


def tune_all(s: Settings) -> dict[str, Any]:
    """Both phases for press, erase and peg_in_hole (module docstring); returns the tuning document."""
    t2 = ("press", "erase")
    peg = "peg_in_hole"
    demos = {t: demo_force_records(_dataset(t)) for t in (*t2, peg)}

    # phase 1: stiffness of the weights, limit alone, hybrid threshold
    b1 = _Batch(s)
    for task in t2:
        for k in s.stiffness_grid[task]:
            b1.add(f"{task}_k{k:g}", task, "forcemap", (f"stiffness={k:g}",))
        kc = CONTACT_STIFFNESS[task]
        for lim in s.limit_grid[task]:
            b1.add(
                f"{task}_d0k{kc:g}L{lim:g}",
                task,
                "forcemap",
                ("delta=0", f"stiffness={kc:g}", f"force_limit={lim:g}"),
            )
    for thr in s.hybrid_thresholds:
        for normal in s.hybrid_normals:
            b1.add(f"peg_hyb{thr:g}{normal}", peg, "hybrid", hybrid=hybrid_kwargs(thr, normal))
    b1.run("tuning 1/2")

    out: dict[str, Any] = {}
    k_star: dict[str, float] = {}
    for task in t2:
        weights = [
            grid_row(f"k={k:g}", {"stiffness": k}, b1.results[f"{task}_k{k:g}"], demos[task])
            for k in s.stiffness_grid[task]
        ]
        best_w = _pick_lowest_mean(weights)
        k_star[task] = best_w["params"]["stiffness"] if best_w else max(s.stiffness_grid[task])
        kc = CONTACT_STIFFNESS[task]
        alone = [
            grid_row(
                f"delta=0, k={kc:g}, L={lim:g}",
                {"delta": 0.0, "stiffness": kc, "force_limit": lim},
                b1.results[f"{task}_d0k{kc:g}L{lim:g}"],
                demos[task],
            )
            for lim in s.limit_grid[task]
        ]
        best_a = _pick_lowest_mean(alone)
        out[task] = {
            "task": task,
            "seeds": list(s.tune_seeds),
            "demos": list(s.tune_demos),
            "criterion": "eligible (all tuning episodes succeed, no protective stop); lowest mean-force change",
            "weights": {"grid": weights, "chosen": best_w["params"] if best_w else None},
            "limit_alone": {"grid": alone, "chosen": best_a["params"] if best_a else None},
            "_best_w": best_w,
        }
    used = [d for d in demos[peg] if d["episode"] in s.tune_demos]
    demo_six = np.concatenate(
        [
            np.mean([d["max_contact_force_xyz"] for d in used], axis=0),
            np.mean([d["mean_contact_force_xyz"] for d in used], axis=0),
        ]
    )
    hybrid_rows = []
    for thr in s.hybrid_thresholds:
        for normal in s.hybrid_normals:
            row = grid_row(
                f"T={thr:g} N, normal {normal}",
                {"force_threshold": thr, "normal": normal},
                b1.results[f"peg_hyb{thr:g}{normal}"],
                demos[peg],
            )
            row["normalised_sum"] = normalised_sum(row, demo_six)
            hybrid_rows.append(row)
    best_h = min([r for r in hybrid_rows if r["eligible"]] or hybrid_rows, key=lambda r: r["normalised_sum"])
    thr_star = best_h["params"]["force_threshold"]

    # phase 2: the force limit on top of the chosen weights; ours on peg at the chosen threshold
    b2 = _Batch(s)
    for task in t2:
        for lim in s.limit_grid[task]:
            b2.add(
                f"{task}_k{k_star[task]:g}L{lim:g}",
                task,
                "forcemap",
                (f"stiffness={k_star[task]:g}", f"force_limit={lim:g}"),
            )
    for k in s.peg_stiffness_grid:
        for fc in s.peg_f_contact_grid:
            b2.add(
                f"peg_k{k:g}fc{fc:g}L{thr_star:g}",
                peg,
                "forcemap",
                (f"stiffness={k:g}", f"force_limit={thr_star:g}", f"f_contact={fc:g}"),
            )
    b2.run("tuning 2/2")

    for task in t2:
        t = out[task]
        best_w = t.pop("_best_w")
        first = dict(best_w or t["weights"]["grid"][-1], label=f"k={k_star[task]:g}, no limit")
        first["params"] = {"stiffness": k_star[task], "force_limit": None}
        combined = [first] + [
            grid_row(
                f"k={k_star[task]:g}, L={lim:g}",
                {"stiffness": k_star[task], "force_limit": lim},
                b2.results[f"{task}_k{k_star[task]:g}L{lim:g}"],
                demos[task],
            )
            for lim in s.limit_grid[task]
        ]
        best_c = _pick_lowest_mean(combined)
        t["weights_limit"] = {"grid": combined, "chosen": best_c["params"] if best_c else None}

    ref = six_numbers(best_h)
    ours_rows = []
    for k in s.peg_stiffness_grid:
        for fc in s.peg_f_contact_grid:
            row = grid_row(
                f"k={k:g}, f_contact={fc:g}, L={thr_star:g}",
                {"stiffness": k, "f_contact": fc, "force_limit": thr_star},
                b2.results[f"peg_k{k:g}fc{fc:g}L{thr_star:g}"],
                demos[peg],
            )
            row["normalised_sum"] = normalised_sum(row, demo_six)
            row["below_hybrid"] = int(np.sum(six_numbers(row) < ref))
            ours_rows.append(row)
    best_o = min(
        [r for r in ours_rows if r["eligible"]] or ours_rows,
        key=lambda r: (-r["below_hybrid"], r["normalised_sum"]),
    )
    out[peg] = {
        "task": peg,
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
    return out
