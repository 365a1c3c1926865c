"""Segment a LeRobot dataset's episodes and write the segments back into it (``forcemap segment``).

Streams per episode (those the dataset has): ``joints`` (observation.state without its last entry),
``position`` (observation.ee_pose x y z), ``wrist_force`` (observation.force fx fy fz), ``gripper``
(observation.state's last entry) and ``finger_force`` (observation.finger_force), all on the
episode's LeRobot ``timestamp``; with a ``contact`` column (``forcemap convert``, ``forcemap record``)
also the ``touch_down`` and ``lift_off`` event streams at its contact edges. They go to
:func:`lerobot_forcemap.segmentation.segment_streams`, by default with the settings in seconds of
``segmentation.DEFAULT_TIMING`` at the dataset's fps (the forcemap policy's defaults).

Write-back (the layout of LeRobot 0.6.1's ``datasets/language.py`` and ``feature_utils.py``):

- a per-frame int64 column ``segment_index`` (``layout.SEGMENT_INDEX``) — what the forcemap policy
  reads; segment k is frames ``[changepoints[k], changepoints[k+1])``;
- LeRobot subtasks: one ``language_persistent`` row per segment (style ``motion`` by default, or
  ``subtask``; ``timestamp`` = the segment's first frame time, content ``"segment k of K"``), the
  per-episode list broadcast to every frame, with an empty ``language_events`` column beside it —
  the same layout ``lerobot-annotate`` writes. ``LeRobotDataset`` reads both back; the resolver
  ``lerobot.datasets.language_render.active_at(t, persistent=..., style=...)`` gives the active
  segment at time ``t``. Rows of ``style`` are replaced; rows of other styles are kept, so two
  segmentations can live side by side as two styles (``segment_index`` holds the last one written).

``meta/info.json`` gains the three features, ``meta/stats.json`` and the episodes' stats gain
``segment_index``. ``subtasks=False`` (``--no-subtasks``) writes ``segment_index`` only and leaves any
language columns as they are: LeRobot 0.6.1's ``lerobot-dataset-viz`` batches frames with PyTorch's
default collate, which stops at the ``None`` fields every language row has (``camera``, ``tool_calls``;
``lerobot-annotate``'s rows too), so it cannot open a dataset with subtasks (``forcemap viz`` can).
Either way, an earlier run's "segment k of K" rows that are kept but no longer match the new
``segment_index`` are named in a warning.
Episodes not segmented in this call keep their labels (or get one segment, 0, when the column is new:
said in a warning). Every episode's labels are checked against the data files before anything is
written; the new dataset is then written to a copy beside it (``data.staging.edit_dir``), which replaces
it only when complete: a failure part way leaves the dataset exactly as it was.
"""

from __future__ import annotations

import json
import re
import warnings
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from tqdm.auto import tqdm

from lerobot_forcemap import layout
from lerobot_forcemap._validation import check_choice
from lerobot_forcemap.contact import mask_to_intervals
from lerobot_forcemap.data.reader import (
    EPISODES_DIR,
    STATS_FILE,
    DatasetMeta,
    check_data_files,
    read_columns,
    read_meta,
    read_table,
    to_meta,
)
from lerobot_forcemap.data.schema import SEGMENT_INDEX_FEATURE, refresh_dataset_card
from lerobot_forcemap.data.staging import edit_dir
from lerobot_forcemap.jsonfile import read_json_object
from lerobot_forcemap.segmentation import (
    DEFAULT_TIMING,
    EVENT_STREAM_WEIGHT,
    EVENT_STREAMS,
    SIGNAL_STREAM_THRESHOLDS,
    EventStream,
    SegmentationConfig,
    SegmentationResult,
    Stream,
    contact_event_streams,
    segment_streams,
)

__all__ = [
    "STREAM_THRESHOLDS",
    "SUBTASK_STYLES",
    "EpisodeSegments",
    "stream_columns",
    "episode_streams",
    "segment_dataset",
    "write_segments",
    "read_segment_index",
    "read_subtasks",
]

