"""The one reader of LeRobot v3 datasets on disk: the metadata once, then columns of chosen episodes.

    meta = read_meta(root)                                    # info.json, meta/episodes, tasks.parquet
    columns = read_columns(meta, [0, 2], ["action", "timestamp"])    # {name: NumPy array}
    data = read_episodes(root, [0], ["action"])               # columns + fps, features, tasks

Columns come straight from ``data/*/*.parquet`` with pyarrow: only the requested columns, only the
row groups holding the chosen episodes. Arrays have the feature's dtype and the shape
``LeRobotDataset.hf_dataset.with_format("numpy")`` gives: ``(rows,)`` for a feature of shape ``(1,)``,
``(rows, *shape)`` otherwise; language, string and image columns are object arrays of their Python
values. Rows are the chosen episodes' rows in file order (files sorted by path), the order LeRobot
reads them in.

A :class:`DatasetMeta` is also what ``make_policy(ds_meta=...)`` needs (``features``, ``stats``,
``repo_id``, ``root``); one can be built from a ``LeRobotDatasetMetadata`` without reading the files
again (:func:`to_meta`). Every problem with the files is a ``ValueError`` naming the file and the
field: a missing or unreadable file, a field ``meta/info.json`` lacks, a data file whose columns
disagree with it. LeRobot itself is imported only by :func:`lerobot_dataset` and for ``stats``.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from functools import cached_property, partial
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap._validation import check_dict, check_int, check_int_list, check_real, check_str, fail
from lerobot_forcemap.data.schema import require_dataset_root
from lerobot_forcemap.jsonfile import read_json_object

__all__ = [
    "DatasetMeta",
    "EpisodeInfo",
    "EpisodeColumns",
    "read_meta",
    "to_meta",
    "read_columns",
    "read_episodes",
    "read_table",
    "data_files",
    "check_data_files",
    "lerobot_dataset",
]

INFO_FILE = "meta/info.json"
TASKS_FILE = "meta/tasks.parquet"
STATS_FILE = "meta/stats.json"
EPISODES_DIR = "meta/episodes"
#: LeRobot v3's data file template (``meta/info.json`` ``data_path`` overrides it)
DEFAULT_DATA_PATH = "data/chunk-{chunk_index:03d}/file-{file_index:03d}.parquet"
#: the columns of ``meta/episodes/*.parquet`` the reader uses
_EPISODE_COLUMNS = (
    "episode_index",
    "tasks",
    "length",
    "dataset_from_index",
    "dataset_to_index",
    "data/chunk_index",
    "data/file_index",
)
#: feature dtypes stored as numbers (the rest come back as Python objects)
_NOT_NUMERIC = ("image", "video", "string", "language")


@dataclass(frozen=True)
class EpisodeInfo:
    """One row of ``meta/episodes``: ``length`` frames, global rows ``[start, stop)``, the data file
    (relative to the dataset root) and the episode's task strings."""

    index: int
    length: int
    start: int
    stop: int
    data_file: str
    tasks: tuple[str, ...]


@dataclass(frozen=True, eq=False)
class DatasetMeta:
    """What ``meta/`` says about a dataset. ``episodes[e]`` is episode ``e``; ``tasks[i]`` the task
    string of ``task_index`` i; ``features`` as LeRobot holds them (shapes as tuples); ``lerobot``:
    the ``LeRobotDatasetMetadata`` it was built from, if any."""

    root: Path
    repo_id: str
    fps: int | float
    features: dict[str, dict[str, Any]]
    episodes: tuple[EpisodeInfo, ...]
    tasks: tuple[str, ...]
    lerobot: Any = field(default=None, repr=False)

    @property
    def total_episodes(self) -> int:
        return len(self.episodes)

    @property
    def camera_keys(self) -> list[str]:
        return [k for k, ft in self.features.items() if ft["dtype"] in ("image", "video")]

    @cached_property
    def stats(self) -> dict[str, dict[str, np.ndarray]] | None:
        """``meta/stats.json`` as LeRobot loads it (``{feature: {stat: array}}``); None without the file."""
        if self.lerobot is not None:
            return self.lerobot.stats
        path = self.root / STATS_FILE
        if not path.is_file():
            return None
        from lerobot.datasets.io_utils import cast_stats_to_numpy  # heavy: only a policy fit asks

        return cast_stats_to_numpy(read_json_object(path))


