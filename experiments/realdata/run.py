"""One real recording through the product: ``forcemap convert`` defaults -> ``forcemap fit`` package
defaults -> the policy's placement from the demonstration's first frame -> the measurements.

The reproduction is what ``ForceMapPolicy.select_action`` commands: the skill placed by ``SkillRun.start``
at the recording's first pose (``observation.ee_pose`` of frame 0; no objects), targets at the dataset's
rate (the policy's ``control_fps`` defaults to it), for as many frames as the demonstration has. The
demonstrated path is the measured flange path (``observation.ee_pose``); the demonstrated targets
(``action``, the next frame's pose) are what a target is compared with frame by frame.
"""

from __future__ import annotations

import json
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from experiments.realdata import metrics
from lerobot_forcemap import layout
from lerobot_forcemap.contact import contact_surfaces

__all__ = ["LABELS_FILE", "RecordingResult", "load_labels", "recording_kind", "run_recording"]

LABELS_FILE = Path(__file__).with_name("labels.json")
#: margin around a contact within which the reproduction's lowest point counts (s)
CONTACT_MARGIN_S = 0.25
#: free space for the force ratios: this far from any contact (s)
FREE_PAD_S = 0.3
#: placement fidelity: how close (m) the placement from the first frame must come to the fitted path
PLACEMENT_TOLERANCE_M = 0.001


def load_labels() -> dict[str, list[dict[str, Any]]]:
    """The hand labels: ``{recording: [{"kind", "t", "rule"}, ...]}`` (times on the dataset's clock)."""
    return json.loads(LABELS_FILE.read_text())["recordings"]


def recording_kind(name: str) -> str:
    """ "press", "wipe" or "other" from a recording's file name."""
    if name.startswith(("press", "three_button_press")):
        return "press"
    return "wipe" if name.startswith("erase") else "other"


@dataclass
class RecordingResult:
    """The numbers of one recording (``report.py`` formats them; lengths m, times s, forces N)."""

    name: str
    kind: str
    fps: float
    frames: int
    values: dict[str, Any] = field(default_factory=dict)


def run_recording(source: Path, work: Path, labels: list[dict[str, Any]] | None) -> RecordingResult:
    """Convert, fit, reproduce and measure one recording (``work``: a scratch folder of its own)."""
    from lerobot_forcemap.cli.fit import fit_policy
    from lerobot_forcemap.data.convert import convert_recordings

    dataset = work / "dataset"
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the converter's notes (unconverted joint efforts, tare) are known
        converted = convert_recordings([source], dataset, overwrite=True, progress=False)
    fitted = fit_policy(dataset, work / "policy", overwrite=True)
    columns = _columns(dataset)
    result = RecordingResult(
        source.stem, recording_kind(source.stem), float(columns["fps"]), len(columns["t"])
    )
    record = converted.episodes[0]["contact"]
    values = _fit_measures(fitted.policy, record)
    placed, stored = _reproduce(fitted.policy, columns["pose0"], columns["t"])
    if labels:
        intervals = metrics.labelled_intervals(labels)
        values.update(_contact_measures(columns, placed, values, intervals))
    else:
        intervals = values["detected"]
    values.update(_motion_measures(columns, placed, stored, intervals, values["stiffness"]))
    result.values = values
    return result


def _columns(dataset: Path) -> dict[str, Any]:
    from lerobot_forcemap.data.reader import read_episodes, read_meta

    keys = ["timestamp", layout.ACTION, layout.OBS_EE_POSE, layout.OBS_FORCE, layout.CONTACT_REACTION]
    data = read_episodes(read_meta(dataset), [0], keys)
    c = {k: np.asarray(v, dtype=np.float64) for k, v in data.columns.items()}
    return {
        "fps": data.fps,
        "t": c["timestamp"].reshape(-1),
        "targets": c[layout.ACTION][:, :3],
        "path": c[layout.OBS_EE_POSE][:, :3],
        "pose0": c[layout.OBS_EE_POSE][0],
        "force": c[layout.OBS_FORCE][:, :3],
        "reaction": c[layout.CONTACT_REACTION],
    }


