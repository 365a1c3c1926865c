"""Tare, tool->base rotation, timestamp cleaning and alignment, on synthetic and real recordings."""

from __future__ import annotations

import dataclasses
import warnings

import numpy as np
import pytest

from lerobot_forcemap.data.recorder import GbtiKey, iter_gbti_demos, read_recording
from lerobot_forcemap.data.transforms import (
    align_recording,
    clean_times,
    describe_gaps,
    estimate_wrench_bias,
    interp_linear,
    tare_wrench,
    wrench_to_base,
)
from lerobot_forcemap.geometry import quat_rotate, rotvec_to_quat, slerp_sequence

from .synthetic import make_streams, write_recorder_file


@pytest.fixture
def synthetic(tmp_path):
    st = make_streams(n=400, rate=100.0, seed=1)
    return st, read_recording(write_recorder_file(tmp_path / "syn.h5", st))


def test_clean_times_collapses_duplicates_and_rejects_backwards():
    t = np.array([0.0, 0.0, 0.0, 0.1, 0.2, 0.2, 0.3])
    v = np.arange(7.0)[:, None]
    tc, vc, info = clean_times("s", t, v)
    np.testing.assert_array_equal(tc, [0.0, 0.1, 0.2, 0.3])
    np.testing.assert_array_equal(vc[:, 0], [1.0, 3.0, 4.5, 6.0])  # mean of each run
    assert (info.n_in, info.n_out, info.duplicates_collapsed, info.first_duplicate_index) == (7, 4, 3, 1)
    with pytest.raises(ValueError, match=r"stream 'demo/wrench': timestamp goes backwards at sample 3"):
        clean_times("demo/wrench", [0.0, 0.1, 0.2, 0.15], np.zeros((4, 1)))
    with pytest.raises(ValueError, match=r"stream 'x': timestamp is not finite at sample 1"):
        clean_times("x", [0.0, np.nan], np.zeros((2, 1)))
    with pytest.raises(ValueError, match="fewer than 2 distinct"):
        clean_times("x", [1.0, 1.0, 1.0], np.zeros((3, 1)))


def test_repeated_pose_timestamp_at_a_quaternion_sign_flip_merges_to_that_rotation():
    """Recorders flip q to −q now and then (the UR5e files do 4-5 times each); a repeated timestamp
    right there must not average the two signs to a near-zero quaternion."""
    q = np.array([0.6060264, 0.65215856, 0.37278298, -0.26163736])
    q /= np.linalg.norm(q)
    pose = np.array([[0.1, 0.2, 0.3, *q], [0.1, 0.2, 0.3, *(-q)], [0.1, 0.2, 0.31, *(-q)]])
    t, v, info = clean_times("demo/pose", [0.0, 0.0, 0.02], pose, quaternion_columns=slice(3, 7))
    assert info.duplicates_collapsed == 1 and len(t) == 2
    np.testing.assert_allclose(v[0], [0.1, 0.2, 0.3, *q], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(v[:, 3:], axis=1), 1.0, atol=1e-12)
    np.testing.assert_array_equal(v[1], pose[2])  # a single sample passes unchanged


def test_wrench_to_base_rotation_law():
    q = rotvec_to_quat(np.array([[np.pi / 2, 0, 0], [0, 0, 0]]))  # 90° about x, identity
    f = np.array([[0.0, 1.0, 0.0], [1.0, 2.0, 3.0]])
    tq = np.array([[0.0, 0.0, 1.0], [0.0, 0.0, 1.0]])
    fb, tb = wrench_to_base(f, tq, q)
    np.testing.assert_allclose(fb, [[0, 0, 1], [1, 2, 3]], atol=1e-12)  # y_tool -> z_base
    np.testing.assert_allclose(tb, [[0, -1, 0], [0, 0, 1]], atol=1e-12)  # z_tool -> -y_base
    fb_neg, _ = wrench_to_base(f, tq, q, sign=-1.0)
    np.testing.assert_allclose(fb_neg, -fb)


def test_tare_recovers_bias_and_auto_avoids_a_shaking_hand(synthetic):
    st, rec = synthetic
    bias = estimate_wrench_bias(rec.force_tool, rec.torque_tool, rec.wrench_time)
    assert bias.window == "start"
    np.testing.assert_allclose(bias.force, st["bias_f"], atol=0.05)
    np.testing.assert_allclose(bias.torque, st["bias_t"], atol=0.005)
    # A hand resting (and shaking) on the robot in the first 0.3 s: auto moves to the quiet end window.
    f = rec.force_tool.copy()
    f[:30] += [10.0, -5.0, 0.0] + np.random.default_rng(0).normal(0, 1.5, (30, 3))
    f_t, _, b = tare_wrench(f, rec.torque_tool, rec.wrench_time)
    assert b.window == "end" and b.disagreement_n > 5
    np.testing.assert_allclose(b.force, st["bias_f"], atol=0.05)
    assert estimate_wrench_bias(f, rec.torque_tool, rec.wrench_time, method="start").window == "start"
    none = estimate_wrench_bias(f, rec.torque_tool, rec.wrench_time, method="none")
    np.testing.assert_array_equal(none.force, 0.0)
    with pytest.raises(ValueError, match="tare method"):
        estimate_wrench_bias(f, rec.torque_tool, rec.wrench_time, method="median")