@dataclass(frozen=True)
class EpisodeColumns:
    """Columns of chosen episodes of a dataset.

    columns: ``{name: array}`` of the requested columns the dataset has (the others are left out:
    ``features`` says what it holds), rows of every chosen episode in file order. features: LeRobot's
    feature dict; fps: frames per second; tasks: the distinct task strings of the chosen episodes,
    sorted; root: the dataset folder.
    """

    columns: dict[str, np.ndarray]
    features: dict[str, dict[str, Any]]
    fps: float
    tasks: list[str]
    root: Path


# ---- metadata -------------------------------------------------------------------------------------------


def read_meta(root: str | Path, *, repo_id: str | None = None, name: str | None = None) -> DatasetMeta:
    """The metadata of the dataset folder ``root``: ``meta/info.json``, ``meta/episodes/*.parquet`` and
    ``meta/tasks.parquet``, each read once. ``repo_id`` defaults to ``local/<folder name>``; ``name``:
    the argument the folder came from, for the error when it holds no dataset (``--dataset``)."""
    root = require_dataset_root(root, name)
    info_path = root / INFO_FILE
    info = read_json_object(info_path)
    where = partial(_info_field, info, info_path)
    where("fps", partial(check_real, low=0, low_open=True))  # kept as stored (LeRobot writes an int)
    features = _features(where("features", check_dict), info_path)
    total = where("total_episodes", partial(check_int, low=0))
    # as LeRobot: tasks.parquet is read when info.json counts tasks
    total_tasks = check_int(f"{info_path} 'total_tasks'", info.get("total_tasks", 0), low=0)
    data_path = check_str(f"{info_path} 'data_path'", info.get("data_path", DEFAULT_DATA_PATH))
    episodes = _read_episode_table(root, data_path, total) if total else ()
    tasks = _read_tasks(root / TASKS_FILE) if total_tasks else ()
    return DatasetMeta(root, repo_id or f"local/{root.name}", info["fps"], features, episodes, tasks)


def _info_field(info: dict, path: Path, key: str, rule: Any) -> Any:
    """``info[key]`` checked by ``rule``, named ``"<path> 'key'"``; a missing key is said to be missing."""
    if key not in info:
        fail(str(path), f"have a {key!r} field (a LeRobot v3 meta/info.json)")
    return rule(f"{path} {key!r}", info[key])


def _features(features: dict, path: Path) -> dict[str, dict[str, Any]]:
    """``meta/info.json``'s features with tuple shapes, each checked to have a dtype and a shape."""
    out = {}
    for key, ft in features.items():
        name = f"{path} 'features'[{key!r}]"
        ft = check_dict(name, ft)
        check_str(f"{name}['dtype']", ft.get("dtype"), empty_ok=False)
        shape = check_int_list(f"{name}['shape']", ft.get("shape"), low=0)
        out[key] = {**ft, "shape": tuple(shape)}
    return out


def _read_episode_table(root: Path, data_path: str, total: int) -> tuple[EpisodeInfo, ...]:
    """``meta/episodes/*/*.parquet`` as one :class:`EpisodeInfo` per episode, episode ``e`` at ``e``."""
    import pyarrow as pa

    folder = root / EPISODES_DIR
    files = sorted(folder.glob("*/*.parquet"))
    if not files:
        fail(str(folder), f"hold the episode index (chunk-*/file-*.parquet) of the {total} episode(s)")
    table = pa.concat_tables([read_table(p, _EPISODE_COLUMNS) for p in files])
    return _episode_infos(table.to_pylist(), data_path, total, str(folder))


