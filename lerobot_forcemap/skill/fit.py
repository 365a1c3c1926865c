"""Demonstrations -> segments -> one arm map and one gripper map per segment (paper §III, §IV-C).

1. Segment every chosen episode (``segments``): multimodal probabilistic segmentation of the
   position, wrist-force, joint, gripper and finger-force streams, plus the contact events
   (touch-downs, lift-offs) when the dataset has a ``contact`` column, with the windows in seconds
   converted at the dataset fps; or the dataset's ``segment_index`` column; or one segment. Several
   episodes are aligned segment by segment, so their segment counts must agree.
2. Anchor: a segment whose (first) demonstration comes within ``anchor_radius`` of an object
   (``<obj>_x/_y/_z`` in the environment state, its position at the same frames) that stays within
   ``static_tolerance`` during the segment in every episode is expressed in that object's frame
   (positions, forces and orientations), in every episode with that episode's object pose at the
   segment's first frame: that is the pose the policy observes when the segment starts and
   re-anchors to. Objects may move between segments (pushed, flipped); an object moving during the
   segment (carried or pushed by the robot) is not its anchor; with ``anchor_by_moved_object`` (the
   default) such a segment is anchored to the static object nearest to where the moved one ends (a
   book pushed upright against a wall: the wall, turned with it).
3. Fit per segment, in parallel in time (paper §IV-C): the arm map (3-D positions with the wrist
   force points, orientations SLERPed along the time law; space-time with ``time_scale``) and the
   gripper map (closure with the finger force as a reaction pointing towards "open"; space-time with
   ``gripper_time_scale``, ``gripper_nodes_per_second`` nodes per second). An arm map whose path
   misses the demonstration outside contact by more than ``path_tolerance_m`` is refitted with more
   nodes (``NODE_REFINEMENTS``).

Segment s of an episode with changepoints c is frames ``[c_s, c_{s+1}]`` (the boundary frame is
shared with the next segment); the last segment ends at the last frame. The segments are fitted
independently, then joined (``junctions.join_segments``): consecutive maps share a node at their
boundary's time, and the skill starts and ends at the demonstrated first and last sample.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, replace

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap import layout
from lerobot_forcemap.elmap import ElasticMapFit, fit_force_elastic_map
from lerobot_forcemap.elmap.timing import node_orientations
from lerobot_forcemap.geometry import polyline_distances
from lerobot_forcemap.segmentation import (
    EventStream,
    SegmentationConfig,
    SegmentationTiming,
    Stream,
    contact_event_streams,
    segment_streams,
)
from lerobot_forcemap.skill.episodes import EpisodeArrays
from lerobot_forcemap.skill.junctions import SegmentEnds, join_segments
from lerobot_forcemap.skill.model import FittedSkill, SegmentMaps
from lerobot_forcemap.skill.params import (
    DEFAULT_STREAM_WEIGHTS,
    EVENT_STREAMS,
    ArmMap,
    SegmentParams,
    SkillParams,
)
from lerobot_forcemap.skill.placement import (
    IDENTITY_POSE,
    ObjectSlot,
    object_distances,
    object_half_heights,
    object_poses,
    object_positions,
    object_slots,
    to_object_frame,
)
from lerobot_forcemap.skill.report import FitReport

logger = logging.getLogger(__name__)

__all__ = [
    "FitReport",
    "segmentation_config",
    "episode_streams",
    "segment_episode",
    "static_objects",
    "segment_anchor",
    "segment_frames",
    "fit_skill",
]

Array = NDArray[np.float64]


def segmentation_config(params: SkillParams, fps: float) -> SegmentationConfig:
    """The segmentation settings at ``fps``: ``segmentation_window_s`` and ``min_segment_s`` in
    seconds (``segmentation.SegmentationTiming``: min_run = the window, grace 4/64 of it, at least 5
    samples for the Savitzky–Golay order 4)."""
    seg = params.segmentation
    timing = SegmentationTiming(window_s=seg.segmentation_window_s, min_segment_s=seg.min_segment_s)
    return timing.config(
        fps, mode=seg.segmentation_mode, changepoints=seg.changepoints, seed=int(seg.segmentation_seed)
    )


#: the setting (``Columns`` field) naming the dataset feature each segmentation stream reads
STREAM_FEATURE_FIELDS = {
    "position": "pose_key",
    "wrist_force": "force_key",
    "joints": "joints_key",
    "gripper": "gripper_key",
    "finger_force": "finger_force_key",
}


def episode_streams(ep: EpisodeArrays, params: SkillParams) -> list[Stream | EventStream]:
    """Segmentation streams of one episode (those with a weight > 0 whose data the dataset has): the
    signal streams, and the contact events (``touch_down``, ``lift_off``) when it has a contact column."""
    sources = {
        "position": ep.pose[:, :3],
        "wrist_force": ep.measured_force if ep.has_force else None,
        "joints": ep.joints,
        "gripper": ep.gripper,
        "finger_force": ep.finger_force,
    }
    seg = params.segmentation
    streams: list[Stream | EventStream] = []
    for name, values in sources.items():
        weight = float(seg.stream_weights[name])
        if values is None:
            _warn_missing(ep, name, weight, getattr(params.columns, STREAM_FEATURE_FIELDS[name]))
        elif weight > 0:
            threshold = float(seg.stream_thresholds[name])
            streams.append(Stream(name, values, ep.times, weight=weight, threshold=threshold))
    weights = {name: float(seg.stream_weights[name]) for name in EVENT_STREAMS}
    if ep.contact is None:
        for name in EVENT_STREAMS:
            _warn_missing(ep, name, weights[name], layout.CONTACT)
    else:
        streams += contact_event_streams(ep.times, ep.contact_intervals(), weights=weights)
    if not streams:
        raise ValueError(
            f"stream_weights={seg.stream_weights}: no stream with a weight > 0 has data "
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


def segment_episode(ep: EpisodeArrays, params: SkillParams, fps: float) -> NDArray[np.int64]:
    """Changepoints (K+1,) of one episode: first 0, last T."""
    T = ep.n_frames
    source, column = params.segmentation.segments, params.columns.segment_column
    if source == "none":
        return np.array([0, T], dtype=np.int64)
    if source == "dataset":
        if ep.segment_labels is None:
            raise ValueError(
                f"segments='dataset': the dataset has no {column!r} column "
                "(run `forcemap segment` first, set segment_column, or use segments='auto')"
            )
        return _labels_to_changepoints(ep.segment_labels, ep.episode, column)
    seg_cfg = segmentation_config(params, fps)
    try:
        result = segment_streams(episode_streams(ep, params), seg_cfg)
    except ValueError as err:
        raise ValueError(f"episode {ep.episode}: segmentation failed: {err}") from err
    if len(result.rejected):
        logger.warning(
            "episode %d: min_segment_s=%g (%d frames) dropped the changepoint(s) at frame(s) %s; kept %s",
            ep.episode, params.segmentation.min_segment_s, seg_cfg.min_segment_frames, result.rejected.tolist(),
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


def _nearest_within(distances: dict[str, Array], radius: float) -> str:
    """The object whose least distance (``{name: (T,)}``, m) is smallest and below ``radius``, or ""."""
    best, best_d = "", np.inf
    for name, d in distances.items():
        d = float(np.min(d))
        if d < radius and d < best_d:
            best, best_d = name, d
    return best


def segment_anchor(
    positions: Array,
    env_state: Array,
    slots: tuple[ObjectSlot, ...],
    static: list[ObjectSlot],
    radius: float,
    *,
    by_moved_object: bool = False,
    surface: bool = True,
) -> str:
    """The anchor of one segment (positions ``(T, 3)`` of the robot, environment state ``(T, E)``).

    Only objects at rest during the segment (``static``) can be anchors: the static object nearest to
    the robot's path, within ``radius`` (with ``surface``, of its bounding box when the state gives its
    extents, :func:`object_distances`). With ``by_moved_object``, a segment in which the robot moves
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
        and float(np.min(object_distances(positions, env_state, slot, surface))) < radius
    ]
    if moved:  # each static object's distance to where the moved objects end (to their boxes)
        last = np.asarray(env_state)[-1:]
        distances = {
            c.name: np.array(
                [object_distances(object_positions(last, c), last, m, surface)[0] for m in moved]
            )
            for c in static
        }
        return _nearest_within(distances, radius)
    return _nearest_within(
        {c.name: object_distances(positions, env_state, c, surface) for c in static}, radius
    )


