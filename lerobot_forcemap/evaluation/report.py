"""Tables and plots from eval documents (``evaluate.evaluation_document``; ``forcemap report``).

    check_eval_document(doc, "--json outputs/eval.json")
    make_report([doc, ...], "outputs/report")

Writes ``report.md`` (one table per document: success, protective stops, max / mean contact force
norm and per axis of the demonstrations vs the reproduction, % change) and PNGs (Agg backend):
``forces.png`` (bars, demonstration vs reproduction), and for documents with traces
``force_profile.png`` (contact force over time, demonstration vs reproduction, like the paper's
Fig. 5) and ``path3d.png`` (target and executed paths in the frame of the first object of the
environment state, e.g. the button).
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap._validation import check_bool, check_int, check_real, check_str, fail, is_real
from lerobot_forcemap.evaluation.records import DEMO_TRACE_COLUMNS, FORCE_KEYS

__all__ = [
    "table_rows",
    "markdown_table",
    "plot_forces",
    "plot_force_profile",
    "plot_paths",
    "make_report",
    "check_eval_document",
]

AXES = "xyz"


def _fmt(stat: dict | None, idx: int | None = None, digits: int = 1) -> str:
    if not stat:
        return "–"
    m, s = stat["mean"], stat["std"]
    if idx is not None:
        m, s = m[idx], s[idx]
    return f"{m:.{digits}f} ± {s:.{digits}f}"


def _pct(rep: dict | None, demo: dict | None, idx: int | None = None) -> str:
    if not rep or not demo:
        return "–"
    r, d = rep["mean"], demo["mean"]
    if idx is not None:
        r, d = r[idx], d[idx]
    return f"{100.0 * (r - d) / d:+.0f}%" if d else "–"


def table_rows(doc: dict[str, Any]) -> list[tuple[str, str, str, str]]:
    """(quantity, demonstration, reproduction, change) rows of one eval document."""
    rep = doc["summary"]
    demos = doc.get("demonstrations") or {}
    demo = (
        demos.get("summary_fitted") if demos.get("summary_fitted", {}).get("n") else demos.get("summary_all")
    )
    demo = demo or {}
    rows = [
        ("episodes (n)", str(demo.get("n", "–")), str(rep["n"]), ""),
        (
            "success",
            f"{100 * demo['success_rate']:.0f}%" if "success_rate" in demo else "–",
            f"{100 * rep['success_rate']:.0f}%",
            "",
        ),
        ("protective stops", str(demo.get("protective_stops", "–")), str(rep["protective_stops"]), ""),
        (
            "episodes with clipped targets (steps)",
            "–",
            f"{rep['episodes_clipped']} ({rep['clipped_steps']})" if "clipped_steps" in rep else "–",
            "",
        ),
        (
            "max contact force (N)",
            _fmt(demo.get("max_contact_force")),
            _fmt(rep.get("max_contact_force")),
            _pct(rep.get("max_contact_force"), demo.get("max_contact_force")),
        ),
        (
            "mean contact force (N)",
            _fmt(demo.get("mean_contact_force"), digits=2),
            _fmt(rep.get("mean_contact_force"), digits=2),
            _pct(rep.get("mean_contact_force"), demo.get("mean_contact_force")),
        ),
    ]
    for kind in ("max", "mean"):
        key = f"{kind}_contact_force_xyz"
        for i, a in enumerate(AXES):
            rows.append(
                (
                    f"{kind} abs(F{a}) (N)",
                    _fmt(demo.get(key), i, 2 if kind == "mean" else 1),
                    _fmt(rep.get(key), i, 2 if kind == "mean" else 1),
                    _pct(rep.get(key), demo.get(key), i),
                )
            )
    return rows


def markdown_table(doc: dict[str, Any]) -> str:
    demos = doc.get("demonstrations") or {}
    fitted = demos.get("fitted_episodes")
    head = (
        f"demonstration (episode{'s' if fitted and len(fitted) > 1 else ''} {fitted})"
        if fitted
        else "demonstrations"
    )
    lines = [f"| {doc['task']} | {head} | reproduction | change |", "|---|---|---|---|"]
    lines += [f"| {q} | {d} | {r} | {c} |" for q, d, r, c in table_rows(doc)]
    return "\n".join(lines)


def plot_forces(docs: Sequence[dict[str, Any]], path: Path) -> Path:
    """Bars: max and mean contact force, demonstration vs reproduction, per document (mean ± std)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(9, 3.6))
    for ax, key, title in zip(
        axes,
        ("max_contact_force", "mean_contact_force"),
        ("max contact force", "mean contact force"),
        strict=True,
    ):
        labels, demo_m, demo_s, rep_m, rep_s = [], [], [], [], []
        for doc in docs:
            demos = doc.get("demonstrations") or {}
            d = (
                demos.get("summary_fitted")
                if demos.get("summary_fitted", {}).get("n")
                else demos.get("summary_all", {})
            )
            labels.append(doc["task"])
            demo_m.append(d.get(key, {}).get("mean", np.nan) if d else np.nan)
            demo_s.append(d.get(key, {}).get("std", 0.0) if d else 0.0)
            rep_m.append(doc["summary"][key]["mean"])
            rep_s.append(doc["summary"][key]["std"])
        x = np.arange(len(labels))
        ax.bar(x - 0.2, demo_m, 0.4, yerr=demo_s, label="demonstration", color="#c44e52", capsize=3)
        ax.bar(x + 0.2, rep_m, 0.4, yerr=rep_s, label="reproduction", color="#4c72b0", capsize=3)
        ax.set_xticks(x, labels)
        ax.set_ylabel("N")
        ax.set_title(title)
    axes[0].legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _trace(rec: dict[str, Any]) -> tuple[np.ndarray, dict[str, int]] | None:
    tr = rec.get("trace")
    if not tr or not tr.get("rows"):
        return None
    return np.asarray(tr["rows"], dtype=float), {c: i for i, c in enumerate(tr["columns"])}


