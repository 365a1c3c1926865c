"""The shipped demonstrations as the experiments use them: replayed actions, force figures, phase switches.

- :func:`load_demo_episode` / :func:`reanchor_actions`: one demonstration's actions, moved rigidly with
  the task object into a new scene (what the hybrid and replay baselines follow);
- :func:`demo_force_records`: the demonstrations' own episode records (the recorder's env statistics);
- :func:`demo_phase_switches` / :func:`segmentation_score`: the scripted demonstrator's phase switches,
  the reference a one-shot fit's changepoints are scored against;
- :func:`auto_stream_weights`: label-free segmentation weights of one demonstration.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap import layout
from lerobot_forcemap.evaluation.demonstrations import demonstration_records
from lerobot_forcemap.evaluation.records import ALL_FIGURES

__all__ = [
    "DemoEpisode",
    "load_demo_episode",
    "reanchor_actions",
    "demo_force_records",
    "demo_phase_switches",
    "segmentation_score",
    "auto_stream_weights",
]

Array = NDArray[np.float64]


@dataclass(frozen=True)
class DemoEpisode:
    """One recorded demonstration: actions (T, 8), environment state (T, E) with its names, fps."""

    episode: int
    actions: Array
    env_state: Array
    state_names: tuple[str, ...]
    fps: float


def _read_columns(meta: Any, keys: Sequence[str]) -> dict[str, np.ndarray]:
    """The ``keys`` columns of every episode as float64 ``(rows, width)``."""
    from lerobot_forcemap.data.reader import read_columns

    cols = read_columns(meta, list(range(meta.total_episodes)), keys)
    return {k: np.asarray(v, dtype=np.float64).reshape(len(v), -1) for k, v in cols.items()}


def load_demo_episode(dataset: str | Path, episode: int) -> DemoEpisode:
    """Actions and environment state of one episode of a LeRobot v3 dataset (read by the data reader)."""
    from lerobot_forcemap.data.reader import read_meta

    root = Path(dataset)
    meta = read_meta(root)
    features = meta.features
    for key in (layout.ACTION, layout.OBS_ENV_STATE):
        if key not in features:
            raise ValueError(f"{root}: feature {key!r} missing (needed to replay a demonstration)")
    cols = _read_columns(meta, [layout.ACTION, layout.OBS_ENV_STATE, "episode_index", "frame_index"])
    rows = np.flatnonzero(cols["episode_index"][:, 0].astype(int) == int(episode))
    if len(rows) == 0:
        have = sorted(set(cols["episode_index"][:, 0].astype(int).tolist()))
        raise ValueError(f"{root}: episode {episode} not in the dataset (episodes {have})")
    rows = rows[np.argsort(cols["frame_index"][rows, 0], kind="stable")]
    return DemoEpisode(
        episode=int(episode),
        actions=cols[layout.ACTION][rows],
        env_state=cols[layout.OBS_ENV_STATE][rows],
        state_names=tuple(features[layout.OBS_ENV_STATE].get("names") or ()),
        fps=float(meta.fps),
    )


def reanchor_actions(demo: DemoEpisode, env_state_now: Array, anchor: str) -> Array:
    """The demonstration's actions moved rigidly with object ``anchor``: from its pose at the
    demonstration's first frame to its pose in ``env_state_now (E,)``. Returns (T, 8)."""
    from lerobot_forcemap.skill.placement import (
        from_object_frame,
        object_poses,
        object_slots,
        to_object_frame,
    )

    slots = [s for s in object_slots(demo.state_names) if s.name == anchor]
    if not slots:
        raise ValueError(
            f"reanchor_actions: object {anchor!r} not in the environment state {list(demo.state_names)}"
        )
    before = object_poses(demo.env_state[0], slots)[anchor]
    now = object_poses(env_state_now, slots)[anchor]
    a = demo.actions
    p, _, q = to_object_frame(before, a[:, layout.ACTION_POS], None, a[:, layout.ACTION_QUAT])
    p, q = from_object_frame(now, p, q)
    out = a.copy()
    out[:, layout.ACTION_POS] = p
    out[:, layout.ACTION_QUAT] = q
    return out


def demo_force_records(dataset: str | Path) -> list[dict[str, Any]]:
    """The demonstrations' records from ``meta/forcemap_episodes.json`` (the recorder's env statistics at
    physics rate, comparable to evaluation records): success, protective stop, force and finger figures."""
    path = Path(dataset) / "meta" / layout.EPISODES_FILE
    if not path.is_file():
        raise ValueError(
            f"{dataset}: no meta/{layout.EPISODES_FILE} (record the dataset with `forcemap record`)"
        )
    return demonstration_records(dataset, figures=ALL_FIGURES)[0]


def demo_phase_switches(dataset: str | Path) -> dict[int, Array]:
    """Per episode, the frames where the scripted demonstrator's phase (``demo_phase``) changes: the
    reference events for scoring segmentation in simulation. ``{}`` without that column."""
    from lerobot_forcemap.data.reader import read_meta

    meta = read_meta(dataset)
    if layout.DEMO_PHASE not in meta.features:
        return {}
    cols = _read_columns(meta, [layout.DEMO_PHASE, "episode_index", "frame_index"])
    episode = cols["episode_index"][:, 0].astype(int)
    out = {}
    for e in np.unique(episode):
        rows = np.flatnonzero(episode == e)
        rows = rows[np.argsort(cols["frame_index"][rows, 0], kind="stable")]
        out[int(e)] = np.flatnonzero(np.diff(cols[layout.DEMO_PHASE][rows, 0])) + 1
    return out


def segmentation_score(
    fits: Sequence[Mapping[str, Any]], switches: Mapping[int, Array]
) -> dict[str, Any] | None:
    """Changepoint precision, recall and F1 of one-shot fits (``rollouts.fitted_checkpoint``'s records)
    against their demonstrations' phase switches, pooled over the fits; tolerance: the segmentation
    window. Segment counts say nothing about quality. None if no fit can be scored."""
    from lerobot_forcemap.segmentation.evaluation import pooled_score, score_changepoints

    scored = [f for f in fits if "changepoints" in f and f.get("demo") in switches]
    if not scored:
        return None
    precision, recall, f1 = pooled_score(
        score_changepoints(
            f["changepoints"][1:-1], switches[f["demo"]], tolerance=f["segmentation_window_frames"]
        )
        for f in scored
    )
    return {
        "precision": precision,
        "recall": recall,
        "f1": f1,
        "n_fits": len(scored),
        "tolerance_frames": sorted({int(f["segmentation_window_frames"]) for f in scored}),
    }


def auto_stream_weights(dataset: str | Path, episode: int, overrides: Sequence[str] = ()) -> dict[str, float]:
    """Label-free segmentation weights (``lerobot_forcemap.segmentation.auto_weights``: jerk contrast)
    of one demonstration's streams, as the policy builds them (window scaled to the dataset fps).
    Streams the dataset lacks get weight 0. Returns ``{stream: weight}`` for ``stream_weights``."""
    from lerobot_forcemap.cli.fit import make_config
    from lerobot_forcemap.segmentation import auto_weights
    from lerobot_forcemap.skill.fit import episode_streams, segmentation_config
    from lerobot_policy_forcemap.modeling_forcemap import load_episodes

    cfg = make_config([episode], overrides)
    episodes, _, fps, _ = load_episodes(Path(dataset), cfg)
    params = cfg.skill_params()
    streams = episode_streams(episodes[0], params)
    weights = auto_weights(streams, segmentation_config(params, fps))
    return {name: float(weights.get(name, 0.0)) for name in cfg.stream_weights}