def _episode_infos(
    rows: list[dict[str, Any]], template: str, total: int, where: str
) -> tuple[EpisodeInfo, ...]:
    """Rows of ``meta/episodes`` as :class:`EpisodeInfo`, checked to list episodes 0..total-1 in order."""
    found = [int(r["episode_index"]) for r in rows]
    if found != list(range(total)):
        fail(where, f"list episodes 0..{total - 1} in order, as meta/info.json's total_episodes says", found)
    return tuple(
        EpisodeInfo(
            index=int(r["episode_index"]),
            length=int(r["length"]),
            start=int(r["dataset_from_index"]),
            stop=int(r["dataset_to_index"]),
            data_file=template.format(chunk_index=r["data/chunk_index"], file_index=r["data/file_index"]),
            tasks=tuple(r["tasks"] or ()),
        )
        for r in rows
    )


def _read_tasks(path: Path) -> tuple[str, ...]:
    """``meta/tasks.parquet`` as the task strings ordered by ``task_index``."""
    table = read_table(path, ["task_index", "task"])
    order = np.argsort(table.column("task_index").to_numpy(), kind="stable")
    return tuple(str(t) for t in np.asarray(table.column("task").to_pylist(), dtype=object)[order])


def to_meta(dataset: Any, *, name: str | None = None) -> DatasetMeta:
    """``dataset`` as a :class:`DatasetMeta`: one as it is, a folder read by :func:`read_meta`, or a
    ``LeRobotDatasetMetadata`` (or a ``LeRobotDataset``'s) taken over without reading its files again."""
    if isinstance(dataset, DatasetMeta):
        return dataset
    if isinstance(dataset, str | os.PathLike):
        return read_meta(dataset, name=name)
    if hasattr(dataset, "hf_dataset"):  # a LeRobotDataset
        dataset = dataset.meta
    return _from_lerobot(dataset)


def _from_lerobot(meta: Any) -> DatasetMeta:
    """A ``LeRobotDatasetMetadata``'s info, episodes (an HF dataset) and tasks (a DataFrame) as ours."""
    total = int(meta.total_episodes)
    episodes: tuple[EpisodeInfo, ...] = ()
    if total:
        rows = meta.episodes.with_format("arrow")[:].select(_EPISODE_COLUMNS).to_pylist()
        episodes = _episode_infos(
            rows, meta.info.data_path or DEFAULT_DATA_PATH, total, f"{meta.root}/{EPISODES_DIR}"
        )
    tasks: tuple[str, ...] = ()
    if meta.tasks is not None:
        order = np.argsort(meta.tasks["task_index"].to_numpy(), kind="stable")
        tasks = tuple(str(t) for t in np.asarray(meta.tasks.index, dtype=object)[order])
    features = {k: {**ft, "shape": tuple(ft["shape"])} for k, ft in meta.features.items()}
    return DatasetMeta(Path(meta.root), str(meta.repo_id), meta.fps, features, episodes, tasks, meta)


# ---- parquet files --------------------------------------------------------------------------------------


def read_table(path: str | Path, columns: Sequence[str] | None = None):
    """A parquet file as a ``pyarrow.Table`` (the named ``columns``, or all); ``ValueError`` naming the
    file when it is missing, unreadable, or lacks one of the columns."""
    pf = _parquet_file(Path(path))
    if columns is not None:
        _require_columns(pf, path, columns)
    return pf.read(columns=None if columns is None else list(columns))


def _parquet_file(path: Path):
    import pyarrow as pa
    import pyarrow.parquet as pq

    if not path.is_file():
        fail(str(path), "exist (a file of the dataset is missing)")
    try:
        return pq.ParquetFile(path)
    except (OSError, pa.ArrowException) as err:
        raise ValueError(f"{path}: not a readable parquet file ({err})") from None


def _require_columns(pf: Any, path: str | Path, columns: Iterable[str]) -> None:
    missing = [c for c in columns if c not in pf.schema_arrow.names]
    if missing:
        fail(str(path), f"hold the column(s) {missing} (found {pf.schema_arrow.names})")


def data_files(meta: DatasetMeta) -> list[Path]:
    """The data files the episodes live in, sorted by path (as LeRobot reads them)."""
    return [meta.root / f for f in sorted({ep.data_file for ep in meta.episodes})]


