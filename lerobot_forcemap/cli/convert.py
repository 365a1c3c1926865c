"""``forcemap convert``: lab-recorder / GBTI h5 recordings -> a LeRobot v3 dataset.

    forcemap convert <recordings>/ur5e/press_*.h5 --out outputs/press_real [--fps 50]
    forcemap convert <recordings>/gbti/Grasping_Demos.h5 --gbti [--gbti-keys Cube/User1/Position1] --out outputs/gbti

The work is :mod:`lerobot_forcemap.data.convert`; this module is its argparse.
"""

from __future__ import annotations

import argparse

from lerobot_forcemap.data.convert import (
    DEFAULT_FPS,
    LOWPASS_FRACTION_OF_FPS,
    LOWPASS_MAX_FRACTION_OF_SOURCE,
    SOURCES_FILE,
    convert_gbti,
    convert_recordings,
)
from lerobot_forcemap.data.recorder import GbtiKey
from lerobot_forcemap.data.transforms import GRIPPER_FULL_SCALE

__all__ = ["add_arguments", "run"]


def _gbti_key_arg(text: str) -> GbtiKey:
    # argparse names the flag with an ArgumentTypeError's text; a ValueError's it replaces by "invalid value"
    try:
        return GbtiKey.parse(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument(
        "inputs", nargs="+", metavar="INPUT", help="lab-recorder h5 files, or one GBTI h5 with --gbti"
    )
    parser.add_argument(
        "--out", required=True, help="output dataset folder (must not exist unless --overwrite)"
    )
    parser.add_argument("--repo-id", default="local/forcemap", help="dataset id (any string works locally)")
    parser.add_argument(
        "--fps", type=int, default=DEFAULT_FPS, help=f"resampling rate in Hz (default {DEFAULT_FPS})"
    )
    parser.add_argument(
        "--gbti", action="store_true", help="INPUT is the GBTI grasping file: one episode per demo"
    )
    parser.add_argument(
        "--gbti-keys",
        nargs="+",
        metavar="KEY",
        type=_gbti_key_arg,
        help="only these demos, e.g. Cube/User1/Position1",
    )
    parser.add_argument(
        "--task", help="task string for every episode (default: from the file name / GBTI object)"
    )
    parser.add_argument(
        "--tare", choices=["auto", "start", "end", "none"], default="auto", help="wrench bias window"
    )
    parser.add_argument(
        "--force-lowpass-hz",
        default="auto",
        help=f"wrench anti-alias cutoff in Hz, or 0 for none; 'auto' (default): {LOWPASS_FRACTION_OF_FPS} x "
        f"--fps when that is below {LOWPASS_MAX_FRACTION_OF_SOURCE} x the recorded wrench's sample rate, else no "
        f"filter (per episode in {SOURCES_FILE})",
    )
    parser.add_argument(
        "--gripper-full-scale", type=float, default=GRIPPER_FULL_SCALE, help="raw gripper reading = closed"
    )
    parser.add_argument(
        "--on-duplicate-timestamps",
        choices=["merge", "raise"],
        default="merge",
        help="samples repeating the previous timestamp: collapse them with a warning (default) or fail",
    )
    parser.add_argument(
        "--teleoperated",
        action="store_true",
        help="no hand guided the tool: the contact reaction is the tared wrench (default: kinesthetic, the "
        "guiding hand's force is estimated and left out of it)",
    )
    parser.add_argument("--overwrite", action="store_true", help="replace --out if it exists")


def _lowpass(text: str) -> float | str | None:
    if text == "auto":
        return text
    try:
        return float(text) or None
    except ValueError:
        raise ValueError(f"--force-lowpass-hz must be a number or 'auto', got {text!r}") from None


def run(args: argparse.Namespace) -> int:
    common = dict(
        repo_id=args.repo_id,
        fps=args.fps,
        tare=args.tare,
        force_lowpass_hz=_lowpass(args.force_lowpass_hz),
        gripper_full_scale=args.gripper_full_scale,
        overwrite=args.overwrite,
        on_duplicate=args.on_duplicate_timestamps,
        kinesthetic=not args.teleoperated,
    )
    if args.gbti:
        if len(args.inputs) != 1:
            raise ValueError("--gbti takes exactly one INPUT file")
        result = convert_gbti(args.inputs[0], args.out, keys=args.gbti_keys, task=args.task, **common)
    else:
        if args.gbti_keys:
            raise ValueError("--gbti-keys needs --gbti")
        result = convert_recordings(args.inputs, args.out, task=args.task, **common)
    size = sum(p.stat().st_size for p in result.root.rglob("*") if p.is_file())
    print(
        f"wrote {result.n_episodes} episode(s), {result.n_frames} frames at {result.fps} Hz to {result.root} "
        f"({size / 1e6:.2f} MB)"
    )
    return 0