#: the original authors' UR5e thresholds (one definition, ``segmentation.SIGNAL_STREAM_THRESHOLDS``)
STREAM_THRESHOLDS: dict[str, float] = SIGNAL_STREAM_THRESHOLDS
SUBTASK_STYLES = ("motion", "subtask")
_ROLE = "assistant"
_OUR_CONTENT = re.compile(r"segment \d+ of \d+")


@dataclass(frozen=True)
class EpisodeSegments:
    """Segments of one episode: changepoints (K+1,) frame indices (first 0, last T), labels (T,) int64."""

    episode_index: int
    changepoints: np.ndarray
    labels: np.ndarray
    result: SegmentationResult | None = None

    @property
    def n_segments(self) -> int:
        return int(len(self.changepoints) - 1)


def stream_columns(features: Mapping[str, Mapping[str, Any]]) -> dict[str, tuple[str, slice]]:
    """``{stream name: (feature key, column slice)}`` for the streams this dataset's features allow."""
    out: dict[str, tuple[str, slice]] = {}
    if layout.OBS_STATE in features:
        n = int(features[layout.OBS_STATE]["shape"][0])
        names = features[layout.OBS_STATE].get("names") or []
        has_gripper = bool(names) and names[-1] == layout.GRIPPER_STATE_NAME
        out["joints"] = (layout.OBS_STATE, slice(0, n - 1 if has_gripper else n))
        if has_gripper:
            out["gripper"] = (layout.OBS_STATE, slice(n - 1, n))
    if layout.OBS_EE_POSE in features:
        out["position"] = (layout.OBS_EE_POSE, layout.EE_POS)
    if layout.OBS_FORCE in features:
        out["wrist_force"] = (layout.OBS_FORCE, layout.FORCE_LINEAR)
    if layout.OBS_FINGER_FORCE in features:
        out["finger_force"] = (layout.OBS_FINGER_FORCE, slice(None))
    return out


def stream_names(features: Mapping[str, Mapping[str, Any]]) -> tuple[list[str], list[str]]:
    """The signal streams (:func:`stream_columns`) and the event streams (``touch_down``, ``lift_off``:
    with a ``contact`` column) this dataset's features allow."""
    return list(stream_columns(features)), list(EVENT_STREAMS) if layout.CONTACT in features else []


def episode_streams(
    columns: Mapping[str, np.ndarray],
    times: np.ndarray,
    features: Mapping[str, Mapping[str, Any]],
    *,
    weights: Mapping[str, float] | None = None,
    thresholds: Mapping[str, float] | None = None,
) -> list[Stream | EventStream]:
    """Segmentation streams of one episode. ``columns``: ``{feature key: (T, dim)}``, ``times`` (T,) s.

    Weights default to 1 for every available signal stream and ``EVENT_STREAM_WEIGHT`` for the event
    streams; ``weights`` overrides by stream name (an unknown name raises ``ValueError`` listing the
    available ones). Thresholds (signal streams only) default to ``STREAM_THRESHOLDS``.
    """
    available = stream_columns(features)
    signals, events = stream_names(features)
    for what, given, known in (("weight", weights, signals + events), ("threshold", thresholds, signals)):
        unknown = sorted(set(given or {}) - set(known))
        if unknown:
            raise ValueError(f"{what} for unknown stream(s) {unknown}; this dataset has {sorted(known)}")
    streams: list[Stream | EventStream] = []
    for name, (key, cols) in available.items():
        values = np.asarray(columns[key], dtype=np.float64)
        values = values.reshape(len(values), -1)[:, cols]
        streams.append(
            Stream(
                name,
                values,
                times,
                weight=float((weights or {}).get(name, 1.0)),
                threshold=float((thresholds or {}).get(name, STREAM_THRESHOLDS[name])),
            )
        )
    if events:
        contact = np.asarray(columns[layout.CONTACT]).reshape(len(times), -1)[:, 0] > 0
        chosen = {name: float(w) for name, w in (weights or {}).items() if name in events}
        streams += contact_event_streams(times, mask_to_intervals(times, contact), weights=chosen)
    return streams


