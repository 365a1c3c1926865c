"""The Markdown tables of ``results/experiments.md``: Tables II and III, grasping, ablations, tuning,
targets and runtime, each a list of lines from the experiments document's records."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from experiments.fragments import Fragments
from experiments.paper.targets import PAPER_TABLE2, PAPER_TABLE3

text = Fragments(Path(__file__).parent / "templates" / "experiments.md")


def _ms(stat: dict | None, idx: int | None = None, digits: int = 1) -> str:
    if not stat:
        return "–"
    m, s = stat["mean"], stat.get("std", float("nan"))
    if idx is not None:
        m, s = m[idx], s[idx]
    return f"{m:.{digits}f} ± {s:.{digits}f}"


def _succ(rec: dict[str, Any]) -> str:
    if rec.get("status") == "pending":
        return "pending"
    if "success_rate" not in rec:
        return "–"
    ci = rec.get("success_ci95")
    s = f"{100 * rec['success_rate']:.0f}%"
    return s + (f" [{100 * ci[0]:.0f}, {100 * ci[1]:.0f}]" if ci else "")


def _chg(rec: dict[str, Any], key: str, held: bool = False) -> str:
    ch = (rec.get("change_vs_demo_held_out") if held else rec.get("change_vs_demo")) or {}
    c = ch.get(key)
    if not c:
        return "–"
    if "mean" in c:
        return f"{c['mean']:+.1f} ± {c['std']:.1f}%"
    return f"{c['pooled']:+.1f}% (vs all demos)"


def table2_md(records: list[dict[str, Any]], task: str) -> list[str]:
    rows = [r for r in records if r["experiment"] == "table2" and r["task"] == task]
    extra = "coverage" if task == "erase" else "max button travel (mm)"
    lines = [
        f"| {task}: method | n | success [95% CI] | stops | max force N | Δ max vs own demo (mean ± std over demos) | "
        f"Δ max, held-out demos | mean force N | Δ mean vs own demo | Δ mean, held-out demos | {extra} |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r.get("status") == "pending":
            lines.append(f"| {r['label']} | pending | pending | | | | | | | | |")
            continue
        name = "coverage" if task == "erase" else "max_button_travel"
        ex, sd = r.get("metric_means", {}).get(name), r.get("metric_stds", {}).get(name)
        scale, digits = (1.0, 3) if task == "erase" else (1e3, 2)
        exs = "–" if ex is None else f"{scale * ex:.{digits}f}"
        if ex is not None and sd is not None:
            exs += f" ± {scale * sd:.{digits}f}"
        lines.append(
            f"| {r['label']} | {r.get('n', '–')} | {_succ(r)} | {r.get('protective_stops', '–')} | "
            f"{_ms(r.get('max_contact_force'))} | {_chg(r, 'max_contact_force')} | {_chg(r, 'max_contact_force', True)} | "
            f"{_ms(r.get('mean_contact_force'), digits=2)} | {_chg(r, 'mean_contact_force')} | "
            f"{_chg(r, 'mean_contact_force', True)} | {exs} |"
        )
    p = PAPER_TABLE2[task]
    lines.append(
        f"| **paper (real UR5e, Table II: its demonstration(s) vs one reproduction)** | 1 | success | | | {p['max']:+.2f}% | | | {p['mean']:+.2f}% | | |"
    )
    return lines


def table3_md(records: list[dict[str, Any]]) -> list[str]:
    rows = [r for r in records if r["experiment"] == "peg"]
    lines = [
        "| peg_in_hole: method | n | success [95% CI] | stops | X max | Y max | Z max | X avg | Y avg | Z avg |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        if r.get("status") == "pending":
            lines.append(f"| {r['label']} | pending | pending | | | | | | | |")
            continue
        mx, mn = r.get("max_contact_force_xyz"), r.get("mean_contact_force_xyz")
        cells = [_ms(mx, i, 2) for i in range(3)] + [_ms(mn, i, 3) for i in range(3)]
        lines.append(
            f"| {r['label']} | {r.get('n', '–')} | {_succ(r)} | {r.get('protective_stops', '–')} | "
            + " | ".join(cells)
            + " |"
        )
    for name, v in PAPER_TABLE3.items():
        lines.append(f"| **paper: {name}** | 1 | success | | " + " | ".join(f"{x:.2f}" for x in v) + " |")
    return lines


def grasp_md(records: list[dict[str, Any]]) -> list[str]:
    rows = [r for r in records if r["experiment"] == "grasp"]
    if not rows:
        return [text("grasp_missing")]
    lines = [
        "| task | object | method | n | success [95% CI] | stops | max finger force N (f0, f1, f2) | max contact force N | failures |",
        "|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        ff = r.get("max_finger_force")
        ffs = (
            ", ".join(f"{m:.1f} ± {sd:.1f}" for m, sd in zip(ff["mean"], ff["std"], strict=True))
            if ff
            else "–"
        )
        fails = ", ".join(f"{k} {v}" for k, v in sorted(r.get("failures", {}).items())) or "–"
        lines.append(
            f"| {r['task']} | {r['object']}{' (demo)' if r.get('seen') else ' (unseen)'} | {r['label']} | {r['n']} | {_succ(r)} | "
            f"{r['protective_stops']} | {ffs} | {_ms(r.get('max_contact_force'))} | {fails} |"
        )
    return lines


def ablation_md(records: list[dict[str, Any]], task: str) -> list[str]:
    rows = [r for r in records if r["experiment"] == "ablation" and r["task"] == task]
    lines = [
        f"| {task}: variant | n | success [95% CI] | stops | max force N | Δ max vs own demo | mean force N | Δ mean vs own demo | segments | changepoint P / R / F1 vs demo phases | failures |",
        "|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        fails = ", ".join(f"{k} {v}" for k, v in sorted(r.get("failures", {}).items())) or "–"
        seg = r.get("n_segments")
        lines.append(
            f"| {r['label']} | {r['n']} | {_succ(r)} | {r['protective_stops']} | {_ms(r.get('max_contact_force'))} | "
            f"{_chg(r, 'max_contact_force')} | {_ms(r.get('mean_contact_force'), digits=2)} | {_chg(r, 'mean_contact_force')} | "
            f"{'–' if not seg else ', '.join(map(str, seg))} | {_prf(r.get('changepoints_vs_demo_phase'))} | {fails} |"
        )
    return lines


def _prf(score: dict[str, Any] | None) -> str:
    """Pooled changepoint precision / recall / F1 against the demonstrator's phase switches."""
    if not score:
        return "–"
    return f"{score['precision']:.2f} / {score['recall']:.2f} / {score['f1']:.2f}"


