"""Bad input and the duplicated-timestamp repair: errors name the stream and frame; nothing is silent."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from lerobot_forcemap.segmentation import (
    SegmentationConfig,
    Stream,
    TimeRepairWarning,
    auto_weights,
    segment_streams,
)
from lerobot_forcemap.segmentation.config import MODES
from lerobot_forcemap.segmentation.keypoints import difference_third_derivative
from tests.segmentation.helpers import DT, jerk_bursts


def event_stream(n: int = 941, seed: int = 0, rel_noise: float = 0.02) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    onsets, lengths, jerks = np.array([150, 500]), np.array([150, 200]), np.array([1.0, -0.7])
    return jerk_bursts(n, onsets, lengths, jerks, rng, n_cols=3, rel_noise=rel_noise)


def pad_first_sample(values: np.ndarray, times: np.ndarray, repeats: int) -> tuple[np.ndarray, np.ndarray]:
    """What the authors' downsampling did to a 941-sample GBTI demo: the first sample repeated to reach 1000."""
    return np.concatenate([np.repeat(values[:1], repeats, axis=0), values]), np.concatenate(
        [np.repeat(times[:1], repeats), times]
    )


@pytest.mark.parametrize("derivative", ["savgol", "difference"])
def test_repeated_first_sample_is_merged_and_reported(derivative: str) -> None:
    # Raw differences need noise-free data to see the events at all.
    values, times = event_stream(rel_noise=0.02 if derivative == "savgol" else 0.0)
    padded_v, padded_t = pad_first_sample(values, times, 59)
    config = SegmentationConfig(derivative=derivative, window=32, min_run=32)
    clean = segment_streams([Stream("joints", values, times)], config)
    with pytest.warns(TimeRepairWarning) as record:
        padded = segment_streams(
            [Stream("joints", padded_v, padded_t), Stream("gripper", np.zeros(1000), padded_t)], config
        )
    messages = sorted(str(r.message) for r in record)
    assert len(messages) == 2
    assert "'gripper': 59 samples repeat" in messages[0] and "'joints': 59 samples repeat" in messages[1]
    if derivative == "difference":
        with np.errstate(divide="ignore", invalid="ignore"):  # what the unguarded authors' jerk would be
            assert not np.isfinite(difference_third_derivative(padded_v, padded_t)).all()
    assert np.isfinite(padded.pmf).all() and padded.pmf.size == 1000
    assert clean.keypoints["joints"].size >= 2
    np.testing.assert_array_equal(padded.keypoints["joints"], clean.keypoints["joints"] + 59)
    repair = padded.streams["joints"].time_repair
    assert repair is not None and repair.n_dropped == 59 and repair.max_value_change == 0.0
    np.testing.assert_array_equal(repair.dropped_frames, np.arange(1, 60))
    assert padded.changepoints[-1] == 1000


def test_a_gap_in_the_sample_times_is_reported_for_the_savgol_jerk() -> None:
    import warnings

    from lerobot_forcemap.segmentation import UnevenTimeWarning

    values, times = event_stream(600)
    jitter = times.copy()
    jitter[100] += 0.9 * (times[101] - times[100])  # one late sample (a 1.9x step): recorder jitter
    with warnings.catch_warnings():
        warnings.simplefilter("error", UnevenTimeWarning)
        segment_streams([Stream("arm", values, jitter)], SegmentationConfig(window=32, min_run=32))
    keep = np.r_[0:300, 305:600]  # 5 dropped frames: a 6x step before what is frame 300 of the stream
    with pytest.warns(
        UnevenTimeWarning, match=r"'arm': 1 time step\(s\) longer than 3x .* 6\.0x before frame 300"
    ):
        segment_streams([Stream("arm", values[keep], times[keep])], SegmentationConfig(window=32, min_run=32))
    with warnings.catch_warnings():  # the raw differences use the real time steps
        warnings.simplefilter("error", UnevenTimeWarning)
        segment_streams(
            [Stream("arm", values[keep], times[keep])],
            SegmentationConfig(window=32, min_run=32, derivative="difference"),
        )


