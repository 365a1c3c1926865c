"""Push a converted / recorded dataset to the Hugging Face Hub with our dataset card.

A thin wrapper over ``LeRobotDataset.push_to_hub`` (LeRobot 0.6.1): it creates the dataset repo
(``HfApi.create_repo``), uploads the dataset folder (``upload_folder``, so ``meta/forcemap_*.json``
and the local README.md go too), pushes a card built from LeRobot's template and tags the revision
``v3.0`` (``create_tag``). LeRobot regenerates the card from its template when pushing, so the
description that :func:`lerobot_forcemap.data.schema.write_dataset_card` stored in
``meta/forcemap_card.json`` (units, frames, sources) is passed back in as ``dataset_description``.
"""

from __future__ import annotations

import fnmatch
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from huggingface_hub.errors import HFValidationError
from huggingface_hub.utils import validate_repo_id

from lerobot_forcemap.data.reader import lerobot_dataset
from lerobot_forcemap.data.schema import require_dataset_root
from lerobot_forcemap.jsonfile import read_json_object

__all__ = ["CARD_FILE", "DATASET_UPLOAD_PATTERNS", "card_kwargs", "check_repo_id", "push_dataset"]

CARD_FILE = "meta/forcemap_card.json"
#: what a LeRobot v3 dataset folder holds (``upload_folder`` globs; ``*`` crosses folders): anything else
#: there (a ``.env``, notes, a half-written ``.partial``) stays local, and is named
DATASET_UPLOAD_PATTERNS = ("data/*", "meta/*", "videos/*", "README.md", ".gitattributes")


def check_repo_id(repo_id: str, name: str = "repo_id") -> str:
    """``repo_id`` if it reads ``owner/name`` under the Hub's naming rules, else a ValueError naming it
    (as ``name``: the argument or flag it came from)."""
    if not isinstance(repo_id, str) or repo_id.count("/") != 1 or not all(repo_id.split("/")):
        raise ValueError(f"{name} must be 'owner/name', got {repo_id!r}")
    try:
        validate_repo_id(repo_id)  # allowed characters, no leading '.', no '--', no '.git' ending
    except HFValidationError as err:
        raise ValueError(f"{name} must be 'owner/name' ({err}), got {repo_id!r}") from None
    return repo_id


def card_kwargs(root: str | Path) -> dict[str, Any]:
    """``tags``, ``license`` and ``dataset_description`` for ``push_to_hub`` from ``meta/forcemap_card.json``
    (empty when the dataset has no forcemap card)."""
    path = Path(root) / CARD_FILE
    if not path.is_file():
        return {}
    card = read_json_object(path)
    return {k: card[k] for k in ("tags", "license", "dataset_description") if card.get(k) is not None}


def push_dataset(
    root: str | Path,
    repo_id: str,
    *,
    private: bool | None = None,
    tags: Sequence[str] | None = None,
    branch: str | None = None,
    push_videos: bool = True,
    tag_version: bool = True,
) -> str:
    """Push the LeRobot dataset at ``root`` to ``https://huggingface.co/datasets/<repo_id>``; returns its URL.

    ``repo_id`` must be ``owner/name``. Needs a Hugging Face token (``huggingface-cli login`` or
    ``HF_TOKEN``) and network access (unset ``HF_HUB_OFFLINE``).
    """
    root = require_dataset_root(root)
    check_repo_id(repo_id)
    kwargs = card_kwargs(root)
    kwargs["tags"] = sorted({*kwargs.get("tags", ()), *(tags or ())}) or None
    license_id = kwargs.pop("license", "apache-2.0")
    dataset = lerobot_dataset(root, repo_id=repo_id)  # its files checked first, by name
    files = (p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file())
    left_out = sorted(f for f in files if not any(fnmatch.fnmatch(f, g) for g in DATASET_UPLOAD_PATTERNS))
    if left_out:
        warnings.warn(f"{root}: not part of the dataset, not uploaded: {left_out}", stacklevel=2)
    dataset.push_to_hub(
        branch=branch,
        allow_patterns=list(DATASET_UPLOAD_PATTERNS),
        license=license_id,
        tag_version=tag_version,
        push_videos=push_videos,
        private=private,
        **kwargs,
    )
    return f"https://huggingface.co/datasets/{repo_id}"
