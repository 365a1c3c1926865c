"""Demonstrations -> segments -> one arm map and one gripper map per segment (paper §III, §IV-C).

1. Segment every chosen episode (``config.segments``): multimodal probabilistic segmentation of the
   position, wrist-force, joint, gripper and finger-force streams with the window scaled to the
   dataset fps; or the dataset's ``segment_index`` column; or one segment. Several episodes are
   aligned segment by segment, so their segment counts must agree.
2. Anchor: a segment whose (first) demonstration comes within ``anchor_radius`` of an object
   (``<obj>_x/_y/_z`` in the environment state, its position at the same frames) that stays within
   ``static_tolerance`` during the segment in every episode is expressed in that object's frame
   (positions, forces and orientations), in every episode with that episode's object pose at the
   segment's first frame: that is the pose the policy observes when the segment starts and
   re-anchors to. Objects may move between segments (pushed, flipped); an object moving during the
   segment (carried or pushed by the robot) is not its anchor.
3. Fit per segment, in parallel in time (paper §IV-C): the arm map (3-D positions with the wrist
   force points, orientations SLERPed along the time law; space-time with ``time_scale``) and the
   gripper map (closure with the finger force as a reaction pointing towards "open"; space-time with
   ``gripper_time_scale``, ``gripper_nodes_per_second`` nodes per second).

Segment s of an episode with changepoints c is frames ``[c_s, c_{s+1}]`` (the boundary frame is
shared with the next segment, so consecutive maps meet); the last segment ends at the last frame.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap.elmap import ElasticMapFit, fit_force_elastic_map
from lerobot_forcemap.segmentation import (
    AUTHORS_RATE_HZ,
    AUTHORS_WINDOW_S,
    SegmentationConfig,
    Stream,
    segment_streams,
)
from lerobot_forcemap.skill.episodes import EpisodeArrays
from lerobot_forcemap.skill.model import FittedSkill, SegmentMaps
from lerobot_forcemap.skill.placement import (
    IDENTITY_POSE,
    ObjectSlot,
    object_poses,
    object_positions,
    object_slots,
    to_object_frame,
)
from lerobot_policy_forcemap.configuration_forcemap import DEFAULT_STREAM_WEIGHTS, ForceMapConfig

logger = logging.getLogger(__name__)

__all__ = [
    "FitReport",
    "segmentation_config",
    "episode_streams",
    "segment_episode",
    "static_objects",
    "choose_anchor",
    "segment_anchor",
    "segment_frames",
    "fit_skill",
]

Array = NDArray[np.float64]
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
                "last_step": a.last_step,
                "last_spring_step": a.last_spring_step,
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


#: the config field naming the dataset feature each segmentation stream reads
STREAM_FEATURE_FIELDS = {
    "position": "pose_key",
    "wrist_force": "force_key",
    "joints": "joints_key",
    "gripper": "gripper_key",
    "finger_force": "finger_force_key",
}


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
        weight = float(config.stream_weights[name])
        if values is None and weight > 0 and weight != DEFAULT_STREAM_WEIGHTS[name]:
            # a default weight of a stream the dataset lacks is skipped quietly (one config serves every
            # task); a weight someone set is not
            logger.warning(
                "episode %d: stream_weights[%r]=%g is set, but the dataset has no %r feature for it; that stream "
                "is left out of the segmentation",
                ep.episode, name, weight, getattr(config, STREAM_FEATURE_FIELDS[name]),
            )  # fmt: skip
        if values is None or weight <= 0:
            continue
        threshold = float(config.stream_thresholds[name])
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
    changepoints = np.concatenate([[0], np.flatnonzero(steps) + 1, [len(labels)]]).astype(np.int64)
    if len(changepoints) > 2 and changepoints[-2] == len(labels) - 1:
        # A label on the last frame only (a recorder that stops on success logs the "done" phase once):
        # segments share their boundary frame, so that frame already ends the previous segment.
        logger.warning(
            "feature %r, episode %d: label %d occurs on the last frame (%d) only; that frame ends segment %d "
            "instead of being a segment of its own (a segment needs >= 2 frames)",
            column, episode, int(labels[-1]), len(labels) - 1, int(labels[-1]) - 1,
        )  # fmt: skip
        changepoints = np.delete(changepoints, -2)
    return changepoints


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
    if len(result.rejected):
        logger.warning(
            "episode %d: min_segment_s=%g (%d frames) dropped the changepoint(s) at frame(s) %s; kept %s",
            ep.episode, config.min_segment_s, seg_cfg.min_segment_frames, result.rejected.tolist(),
            result.changepoints.tolist(),
        )  # fmt: skip
    return np.asarray(result.changepoints, dtype=np.int64)


def segment_frames(changepoints: NDArray[np.int64], s: int) -> NDArray[np.int64]:
    """Frame indices of segment s: ``[c_s, c_{s+1}]``, the last segment ``[c_s, T-1]``."""
    T = int(changepoints[-1])
    stop = min(int(changepoints[s + 1]), T - 1)
    return np.arange(int(changepoints[s]), stop + 1)


def static_objects(
    episodes: list[EpisodeArrays],
    slots: tuple[ObjectSlot, ...],
    tolerance: float,
    frames: list[NDArray[np.int64]] | None = None,
) -> list[ObjectSlot]:
    """Objects whose position moves less than ``tolerance`` (m) within every episode, or within the
    given per-episode ``frames`` (one segment): no carried or pushed objects."""
    out = []
    for slot in slots:
        moved = max(
            float(
                np.max(
                    np.ptp(ep.env_state[slice(None) if fr is None else fr][:, list(slot.position)], axis=0)
                )
            )
            for ep, fr in zip(episodes, frames or [None] * len(episodes), strict=True)
        )
        if moved < tolerance:
            out.append(slot)
    return out


def choose_anchor(
    positions: Array, poses: dict[str, Array], candidates: list[ObjectSlot], radius: float
) -> str:
    """The nearest candidate object coming within ``radius`` of the positions ``(T, 3)``, or "".

    ``poses[name]``: the object's pose ``(7,)``, or its poses at the same frames ``(T, 7)``."""
    best, best_d = "", np.inf
    for slot in candidates:
        d = float(np.min(np.linalg.norm(positions - np.asarray(poses[slot.name])[..., :3], axis=-1)))
        if d < radius and d < best_d:
            best, best_d = slot.name, d
    return best


