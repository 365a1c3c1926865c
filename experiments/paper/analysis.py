"""The "where we miss, and why" section of ``results/experiments.md``, written from the numbers.

Every number is computed from this run's records and traces (nothing is pasted in by hand); the prose,
including the mechanisms the traces show, is in ``templates/analysis.md``, one fragment per sentence
or bullet that a result may call for.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from experiments.fragments import Fragments
from experiments.paper.targets import SIX_NAMES, six

#: press physics (``lerobot_forcemap/envs/tasks/press.py``): the switch point and the hard stop
PRESS_SWITCH_N = 6.4
PRESS_STOP_N = 8.0
#: erase: the sim impedance (2000 N/m) in series with the eraser's 2000 N/m spring
ERASE_K_EFF = 1000.0
SIM_K = 2000.0

text = Fragments(Path(__file__).parent / "templates" / "analysis.md")


def _rec(doc, **kw) -> dict[str, Any] | None:
    for r in doc["records"]:
        if all(r.get(k) == v for k, v in kw.items()):
            return r
    return None


def _cells(cells, experiment: str, task: str, method: str, obj: str | None = None):
    return [
        c
        for c in cells
        if c.experiment == experiment
        and c.task == task
        and c.method == method
        and (obj is None or c.object == obj)
    ]


def _trace(cells, experiment: str, task: str, method: str, obj: str | None = None):
    """(rows, column index) of the first traced episode of the matching cells, or None."""
    for c in _cells(cells, experiment, task, method, obj):
        for r in c.records:
            if r.get("trace"):
                rows = np.asarray(r["trace"]["rows"], dtype=float)
                return rows, {k: i for i, k in enumerate(r["trace"]["columns"])}
    return None


def _failing_demos(cells, experiment: str, task: str, method: str) -> dict[int, dict[str, float]]:
    """Per demonstration whose episodes did not all succeed: its success rate and mean max button travel (mm)."""
    out: dict[int, list] = {}
    for c in _cells(cells, experiment, task, method):
        for r in c.records:
            out.setdefault(r["demo"], []).append(r)
    fails = {}
    for d, rs in sorted(out.items()):
        rate = float(np.mean([r["success"] for r in rs]))
        if rate < 1.0:
            travel = [
                r["metrics"].get("max_button_travel") for r in rs if "max_button_travel" in r["metrics"]
            ]
            fails[d] = {
                "success": rate,
                "travel_mm": 1e3 * float(np.mean(travel)) if travel else float("nan"),
            }
    return fails


def _gripper_opening(rows: np.ndarray, c: dict[str, int]) -> dict[str, float] | None:
    """The first gripper opening of a trace: the command leaves >= 0.95 at ``start`` and reaches <= 0.05 at
    ``end`` (None if the episode ended first; then ``last`` is the command at the episode's end, ``t_last``)."""
    g = rows[:, c["gripper"]]
    t = rows[:, c["t"]]
    hi = np.flatnonzero(g >= 0.95)
    if not len(hi):
        return None
    leaving = np.flatnonzero((g < 0.95) & (np.arange(len(g)) > hi[0]))
    if not len(leaving):
        return None
    start = leaving[0] - 1
    low = np.flatnonzero((g <= 0.05) & (np.arange(len(g)) > start))
    end = float(t[low[0]]) if len(low) else None
    return {"start": float(t[start]), "end": end, "last": float(g[-1]), "t_last": float(t[-1])}


def _opening_text(op: dict[str, float] | None) -> str:
    if op is None:
        return text("opening_none")
    if op["end"] is not None:
        return text("opening_done", duration=op["end"] - op["start"], start=op["start"])
    return text("opening_unfinished", start=op["start"], last=op["last"], t_last=op["t_last"])


def _slow(op: dict[str, float] | None) -> bool:
    """An opening that takes longer than 0.2 s (or does not end): the fingers drag the object."""
    return op is not None and (op["end"] is None or op["end"] - op["start"] > 0.2)


# ---- press ----------------------------------------------------------------------------------------------


def press_section(doc, cells) -> list[str]:
    demos = _rec(doc, experiment="table2", task="press", method="demonstration")
    ours = _rec(doc, experiment="table2", task="press", method="ours")
    if not demos or not ours:
        return []
    tuning = doc["tuning"].get("press", {})
    k = (tuning.get("weights", {}).get("chosen") or {}).get("stiffness")
    out = [text("press_heading")]
    pkg = _rec(doc, experiment="table2", task="press", method="ours_default")
    if pkg:
        out.append(
            text("press_package", c=pkg["change_vs_demo"], success_pct=100 * pkg["success_rate"], n=pkg["n"])
        )
    out.append(_press_weights(ours, k))
    if k is not None and k < SIM_K:
        grid = {row["params"]["stiffness"]: row for row in tuning["weights"]["grid"]}
        softer = ", ".join(
            f"k = {kk:g}: {100 * grid[kk]['success_rate']:.0f}%" for kk in sorted(grid) if kk < k
        )
        travel = 1e3 * ours["metric_means"].get("max_button_travel", float("nan"))
        out.append(text("press_soft_k", k=k, sim_k=SIM_K, travel_mm=travel, softer=softer))
    old = _rec(doc, experiment="table2", task="press", method="ours_k3000")
    if old:
        out.append(text("press_k3000", c=old["change_vs_demo"]))
    lim = _rec(doc, experiment="table2", task="press", method="ours_limit")
    if lim:
        out.append(_press_limit(lim, tuning, cells))
    alone = _rec(doc, experiment="table2", task="press", method="limit_alone")
    if alone:
        out.append(
            text(
                "press_limit_alone",
                c=alone["change_vs_demo"],
                success_pct=100 * alone["success_rate"],
                peak=alone["max_contact_force"]["mean"],
            )
        )
    return out


def _press_weights(ours: dict[str, Any], k: float | None) -> str:
    """The headline bullet: the tuned weights against the target, and the floor the switch force sets."""
    from experiments.paper.demos import demo_force_records

    from .common import REPO

    d = demo_force_records(REPO / "datasets" / "press")
    fmax = np.array([x["max_contact_force"] for x in d])
    floor = 100 * (PRESS_SWITCH_N / fmax - 1)
    below = [i for i, f in enumerate(fmax) if 0.16 * f < PRESS_SWITCH_N]
    return text(
        "press_weights",
        k=k,
        c=ours["change_vs_demo"],
        success_pct=100 * ours["success_rate"],
        n=ours["n"],
        held_dmax=ours["change_vs_demo_held_out"]["max_contact_force"]["mean"],
        switch_n=PRESS_SWITCH_N,
        stop_n=PRESS_STOP_N,
        below=below,
        below_peaks=", ".join(f"{fmax[i]:.1f}" for i in below),
        floor_mean=floor.mean(),
        floor_min=floor.min(),
        floor_max=floor.max(),
        peak=ours["max_contact_force"],
    )


def _press_limit(lim: dict[str, Any], tuning: dict[str, Any], cells) -> str:
    """The weights + force_limit bullet, naming the demonstrations the over-tight limit fails on."""
    ch = tuning.get("weights_limit", {}).get("chosen") or {}
    line = text(
        "press_limit",
        k=ch.get("stiffness", float("nan")),
        limit=ch.get("force_limit", float("nan")),
        c=lim["change_vs_demo"],
        success_pct=100 * lim["success_rate"],
        n=lim["n"],
    )
    fails = _failing_demos(cells, "table2", "press", "ours_limit")
    if fails:
        failing = ", ".join(
            text("press_limit_failing_demo", demo=d, travel_mm=v["travel_mm"]) for d, v in fails.items()
        )
        line += text("press_limit_failing", failing=failing)
    return line


# ---- erase ----------------------------------------------------------------------------------------------


def erase_section(doc, cells) -> list[str]:
    out = [text("erase_heading")]
    pkg = _rec(doc, experiment="table2", task="erase", method="ours_default")
    old = _rec(doc, experiment="table2", task="erase", method="ours_k3000")
    ours = _rec(doc, experiment="table2", task="erase", method="ours")
    k = (doc["tuning"].get("erase", {}).get("weights", {}).get("chosen") or {}).get("stiffness")
    if pkg:
        out.append(
            text(
                "erase_package",
                c=pkg["change_vs_demo"],
                coverage_pct=100 * pkg["metric_means"].get("coverage", float("nan")),
                success_pct=100 * pkg["success_rate"],
                n=pkg["n"],
            )
        )
    if old:
        out.append(text("erase_k3000", k_eff=ERASE_K_EFF, c=old["change_vs_demo"]))
    if ours and k:
        coverage = 100 * ours["metric_means"].get("coverage", float("nan"))
        kept = 1 - ERASE_K_EFF / k
        out.append(
            text(
                "erase_tuned",
                k=k,
                k_eff=ERASE_K_EFF,
                kept=kept,
                c=ours["change_vs_demo"],
                coverage_pct=coverage,
            )
        )
    lim = _rec(doc, experiment="table2", task="erase", method="ours_limit")
    if lim and ours:
        out.append(
            text(
                "erase_limit",
                limit_dmean=lim["change_vs_demo"]["mean_contact_force"]["mean"],
                ours_dmean=ours["change_vs_demo"]["mean_contact_force"]["mean"],
                rows=lim.get("force_limit_rows_mean", 0),
            )
        )
    return out


# ---- peg_in_hole ----------------------------------------------------------------------------------------


def peg_section(doc, cells) -> list[str]:
    hyb = _rec(doc, experiment="peg", method="hybrid")
    ours = _rec(doc, experiment="peg", method="ours")
    if not hyb or not ours:
        return []
    out = [text("peg_heading")]
    pkg = _rec(doc, experiment="peg", method="ours_default")
    if pkg and "max_contact_force_xyz" in pkg:
        out.append(_peg_package(hyb, pkg))
    out.append(_peg_six_numbers(doc, hyb, ours))
    ph_o, ph_h = ours.get("force_by_gripper_phase"), hyb.get("force_by_gripper_phase")
    if ph_o and ph_h:
        closed = text(
            "peg_phase_closed",
            ours_fx=ph_o["closed"]["max_xyz_mean"][0],
            hybrid_fx=ph_h["closed"]["max_xyz_mean"][0],
        )
        moving = ph_o["moving"]
        if moving["episodes"]:
            out.append(
                text(
                    "peg_phase_moving",
                    closed=closed,
                    share_pct=100 * moving["peak_share_xyz"][0],
                    episodes=moving["episodes"],
                    fx=moving["max_xyz_mean"][0],
                )
            )
        else:
            out.append(text("peg_phase_no_moving", closed=closed))
    tr = _trace(cells, "peg", "peg_in_hole", "ours")
    trh = _trace(cells, "peg", "peg_in_hole", "hybrid")
    if tr is not None and trh is not None:
        op = _gripper_opening(*tr)
        out.append(
            text(
                "peg_release",
                ours_opening=_opening_text(op),
                hybrid_opening=_opening_text(_gripper_opening(*trh)),
                why=text("peg_release_slow" if _slow(op) else "peg_release_step"),
            )
        )
    return out


def _peg_package(hyb: dict[str, Any], pkg: dict[str, Any]) -> str:
    """The package defaults against hybrid control on the six per-axis numbers."""
    h, o = six(hyb), six(pkg)
    lost = [f"{n} ({a:.2f} vs {b:.2f} N)" for n, a, b in zip(SIX_NAMES, o, h, strict=True) if a >= b]
    return text(
        "peg_package",
        n_won=6 - len(lost),
        lost=f"; not below on {', '.join(lost)}" if lost else "",
        success_pct=100 * pkg["success_rate"],
        n=pkg["n"],
    )


def _peg_six_numbers(doc, hyb: dict[str, Any], ours: dict[str, Any]) -> str:
    """Ours against hybrid control on the six per-axis numbers, and Z max against the demonstrations'."""
    h, o = six(hyb), six(ours)
    won = [n for n, a, b in zip(SIX_NAMES, o, h, strict=True) if a < b]
    lost = [f"{n} ({a:.2f} vs {b:.2f} N)" for n, a, b in zip(SIX_NAMES, o, h, strict=True) if a >= b]
    gap, rel = h - o, 100.0 * (o / np.where(h > 0, h, np.nan) - 1.0)
    big, most = int(np.argmax(gap)), int(np.nanargmin(rel))
    demo = _rec(doc, experiment="peg", method="demonstration")
    z_demo = (
        text("peg_z_demo", ours_z=o[2], demo_z=demo["max_contact_force_xyz"]["mean"][2])
        if demo and "max_contact_force_xyz" in demo
        else ""
    )
    return text(
        "peg_six_numbers",
        n_won=len(won),
        won=", ".join(won),
        lost=", ".join(lost) or "none",
        big_name=SIX_NAMES[big],
        big_ours=o[big],
        big_hybrid=h[big],
        rel_name=SIX_NAMES[most],
        rel=rel[most],
        z_demo=z_demo,
    )


# ---- grasping -------------------------------------------------------------------------------------------


def grasp_section(doc, cells) -> list[str]:
    rows = [r for r in doc["records"] if r["experiment"] == "grasp" and r["method"] == "ours"]
    if not rows:
        return []
    seen = [r for r in rows if r.get("seen")]
    unseen = [r for r in rows if not r.get("seen")]
    out = [text("grasp_heading"), _grasp_success(seen, unseen)]
    if unseen:
        out.append(_grasp_unseen(doc, unseen))
    for r in rows:
        if r.get("failures"):
            out.append(_grasp_failures(r, cells))
    dflt = [r for r in doc["records"] if r["experiment"] == "grasp" and r["method"] == "ours_default"]
    if dflt:
        out.append(_grasp_defaults(dflt, cells))
    return out


def _grasp_success(seen: list[dict[str, Any]], unseen: list[dict[str, Any]]) -> str:
    def rate(kind: str, r: dict[str, Any]) -> str:
        return text(kind, task=r["task"], object=r["object"], success_pct=100 * r["success_rate"], n=r["n"])

    return text(
        "grasp_success",
        seen=", ".join(rate("grasp_success_seen", r) for r in seen),
        unseen=", ".join(rate("grasp_success_unseen", r) for r in unseen),
    )


def _grasp_unseen(doc, unseen: list[dict[str, Any]]) -> str:
    """How ours follows an unseen object, against the open-loop replay's success on it."""
    replay = {
        (r["task"], r["object"]): r
        for r in doc["records"]
        if r["experiment"] == "grasp" and r["method"] == "replay"
    }
    ref = ", ".join(
        f"{r['task']}/{r['object']} {100 * replay[(r['task'], r['object'])]['success_rate']:.0f}%"
        for r in unseen
        if (r["task"], r["object"]) in replay
    )
    return text("grasp_unseen_objects", replay=f": {ref}" if ref else "")


def _grasp_failures(r: dict[str, Any], cells) -> str:
    """One cell's failures, its protective stops and, for a slow release, the trace's gripper opening."""
    stops = _stopped_episodes(cells, r["task"], "ours", r["object"])
    tr = _trace(cells, "grasp", r["task"], "ours", r["object"])
    op = _gripper_opening(*tr) if tr is not None else None
    return text(
        "grasp_failures",
        task=r["task"],
        object=r["object"],
        success_pct=100 * r["success_rate"],
        n=r["n"],
        failures=r.get("failures"),
        stops=text("grasp_stops", stops="; ".join(stops)) if stops else "",
        opening=text("grasp_slow_opening", opening=_opening_text(op)) if _slow(op) else "",
    )


def _stopped_episodes(cells, task: str, method: str, obj: str) -> list[str]:
    """The protective stops of a grasp cell: demonstration, seed, fingertip and contact forces."""
    out = []
    for c in _cells(cells, "grasp", task, method, obj):
        for r in c.records:
            if r.get("protective_stop"):
                out.append(
                    text(
                        "grasp_stopped_episode",
                        demo=r["demo"],
                        seed=r["seed"],
                        fingers=", ".join(f"{f:.1f}" for f in r.get("max_finger_force", [])),
                        force=r["max_contact_force"],
                    )
                )
    return out


def _grasp_defaults(dflt: list[dict[str, Any]], cells) -> str:
    """The package defaults on the demonstration objects, and the segment anchors they choose."""
    rates = ", ".join(
        text(
            "grasp_defaults_rate",
            task=r["task"],
            object=r["object"],
            success_pct=100 * r["success_rate"],
            failures=r.get("failures") or "–",
        )
        for r in dflt
    )
    anchors = "; ".join(
        text(
            "grasp_defaults_anchors",
            task=t,
            defaults=_anchors_of_first_fit(cells, t, "ours_default"),
            ours=_anchors_of_first_fit(cells, t, "ours"),
        )
        for t in dict.fromkeys(r["task"] for r in dflt)
    )
    return text("grasp_defaults", rates=rates, anchors=anchors)


def _anchors_of_first_fit(cells, task: str, method: str) -> str:
    """The segment anchors of the first demonstration's fit of a grasp cell, e.g. '[obj, wall, -]'."""
    for c in cells:
        if c.experiment == "grasp" and c.task == task and c.method == method:
            for res in c.results:
                fit = res.get("fit") or {}
                if fit.get("segments"):
                    return "[" + ", ".join(sg.get("anchor") or "-" for sg in fit["segments"]) + "]"
    return "(no fit)"


# ---- learned baselines ----------------------------------------------------------------------------------


def learned_section(doc) -> list[str]:
    rows = [r for r in doc["records"] if r.get("kind") == "learned"]
    if not rows:
        return []
    done = [r for r in rows if r.get("status") == "done"]
    pending = [f"{r['task']}/{r['method']}" for r in rows if r.get("status") == "pending"]
    out = [text("learned_heading"), *(_learned_row(r) for r in done)]
    if done:
        fit_max = [r["fit_s_max"] for r in doc["records"] if r.get("method") == "ours" and "fit_s_max" in r]
        fit_text = text("learned_fit_max", fit_max=max(fit_max)) if fit_max else text("learned_fit_none")
        comparisons = "; ".join(_learned_vs_ours(doc, r) for r in done)
        out.append(text("learned_vs_ours", fit_text=fit_text, comparisons=comparisons))
        failing = [f"{r['task']}/{r['method']}" for r in done if r["success_rate"] < 0.5]
        if failing:
            out.append(text("learned_low_success", failing=", ".join(failing)))
    out += _lerobot_eval_agreement(done)
    if pending:
        out.append(text("learned_pending", pending=", ".join(pending)))
    return out


def _learned_row(r: dict[str, Any]) -> str:
    ch = r.get("change_vs_demo", {})
    return text(
        "learned_row",
        task=r["task"],
        method=r["method"],
        steps=r.get("train_steps"),
        train_min=(r.get("train_wall_time_s") or 0) / 60,
        success_pct=100 * r["success_rate"],
        n=r["n"],
        max_force=r["max_contact_force"]["mean"],
        max_change=ch.get("max_contact_force", {}).get("pooled", float("nan")),
        failures=r.get("failures") or "–",
    )


def _learned_vs_ours(doc, r) -> str:
    """One learned row against ours on its task: success and force change, said as they compare."""
    experiment = "peg" if r["task"] == "peg_in_hole" else "table2"
    ours = next(
        (
            x
            for x in doc["records"]
            if x.get("experiment") == experiment and x["task"] == r["task"] and x["method"] == "ours"
        ),
        None,
    )
    name = f"{r['task']}/{r['method']}"
    if ours is None:
        return text("learned_no_ours", name=name)
    line = text(
        "learned_success", name=name, learned_pct=100 * r["success_rate"], ours_pct=100 * ours["success_rate"]
    )
    learned_ch, ours_ch = r.get("change_vs_demo", {}), ours.get("change_vs_demo", {})
    parts = []
    for key, label in (("max_contact_force", "max"), ("mean_contact_force", "mean")):
        mine = learned_ch.get(key, {}).get("pooled")
        theirs = ours_ch.get(key, {}).get("mean")
        if mine is None or theirs is None:
            continue
        verdict = "lower than ours" if mine < theirs else "not lower"
        parts.append(text("learned_change", label=label, mine=mine, theirs=theirs, verdict=verdict))
    return line + (", " + ", ".join(parts) if parts else "")


def _lerobot_eval_agreement(done: list[dict[str, Any]]) -> list[str]:
    """One line on how ``lerobot-eval``'s own run of each checkpoint compares with ours, seed by seed."""
    compared = [r for r in done if r.get("lerobot_eval_disagreeing_seeds") is not None]
    if not compared:
        return []
    agree = [f"{r['task']}/{r['method']}" for r in compared if not r["lerobot_eval_disagreeing_seeds"]]
    differ = [
        text(
            "lerobot_eval_differ_row",
            task=r["task"],
            method=r["method"],
            seeds=", ".join(map(str, r["lerobot_eval_disagreeing_seeds"])),
            lerobot_pct=100 * r["lerobot_eval"]["success_rate"],
            ours_pct=100 * r["success_rate"],
        )
        for r in compared
        if r["lerobot_eval_disagreeing_seeds"]
    ]
    line = text("lerobot_eval_agree", agree=", ".join(agree)) if agree else text("lerobot_eval_agree_none")
    if differ:
        line += text("lerobot_eval_differ", differ=", ".join(differ))
    return [line + "."]


def analysis(doc: dict[str, Any], cells: list | None = None) -> list[str]:
    """The section's lines: press, erase, peg_in_hole, grasping (a section a partial run cannot fill
    says so), then the learned baselines."""
    cells = cells or []
    parts: list[str] = []
    for fn in (press_section, erase_section, peg_section, grasp_section):
        try:
            sec = fn(doc, cells)
        except (KeyError, TypeError, ValueError, IndexError) as err:  # a partial run lacks some rows
            sec = [text("section_error", section=fn.__name__, error=err)]
        if sec:
            parts += sec + [""]
    parts += learned_section(doc)
    return parts