def _check_stream_settings(
    signals: Sequence[str],
    events: Sequence[str],
    weights: Mapping[str, float] | None,
    thresholds: Mapping[str, float] | None,
) -> None:
    """Stream names and values of ``--weights`` / ``--thresholds``, checked once (a bad value is the
    flag's fault, not the first episode's); event streams take a weight, no threshold."""
    available = [*signals, *events]
    for flag, given, known in (("--weights", weights, available), ("--thresholds", thresholds, signals)):
        unknown = sorted(set(given or {}) - set(known))
        if unknown:
            raise ValueError(f"{flag}: unknown stream(s) {unknown}; this dataset has {sorted(known)}")
    for flag, given, field in (("--weights", weights, "weight"), ("--thresholds", thresholds, "threshold")):
        for name, value in (given or {}).items():
            try:  # Stream's own checks (weight finite >= 0 and not huge, threshold in (0, 1])
                Stream(name, np.zeros(2), np.arange(2.0), **{field: value})
            except ValueError as err:
                raise ValueError(f"{flag}: {err}") from None
    default = {**dict.fromkeys(signals, 1.0), **dict.fromkeys(events, EVENT_STREAM_WEIGHT)}
    if not any((weights or {}).get(name, default[name]) > 0 for name in available):
        raise ValueError(
            f"--weights: every stream has weight 0 ({sorted(available)}); one needs a weight > 0"
        )


def _stream_keys(
    meta: DatasetMeta, weights: Mapping[str, float] | None, thresholds: Mapping[str, float] | None
) -> list[str]:
    """The features the dataset's streams come from, after checking the stream settings against them;
    a dataset without force is segmented with a warning."""
    available = stream_columns(meta.features)
    if not available:
        raise ValueError(
            f"{meta.root}: no feature to segment on (need {layout.OBS_STATE}, {layout.OBS_FORCE}, ...)"
        )
    signals, events = stream_names(meta.features)
    _check_stream_settings(signals, events, weights, thresholds)
    if not {layout.OBS_FORCE, layout.OBS_FINGER_FORCE} & set(meta.features):
        warnings.warn(
            f"{meta.root}: no force feature ({layout.OBS_FORCE} or {layout.OBS_FINGER_FORCE}); segmenting on "
            f"{', '.join(sorted(available))} only",
            stacklevel=3,
        )
    return sorted({key for key, _ in available.values()} | ({layout.CONTACT} if events else set()))


def segment_dataset(
    root: str | Path,
    *,
    weights: Mapping[str, float] | None = None,
    thresholds: Mapping[str, float] | None = None,
    config: SegmentationConfig | None = None,
    episodes: Sequence[int] | None = None,
    style: str = "motion",
    subtasks: bool = True,
    repo_id: str = "local/forcemap",
    write: bool = True,
    progress: bool = True,
) -> list[EpisodeSegments]:
    """Segment the episodes (all, or ``episodes``) of the dataset at ``root``; write them back if ``write``
    (``segment_index``, plus LeRobot subtasks of ``style`` if ``subtasks``). ``repo_id``: the id the
    dataset goes by; ``config``: None takes ``segmentation.DEFAULT_TIMING`` at the dataset's fps."""
    meta = read_meta(root, repo_id=repo_id, name="--dataset")
    check_choice("style", style, SUBTASK_STYLES)
    if config is None:
        config = DEFAULT_TIMING.config(float(meta.fps))
    keys = _stream_keys(meta, weights, thresholds)
    chosen = list(range(meta.total_episodes)) if episodes is None else list(episodes)
    columns = read_columns(meta, chosen, [*keys, "timestamp", "episode_index"], name="--episodes")
    episode_column = columns["episode_index"]
    times = np.asarray(columns["timestamp"], dtype=np.float64)
    out = []
    for e in tqdm(chosen, desc="segment", unit="episode", disable=not progress):
        rows = np.flatnonzero(episode_column == e)
        streams = {key: columns[key][rows] for key in keys}
        out.append(_segment_episode(e, streams, times[rows], meta.features, weights, thresholds, config))
    if write:
        write_segments(meta, out, style=style, subtasks=subtasks)
    return out