def _pct_spread(row: dict[str, Any], name: str) -> str:
    std = row.get(f"{name}_change_std")
    return f"{row[f'{name}_change_pct']:+.1f}%" + ("" if std is None else f" ± {std:.1f}")


def tuning_md(tuning: dict[str, Any]) -> list[str]:
    lines: list[str] = []
    for task in ("press", "erase"):
        t = tuning.get(task)
        if not t:
            continue
        lines += [
            f"**{task}** (tuning demos {t['demos']}, seeds {t['seeds']}; criterion: {t['criterion']})",
            "",
            "| variant | setting | n | success | stops | Δ max (mean ± std over demos) | Δ mean | chosen |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for part, name in (
            ("weights", "weights"),
            ("weights_limit", "weights + limit"),
            ("limit_alone", "limit alone"),
        ):
            chosen = t[part]["chosen"]
            for row in t[part]["grid"]:
                lines.append(
                    f"| {name} | {row['label']} | {row['n']} | {100 * row['success_rate']:.0f}% | {row['protective_stops']} | "
                    f"{_pct_spread(row, 'max')} | {_pct_spread(row, 'mean')} | {'**✓**' if row['params'] == chosen else ''} |"
                )
        lines.append("")
    t = tuning.get("peg_in_hole")
    if t:
        lines += [
            f"**peg_in_hole** (tuning demos {t['demos']}, seeds {t['seeds']}; six numbers = X/Y/Z max, X/Y/Z mean)",
            "",
            "| method | setting | n | success | six numbers (N, means over episodes) | normalised sum | below tuned hybrid | chosen |",
            "|---|---|---|---|---|---|---|---|",
        ]
        for part in ("hybrid", "ours"):
            chosen = t[part]["chosen"]
            for row in t[part]["grid"]:
                sixn = ", ".join(f"{v:.2f}" for v in [*row["max_xyz"], *row["mean_xyz"]])
                lines.append(
                    f"| {part} | {row['label']} | {row['n']} | {100 * row['success_rate']:.0f}% | {sixn} | {row['normalised_sum']:.2f} | "
                    f"{row.get('below_hybrid', '–')} | {'**✓**' if row['params'] == chosen else ''} |"
                )
        lines += ["", f"Criteria: hybrid — {t['hybrid']['criterion']}; ours — {t['ours']['criterion']}.", ""]
    return lines


def targets_md(checked: list[dict[str, Any]]) -> list[str]:
    """The targets table of ``targets.targets``' rows, after its legend."""
    L = [
        text("targets_legend"),
        "",
        "| target | method | ours | met | force beyond the spread | success lower bound |",
        "|---|---|---|---|---|---|",
    ]
    for t in checked:
        met = "yes" if t["met"] else "**no**"
        beyond = {True: "yes", False: "no", None: "–"}[t.get("force_met_with_95_interval")]
        lower = t.get("success_lower_95")
        lower = "–" if lower is None else f"{100 * lower:.0f}%"
        L.append(f"| {t['target']} | {t['method']} | {t['value']} | {met} | {beyond} | {lower} |")
    return L


def runtime_md(run: dict[str, Any]) -> list[str]:
    """Wall time and episodes per stage of a run's ``runtime``, and the total."""
    lines = ["| stage | wall time (s) | episodes |", "|---|---|---|"]
    for stage, v in run["stages"].items():
        lines.append(f"| {stage} | {v['wall_s']:.0f} | {v.get('episodes') or '–'} |")
    lines.append(f"| **total** | {run['total_s']:.0f} ({run['total_s'] / 60:.1f} min) | |")
    return lines
