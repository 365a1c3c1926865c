"""``results/wide.md`` from the document of ``experiments/wide.py``: a table per task, the targets
(met or missed, with the numbers), and the controller-stiffness check."""

from __future__ import annotations

from typing import Any

from experiments.wide import FORCE_TASKS, STIFFNESS_SCALES, with_set

GRASP = ("grasp_push", "grasp_flip")
#: the order of a task table's rows
_ROW_ORDER = ("defaults", "defaults_no_feedback", "k3000", "tuned", "hybrid")
#: how far (points) a force reduction may move between x0.5 / x2 and x1
STIFFNESS_SPREAD = 10.0


def _change(rec: dict[str, Any], key: str) -> float | None:
    ch = rec.get("change_vs_demo", {}).get(key)
    return None if not ch or "mean" not in ch else float(ch["mean"])


def _pct(v: float | None) -> str:
    return "–" if v is None else f"{v:+.1f}"


def _success(rec: dict[str, Any]) -> str:
    lo, hi = rec["success_ci95"]
    return f"{100 * rec['success_rate']:.0f} % [{100 * lo:.0f}, {100 * hi:.0f}]"


def _metric(rec: dict[str, Any]) -> str:
    m = rec.get("metric_means", {})
    parts = []
    if "coverage" in m:
        parts.append(f"coverage {m['coverage']:.3f}")
    if "max_button_travel" in m:
        parts.append(f"travel {1e3 * m['max_button_travel']:.1f} mm (min {1e3 * m['min_button_travel']:.1f})")
    if rec["task"] == "peg_in_hole":
        mx, mn = rec["max_contact_force_xyz"]["mean"], rec["mean_contact_force_xyz"]["mean"]
        parts.append(
            "max " + "/".join(f"{v:.2f}" for v in mx) + " N, mean " + "/".join(f"{v:.3f}" for v in mn) + " N"
        )
    fails = rec.get("failures") or {}
    if fails:
        parts.append("failures: " + ", ".join(f"{k} {v}" for k, v in fails.items()))
    return "; ".join(parts)