def plot_force_profile(doc: dict[str, Any], path: Path) -> Path | None:
    """Contact force norm over time: the fitted demonstration vs every reproduction (first one bold)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    reps = [t for t in (_trace(r) for r in doc["episodes"]) if t is not None]
    if not reps:
        return None
    demos = doc.get("demonstrations") or {}
    fitted = demos.get("fitted_episodes") or [0]
    demo = next(
        (_trace(d) for d in demos.get("episodes", []) if d["episode"] == fitted[0] and d.get("trace")), None
    )
    fig, ax = plt.subplots(figsize=(7, 3.6))
    if demo is not None:
        rows, c = demo
        ax.plot(
            rows[:, c["t"]],
            np.linalg.norm(rows[:, [c["fx"], c["fy"], c["fz"]]], axis=1),
            color="#c44e52",
            lw=2,
            label=f"demonstration (episode {fitted[0]})",
        )
    for k, (rows, c) in enumerate(reps):
        f = np.linalg.norm(rows[:, [c["fx"], c["fy"], c["fz"]]], axis=1)
        ax.plot(
            rows[:, c["t"]],
            f,
            color="#4c72b0",
            lw=2 if k == 0 else 0.6,
            alpha=1.0 if k == 0 else 0.35,
            label=f"reproduction ({len(reps)} episodes)" if k == 0 else None,
        )
    ax.set_xlabel("time (s)")
    ax.set_ylabel("contact force |F| (N)")
    ax.set_title(f"{doc['task']}: contact force, demonstration vs reproduction")
    ax.legend()
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    plt.close(fig)
    return path


def _object_origin(tr: dict[str, Any]) -> tuple[np.ndarray, str]:
    names = tr.get("environment_state_names") or []
    state = tr.get("environment_state")
    for i, n in enumerate(names):
        if n.endswith("_x") and state is not None and i + 2 < len(state):
            return np.asarray(state[i : i + 3], dtype=float), n[:-2]
    return np.zeros(3), "base"


def plot_paths(doc: dict[str, Any], path: Path) -> Path | None:
    """Left: 3-D target and executed paths of the fitted demonstration and the first reproduction in
    the frame of the first object of the environment state (positions minus its position). Right:
    height over time, where the force-constrained map lifts the target out of the contact."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.ticker import MaxNLocator

    rep = next((r for r in doc["episodes"] if r.get("trace")), None)
    if rep is None:
        return None
    demos = doc.get("demonstrations") or {}
    fitted = (demos.get("fitted_episodes") or [0])[0]
    demo = next((d for d in demos.get("episodes", []) if d["episode"] == fitted and d.get("trace")), None)
    fig = plt.figure(figsize=(11, 4.8))
    ax = fig.add_subplot(1, 2, 1, projection="3d")
    ax_z = fig.add_subplot(1, 2, 2)
    frame = "base"
    for rec, colour, label in (
        (demo, "#c44e52", f"demonstration {fitted}"),
        (rep, "#4c72b0", f"reproduction (seed {rep['seed']})"),
    ):
        if rec is None:
            continue
        rows, c = _trace(rec)
        origin, frame = _object_origin(rec["trace"])
        tgt = 1e3 * (rows[:, [c["target_x"], c["target_y"], c["target_z"]]] - origin)
        ee = 1e3 * (rows[:, [c["x"], c["y"], c["z"]]] - origin)
        touch = np.linalg.norm(rows[:, [c["fx"], c["fy"], c["fz"]]], axis=1) > 1.0
        ax.plot(*tgt.T, color=colour, lw=1, ls="--", label=f"{label}: target")
        ax.plot(*ee.T, color=colour, lw=2, label=f"{label}: executed")
        if touch.any():
            ax.scatter(*ee[touch].T, color=colour, s=6)
        t = rows[:, c["t"]]
        ax_z.plot(t, tgt[:, 2], color=colour, lw=1, ls="--", label=f"{label}: target")
        ax_z.plot(t, ee[:, 2], color=colour, lw=2, label=f"{label}: executed")
    pts = np.concatenate([np.column_stack(line.get_data_3d()) for line in ax.get_lines()])
    ax.set_box_aspect(np.maximum(np.ptp(pts, axis=0), 40.0))  # equal mm scale, at least 40 mm per axis
    for axis in (ax.xaxis, ax.yaxis, ax.zaxis):  # a short axis at the default density overprints its ticks
        axis.set_major_locator(MaxNLocator(nbins=4))
    ax.set_xlabel(f"x - {frame} (mm)")
    ax.set_ylabel(f"y - {frame} (mm)")
    ax.set_zlabel(f"z - {frame} (mm)")
    ax.set_title(f"{doc['task']}: paths relative to the {frame}\n(dots: contact > 1 N)", fontsize=10)
    ax_z.axhline(0.0, color="0.6", lw=0.8)
    ax_z.set_xlabel("time (s)")
    ax_z.set_ylabel(f"z - {frame} (mm)")
    ax_z.set_title("height over time (in contact the target is lifted)", fontsize=10)
    ax_z.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120, bbox_inches="tight")  # the 3-D axis labels reach past the figure
    plt.close(fig)
    return path


