"""``forcemap viz``: one episode of a LeRobot dataset in Rerun, with what ``lerobot-dataset-viz`` leaves out.

LeRobot 0.6.1's ``lerobot-dataset-viz`` logs the cameras, ``action``, ``observation.state`` and
``next.{done,reward,success}`` only (``lerobot/scripts/lerobot_dataset_viz.py``; its Foxglove mode
the same), so the force features and the segments ``forcemap segment`` writes do not show there.
:func:`log_episode` logs the entities ``lerobot-dataset-viz`` logs, under the same names and timelines
(``frame_index``, ``timestamp``), plus every other numeric feature (``observation.force``,
``observation.finger_force``, ``contact_force``, ``observation.ee_pose``,
``observation.environment_state``, ``segment_index``, ``demo_phase``, ...) as time series named per
dimension, and the LeRobot subtasks (``language_persistent``, one text row per segment start) under
``subtasks/<style>``. Numeric features go in as whole columns (no per-frame Python loop); camera
frames are decoded one by one, as LeRobot does. Needs ``rerun-sdk`` (the ``viz`` extra, as for
``lerobot-dataset-viz``).

    forcemap viz --dataset datasets/press --episode 0                  # opens the Rerun viewer
    forcemap viz --dataset datasets/press --episode 0 --save ep0.rrd   # writes a recording file
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap import layout
from lerobot_forcemap.data.schema import check_data_columns, numeric_feature_keys, require_dataset_root
from lerobot_forcemap.data.segment import SUBTASK_STYLES, read_subtasks

__all__ = ["ENTITY_NAMES", "log_episode", "visualize_episode", "add_arguments", "run"]

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


def _episode_rows(dataset: Any, episode: int) -> tuple[int, int]:
    if episode not in range(dataset.meta.total_episodes):
        raise ValueError(
            f"--episode {episode}: the dataset has episodes 0..{dataset.meta.total_episodes - 1}"
        )
    ep = dataset.meta.episodes[episode]
    return int(ep["dataset_from_index"]), int(ep["dataset_to_index"])


def log_episode(dataset: Any, episode: int, recording: Any) -> dict[str, int]:
    """Log episode ``episode`` of a loaded ``LeRobotDataset`` to a Rerun ``recording`` (a
    ``rerun.RecordingStream``). Returns ``{entity path: rows logged}``."""
    from lerobot.scripts.lerobot_dataset_viz import get_feature_names, to_hwc_uint8_numpy

    rr = _import_rerun()
    start, stop = _episode_rows(dataset, episode)
    table = dataset.hf_dataset.with_format("numpy")[start:stop]
    frames = np.asarray(table["frame_index"], dtype=np.int64)
    times = np.asarray(table["timestamp"], dtype=np.float64)
    indexes = [rr.TimeColumn("frame_index", sequence=frames), rr.TimeColumn("timestamp", timestamp=times)]
    logged: dict[str, int] = {}
    for key in numeric_feature_keys(dataset.meta.features):
        values = np.asarray(table[key], dtype=np.float64).reshape(len(frames), -1)
        bad = ~np.isfinite(values).all(axis=1)
        if bad.any():  # logged as they are (gaps in the plot), but said: fit would refuse this episode
            warnings.warn(
                f"episode {episode}: {key} is not finite in {int(bad.sum())} frame(s), first at frame "
                f"{int(frames[bad.argmax()])} (drawn as gaps)",
                stacklevel=2,
            )
        entity = ENTITY_NAMES.get(key, key)
        if values.shape[1] > 1 or dataset.features[key].get("names"):
            recording.log(entity, rr.SeriesLines(names=get_feature_names(dataset, key)), static=True)
        recording.send_columns(entity, indexes=indexes, columns=rr.Scalars.columns(scalars=values))
        logged[entity] = len(frames)
    for style in SUBTASK_STYLES:
        rows = read_subtasks(dataset, episode, style=style)
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
    for key in dataset.meta.camera_keys:
        for i in range(start, stop):
            recording.set_time("frame_index", sequence=int(frames[i - start]))
            recording.set_time("timestamp", timestamp=float(times[i - start]))
            recording.log(key, rr.Image(to_hwc_uint8_numpy(dataset[i][key])))
        logged[key] = stop - start
    return logged


def visualize_episode(
    root: str | Path, episode: int, *, save: str | Path | None = None, repo_id: str | None = None
) -> tuple[Path | None, dict[str, int]]:
    """Open the dataset at ``root`` and log one episode: to the file ``save`` (``.rrd``), else to a
    spawned Rerun viewer. Returns the file (or None) and the entities logged."""
    from lerobot.datasets.lerobot_dataset import LeRobotDataset  # lazy: heavy import

    root = require_dataset_root(root, "--dataset")
    check_data_columns(root)
    if save is not None and Path(save).is_dir():
        raise ValueError(
            f"--save {save}: is a folder; give a file name such as {Path(save) / f'episode_{episode}.rrd'}"
        )
    if save is not None and Path(save).suffix != ".rrd":  # and no other kind of file is overwritten
        raise ValueError(f"--save {save}: a Rerun recording file ends in .rrd")
    if save is None:
        _put_viewer_on_path()
    rr = _import_rerun()
    dataset = LeRobotDataset(repo_id or f"local/{root.name}", root=root)
    _episode_rows(dataset, episode)  # a bad episode fails before a viewer or file is opened
    recording = rr.RecordingStream(application_id=f"{dataset.repo_id}/episode_{episode}")
    if save is not None:
        save = Path(save)
        save.parent.mkdir(parents=True, exist_ok=True)
        recording.save(str(save))
    else:
        recording.spawn()
    logged = log_episode(dataset, episode, recording)
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


# ---- CLI ------------------------------------------------------------------------------------------------


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