def segment_anchor(
    positions: Array,
    env_state: Array,
    slots: tuple[ObjectSlot, ...],
    static: list[ObjectSlot],
    radius: float,
    *,
    by_moved_object: bool = False,
) -> str:
    """The anchor of one segment (positions ``(T, 3)`` of the robot, environment state ``(T, E)``).

    Only objects at rest during the segment (``static``) can be anchors: the static object nearest to
    the robot's path, within ``radius``. With ``by_moved_object``, a segment in which the robot moves
    an object (one that comes within ``radius`` of its path and is not at rest: carried, pushed) is
    about where that object goes: its anchor is the static object nearest to the moved object's final
    position (within ``radius``: a book pushed against a wall), or none (an object lifted into free
    space or tipped over on the table: the segment follows its neighbours)."""
    rest = {c.name for c in static}
    moved = [
        slot
        for slot in slots
        if by_moved_object
        and slot.name not in rest
        and float(np.min(np.linalg.norm(positions - object_positions(env_state, slot), axis=1))) < radius
    ]
    if moved:
        reference = np.stack([object_positions(env_state, slot)[-1] for slot in moved])
        track = {c.name: object_positions(env_state, c)[-1] for c in static}
    else:
        reference = positions
        track = {c.name: object_positions(env_state, c) for c in static}
    return choose_anchor(reference, track, static, radius)


def _n_nodes(params: dict, config: ForceMapConfig, duration: float, n_samples: int) -> int:
    if params.get("n_nodes") is not None:
        return int(params["n_nodes"])
    n = int(round(config.nodes_per_second * duration)) + 1
    return max(int(config.min_nodes), min(n, max(n_samples, 3)))


def _n_gripper_nodes(config: ForceMapConfig, fps: float, duration: float, n_samples: int) -> int:
    """Gripper-map nodes: ``gripper_nodes_per_second`` (default the fps: one per control period)."""
    rate = fps if config.gripper_nodes_per_second is None else float(config.gripper_nodes_per_second)
    n = int(round(rate * duration)) + 1
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
    if env_state_names and all(ep.env_state is not None for ep in episodes):
        slots = object_slots(env_state_names)
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
        anchor = ""
        if slots:
            static = static_objects(episodes, slots, config.static_tolerance, frames)
            anchor = segment_anchor(
                first.pose[frames[0], :3],
                first.env_state[frames[0]],
                slots,
                static,
                config.anchor_radius,
                by_moved_object=config.anchor_by_moved_object,
            )
        # the frame each episode's data is stored in: the anchor's pose at the segment's first frame
        seg_poses = [
            object_poses(ep.env_state[fr[0]], slots)[anchor] if anchor else None
            for ep, fr in zip(episodes, frames, strict=True)
        ]
        xs, fs, qs, ts, gs, gfs = [], [], [], [], [], []
        for ep, fr, pose in zip(episodes, frames, seg_poses, strict=True):
            x, f, q = ep.pose[fr, :3], ep.force[fr], ep.pose[fr, 3:7]
            if anchor:
                x, f, q = to_object_frame(pose, x, f, q)
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
        ng = _n_gripper_nodes(config, fps, duration, len(frames[0]))
        vg = float(p["gripper_time_scale"])
        gfs = gfs if len(gfs) == len(gs) else None
        if vg > 0:  # space-time gripper map: (closure, v_g t), the finger force on the closure only
            gs = [np.column_stack([g, vg * t]) for g, t in zip(gs, ts, strict=True)]
            if gfs is not None:
                gfs = [np.column_stack([gf, np.zeros(len(gf))]) for gf in gfs]
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
                gfs,
                n_nodes=ng,
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
        for what, fit in (("arm", arm), ("gripper", grip)):
            if fit.stop_reason == "max_iter":
                # the EM still moved: these nodes are one iterate of many, not a fixed point
                logger.warning(
                    "segment %d: the %s map's EM stopped at max_iter=%d without converging (%d capped "
                    "node-axes; nodes still moved up to %.3g and spring lengths up to %.3g in the last "
                    "iteration, where the stop test needs both <= %.3g); its nodes may change by about that "
                    "much with max_iter. A stiffer map (stiffness) caps fewer nodes.",
                    s,
                    what,
                    fit.n_iter,
                    len(fit.capped_nodes),
                    fit.last_step,
                    fit.last_spring_step,
                    fit.step_tolerance,
                )
        segments.append(
            SegmentMaps(
                nodes=arm.nodes[:, :3],
                node_times=arm.node_times,
                orientations=arm.orientations,
                gripper_nodes=grip.nodes[:, :1],
                gripper_node_times=grip.node_times,
                duration=duration,
                anchor=anchor,
                anchor_pose=seg_poses[0] if anchor else IDENTITY_POSE.copy(),
                anchor_initial_pose=scene[0][anchor] if anchor else IDENTITY_POSE.copy(),
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
