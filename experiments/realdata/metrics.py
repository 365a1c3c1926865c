"""The measurements of the real-data study, on arrays (pure NumPy; no LeRobot).

Every function takes one recording's frames: ``times (T,)`` s on the dataset's clock, demonstrated
positions ``(T, 3)`` m (the measured flange path ``observation.ee_pose``, or the demonstrated targets
``action`` where a target is compared frame by frame), the reproduction's targets ``(T, 3)`` m at the
same times, forces ``(T, 3)`` N, and contact intervals ``(K, 2)`` [touch-down, lift-off] s. Distances
are metres, reported by the caller in millimetres.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap.contact import ContactSurface, event_errors, intervals_to_mask, rms_ratio
from lerobot_forcemap.geometry import polyline_distances

__all__ = [
    "event_errors",
    "labelled_intervals",
    "changepoint_errors",
    "free_frames",
    "reaction_in_contact",
    "lift_at_largest_reaction",
    "largest_step",
    "distance_to_path",
    "lowest_point",
    "depth_below",
]

Array = NDArray[np.float64]


def labelled_intervals(events: Sequence[Mapping[str, object]]) -> Array:
    """(K, 2) [touch-down, lift-off] s from a recording's labels (``{"kind", "t"}`` in time order)."""
    down = [float(e["t"]) for e in events if e["kind"] == "touch_down"]
    up = [float(e["t"]) for e in events if e["kind"] == "lift_off"]
    return np.array(list(zip(down, up, strict=True)), dtype=np.float64).reshape(-1, 2)


def changepoint_errors(changepoints_s: Array, intervals: Array) -> Array:
    """(K, 2) signed time (s) from each labelled touch-down and lift-off to the nearest interior
    changepoint (NaN without one)."""
    inner = np.asarray(changepoints_s, dtype=np.float64)[1:-1]
    return np.stack([event_errors(inner, intervals[:, 0]), event_errors(inner, intervals[:, 1])], axis=1)


def free_frames(times: Array, intervals: Array, pad_s: float = 0.3) -> NDArray[np.bool_]:
    """(T,) bool: the frames at least ``pad_s`` away from every contact."""
    return ~intervals_to_mask(times, intervals, pad_s)


def reaction_in_contact(
    times: Array, reaction: Array, intervals: Array, surfaces: Sequence[ContactSurface]
) -> tuple[float, float, float]:
    """Over the frames inside the contacts: the fractions where the reaction points away from the surface
    (``normal · r > 0``) and into it (``< 0``), and the median of ``normal · r`` (N)."""
    along = []
    for (start, stop), surface in zip(intervals, surfaces, strict=True):
        inside = (times >= start) & (times <= stop)
        along.append(reaction[inside] @ surface.normal)
    values = np.concatenate(along) if along else np.zeros(0)
    if not values.size:
        return float("nan"), float("nan"), float("nan")
    return float(np.mean(values > 0)), float(np.mean(values < 0)), float(np.median(values))


def lift_at_largest_reaction(
    times: Array, reaction: Array, demo: Array, targets: Array, stiffness: float
) -> tuple[float, float, float, float]:
    """At the frame of the largest reaction: (its time s, its size N, Hooke's lift |F|/k m, the
    reproduction's lift m: how far the target stands from the demonstrated position along the force)."""
    size = np.linalg.norm(reaction, axis=1)
    k = int(np.argmax(size))
    if size[k] <= 0:
        return float("nan"), 0.0, 0.0, float("nan")
    direction = reaction[k] / size[k]
    return (
        float(times[k]),
        float(size[k]),
        float(size[k] / stiffness),
        float((targets[k] - demo[k]) @ direction),
    )


def largest_step(points: Array) -> float:
    """The largest distance (m) between consecutive points (N, 3)."""
    return float(np.max(np.linalg.norm(np.diff(points, axis=0), axis=1))) if len(points) > 1 else 0.0


def distance_to_path(points: Array, path: Array) -> Array:
    """(N,) distance (m) of each point to the polyline ``path (M, 3)``."""
    return polyline_distances(points, path)


def lowest_point(
    times: Array, demo: Array, targets: Array, interval: Array, margin_s: float, settle_s: float = 0.05
) -> tuple[float, float, float]:
    """A press: (the demonstration's lowest z in the contact, its lowest z held from ``settle_s`` after
    touch-down to lift-off: the press's depth, past the impact's overshoot of a frame or two, the
    reproduction's lowest z within ``margin_s`` of the contact), m."""
    inside = (times >= interval[0]) & (times <= interval[1])
    held = (times >= interval[0] + settle_s) & (times <= interval[1])
    near = (times >= interval[0] - margin_s) & (times <= interval[1] + margin_s)
    return float(demo[inside, 2].min()), float(demo[held, 2].min()), float(targets[near, 2].min())


def depth_below(surface: ContactSurface, targets: Array, times: Array, margin_s: float) -> float:
    """A wipe: how far the deepest target within ``margin_s`` of the contact lies below the surface
    through the demonstration's deepest contact sample (m; <= 0: none below)."""
    near = (times >= surface.interval[0] - margin_s) & (times <= surface.interval[1] + margin_s)
    return float(surface.depth_below(targets[near]).max())


def free_space_ratio(measured: Array, part: Array, free: NDArray[np.bool_]) -> float:
    """RMS of |part| over RMS of |measured| on the free frames (NaN when the measured force is zero)."""
    return rms_ratio(part, measured, free)