def test_align_native_equals_documented_transforms(synthetic):
    st, rec = synthetic
    a = align_recording(rec)  # native: the joint timestamps
    np.testing.assert_allclose(a.source_times, rec.joint_time)
    np.testing.assert_allclose(a.times, rec.joint_time - rec.joint_time[0])
    np.testing.assert_allclose(a.joint_positions, st["joints"], atol=1e-12)
    np.testing.assert_allclose(a.positions, st["pos"], atol=1e-12)
    np.testing.assert_allclose(np.abs(np.sum(a.orientations * st["quat"], axis=1)), 1.0, atol=1e-12)
    f_expected = quat_rotate(st["quat"], st["force"] - a.bias.force)  # R(q) (f - b), sign +1
    np.testing.assert_allclose(a.force, f_expected, atol=1e-9)
    # ... which recovers the synthetic base-frame contact force up to sensor noise.
    np.testing.assert_allclose(a.force, st["f_base"], atol=0.3)
    np.testing.assert_allclose(a.torque, st["t_base"], atol=0.03)
    np.testing.assert_allclose(a.gripper, st["gripper"] / 100.0)
    assert a.finger_force is None and a.warnings == ()


def test_align_fps_interpolates(synthetic):
    st, rec = synthetic
    a = align_recording(rec, fps=30.0)
    assert a.fps == 30.0 and len(a) == int(np.floor(3.99 * 30)) + 1
    np.testing.assert_allclose(np.diff(a.times), 1 / 30.0, atol=1e-9)
    np.testing.assert_allclose(
        a.joint_positions, interp_linear(rec.joint_time, st["joints"], a.source_times), atol=1e-12
    )
    q_ref = slerp_sequence(rec.pose_time, st["quat"], a.source_times)
    np.testing.assert_allclose(a.orientations, q_ref, atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(a.orientations, axis=1), 1.0, atol=1e-12)
    b = align_recording(rec, n_samples=1000)
    assert len(b) == 1000 and np.all(np.diff(b.times) > 0)
    with pytest.raises(ValueError, match="not both"):
        align_recording(rec, fps=10, n_samples=10)


def test_align_collapses_a_repeated_first_sample_without_nan(synthetic):
    """The authors' resampled GBTI demo repeats its first sample 59 times: collapse, warn, no NaN."""
    _, rec = synthetic
    rep = 59
    padded = dataclasses.replace(
        rec,
        joint_time=np.concatenate([np.repeat(rec.joint_time[:1], rep), rec.joint_time[1:]]),
        joint_positions=np.concatenate([np.repeat(rec.joint_positions[:1], rep, 0), rec.joint_positions[1:]]),
    )
    with pytest.warns(UserWarning, match=r"stream 'joint': 58 sample\(s\) repeat the previous timestamp"):
        a = align_recording(padded, n_samples=1000)
    info = {c.stream.split("/")[-1]: c for c in a.time_cleaning}
    assert info["joint"].duplicates_collapsed == rep - 1 and info["wrench"].duplicates_collapsed == 0
    assert any("repeat the previous timestamp" in w for w in a.warnings)
    assert all(np.all(np.isfinite(x)) for x in (a.joint_positions, a.positions, a.force, a.orientations))
    ref = align_recording(rec, n_samples=1000)
    np.testing.assert_allclose(a.joint_positions, ref.joint_positions, atol=1e-12)


def test_a_gap_in_a_stream_is_reported_not_bridged_silently(synthetic):
    """Dropped samples (0.5 s of wrench) are named with their place; the frames across are interpolated."""
    _, rec = synthetic
    keep = np.r_[0:150, 200 : len(rec.wrench_time)]
    gappy = dataclasses.replace(
        rec,
        wrench_time=rec.wrench_time[keep],
        force_tool=rec.force_tool[keep],
        torque_tool=rec.torque_tool[keep],
    )
    with pytest.warns(
        UserWarning, match=r"stream 'wrench': 1 gap\(s\) .* the longest, 0.510 s, after sample 149"
    ):
        a = align_recording(gappy, fps=20)
    assert any("gap(s) in time" in w for w in a.warnings)
    assert not any("gap" in w for w in align_recording(rec, fps=20).warnings)
    assert describe_gaps(np.arange(10.0)) == "" and describe_gaps(np.array([0.0])) == ""


def test_align_bad_gripper_range_names_sample(synthetic):
    _, rec = synthetic
    g = rec.gripper.copy()
    g[123] = 180.0
    with pytest.raises(ValueError, match=r"gripper reading 180.0 at sample 123 outside \[0, 100.0\]"):
        align_recording(dataclasses.replace(rec, gripper=g))