#: the node counts, as multiples of ``nodes_per_second``'s, a segment's arm map is refitted with (in
#: this order, while it stays farther than ``path_tolerance_m`` from the demonstration)
NODE_REFINEMENTS = (1.5, 2.0, 3.0)
#: the closest refit is kept only if it comes at least this fraction closer to the demonstration than
#: the first fit (a sharp corner's does: 30 % on the UR5e wipe's approach)
REFIT_MIN_GAIN = 0.1


def _n_nodes(arm: ArmMap, duration: float, n_samples: int) -> int:
    if arm.n_nodes is not None:
        return int(arm.n_nodes)
    n = int(round(arm.nodes_per_second * duration)) + 1
    return max(int(arm.min_nodes), min(n, max(n_samples, 3)))


def _n_gripper_nodes(p: SegmentParams, fps: float, duration: float, n_samples: int) -> int:
    """Gripper-map nodes: ``gripper_nodes_per_second`` (default the fps: one per control period)."""
    per_second = p.gripper.gripper_nodes_per_second
    rate = fps if per_second is None else float(per_second)
    n = int(round(rate * duration)) + 1
    return max(int(p.arm.min_nodes), min(n, max(n_samples, 3)))


def fit_skill(
    episodes: list[EpisodeArrays],
    params: SkillParams,
    fps: float,
    env_state_names: list[str] | None = None,
) -> tuple[FittedSkill, FitReport]:
    """Segment and fit the demonstrations (module docstring). Returns the skill and diagnostics.

    ``fps``: the dataset's frame rate (Hz); ``env_state_names``: the names of the environment-state
    columns (objects ``<obj>_x/_y/_z``), None when the episodes carry none.
    """
    if not episodes:
        raise ValueError("fit_skill: no episodes")
    if not fps or fps <= 0:
        raise ValueError(f"fit_skill: fps must be > 0, got {fps}")
    t0 = time.perf_counter()
    changepoints = _changepoints(episodes, params, fps)
    slots: tuple[ObjectSlot, ...] = ()
    if env_state_names and all(ep.env_state is not None for ep in episodes):
        slots = object_slots(env_state_names)
    scene = object_poses(episodes[0].env_state[0], slots) if slots else {}
    segments: list[SegmentMaps] = []
    arm_fits, gripper_fits, ends = [], [], []
    for s in range(len(changepoints[0]) - 1):
        frames = _frames_of_segment(episodes, changepoints, s)
        anchor = _anchor_of_segment(episodes, frames, slots, params) if slots else ""
        maps, arm, grip, end = _fit_segment(episodes, frames, slots, anchor, params.segment(s), fps, s)
        initial = scene[anchor] if anchor else IDENTITY_POSE.copy()
        segments.append(replace(maps, anchor_initial_pose=initial))
        arm_fits.append(arm)
        gripper_fits.append(grip)
        ends.append(end)
    # an end node within a frame of a boundary is the boundary (junctions module docstring)
    skill = FittedSkill(join_segments(segments, ends[0], ends[-1], merge_s=1.0 / fps))
    report = FitReport.build(
        skill, episodes, changepoints, arm_fits, gripper_fits, fps, time.perf_counter() - t0
    )
    return skill, report


