"""The figures of ``results/experiments.md`` (PNG, Agg backend): force profiles, paths, Table II's
per-demonstration force change and Table III's per-axis forces. Each returns the written path, or
None (nothing written) when the run has nothing to draw."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from experiments.paper.targets import PAPER_TABLE2

#: a colour per method, the same in every figure
COLORS = {
    "demonstration": "#c44e52",
    "hybrid": "#55a868",
    "ours": "#4c72b0",
    "ours_limit": "#8172b2",
    "limit_alone": "#937860",
    "replay": "#c44e52",
    "elmap": "#8c8c8c",
}


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(fig, path: Path, drawn: bool = True) -> Path | None:
    """Write the figure (None, and nothing written, when nothing was drawn) and close it."""
    plt = _plt()
    if drawn:
        fig.tight_layout()
        fig.savefig(path, dpi=110)
    plt.close(fig)
    return path if drawn else None


def _trace_of(cells, experiment: str, task: str, method: str):
    for c in cells:
        if c.experiment == experiment and c.task == task and c.method == method:
            for rec in c.records:
                if rec.get("trace"):
                    return rec
    return None


def _demo_trace(task: str, episode: int):
    from lerobot_forcemap.evaluation.demonstrations import demonstration_records

    from .common import REPO

    demos, _ = demonstration_records(REPO / "datasets" / task, trace=True)
    return next((d for d in demos if d["episode"] == episode), None)


def _rows(rec) -> tuple[np.ndarray, dict[str, int]]:
    tr = rec["trace"]
    return np.asarray(tr["rows"], dtype=float), {c: i for i, c in enumerate(tr["columns"])}


def _origin(rec, anchor: str) -> np.ndarray:
    tr = rec["trace"]
    names = tr.get("environment_state_names") or []
    state = tr.get("environment_state")
    if state is None or f"{anchor}_x" not in names:
        return np.zeros(3)
    i = names.index(f"{anchor}_x")
    return np.asarray(state[i : i + 3], dtype=float)


def plot_force_profiles(cells, path: Path, demo_episode: int = 0) -> Path | None:
    """Contact force over time: demonstration vs hybrid control vs ours (press, erase: |F|; peg: per axis)."""
    plt = _plt()
    fig = plt.figure(figsize=(15, 8.5))
    grid = fig.add_gridspec(2, 6)
    layout = [
        ("table2", "press", "norm", grid[0, 0:3]),
        ("table2", "erase", "norm", grid[0, 3:6]),
        ("peg", "peg_in_hole", "x", grid[1, 0:2]),
        ("peg", "peg_in_hole", "y", grid[1, 2:4]),
        ("peg", "peg_in_hole", "z", grid[1, 4:6]),
    ]
    demos: dict[str, Any] = {}
    drawn = False
    for exp, task, comp, spec in layout:
        ax = fig.add_subplot(spec)
        if task not in demos:
            demos[task] = _demo_trace(task, demo_episode)
        series = [("demonstration", demos[task])]
        for method in ("hybrid", "ours", "ours_limit"):
            series.append((method, _trace_of(cells, exp, task, method)))
        for name, rec in series:
            if rec is None or not rec.get("trace"):
                continue
            rows, c = _rows(rec)
            f = rows[:, [c["fx"], c["fy"], c["fz"]]]
            y = np.linalg.norm(f, axis=1) if comp == "norm" else np.abs(f[:, "xyz".index(comp)])
            ax.plot(rows[:, c["t"]], y, color=COLORS.get(name, "k"), lw=2.2 if name == "demonstration" else 1.4,
                    label=name if name != "demonstration" else f"demonstration {demo_episode}")  # fmt: skip
            drawn = True
        ax.set_title(f"{task}: {'|F|' if comp == 'norm' else '|F' + comp + '|'}", fontsize=10)
        ax.set_xlabel("time (s)")
        ax.set_ylabel("N")
        ax.legend(fontsize=7)
    if not drawn:
        plt.close(fig)
        return None
    fig.suptitle(
        f"Contact force, demonstration {demo_episode} vs its reproductions (first evaluation seed; physics-rate filtered force sampled at 20 Hz)",
        fontsize=11,
    )
    return _save(fig, path)


def plot_paths(cells, path: Path, demo_episode: int = 0) -> Path | None:
    """Target and executed TCP height relative to the task object (press, peg) and the erase path seen from above."""
    from lerobot_forcemap.envs.registration import task_spec

    plt = _plt()
    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6))
    drawn = False
    for ax, (exp, task) in zip(
        axes, (("table2", "press"), ("table2", "erase"), ("peg", "peg_in_hole")), strict=True
    ):
        anchor = task_spec(task).anchor
        for name in ("demonstration", "hybrid", "ours"):
            rec = (
                _demo_trace(task, demo_episode)
                if name == "demonstration"
                else _trace_of(cells, exp, task, name)
            )
            if rec is None or not rec.get("trace"):
                continue
            rows, c = _rows(rec)
            o = _origin(rec, anchor)
            ex = 1e3 * (rows[:, [c["x"], c["y"], c["z"]]] - o)
            tg = 1e3 * (rows[:, [c["target_x"], c["target_y"], c["target_z"]]] - o)
            col = COLORS.get(name, "k")
            if task == "erase":
                ax.plot(ex[:, 0], ex[:, 1], color=col, lw=1.6, label=f"{name}: executed")
                ax.plot(tg[:, 0], tg[:, 1], color=col, lw=0.8, ls="--", label=f"{name}: target")
            else:
                t = rows[:, c["t"]]
                ax.plot(t, ex[:, 2], color=col, lw=1.6, label=f"{name}: executed")
                ax.plot(t, tg[:, 2], color=col, lw=0.8, ls="--", label=f"{name}: target")
            drawn = True
        if task == "erase":
            ax.set_xlabel(f"x − {anchor} (mm)")
            ax.set_ylabel(f"y − {anchor} (mm)")
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_title("erase: TCP path over the board (base-frame axes)", fontsize=10)
        else:
            ax.set_xlabel("time (s)")
            ax.set_ylabel(f"z − {anchor} top (mm)")
            ax.axhline(0, color="0.7", lw=0.8)
            ax.set_title(f"{task}: height (in contact, ours lifts the target)", fontsize=10)
        ax.legend(fontsize=7)
    return _save(fig, path, drawn)


def plot_table2(records: list[dict[str, Any]], path: Path) -> Path | None:
    """Per-demonstration % change of max and mean force, per method (dots: demonstrations; bar: mean)."""
    plt = _plt()
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.4))
    drawn = False
    for ax, task in zip(axes, ("press", "erase"), strict=True):
        rows = [
            r
            for r in records
            if r["experiment"] == "table2"
            and r["task"] == task
            and "change_vs_demo" in r
            and "mean" in r["change_vs_demo"]["max_contact_force"]
        ]
        for i, r in enumerate(rows):
            for j, (key, colour) in enumerate(
                (("max_contact_force", "#c44e52"), ("mean_contact_force", "#4c72b0"))
            ):
                c = r["change_vs_demo"][key]
                x = i + (j - 0.5) * 0.35
                ax.bar(
                    x,
                    c["mean"],
                    0.33,
                    color=colour,
                    alpha=0.55,
                    label=("Δ max" if key.startswith("max") else "Δ mean") if i == 0 else None,
                )
                ax.scatter(
                    np.full(len(c["per_demo"]), x), list(c["per_demo"].values()), s=9, color=colour, zorder=3
                )
            drawn = True
        for key, style in (("max", ":"), ("mean", "--")):
            ax.axhline(PAPER_TABLE2[task][key], color="k", ls=style, lw=0.9, label=f"paper Δ {key}")
        ax.set_xticks(range(len(rows)), [r["method"] for r in rows], rotation=20, fontsize=8)
        ax.set_ylabel("% change vs own demonstration")
        ax.set_title(f"{task}: force change per method (dots: the 10 demonstrations)", fontsize=10)
        ax.legend(fontsize=7)
    return _save(fig, path, drawn)


def plot_peg(records: list[dict[str, Any]], path: Path) -> Path | None:
    """Table III as bars: per-axis max and mean force, demonstration / hybrid / ours (mean ± std)."""
    plt = _plt()
    rows = [
        r
        for r in records
        if r["experiment"] == "peg"
        and r.get("max_contact_force_xyz")
        and r["method"] in ("demonstration", "hybrid", "ours")
    ]
    if not rows:
        return None
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for ax, key, title in zip(
        axes, ("max_contact_force_xyz", "mean_contact_force_xyz"), ("max", "mean"), strict=True
    ):
        for i, r in enumerate(rows):
            ax.bar(np.arange(3) + (i - 1) * 0.27, r[key]["mean"], 0.26, yerr=r[key]["std"], capsize=2,
                   color=COLORS.get(r["method"], "k"), label=r["method"])  # fmt: skip
        ax.set_xticks(range(3), ["X", "Y", "Z"])
        ax.set_ylabel("N")
        ax.set_title(f"peg_in_hole: {title} |F| per axis (mean ± std over episodes)", fontsize=10)
        ax.legend(fontsize=8)
    return _save(fig, path)