def _segment_episode(
    episode: int,
    columns: Mapping[str, np.ndarray],
    times: np.ndarray,
    features: Mapping[str, Mapping[str, Any]],
    weights: Mapping[str, float] | None,
    thresholds: Mapping[str, float] | None,
    config: SegmentationConfig | None,
) -> EpisodeSegments:
    """One episode's segments; its errors and warnings name the episode."""
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            streams = episode_streams(columns, times, features, weights=weights, thresholds=thresholds)
            result = segment_streams(streams, config)
    except ValueError as err:
        raise ValueError(f"episode {episode}: {err}") from err
    for w in caught:  # e.g. repeated timestamps: which of 60 episodes is it?
        warnings.warn(f"episode {episode}: {w.message}", w.category, stacklevel=3)
    return EpisodeSegments(episode, np.asarray(result.changepoints, dtype=np.int64), result.labels(), result)


# ---- write-back -----------------------------------------------------------------------------------------


def write_segments(
    dataset: str | Path | DatasetMeta,
    segments: Sequence[EpisodeSegments] | Mapping[int, np.ndarray],
    *,
    style: str = "motion",
    fps: int | None = None,
    subtasks: bool = True,
) -> None:
    """Write per-frame labels (``{episode: labels (T,)}`` or :class:`EpisodeSegments`) into the dataset
    (a folder, or its :class:`~lerobot_forcemap.data.reader.DatasetMeta`), and, if ``subtasks``, one
    LeRobot subtask row of ``style`` per segment; ``fps`` (default the dataset's) times the rows.

    Labels must be non-decreasing integers starting at 0 with steps of 1 (segment k follows k-1);
    otherwise ``ValueError`` names the episode and the frame. Everything is checked before anything is
    written, and the dataset is replaced only once the new one is complete.
    """
    meta = to_meta(dataset)
    check_choice("style", style, SUBTASK_STYLES)
    labels_by_ep = _labels_by_episode(segments)
    check_data_files(meta)  # the rewrite keeps every column: one info.json does not list would stay so
    _check_labels_fit(meta, labels_by_ep)
    fps = int(fps or meta.fps)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with edit_dir(meta.root) as work:
            stale = _rewrite_data_files(meta, work, labels_by_ep, style=style, fps=fps, subtasks=subtasks)
            _write_info(work, subtasks)
            _write_segment_stats(work)
            refresh_dataset_card(work)  # the card's feature table gains the new columns
    for w in caught:  # said of the dataset, not of its copy being written
        warnings.warn(str(w.message).replace(str(work), str(meta.root)), w.category, stacklevel=2)
    if stale:
        warnings.warn(
            f"{meta.root}: episode(s) {sorted(stale)} keep subtask rows of an earlier `forcemap segment` "
            f"(other style, or --no-subtasks) that no longer match the new {layout.SEGMENT_INDEX}; rerun with "
            "that --style to update them",
            stacklevel=2,
        )


