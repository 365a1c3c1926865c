"""``forcemap segment``: segment a dataset's episodes and write the segments back into it.

    forcemap segment --dataset outputs/gbti --weights wrist_force=0.35 finger_force=0.35 [--dry-run]

The work is :func:`lerobot_forcemap.data.segment.segment_dataset`; this module is its argparse.
"""

from __future__ import annotations

import argparse
from collections.abc import Sequence

from lerobot_forcemap import layout
from lerobot_forcemap.data.reader import read_meta
from lerobot_forcemap.data.segment import SUBTASK_STYLES, EpisodeSegments, segment_dataset
from lerobot_forcemap.segmentation import AUTHORS_WINDOW_S, SegmentationConfig
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
        "(unlisted streams: 1)",
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
        help="peaks (default, deterministic: maxima of the combined density at least --window frames "
        "apart) or sample (the paper: random draws from it, clustered; see --seed)",
    )
    parser.add_argument("--window", type=int, default=64, help="jerk moving-average window, frames")
    parser.add_argument("--min-run", type=int, default=64, help="frames a run above threshold must last")
    parser.add_argument(
        "--grace", type=int, default=4, help="frames a run may dip below threshold without ending (default 4)"
    )
    parser.add_argument("--min-segment-length", type=int, default=None, help="frames (default window/2)")
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


def run(args: argparse.Namespace) -> int:
    config = SegmentationConfig(
        window=args.window,
        min_run=args.min_run,
        grace=args.grace,
        mode=args.mode,
        changepoints=args.changepoints,
        seed=args.seed,
        min_segment_length=args.min_segment_length,
    )
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
        # --window/--min-run count frames: the authors' 64 are 0.39 s at their ~166 Hz recorder
        fps = float(read_meta(args.dataset).fps)
        scaled = max(5, int(round(AUTHORS_WINDOW_S * fps)))
        print(
            f"note: {len(single)} of {len(segs)} episode(s) found no changepoint. --window {args.window} and "
            f"--min-run {args.min_run} count frames; the authors' 64 frames are {AUTHORS_WINDOW_S:.2f} s at "
            f"their ~166 Hz, which at this dataset's {fps:g} fps is --window {scaled} --min-run {scaled} "
            "(the forcemap policy's window at this rate; its own segments='auto' reads the commanded action, "
            "not the measured pose, so its cuts can differ: fit with segments='dataset' to use these labels)"
        )
