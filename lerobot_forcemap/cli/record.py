"""``forcemap record``: scripted demonstrations of a sim task into a LeRobot v3 dataset.

    forcemap record --task press --episodes 5 --seed 0 --out datasets/press [--images] [--object apple]

The work is ``lerobot_forcemap.envs.record.record_demonstrations``; this module is its argparse.
"""

from __future__ import annotations

import argparse
from pathlib import Path


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from lerobot_forcemap.envs.registration import TASKS

    parser.add_argument("--task", required=True, choices=sorted(TASKS), help="sim task")
    parser.add_argument(
        "--episodes", type=int, default=5, help="number of successful demonstrations to record"
    )
    parser.add_argument(
        "--seed", type=int, default=0, help="seed of the first episode (episode k uses seed + attempt)"
    )
    parser.add_argument("--out", required=True, type=Path, help="dataset root folder")
    parser.add_argument("--repo-id", default=None, help="dataset repo id (default local/forcemap_<task>)")
    parser.add_argument("--images", action="store_true", help="also record the front camera (video)")
    parser.add_argument("--image-size", type=int, default=128, help="camera image size in pixels (square)")
    parser.add_argument("--overwrite", action="store_true", help="replace --out if it exists")
    parser.add_argument(
        "--max-attempts",
        type=int,
        default=None,
        help="give up after this many attempts, failed demonstrations included (default 3 x --episodes)",
    )
    parser.add_argument(
        "--object", default=None, help="grasping tasks: the object (default: the task's demonstration object)"
    )


def run(args: argparse.Namespace) -> int:
    from lerobot_forcemap.envs.record import record_demonstrations, summary

    result = record_demonstrations(
        args.task,
        args.episodes,
        args.seed,
        args.out,
        images=args.images,
        image_size=args.image_size,
        repo_id=args.repo_id,
        overwrite=args.overwrite,
        max_attempts=args.max_attempts,
        object_name=args.object,
    )
    s = summary(result.episodes)
    print(
        f"wrote {result.n_episodes} episodes of {result.task} to {result.root} (seeds {result.seeds}; "
        f"skipped {result.skipped_seeds}); max contact force {s['max_contact_force']['mean']:.1f} ± "
        f"{s['max_contact_force']['std']:.1f} N, mean {s['mean_contact_force']['mean']:.2f} ± "
        f"{s['mean_contact_force']['std']:.2f} N"
    )
    return 0
