"""Scores of segmentation runs against the reference events: P / R / F1 per demo and pooled, hit rates
per event kind, each stream's own keypoints, paired comparisons."""

from __future__ import annotations

from dataclasses import asdict

import numpy as np
from scipy import stats

from lerobot_forcemap.evaluation.stats import mean_interval
from lerobot_forcemap.segmentation.evaluation import hit_rate, prf, score_changepoints
from lerobot_forcemap.segmentation.events import EVENT_KINDS

from .configurations import RunResult
from .data import STREAMS, WINDOW, Demo


def tolerance_frames(demo: Demo, tolerance: float, unit: str) -> float:
    return tolerance if unit == "frames" else tolerance / demo.frame_dt


def score_run(
    res: RunResult, demos: list[Demo], tolerance: float, unit: str = "frames", method: str = "optimal"
) -> dict:
    """Per-demo (seed-averaged) P/R/F1, their summaries, pooled scores and segment-count stats."""
    n_seeds = res.n_segments.shape[1]
    p = np.zeros((len(demos), n_seeds))
    r = np.zeros_like(p)
    f = np.zeros_like(p)
    m_tot = p_tot = e_tot = 0
    errors: list[np.ndarray] = []
    for d, demo in enumerate(demos):
        tol = tolerance_frames(demo, tolerance, unit)
        for s in range(n_seeds):
            sc = score_changepoints(res.changepoints[d][s], demo.reference, tol, method)
            p[d, s], r[d, s], f[d, s] = sc.precision, sc.recall, sc.f1
            m_tot, p_tot, e_tot = m_tot + sc.n_matched, p_tot + sc.n_predicted, e_tot + sc.n_reference
            errors.append(sc.errors)
    err = np.concatenate(errors) if errors else np.zeros(0)
    counts = res.n_segments.astype(np.float64)
    pooled = prf(m_tot, p_tot, e_tot)
    return {
        "spec": asdict(res.spec),
        "n_seeds": int(n_seeds),
        "segments": {
            "mean": float(counts.mean()),
            "std": float(counts.std()),
            "per_demo_mean": mean_interval(counts.mean(1)),
        },
        "precision": mean_interval(p.mean(1)),
        "recall": mean_interval(r.mean(1)),
        "f1": mean_interval(f.mean(1)),
        "pooled": {"precision": pooled[0], "recall": pooled[1], "f1": pooled[2]},
        "matched_offset_frames": {"median": float(np.median(err)) if err.size else None, "n": int(err.size)},
        "per_demo_f1": np.round(f.mean(1), 4).tolist(),
    }


def kind_hits(res: RunResult, demos: list[Demo], tolerance: float) -> dict[str, dict[str, float]]:
    """Per event kind: fraction of (raw, unmerged) events with any changepoint within tolerance."""
    out = {}
    for kind in EVENT_KINDS:
        hits = total = 0.0
        for d, demo in enumerate(demos):
            ev = demo.events.of_kind(kind)
            for cps in res.changepoints[d]:
                hits += float(hit_rate(cps, ev, tolerance).sum())
                total += ev.size
        out[kind] = {
            "hit_rate": hits / total if total else float("nan"),
            "n_events": int(total / len(res.changepoints[0])),
        }
    return out


def keypoint_scores(res: RunResult, demos: list[Demo], tolerance: float) -> dict[str, dict]:
    """Each stream's own keypoints (before any pmf) scored against the reference events."""
    out = {}
    for n in STREAMS:
        f = np.array(
            [
                score_changepoints(res.keypoints[d][n], demo.reference, tolerance).f1
                for d, demo in enumerate(demos)
            ]
        )
        pr = [
            score_changepoints(res.keypoints[d][n], demo.reference, tolerance) for d, demo in enumerate(demos)
        ]
        counts = res.keypoint_counts[n]
        out[n] = {
            "keypoints_per_demo": mean_interval(counts),
            "demos_without_keypoints": int((counts == 0).sum()),
            "precision": mean_interval(np.array([s.precision for s in pr])),
            "recall": mean_interval(np.array([s.recall for s in pr])),
            "f1": mean_interval(f),
        }
    return out


def keypoint_offsets(
    res: RunResult, demos: list[Demo], reach: int = 2 * WINDOW
) -> dict[str, dict[str, dict]]:
    """Per stream and raw event kind: nearest keypoint − event (frames), over events with a keypoint within `reach`."""
    out: dict[str, dict[str, dict]] = {}
    for n in STREAMS:
        out[n] = {}
        for kind in EVENT_KINDS:
            off = []
            n_events = 0
            for d, demo in enumerate(demos):
                kp = res.keypoints[d][n]
                for e in demo.events.of_kind(kind).tolist():
                    n_events += 1
                    if kp.size:
                        j = int(np.argmin(np.abs(kp - e)))
                        if abs(int(kp[j]) - e) <= reach:
                            off.append(int(kp[j]) - e)
            o = np.array(off)
            out[n][kind] = {
                "n_events": n_events,
                "n_with_keypoint": int(o.size),
                "median": float(np.median(o)) if o.size else None,
                "p10": float(np.percentile(o, 10)) if o.size else None,
                "p90": float(np.percentile(o, 90)) if o.size else None,
            }
    return out


def paired(a: dict, b: dict) -> dict:
    """a − b on per-demo F1: mean, 95% CI, Wilcoxon signed-rank p (two-sided), wins/ties/losses."""
    x = np.array(a["per_demo_f1"]) - np.array(b["per_demo_f1"])
    s = mean_interval(x)
    nonzero = x[np.abs(x) > 1e-12]
    p = float(stats.wilcoxon(nonzero).pvalue) if nonzero.size >= 5 else float("nan")
    return {
        **s,
        "wilcoxon_p": p,
        "wins": int((x > 1e-12).sum()),
        "ties": int((np.abs(x) <= 1e-12).sum()),
        "losses": int((x < -1e-12).sum()),
    }
