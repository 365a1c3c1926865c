"""The real recordings: the three-button UR5e demo and the GBTI demo that needed padding."""

from __future__ import annotations

from pathlib import Path

import h5py
import numpy as np
import pytest

from lerobot_forcemap.segmentation import SegmentationConfig, Stream, TimeRepairWarning, segment_streams
from lerobot_forcemap.segmentation.reference import loop_segment_streams

pytestmark = pytest.mark.realdata

THRESHOLDS = {"joints": 0.20, "cartesian": 0.25, "wrist_force": 0.15, "wrist_torque": 0.15, "gripper": 0.10}


def seconds(rows: np.ndarray) -> np.ndarray:
    return rows[:, 0] + rows[:, 1] * 1e-9


def recorder_streams(group: h5py.Group, gripper_key: str = "gripper_position") -> list[Stream]:
    """The five streams of a recorder file, interpolated onto the joint time base."""
    t = seconds(group["joint_state_info/joint_time"][()])

    def on_joint_time(values: np.ndarray, time_key: str) -> np.ndarray:
        ts = seconds(group[time_key][()])
        return np.stack([np.interp(t, ts, column) for column in values.T], axis=1)

    values = {
        "joints": np.unwrap(group["joint_state_info/joint_positions"][()], axis=0),
        "cartesian": on_joint_time(
            group["transform_info/transform_positions"][()], "transform_info/transform_time"
        ),
        "wrist_force": on_joint_time(group["wrench_info/wrench_force"][()], "wrench_info/wrench_time"),
        "wrist_torque": on_joint_time(group["wrench_info/wrench_torque"][()], "wrench_info/wrench_time"),
        "gripper": on_joint_time(group[f"gripper_info/{gripper_key}"][()], "gripper_info/gripper_time"),
    }
    return [Stream(k, v, t - t[0], weight=0.2, threshold=THRESHOLDS[k]) for k, v in values.items()]


def test_three_button_demo_agrees_with_loop_reference(shared_data: Path) -> None:
    with h5py.File(shared_data / "ur5e" / "three_button_press.h5") as f:
        streams = recorder_streams(f)
    assert streams[0].n_frames == 4099
    config = SegmentationConfig()
    fast = segment_streams(streams, config)
    ref = loop_segment_streams(streams, config)
    assert {k: v.tolist() for k, v in fast.keypoints.items()} == ref["keypoints"]
    np.testing.assert_array_equal(fast.changepoints, ref["changepoints"])
    assert fast.n_segments >= 4
    # The three presses: the wrist force stream finds them, and so does the torque stream.
    assert fast.keypoints["wrist_force"].size >= 3


def test_raw_differences_drown_position_streams_in_noise(shared_data: Path) -> None:
    """With forward differences the 166 Hz joint and Cartesian jerk sits above every threshold
    from the first sample, so those streams give no keypoint; the Savitzky–Golay default finds them."""
    with h5py.File(shared_data / "ur5e" / "three_button_press.h5") as f:
        streams = recorder_streams(f)
    raw = segment_streams(streams, SegmentationConfig(derivative="difference"))
    smooth = segment_streams(streams, SegmentationConfig(derivative="savgol"))
    for name in ("joints", "cartesian"):
        assert raw.keypoints[name].size == 0
        assert smooth.keypoints[name].size >= 3


def test_gbti_demo_padded_to_1000_points(shared_data: Path) -> None:
    """Cube/User3/Position2 has 941 samples; resampled to 1000 points its first sample repeats 59 times."""
    with h5py.File(shared_data / "gbti" / "Grasping_Demos.h5") as f:
        streams = recorder_streams(f["Cube/User3/Position2"], gripper_key="gripper_vals")
    assert streams[0].n_frames == 941
    padded = [
        Stream(
            s.name,
            np.concatenate([np.repeat(s.values[:1], 59, axis=0), s.values]),
            np.concatenate([np.zeros(59), s.times]),
            weight=s.weight,
            threshold=s.threshold,
        )
        for s in streams
    ]
    for derivative in ("savgol", "difference"):
        config = SegmentationConfig(derivative=derivative)
        clean = segment_streams(streams, config)
        with pytest.warns(TimeRepairWarning):
            seg = segment_streams(padded, config)
        assert np.isfinite(seg.pmf).all()
        for name in clean.keypoints:
            np.testing.assert_array_equal(seg.keypoints[name], clean.keypoints[name] + 59)