def _fit_measures(policy: Any, record: dict[str, Any]) -> dict[str, Any]:
    """What the converter and the fit report say."""
    report = policy.fit_report
    return {
        "detected": np.asarray(record["intervals_s"], dtype=np.float64).reshape(-1, 2),
        "hand_residual_ratio": record["hand_model_residual_ratio_free"],
        "guiding_share": record["guiding_force_share"],
        "changepoints_s": report.changepoints_s[0],
        "n_segments": len(report.changepoints[0]) - 1,
        "boundary_gap_max_m": max(report.boundary_gaps_m, default=0.0),
        # the fitted k: stiffness_from_demo x the demonstration's own stiffness when it tells it
        "stiffness": float(policy.params.arm.stiffness),
    }


def _reproduce(policy: Any, pose0: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The targets (T, 3) played from ``pose0`` and those of the stored start (the fitted path)."""
    from lerobot_forcemap.skill.placement import SkillRun

    skill, params = policy.skill, policy.params
    placed = SkillRun.start(skill, params, pose0[None], [{}], online=True).actions_at(times)[0]
    stored = SkillRun.start(skill, params, None, [{}], online=True).actions_at(times)[0]
    return placed[:, :3], stored[:, :3]


def _motion_measures(
    c: dict[str, Any], placed: np.ndarray, stored: np.ndarray, intervals: np.ndarray, stiffness: float
) -> dict[str, Any]:
    """Steps, placement, the path outside the contact ``intervals`` (K, 2) s, the forces in free space
    and the lift at the largest reaction; ``placed`` / ``stored``: the targets from the first frame and
    from the stored start."""
    t, path, force, reaction = c["t"], c["path"], c["force"], c["reaction"]
    outside = metrics.free_frames(t, intervals, 0.0)
    off = np.linalg.norm(placed - stored, axis=1)
    faithful = np.flatnonzero(off > PLACEMENT_TOLERANCE_M)
    return {
        "step_max_m": metrics.largest_step(placed),
        "demo_step_max_m": metrics.largest_step(path),
        "placement_start_m": float(off[0]),
        "placement_max_m": float(off.max()),
        "placement_settled_s": float(t[faithful[-1] + 1]) if len(faithful) else 0.0,
        "path_max_m": float(metrics.distance_to_path(placed[outside], path).max()) if outside.any() else 0.0,
        "reaction_free_ratio": metrics.free_space_ratio(
            force, reaction, metrics.free_frames(t, intervals, FREE_PAD_S)
        ),
        "lift": metrics.lift_at_largest_reaction(t, reaction, c["targets"], placed, stiffness),
    }


def _contact_measures(
    c: dict[str, Any], placed: np.ndarray, values: dict[str, Any], intervals: np.ndarray
) -> dict[str, Any]:
    """The measures against the labelled contact ``intervals`` (K, 2) s: events, changepoints, the
    reaction's direction, the lowest target of a press and the deepest target of a wipe."""
    t, path = c["t"], c["path"]
    detected = values["detected"]
    surfaces = contact_surfaces(t, path, intervals)
    away, into, median = metrics.reaction_in_contact(t, c["reaction"], intervals, surfaces)
    found = np.stack(
        [
            metrics.event_errors(detected[:, 0], intervals[:, 0]),
            metrics.event_errors(detected[:, 1], intervals[:, 1]),
        ],
        axis=1,
    )
    return {
        "labelled": intervals,
        "event_errors": found,
        "extra_detections": int(len(detected) - np.sum(np.abs(found[:, 0]) <= 0.5)),
        "changepoint_errors": metrics.changepoint_errors(values["changepoints_s"], intervals),
        "reaction_away_fraction": away,
        "reaction_into_fraction": into,
        "reaction_median_n": median,
        "lowest": [metrics.lowest_point(t, path, placed, iv, CONTACT_MARGIN_S) for iv in intervals],
        "below_surface_m": [metrics.depth_below(s, placed, t, CONTACT_MARGIN_S) for s in surfaces],
    }
