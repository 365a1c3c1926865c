"""``forcemap push``: share a dataset or a fitted policy on the Hugging Face Hub.

    forcemap push --dataset datasets/press --repo-id you/press-demos [--private] [--tag ur5e ...]
    forcemap push --policy outputs/press_policy --repo-id you/forcemap-press [--private] \
        [--dataset-repo-id you/press-demos]

A dataset goes up through :func:`lerobot_forcemap.data.hub.push_dataset` (LeRobot's dataset push, with
our card: units, frames, sources). A policy folder (``forcemap fit --out`` or lerobot-train's
``checkpoints/last/pretrained_model``) is loaded first, so a corrupted or mismatched checkpoint fails
here with the loader's message (safetensors only, nothing unpickled); then its config and weights, its
pre-/post-processor files, the fit report and a model card go to one model repo in a single commit,
which is what ``lerobot-eval --policy.path=<repo_id>`` and ``ForceMapPolicy.from_pretrained(<repo_id>)``
read back. The card's ``datasets:`` field names the Hub dataset the policy was fitted from:
``--dataset-repo-id``, else the one lerobot-train (``train_config.json``) or ``forcemap fit --repo-id``
(``fit_report.json``) recorded; a ``local/...`` id names none.
Needs a token (``hf auth login`` or ``HF_TOKEN``) and network access (unset ``HF_HUB_OFFLINE``).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from lerobot_forcemap.data.hub import check_repo_id, push_dataset
from lerobot_forcemap.jsonfile import read_json_object

__all__ = ["POLICY_UPLOAD_PATTERNS", "push_policy", "add_arguments", "run"]


#: what a policy push uploads (LeRobot's own ``push_model_to_hub`` allows the same kinds)
POLICY_UPLOAD_PATTERNS = ("*.safetensors", "*.json", "*.md")


def push_policy(
    path: str | Path, repo_id: str, *, private: bool | None = None, dataset_repo_id: str | None = None
) -> str:
    """Push the forcemap checkpoint folder ``path`` to the model repo ``repo_id``; returns its URL.
    ``dataset_repo_id``: the Hub dataset it was fitted from, for the card (default: the recorded one).

    Everything is loaded and checked first (policy, both processor pipelines), then written to one
    temporary folder with a model card and uploaded in a single commit: a bad file fails before
    anything reaches the Hub, and the repo never holds a policy without its processors.
    """
    check_repo_id(repo_id)
    if dataset_repo_id is not None:
        check_repo_id(dataset_repo_id, "--dataset-repo-id")
    path = Path(path)
    if not (path / "config.json").is_file():
        raise ValueError(f"{path}: not a policy checkpoint folder (no config.json)")
    import tempfile

    from huggingface_hub import HfApi
    from lerobot.policies.factory import make_pre_post_processors  # lazy: heavy imports

    from lerobot_policy_forcemap.checkpoint import check_processor_files
    from lerobot_policy_forcemap.modeling_forcemap import ForceMapPolicy

    policy = ForceMapPolicy.from_pretrained(path)
    check_processor_files(path, required=True)
    pre, post = make_pre_post_processors(policy.config, pretrained_path=str(path))
    report = _fit_report(path)
    dataset_repo_id = dataset_repo_id or _recorded_dataset_repo_id(path)
    # as lerobot-train's push does: the pushed config and the card's usage line name the repo
    policy.config.repo_id = repo_id
    if private is not None:
        policy.config.private = private
    with tempfile.TemporaryDirectory(prefix="forcemap-push-") as tmp:
        staged = Path(tmp)
        policy.save_pretrained(staged)
        pre.save_pretrained(staged)
        post.save_pretrained(staged)
        if report is not None:
            (staged / FIT_REPORT).write_text(json.dumps(report, indent=2))
        _model_card(policy, report, dataset_repo_id).save(str(staged / "README.md"))
        api = HfApi()
        repo_id = api.create_repo(repo_id=repo_id, private=private, exist_ok=True).repo_id
        api.upload_folder(
            repo_id=repo_id,
            repo_type="model",
            folder_path=staged,
            commit_message="Upload forcemap policy: config, fitted maps, processors, fit report, card",
            allow_patterns=list(POLICY_UPLOAD_PATTERNS),
        )
    return f"https://huggingface.co/{repo_id}"


#: ``forcemap fit`` writes this next to the checkpoint (segments, changepoints, EM diagnostics)
FIT_REPORT = "fit_report.json"


def _fit_report(path: Path) -> dict | None:
    file = path / FIT_REPORT
    if not file.is_file():
        return None
    report = read_json_object(file)
    # a local dataset path says nothing on the Hub and may reveal the user's folders
    if "dataset" in report and Path(str(report["dataset"])).is_absolute():
        report["dataset"] = Path(str(report["dataset"])).name
    return report


def _recorded_dataset_repo_id(path: Path) -> str | None:
    """The Hub dataset id lerobot-train (``train_config.json``) or ``forcemap fit`` (``fit_report.json``)
    recorded next to the checkpoint; None for ``local/...`` ids (a dataset never on the Hub)."""
    for name, keys in (("train_config.json", ("dataset", "repo_id")), (FIT_REPORT, ("dataset_repo_id",))):
        if not (path / name).is_file():
            continue
        value = read_json_object(path / name)
        for key in keys:
            value = value.get(key) if isinstance(value, dict) else None
        if isinstance(value, str) and value.count("/") == 1 and not value.startswith("local/"):
            return value
    return None


def _model_card(policy, report: dict | None, dataset_repo_id: str | None):
    """LeRobot's model card (as ``lerobot-train --policy.push_to_hub`` writes it) plus what the fit found."""
    config = policy.config
    card = policy.generate_model_card(dataset_repo_id, config.type, config.license, config.tags)
    lines = [
        "",
        "## Force-constrained elastic maps (lerobot_forcemap)",
        "",
        f"Closed-form skill: {config.n_segments} segment(s) fitted at {config.fps:g} fps "
        f"(arm nodes {list(config.segment_n_nodes)}, gripper nodes {list(config.segment_n_gripper_nodes)}, "
        f"task anchors {list(config.segment_anchors)}); tasks: {list(config.dataset_tasks)}.",
    ]
    if report:
        lines.append(
            f"Fitted from `{report.get('dataset')}`, episodes {report.get('episodes')}; "
            f"the full fit report is `{FIT_REPORT}`."
        )
    card.text += "\n".join(lines) + "\n"
    return card


def add_arguments(parser: argparse.ArgumentParser) -> None:
    what = parser.add_mutually_exclusive_group(required=True)
    what.add_argument("--dataset", help="LeRobot dataset folder to push (e.g. datasets/press)")
    what.add_argument(
        "--policy", help="policy checkpoint folder to push (forcemap fit --out, or pretrained_model)"
    )
    parser.add_argument("--repo-id", required=True, help="owner/name on the Hub")
    parser.add_argument("--private", action="store_true", help="create the repo private")
    parser.add_argument(
        "--dataset-repo-id",
        default=None,
        help="policies only: the Hub dataset it was fitted from, for the model card "
        "(default: the id lerobot-train or forcemap fit --repo-id recorded)",
    )
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
        if args.dataset_repo_id:
            raise ValueError(
                "--dataset-repo-id applies to policies only (--repo-id names the dataset's repo)"
            )
        url = push_dataset(args.dataset, args.repo_id, private=private, tags=args.tags)
    else:
        if args.tags:
            raise ValueError("--tag applies to datasets only")
        url = push_policy(args.policy, args.repo_id, private=private, dataset_repo_id=args.dataset_repo_id)
    print(f"pushed to {url}")
    return 0