def test_press_force_points_up_during_the_press(shared_data):
    """The force sign (reaction on the robot) on press_2023-07-27_160905.h5: tared and rotated to the base,
    the press reads tens of N up."""
    rec = read_recording(shared_data / "ur5e" / "press_2023-07-27_160905.h5")
    a = align_recording(rec)
    # Tool-frame bias: the quiet rest windows at start and end agree (the bias rides with the sensor).
    assert a.bias.window == "start" and a.bias.disagreement_n < 0.2
    np.testing.assert_allclose(a.bias.force, [7.59, -0.76, -7.90], atol=0.05)
    press = int(np.argmin(a.positions[:, 2]))  # the lowest point of the tool: on the button
    window = slice(press - 50, press + 50)  # ±0.1 s at 500 Hz
    i = window.start + int(np.argmax(a.force[window, 2]))
    fz, fnorm = a.force[i, 2], np.linalg.norm(a.force[i])
    assert 25.0 < fz < 40.0 and fz > 0.9 * fnorm  # up (away from the button), tens of newtons
    assert abs(a.positions[i, 2] - a.positions[press, 2]) < 0.002
    # While the hand pushes the tool down towards the button, the base-frame force points down.
    assert np.median(a.force[press - 400 : press - 100, 2]) < -5.0
    # Resampled to 50 Hz with the 20 Hz anti-alias low-pass the press still reads tens of N up.
    b = align_recording(rec, fps=50, force_lowpass_hz=20.0)
    assert b.force[:, 2].max() > 15.0 and b.force[np.argmax(b.force[:, 2]), 2] > 0.9 * np.linalg.norm(
        b.force[np.argmax(b.force[:, 2])]
    )


def test_gbti_short_demo_resampled_to_1000_points(shared_data):
    """Cube/User3/Position2 has 941 samples; the authors' 1000-point resampling repeated samples, ours doesn't."""
    ((key, rec),) = iter_gbti_demos(shared_data / "gbti" / "Grasping_Demos.h5", [GbtiKey("Cube", 3, 2)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # tare disagreement warning (hand on the robot at the start)
        a = align_recording(rec, n_samples=1000)
    assert len(a) == 1000 and np.all(np.diff(a.times) > 0)
    for x in (a.joint_positions, a.positions, a.orientations, a.force, a.torque, a.gripper, a.finger_force):
        assert np.all(np.isfinite(x))
    assert a.bias.window == "end"  # the start window is not quiet (force std > 0.5 N)
    assert 0.0 <= a.gripper.min() and a.gripper.max() <= 1.0 and a.gripper.max() > 0.4
    assert 360 < np.median(a.finger_force) < 400  # raw counts, untouched


def test_all_60_gbti_demos_align(shared_data):
    """Every GBTI demo aligns at 50 Hz: finite streams, gripper in [0, 1], tare window chosen."""
    n = 0
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for key, rec in iter_gbti_demos(shared_data / "gbti" / "Grasping_Demos.h5"):
            a = align_recording(rec, fps=50)
            for x in (
                a.joint_positions,
                a.positions,
                a.orientations,
                a.force,
                a.torque,
                a.gripper,
                a.finger_force,
            ):
                assert np.all(np.isfinite(x)), key
            assert 0.0 <= a.gripper.min() and a.gripper.max() <= 1.0
            assert a.bias.window in ("start", "end") and len(a) > 300
            n += 1
    assert n == 60


@pytest.mark.parametrize("scale, unit", [(1e3, "ms"), (1e9, "ns")])
def test_timestamps_in_other_units_than_seconds_are_refused(synthetic, scale, unit):
    """ms as plain seconds resampled to 1000x the frames (minutes, GBs); ns asked for TiBs."""
    _, rec = synthetic
    t = (rec.joint_time - rec.joint_time[0]) * scale
    bad = dataclasses.replace(rec, joint_time=t, pose_time=t, wrench_time=t, gripper_time=t)
    with pytest.raises(
        ValueError, match=r"stream 'joint' has a median sample step of .* are they ms, µs or ns\?"
    ):
        align_recording(bad, fps=50)


def test_streams_cut_to_their_overlap_are_reported(synthetic):
    _, rec = synthetic
    keep = rec.wrench_time < rec.wrench_time[0] + 1.5  # the wrench stops after 1.5 s of 4 s
    short = dataclasses.replace(
        rec,
        wrench_time=rec.wrench_time[keep],
        force_tool=rec.force_tool[keep],
        torque_tool=rec.torque_tool[keep],
    )
    with pytest.warns(
        UserWarning,
        match=r"cover different time spans; kept their overlap 0.000..1.490 s, dropping 2.500 s at "
        r"the end \(stream\(s\) \['wrench'\] end first\)",
    ):
        a = align_recording(short, fps=20)
    assert a.trimmed_s == pytest.approx((0.0, 2.5))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        align_recording(rec, fps=20)  # same spans: nothing to say


def test_gripper_full_scale_must_be_positive(synthetic):
    _, rec = synthetic
    for value in (float("nan"), 0.0, -1.0):
        with pytest.raises(ValueError, match="gripper_full_scale: must be a finite number > 0"):
            align_recording(rec, gripper_full_scale=value)
