"""``python -m experiments.gbti_segmentation`` (``make segmentation-experiment``): the study end to end
(package docstring); the flags are checked before anything is read or written."""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from dataclasses import asdict
from pathlib import Path

import numpy as np
from tqdm import tqdm

from lerobot_forcemap._validation import check_int, check_real, usage_errors
from lerobot_forcemap.data.recorder import gbti_keys
from lerobot_forcemap.evaluation.stats import mean_interval
from lerobot_forcemap.segmentation.events import EVENT_KINDS, EventThresholds

from . import study
from .configurations import RunSpec
from .data import (
    FIGURE_DEMO,
    GBTI_FILE,
    PAPER_COUNTS,
    STREAMS,
    TABLE_I,
    THRESHOLDS,
    WINDOW,
    Demo,
    chosen_keys,
    default_data_dir,
    load_demos,
)
from .report import REPO, render_markdown
from .scoring import score_run

#: what each stream holds, for the report's settings
STREAM_CONTENTS = {
    "cartesian": "TCP position (3)",
    "joints": "joint positions (6, unwrapped)",
    "gripper": "opening 0..1 (1)",
    "wrist_force": "tared base-frame force (3)",
    "finger_force": "raw finger-force counts (1)",
}


def parse_args(argv: list[str] | None) -> tuple[argparse.Namespace, Path, list]:
    """The checked flags, the GBTI file and the demo keys used; ``--figure-demo`` resolved."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=None, help=f"folder holding {GBTI_FILE} (default: found)")
    ap.add_argument("--out", type=Path, default=REPO / "results")
    ap.add_argument("--seeds", type=int, default=5, help="sample-mode runs per demo (the paper: 5; >= 1)")
    ap.add_argument(
        "--n-points", type=int, default=1000, help="frames per demo after resampling (the paper: 1000)"
    )
    ap.add_argument(
        "--tolerance", type=float, default=64.0, help="matching tolerance in frames (default: one window)"
    )
    ap.add_argument(
        "--merge-within", type=float, default=64.0, help="events closer than this many frames count as one"
    )
    ap.add_argument("--limit", type=int, default=None, help="use only N demos (quick check; >= 1)")
    ap.add_argument(
        "--figure-demo",
        default=None,
        help=f"demo key drawn in segmentation.png (default {FIGURE_DEMO}, or the first demo used when "
        "--limit leaves it out)",
    )
    args = ap.parse_args(argv)
    with usage_errors(ap):
        check_int("--seeds", args.seeds, low=1)
        if args.limit is not None:
            check_int("--limit", args.limit, low=1)
        check_int("--n-points", args.n_points, low=1)
        check_real("--tolerance", args.tolerance, low=0.0, low_open=True)
        args.data = args.data or default_data_dir()
        h5 = args.data / GBTI_FILE if args.data is not None else None
        if h5 is None or not h5.is_file():
            raise ValueError(
                f"--data {args.data}: {h5 or GBTI_FILE} not found (pass --data or set FORCEMAP_SHARED_DATA)"
            )
        keys = chosen_keys(h5, args.limit)
        args.figure_demo = _figure_demo(args.figure_demo, h5, keys, args.limit)
    return args, h5, keys


def _figure_demo(given: str | None, h5: Path, keys: list, limit: int | None) -> str:
    """The demo drawn in segmentation.png: ``given`` when it is among the demos used, else the paper's
    first plate demo, or the first demo used when ``--limit`` leaves it out (said on stderr)."""
    used = [str(k) for k in keys]
    if given is None:
        if FIGURE_DEMO in used:
            return FIGURE_DEMO
        print(f"note: figure demo {FIGURE_DEMO} left out by --limit; drawing {used[0]}", file=sys.stderr)
        return used[0]
    if given not in used:
        if given in {str(k) for k in gbti_keys(h5)}:
            raise ValueError(
                f"--figure-demo {given!r} is left out by --limit {limit}; the demos used: {', '.join(used)}"
            )
        raise ValueError(f"--figure-demo {given!r}: no such demo in {h5}; valid keys: {', '.join(used)}")
    return given


def main(argv: list[str] | None = None) -> int:
    args, h5, keys = parse_args(argv)
    from .figures import figure_demo, figure_f1  # matplotlib: only once the flags are good

    started = time.perf_counter()
    args.out.mkdir(parents=True, exist_ok=True)
    tol = float(args.tolerance)
    demos, align_notes = load_demos(h5, args.n_points, args.merge_within, keys)
    study.add_auto_weights(demos)
    seg_started = time.perf_counter()
    results = study.run_all(demos, args.seeds)
    runtime = {
        "segmentation": time.perf_counter() - seg_started,
        "segment_streams_calls": int(sum(r.n_segments.size for r in results.values())),
    }
    scores = {k: score_run(r, demos, tol) for k, r in tqdm(results.items(), desc="score", unit="config")}
    tol_curve = study.tolerance_sensitivity(results, scores, demos, tol)
    kp, kp_offsets = study.stream_keypoints(results, demos, tol)
    analyses = {
        "paper_counts": PAPER_COUNTS,
        "scores": scores,
        "tolerance_sensitivity": tol_curve,
        "event_kind_hit_rates": study.event_kind_hits(results, demos, tol),
        "stream_keypoints": kp,
        "stream_keypoint_offsets": kp_offsets,
        "paired_comparisons": study.paired_comparisons(scores),
        "count_t_tests": study.count_t_tests(results),
        "auto_weights": study.auto_weight_summary(demos),
    }
    fig_specs = {w: RunSpec("f1", "savgol", w, "geometric", "peaks", None) for w in TABLE_I}
    analyses["figure"] = figure_demo(demos, args.figure_demo, args.out / "segmentation.png", fig_specs)
    figure_f1(scores, tol_curve, args.out / "segmentation_f1.png")
    runtime = {"total": time.perf_counter() - started, **runtime}
    payload = {
        **_head(argv, runtime),
        "data": _data_block(h5, demos, args.n_points, align_notes),
        "settings": _settings_block(args, demos),
        "events": _events_block(demos),
        **analyses,
    }
    (args.out / "segmentation.json").write_text(json.dumps(payload, indent=1, default=float))
    (args.out / "segmentation.md").write_text(render_markdown(payload, scores, args.out))
    print(
        f"wrote {args.out / 'segmentation.md'}, .json, .png, segmentation_f1.png in {runtime['total']:.1f} s "
        f"({runtime['segment_streams_calls']} segment_streams calls in {runtime['segmentation']:.1f} s)"
    )
    return 0


def _head(argv: list[str] | None, runtime: dict) -> dict:
    """The command that ran, its run times and the machine."""
    command = [
        f"OPENBLAS_NUM_THREADS={os.environ.get('OPENBLAS_NUM_THREADS')} .venv/bin/python -m experiments.gbti_segmentation",
        *(sys.argv[1:] if argv is None else argv),
    ]
    return {
        "command": " ".join(command),
        "runtime_s": runtime,
        "machine": {
            "python": platform.python_version(),
            "numpy": np.__version__,
            "cpu_threads": os.environ.get("OPENBLAS_NUM_THREADS"),
            "cpu_count": os.cpu_count(),
        },
    }


def _data_block(h5: Path, demos: list[Demo], n_points: int, align_notes: list[str]) -> dict:
    dt = np.array([d.frame_dt for d in demos])
    return {
        "file": str(h5),
        "n_demos": len(demos),
        "n_points": n_points,
        "frame_dt_s": {"median": float(np.median(dt)), "min": float(dt.min()), "max": float(dt.max())},
        "alignment_warnings": align_notes,
    }


def _settings_block(args: argparse.Namespace, demos: list[Demo]) -> dict:
    tol = float(args.tolerance)
    tol_s = tol * np.array([d.frame_dt for d in demos])
    return {
        "window": WINDOW,
        "min_run": 64,
        "grace": 4,
        "thresholds": THRESHOLDS,
        "n_samples": 20,
        "n_pass": 3,
        "seeds": args.seeds,
        "seed_rule": "numpy.random.default_rng([seed, demo_index]), seed = 0..S-1",
        "tolerance_frames": tol,
        "merge_within_frames": args.merge_within,
        "tolerance_seconds": {
            "median": float(np.median(tol_s)),
            "min": float(tol_s.min()),
            "max": float(tol_s.max()),
        },
        "event_thresholds": asdict(EventThresholds()),
        "streams": STREAM_CONTENTS,
        "table_i_weights": {w: dict(zip(STREAMS, v, strict=True)) for w, v in TABLE_I.items()},
    }


def _events_block(demos: list[Demo]) -> dict:
    """The reference events: counts, merged events per demo, demos without contact events, the delay from
    gripper close to contact, the finger-force contrast around the threshold, and each demo's events."""
    delays = [
        int(d.events.of_kind("contact")[0] - d.events.of_kind("close")[0])
        for d in demos
        if d.events.of_kind("close").size and d.events.of_kind("contact").size
    ]
    delays_arr = np.array(delays) if delays else np.zeros(1)
    n_ref = np.array([d.reference.size for d in demos])
    contrast = np.array([d.events.contact_contrast for d in demos])
    threshold = EventThresholds().min_contrast
    ok, not_ok = contrast >= threshold, contrast < threshold
    return {
        "counts": {k: int(sum(d.events.of_kind(k).size for d in demos)) for k in EVENT_KINDS},
        "reference_after_merge": {"total": int(n_ref.sum()), "per_demo": mean_interval(n_ref)},
        "demos_without_contact_events": [d.key for d in demos if not d.events.finger_force_ok],
        "close_to_contact_delay_frames": {
            "median": float(np.median(delays_arr)),
            "min": int(delays_arr.min()),
            "max": int(delays_arr.max()),
        },
        "finger_force_contrast": {
            "min_ok": float(contrast[ok].min()) if ok.any() else None,
            "max_not_ok": float(contrast[not_ok].max()) if not_ok.any() else None,
        },
        "per_demo": {
            d.key: {
                "frames": d.events.frames.tolist(),
                "kinds": d.events.kinds.tolist(),
                "reference": d.reference.tolist(),
                "contact_contrast": d.events.contact_contrast,
                "gripper_span": d.events.gripper_span,
            }
            for d in demos
        },
    }


if __name__ == "__main__":
    raise SystemExit(main())
