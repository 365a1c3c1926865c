"""``forcemap viz``: one episode of a LeRobot dataset in Rerun, with its force features and segments.

    forcemap viz --dataset datasets/press --episode 0                  # opens the Rerun viewer
    forcemap viz --dataset datasets/press --episode 0 --save ep0.rrd   # writes a recording file

The work is :func:`lerobot_forcemap.data.viz.visualize_episode`; this module is its argparse.
"""

from __future__ import annotations

import argparse

from lerobot_forcemap.data.viz import viewer_command, visualize_episode

__all__ = ["add_arguments", "run"]


def add_arguments(parser: argparse.ArgumentParser) -> None:
    parser.add_argument("--dataset", required=True, help="dataset root folder")
    parser.add_argument("--episode", type=int, default=0, help="episode index (default 0)")
    parser.add_argument(
        "--save", default=None, help="write a .rrd recording here instead of opening a viewer"
    )
    parser.add_argument("--repo-id", default=None)


def run(args: argparse.Namespace) -> int:
    path, logged = visualize_episode(args.dataset, args.episode, save=args.save, repo_id=args.repo_id)
    print(f"episode {args.episode}: " + ", ".join(f"{k} ({n})" for k, n in logged.items()))
    if path is not None:
        print(f"wrote {path} (open with: {viewer_command() or 'rerun'} {path})")
    return 0