@pytest.mark.parametrize("derivative", ["savgol", "difference"])
def test_a_near_duplicate_timestamp_is_reported(derivative: str) -> None:
    """A 1 ns step is not merged (the times differ) but its jerk spike moved a changepoint 766 -> 568."""
    from lerobot_forcemap.segmentation import UnevenTimeWarning

    values, times = event_stream(600)
    near = times.copy()
    near[300] = near[299] + 1e-9
    with pytest.warns(
        UnevenTimeWarning,
        match=r"'arm': 1 time step\(s\) shorter than 0.001x the median .* 1e-09 s before frame 300",
    ):
        segment_streams(
            [Stream("arm", values, near)], SegmentationConfig(window=32, min_run=32, derivative=derivative)
        )


def test_duplicates_in_the_middle_with_different_values_are_reported() -> None:
    values, times = event_stream(600)
    times = times.copy()
    times[300] = times[299]  # a stalled clock; the value differs
    with pytest.warns(TimeRepairWarning, match="first at frame 300"):
        seg = segment_streams([Stream("arm", values, times)], SegmentationConfig(window=32, min_run=32))
    repair = seg.streams["arm"].time_repair
    assert repair.dropped_frames.tolist() == [300]
    assert repair.max_value_change == pytest.approx(np.abs(values[300] - values[299]).max())


def test_duplicates_raise_when_asked() -> None:
    values, times = pad_first_sample(*event_stream(), 59)
    with pytest.raises(
        ValueError,
        match=r"^Stream\('joints'\).times: must hold no duplicated timestamp .*got one at frame 1 .*59 duplicated frames",
    ):
        segment_streams([Stream("joints", values, times)], SegmentationConfig(duplicate_times="raise"))


def test_no_warning_without_duplicates() -> None:
    values, times = event_stream()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        seg = segment_streams([Stream("arm", values, times)], SegmentationConfig(window=32, min_run=32))
    assert seg.streams["arm"].time_repair is None


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_values_name_stream_frame_and_column(bad: float) -> None:
    values, times = event_stream(300)
    values = values.copy()
    values[17, 2] = bad
    values[40, 0] = bad
    with pytest.raises(
        ValueError,
        match=r"^Stream\('wrist_force'\).values: must hold finite values only \(the first bad one is at frame 17, "
        r"column 2; 2 bad frames in all\)",
    ):
        Stream("wrist_force", values, times)


def test_bad_times_name_stream_and_frame() -> None:
    values, times = event_stream(300)
    t = times.copy()
    t[5] = np.nan
    with pytest.raises(
        ValueError,
        match=r"^Stream\('arm'\).times: must hold finite values only \(the first bad one is at frame 5\), got nan",
    ):
        Stream("arm", values, t)
    t = times.copy()
    t[120] = t[118]
    with pytest.raises(ValueError, match=r"^Stream\('arm'\).times: must be non-decreasing .*at frame 120$"):
        Stream("arm", values, t)
    with pytest.raises(
        ValueError,
        match=r"^Stream\('arm'\).times: must have shape \(300,\) to match values, got shape \(299,\)",
    ):
        Stream("arm", values, times[:-1])


def test_streams_must_share_one_time_base() -> None:
    values, times = event_stream(300)
    a = Stream("joints", values, times)
    with pytest.raises(
        ValueError,
        match=r"^Stream\('finger'\).times: must share the time base of Stream\('joints'\) .*got 299 samples against 300",
    ):
        segment_streams([a, Stream("finger", values[:-1], times[:-1])])
    # A 200 Hz stream against a 166 Hz one with the same sample count drifts apart.
    with pytest.raises(
        ValueError,
        match=r"^Stream\('finger'\).times: must share the time base of Stream\('joints'\) .*got a sample time at frame",
    ):
        segment_streams([a, Stream("finger", values, np.arange(300) * 0.005)])
    # A constant offset of a few ms (recorder topics) is accepted
    ok = segment_streams(
        [a, Stream("gripper", values, times + 0.008)], SegmentationConfig(window=32, min_run=32)
    )
    assert ok.time_tolerance == pytest.approx(2 * DT)
    with pytest.raises(ValueError, match="differs"):
        auto_weights([a, Stream("finger", values, np.arange(300) * 0.005)])


