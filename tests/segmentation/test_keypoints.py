"""Per-stream keypoints: known jerk events, the derivative kernels, and agreement with the loop reference."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import savgol_filter

from lerobot_forcemap.segmentation import (
    SegmentationConfig,
    Stream,
    segment_streams,
    stream_keypoints,
    threshold_runs,
)
from lerobot_forcemap.segmentation.keypoints import (
    FLAT_RELATIVE,
    difference_third_derivative,
    jerk_norm,
    roundoff_jerk,
    savgol_third_derivative,
    savgol_third_derivative_kernels,
)
from lerobot_forcemap.segmentation.reference import (
    loop_run_starts,
    loop_signal,
    loop_stream_keypoints,
    loop_third_derivative,
)
from tests.segmentation.helpers import DT, jerk_bursts, random_events, random_stream_values


@pytest.mark.parametrize("seed", range(6))
@pytest.mark.parametrize("threshold", [0.2, 0.25])
def test_keypoints_land_within_half_window_of_jerk_onsets(seed: int, threshold: float) -> None:
    rng = np.random.default_rng(seed)
    config = SegmentationConfig()  # window 64, min_run 64, grace 4, savgol
    onsets, lengths, jerks = random_events(rng)
    values, times = jerk_bursts(2400, onsets, lengths, jerks, rng, n_cols=1 + seed % 3, rel_noise=0.02)
    seg = segment_streams([Stream("pos", values, times, threshold=threshold)], config)
    keypoints = seg.keypoints["pos"]
    assert keypoints.shape == onsets.shape, (keypoints, onsets)
    assert np.all(np.abs(keypoints - onsets) <= config.window // 2), keypoints - onsets


@pytest.mark.parametrize(("window", "polyorder"), [(64, 4), (33, 4), (20, 3)])
def test_savgol_third_derivative_equals_scipy(window: int, polyorder: int) -> None:
    rng = np.random.default_rng(window)
    x = np.cumsum(rng.normal(size=(500, 3)), axis=0)
    dt = 0.0073
    ours = savgol_third_derivative(x, dt, window, polyorder)
    scipy_d3 = savgol_filter(x, window, polyorder, deriv=3, delta=dt, axis=0, mode="interp")
    np.testing.assert_allclose(ours, scipy_d3, rtol=0, atol=1e-9 * np.abs(scipy_d3).max())


def test_difference_derivative_equals_loop_with_real_dt() -> None:
    rng = np.random.default_rng(1)
    t = np.cumsum(rng.uniform(0.004, 0.008, size=300))
    x = rng.normal(size=(300, 2))
    np.testing.assert_allclose(
        difference_third_derivative(x, t), loop_third_derivative(x, t, "difference", 64, 4), rtol=1e-10
    )


def test_threshold_runs_agree_exactly_with_loop_reference() -> None:
    rng = np.random.default_rng(2)
    for _ in range(400):
        n = int(rng.integers(1, 400))
        # Piecewise-constant random levels make long runs, short dips and dips of exactly `grace`.
        levels = rng.uniform(size=int(rng.integers(1, 60)))
        signal = levels[np.sort(rng.integers(0, levels.size, size=n))]
        signal = np.where(rng.uniform(size=n) < 0.05, rng.uniform(size=n), signal)
        threshold = float(rng.uniform(0.05, 0.95))
        min_run = int(rng.integers(1, 80))
        grace = int(rng.integers(0, 8))
        ours = threshold_runs(signal, threshold, min_run, grace)
        ref = loop_run_starts(signal.tolist(), threshold, min_run, grace)
        assert ours.tolist() == ref, (threshold, min_run, grace)


def test_grace_min_run_and_start_semantics() -> None:
    def runs(mask: list[int], min_run: int = 5, grace: int = 2) -> list[int]:
        return threshold_runs(np.array(mask, dtype=float), 0.5, min_run, grace).tolist()

    assert runs([0, 0, 1, 1, 1, 1, 1, 0]) == [2]  # exactly min_run
    assert runs([0, 0, 1, 1, 1, 1, 0, 0]) == []  # min_run - 1
    assert runs([0, 1, 1, 1, 0, 0, 1, 1, 1, 0]) == [1]  # dip of `grace` bridged: one run of 8
    assert runs([0, 1, 1, 1, 0, 0, 0, 1, 1, 1, 1, 1, 0]) == [7]  # dip of grace + 1 ends the first (short) run
    assert runs([0, 1, 1, 1, 1, 1, 0, 0, 0, 1, 1, 1, 1, 1]) == [1, 9]  # a new keypoint after a real drop
    assert runs([1, 1, 1, 1, 1, 1, 0, 0, 0]) == []  # high from the first sample: no keypoint


@pytest.mark.parametrize("derivative", ["savgol", "difference"])
def test_stream_keypoints_agree_exactly_with_per_sample_loop(derivative: str) -> None:
    rng = np.random.default_rng(3)
    config = SegmentationConfig(derivative=derivative, window=32, min_run=24, grace=3)
    n_keypoints = 0
    for trial in range(25):
        n = int(rng.integers(120, 900))
        values = random_stream_values(rng, n, int(rng.integers(1, 4)))
        times = np.cumsum(rng.uniform(0.005, 0.007, size=n))
        stream = Stream("s", values, times, threshold=float(rng.uniform(0.1, 0.4)))
        found = stream_keypoints(
            stream.values,
            stream.times,
            threshold=stream.threshold,
            window=config.window,
            min_run=config.min_run,
            grace=config.grace,
            derivative=derivative,
        )
        assert found.keypoints.tolist() == loop_stream_keypoints(stream, config), trial
        np.testing.assert_allclose(
            found.signal, loop_signal(stream.values, stream.times, derivative, config.window, 4), atol=1e-9
        )
        n_keypoints += found.keypoints.size
    assert n_keypoints > 10  # the comparison exercised real keypoints


def test_flat_stream_gives_no_keypoints_and_no_nan() -> None:
    t = np.arange(500) * DT
    seg = segment_streams(
        [
            Stream("still", np.ones((500, 2)), t),
            Stream("moving", random_stream_values(np.random.default_rng(0), 500, 2), t),
        ]
    )
    still = seg.streams["still"]
    assert still.flat and still.keypoints.size == 0
    assert np.all(still.signal == 0)
    np.testing.assert_allclose(still.pmf, 1 / 500)
    assert np.isfinite(seg.pmf).all()


@pytest.mark.parametrize("derivative", ["savgol", "difference"])
def test_roundoff_jerk_is_the_flat_fraction_of_the_largest_jerk_the_range_allows(derivative: str) -> None:
    """roundoff_jerk / FLAT_RELATIVE bounds the jerk norm of any stream by its range about the first
    sample, and the worst case reaches it. The loop reference shares this function, so it is checked
    here against the derivatives themselves."""
    window, polyorder, n, v = 21, 4, 200, 0.02
    t = np.arange(n) * DT
    if derivative == "difference":  # [0, v, -v, v, ...]: every third difference is 8 v
        worst = np.where(np.arange(n) % 2 == 1, v, -v)
        worst[0] = 0.0
    else:  # the end samples follow the signs of the largest end kernel row
        right = savgol_third_derivative_kernels(window, polyorder)[2]
        worst = np.zeros(n)
        worst[n - window :] = v * np.sign(right[np.abs(right).sum(axis=1).argmax()])
    rng = np.random.default_rng(3)
    for k in (1, 3):
        cases = (
            np.tile(worst[:, None], k),
            rng.uniform(-v, v, (n, k)),
            np.cumsum(rng.normal(0, 1e-3, (n, k)), axis=0),
        )
        for i, x in enumerate(cases):
            bound = roundoff_jerk(x, t, derivative, window, polyorder) / FLAT_RELATIVE
            jerk = jerk_norm(x, t, derivative, window, polyorder).max()
            assert jerk <= bound * (1 + 1e-12)
            if i == 0:
                assert jerk == pytest.approx(bound, rel=1e-9)


def test_an_exactly_linear_ramp_is_flat_not_round_off_keypoints() -> None:
    t = np.arange(400) * DT
    ramp = np.linspace(0.0, 0.08, 400)[:, None] * [1.0, -0.5]  # a scripted gripper opening
    seg = segment_streams(
        [Stream("ramp", ramp, t), Stream("moving", random_stream_values(np.random.default_rng(1), 400, 2), t)]
    )
    assert (
        0 < jerk_norm(ramp, t, "savgol", 64, 4).max() < roundoff_jerk(ramp, t, "savgol", 64, 4)
    )  # round-off only
    assert seg.streams["ramp"].flat and seg.streams["ramp"].keypoints.size == 0