def _labels_by_episode(
    segments: Sequence[EpisodeSegments] | Mapping[int, np.ndarray],
) -> dict[int, np.ndarray]:
    """``{episode: labels (T,) int64}``, each starting at 0 and stepping by 0 or 1."""
    if isinstance(segments, Mapping):
        labels_by_ep = {int(e): np.asarray(v, dtype=np.int64) for e, v in segments.items()}
    else:
        labels_by_ep = {s.episode_index: s.labels for s in segments}
    for e, lab in labels_by_ep.items():
        if lab.ndim != 1 or len(lab) == 0:
            raise ValueError(f"episode {e}: labels must be a non-empty (T,) array, got shape {lab.shape}")
        steps = np.diff(lab)
        if lab[0] != 0 or np.any((steps != 0) & (steps != 1)):
            i = 0 if lab[0] != 0 else int(np.argmax((steps != 0) & (steps != 1))) + 1
            raise ValueError(
                f"episode {e}, frame {i}: segment labels must start at 0 and step by 1, got {lab[i]}"
            )
    return labels_by_ep


def _check_labels_fit(meta: DatasetMeta, labels_by_ep: Mapping[int, np.ndarray]) -> None:
    """One label per frame of each labelled episode, counted in the data files; said when the column
    is new and episodes not labelled now get one segment."""
    frames: dict[int, int] = {}
    for path in sorted({meta.root / ep.data_file for ep in meta.episodes}):
        episode = read_table(path, ["episode_index"]).column(0).to_numpy()
        for e, n in zip(*np.unique(episode, return_counts=True), strict=True):
            frames[int(e)] = frames.get(int(e), 0) + int(n)
    missing = sorted(set(labels_by_ep) - set(frames))
    if missing:
        raise ValueError(f"{meta.root}: episode(s) {missing} not found in the data files")
    for e, lab in labels_by_ep.items():
        if len(lab) != frames[e]:
            raise ValueError(f"episode {e}: {len(lab)} labels for {frames[e]} frames")
    unlabelled = sorted(set(frames) - set(labels_by_ep))
    if layout.SEGMENT_INDEX not in meta.features and unlabelled:
        warnings.warn(
            f"{meta.root}: {layout.SEGMENT_INDEX} is new; episode(s) {unlabelled}, not segmented in this call, "
            "get one segment (0)",
            stacklevel=3,
        )


def _rewrite_data_files(
    meta: DatasetMeta,
    work: Path,
    labels_by_ep: Mapping[int, np.ndarray],
    *,
    style: str,
    fps: int,
    subtasks: bool,
) -> set[int]:
    """Each data file of ``meta`` with the new labels (and rows), written to the same place in ``work``;
    returns the episodes whose kept subtask rows of another run now disagree with the labels."""
    from lerobot.datasets.io_utils import write_table_one_row_group_per_episode

    stale: set[int] = set()
    for file in sorted({ep.data_file for ep in meta.episodes}):
        table, file_stale = _relabel_table(read_table(meta.root / file), labels_by_ep, style, fps, subtasks)
        write_table_one_row_group_per_episode(table, work / file)
        stale |= file_stale
    return stale


def _relabel_table(
    table: Any, labels_by_ep: Mapping[int, np.ndarray], style: str, fps: int, subtasks: bool
) -> tuple[Any, set[int]]:
    """One data file's table with ``segment_index`` set for the labelled episodes and, with
    ``subtasks``, their ``style`` rows replaced; plus the episodes with stale rows of another run."""
    from lerobot.datasets.language import LANGUAGE_PERSISTENT

    ep = table.column("episode_index").to_numpy()
    frame = table.column("frame_index").to_numpy()
    if layout.SEGMENT_INDEX in table.column_names:
        seg_col = table.column(layout.SEGMENT_INDEX).to_numpy().astype(np.int64)
    else:
        seg_col = np.zeros(len(ep), dtype=np.int64)
    has_language = LANGUAGE_PERSISTENT in table.column_names
    persistent = table.column(LANGUAGE_PERSISTENT).to_pylist() if has_language else [[] for _ in ep]
    episode_rows: dict[int, list[dict]] = {}
    stale: set[int] = set()
    for e in (int(e) for e in np.unique(ep) if int(e) in labels_by_ep):
        rows = np.flatnonzero(ep == e)
        lab = labels_by_ep[e]
        seg_col[rows] = lab[frame[rows]]
        if not (subtasks or has_language):
            continue
        kept = [r for r in (persistent[rows[0]] or []) if not (subtasks and r.get("style") == style)]
        if _disagree(kept, lab, fps):
            stale.add(e)
        if subtasks:
            episode_rows[e] = _with_segment_rows(kept, lab, style, fps)
    return _assemble_table(table, ep, seg_col, persistent, episode_rows, subtasks), stale