def test_other_bad_input() -> None:
    values, times = event_stream(300)
    with pytest.raises(
        ValueError,
        match=r"^Stream\('short'\).values: must hold at least 67 samples for window=64 with derivative='difference', got 66",
    ):
        segment_streams(
            [Stream("short", values[:66], times[:66])], SegmentationConfig(derivative="difference")
        )
    with pytest.raises(
        ValueError,
        match=r"^Stream\('short'\).values: must hold at least 64 samples .*got 60 after dropping 59 duplicated-timestamp samples",
    ):
        with pytest.warns(TimeRepairWarning):
            v, t = pad_first_sample(values[:60], times[:60], 59)
            segment_streams([Stream("short", v, t)])
    with pytest.raises(
        ValueError,
        match=r"^segment_streams\(streams=...\): must hold streams of unique names, got \['a'\] more than once",
    ):
        segment_streams([Stream("a", values, times), Stream("a", values, times)])
    with pytest.raises(ValueError, match=r"^segment_streams\(streams=...\): must hold at least one stream"):
        segment_streams([])
    with pytest.raises(
        ValueError, match=r"^Stream\('a'\).weight: must be a finite number >= 0 and <= 1e\+100, got -0.1"
    ):
        Stream("a", values, times, weight=-0.1)
    with pytest.raises(
        ValueError, match=r"^Stream\('a'\).threshold: must be a finite number > 0 and <= 1, got 1.5"
    ):
        Stream("a", values, times, threshold=1.5)
    with pytest.raises(
        ValueError, match=r"^Stream\('a'\).threshold: must be a finite number > 0 and <= 1, got 'x'"
    ):
        Stream("a", values, times, threshold="x")
    with pytest.raises(
        ValueError, match=r"^Stream\('a'\).weight: must be a finite number >= 0 and <= 1e\+100, got None"
    ):
        Stream("a", values, times, weight=None)
    with pytest.raises(
        ValueError,
        match=r"^Stream\('a'\).values: must have shape \(T,\) or \(T, k\) with T >= 2, got shape \(300, 2, 2\)",
    ):
        Stream("a", np.zeros((300, 2, 2)), times)
    # a single Stream, or a dict of settings, failed with a TypeError / AttributeError naming neither
    with pytest.raises(
        ValueError, match=r"^segment_streams\(streams=...\): must be a list of Streams .*got one Stream"
    ):
        segment_streams(Stream("a", values, times))
    with pytest.raises(
        ValueError, match=r"^segment_streams\(streams=...\): must be a list of Streams, got NoneType"
    ):
        segment_streams(None)
    with pytest.raises(
        ValueError,
        match=r"^segment_streams\(config=...\): must be a SegmentationConfig or None \(build one.*got dict",
    ):
        segment_streams([Stream("a", values, times)], {"window": 64})
    with pytest.raises(
        ValueError, match=r"^auto_weights\(config=...\): must be a SegmentationConfig or None, got str"
    ):
        auto_weights([Stream("a", values, times)], "peaks")
    with pytest.raises(
        ValueError, match=r"^Stream\('a'\).weight: must be a finite number >= 0 and <= 1e\+100, got array"
    ):
        Stream("a", values, times, weight=np.array([1.0]))