def check_data_files(meta: DatasetMeta) -> None:
    """Every data file holds exactly the columns ``meta/info.json`` lists (videos live elsewhere),
    with its per-frame sizes; else a ``ValueError`` naming the file and the features. Run before
    rewriting the files, which keeps every column as it is."""
    import pyarrow as pa

    in_data = {k: ft for k, ft in meta.features.items() if ft["dtype"] != "video"}
    for path in data_files(meta):
        schema = _parquet_file(path).schema_arrow
        missing = sorted(set(in_data) - set(schema.names))
        extra = sorted(set(schema.names) - set(in_data))
        if missing or extra:
            differ = [
                f"{what} {names}"
                for what, names in (
                    ("in meta/info.json but not in the file:", missing),
                    ("in the file but not in meta/info.json:", extra),
                )
                if names
            ]
            raise ValueError(f"{path}: columns and meta/info.json features differ: " + "; ".join(differ))
        for key, ft in in_data.items():
            kind = schema.field(key).type
            if pa.types.is_fixed_size_list(kind) and len(ft["shape"]) == 1:
                _check_width(path, key, kind.list_size, ft["shape"])


def _check_width(path: Path, key: str, width: int, shape: tuple[int, ...]) -> None:
    if width != int(np.prod(shape)):
        raise ValueError(
            f"{path}: feature {key!r} holds {width} values per frame, meta/info.json says shape {list(shape)}"
        )


# ---- columns of episodes --------------------------------------------------------------------------------


def read_columns(
    dataset: Any, episodes: Sequence[int], columns: Iterable[str], *, name: str = "episodes"
) -> dict[str, np.ndarray]:
    """The ``columns`` (those the dataset has; videos excluded) of the chosen ``episodes`` (indices,
    each once) of ``dataset`` (see :func:`to_meta`); shapes and row order in the module docstring.
    ``name``: what the episodes are called in errors (the setting that chose them)."""
    meta = to_meta(dataset)
    return _read_chosen(meta, _chosen_episodes(meta, episodes, name, non_empty=False), columns)


def _read_chosen(meta: DatasetMeta, chosen: list[int], columns: Iterable[str]) -> dict[str, np.ndarray]:
    keys = [k for k in dict.fromkeys(columns) if k in meta.features and meta.features[k]["dtype"] != "video"]
    by_file: dict[str, list[int]] = {}
    for e in chosen:
        by_file.setdefault(meta.episodes[e].data_file, []).append(e)
    parts = [_read_file_rows(meta, f, by_file[f], keys) for f in sorted(by_file)]
    if not parts:
        return {k: _empty(meta.features[k]) for k in keys}
    return {k: np.concatenate([p[k] for p in parts]) for k in keys}


def _chosen_episodes(meta: DatasetMeta, episodes: Sequence[int], name: str, *, non_empty: bool) -> list[int]:
    """``episodes`` as a list of distinct episode indices the dataset has, else a ValueError naming them."""
    chosen = check_int_list(name, episodes, low=0, non_empty=non_empty)
    repeated = sorted({e for e in chosen if chosen.count(e) > 1})
    if repeated:
        raise ValueError(f"{name}: episode(s) {repeated} given more than once")
    missing = [e for e in chosen if e >= meta.total_episodes]
    if missing:
        have = f"episodes 0..{meta.total_episodes - 1}" if meta.total_episodes else "no episodes"
        raise ValueError(f"{name}: episode(s) {missing} not in the dataset {meta.root} (it has {have})")
    return chosen


def _read_file_rows(
    meta: DatasetMeta, file: str, episodes: list[int], keys: list[str]
) -> dict[str, np.ndarray]:
    """The ``keys`` columns of ``episodes``' rows in one data file (only the row groups holding them)."""
    path = meta.root / file
    pf = _parquet_file(path)
    _require_columns(pf, path, ["episode_index", *keys])
    episode_column = pf.read(columns=["episode_index"]).column(0).to_numpy()
    rows = np.flatnonzero(np.isin(episode_column, episodes))
    counts = np.bincount(episode_column[rows], minlength=max(episodes) + 1)
    for e in episodes:
        if counts[e] != meta.episodes[e].length:
            fail(
                str(path),
                f"hold the {meta.episodes[e].length} rows meta/episodes gives episode {e}",
                int(counts[e]),
            )
    table = _take_rows(pf, rows, keys)
    return {k: _to_numpy(table.column(k), meta.features[k], path, k) for k in keys}