def _warn_missing(ep: EpisodeArrays, name: str, weight: float, feature: str) -> None:
    """A stream the dataset has no data for: a default weight is skipped quietly (one config serves every
    task), a weight someone set is not."""
    if weight > 0 and weight != DEFAULT_STREAM_WEIGHTS[name]:
        logger.warning(
            "episode %d: stream_weights[%r]=%g is set, but the dataset has no %r feature for it; that stream "
            "is left out of the segmentation",
            ep.episode, name, weight, feature,
        )  # fmt: skip


def _changepoints(episodes: list[EpisodeArrays], params: SkillParams, fps: float) -> list[NDArray[np.int64]]:
    """Changepoints of every episode; their segment counts must agree (the maps pool segment by segment)."""
    changepoints = [segment_episode(ep, params, fps) for ep in episodes]
    counts = [len(c) - 1 for c in changepoints]
    if len(set(counts)) > 1:
        detail = ", ".join(f"episode {ep.episode}: {n}" for ep, n in zip(episodes, counts, strict=True))
        raise ValueError(
            f"segment counts differ between the chosen episodes ({detail}); several demonstrations are "
            "mapped segment by segment, so they need the same number of segments. Pick episodes that "
            "agree, write consistent labels with `forcemap segment` (segments='dataset'), or use segments='none'."
        )
    return changepoints