def test_defaults_are_the_authors_ur5e_values_with_geometric_pooling() -> None:
    """`geometric` is the default mode; the authors' window 64, min_run 64, grace 4, 20 samples, n_pass 3."""
    cfg = SegmentationConfig()
    assert (cfg.mode, cfg.window, cfg.min_run, cfg.grace) == ("geometric", 64, 64, 4)
    assert (cfg.n_samples, cfg.n_pass) == (20, 3)
    values, times = event_stream()
    late, _ = jerk_bursts(941, np.array([300]), np.array([150]), np.array([1.0]), np.random.default_rng(1))
    streams = [Stream("arm", values, times, weight=0.2), Stream("force", late, times, weight=0.8)]
    pmf = {mode: segment_streams(streams, SegmentationConfig(mode=mode)).pmf for mode in MODES}
    np.testing.assert_array_equal(segment_streams(streams, cfg).pmf, pmf["geometric"])
    assert np.max(np.abs(pmf["geometric"] / pmf["product"] - 1)) > 0.1  # the weights do not cancel
    assert np.max(np.abs(pmf["geometric"] / pmf["linear"] - 1)) > 0.1


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        (
            {"mode": "sum"},
            r"^SegmentationConfig.mode: must be one of \['geometric', 'linear', 'product'\], got 'sum'",
        ),
        ({"changepoints": "viterbi"}, "^SegmentationConfig.changepoints: must be one of"),
        ({"derivative": "spline"}, "^SegmentationConfig.derivative: must be one of"),
        ({"window": 3}, "^SegmentationConfig.window: must be an integer >= 5, got 3"),
        ({"floor": 0.0}, "^SegmentationConfig.floor: must be a finite number > 0, got 0.0"),
        (
            {"sigma": -1.0},
            "^SegmentationConfig.sigma: must be a finite number >= 0.001 samples or None, got -1.0",
        ),
        (
            {"sigma": 1e-300},
            "^SegmentationConfig.sigma: must be a finite number >= 0.001 samples or None",
        ),  # 1/σ overflowed
        (
            {"sigma": "a"},
            "^SegmentationConfig.sigma: must be a finite number >= 0.001 samples or None, got 'a'",
        ),
        (
            {"n_samples": 10**12},
            "^SegmentationConfig.n_samples: must be an integer >= 1 and <= 1000000",
        ),  # 7 TiB of draws
        ({"floor": None}, "^SegmentationConfig.floor: must be a finite number > 0, got None"),
        (
            {"seed": 1.5},
            "^SegmentationConfig.seed: must be an integer >= 0 or a numpy.random.Generator, got 1.5",
        ),
        (
            {"min_segment_length": 0},
            "^SegmentationConfig.min_segment_length: must be an integer >= 1 or None, got 0",
        ),
        ({"polyorder": 2}, "^SegmentationConfig.polyorder: must be an integer >= 3 and <= 63, got 2"),
        ({"peak_ratio": 0.5}, "^SegmentationConfig.peak_ratio: must be a finite number >= 1, got 0.5"),
        ({"peak_ratio": "2"}, "^SegmentationConfig.peak_ratio: must be a finite number >= 1, got '2'"),
        ({"peak_ratio": None}, "^SegmentationConfig.peak_ratio: must be a finite number >= 1, got None"),
        (
            {"time_tolerance": "0.1"},
            "^SegmentationConfig.time_tolerance: must be a finite number >= 0 s or None, got '0.1'",
        ),
        ({"duplicate_times": "ignore"}, "^SegmentationConfig.duplicate_times: must be one of"),
        # no window can hold more draws than there are: the result would be [0, T] whatever the data
        (
            {"changepoints": "sample", "n_samples": 2, "n_pass": 5},
            "^SegmentationConfig.n_pass: must be <= n_samples=2 .*got 5",
        ),
    ],
)
def test_config_validation(kwargs: dict, message: str) -> None:
    with pytest.raises(ValueError, match=message):
        SegmentationConfig(**kwargs)