def _take_rows(pf: Any, rows: np.ndarray, keys: list[str]):
    """Rows ``rows`` (sorted file positions) of the ``keys`` columns, reading only their row groups."""
    md = pf.metadata
    sizes = np.array([md.row_group(i).num_rows for i in range(md.num_row_groups)], dtype=np.int64)
    ends = np.cumsum(sizes)
    group_of_row = np.searchsorted(ends, rows, side="right")
    groups = np.unique(group_of_row)
    table = pf.read_row_groups(groups.tolist(), columns=keys)
    if len(rows) == table.num_rows:  # every row of the groups read
        return table
    group_start_in_table = np.cumsum(sizes[groups]) - sizes[groups]
    local = rows - (ends - sizes)[group_of_row] + group_start_in_table[np.searchsorted(groups, group_of_row)]
    return table.take(local)


def _to_numpy(column: Any, feature: dict[str, Any], path: Path, key: str) -> np.ndarray:
    """One column as a NumPy array of the feature's dtype, ``(rows,)`` or ``(rows, *shape)``."""
    import pyarrow as pa

    rows = len(column)
    if feature["dtype"] in _NOT_NUMERIC:
        out = np.empty(rows, dtype=object)
        out[:] = column.to_pylist()
        return out
    array = column.combine_chunks()
    while True:
        if array.null_count:
            fail(f"{path} column {key!r}", "hold no missing (null) values", f"{array.null_count} nulls")
        if not (pa.types.is_list(array.type) or pa.types.is_fixed_size_list(array.type)
                or pa.types.is_large_list(array.type)):  # fmt: skip
            break
        array = array.flatten()
    values = array.to_numpy(zero_copy_only=False)
    shape = feature["shape"]
    if rows and len(values) != rows * int(np.prod(shape)):
        _check_width(path, key, len(values) // rows, shape)
    values = values.astype(feature["dtype"], copy=False)
    return values.reshape(rows) if shape == (1,) else values.reshape(rows, *shape)


def _empty(feature: dict[str, Any]) -> np.ndarray:
    if feature["dtype"] in _NOT_NUMERIC:
        return np.empty(0, dtype=object)
    shape = feature["shape"]
    return np.empty((0,) if shape == (1,) else (0, *shape), dtype=feature["dtype"])


def read_episodes(
    dataset: Any, episodes: Sequence[int], columns: Iterable[str], *, name: str = "episodes"
) -> EpisodeColumns:
    """:func:`read_columns` of ``episodes`` (at least one) with the dataset's fps and features and the
    task strings of those episodes."""
    meta = to_meta(dataset)
    chosen = _chosen_episodes(meta, episodes, name, non_empty=True)
    data = _read_chosen(meta, chosen, columns)
    tasks = sorted({t for e in chosen for t in meta.episodes[e].tasks})
    return EpisodeColumns(data, meta.features, float(meta.fps), tasks, meta.root)


# ---- LeRobot's own dataset object --------------------------------------------------------------------------


def lerobot_dataset(dataset: Any, *, repo_id: str | None = None, episodes: Sequence[int] | None = None):
    """A ``LeRobotDataset`` of the dataset folder, for what only LeRobot does (decoding camera frames,
    pushing to the Hub, ``dataset_tools`` edits). The metadata and data files are checked first, so a
    missing file is named here rather than looked for on the Hub."""
    meta = to_meta(dataset)
    for path in data_files(meta):
        _parquet_file(path)
    from lerobot.datasets.lerobot_dataset import LeRobotDataset  # heavy import

    return LeRobotDataset(repo_id or meta.repo_id, root=meta.root, episodes=episodes)
