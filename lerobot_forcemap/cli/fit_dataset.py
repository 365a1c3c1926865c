"""``forcemap fit --all-episodes``: a skill library, one fitted skill per episode of a dataset.

    forcemap fit --dataset datasets/press --all-episodes --out outputs/press_skills [--workers 2 | --ray]

Every episode is segmented and fitted on its own (:func:`fit_policy` with ``episodes=[e]``), as a job of
an :mod:`lerobot_forcemap.executor` (this process, a process pool, or Ray), into its own checkpoint
folder ``episode_<e:06d>/`` (what ``forcemap fit --episodes e`` writes: loadable by ``forcemap eval`` and
``lerobot-eval --policy.path``). ``index.json`` lists every episode: its folder, ``status`` (``ok``;
``refused``: the fit refused the episode, ``reason`` says why, naming the field, episode or frame;
``failed``: an unexpected error, its type and message), the segments with their EM stop reasons, and
``events``: where the dataset has the recorder's ``demo_phase`` column, the frames where the
demonstrator's phase changes (contact made and broken among them). A bad episode does not stop the
others. The library is built beside ``--out`` and moved there only when every episode has been tried:
an interrupted run leaves nothing at ``--out`` (and, with ``--overwrite``, the old library in place).
"""

from __future__ import annotations

import json
import shutil
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from lerobot_forcemap import layout
from lerobot_forcemap._validation import check_int_list
from lerobot_forcemap.data.reader import DatasetMeta, read_columns, read_meta
from lerobot_forcemap.data.staging import check_output, partial_dir, replace_dir
from lerobot_forcemap.executor import Executor

__all__ = ["INDEX_FILE", "EpisodeJob", "episode_folder", "fit_episode", "fit_dataset"]

INDEX_FILE = "index.json"
#: the per-segment figures of ``FitReport.summary()`` the index keeps (no timings: the index is the
#: same whichever executor ran the fits)
_SEGMENT_FIELDS = ("segment", "anchor", "n_nodes", "n_iter", "stop_reason", "capped_nodes", "n_force_points")


@dataclass(frozen=True)
class EpisodeJob:
    """Fit episode ``episode`` of the dataset at ``dataset`` into the checkpoint folder ``out``."""

    dataset: str
    repo_id: str
    episode: int
    overrides: tuple[str, ...]
    out: str


def episode_folder(episode: int) -> str:
    """The checkpoint folder of ``episode`` inside the library."""
    return f"episode_{episode:06d}"


def fit_episode(job: EpisodeJob) -> dict[str, Any]:
    """One episode's row of the index (module docstring); the fit's errors become its status."""
    from lerobot_forcemap.cli.fit import fit_policy

    row: dict[str, Any] = {"episode": job.episode, "folder": None, "status": "ok", "reason": None}
    try:
        result = fit_policy(
            job.dataset, job.out, repo_id=job.repo_id, episodes=[job.episode], overrides=job.overrides
        )
    except ValueError as err:  # a refusal: the message names the field, episode or frame
        shutil.rmtree(job.out, ignore_errors=True)
        return {**row, "status": "refused", "reason": str(err)}
    except Exception as err:  # anything else fails this episode only
        shutil.rmtree(job.out, ignore_errors=True)
        return {**row, "status": "failed", "reason": f"{type(err).__name__}: {err}"}
    report = result.policy.fit_report
    segments = [{k: seg[k] for k in _SEGMENT_FIELDS} for seg in report.summary()]
    return {
        **row,
        "folder": Path(job.out).name,
        "n_segments": len(segments),
        "changepoints": report.changepoints[0].tolist(),
        "segments": segments,
    }


def fit_dataset(
    dataset: str | Path,
    out: str | Path,
    executor: Executor,
    *,
    repo_id: str | None = None,
    overrides: Sequence[str] = (),
    episodes: Sequence[int] | None = None,
    overwrite: bool = False,
    progress: bool = True,
) -> dict[str, Any]:
    """Fit every episode of ``dataset`` (or only ``episodes``) into the library ``out`` (module
    docstring) with ``executor``; returns the index. ``overrides``: ``ForceMapConfig`` fields as
    ``FIELD=VALUE`` (``--set``), the same for every episode. ``ValueError`` (before any fit) for a bad
    ``--out``, dataset, episode list or setting."""
    from lerobot_forcemap.cli.fit import make_config

    out = check_output(out, overwrite=overwrite, marker=INDEX_FILE, what="skill library")
    meta = read_meta(dataset, repo_id=repo_id, name="--dataset")
    make_config([0], overrides)  # the settings refused once here, not once per episode
    chosen = list(range(meta.total_episodes))
    if episodes is not None:
        chosen = check_int_list("episodes", episodes, low=0, distinct=True)
        missing = sorted(set(chosen) - set(range(meta.total_episodes)))
        if missing:
            raise ValueError(f"episodes: {missing} not in {meta.root} ({meta.total_episodes} episodes)")
    work = partial_dir(out)
    work.mkdir()
    try:
        jobs = [
            EpisodeJob(str(meta.root), meta.repo_id, e, tuple(overrides), str(work / episode_folder(e)))
            for e in chosen
        ]
        rows = executor.map(fit_episode, jobs, desc="fit episodes", unit="episode", progress=progress)
        events = _phase_switches(meta)
        for row in rows:
            row["events"] = events.get(row["episode"])
        index = _index(meta, overrides, rows)
        (work / INDEX_FILE).write_text(json.dumps(index, indent=1))
    except BaseException:
        shutil.rmtree(work, ignore_errors=True)
        raise
    replace_dir(out, work)
    return index


def _phase_switches(meta: DatasetMeta) -> dict[int, list[int]]:
    """Per episode, the frames where ``demo_phase`` changes (``{}`` when the dataset lacks it)."""
    import numpy as np

    if layout.DEMO_PHASE not in meta.features or not meta.total_episodes:
        return {}
    cols = read_columns(meta, list(range(meta.total_episodes)), [layout.DEMO_PHASE, "episode_index"])
    phase = np.asarray(cols[layout.DEMO_PHASE]).reshape(len(cols["episode_index"]), -1)[:, 0]
    out = {}
    for e in np.unique(cols["episode_index"]):
        p = phase[cols["episode_index"] == e]
        out[int(e)] = (np.flatnonzero(np.diff(p)) + 1).tolist()
    return out


def _index(meta: DatasetMeta, overrides: Sequence[str], rows: list[dict[str, Any]]) -> dict[str, Any]:
    counts = {s: sum(r["status"] == s for r in rows) for s in ("ok", "refused", "failed")}
    return {
        "dataset": str(meta.root.resolve()),
        "dataset_repo_id": meta.repo_id,
        "overrides": list(overrides),
        "total_episodes": meta.total_episodes,
        "counts": counts,
        "episodes": rows,
    }