def test_n_pass_above_n_samples_only_matters_in_sample_mode() -> None:
    values, times = event_stream(600)
    streams = [Stream("arm", values, times)]
    peaks = SegmentationConfig(changepoints="peaks", n_samples=2, n_pass=5, window=32, min_run=32)
    default_peaks = SegmentationConfig(changepoints="peaks", window=32, min_run=32)
    # peaks mode draws nothing: the two fields change nothing there
    assert (
        segment_streams(streams, peaks).changepoints.tolist()
        == segment_streams(streams, default_peaks).changepoints.tolist()
    )
    # sample mode, same seed (same draws, same groups): a stricter n_pass, up to n_pass == n_samples,
    # keeps a subset of the candidates (before the minimum segment length, which sees their neighbours)
    kept = [
        set(
            segment_streams(
                streams,
                SegmentationConfig(
                    changepoints="sample", n_samples=5, n_pass=k, window=32, min_run=32, seed=0
                ),
            ).candidates.tolist()
        )
        for k in (1, 3, 5)
    ]
    assert kept[0] >= kept[1] >= kept[2] and kept[0] != kept[2]  # and n_pass does filter


@pytest.mark.parametrize("field", ["values", "times"])
@pytest.mark.parametrize(
    ("data", "shown"),
    [
        (np.array(["a"] * 10), r"an array of shape \(10,\) \(<U1\)"),
        ([[1.0, 2.0], [3.0]] + [[0.0, 0.0]] * 8, r"\[\[1.0, 2.0\], \[3.0\]"),
        ([{"t": 1.0}] * 10, r"\[\{'t': 1.0\}"),
        (
            np.arange(10) * (1 + 1j),
            r"an array of shape \(10,\) \(complex128\)",
        ),  # not cast to real with a warning
    ],
)
def test_unconvertible_values_and_times_name_the_stream(field: str, data, shown: str) -> None:
    # numpy's own message named neither the stream nor the argument
    args = {"values": np.zeros(10), "times": np.arange(10) * DT, field: data}
    with pytest.raises(
        ValueError, match=rf"^Stream\('pos'\).{field}: must be an array of numbers .*got {shown}"
    ):
        Stream("pos", **args)


def test_stream_keeps_caller_arrays_writable() -> None:
    values, times = event_stream(300)
    stream = Stream("arm", values, times)
    assert values.flags.writeable and times.flags.writeable  # the caller's arrays stay writable
    assert not stream.values.flags.writeable  # the stream's own copy is read-only
    with pytest.raises(ValueError):
        stream.values[0, 0] = 1.0
    # the stream holds copies: an edit after the checks (a NaN, a time going back) cannot reach it
    checked = stream.values.copy(), stream.times.copy()
    values[10] = np.nan
    times[5] = -1.0
    np.testing.assert_array_equal(stream.values, checked[0])
    np.testing.assert_array_equal(stream.times, checked[1])


@pytest.mark.parametrize("derivative", ["savgol", "difference"])
@pytest.mark.parametrize(("value_scale", "time_scale"), [(1e200, 1.0), (1.0, 1e110), (1.0, 1e-110)])
def test_a_third_derivative_outside_float64_names_the_stream(derivative, value_scale, time_scale) -> None:
    # an infinite jerk used to be thresholded as a flat stream: no keypoints, no word
    values, times = event_stream()
    config = SegmentationConfig(derivative=derivative, window=32, min_run=32)
    with pytest.raises(
        ValueError,
        match=r"^Stream\('joints'\).values: must have a third derivative within float64's range .*got values changing by up to",
    ):
        segment_streams([Stream("joints", values * value_scale, times * time_scale)], config)


def test_large_values_within_range_keep_their_keypoints() -> None:
    values, times = event_stream()
    config = SegmentationConfig(window=32, min_run=32)
    plain = segment_streams([Stream("joints", values, times)], config)
    scaled = segment_streams([Stream("joints", values * 1e100, times)], config)
    np.testing.assert_array_equal(scaled.keypoints["joints"], plain.keypoints["joints"])


def test_a_stream_weight_above_the_limit_is_refused() -> None:
    values, times = event_stream()
    with pytest.raises(
        ValueError,
        match=r"^Stream\('joints'\).weight: must be a finite number >= 0 and <= 1e\+100, got 1e\+308",
    ):
        Stream("joints", values, times, weight=1e308)