def make_report(docs: Sequence[dict[str, Any]], out: str | Path) -> dict[str, Any]:
    """Write report.md and the PNGs for ``docs`` into ``out``; returns {"markdown": str, "files": [...]}.

    Everything is drawn in a temporary folder first and moved into ``out`` at the end, so a failure
    leaves ``out`` as it was (``out`` may hold other files: ``make demo`` writes its policy there).
    """
    import shutil
    import tempfile

    out = Path(out)
    if out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: is a file; give the folder to write report.md and the PNGs into")
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix=".report-", dir=out) as tmp:
        md, names = _draw_report(docs, Path(tmp), out)
        (Path(tmp) / "report.md").write_text(md)
        for name in [*names, "report.md"]:
            shutil.move(str(Path(tmp) / name), out / name)
    return {"markdown": md, "files": [str(out / name) for name in [*names, "report.md"]]}


def _draw_report(docs: Sequence[dict[str, Any]], tmp: Path, out: Path) -> tuple[str, list[str]]:
    """report.md's text and the PNG files drawn into ``tmp`` (links relative to ``out``)."""
    parts = ["# forcemap evaluation", ""]
    names = [plot_forces(docs, tmp / "forces.png").name]
    for i, doc in enumerate(docs):
        obj = f" (object {doc['object']})" if doc.get("object") else ""
        parts += [
            f"## {doc['task']}{obj} — policy `{doc['policy']}`, seeds {doc['seed']}..{doc['seed'] + doc['summary']['n'] - 1}",
            "",
        ]
        parts += [markdown_table(doc), ""]
        demos = doc.get("demonstrations")
        if demos:
            parts += [f"Demonstration figures from `{demos['source']}`.", ""]
            shown = sorted({str(d["object"]) for d in demos.get("episodes", []) if d.get("object")})
            if doc.get("object") and shown and shown != [str(doc["object"])]:
                parts += [
                    f"The demonstrations handled {', '.join(shown)}; the reproduction {doc['object']}.",
                    "",
                ]
        videos = [r["video"] for r in doc["episodes"] if r.get("video")]
        if videos:
            links = ", ".join(
                f"[{Path(v).name}]({os.path.relpath(Path(v).resolve(), out.resolve())})" for v in videos
            )
            parts += [f"Videos: {links}.", ""]
        # one file per document: two documents of the same task must not overwrite each other's plots
        same_task = sum(d["task"] == doc["task"] for d in docs)
        suffix = "" if len(docs) == 1 else f"_{doc['task']}" + (f"_{i}" if same_task > 1 else "")
        for fn, name in (
            (plot_force_profile, f"force_profile{suffix}.png"),
            (plot_paths, f"path3d{suffix}.png"),
        ):
            if fn(doc, tmp / name) is not None:
                names.append(name)
                parts += [f"![{name}]({name})", ""]
    parts += ["![forces.png](forces.png)", ""]
    return "\n".join(parts), names