def _table(rows: list[dict[str, Any]]) -> list[str]:
    out = [
        "| row | n | success [95 % CI] | max \\|F\\| N | Δmax % | mean \\|F\\| N | Δmean % | task figures |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        label = r["label"] + (f" — {r['object']}" if r.get("object") else "")
        out.append(
            f"| {label} | {r['n']} | {_success(r)} | {r['max_contact_force']['mean']:.2f} | "
            f"{_pct(_change(r, 'max_contact_force'))} | {r['mean_contact_force']['mean']:.2f} | "
            f"{_pct(_change(r, 'mean_contact_force'))} | {_metric(r)} |"
        )
    return out


def _failure_lines(rows: list[dict[str, Any]]) -> list[str]:
    """The scene draws of the defaults rows' failed episodes (what made them fail)."""
    out = []
    for r in rows:
        fails = r.get("variation_of_failures") or []
        if r["method"] != "defaults" or not fails:
            continue
        shown = "; ".join(
            f"seed {f['seed']} ({f['reason']}): spring x{f['spring_scale']:.2f}, controller x{f['stiffness_scale']:.2f}, "
            f"yaw {f['yaw']:+.2f} rad, shift {1e3 * f['shift'][0]:+.0f}/{1e3 * f['shift'][1]:+.0f}/{1e3 * f['shift'][2]:+.0f} mm"
            for f in fails[:12]
        )
        obj = f" ({r['object']})" if r.get("object") else ""
        out += ["", f"Failed episodes of the defaults{obj}: {shown}{' ...' if len(fails) > 12 else ''}."]
    return out


def _find(records, part: str, task: str, method: str, obj: str | None = None, scale: float | None = None):
    for r in records:
        if (r["experiment"], r["task"], r["method"]) != (part, task, method):
            continue
        if obj is not None and r.get("object") != obj:
            continue
        if scale is not None and r["settings"].get("stiffness_scale") != scale:
            continue
        return r
    return None


def target_lines(records: list[dict[str, Any]]) -> list[str]:
    """One line per task: the defaults row against the issue's target."""
    lines = []
    r = _find(records, "wide", "press", "defaults")
    if r:
        dmax, dmean = _change(r, "max_contact_force"), _change(r, "mean_contact_force")
        ok = r["success_rate"] >= 0.95 and dmax <= -84 and dmean <= -67
        lines.append(
            f"- press: {'met' if ok else 'MISSED'} — success {100 * r['success_rate']:.0f} % (target >= 95 %), "
            f"Δmax {dmax:+.1f} % (<= -84 %), Δmean {dmean:+.1f} % (<= -67 %)"
        )
    r = _find(records, "wide", "erase", "defaults")
    if r:
        dmean, cov = _change(r, "mean_contact_force"), r.get("metric_means", {}).get("coverage", float("nan"))
        ok = dmean <= -32 and cov >= 0.9
        lines.append(
            f"- erase: {'met' if ok else 'MISSED'} — Δmean {dmean:+.1f} % (<= -32 %), coverage {cov:.3f} "
            f"(>= 0.9), success {100 * r['success_rate']:.0f} %"
        )
    r, h = _find(records, "wide", "peg_in_hole", "defaults"), _find(records, "wide", "peg_in_hole", "hybrid")
    if r and h:
        ours = [*r["max_contact_force_xyz"]["mean"], *r["mean_contact_force_xyz"]["mean"]]
        theirs = [*h["max_contact_force_xyz"]["mean"], *h["mean_contact_force_xyz"]["mean"]]
        below = [a < b for a, b in zip(ours, theirs, strict=True)]
        show = ", ".join(f"{a:.3g} vs {b:.3g}" for a, b in zip(ours, theirs, strict=True))
        lines.append(
            f"- peg_in_hole: {'met' if all(below) else 'MISSED'} — {sum(below)}/6 per-axis numbers below hybrid "
            f"(max x/y/z, mean x/y/z, ours vs hybrid, N: {show}); success {100 * r['success_rate']:.0f} %"
        )
    for task in GRASP:
        rows = [
            x for x in records if (x["experiment"], x["task"], x["method"]) == ("grasp", task, "defaults")
        ]
        if rows:
            ok = all(x["success_rate"] >= 0.9 for x in rows)
            show = ", ".join(f"{x['object']} {100 * x['success_rate']:.0f} % (n {x['n']})" for x in rows)
            lines.append(f"- {task}: {'met' if ok else 'MISSED'} — success {show} (target >= 90 % each)")
    return lines


def stiffness_lines(records: list[dict[str, Any]], extra: list[str] | tuple[str, ...] = ()) -> list[str]:
    """The x0.5 / x1 / x2 table and its verdict per task and force law (``extra``: the ``--set``
    settings the defaults ran with, named in the law column)."""
    out = [
        "| task | law | success x0.5 / x1 / x2 | Δmax % x0.5 / x1 / x2 | Δmean % x0.5 / x1 / x2 | verdict |",
        "|---|---|---|---|---|---|",
    ]
    for task in (*FORCE_TASKS, *GRASP):
        for method in ("defaults", "k3000"):
            cells = [_find(records, "stiffness", task, method, scale=s) for s in STIFFNESS_SCALES]
            if not all(cells):
                continue
            succ = [c["success_rate"] for c in cells]
            dmax = [_change(c, "max_contact_force") for c in cells]
            dmean = [_change(c, "mean_contact_force") for c in cells]
            spread = max(abs(d - dmean[1]) for d in dmean) if None not in dmean else float("nan")
            spread_max = max(abs(d - dmax[1]) for d in dmax) if None not in dmax else float("nan")
            ok = min(succ) >= 0.9 and spread <= STIFFNESS_SPREAD and spread_max <= STIFFNESS_SPREAD
            law = with_set(method, extra) if method == "defaults" else method
            out.append(
                f"| {task} | {law} | {' / '.join(f'{100 * v:.0f} %' for v in succ)} | "
                f"{' / '.join(_pct(v) for v in dmax)} | {' / '.join(_pct(v) for v in dmean)} | "
                f"{'met' if ok else 'MISSED'} (Δmax within {spread_max:.1f}, Δmean within {spread:.1f} points of x1) |"
            )
    return out


def write_report(doc: dict[str, Any]) -> str:
    records = doc["records"]
    lines = [
        "# Force tasks under wide variation",
        "",
        doc["protocol"].strip(),
        "",
        f"## Targets ({with_set('package defaults', doc.get('set', ()))})",
        "",
    ]
    lines += target_lines(records)
    for task in (*FORCE_TASKS, *GRASP):
        rows = [r for r in records if r["task"] == task and r["experiment"] in ("wide", "grasp")]
        rows.sort(key=lambda r: (r.get("object") or "", _ROW_ORDER.index(r["method"])))
        if not rows:
            continue
        lines += [
            "",
            f'## {task} (randomize="wide")',
            "",
            *_table(rows),
            "",
            f"Learned: {doc['learned'][task]}.",
            *_failure_lines(rows),
        ]
    lines += [
        "",
        "## Controller stiffness x0.5 / x1 / x2 (one checkpoint per task: demonstration 0; paper scenes)",
        "",
        f"Target: success >= 90 % at every stiffness, and the force change within {STIFFNESS_SPREAD:g} points "
        "of the x1 figure.",
        "",
        *stiffness_lines(records, doc.get("set", ())),
        "",
    ]
    return "\n".join(lines)
