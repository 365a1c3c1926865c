"""``forcemap segment``: segment a LeRobot dataset's episodes and write the segments back into it.

Streams per episode (those the dataset has): ``joints`` (observation.state without its last entry),
``position`` (observation.ee_pose x y z), ``wrist_force`` (observation.force fx fy fz), ``gripper``
(observation.state's last entry) and ``finger_force`` (observation.finger_force), all on the
episode's LeRobot ``timestamp``. They go to :func:`lerobot_forcemap.segmentation.segment_streams`.

Write-back, in place (LeRobot 0.6.1 checked, ``datasets/language.py``, ``feature_utils.py``):

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
written; the parquet shards are then all written to temporary files and renamed together.
"""

from __future__ import annotations

import argparse
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
from lerobot_forcemap.data.schema import (
    SEGMENT_INDEX_FEATURE,
    check_data_columns,
    refresh_dataset_card,
    require_dataset_root,
)
from lerobot_forcemap.segmentation import (
    AUTHORS_WINDOW_S,
    SegmentationConfig,
    SegmentationResult,
    Stream,
    segment_streams,
)
from lerobot_forcemap.segmentation.config import CHANGEPOINT_METHODS, MODES

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
    "add_arguments",
    "run",
]

# The authors' UR5e thresholds (SPEC §2): joints 0.20, Cartesian 0.25, wrist force 0.15, gripper
# 0.10; finger force has none there and takes the wrist force's.
STREAM_THRESHOLDS: dict[str, float] = {
    "joints": 0.20,
    "position": 0.25,
    "wrist_force": 0.15,
    "gripper": 0.10,
    "finger_force": 0.15,
}
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


def episode_streams(
    columns: Mapping[str, np.ndarray],
    times: np.ndarray,
    features: Mapping[str, Mapping[str, Any]],
    *,
    weights: Mapping[str, float] | None = None,
    thresholds: Mapping[str, float] | None = None,
) -> list[Stream]:
    """Segmentation streams of one episode. ``columns``: ``{feature key: (T, dim)}``, ``times`` (T,) s.

    Weights default to 1 for every available stream; ``weights`` overrides by stream name (an unknown
    name raises ``ValueError`` listing the available ones). Thresholds default to ``STREAM_THRESHOLDS``.
    """
    available = stream_columns(features)
    for what, given in (("weight", weights), ("threshold", thresholds)):
        unknown = sorted(set(given or {}) - set(available))
        if unknown:
            raise ValueError(f"{what} for unknown stream(s) {unknown}; this dataset has {sorted(available)}")
    streams = []
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
    return streams


def _data_files(root: Path) -> list[Path]:
    files = sorted((root / "data").glob("*/*.parquet"))
    if not files:
        raise ValueError(f"{root}: no data/*/*.parquet files (not a LeRobot v3 dataset?)")
    return files


def _load(root: Path, repo_id: str):
    from lerobot.datasets.lerobot_dataset import LeRobotDataset  # lazy: heavy import

    # a data file that disagrees with meta/info.json: named here, before LeRobot's parquet traceback
    check_data_columns(root)
    return LeRobotDataset(repo_id, root=root)