# ---- what a report reads ----------------------------------------------------------------------------------

#: the fields of an eval document the tables and plots read, with their checks
_DOCUMENT_FIELDS = {"task": check_str, "policy": check_str, "seed": check_int}


def check_eval_document(doc: Any, where: str) -> None:
    """``ValueError("<where>: <field>: must ...")`` when ``doc`` is not what ``forcemap eval`` writes:
    the fields the tables and plots read, with their types (a NaN would print as "nan ± 0.0")."""
    try:
        _check_document(doc)
    except ValueError as err:
        raise ValueError(f"{where}: {err}") from None


def _check_document(doc: Any) -> None:
    if not isinstance(doc, dict):
        fail("the document", "be a JSON object (a `forcemap eval` document)", doc)
    for key, rule in _DOCUMENT_FIELDS.items():
        _present(doc, key, key)
        rule(key, doc[key])
    for key in ("summary", "episodes"):
        _present(doc, key, key)
    summary, episodes = doc["summary"], doc["episodes"]
    if not isinstance(episodes, list):
        fail("episodes", "be a list of episode records", episodes)
    _check_summary("summary", summary)
    if not (isinstance(summary.get("n"), int) and summary["n"] >= 1 and summary["n"] == len(episodes)):
        fail(
            "summary.n",
            f"equal the number of episode records ({len(episodes)}) and be >= 1",
            summary.get("n"),
        )
    check_real("summary.success_rate", summary.get("success_rate"))
    check_int("summary.protective_stops", summary.get("protective_stops"))
    for key in ("max_contact_force", "mean_contact_force"):  # the bars of forces.png
        _present(summary, key, f"summary.{key}")
    for i, rec in enumerate(episodes):
        _check_record(rec, f"episodes[{i}]")
        check_int(f"episodes[{i}].seed", rec.get("seed"))
    if doc.get("demonstrations") is not None:
        _check_demonstrations(doc["demonstrations"])