def _with_segment_rows(kept: list[dict], labels: np.ndarray, style: str, fps: int) -> list[dict]:
    """``kept`` rows plus one "segment k of K" row of ``style`` per segment, sorted by time."""
    starts = _starts(labels)
    ours = [
        {
            "role": _ROLE,
            "content": f"segment {k} of {len(starts)}",
            "style": style,
            "timestamp": float(np.float32(start / fps)),
            "camera": None,
            "tool_calls": None,
        }
        for k, start in enumerate(starts)
    ]
    return sorted(kept + ours, key=lambda r: (float(r["timestamp"]), r.get("style") or ""))


def _assemble_table(
    table: Any,
    ep: np.ndarray,
    seg_col: np.ndarray,
    persistent: list[list[dict]],
    episode_rows: Mapping[int, list[dict]],
    subtasks: bool,
) -> Any:
    """The other columns as they were, then ``segment_index`` and the language columns (new with
    ``subtasks``, else as they were or absent)."""
    import pyarrow as pa
    from lerobot.datasets.language import LANGUAGE_EVENTS, LANGUAGE_PERSISTENT

    language = [n for n in (LANGUAGE_PERSISTENT, LANGUAGE_EVENTS) if subtasks or n in table.column_names]
    keep = [n for n in table.column_names if n not in (layout.SEGMENT_INDEX, *language)]
    columns = [table.column(n) for n in keep] + [pa.array(seg_col)]
    if subtasks:
        new_persistent = [episode_rows.get(int(e), persistent[i] or []) for i, e in enumerate(ep)]
        events = (
            table.column(LANGUAGE_EVENTS)
            if LANGUAGE_EVENTS in table.column_names
            else pa.array([[] for _ in range(len(ep))], type=pa.list_(_event_row_type()))
        )
        columns += [_persistent_array(new_persistent), events]
    else:
        columns += [table.column(n) for n in language]
    return pa.Table.from_arrays(columns, names=[*keep, layout.SEGMENT_INDEX, *language])


def _write_info(root: Path, subtasks: bool) -> None:
    """``meta/info.json`` with ``segment_index`` (and, with ``subtasks``, the language columns)."""
    from lerobot.datasets.io_utils import load_info, write_info
    from lerobot.datasets.language import language_feature_info

    info = load_info(root)
    info.features = {
        **info.features,
        layout.SEGMENT_INDEX: dict(SEGMENT_INDEX_FEATURE),
        **(language_feature_info() if subtasks else {}),
    }
    write_info(info, root)


def _starts(labels: np.ndarray) -> np.ndarray:
    """First frame of each segment of per-frame labels."""
    return np.flatnonzero(np.concatenate([[True], np.diff(labels) != 0]))


def _disagree(rows: Sequence[Mapping[str, Any]], labels: np.ndarray, fps: int) -> bool:
    """Whether the "segment k of K" rows of some style, written by an earlier ``forcemap segment``,
    start segments at other times than ``labels`` do (rows of other writers are not judged)."""
    starts = [float(np.float32(f / fps)) for f in _starts(labels)]
    for style in SUBTASK_STYLES:
        ours = [r for r in rows if r.get("style") == style and _OUR_CONTENT.fullmatch(str(r.get("content")))]
        if ours and sorted(float(r["timestamp"]) for r in ours) != starts:
            return True
    return False


