"""The study's figures: one demo segmented under the paper's three weightings (like its Fig. 4), and
segment count vs event F1, F1 per weighting and F1 vs tolerance."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from lerobot_forcemap.segmentation.evaluation import score_changepoints  # noqa: E402
from lerobot_forcemap.segmentation.events import EVENT_KINDS  # noqa: E402

from .configurations import RunSpec, segment_once  # noqa: E402
from .data import ABBREV, STREAMS, TABLE_I, WINDOW, Demo  # noqa: E402


def segment_colours(n: int) -> list:
    cmap = plt.get_cmap("tab10")
    return [cmap(i % 10) for i in range(n)]


def _normalised(v: np.ndarray) -> np.ndarray:
    v = np.asarray(v, dtype=np.float64)
    return (v - v.min()) / max(np.ptp(v), 1e-12)


def figure_demo(demos: list[Demo], key: str, out: Path, spec_of: dict[str, RunSpec]) -> dict:
    """Fig. 4 analogue: the demo's 3-D path coloured by segment and its streams over time, per weighting
    of the paper's Table I (``spec_of``: the configuration of each). Returns the drawn segmentations."""
    demo = next((d for d in demos if d.key == key), None)
    if demo is None:
        raise ValueError(f"figure demo {key!r} is not among the loaded demos")
    fig = plt.figure(figsize=(16, 10.5))
    info = {
        "demo": demo.key,
        "reference_events": demo.reference.tolist(),
        "raw_events": {k: demo.events.of_kind(k).tolist() for k in EVENT_KINDS},
    }
    t, x = demo.times, demo.values["cartesian"]
    traces = {
        "gripper": _normalised(demo.values["gripper"][:, 0]),
        "finger force": _normalised(demo.values["finger_force"][:, 0]),
        "|wrist force|": _normalised(np.linalg.norm(demo.values["wrist_force"], axis=1)),
        "TCP speed": _normalised(np.linalg.norm(np.gradient(x, t, axis=0), axis=1)),
    }
    for col, w in enumerate(TABLE_I):
        seg = segment_once(demo, spec_of[w], np.random.default_rng([0, 0]))
        sc = score_changepoints(seg.changepoints[1:-1], demo.reference, WINDOW)
        info[w] = {
            "changepoints": seg.changepoints.tolist(),
            "f1": sc.f1,
            "precision": sc.precision,
            "recall": sc.recall,
        }
        colours = segment_colours(seg.n_segments)
        _draw_path(fig.add_subplot(2, 3, col + 1, projection="3d"), demo, seg, colours, w, sc.f1)
        _draw_streams(fig.add_subplot(2, 3, col + 4), demo, seg, colours, traces, legend=col == 0)
    fig.suptitle(
        f"GBTI {demo.key}: segments under the paper's three weightings "
        f"({spec_of['custom'].mode} pooling, {spec_of['custom'].method} changepoints, {spec_of['custom'].derivative} jerk)",
        fontsize=11,
    )
    fig.tight_layout()
    fig.savefig(out, dpi=90)
    plt.close(fig)
    return info


def _draw_path(ax, demo: Demo, seg, colours: list, weighting: str, f1: float) -> None:
    """The TCP path coloured by segment, the reference events as crosses."""
    x = demo.values["cartesian"]
    for i, (a, b) in enumerate(seg.segments):
        ax.plot(
            x[a : b + 1, 0],
            x[a : b + 1, 1],
            x[a : b + 1, 2],
            color=colours[i],
            lw=3,
            label=f"segment {i + 1}",
        )
    ev = demo.reference
    ax.scatter(
        x[ev, 0], x[ev, 1], x[ev, 2], color="k", marker="x", s=70, depthshade=False, label="reference event"
    )
    wtxt = " ".join(f"{ABBREV[n]} {v:g}" for n, v in zip(STREAMS, TABLE_I[weighting], strict=True))
    ax.set_title(f"{weighting}: {wtxt}\n{seg.n_segments} segments, F1 {f1:.2f}", fontsize=9)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_zlabel("z (m)")
    ax.legend(fontsize=7, loc="upper left")


