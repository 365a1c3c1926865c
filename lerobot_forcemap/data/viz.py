"""``forcemap viz``: one episode of a LeRobot dataset in Rerun, with what ``lerobot-dataset-viz`` leaves out.

LeRobot 0.6.1's ``lerobot-dataset-viz`` logs the cameras, ``action``, ``observation.state`` and
``next.{done,reward,success}`` only (``lerobot/scripts/lerobot_dataset_viz.py``; its Foxglove mode
the same), so the force features and the segments ``forcemap segment`` writes do not show there.
:func:`log_episode` logs the entities ``lerobot-dataset-viz`` logs, under the same names and timelines
(``frame_index``, ``timestamp``), plus every other numeric feature (``observation.force``,
``observation.finger_force``, ``contact_force``, ``observation.ee_pose``,
``observation.environment_state``, ``segment_index``, ``demo_phase``, ...) as time series named per
dimension, and the LeRobot subtasks (``language_persistent``, one text row per segment start) under
``subtasks/<style>``. Numeric features go in as whole columns (no per-frame Python loop), read by
:mod:`.reader`; camera frames are decoded one by one by LeRobot, as ``lerobot-dataset-viz`` does. Needs
``rerun-sdk`` (the ``viz`` extra, as for ``lerobot-dataset-viz``). The command line is
``lerobot_forcemap/cli/viz.py``.

    forcemap viz --dataset datasets/press --episode 0                  # opens the Rerun viewer
    forcemap viz --dataset datasets/press --episode 0 --save ep0.rrd   # writes a recording file
"""

from __future__ import annotations

import os
import shutil
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap import layout
from lerobot_forcemap.data.reader import DatasetMeta, lerobot_dataset, read_columns, read_meta, to_meta
from lerobot_forcemap.data.schema import numeric_feature_keys
from lerobot_forcemap.data.segment import SUBTASK_STYLES, read_subtasks

__all__ = ["ENTITY_NAMES", "log_episode", "visualize_episode", "viewer_command"]

#: entity paths that differ from the feature key, as ``lerobot-dataset-viz`` names them
ENTITY_NAMES = {layout.OBS_STATE: "state"}


def _import_rerun():
    try:
        import rerun as rr
    except ImportError as err:
        raise ImportError(
            "forcemap viz needs rerun-sdk: pip install 'lerobot_policy_forcemap[viz]' "
            "(or 'lerobot[viz]', as for lerobot-dataset-viz)"
        ) from err
    return rr


def _check_episode(meta: DatasetMeta, episode: int) -> None:
    if episode not in range(meta.total_episodes):
        raise ValueError(f"--episode {episode}: the dataset has episodes 0..{meta.total_episodes - 1}")


def _feature_names(feature: dict[str, Any], key: str) -> list[str]:
    """Per-dimension names, as ``lerobot-dataset-viz`` gives them: the feature's names, else
    ``<key>_<i>``."""
    dim = feature["shape"][-1]
    names = feature.get("names")
    if isinstance(names, list) and len(names) == dim:
        return [str(name) for name in names]
    return [f"{key}_{d}" for d in range(dim)]


def log_episode(dataset: Any, episode: int, recording: Any) -> dict[str, int]:
    """Log episode ``episode`` of a dataset (a folder, a ``DatasetMeta``, a ``LeRobotDataset`` or its
    metadata) to a Rerun ``recording`` (a ``rerun.RecordingStream``). Returns ``{entity path: rows
    logged}``."""
    rr = _import_rerun()
    meta = to_meta(dataset)
    keys = numeric_feature_keys(meta.features)
    columns = read_columns(meta, [episode], ["frame_index", "timestamp", *keys], name="--episode")
    frames = np.asarray(columns["frame_index"], dtype=np.int64)
    times = np.asarray(columns["timestamp"], dtype=np.float64)
    logged = _log_features(rr, recording, meta, episode, columns, frames, times)
    logged |= _log_subtasks(rr, recording, meta, episode, frames, times)
    logged |= _log_cameras(rr, recording, meta, episode, frames, times)
    return logged


def _log_features(rr, recording, meta: DatasetMeta, episode: int, columns, frames, times) -> dict[str, int]:
    """Every numeric feature as a time series, one line per dimension."""
    indexes = [rr.TimeColumn("frame_index", sequence=frames), rr.TimeColumn("timestamp", timestamp=times)]
    logged: dict[str, int] = {}
    for key in numeric_feature_keys(meta.features):
        values = np.asarray(columns[key], dtype=np.float64).reshape(len(frames), -1)
        bad = ~np.isfinite(values).all(axis=1)
        if bad.any():  # logged as they are (gaps in the plot), but said: fit would refuse this episode
            warnings.warn(
                f"episode {episode}: {key} is not finite in {int(bad.sum())} frame(s), first at frame "
                f"{int(frames[bad.argmax()])} (drawn as gaps)",
                stacklevel=3,
            )
        entity = ENTITY_NAMES.get(key, key)
        if values.shape[1] > 1 or meta.features[key].get("names"):
            names = _feature_names(meta.features[key], key)
            recording.log(entity, rr.SeriesLines(names=names), static=True)
        recording.send_columns(entity, indexes=indexes, columns=rr.Scalars.columns(scalars=values))
        logged[entity] = len(frames)
    return logged


