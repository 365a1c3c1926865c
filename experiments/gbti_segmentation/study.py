"""The study's computations: every configuration segmented and scored, and the analyses built on them.

Each function returns a block of ``results/segmentation.json`` (see ``__main__.py`` for its order).
"""

from __future__ import annotations

import numpy as np
from scipy import stats
from tqdm import tqdm

from lerobot_forcemap.evaluation.stats import mean_interval
from lerobot_forcemap.segmentation import auto_weights

from .configurations import RunResult, RunSpec, config_for, run, streams_for, weights_of
from .data import MODES, STREAMS, TABLE_I, Demo
from .scoring import keypoint_offsets, keypoint_scores, kind_hits, paired, score_run

#: tolerances of the sensitivity table (frames of 1000) and in seconds
TOLERANCES = [16, 32, 48, 64, 96, 128]
TOLERANCES_S = (0.5, 1.0)
#: the paired comparisons of weightings (a - b) on per-demo F1
PAIRS = (
    ("custom", "position"),
    ("uniform", "position"),
    ("custom", "uniform"),
    ("auto", "custom"),
    ("auto", "position"),
)


def add_auto_weights(demos: list[Demo]) -> None:
    """Each demo's label-free weights (``auto_weights``), per derivative, into ``demo.auto``."""
    for derivative in ("savgol", "difference"):
        cfg = config_for(RunSpec("f1", derivative, "uniform", "geometric", "peaks", None), 0)
        for demo in demos:
            demo.auto[derivative] = auto_weights(
                streams_for(demo, weights_of("uniform", demo, derivative)), cfg
            )


def all_specs() -> list[RunSpec]:
    """The Table II reproduction (sampled changepoints, raw differences and Savitzky–Golay) and the F1
    configurations: weightings x modes x changepoint methods x derivatives, controls, single streams."""
    specs: list[RunSpec] = []
    for derivative in ("difference", "savgol"):
        for w in TABLE_I:
            for mode in MODES:
                specs.append(RunSpec("paper", derivative, w, mode, "sample", 1))
        specs.append(RunSpec("paper", derivative, "flat", "product", "sample", 1))
    for derivative in ("savgol", "difference"):
        for method in ("peaks", "sample"):
            for w in (*TABLE_I, "auto"):
                for mode in MODES:
                    specs.append(RunSpec("f1", derivative, w, mode, method, None))
            specs.append(RunSpec("f1", derivative, "gripper_only", "geometric", method, None))
        specs.append(RunSpec("f1", derivative, "flat", "geometric", "sample", None))
        for n in STREAMS:
            if n != "gripper":
                specs.append(RunSpec("f1", derivative, f"only:{n}", "geometric", "peaks", None))
    return specs


def run_all(demos: list[Demo], seeds: int) -> dict[str, RunResult]:
    """Every configuration of :func:`all_specs` over every demo (and seed), by label; the stream
    keypoints are kept for the uniform, geometric, peaks runs."""
    results: dict[str, RunResult] = {}
    for spec in tqdm(all_specs(), desc="segment (configurations x demos x seeds)", unit="config"):
        keep = (
            spec.table == "f1"
            and spec.weighting == "uniform"
            and spec.mode == "geometric"
            and spec.method == "peaks"
        )
        results[spec.label] = run(demos, spec, seeds, keep_keypoints=keep)
    return results


def tolerance_sensitivity(
    results: dict[str, RunResult], scores: dict[str, dict], demos: list[Demo], tol: float
) -> dict:
    """F1 against the tolerance (frames and seconds) for the main configuration, and every
    configuration's mean F1 with closest-pair-first instead of maximum-cardinality matching."""
    curve: dict = {"tolerances_frames": TOLERANCES, "frames": {}, "seconds": {}}
    runs = {
        w: results[RunSpec("f1", "savgol", w, "geometric", "peaks", None).label]
        for w in ("position", "uniform", "custom", "auto", "gripper_only")
    }
    runs["flat (sample)"] = results[RunSpec("f1", "savgol", "flat", "geometric", "sample", None).label]
    for w, res in runs.items():
        curve["frames"][w] = [score_run(res, demos, float(t))["f1"] for t in TOLERANCES]
        curve["seconds"][w] = {f"{s:g}s": score_run(res, demos, s, "seconds")["f1"] for s in TOLERANCES_S}
    curve["greedy_matching"] = {
        key: {
            "greedy": score_run(res, demos, tol, method="greedy")["f1"]["mean"],
            "optimal": scores[key]["f1"]["mean"],
        }
        for key, res in results.items()
    }
    return curve


def event_kind_hits(results: dict[str, RunResult], demos: list[Demo], tol: float) -> dict:
    """Per weighting and changepoint method (Savitzky–Golay, geometric): the hit rate of each event kind."""
    return {
        f"{w}|{method}": kind_hits(
            results[RunSpec("f1", "savgol", w, "geometric", method, None).label], demos, tol
        )
        for w in (*TABLE_I, "auto", "gripper_only")
        for method in ("peaks", "sample")
    }


def stream_keypoints(results: dict[str, RunResult], demos: list[Demo], tol: float) -> tuple[dict, dict]:
    """Per derivative: each stream's own keypoints scored, and where they fall around the events."""
    runs = {
        d: results[RunSpec("f1", d, "uniform", "geometric", "peaks", None).label]
        for d in ("savgol", "difference")
    }
    scores = {d: keypoint_scores(res, demos, tol) for d, res in runs.items()}
    offsets = {d: keypoint_offsets(res, demos) for d, res in runs.items()}
    return scores, offsets


def paired_comparisons(scores: dict[str, dict]) -> dict:
    """Per-demo F1 differences: weighting pairs (Savitzky–Golay) and Savitzky–Golay vs raw differences."""

    def sc(d: str, w: str, mode: str, method: str) -> dict:
        return scores[RunSpec("f1", d, w, mode, method, None).label]

    comparisons = {}
    for method in ("peaks", "sample"):
        for mode in MODES:
            for a, b in PAIRS:
                comparisons[f"savgol|{mode}|{method}|{a}-{b}"] = paired(
                    sc("savgol", a, mode, method), sc("savgol", b, mode, method)
                )
        for w in (*TABLE_I, "auto"):
            for mode in MODES:
                comparisons[f"{w}|{mode}|{method}|savgol-difference"] = paired(
                    sc("savgol", w, mode, method), sc("difference", w, mode, method)
                )
    return comparisons


def count_t_tests(results: dict[str, RunResult]) -> dict:
    """The paper's significance claim on counts (custom lower than position only): a Welch t-test over
    the demo x seed counts, per derivative and mode."""
    out = {}
    for d in ("difference", "savgol"):
        for mode in MODES:
            a = results[RunSpec("paper", d, "custom", mode, "sample", 1).label].n_segments.ravel()
            b = results[RunSpec("paper", d, "position", mode, "sample", 1).label].n_segments.ravel()
            t_res = stats.ttest_ind(a, b, equal_var=False)
            out[f"{d}|{mode}"] = {
                "custom_minus_position": float(a.mean() - b.mean()),
                "welch_p": float(t_res.pvalue),
            }
    return out


def auto_weight_summary(demos: list[Demo]) -> dict:
    """Per derivative and stream: the automatic weights' mean, std and 95 % interval over the demos."""
    return {
        der: {n: mean_interval(np.array([d.auto[der][n] for d in demos])) for n in STREAMS}
        for der in ("savgol", "difference")
    }
