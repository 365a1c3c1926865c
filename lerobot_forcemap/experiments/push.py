"""``forcemap push``: share a dataset or a fitted policy on the Hugging Face Hub.

    forcemap push --dataset datasets/press --repo-id you/press-demos [--private] [--tag ur5e ...]
    forcemap push --policy outputs/press_policy --repo-id you/forcemap-press [--private]

A dataset goes up through :func:`lerobot_forcemap.data.hub.push_dataset` (LeRobot's dataset push, with
our card: units, frames, sources). A policy folder (``forcemap fit --out`` or lerobot-train's
``checkpoints/last/pretrained_model``) is loaded first, so a corrupted or mismatched checkpoint fails
here with the loader's message (safetensors only, nothing unpickled); then its config and weights and
its pre-/post-processor files go to one model repo with LeRobot's ``push_to_hub``, which is what
``lerobot-eval --policy.path=<repo_id>`` and ``ForceMapPolicy.from_pretrained(<repo_id>)`` read back.
Needs a token (``hf auth login`` or ``HF_TOKEN``) and network access (unset ``HF_HUB_OFFLINE``).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..data.hub import check_repo_id, push_dataset

__all__ = ["push_policy", "add_arguments", "run"]


def push_policy(path: str | Path, repo_id: str, *, private: bool | None = None) -> str:
    """Push the forcemap checkpoint folder ``path`` to the model repo ``repo_id``; returns its URL."""
    from lerobot.policies.factory import make_pre_post_processors  # lazy: heavy imports

    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    check_repo_id(repo_id)
    path = Path(path)
    if not (path / "config.json").is_file():
        raise ValueError(f"{path}: not a policy checkpoint folder (no config.json)")
    policy = ForceMapPolicy.from_pretrained(path)
    policy.push_to_hub(repo_id, private=private)
    for processor in make_pre_post_processors(policy.config, pretrained_path=str(path)):
        processor.push_to_hub(repo_id, private=private)
    return f"https://huggingface.co/{repo_id}"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--dataset", help="LeRobot dataset folder to push (e.g. datasets/press)")
    what.add_argument(
        "--policy", help="policy checkpoint folder to push (forcemap fit --out, or pretrained_model)"
    )
    parser.add_argument("--repo-id", required=True, help="owner/name on the Hub")
    parser.add_argument("--private", action="store_true", help="create the repo private")
    parser.add_argument(
        "--tag",
        dest="tags",
        action="append",
        default=[],
        help="extra dataset tag (repeatable; datasets only)",
    )


def run(args: argparse.Namespace) -> int:
    private = True if args.private else None
    if args.dataset:
        url = push_dataset(args.dataset, args.repo_id, private=private, tags=args.tags)
    else:
        if args.tags:
            raise ValueError("--tag applies to datasets only")
        url = push_policy(args.policy, args.repo_id, private=private)
    print(f"pushed to {url}")
    return 0