def _log_subtasks(rr, recording, meta: DatasetMeta, episode: int, frames, times) -> dict[str, int]:
    """The LeRobot subtask rows of each style, one text row at the frame each starts at."""
    logged: dict[str, int] = {}
    for style in SUBTASK_STYLES:
        rows = read_subtasks(meta, episode, style=style)
        if rows:
            at = np.array([r["timestamp"] for r in rows], dtype=np.float64)
            # the frame each row starts at (its timestamp is that frame's)
            first = np.clip(np.searchsorted(times, at - 1e-9), 0, len(frames) - 1)
            recording.send_columns(
                f"subtasks/{style}",
                indexes=[
                    rr.TimeColumn("frame_index", sequence=frames[first]),
                    rr.TimeColumn("timestamp", timestamp=times[first]),
                ],
                columns=rr.TextLog.columns(text=[str(r["content"]) for r in rows]),
            )
            logged[f"subtasks/{style}"] = len(rows)
    return logged


def _log_cameras(rr, recording, meta: DatasetMeta, episode: int, frames, times) -> dict[str, int]:
    """Camera frames, decoded by LeRobot (only opened when the dataset has cameras)."""
    if not meta.camera_keys:
        return {}
    from lerobot.scripts.lerobot_dataset_viz import to_hwc_uint8_numpy

    dataset = lerobot_dataset(meta)
    start = meta.episodes[episode].start
    logged: dict[str, int] = {}
    for key in meta.camera_keys:
        for i in range(len(frames)):
            recording.set_time("frame_index", sequence=int(frames[i]))
            recording.set_time("timestamp", timestamp=float(times[i]))
            recording.log(key, rr.Image(to_hwc_uint8_numpy(dataset[start + i][key])))
        logged[key] = len(frames)
    return logged


def visualize_episode(
    root: str | Path, episode: int, *, save: str | Path | None = None, repo_id: str | None = None
) -> tuple[Path | None, dict[str, int]]:
    """Open the dataset at ``root`` and log one episode: to the file ``save`` (``.rrd``), else to a
    spawned Rerun viewer. Returns the file (or None) and the entities logged."""
    meta = read_meta(root, repo_id=repo_id, name="--dataset")
    if save is not None and Path(save).is_dir():
        raise ValueError(
            f"--save {save}: is a folder; give a file name such as {Path(save) / f'episode_{episode}.rrd'}"
        )
    if save is not None and Path(save).suffix != ".rrd":  # and no other kind of file is overwritten
        raise ValueError(f"--save {save}: a Rerun recording file ends in .rrd")
    if save is None:
        _put_viewer_on_path()
    rr = _import_rerun()
    _check_episode(meta, episode)  # a bad episode fails before a viewer or file is opened
    recording = rr.RecordingStream(application_id=f"{meta.repo_id}/episode_{episode}")
    if save is not None:
        save = Path(save)
        save.parent.mkdir(parents=True, exist_ok=True)
        recording.save(str(save))
    else:
        recording.spawn()
    logged = log_episode(meta, episode, recording)
    recording.flush()
    return save, logged


def viewer_command() -> str | None:
    """The Rerun viewer to run: ``rerun`` on PATH, else the one installed beside this Python (a venv
    used without activating it), else None."""
    beside = Path(sys.executable).parent / "rerun"
    return shutil.which("rerun") or (str(beside) if beside.is_file() else None)


def _put_viewer_on_path() -> None:
    """``RecordingStream.spawn`` looks for ``rerun`` on PATH only: add the venv's, or say none is there."""
    viewer = viewer_command()
    if viewer is None:
        raise ValueError(
            "no Rerun viewer found (`rerun` is not on PATH nor beside this Python): write a file with "
            "--save episode.rrd, or install the viz extra (pip install rerun-sdk)"
        )
    if _headless() and not _viewer_listening():
        # spawn() would start a viewer that cannot open a window, then time out after 6 s with a traceback
        raise ValueError(
            "no display for the Rerun viewer (DISPLAY and WAYLAND_DISPLAY are unset): write a file with "
            "--save episode.rrd and open it where there is a screen (or start `rerun --web-viewer` first)"
        )
    if shutil.which("rerun") is None:
        os.environ["PATH"] = f"{Path(viewer).parent}{os.pathsep}{os.environ.get('PATH', '')}"


#: where a spawned or already running Rerun viewer listens (rerun-sdk's default)
VIEWER_PORT = 9876


def _headless() -> bool:
    """Linux with no X11 or Wayland display to open a window on (other systems always have one)."""
    if not sys.platform.startswith("linux"):
        return False
    return not any(os.environ.get(v) for v in ("DISPLAY", "WAYLAND_DISPLAY", "WAYLAND_SOCKET"))


def _viewer_listening() -> bool:
    """A viewer (a web viewer, say) already listens on the local port: spawn() connects to it."""
    import socket

    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.settimeout(0.2)
        return s.connect_ex(("127.0.0.1", VIEWER_PORT)) == 0