def _check_stream_settings(
    available: Sequence[str], weights: Mapping[str, float] | None, thresholds: Mapping[str, float] | None
) -> None:
    """Stream names and values of ``--weights`` / ``--thresholds``, checked once (a bad value is the
    flag's fault, not the first episode's)."""
    for flag, given in (("--weights", weights), ("--thresholds", thresholds)):
        unknown = sorted(set(given or {}) - set(available))
        if unknown:
            raise ValueError(f"{flag}: unknown stream(s) {unknown}; this dataset has {sorted(available)}")
    for flag, given, field in (("--weights", weights, "weight"), ("--thresholds", thresholds, "threshold")):
        for name, value in (given or {}).items():
            try:  # Stream's own checks (weight finite >= 0 and not huge, threshold in (0, 1])
                Stream(name, np.zeros(2), np.arange(2.0), **{field: value})
            except ValueError as err:
                raise ValueError(f"{flag}: {err}") from None
    if not any((weights or {}).get(name, 1.0) > 0 for name in available):
        raise ValueError(
            f"--weights: every stream has weight 0 ({sorted(available)}); one needs a weight > 0"
        )


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
    (``segment_index``, plus LeRobot subtasks of ``style`` if ``subtasks``)."""
    # checked first: LeRobotDataset would create a missing folder and then look for it on the Hub
    root = require_dataset_root(root, "--dataset")
    if style not in SUBTASK_STYLES:
        raise ValueError(f"style must be one of {SUBTASK_STYLES}, got {style!r}")
    ds = _load(root, repo_id)
    features = ds.meta.features
    keys = sorted({key for key, _ in stream_columns(features).values()})
    if not keys:
        raise ValueError(
            f"{root}: no feature to segment on (need {layout.OBS_STATE}, {layout.OBS_FORCE}, ...)"
        )
    _check_stream_settings(list(stream_columns(features)), weights, thresholds)
    if not {layout.OBS_FORCE, layout.OBS_FINGER_FORCE} & set(features):
        warnings.warn(
            f"{root}: no force feature ({layout.OBS_FORCE} or {layout.OBS_FINGER_FORCE}); segmenting on "
            f"{', '.join(sorted(stream_columns(features)))} only",
            stacklevel=2,
        )
    table = ds.hf_dataset.with_format("numpy")
    ep_col = np.asarray(table["episode_index"])
    n_episodes = ds.meta.total_episodes
    chosen = list(range(n_episodes)) if episodes is None else [int(e) for e in episodes]
    repeated = sorted({e for e in chosen if chosen.count(e) > 1})
    if repeated:  # segmenting one twice would write its labels twice over
        raise ValueError(f"--episodes: episode(s) {repeated} given more than once")
    bad = [e for e in chosen if not 0 <= e < n_episodes]
    if bad:
        raise ValueError(f"{root}: episode(s) {bad} not in the dataset (0..{n_episodes - 1})")
    data = {key: np.asarray(table[key]) for key in keys}
    ts = np.asarray(table["timestamp"], dtype=np.float64)
    out = []
    for e in tqdm(chosen, desc="segment", unit="episode", disable=not progress):
        rows = np.flatnonzero(ep_col == e)
        cols = {key: data[key][rows] for key in keys}
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always")
                streams = episode_streams(cols, ts[rows], features, weights=weights, thresholds=thresholds)
                result = segment_streams(streams, config)
        except ValueError as err:
            raise ValueError(f"episode {e}: {err}") from err
        for w in caught:  # e.g. repeated timestamps: which of 60 episodes is it?
            warnings.warn(f"episode {e}: {w.message}", w.category, stacklevel=2)
        out.append(
            EpisodeSegments(e, np.asarray(result.changepoints, dtype=np.int64), result.labels(), result)
        )
    if write:
        write_segments(root, out, style=style, fps=ds.meta.fps, subtasks=subtasks)
    return out


def _labels_from(seg: EpisodeSegments | np.ndarray) -> np.ndarray:
    return seg.labels if isinstance(seg, EpisodeSegments) else np.asarray(seg, dtype=np.int64)


def write_segments(
    root: str | Path,
    segments: Sequence[EpisodeSegments] | Mapping[int, np.ndarray],
    *,
    style: str = "motion",
    fps: int | None = None,
    subtasks: bool = True,
) -> None:
    """Write per-frame labels (``{episode: labels (T,)}`` or :class:`EpisodeSegments`) into the dataset,
    and, if ``subtasks``, one LeRobot subtask row of ``style`` per segment.

    Labels must be non-decreasing integers starting at 0 with steps of 1 (segment k follows k-1);
    otherwise ``ValueError`` names the episode and the frame.
    """
    import pyarrow as pa
    import pyarrow.parquet as pq
    from lerobot.datasets.io_utils import load_info, write_info, write_table_one_row_group_per_episode
    from lerobot.datasets.language import LANGUAGE_EVENTS, LANGUAGE_PERSISTENT, language_feature_info

    root = Path(root)
    if style not in SUBTASK_STYLES:
        raise ValueError(f"style must be one of {SUBTASK_STYLES}, got {style!r}")
    if isinstance(segments, Mapping):
        labels_by_ep = {int(e): np.asarray(v, dtype=np.int64) for e, v in segments.items()}
    else:
        labels_by_ep = {s.episode_index: _labels_from(s) for s in segments}
    info = load_info(root)
    fps = int(fps or info.fps)
    for e, lab in labels_by_ep.items():
        if lab.ndim != 1 or len(lab) == 0:
            raise ValueError(f"episode {e}: labels must be a non-empty (T,) array, got shape {lab.shape}")
        steps = np.diff(lab)
        if lab[0] != 0 or np.any((steps != 0) & (steps != 1)):
            i = 0 if lab[0] != 0 else int(np.argmax((steps != 0) & (steps != 1))) + 1
            raise ValueError(
                f"episode {e}, frame {i}: segment labels must start at 0 and step by 1, got {lab[i]}"
            )

    # every episode checked against the data files before any file is written: a bad one leaves the
    # dataset as it was (LeRobot cannot open a data file whose columns info.json does not list)
    files = _data_files(root)
    frames: dict[int, int] = {}
    has_column = True
    for path in files:
        ep = pq.read_table(path, columns=["episode_index"]).column("episode_index").to_numpy()
        for e, n in zip(*np.unique(ep, return_counts=True), strict=True):
            frames[int(e)] = frames.get(int(e), 0) + int(n)
        has_column &= layout.SEGMENT_INDEX in pq.read_schema(path).names
    missing = sorted(set(labels_by_ep) - set(frames))
    if missing:
        raise ValueError(f"{root}: episode(s) {missing} not found in the data files")
    for e, lab in labels_by_ep.items():
        if len(lab) != frames[e]:
            raise ValueError(f"episode {e}: {len(lab)} labels for {frames[e]} frames")
    if not has_column and set(frames) - set(labels_by_ep):
        warnings.warn(
            f"{root}: {layout.SEGMENT_INDEX} is new; episode(s) {sorted(set(frames) - set(labels_by_ep))}, "
            "not segmented in this call, get one segment (0)",
            stacklevel=2,
        )

    staged: list[tuple[Path, Path]] = []
    stale: set[int] = set()  # episodes keeping an earlier run's rows that the new labels contradict
    for path in files:
        table = pq.read_table(path)
        ep = table.column("episode_index").to_numpy()
        frame = table.column("frame_index").to_numpy()
        if layout.SEGMENT_INDEX in table.column_names:
            seg_col = table.column(layout.SEGMENT_INDEX).to_numpy().astype(np.int64)
        else:
            seg_col = np.zeros(len(ep), dtype=np.int64)
        has_language = LANGUAGE_PERSISTENT in table.column_names
        if has_language:
            persistent = table.column(LANGUAGE_PERSISTENT).to_pylist()
        else:
            persistent = [[] for _ in range(len(ep))]
        episode_rows: dict[int, list[dict]] = {}
        for e in np.unique(ep):
            e = int(e)
            if e not in labels_by_ep:
                continue
            rows = np.flatnonzero(ep == e)
            lab = labels_by_ep[e]
            seg_col[rows] = lab[frame[rows]]
            if not (subtasks or has_language):
                continue
            old = persistent[rows[0]] or []
            kept = [r for r in old if not (subtasks and r.get("style") == style)]
            if _disagree(kept, lab, fps):
                stale.add(e)
            if not subtasks:
                continue
            starts = _starts(lab)
            n_seg = len(starts)
            ours = [
                {
                    "role": _ROLE,
                    "content": f"segment {k} of {n_seg}",
                    "style": style,
                    "timestamp": float(np.float32(start / fps)),
                    "camera": None,
                    "tool_calls": None,
                }
                for k, start in enumerate(starts)
            ]
            episode_rows[e] = sorted(kept + ours, key=lambda r: (float(r["timestamp"]), r.get("style") or ""))
        # without subtasks the language columns stay as they are (or absent)
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
        new_table = pa.Table.from_arrays(columns, names=[*keep, layout.SEGMENT_INDEX, *language])
        tmp = path.with_suffix(path.suffix + ".tmp")
        write_table_one_row_group_per_episode(new_table, tmp)
        staged.append((tmp, path))
    for tmp, path in staged:
        tmp.replace(path)
    if stale:
        warnings.warn(
            f"{root}: episode(s) {sorted(stale)} keep subtask rows of an earlier `forcemap segment` (other "
            f"style, or --no-subtasks) that no longer match the new {layout.SEGMENT_INDEX}; rerun with that "
            "--style to update them",
            stacklevel=2,
        )

    info.features = {
        **info.features,
        layout.SEGMENT_INDEX: dict(SEGMENT_INDEX_FEATURE),
        **(language_feature_info() if subtasks else {}),
    }
    write_info(info, root)
    _write_segment_stats(root)
    refresh_dataset_card(root)  # the card's feature table gains segment_index and the language columns


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
    """Per-episode stats (meta/episodes) and dataset stats (meta/stats.json) of ``segment_index``."""
    import pandas as pd
    import pyarrow.parquet as pq
    from lerobot.datasets.compute_stats import aggregate_stats, compute_episode_stats

    feature = {layout.SEGMENT_INDEX: dict(SEGMENT_INDEX_FEATURE)}
    per_ep: dict[int, dict] = {}
    for path in _data_files(root):
        t = pq.read_table(path, columns=["episode_index", layout.SEGMENT_INDEX])
        ep = t.column("episode_index").to_numpy()
        seg = t.column(layout.SEGMENT_INDEX).to_numpy()
        for e in np.unique(ep):
            per_ep[int(e)] = compute_episode_stats({layout.SEGMENT_INDEX: seg[ep == e]}, feature)
    for path in sorted((root / "meta" / "episodes").glob("*/*.parquet")):
        df = pd.read_parquet(path)
        stats = [per_ep[int(e)][layout.SEGMENT_INDEX] for e in df["episode_index"]]
        for name in stats[0]:
            df[f"stats/{layout.SEGMENT_INDEX}/{name}"] = [np.asarray(s[name]) for s in stats]
        tmp = path.with_suffix(path.suffix + ".tmp")
        df.to_parquet(tmp, index=False)
        tmp.replace(path)
    total = aggregate_stats([per_ep[e] for e in sorted(per_ep)])[layout.SEGMENT_INDEX]
    stats_path = root / "meta" / "stats.json"
    all_stats = json.loads(stats_path.read_text()) if stats_path.exists() else {}
    all_stats[layout.SEGMENT_INDEX] = {k: np.asarray(v).tolist() for k, v in total.items()}
    stats_path.write_text(json.dumps(all_stats, indent=4))


def read_segment_index(dataset: Any) -> dict[int, np.ndarray]:
    """``{episode: changepoints (K+1,)}`` from a loaded ``LeRobotDataset``'s ``segment_index`` column."""
    if layout.SEGMENT_INDEX not in dataset.meta.features:
        raise ValueError(f"dataset has no {layout.SEGMENT_INDEX!r} feature (run `forcemap segment` first)")
    table = dataset.hf_dataset.with_format("numpy")
    ep = np.asarray(table["episode_index"])
    seg = np.asarray(table[layout.SEGMENT_INDEX]).reshape(-1)
    out = {}
    for e in np.unique(ep):
        lab = seg[ep == e]
        out[int(e)] = np.concatenate([[0], np.flatnonzero(np.diff(lab)) + 1, [len(lab)]]).astype(np.int64)
    return out