def _frames_of_segment(
    episodes: list[EpisodeArrays], changepoints: list[NDArray[np.int64]], s: int
) -> list[NDArray[np.int64]]:
    frames = [segment_frames(c, s) for c in changepoints]
    for ep, fr in zip(episodes, frames, strict=True):
        if len(fr) < 2:
            raise ValueError(f"episode {ep.episode}, segment {s}: {len(fr)} frame(s); a segment needs >= 2")
    return frames


def _anchor_of_segment(
    episodes: list[EpisodeArrays],
    frames: list[NDArray[np.int64]],
    slots: tuple[ObjectSlot, ...],
    params: SkillParams,
) -> str:
    """The segment's anchor, chosen on the first episode among objects at rest in every episode."""
    a = params.anchoring
    static = static_objects(episodes, slots, a.static_tolerance, frames)
    first = episodes[0]
    return segment_anchor(
        first.pose[frames[0], :3],
        first.env_state[frames[0]],
        slots,
        static,
        a.anchor_radius,
        by_moved_object=a.anchor_by_moved_object,
        surface=a.anchor_to_surface,
    )


@dataclass(frozen=True)
class _SegmentData:
    """One segment of every episode: positions xs (T, 3), forces fs (T, 3) and orientations qs (T, 4)
    in the anchor's frame, times ts (T,) from the segment's start, gripper gs (T, 1) and its force
    gfs (T, 1) (None unless every episode has finger forces)."""

    xs: list[Array]
    fs: list[Array]
    qs: list[Array]
    ts: list[Array]
    gs: list[Array]
    gfs: list[Array] | None


def _segment_data(
    episodes: list[EpisodeArrays], frames: list[NDArray[np.int64]], poses: list[Array | None]
) -> _SegmentData:
    """Each episode's segment, in its anchor's pose (7,) at the segment's first frame (None: base frame)."""
    xs, fs, qs, ts, gs, gfs = [], [], [], [], [], []
    for ep, fr, pose in zip(episodes, frames, poses, strict=True):
        x, f, q = ep.pose[fr, :3], ep.force[fr], ep.pose[fr, 3:7]
        if pose is not None:
            x, f, q = to_object_frame(pose, x, f, q)
        xs.append(x)
        fs.append(f)
        qs.append(q)
        ts.append(ep.times[fr] - ep.times[fr[0]])
        gs.append(ep.gripper[fr][:, None])
        if ep.gripper_force is not None:
            gfs.append(ep.gripper_force[fr][:, None])
    return _SegmentData(xs, fs, qs, ts, gs, gfs if len(gfs) == len(gs) else None)


