"""Changepoints: deterministic peaks, seeded sampling, minimum segment length, output format."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.segmentation import (
    SegmentationConfig,
    Stream,
    enforce_min_segment_length,
    peak_changepoints,
    sample_changepoints,
    segment_streams,
    stream_pmf,
)
from tests.segmentation.helpers import jerk_bursts, random_events


def demo_streams(seed: int = 0) -> list[Stream]:
    rng = np.random.default_rng(seed)
    onsets, lengths, jerks = random_events(rng)
    arm, t = jerk_bursts(2400, onsets, lengths, jerks, rng, n_cols=3, rel_noise=0.05)
    force, _ = jerk_bursts(2400, onsets + 150, lengths // 2, jerks, rng, n_cols=3, rel_noise=0.05)
    grip, _ = jerk_bursts(2400, np.array([1300]), np.array([200]), np.array([1.0]), rng, rel_noise=0.05)
    return [
        Stream("arm", arm, t, weight=0.3, threshold=0.25),
        Stream("force", force, t, weight=0.5, threshold=0.15),
        Stream("gripper", grip, t, weight=0.2, threshold=0.1),
    ]


def test_output_format() -> None:
    seg = segment_streams(demo_streams(), SegmentationConfig())
    cp = seg.changepoints
    assert cp.dtype == np.int64 and cp[0] == 0 and cp[-1] == 2400
    assert np.all(np.diff(cp) > 0)
    assert seg.n_segments == cp.size - 1 >= 3
    labels = seg.labels()
    assert labels.shape == (2400,) and labels[0] == 0 and labels[-1] == seg.n_segments - 1
    assert seg.segments[0] == (0, int(cp[1]))


def test_peaks_are_deterministic_and_ignore_the_seed() -> None:
    streams = demo_streams(1)
    runs = [
        segment_streams(streams, SegmentationConfig(changepoints="peaks", seed=s)) for s in (0, 0, 1, 12345)
    ]
    for r in runs[1:]:
        np.testing.assert_array_equal(r.changepoints, runs[0].changepoints)
        np.testing.assert_array_equal(r.pmf, runs[0].pmf)
    assert runs[0].draws is None


def test_peaks_are_tall_separated_local_maxima() -> None:
    window = 64
    p, floor_level = stream_pmf(np.array([200, 230, 500, 900, 1000]), 1200, 40.0, 1.0)
    peaks = peak_changepoints(p, floor_level, 2.0, window)
    assert peaks.size >= 3
    assert np.all(np.diff(peaks) >= window)
    assert np.all(p[peaks] >= 2.0 * floor_level)
    assert np.all((p[peaks] >= p[peaks - 1]) & (p[peaks] >= p[peaks + 1]))
    # a flat pmf has no peaks
    flat, level = stream_pmf(np.array([], dtype=np.int64), 1200, 40.0, 1.0)
    assert peak_changepoints(flat, level, 2.0, window).size == 0


def test_sample_mode_is_reproducible_per_seed() -> None:
    streams = demo_streams(2)
    a = segment_streams(streams, SegmentationConfig(changepoints="sample", n_samples=40, seed=7))
    b = segment_streams(streams, SegmentationConfig(changepoints="sample", n_samples=40, seed=7))
    np.testing.assert_array_equal(a.draws, b.draws)
    np.testing.assert_array_equal(a.changepoints, b.changepoints)
    # a Generator seeded the same way gives the same result; it is advanced by the call
    gen = np.random.default_rng(7)
    c = segment_streams(streams, SegmentationConfig(changepoints="sample", n_samples=40, seed=gen))
    np.testing.assert_array_equal(c.draws, a.draws)
    d = segment_streams(streams, SegmentationConfig(changepoints="sample", n_samples=40, seed=gen))
    assert not np.array_equal(d.draws, a.draws)
    others = [
        segment_streams(streams, SegmentationConfig(changepoints="sample", n_samples=40, seed=s)).draws
        for s in range(5)
    ]
    assert len({tuple(o) for o in others}) == 5
    assert SegmentationConfig().seed == 0  # reproducible by default


def test_sample_grouping_follows_the_paper() -> None:
    # All mass on frames 100, 101, 400 and 900 (0.3, 0.3, 0.3, 0.1): groups form around 100 and 400.
    pmf = np.zeros(1000)
    pmf[[100, 101, 400, 900]] = [0.3, 0.3, 0.3, 0.1]
    cands, draws = sample_changepoints(pmf, np.random.default_rng(0), n_samples=200, n_pass=3, window=64)
    assert set(draws.tolist()) <= {100, 101, 400, 900}
    near_100 = draws[draws < 200]
    assert cands.tolist() == [int(np.mean(near_100)), 400, 900]
    # n_pass larger than any group: no changepoint
    cands, _ = sample_changepoints(pmf, np.random.default_rng(0), n_samples=5, n_pass=6, window=64)
    assert cands.size == 0


def test_min_segment_length_is_enforced_strongest_first() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        n = int(rng.integers(50, 3000))
        cands = np.sort(rng.integers(0, n + 1, size=int(rng.integers(0, 30))))
        strength = rng.uniform(size=cands.size)
        min_len = int(rng.integers(1, 200))
        cp, rejected = enforce_min_segment_length(cands, strength, n, min_len)
        assert cp[0] == 0 and cp[-1] == n
        interior = cp[1:-1]
        if n >= 2 * min_len:
            assert np.all(np.diff(cp) >= min_len)
        assert sorted([*interior.tolist(), *rejected.tolist()]) == sorted(cands.tolist())
        if cands.size:
            best = int(np.argmax(strength))
            if min_len <= cands[best] <= n - min_len:
                assert cands[best] in interior  # the strongest valid candidate always survives


def test_min_segment_length_in_segment_streams() -> None:
    streams = demo_streams(4)
    short = segment_streams(streams, SegmentationConfig(min_segment_length=1, window=32, min_run=32))
    assert np.diff(short.changepoints).min() < 400  # there are close changepoints to merge
    long = segment_streams(streams, SegmentationConfig(min_segment_length=400, window=32, min_run=32))
    assert np.diff(long.changepoints).min() >= 400
    assert long.rejected.size > 0
    default = segment_streams(streams, SegmentationConfig())
    assert np.diff(default.changepoints).min() >= 32  # window // 2


@pytest.mark.parametrize("changepoints", ["peaks", "sample"])
def test_no_changepoint_repeats_the_ends(changepoints: str) -> None:
    for seed in range(5):
        seg = segment_streams(demo_streams(seed), SegmentationConfig(changepoints=changepoints, seed=seed))
        assert np.all(np.diff(seg.changepoints) >= seg.config.min_segment_frames)


def test_flat_pmf_reproduces_the_papers_segment_counts() -> None:
    """With window 64, 20 samples and n_pass 3 a flat pmf over 1000 frames already yields
    4.07 ± 0.91 segments (the paper's Table I level) when no minimum segment length is applied."""
    pmf = np.full(1000, 1e-3)
    rng = np.random.default_rng(0)
    counts = []
    for _ in range(4000):
        cands, _ = sample_changepoints(pmf, rng, n_samples=20, n_pass=3, window=64)
        changepoints, _ = enforce_min_segment_length(cands, pmf[cands], 1000, 1)
        counts.append(changepoints.size - 1)
    assert np.mean(counts) == pytest.approx(4.07, abs=0.06)
    assert np.std(counts) == pytest.approx(0.91, abs=0.05)


@pytest.mark.parametrize(("gap", "expected"), [(63, [163]), (64, [100, 164])])
def test_peaks_closer_than_window_are_one_changepoint(gap: int, expected: list[int]) -> None:
    """Peaks mode: local maxima at least `window` apart (the taller of two closer ones stays)."""
    pmf = np.full(400, 1e-3)
    pmf[100], pmf[100 + gap] = 0.01, 0.02
    assert peak_changepoints(pmf, 1e-3, 2.0, 64).tolist() == expected


def test_a_flat_topped_peak_is_one_changepoint_at_its_middle_in_library_and_reference():
    """Two keypoints an odd number of frames apart give a pmf with a two-sample flat top: one peak, at
    its lower middle (scipy's rule), found by the library and by the per-sample reference loop alike."""
    from lerobot_forcemap.segmentation.reference import loop_peaks

    pmf, floor = stream_pmf(np.array([110, 159]), 233, 26.0, 1.0)
    assert pmf[134] == pmf[135] > max(pmf[133], pmf[136])
    assert peak_changepoints(pmf, floor, 2.0, 26).tolist() == [134]
    assert loop_peaks(pmf, floor, 2.0, 26) == [134]
    wide = np.array(
        [0.1, 0.2, 0.5, 0.5, 0.5, 0.5, 0.2, 0.5, 0.5]
    )  # 4-wide top; a plateau at the edge is no peak
    assert peak_changepoints(wide, 0.01, 2.0, 1).tolist() == loop_peaks(wide, 0.01, 2.0, 1) == [3]


def test_peaks_must_reach_peak_ratio_times_the_floor():
    """Peaks must stand above the floor by the documented margin: in linear pooling a keypoint that only one
    of two streams sees stands 1.6x above the floor, below the default peak_ratio of 2."""
    from lerobot_forcemap.segmentation.combine import combine_pmfs, stream_pmf
    from lerobot_forcemap.segmentation.config import SegmentationConfig

    cfg = SegmentationConfig()
    n = 300
    one, f_one = stream_pmf(np.array([150]), n, cfg.sigma_frames, cfg.floor)
    none, f_none = stream_pmf(np.array([], dtype=int), n, cfg.sigma_frames, cfg.floor)
    pmf, floor = combine_pmfs(
        np.stack([one, none]), np.array([f_one, f_none]), np.array([1.0, 1.0]), "linear"
    )
    ratio = pmf.max() / floor
    assert 1.5 < ratio < 2.0 and cfg.peak_ratio == 2.0
    assert peak_changepoints(pmf, floor, cfg.peak_ratio, cfg.window).tolist() == []
    assert peak_changepoints(pmf, floor, 1.0, cfg.window).tolist() == [150]
    assert peak_changepoints(pmf, floor, ratio * 1.001, cfg.window).tolist() == []


def test_low_level_counts_are_checked_before_they_make_empty_segments() -> None:
    # min_length 0 accepted 0, T and repeats: [0, 0, 5, 5, 10, 10], three empty segments
    with pytest.raises(ValueError, match="^min_length: must be an integer >= 1, got 0"):
        enforce_min_segment_length(np.array([0, 5, 5, 10]), np.ones(4), 10, 0)
    with pytest.raises(ValueError, match="^n_frames: must be an integer >= 1, got 0"):
        enforce_min_segment_length(np.array([], dtype=np.int64), np.ones(0), 0, 1)
    with pytest.raises(ValueError, match=r"^strength: must have shape \(2,\), got shape \(3,\)"):
        enforce_min_segment_length(np.array([3, 6]), np.ones(3), 10, 1)
    pmf = np.full(100, 0.01)
    with pytest.raises(ValueError, match="^window: must be an integer >= 1, got 0"):
        peak_changepoints(pmf, 0.01, 2.0, 0)
    with pytest.raises(ValueError, match="^window: must be an integer >= 1, got 0"):
        sample_changepoints(pmf, np.random.default_rng(0), 20, 3, 0)
    cp, rejected = enforce_min_segment_length(np.array([0, 5, 5, 10]), np.ones(4), 10, 1)
    assert cp.tolist() == [0, 5, 10] and rejected.tolist() == [0, 5, 10]


def test_the_exported_keypoint_functions_check_what_segment_streams_would_have_checked() -> None:
    from lerobot_forcemap.segmentation import jerk_contrast, savgol_third_derivative, stream_keypoints

    t = np.arange(200) * 0.01
    x = np.zeros((200, 1))
    kwargs = dict(threshold=0.2, window=32, min_run=8, grace=2)
    with pytest.raises(ValueError, match=r"^t: must be strictly increasing, got a step <= 0 after frame 99"):
        stream_keypoints(x, np.r_[t[:100], t[100:] - 1.0], **kwargs)  # gave keypoints silently
    with pytest.raises(ValueError, match=r"^x: must have shape \(n, k\) with n >= 35 .* got shape \(200,\)"):
        stream_keypoints(x[:, 0], t, derivative="difference", **kwargs)
    with pytest.raises(
        ValueError, match=r"^x: must hold finite values only \(the first bad one is at frame 0, column 0\)"
    ):
        stream_keypoints(np.full((200, 1), np.nan), t, **kwargs)
    with pytest.raises(
        ValueError, match=r"^x: must have shape \(n, k\) with n >= window=32 and k >= 1, got shape \(10, 1\)"
    ):
        savgol_third_derivative(x[:10], 0.01, 32, 4)
    with pytest.raises(
        ValueError, match=r"^signal: must hold finite values only \(the first bad one is at index 0\)"
    ):
        jerk_contrast(np.array([np.nan, 1.0]))
