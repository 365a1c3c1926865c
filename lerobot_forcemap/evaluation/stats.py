"""Statistics of episode records: the one summariser of ``forcemap eval``, the experiments and the studies.

    summary = summarize(records)                        # n, success (+ Wilson 95 %), stops, force figures
    change = percent_change(summary, demo_summary)      # % change of the mean figures
    per_demo = demo_change(records, demos, "max_contact_force")   # vs each record's own demonstration

Spreads are sample standard deviations (ddof 1; 0 for one value); 95 % intervals of a mean are
Student-t half-widths (NaN for one value); success intervals are Wilson score intervals. Every result
is plain JSON types (floats may be NaN: write them with ``records.finite_or_none``).
"""

from __future__ import annotations

import math
from collections import Counter
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np

from lerobot_forcemap.evaluation.records import FORCE_KEYS, GRIPPER_PHASES, to_json

__all__ = [
    "wilson_interval",
    "t_half_width",
    "sample_stats",
    "mean_interval",
    "success_interval",
    "summarize",
    "failure_counts",
    "percent_change",
    "demo_change",
    "gripper_phase_summary",
    "metric_stats",
]


def wilson_interval(successes: float, n: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score 95 % interval of a success rate (k of n, k may be a sum of rates); (0, 1) when n = 0."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


def _t95(df: int) -> float:
    """Two-sided 95 % Student-t quantile."""
    if df <= 0:
        return float("nan")
    from scipy.stats import t

    return float(t.ppf(0.975, df))


def t_half_width(std: Any, n: int) -> Any:
    """Half-width of the two-sided 95 % t-interval of a mean of ``n`` values with sample std ``std``
    (a number or an array); NaN for fewer than 2 values."""
    if n < 2:
        return np.full_like(np.asarray(std, dtype=np.float64), np.nan)
    return _t95(n - 1) * std / math.sqrt(n)


def sample_stats(values: Any) -> dict[str, Any]:
    """``{mean, std, ci95 (t half-width), min, max}`` over the first axis of ``values`` (per column for
    vectors), as plain JSON numbers; std 0 and ci95 NaN for one value."""
    v = np.asarray(values, dtype=np.float64)
    n = len(v)
    mean = v.mean(axis=0)
    std = v.std(axis=0, ddof=1) if n > 1 else np.zeros_like(mean)
    half = t_half_width(std, n)
    return to_json({"mean": mean, "std": std, "ci95": half, "min": v.min(axis=0), "max": v.max(axis=0)})


def mean_interval(values: Any) -> dict[str, Any]:
    """``{mean, std, ci95: [low, high], n}`` of 1-D ``values``: the mean with its 95 % t-interval (the
    interval is the mean itself for one value)."""
    v = np.asarray(values, dtype=np.float64)
    n = v.size
    mean = float(v.mean())
    sd = float(v.std(ddof=1)) if n > 1 else 0.0
    half = float(t_half_width(sd, n)) if n > 1 else 0.0
    return {"mean": mean, "std": sd, "ci95": [mean - half, mean + half], "n": int(n)}


def success_interval(records: Sequence[Mapping[str, Any]]) -> tuple[tuple[float, float], str, int]:
    """Wilson 95 % interval of the success rate, its unit and the number of units.

    Episodes of one demonstration's policy are not independent (it re-anchors to the object, so its
    outcome hardly changes with the seed): when records carry ``demo`` and a demonstration ran several
    episodes, the unit is the demonstration, with its success rate over its episodes (Wilson on the sum
    of the rates out of the number of demonstrations). Otherwise each episode is a unit.
    """
    demos = [r.get("demo") for r in records]
    if all(d is not None for d in demos) and len(set(demos)) < len(records):
        by_demo: dict[Any, list[bool]] = {}
        for d, r in zip(demos, records, strict=True):
            by_demo.setdefault(d, []).append(bool(r["success"]))
        rates = [float(np.mean(v)) for v in by_demo.values()]
        return wilson_interval(sum(rates), len(rates)), "demonstration", len(rates)
    k = sum(bool(r["success"]) for r in records)
    return wilson_interval(k, len(records)), "episode", len(records)


def summarize(
    records: Sequence[Mapping[str, Any]], figures: Sequence[str] = FORCE_KEYS, *, clipped: bool = True
) -> dict[str, Any]:
    """The summary of episode records (``records.py``): n, seeds, success rate with its Wilson 95 %
    interval (:func:`success_interval`), protective stops, and :func:`sample_stats` of every figure in
    ``figures`` over the records holding it (per axis / finger for vectors).

    ``clipped``: add ``clipped_steps`` (summed over episodes) and ``episodes_clipped`` from the records'
    ``metrics.n_clipped_steps``: the env clips targets outside its workspace or speed limit, so a table
    shows whether the policy asked for what the robot did not do. ``{"n": 0}`` for no records.
    """
    if not records:
        return {"n": 0}
    n = len(records)
    (lo, hi), unit, n_units = success_interval(records)
    out: dict[str, Any] = {
        "n": n,
        "seeds": sorted({int(r["seed"]) for r in records if r.get("seed") is not None}),
        "success_rate": int(sum(bool(r["success"]) for r in records)) / n,
        "success_ci95": [lo, hi],
        "success_ci95_unit": unit,
        "success_ci95_n": n_units,
        "protective_stops": int(sum(bool(r.get("protective_stop")) for r in records)),
    }
    for key in figures:
        values = [r[key] for r in records if key in r]
        if values:
            out[key] = sample_stats(values)
    if clipped:
        counts = [
            r["metrics"]["n_clipped_steps"] for r in records if "n_clipped_steps" in r.get("metrics", {})
        ]
        if counts:
            out["clipped_steps"] = int(sum(counts))
            out["episodes_clipped"] = int(sum(c > 0 for c in counts))
    return out


def failure_counts(records: Sequence[Mapping[str, Any]]) -> dict[str, int]:
    """``{termination reason: episodes}`` of the failed records, in order of first appearance (a
    failure without a reason counts as ``failed``)."""
    return dict(
        Counter(r.get("termination_reason") or "failed" for r in records if not r.get("success", True))
    )


def percent_change(reproduction: Mapping[str, Any], reference: Mapping[str, Any]) -> dict[str, Any]:
    """``{<figure>_change_pct: 100 (r - d) / d}`` of the mean force figures of two :func:`summarize`
    results, reproduction vs reference (negative = less force; NaN where the reference is 0)."""
    out = {}
    for k in FORCE_KEYS:
        if k in reproduction and k in reference:
            r = np.asarray(reproduction[k]["mean"], dtype=float)
            d = np.asarray(reference[k]["mean"], dtype=float)
            with np.errstate(divide="ignore", invalid="ignore"):
                out[k + "_change_pct"] = to_json(np.where(d != 0, 100.0 * (r - d) / d, np.nan))
    return out


def demo_change(
    records: Sequence[Mapping[str, Any]], demos: Sequence[Mapping[str, Any]], key: str
) -> dict[str, Any]:
    """% change of scalar figure ``key`` of each reproduction vs its own demonstration.

    ``records`` carry ``demo`` (the episode they were learned from); ``demos`` are demonstration records
    (``episode`` and ``key``). Per demonstration d: ``100 (mean over its records / demo_d - 1)``; returns
    ``{"per_demo": {d: pct}, "n_demos", "mean", "std", "ci95", "min", "max", "pooled"}`` where pooled is
    ``100 (mean over all records / mean over the used demonstrations - 1)``.
    """
    by_demo: dict[int, list[float]] = {}
    for r in records:
        by_demo.setdefault(int(r["demo"]), []).append(float(r[key]))
    ref = {int(d["episode"]): float(d[key]) for d in demos}
    missing = sorted(set(by_demo) - set(ref))
    if missing:
        raise ValueError(f"demo_change: demonstrations {missing} have no {key!r} figure")
    per = {d: 100.0 * (np.mean(v) / ref[d] - 1.0) for d, v in sorted(by_demo.items()) if ref[d] > 0}
    vals = np.array(list(per.values()))
    if len(vals) == 0:
        return {"per_demo": {}, "n_demos": 0}
    rep_all = np.mean([float(r[key]) for r in records])
    demo_all = np.mean([ref[d] for d in by_demo])
    return {
        "per_demo": {str(d): v for d, v in per.items()},
        "n_demos": len(vals),
        **sample_stats(vals),
        "pooled": float(100.0 * (rep_all / demo_all - 1.0)) if demo_all > 0 else float("nan"),
    }


def gripper_phase_summary(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """Per gripper phase of the records' ``force_by_gripper_phase``: episodes with steps in it, the mean
    of their per-axis max |F|, and per axis the share of episodes whose largest |F| fell in that phase.
    ``{}`` when no record holds it."""
    recs = [r for r in records if r.get("force_by_gripper_phase")]
    if not recs:
        return {}
    per = np.array([[r["force_by_gripper_phase"][p]["max_xyz"] for p in GRIPPER_PHASES] for r in recs])
    steps = np.array([[r["force_by_gripper_phase"][p]["steps"] for p in GRIPPER_PHASES] for r in recs])
    where = np.argmax(per, axis=1)  # (n, 3): the phase of each axis' peak
    out = {}
    for i, p in enumerate(GRIPPER_PHASES):
        used = steps[:, i] > 0
        out[p] = {
            "episodes": int(used.sum()),
            "max_xyz_mean": per[used, i].mean(axis=0).tolist() if used.any() else [0.0, 0.0, 0.0],
            "peak_share_xyz": (where == i).mean(axis=0).tolist(),
        }
    return out


def metric_stats(records: Sequence[Mapping[str, Any]]) -> dict[str, dict[str, float]]:
    """Per scalar task metric that every record holds (``metrics``: coverage, button travel, ...):
    ``{"mean", "std"}`` over the records (sample std, ddof 1; 0 for one record)."""
    values: dict[str, list[float]] = {}
    for r in records:
        for k, v in r.get("metrics", {}).items():
            if isinstance(v, (int, float)) and not isinstance(v, bool):
                values.setdefault(k, []).append(float(v))
    return {
        k: {"mean": float(np.mean(v)), "std": float(np.std(v, ddof=1)) if len(v) > 1 else 0.0}
        for k, v in values.items()
        if len(v) == len(records)
    }
