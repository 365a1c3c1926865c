"""Demonstrations -> segments -> one arm map and one gripper map per segment (paper §III, §IV-C).

1. Segment every chosen episode (``config.segments``): multimodal probabilistic segmentation of the
   position, wrist-force, joint, gripper and finger-force streams with the window scaled to the
   dataset fps; or the dataset's ``segment_index`` column; or one segment. Several episodes are
   aligned segment by segment, so their segment counts must agree.
2. Anchor: a segment whose (first) demonstration comes within ``anchor_radius`` of a static object
   (``<obj>_x/_y/_z`` in the environment state) is expressed in that object's frame (positions,
   forces and orientations), in every episode with that episode's object pose at its first frame.
3. Fit per segment, in parallel in time (paper §IV-C): the arm map (3-D positions with the wrist
   force points, orientations SLERPed along the time law) and the gripper map (1-D closure with
   the finger force as a reaction pointing towards "open").

Segment s of an episode with changepoints c is frames ``[c_s, c_{s+1}]`` (the boundary frame is
shared with the next segment, so consecutive maps meet); the last segment ends at the last frame.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap.elmap import ElasticMapFit, fit_force_elastic_map
from lerobot_forcemap.segmentation import SegmentationConfig, Stream, segment_streams

from .anchoring import IDENTITY_POSE, ObjectSlot, object_poses, object_slots, to_object_frame
from .configuration_forcemap import AUTHORS_WINDOW_S, ForceMapConfig
from .episodes import EpisodeArrays
from .skill import FittedSkill, SegmentMaps

__all__ = [
    "FitReport",
    "segmentation_config",
    "episode_streams",
    "segment_episode",
    "static_objects",
    "choose_anchor",
    "segment_frames",
    "fit_skill",
]

Array = NDArray[np.float64]
AUTHORS_RATE_HZ = 166.0
AUTHORS_GRACE = 4


@dataclass(frozen=True)
class FitReport:
    """Diagnostics of :func:`fit_skill`: changepoints per episode, per-segment fits, timing."""

    episodes: tuple[int, ...]
    changepoints: tuple[NDArray[np.int64], ...]
    anchors: tuple[str, ...]
    arm_fits: tuple[ElasticMapFit, ...]
    gripper_fits: tuple[ElasticMapFit, ...]
    seconds: float

    def summary(self) -> list[dict]:
        """One row per segment: anchor, nodes, EM iterations, stop reason, capped nodes, force points."""
        return [
            {
                "segment": s,
                "anchor": self.anchors[s],
                "n_nodes": a.n_nodes,
                "duration_s": a.duration,
                "n_iter": a.n_iter,
                "stop_reason": a.stop_reason,
                "n_force_points": a.n_force_points,
                "capped_nodes": int(len(a.capped_nodes)),
                "gripper_n_iter": g.n_iter,
                "gripper_force_points": g.n_force_points,
            }
            for s, (a, g) in enumerate(zip(self.arm_fits, self.gripper_fits, strict=True))
        ]


def segmentation_config(config: ForceMapConfig, fps: float) -> SegmentationConfig:
    """The segmentation settings with the window (and min_run, grace) scaled to ``fps``.

    The authors used window = min_run = 64 and grace = 4 samples at ~166 Hz; here the window is
    ``segmentation_window_s`` seconds (default 64/166 s), at least 5 samples (Savitzky–Golay order 4).
    """
    window = max(5, int(round(config.segmentation_window_s * fps)))
    grace = int(round(AUTHORS_GRACE * window / (AUTHORS_WINDOW_S * AUTHORS_RATE_HZ)))
    min_len = None if config.min_segment_s is None else max(1, int(round(config.min_segment_s * fps)))
    return SegmentationConfig(
        window=window,
        min_run=window,
        grace=grace,
        mode=config.segmentation_mode,
        changepoints=config.changepoints,
        seed=int(config.segmentation_seed),
        min_segment_length=min_len,
    )


def episode_streams(ep: EpisodeArrays, config: ForceMapConfig) -> list[Stream]:
    """Segmentation streams of one episode (those with a weight > 0 whose data the dataset has)."""
    sources = {
        "position": ep.pose[:, :3],
        "wrist_force": ep.force if ep.has_force else None,
        "joints": ep.joints,
        "gripper": ep.gripper,
        "finger_force": ep.finger_force,
    }
    streams = []
    for name, values in sources.items():
        weight = float(config.stream_weights.get(name, 0.0))
        if values is None or weight <= 0:
            continue
        threshold = float(config.stream_thresholds.get(name, 0.2))
        streams.append(Stream(name, values, ep.times, weight=weight, threshold=threshold))
    if not streams:
        raise ValueError(
            f"ForceMapConfig.stream_weights={config.stream_weights}: no stream with a weight > 0 has data "
            f"in episode {ep.episode}"
        )
    return streams


def _labels_to_changepoints(labels: NDArray[np.int64], episode: int, column: str) -> NDArray[np.int64]:
    steps = np.diff(labels)
    if labels[0] != 0 or np.any((steps != 0) & (steps != 1)):
        i = 0 if labels[0] != 0 else int(np.argmax((steps != 0) & (steps != 1))) + 1
        raise ValueError(
            f"feature {column!r}, episode {episode}, frame {i}: segment labels must start at 0 and "
            f"step by 1, got {int(labels[i])}"
        )
    return np.concatenate([[0], np.flatnonzero(steps) + 1, [len(labels)]]).astype(np.int64)


def segment_episode(ep: EpisodeArrays, config: ForceMapConfig, fps: float) -> NDArray[np.int64]:
    """Changepoints (K+1,) of one episode: first 0, last T."""
    T = ep.n_frames
    if config.segments == "none":
        return np.array([0, T], dtype=np.int64)
    if config.segments == "dataset":
        if ep.segment_labels is None:
            raise ValueError(
                f"ForceMapConfig.segments='dataset': the dataset has no {config.segment_column!r} column "
                "(run `forcemap segment` first, set segment_column, or use segments='auto')"
            )
        return _labels_to_changepoints(ep.segment_labels, ep.episode, config.segment_column)
    seg_cfg = segmentation_config(config, fps)
    try:
        result = segment_streams(episode_streams(ep, config), seg_cfg)
    except ValueError as err:
        raise ValueError(f"episode {ep.episode}: segmentation failed: {err}") from err
    return np.asarray(result.changepoints, dtype=np.int64)


def segment_frames(changepoints: NDArray[np.int64], s: int) -> NDArray[np.int64]:
    """Frame indices of segment s: ``[c_s, c_{s+1}]``, the last segment ``[c_s, T-1]``."""
    T = int(changepoints[-1])
    stop = min(int(changepoints[s + 1]), T - 1)
    return np.arange(int(changepoints[s]), stop + 1)


def static_objects(
    episodes: list[EpisodeArrays], slots: tuple[ObjectSlot, ...], tolerance: float
) -> list[ObjectSlot]:
    """Objects whose position moves less than ``tolerance`` (m) within every episode (no carried objects)."""
    out = []
    for slot in slots:
        moved = max(float(np.max(np.ptp(ep.env_state[:, list(slot.position)], axis=0))) for ep in episodes)
        if moved < tolerance:
            out.append(slot)
    return out


def choose_anchor(
    positions: Array, poses: dict[str, Array], candidates: list[ObjectSlot], radius: float
) -> str:
    """The nearest candidate object coming within ``radius`` of the positions ``(T, 3)``, or ""."""
    best, best_d = "", np.inf
    for slot in candidates:
        d = float(np.min(np.linalg.norm(positions - poses[slot.name][:3], axis=1)))
        if d < radius and d < best_d:
            best, best_d = slot.name, d
    return best


def _n_nodes(params: dict, config: ForceMapConfig, duration: float, n_samples: int) -> int:
    if params.get("n_nodes") is not None:
        return int(params["n_nodes"])
    n = int(round(config.nodes_per_second * duration)) + 1
    return max(int(config.min_nodes), min(n, max(n_samples, 3)))


def fit_skill(
    episodes: list[EpisodeArrays],
    config: ForceMapConfig,
    fps: float,
    env_state_names: list[str] | None = None,
) -> tuple[FittedSkill, FitReport]:
    """Segment and fit the demonstrations (module docstring). Returns the skill and diagnostics."""
    if not episodes:
        raise ValueError("fit_skill: no episodes")
    if not fps or fps <= 0:
        raise ValueError(f"fit_skill: fps must be > 0, got {fps}")
    t0 = time.perf_counter()
    changepoints = [segment_episode(ep, config, fps) for ep in episodes]
    counts = [len(c) - 1 for c in changepoints]
    if len(set(counts)) > 1:
        detail = ", ".join(f"episode {ep.episode}: {n}" for ep, n in zip(episodes, counts, strict=True))
        raise ValueError(
            f"segment counts differ between the chosen episodes ({detail}); several demonstrations are "
            "mapped segment by segment, so they need the same number of segments. Pick episodes that "
            "agree, write consistent labels with `forcemap segment` (segments='dataset'), or use segments='none'."
        )
    n_seg = counts[0]

    slots: tuple[ObjectSlot, ...] = ()
    candidates: list[ObjectSlot] = []
    if env_state_names and all(ep.env_state is not None for ep in episodes):
        slots = object_slots(env_state_names)
        candidates = static_objects(episodes, slots, config.static_tolerance)
    scene = [object_poses(ep.env_state[0], slots) if slots else {} for ep in episodes]

    segments, arm_fits, gripper_fits, anchors = [], [], [], []
    for s in range(n_seg):
        frames = [segment_frames(c, s) for c in changepoints]
        for ep, fr in zip(episodes, frames, strict=True):
            if len(fr) < 2:
                raise ValueError(
                    f"episode {ep.episode}, segment {s}: {len(fr)} frame(s); a segment needs >= 2"
                )
        first = episodes[0]
        anchor = choose_anchor(first.pose[frames[0], :3], scene[0], candidates, config.anchor_radius)
        xs, fs, qs, ts, gs, gfs = [], [], [], [], [], []
        for ep, fr, poses in zip(episodes, frames, scene, strict=True):
            x, f, q = ep.pose[fr, :3], ep.force[fr], ep.pose[fr, 3:7]
            if anchor:
                x, f, q = to_object_frame(poses[anchor], x, f, q)
            xs.append(x)
            fs.append(f)
            qs.append(q)
            ts.append(ep.times[fr] - ep.times[fr[0]])
            gs.append(ep.gripper[fr][:, None])
            if ep.gripper_force is not None:
                gfs.append(ep.gripper_force[fr][:, None])
        p = config.segment_params(s)
        duration = float(np.mean([t[-1] for t in ts]))
        n = _n_nodes(p, config, duration, len(frames[0]))
        v = float(p["time_scale"])
        if v > 0:  # space-time map: time as a 4th coordinate (m), no force on it
            xs_fit = [np.column_stack([x, v * t]) for x, t in zip(xs, ts, strict=True)]
            fs_fit = [np.column_stack([f, np.zeros(len(f))]) for f in fs]
        else:
            xs_fit, fs_fit = xs, fs
        try:
            arm = fit_force_elastic_map(
                xs_fit,
                fs_fit if first.has_force else None,
                n_nodes=n,
                lam=p["lam"],
                mu=p["mu"],
                delta=p["delta"],
                f_contact=p["f_contact"],
                stiffness=p["stiffness"],
                rho_max=p["rho_max"],
                force_limit=p["force_limit"],
                times=ts,
                orientations=qs,
                max_iter=int(config.max_iter),
            )
            grip = fit_force_elastic_map(
                gs,
                gfs if len(gfs) == len(gs) else None,
                n_nodes=n,
                lam=p["gripper_lam"],
                mu=p["gripper_mu"],
                delta=p["gripper_delta"],
                f_contact=p["gripper_f_contact"],
                stiffness=p["gripper_stiffness"],
                rho_max=p["rho_max"],
                times=ts,
                max_iter=int(config.max_iter),
            )
        except ValueError as err:
            raise ValueError(f"segment {s} (episodes {[ep.episode for ep in episodes]}): {err}") from err
        segments.append(
            SegmentMaps(
                nodes=arm.nodes[:, :3],
                node_times=arm.node_times,
                orientations=arm.orientations,
                gripper_nodes=grip.nodes,
                gripper_node_times=grip.node_times,
                duration=duration,
                anchor=anchor,
                anchor_pose=scene[0][anchor] if anchor else IDENTITY_POSE.copy(),
            )
        )
        arm_fits.append(arm)
        gripper_fits.append(grip)
        anchors.append(anchor)
    report = FitReport(
        episodes=tuple(ep.episode for ep in episodes),
        changepoints=tuple(changepoints),
        anchors=tuple(anchors),
        arm_fits=tuple(arm_fits),
        gripper_fits=tuple(gripper_fits),
        seconds=time.perf_counter() - t0,
    )
    return FittedSkill(tuple(segments)), report