def _fit_segment(
    episodes: list[EpisodeArrays],
    frames: list[NDArray[np.int64]],
    slots: tuple[ObjectSlot, ...],
    anchor: str,
    p: SegmentParams,
    fps: float,
    s: int,
) -> tuple[SegmentMaps, ElasticMapFit, ElasticMapFit, SegmentEnds]:
    """The arm and gripper maps of segment ``s`` (its ``anchor_initial_pose`` is the caller's) and its
    demonstrated ends."""
    # the frame each episode's data is stored in: the anchor's pose at the segment's first frame
    poses = [
        object_poses(ep.env_state[fr[0]], slots)[anchor] if anchor else None
        for ep, fr in zip(episodes, frames, strict=True)
    ]
    data = _segment_data(episodes, frames, poses)
    duration = float(np.mean([t[-1] for t in data.ts]))
    n_samples = len(frames[0])
    try:
        arm = _fit_arm_within_tolerance(data, p.arm, duration, n_samples, episodes[0].has_force)
        grip = _fit_gripper(data, p, _n_gripper_nodes(p, fps, duration, n_samples))
    except ValueError as err:
        raise ValueError(f"segment {s} (episodes {[ep.episode for ep in episodes]}): {err}") from err
    for what, fit in (("arm", arm), ("gripper", grip)):
        _warn_unconverged(s, what, fit)
    first = episodes[0].env_state[frames[0][0]] if anchor else None
    maps = SegmentMaps(
        nodes=arm.nodes[:, :3],
        node_times=arm.node_times,
        orientations=arm.orientations,
        gripper_nodes=grip.nodes[:, :1],
        gripper_node_times=grip.node_times,
        duration=duration,
        anchor=anchor,
        anchor_pose=poses[0] if anchor else IDENTITY_POSE.copy(),
        anchor_half_height=object_half_heights(first, slots).get(anchor, 0.0) if anchor else 0.0,
    )
    return maps, arm, grip, _ends(data, duration)


def _ends(data: _SegmentData, duration: float) -> SegmentEnds:
    """The segment's first and last demonstrated sample in its frame, means over the episodes (the
    orientations sign-aligned, as the maps' own)."""
    fractions = [t / t[-1] if t[-1] > 0 else np.zeros_like(t) for t in data.ts]
    return SegmentEnds(
        positions=np.stack(
            [np.mean([x[0] for x in data.xs], axis=0), np.mean([x[-1] for x in data.xs], axis=0)]
        ),
        orientations=node_orientations(np.array([0.0, duration]), fractions, data.qs, duration),
        gripper=np.stack(
            [np.mean([g[0] for g in data.gs], axis=0), np.mean([g[-1] for g in data.gs], axis=0)]
        ),
    )


def _fit_arm_within_tolerance(
    data: _SegmentData, arm: ArmMap, duration: float, n_samples: int, has_force: bool
) -> ElasticMapFit:
    """The arm map with ``_n_nodes`` nodes; with ``path_tolerance_m`` (and ``n_nodes`` None) refitted
    with ``NODE_REFINEMENTS`` times the node density (at most one node per sample) while its path stays
    farther than the tolerance from a demonstrated sample outside contact (``_free_samples``).

    Nodes spaced evenly in time cut a corner that the demonstration turns within a node spacing; a
    smooth path keeps its count. A refit that comes no closer ends the search; the closest fit is kept
    if it is ``REFIT_MIN_GAIN`` closer than the first, else the first is: more nodes do not fix what the
    map misses there (demonstrations that differ from each other, a contact's effect past the margin)."""
    n_nodes = _n_nodes(arm, duration, n_samples)
    fit = _fit_arm(data, arm, n_nodes, has_force)
    tolerance = arm.path_tolerance_m
    if tolerance is None or arm.n_nodes is not None:
        return fit
    free = _free_samples(data, fit, float(arm.f_contact) if has_force else None)
    first_error = error = _path_error(free, fit)
    best = fit
    for factor in NODE_REFINEMENTS:
        n = min(int(round(factor * (n_nodes - 1))) + 1, max(n_samples, 3))
        if error <= tolerance or n <= best.n_nodes:
            break
        refit = _fit_arm(data, arm, n, has_force)
        refit_error = _path_error(free, refit)
        if refit_error >= error:
            break
        best, error = refit, refit_error
    if error > (1.0 - REFIT_MIN_GAIN) * first_error:
        return fit
    if best is not fit:
        logger.info(
            "arm map refitted with %d nodes instead of %d: %.2f mm from the demonstration outside contact "
            "instead of %.2f mm (path_tolerance_m=%g)", best.n_nodes, n_nodes, 1e3 * error, 1e3 * first_error,
            tolerance,
        )  # fmt: skip
    return best


