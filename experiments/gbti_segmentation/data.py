"""The GBTI demos as the study uses them: the paper's streams, weightings and thresholds, and each demo
aligned onto evenly spaced frames with its reference events."""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from tqdm import tqdm

from lerobot_forcemap.data.recorder import gbti_keys, iter_gbti_demos
from lerobot_forcemap.data.transforms import align_recording
from lerobot_forcemap.segmentation.events import (
    EventThresholds,
    ReferenceEvents,
    merge_events,
    reference_events,
)
from lerobot_forcemap.shared_data import find_shared_data

#: the GBTI recording, relative to the real-data folder (``lerobot_forcemap.shared_data``)
GBTI_FILE = "gbti/Grasping_Demos.h5"

# The paper's Table I streams, in its column order, with the authors' UR5e thresholds (finger force: ours).
STREAMS: tuple[str, ...] = ("cartesian", "joints", "gripper", "wrist_force", "finger_force")
THRESHOLDS: dict[str, float] = {
    "cartesian": 0.25,
    "joints": 0.20,
    "gripper": 0.10,
    "wrist_force": 0.15,
    "finger_force": 0.15,  # not given by the authors: the same fraction as the other force stream
}
TABLE_I: dict[str, tuple[float, ...]] = {
    "position": (0.5, 0.5, 0.0, 0.0, 0.0),
    "uniform": (0.2, 0.2, 0.2, 0.2, 0.2),
    "custom": (0.1, 0.1, 0.1, 0.35, 0.35),
}
PAPER_COUNTS = {"position": (4.09, 0.95), "uniform": (4.11, 0.87), "custom": (3.86, 0.84)}
MODES = ("product", "geometric", "linear")
# Controls: "flat" = one constant stream (no keypoints: the pmf is uniform); "gripper_only" = the gripper
# stream alone (the signal most reference events are read from: a circular upper reference, not a method).
CONTROLS = ("flat", "gripper_only")
WINDOW = 64
ABBREV = {
    "cartesian": "cart",
    "joints": "joint",
    "gripper": "grip",
    "wrist_force": "wrist F",
    "finger_force": "finger F",
}
# The first plate demo (the paper's Fig. 4 shows a plate), fixed before looking at any result.
FIGURE_DEMO = "Plate/User1/Position1"


@dataclass
class Demo:
    key: str
    times: np.ndarray  # (T,) s from the first frame
    values: dict[str, np.ndarray]  # stream name -> (T, k)
    events: ReferenceEvents
    reference: np.ndarray  # merged event frames (E,)
    frame_dt: float  # s per frame
    auto: dict[str, dict[str, float]] = field(default_factory=dict)  # derivative -> stream -> weight


def default_data_dir() -> Path | None:
    """The real-data folder holding :data:`GBTI_FILE`, None when it is not found."""
    return find_shared_data(GBTI_FILE)


def chosen_keys(path: Path, limit: int | None) -> list:
    """The GBTI demo keys used: all of them, or ``limit`` (>= 1) spread evenly over the key order."""
    keys = gbti_keys(path)
    if limit is not None:
        keys = keys[:: max(1, len(keys) // limit)][:limit]
    return keys


def load_demos(path: Path, n_points: int, merge_within: float, keys: list) -> tuple[list[Demo], list[str]]:
    """The given GBTI demos aligned onto n_points evenly spaced frames, their streams and reference events."""
    demos: list[Demo] = []
    notes: list[str] = []
    items = iter_gbti_demos(path, keys)
    for key, rec in tqdm(items, total=len(keys), desc="load + align + events", unit="demo"):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            a = align_recording(rec, n_samples=n_points)
        notes += [f"{key}: {w.message}" for w in caught]
        values = {
            "cartesian": a.positions,
            "joints": np.unwrap(a.joint_positions, axis=0),
            "gripper": a.gripper[:, None],
            "wrist_force": a.force,
            "finger_force": a.finger_force[:, None],
        }
        ev = reference_events(a.times, a.gripper, a.finger_force, EventThresholds())
        demos.append(
            Demo(
                key=str(key),
                times=a.times,
                values=values,
                events=ev,
                reference=merge_events(ev.frames, merge_within),
                frame_dt=float(a.times[-1] / (a.times.size - 1)),
            )
        )
    return demos, notes
