"""Read chosen episodes of a LeRobot v3 dataset as NumPy columns, with the metadata read once.

``read_episodes(repo_id, root, episodes, columns)`` returns the requested columns of those episodes'
frames (rows in file order) together with the dataset's fps, feature dict and the task strings of the
episodes. Errors name the dataset and the episodes or file at fault before LeRobot's own readers run
(an episode the dataset lacks, a data file that disagrees with ``meta/info.json``).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap._validation import check_int_list
from lerobot_forcemap.data.schema import check_data_columns

__all__ = ["EpisodeColumns", "read_episodes"]


@dataclass(frozen=True)
class EpisodeColumns:
    """Columns of chosen episodes of a dataset.

    columns: ``{name: (rows, *shape) array}`` of the requested columns the dataset has (the others are
    left out: ``features`` says what it holds); rows of every chosen episode, in file order.
    features: LeRobot's feature dict (``meta/info.json``); fps: frames per second; tasks: the distinct
    task strings of the chosen episodes, sorted; root: the dataset folder.
    """

    columns: dict[str, np.ndarray]
    features: dict[str, dict[str, Any]]
    fps: float
    tasks: list[str]
    root: Path


def read_episodes(
    repo_id: str,
    root: str | Path | None,
    episodes: Sequence[int],
    columns: Iterable[str],
    *,
    name: str = "episodes",
) -> EpisodeColumns:
    """The ``columns`` of ``episodes`` (indices) of the dataset ``repo_id`` at ``root`` (None: LeRobot's
    cache, fetched from the Hub if missing). ``name``: what the episodes are called in errors (the
    setting that chose them)."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset, LeRobotDatasetMetadata  # heavy import

    episodes = sorted(check_int_list(name, episodes, low=0, distinct=True))
    meta = LeRobotDatasetMetadata(repo_id, root=root)
    # checked first: LeRobotDataset given an episode it lacks fails with "Instruction 'train'
    # corresponds to no data!", or goes looking on the Hub for the missing files
    missing = [e for e in episodes if e >= meta.total_episodes]
    if missing:
        raise ValueError(
            f"{name}: episode(s) {missing} not in the dataset {meta.root} "
            f"(it has episodes 0..{meta.total_episodes - 1})"
        )
    if (Path(meta.root) / "data").is_dir():
        check_data_columns(meta.root)
    dataset = LeRobotDataset(repo_id, root=meta.root, episodes=episodes)
    keys = [k for k in dict.fromkeys(columns) if k in dataset.hf_dataset.column_names]
    table = dataset.hf_dataset.with_format("numpy", columns=keys)
    return EpisodeColumns(
        columns={k: np.asarray(table[k]) for k in keys},
        features=dict(meta.features),
        fps=float(meta.fps),
        tasks=_episode_tasks(meta, episodes),
        root=Path(meta.root),
    )


def _episode_tasks(meta: Any, episodes: Sequence[int]) -> list[str]:
    """The task strings (sorted, distinct) of ``episodes`` in a ``LeRobotDatasetMetadata``."""
    chosen = set(episodes)
    table = meta.episodes.select_columns(["episode_index", "tasks"]).to_dict()
    found = {
        str(t)
        for e, tasks in zip(table["episode_index"], table["tasks"], strict=True)
        if int(e) in chosen
        for t in tasks
    }
    return sorted(found)