def _draw_streams(ax, demo: Demo, seg, colours: list, traces: dict, *, legend: bool) -> None:
    """The normalised streams over time under the segments, the combined pmf, the changepoints and the
    reference events with their tolerance."""
    t = demo.times
    for i, (a, b) in enumerate(seg.segments):
        ax.axvspan(t[a], t[min(b, t.size - 1)], color=colours[i], alpha=0.15, lw=0)
    for name, v in traces.items():
        ax.plot(t, v, lw=1.2, label=name)
    ax.fill_between(t, 0, seg.pmf / seg.pmf.max(), color="grey", alpha=0.3, label="combined pmf (scaled)")
    for c in seg.changepoints[1:-1]:
        ax.axvline(t[c], color="k", lw=2)
    for e in demo.reference:
        ax.axvline(t[e], color="r", ls="--", lw=1.5)
    for e_lo in demo.reference:  # the tolerance, as a strip along the top
        ax.axvspan(
            t[max(e_lo - WINDOW, 0)],
            t[min(e_lo + WINDOW, t.size - 1)],
            ymin=0.96,
            ymax=1.0,
            color="r",
            alpha=0.6,
            lw=0,
        )
    ax.set_xlabel("time (s)")
    ax.set_ylabel("normalised")
    ax.set_title("black: changepoints; red dashed: reference events (red strip: ±tolerance)", fontsize=8)
    if legend:
        ax.legend(fontsize=7, loc="center left")


def figure_f1(scores: dict[str, dict], tol_curve: dict, out: Path) -> None:
    """(a) segment count vs event F1 of every configuration, (b) F1 with its 95 % CI per weighting,
    (c) F1 vs tolerance."""
    fig, axes = plt.subplots(1, 3, figsize=(17, 4.8))
    _counts_vs_f1(axes[0], scores)
    _f1_per_weighting(axes[1], scores)
    ax = axes[2]
    for w, curve in tol_curve["frames"].items():
        ax.plot(tol_curve["tolerances_frames"], [c["mean"] for c in curve], marker="o", label=w)
    ax.axvline(64, color="grey", ls=":")
    ax.set_xlabel("tolerance (frames of 1000)")
    ax.set_ylabel("event F1")
    ax.set_ylim(0, 1)
    ax.set_title("F1 vs tolerance (peaks, geometric, savgol)", fontsize=9)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


def _counts_vs_f1(ax, scores: dict[str, dict]) -> None:
    """Counts do not rank quality: every configuration's mean segment count against its event F1."""
    marker = {"position": "o", "uniform": "s", "custom": "^", "auto": "D", "flat": "x", "gripper_only": "*"}
    for s in scores.values():
        sp = s["spec"]
        if sp["weighting"].startswith("only:"):
            continue
        c = "tab:blue" if sp["method"] == "sample" else "tab:orange"
        ax.scatter(
            s["segments"]["mean"],
            s["f1"]["mean"],
            marker=marker.get(sp["weighting"], "."),
            color=c,
            alpha=0.8 if sp["derivative"] == "savgol" else 0.35,
            s=40,
        )
    ax.axvspan(3.86 - 0.05, 4.11 + 0.05, color="grey", alpha=0.2, label="paper's counts 3.86–4.11")
    ax.set_xlabel("mean segment count")
    ax.set_ylabel("event F1 (mean over demos)")
    ax.set_title(
        "every configuration: segment count vs event F1\n(blue: sample, orange: peaks; faint: difference jerk)",
        fontsize=9,
    )
    for w, mk in marker.items():
        ax.scatter([], [], marker=mk, color="k", label=w)
    ax.legend(fontsize=7)


def _f1_per_weighting(ax, scores: dict[str, dict]) -> None:
    """F1 with its 95 % CI per weighting, peaks and sample changepoints (geometric, Savitzky–Golay)."""
    order = ["position", "uniform", "custom", "auto", "gripper_only", "flat"]
    for j, (method, colour) in enumerate((("peaks", "tab:orange"), ("sample", "tab:blue"))):
        for i, w in enumerate(order):
            key = f"f1|savgol|{w}|geometric|{method}|msl=default"
            if key not in scores:
                continue
            s = scores[key]["f1"]
            ax.bar(i + 0.38 * j, s["mean"], width=0.38, color=colour, label=method if i == 0 else None)
            ax.errorbar(
                i + 0.38 * j,
                s["mean"],
                yerr=[[s["mean"] - s["ci95"][0]], [s["ci95"][1] - s["mean"]]],
                color="k",
                capsize=3,
            )
    ax.set_xticks(np.arange(len(order)) + 0.19, order, rotation=20, fontsize=8)
    ax.set_ylabel("event F1 (mean, 95% CI over demos)")
    ax.set_ylim(0, 1)
    ax.set_title("geometric pooling, Savitzky–Golay jerk, tolerance ±64 frames", fontsize=9)
    ax.legend(fontsize=8)