def _free_samples(data: _SegmentData, fit: ElasticMapFit, f_contact: float | None) -> list[Array]:
    """Per episode, the demonstrated positions ``(k, 3)`` the path tolerance holds at: those within the
    time span of the map's own nodes (before its first node and after its last, the junctions with the
    neighbouring segments set the path), more than one node spacing in time from every contact sample
    (force norm above ``f_contact``; None: no contact): the force points lift the map there on purpose,
    and its neighbouring nodes with it. Times are fractions of each episode's segment."""
    scale = fit.duration if fit.duration > 0 else 1.0
    first, last = fit.node_times[0] / scale, fit.node_times[-1] / scale
    spacing = 1.0 / (fit.n_nodes - 1)
    free = []
    for x, f, t in zip(data.xs, data.fs, data.ts, strict=True):
        frac = t / t[-1] if t[-1] > 0 else np.zeros_like(t)
        keep = (frac >= first) & (frac <= last)
        touch = frac[np.linalg.norm(f, axis=1) > f_contact] if f_contact is not None else frac[:0]
        if len(touch):
            after = np.minimum(np.searchsorted(touch, frac), len(touch) - 1)
            before = np.maximum(after - 1, 0)
            gap = np.minimum(np.abs(frac - touch[after]), np.abs(frac - touch[before]))
            keep &= gap > spacing
        free.append(x[keep])
    return free


def _path_error(free: list[Array], fit: ElasticMapFit) -> float:
    """The largest distance (m) from the positions ``free`` to the map's path: its nodes' positions
    joined by straight lines (a space-time map's time coordinate left out); 0 without positions."""
    return max((float(polyline_distances(x, fit.nodes[:, :3]).max()) for x in free if len(x)), default=0.0)


def _fit_arm(data: _SegmentData, arm: ArmMap, n_nodes: int, has_force: bool) -> ElasticMapFit:
    """Positions with the wrist force points; with ``time_scale`` v > 0 in space-time (x, v t), no
    force on the time axis."""
    xs, fs = data.xs, data.fs
    v = float(arm.time_scale)
    if v > 0:
        xs = [np.column_stack([x, v * t]) for x, t in zip(xs, data.ts, strict=True)]
        fs = [np.column_stack([f, np.zeros(len(f))]) for f in fs]
    return fit_force_elastic_map(
        xs,
        fs if has_force else None,
        n_nodes=n_nodes,
        lam=arm.lam,
        mu=arm.mu,
        delta=arm.delta,
        f_contact=arm.f_contact,
        stiffness=arm.stiffness,
        rho_max=arm.rho_max,
        force_limit=arm.force_limit,
        times=data.ts,
        orientations=data.qs,
        max_iter=int(arm.max_iter),
    )


def _fit_gripper(data: _SegmentData, p: SegmentParams, n_nodes: int) -> ElasticMapFit:
    """The gripper coordinate with the finger force; with ``gripper_time_scale`` v_g > 0 in space-time
    (closure, v_g t), the finger force on the closure only. ``rho_max`` and ``max_iter`` are the arm's."""
    g = p.gripper
    gs, gfs = data.gs, data.gfs
    vg = float(g.gripper_time_scale)
    if vg > 0:
        gs = [np.column_stack([x, vg * t]) for x, t in zip(gs, data.ts, strict=True)]
        if gfs is not None:
            gfs = [np.column_stack([gf, np.zeros(len(gf))]) for gf in gfs]
    return fit_force_elastic_map(
        gs,
        gfs,
        n_nodes=n_nodes,
        lam=g.gripper_lam,
        mu=g.gripper_mu,
        delta=g.gripper_delta,
        f_contact=g.gripper_f_contact,
        stiffness=g.gripper_stiffness,
        rho_max=p.arm.rho_max,
        times=data.ts,
        max_iter=int(p.arm.max_iter),
    )


def _warn_unconverged(s: int, what: str, fit: ElasticMapFit) -> None:
    if fit.stop_reason == "max_iter":
        # the EM still moved: these nodes are one iterate of many, not a fixed point
        logger.warning(
            "segment %d: the %s map's EM stopped at max_iter=%d without converging (%d capped "
            "node-axes; nodes still moved up to %.3g and spring lengths up to %.3g in the last "
            "iteration, where the stop test needs both <= %.3g); its nodes may change by about that "
            "much with max_iter. A stiffer map (stiffness) caps fewer nodes.",
            s, what, fit.n_iter, len(fit.capped_nodes), fit.last_step, fit.last_spring_step,
            fit.step_tolerance,
        )  # fmt: skip