def _event_row_type():
    import pyarrow as pa

    return pa.struct(
        [
            ("role", pa.string()),
            ("content", pa.string()),
            ("style", pa.string()),
            ("camera", pa.string()),
            ("tool_calls", pa.list_(pa.string())),
        ]
    )


def _persistent_array(rows: list[list[dict]]):
    import pyarrow as pa

    row_type = pa.struct(
        [
            ("role", pa.string()),
            ("content", pa.string()),
            ("style", pa.string()),
            ("timestamp", pa.float32()),
            ("camera", pa.string()),
            ("tool_calls", pa.list_(pa.string())),
        ]
    )
    return pa.array(rows, type=pa.list_(row_type))


def _write_segment_stats(root: Path) -> None:
    """Per-episode stats (meta/episodes) and dataset stats (meta/stats.json) of ``segment_index``, of the
    dataset at ``root`` whose data files and info.json already hold it."""
    from lerobot.datasets.compute_stats import aggregate_stats, compute_episode_stats

    meta = read_meta(root)
    feature = {layout.SEGMENT_INDEX: dict(SEGMENT_INDEX_FEATURE)}
    every = list(range(meta.total_episodes))
    columns = read_columns(meta, every, ["episode_index", layout.SEGMENT_INDEX])
    ep, seg = columns["episode_index"], columns[layout.SEGMENT_INDEX]
    per_ep = {e: compute_episode_stats({layout.SEGMENT_INDEX: seg[ep == e]}, feature) for e in every}
    for path in sorted((root / EPISODES_DIR).glob("*/*.parquet")):
        df = read_table(path).to_pandas()
        stats = [per_ep[int(e)][layout.SEGMENT_INDEX] for e in df["episode_index"]]
        for name in stats[0]:
            df[f"stats/{layout.SEGMENT_INDEX}/{name}"] = [np.asarray(s[name]) for s in stats]
        df.to_parquet(path, index=False)
    total = aggregate_stats([per_ep[e] for e in every])[layout.SEGMENT_INDEX]
    stats_path = root / STATS_FILE
    all_stats = read_json_object(stats_path) if stats_path.exists() else {}
    all_stats[layout.SEGMENT_INDEX] = {k: np.asarray(v).tolist() for k, v in total.items()}
    stats_path.write_text(json.dumps(all_stats, indent=4))


def read_segment_index(dataset: Any) -> dict[int, np.ndarray]:
    """``{episode: changepoints (K+1,)}`` from the ``segment_index`` column of a dataset (a folder, a
    ``DatasetMeta``, a ``LeRobotDataset`` or its metadata)."""
    meta = to_meta(dataset)
    if layout.SEGMENT_INDEX not in meta.features:
        raise ValueError(f"dataset has no {layout.SEGMENT_INDEX!r} feature (run `forcemap segment` first)")
    columns = read_columns(meta, list(range(meta.total_episodes)), ["episode_index", layout.SEGMENT_INDEX])
    ep = columns["episode_index"]
    seg = columns[layout.SEGMENT_INDEX].reshape(-1)
    out = {}
    for e in np.unique(ep):
        lab = seg[ep == e]
        out[int(e)] = np.concatenate([[0], np.flatnonzero(np.diff(lab)) + 1, [len(lab)]]).astype(np.int64)
    return out


def read_subtasks(dataset: Any, episode: int, *, style: str = "motion") -> list[dict]:
    """The ``language_persistent`` rows of ``style`` of one episode (sorted by timestamp); ``dataset`` as
    for :func:`read_segment_index`."""
    from lerobot.datasets.language import LANGUAGE_PERSISTENT

    meta = to_meta(dataset)
    if LANGUAGE_PERSISTENT not in meta.features:
        return []
    rows = read_columns(meta, [episode], [LANGUAGE_PERSISTENT], name="episode")[LANGUAGE_PERSISTENT]
    first = rows[0] if len(rows) else None
    return sorted((r for r in first or [] if r.get("style") == style), key=lambda r: r["timestamp"])
