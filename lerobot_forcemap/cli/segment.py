"""``forcemap segment``: segment a dataset's episodes and write the segments back into it.

    forcemap segment --dataset outputs/gbti --weights wrist_force=0.35 finger_force=0.35 [--dry-run]

The work is :func:`lerobot_forcemap.data.segment.segment_dataset`; this module is its argparse. The
windows are given in seconds (``--window-s`` ...; defaults ``segmentation.DEFAULT_TIMING``, the forcemap
policy's) and converted at the dataset's fps; ``--window`` ... in frames replace them.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence
from dataclasses import replace

from lerobot_forcemap import layout
from lerobot_forcemap.data.reader import read_meta
from lerobot_forcemap.data.segment import SUBTASK_STYLES, EpisodeSegments, segment_dataset
from lerobot_forcemap.segmentation import DEFAULT_TIMING, SegmentationConfig, SegmentationTiming
from lerobot_forcemap.segmentation.config import CHANGEPOINT_METHODS, MODES

__all__ = ["add_arguments", "run"]


def _parse_pairs(items: Sequence[str] | None, what: str) -> dict[str, float]:
    out = {}
    for item in items or ():
        name, sep, value = item.partition("=")
        if not sep:
            raise ValueError(f"--{what} takes name=value pairs, got {item!r}")
        try:
            number = float(value)
        except ValueError:
            raise ValueError(f"--{what} {item!r}: {value!r} is not a number") from None
        if name.strip() in out:
            raise ValueError(f"--{what}: {name.strip()!r} given twice")
        out[name.strip()] = number
    return out


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--dataset", required=True, help="dataset root folder (rewritten when done)")
    parser.add_argument(
        "--repo-id",
        default="local/forcemap",
        help="dataset id the folder goes by (any string works locally; default local/forcemap)",
    )
    parser.add_argument(
        "--weights",
        nargs="+",
        metavar="NAME=V",
        help="stream weights, e.g. joints=0 position=0.1 wrist_force=0.35 gripper=0.35 finger_force=0.2 "
        "touch_down=4 lift_off=4 (unlisted streams: 1, the contact events of a dataset with a contact "
        "column: 4)",
    )
    parser.add_argument(
        "--thresholds", nargs="+", metavar="NAME=V", help="keypoint thresholds (fractions of max)"
    )
    parser.add_argument(
        "--mode",
        choices=MODES,
        default="geometric",
        help="how the streams' keypoint densities combine: geometric (default, weighted sum of logs), "
        "product (of the streams with weight > 0; weights only select) or linear (weighted mean)",
    )
    parser.add_argument(
        "--changepoints",
        choices=CHANGEPOINT_METHODS,
        default="peaks",
        help="peaks (default, deterministic: maxima of the combined density at least a window "
        "apart) or sample (the paper: random draws from it, clustered; see --seed)",
    )
    _add_timing_arguments(parser)
    parser.add_argument(
        "--seed",
        type=int,
        default=0,
        help="random seed of --changepoints sample (default 0; peaks ignores it)",
    )
    parser.add_argument("--episodes", type=int, nargs="+", help="only these episodes (default all)")
    parser.add_argument("--style", choices=list(SUBTASK_STYLES), default="motion", help="subtask row style")
    parser.add_argument(
        "--no-subtasks",
        action="store_true",
        help="write segment_index only, no LeRobot subtask rows (LeRobot 0.6.1's lerobot-dataset-viz "
        "cannot batch language rows; forcemap viz shows both)",
    )
    parser.add_argument("--dry-run", action="store_true", help="print the changepoints, write nothing")


def _add_timing_arguments(parser: argparse.ArgumentParser) -> None:
    """The window, run, grace and shortest segment: in seconds, or in frames (which replace them)."""
    d = DEFAULT_TIMING
    parser.add_argument(
        "--window-s",
        type=float,
        default=d.window_s,
        help=f"jerk moving-average window, s (default {d.window_s:g})",
    )
    parser.add_argument(
        "--min-run-s",
        type=float,
        default=d.min_run_s,
        help="s a run above threshold must last (default the window)",
    )
    parser.add_argument(
        "--grace-s",
        type=float,
        default=d.grace_s,
        help="s a run may dip below threshold (default 4/64 of the window)",
    )
    parser.add_argument(
        "--min-segment-s",
        type=float,
        default=d.min_segment_s,
        help="shortest segment, s (default half the window)",
    )
    parser.add_argument("--window", type=int, default=None, help="the window in frames (replaces --window-s)")
    parser.add_argument(
        "--min-run", type=int, default=None, help="frames a run must last (default: the window)"
    )
    parser.add_argument("--grace", type=int, default=None, help="frames a run may dip (replaces --grace-s)")
    parser.add_argument(
        "--min-segment-length", type=int, default=None, help="frames (replaces --min-segment-s)"
    )


def _config(args: argparse.Namespace, fps: float) -> SegmentationConfig:
    """The settings in seconds at the dataset's ``fps``, the ones given in frames put in."""
    timing = SegmentationTiming(
        window_s=args.window_s,
        min_run_s=args.min_run_s,
        grace_s=args.grace_s,
        min_segment_s=args.min_segment_s,
    )
    config = timing.config(fps, mode=args.mode, changepoints=args.changepoints, seed=args.seed)
    frames = {
        "window": args.window,
        # a run lasts the window unless told otherwise, in frames or in seconds
        "min_run": args.window if args.min_run is None and args.min_run_s is None else args.min_run,
        "grace": args.grace,
        "min_segment_length": args.min_segment_length,
    }
    return replace(config, **{k: v for k, v in frames.items() if v is not None})


