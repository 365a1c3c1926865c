"""The demonstrations' own figures, as episode records comparable with evaluated ones.

    records, source = demonstration_records("datasets/press", trace=True, task="press")

Source ``meta/forcemap_episodes.json`` (written by ``forcemap record``: the env's own statistics at
physics rate, the same figures an evaluated episode gets), else the dataset's ``contact_force``
column, else the wrist force ``observation.force`` (both at the dataset's frame rate, so maxima may
read lower).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap import layout
from lerobot_forcemap._validation import check_dict, check_real, fail
from lerobot_forcemap.evaluation.records import DEMO_TRACE_COLUMNS, FORCE_KEYS, to_json
from lerobot_forcemap.jsonfile import read_json_object

__all__ = ["demonstration_records"]


def demonstration_records(
    dataset: str | Path,
    *,
    trace: bool = False,
    task: str | None = None,
    figures: Sequence[str] = FORCE_KEYS,
) -> tuple[list[dict[str, Any]], str]:
    """Per-episode records of the demonstrations in a dataset; returns (records, source).

    A record holds ``episode, seed, success, protective_stop`` (``object`` on the grasping tasks) and
    the force ``figures`` the source has (module docstring). ``trace`` adds per-frame rows
    :data:`~lerobot_forcemap.evaluation.records.DEMO_TRACE_COLUMNS` and the episode's first environment
    state. ``task``: the evaluated task; demonstrations ``forcemap record`` wrote for another task are
    refused (a press policy compared with erase demonstrations says nothing).
    """
    root = Path(dataset)
    meta_file = root / "meta" / layout.EPISODES_FILE
    records: list[dict[str, Any]] = []
    source = ""
    if meta_file.is_file():
        records = _meta_records(root, meta_file, task, figures)
        source = str(meta_file)
    if trace or not records:
        table, names = _read_table(root)
        force_key = layout.CONTACT_FORCE if layout.CONTACT_FORCE in table else layout.OBS_FORCE
        if not records:
            source = f"{root} column {force_key!r} (frame rate)"
        _add_frame_figures(records, table, names, force_key, trace)
    return records, source


def _meta_records(root: Path, path: Path, task: str | None, figures: Sequence[str]) -> list[dict[str, Any]]:
    """The records of ``meta/forcemap_episodes.json`` (``path``), its force figures checked."""
    data = read_json_object(path)
    if task is not None and data.get("task") not in (None, task):
        raise ValueError(
            f"--dataset {root}: demonstrations of task {data['task']!r} ({path.name}), not of the "
            f"evaluated task {task!r}"
        )
    records = []
    for i, ep in enumerate(data.get("episodes", [])):
        _check_force_figures(ep, f"{path}: episodes[{i}]")
        records.append(
            {
                "episode": i,
                "seed": ep.get("seed"),
                "success": bool(ep.get("is_success", True)),
                "protective_stop": bool(ep.get("protective_stop", False)),
                **({"object": ep["object"]} if "object" in ep else {}),
                **{k: ep[k] for k in figures if k in ep},
            }
        )
    return records


def _check_force_figures(record: Any, where: str) -> None:
    """The force figures of one stored record are finite numbers (3 per ``_xyz`` key): a NaN would
    print as "+nan%" and write non-standard JSON."""
    check_dict(where, record)
    for key in FORCE_KEYS:
        if key not in record:
            continue
        name, value = f"{where}.{key}", record[key]
        if not key.endswith("_xyz"):
            check_real(name, value)
            continue
        if not isinstance(value, list) or len(value) != 3:
            fail(name, "be a list of 3 finite numbers", value)
        for i, v in enumerate(value):
            check_real(f"{name}[{i}]", v)


def _add_frame_figures(
    records: list[dict[str, Any]],
    table: dict[str, np.ndarray],
    names: list[str],
    force_key: str,
    trace: bool,
) -> None:
    """Per episode of ``table``: a record from the frame-rate force column where ``records`` has none,
    and with ``trace`` the episode's trace rows and first environment state."""
    ep_col = table["episode_index"].astype(int)
    for e in np.unique(ep_col):
        rows = ep_col == e
        f = table[force_key][rows][:, :3].astype(float)
        if len(records) <= e:
            n = np.linalg.norm(f, axis=1)
            records.append(
                {
                    "episode": int(e),
                    "success": True,
                    "protective_stop": False,
                    "max_contact_force": float(n.max()),
                    "mean_contact_force": float(n.mean()),
                    "max_contact_force_xyz": np.abs(f).max(axis=0).tolist(),
                    "mean_contact_force_xyz": np.abs(f).mean(axis=0).tolist(),
                }
            )
        if trace:
            t = table["timestamp"][rows].astype(float).reshape(-1)
            ee = table[layout.OBS_EE_POSE][rows][:, :3].astype(float)
            act = table[layout.ACTION][rows][:, :3].astype(float)
            env_state = table[layout.OBS_ENV_STATE][rows][0] if layout.OBS_ENV_STATE in table else None
            records[int(e)]["trace"] = {
                "columns": list(DEMO_TRACE_COLUMNS),
                "rows": to_json(np.column_stack([t - t[0], f, ee, act])),
                "environment_state": to_json(env_state) if env_state is not None else None,
                "environment_state_names": names,
                "force_source": force_key,
            }


def _read_table(root: Path) -> tuple[dict[str, np.ndarray], list[str]]:
    """Numeric 1-D features of a LeRobot v3 dataset as ``{key: (rows, width)}`` (episode_index,
    timestamp, frame_index as ``(rows,)``), read by ``lerobot_forcemap.data.reader`` (no video
    decoding); + env-state names."""
    from lerobot_forcemap.data.reader import read_columns, read_meta

    meta = read_meta(root)
    features = meta.features
    keys = [
        k
        for k, ft in features.items()
        if ft["dtype"] not in ("image", "video", "string", "language") and len(ft["shape"]) == 1
    ]
    cols = read_columns(meta, list(range(meta.total_episodes)), keys)
    out = {k: v.reshape(len(v), -1) for k, v in cols.items()}
    for k in ("episode_index", "timestamp", "frame_index"):
        out[k] = out[k][:, 0]
    names = list(features.get("observation.environment_state", {}).get("names") or [])
    return out, names