def read_subtasks(dataset: Any, episode: int, *, style: str = "motion") -> list[dict]:
    """The ``language_persistent`` rows of ``style`` of one episode (sorted by timestamp)."""
    from lerobot.datasets.language import LANGUAGE_PERSISTENT

    if LANGUAGE_PERSISTENT not in dataset.meta.features:
        return []
    start = int(dataset.meta.episodes[episode]["dataset_from_index"])
    rows = dataset.hf_dataset[start][LANGUAGE_PERSISTENT] or []
    return sorted((r for r in rows if r.get("style") == style), key=lambda r: r["timestamp"])


# ---- CLI ------------------------------------------------------------------------------------------------


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
    parser.add_argument("--dataset", required=True, help="dataset root folder (written in place)")
    parser.add_argument(
        "--repo-id",
        default="local/forcemap",
        help="dataset id LeRobot opens the folder under (any string works locally; default local/forcemap)",
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
        fps = float(json.loads((Path(args.dataset) / "meta" / "info.json").read_text())["fps"])
        scaled = max(5, int(round(AUTHORS_WINDOW_S * fps)))
        print(
            f"note: {len(single)} of {len(segs)} episode(s) found no changepoint. --window {args.window} and "
            f"--min-run {args.min_run} count frames; the authors' 64 frames are {AUTHORS_WINDOW_S:.2f} s at "
            f"their ~166 Hz, which at this dataset's {fps:g} fps is --window {scaled} --min-run {scaled} "
            "(the forcemap policy's window at this rate; its own segments='auto' reads the commanded action, "
            "not the measured pose, so its cuts can differ: fit with segments='dataset' to use these labels)"
        )
    if not args.dry_run:
        what = f"{layout.SEGMENT_INDEX}" + ("" if args.no_subtasks else f" and {args.style} subtasks")
        print(f"wrote {what} to {args.dataset}")
    return 0