def run(args: argparse.Namespace) -> int:
    # the windows are seconds at the dataset's fps; a wrong path is named before the heavy imports
    config = _config(args, float(read_meta(args.dataset, repo_id=args.repo_id, name="--dataset").fps))
    segs = segment_dataset(
        args.dataset,
        weights=_parse_pairs(args.weights, "weights"),
        thresholds=_parse_pairs(args.thresholds, "thresholds"),
        config=config,
        episodes=args.episodes,
        style=args.style,
        subtasks=not args.no_subtasks,
        repo_id=args.repo_id,
        write=not args.dry_run,
    )
    _print_segments(segs)
    _print_notes(segs, config, args)
    if not args.dry_run:
        what = f"{layout.SEGMENT_INDEX}" + ("" if args.no_subtasks else f" and {args.style} subtasks")
        print(f"wrote {what} to {args.dataset}")
    return 0


def _print_segments(segs: Sequence[EpisodeSegments]) -> None:
    """The stream settings used, then each episode's changepoints."""
    first = next((s.result for s in segs if s.result is not None), None)
    if first is not None:  # a stream not given in --weights keeps weight 1: say what was used
        print(
            "streams (weight, threshold): "
            + ", ".join(f"{n} ({r.weight:g}, {r.threshold:g})" for n, r in first.streams.items())
        )
    for s in segs:
        dropped = s.result.rejected.tolist() if s.result is not None else []
        print(
            f"episode {s.episode_index}: {s.n_segments} segment(s), changepoints {s.changepoints.tolist()}"
            + (f"; --min-segment-length dropped {dropped}" if dropped else "")
        )


def _print_notes(
    segs: Sequence[EpisodeSegments], config: SegmentationConfig, args: argparse.Namespace
) -> None:
    """What to change when episodes got one segment: the length limit, or the window in frames."""

    def all_dropped(s: EpisodeSegments) -> bool:
        return s.result is not None and s.result.rejected.size > 0

    single = [s for s in segs if s.n_segments == 1 and not all_dropped(s)]
    cut = [s for s in segs if s.n_segments == 1 and all_dropped(s)]
    if cut:
        shortest = config.min_segment_length or config.window // 2
        print(
            f"note: {len(cut)} of {len(segs)} episode(s) found changepoints but --min-segment-length "
            f"{shortest} (frames) dropped them all: lower it to keep them"
        )
    if single:
        fps = float(read_meta(args.dataset, repo_id=args.repo_id).fps)
        default = DEFAULT_TIMING.config(fps)
        print(
            f"note: {len(single)} of {len(segs)} episode(s) found no changepoint with a window of "
            f"{config.window} frames and runs of {config.min_run} frames; the default {DEFAULT_TIMING.window_s:g} s "
            f"at this dataset's {fps:g} fps is --window {default.window} --min-run {default.min_run} "
            "(the forcemap policy's window at this rate; its own segments='auto' reads the commanded action, "
            "not the measured pose, so its cuts can differ: fit with segments='dataset' to use these labels)"
        )