def _present(block: dict, key: str, name: str) -> None:
    if key not in block:
        fail(name, "be present (a `forcemap eval` document holds it)")


def _check_demonstrations(demos: Any) -> None:
    if not isinstance(demos, dict):
        fail("demonstrations", "be a JSON object", demos)
    check_str("demonstrations.source", demos.get("source"))
    for key in ("summary_fitted", "summary_all"):
        if key in demos:
            _check_summary(f"demonstrations.{key}", demos[key])
    episodes = demos.get("episodes", [])
    if not isinstance(episodes, list):
        fail("demonstrations.episodes", "be a list of episode records", episodes)
    for i, rec in enumerate(episodes):
        _check_record(rec, f"demonstrations.episodes[{i}]")
        check_int(f"demonstrations.episodes[{i}].episode", rec.get("episode"))


def _check_summary(name: str, block: Any) -> None:
    """The force statistics the tables format and the plots draw: finite means and stds (3 per axis)."""
    if not isinstance(block, dict):
        fail(name, "be a JSON object", block)
    for key in FORCE_KEYS:
        if key not in block:
            continue
        for part in ("mean", "std"):
            value = block[key].get(part) if isinstance(block[key], dict) else None
            field = f"{name}.{key}.{part}"
            if key.endswith("_xyz"):
                _check_numbers(field, value, 3)
            else:
                check_real(field, value)


def _check_numbers(name: str, value: Any, n: int) -> None:
    """``value`` is a list of ``n`` finite numbers."""
    if not (isinstance(value, list) and len(value) == n and all(map(_is_finite, value))):
        fail(name, f"be a list of {n} finite numbers", value)


def _is_finite(value: Any) -> bool:
    return is_real(value) and math.isfinite(value)


def _check_record(rec: Any, name: str) -> None:
    """One episode record: success, force figures, and its trace (columns, finite rows, environment state)."""
    if not isinstance(rec, dict):
        fail(name, "be a JSON object (an episode record)", rec)
    check_bool(f"{name}.success", rec.get("success"))
    for key in ("max_contact_force", "mean_contact_force"):
        check_real(f"{name}.{key}", rec.get(key))
    if rec.get("trace"):
        _check_trace(rec["trace"], f"{name}.trace")


def _check_trace(trace: Any, name: str) -> None:
    cols = trace.get("columns") if isinstance(trace, dict) else None
    rows = trace.get("rows") if isinstance(trace, dict) else None
    if not isinstance(cols, list) or not isinstance(rows, list):
        fail(name, "hold 'columns' and 'rows' lists", trace)
    missing = [c for c in DEMO_TRACE_COLUMNS if c not in cols]  # what the plots read
    if missing:
        fail(f"{name}.columns", f"hold the columns {list(DEMO_TRACE_COLUMNS)} (it lacks {missing})", cols)
    for j, row in enumerate(rows):
        if not isinstance(row, list) or len(row) != len(cols):
            fail(f"{name}.rows[{j}]", f"hold the {len(cols)} columns {cols}", row)
        if not all(map(_is_finite, row)):
            fail(f"{name}.rows[{j}]", "hold finite numbers only", row)
    state, names = trace.get("environment_state"), trace.get("environment_state_names")
    if state is not None and not (
        isinstance(state, list)
        and all(map(_is_finite, state))
        and isinstance(names, list)
        and len(names) == len(state)
        and all(isinstance(n, str) for n in names)
    ):
        fail(f"{name}.environment_state", "be finite numbers matching environment_state_names", state)
