"""Stream pmfs and the three combination modes: the laws each mode documents."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.segmentation import (
    SegmentationConfig,
    Stream,
    combine_pmfs,
    segment_streams,
    stream_pmf,
)
from lerobot_forcemap.segmentation.reference import loop_segment_streams
from tests.segmentation.helpers import DT, jerk_bursts, random_events, random_stream_values

T = 1200
SIGMA = 64.0


def three_pmfs() -> tuple[np.ndarray, np.ndarray]:
    keypoint_sets = [np.array([300, 700]), np.array([310]), np.array([900, 1000, 650])]
    pmfs, floors = zip(*(stream_pmf(k, T, SIGMA, 1.0) for k in keypoint_sets), strict=True)
    return np.array(pmfs), np.array(floors)


def test_stream_pmf_is_normalised_with_the_documented_floor_mass() -> None:
    p, floor_level = stream_pmf(np.array([400, 800]), T, SIGMA, floor=1.0)
    assert p.sum() == pytest.approx(1.0, abs=1e-12)
    # Interior keypoints: each Gaussian has unit mass, the floor has mass `floor` -> floor share 1/3.
    assert floor_level * T == pytest.approx(1 / 3, rel=1e-6)
    assert p[0] == pytest.approx(floor_level, rel=1e-6)  # 6 sigma from the nearest keypoint
    uniform, level = stream_pmf(np.array([], dtype=np.int64), T, SIGMA, floor=0.3)
    np.testing.assert_allclose(uniform, 1 / T, rtol=1e-12)
    assert level == pytest.approx(1 / T)


def test_product_ignores_weight_scale_and_ratios() -> None:
    pmfs, floors = three_pmfs()
    base, base_floor = combine_pmfs(pmfs, floors, np.array([0.2, 0.3, 0.5]), "product")
    for weights in ([2.0, 3.0, 5.0], [1e-3, 1.5e-3, 2.5e-3], [7.0, 0.01, 1.0]):
        p, f = combine_pmfs(pmfs, floors, np.array(weights), "product")
        np.testing.assert_allclose(p, base, rtol=1e-12)
        assert f == pytest.approx(base_floor, rel=1e-12)
    # ... but a weight of 0 removes the stream.
    dropped, _ = combine_pmfs(pmfs, floors, np.array([0.2, 0.0, 0.5]), "product")
    assert np.abs(dropped - base).max() > 1e-3 * base.max()


def test_product_via_segment_streams_ignores_weight_scale() -> None:
    rng = np.random.default_rng(5)
    onsets, lengths, jerks = random_events(rng)
    a, t = jerk_bursts(2400, onsets, lengths, jerks, rng, n_cols=3, rel_noise=0.02)
    b, _ = jerk_bursts(2400, onsets + 200, lengths, jerks, rng, n_cols=1, rel_noise=0.02)
    config = SegmentationConfig(mode="product")
    results = [
        segment_streams([Stream("a", a, t, weight=c * 0.35), Stream("b", b, t, weight=c * 0.1)], config)
        for c in (1.0, 4.0, 0.01)
    ]
    for r in results[1:]:
        np.testing.assert_allclose(r.pmf, results[0].pmf, rtol=1e-12)
        np.testing.assert_array_equal(r.changepoints, results[0].changepoints)


def test_geometric_laws() -> None:
    pmfs, floors = three_pmfs()
    product, _ = combine_pmfs(pmfs, floors, np.ones(3), "product")
    ones, _ = combine_pmfs(pmfs, floors, np.ones(3), "geometric")
    np.testing.assert_allclose(ones, product, rtol=1e-12)  # all v_i = 1 is the product
    v = np.array([0.1, 0.1, 0.35])
    p, _ = combine_pmfs(pmfs, floors, v, "geometric")
    expected = np.prod(pmfs ** v[:, None], axis=0)
    np.testing.assert_allclose(p, expected / expected.sum(), rtol=1e-10)
    # Scaling the weights by c raises the pmf to the power c (inverse temperature).
    p3, _ = combine_pmfs(pmfs, floors, 3 * v, "geometric")
    np.testing.assert_allclose(p3, p**3 / (p**3).sum(), rtol=1e-9)
    assert p3.max() > p.max()


def test_linear_is_a_scale_invariant_mixture() -> None:
    pmfs, floors = three_pmfs()
    v = np.array([0.1, 0.1, 0.35])
    p, f = combine_pmfs(pmfs, floors, v, "linear")
    np.testing.assert_allclose(p, v @ pmfs / v.sum(), rtol=1e-12)
    assert f == pytest.approx(v @ floors / v.sum())
    p10, _ = combine_pmfs(pmfs, floors, 10 * v, "linear")
    np.testing.assert_allclose(p10, p, rtol=1e-12)


def test_modes_differ_as_documented_for_a_keypoint_seen_by_one_stream() -> None:
    """Stream A has a keypoint at 600, stream B has none (uniform pmf)."""
    pa, fa = stream_pmf(np.array([600]), T, SIGMA, 1.0)
    pb, fb = stream_pmf(np.array([], dtype=np.int64), T, SIGMA, 1.0)
    pmfs, floors = np.array([pa, pb]), np.array([fa, fb])
    single_ratio = pa[600] / fa
    for va in (0.1, 0.35, 0.8):
        w = np.array([va, 1 - va])
        prod, prod_floor = combine_pmfs(pmfs, floors, w, "product")
        geo, geo_floor = combine_pmfs(pmfs, floors, w, "geometric")
        lin, lin_floor = combine_pmfs(pmfs, floors, w, "linear")
        # product: a uniform stream changes nothing, whatever the weights
        np.testing.assert_allclose(prod, pa, rtol=1e-12)
        # geometric: peak-to-floor ratio is the single-stream ratio to the power v_A
        assert geo[600] / geo_floor == pytest.approx(single_ratio**va, rel=1e-9)
        # linear: the bump above the floor scales linearly with v_A / sum(v)
        assert (lin[600] - lin_floor) == pytest.approx(va * (pa[600] - fa), rel=1e-9)


def test_zero_weight_streams_are_left_out_without_nan() -> None:
    rng = np.random.default_rng(7)
    onsets, lengths, jerks = random_events(rng)
    a, t = jerk_bursts(2400, onsets, lengths, jerks, rng, n_cols=3, rel_noise=0.02)
    spiky, _ = jerk_bursts(2400, onsets + 300, lengths, jerks, rng, rel_noise=0.02)
    for mode in ("product", "geometric", "linear"):
        config = SegmentationConfig(mode=mode)
        alone = segment_streams([Stream("a", a, t, weight=0.4)], config)
        with_zero = segment_streams(
            [
                Stream("a", a, t, weight=0.4),
                Stream("spiky", spiky, t, weight=0.0),
                Stream("still", np.zeros(2400), t, weight=0.0),
            ],
            config,
        )
        assert np.isfinite(with_zero.pmf).all()
        np.testing.assert_allclose(with_zero.pmf, alone.pmf, rtol=1e-12)
        np.testing.assert_array_equal(with_zero.changepoints, alone.changepoints)
        assert (
            not with_zero.streams["spiky"].used and with_zero.keypoints["spiky"].size == 3
        )  # still reported


def test_all_zero_weights_is_an_error() -> None:
    t = np.arange(200) * DT
    streams = [Stream("a", np.sin(t), t, weight=0.0), Stream("b", np.cos(t), t, weight=0.0)]
    with pytest.raises(
        ValueError, match=r"^segment_streams\(streams=...\): must give at least one stream a weight > 0"
    ):
        segment_streams(streams)
    pmfs, floors = three_pmfs()
    with pytest.raises(ValueError, match="^weights: must give at least one stream a weight > 0"):
        combine_pmfs(pmfs, floors, np.zeros(3), "linear")


@pytest.mark.parametrize("mode", ["product", "geometric", "linear"])
@pytest.mark.parametrize("changepoints", ["peaks", "sample"])
def test_segment_streams_agrees_with_per_sample_loop_reference(mode: str, changepoints: str) -> None:
    rng = np.random.default_rng(11)
    config = SegmentationConfig(mode=mode, changepoints=changepoints, window=32, min_run=24, seed=4)
    for _ in range(3):
        n = int(rng.integers(300, 700))
        t = np.cumsum(rng.uniform(0.005, 0.007, size=n))
        streams = [
            Stream(
                f"s{i}",
                random_stream_values(rng, n, int(rng.integers(1, 4))),
                t,
                weight=float(w),
                threshold=0.2,
            )
            for i, w in enumerate(rng.choice([0.0, 0.1, 0.35, 1.0], size=4))
        ]
        if all(s.weight == 0 for s in streams):
            continue
        fast = segment_streams(streams, config)
        ref = loop_segment_streams(streams, config)
        assert {k: v.tolist() for k, v in fast.keypoints.items()} == ref["keypoints"]
        np.testing.assert_allclose(fast.pmf, ref["pmf"], rtol=1e-9, atol=0)
        np.testing.assert_array_equal(fast.changepoints, ref["changepoints"])


def test_a_gaussian_wider_than_the_demo_is_cut_at_its_length() -> None:
    """σ = 1e7 frames used to build a (K, 1.6e8) table (4 GB for T = 600); every frame lies within T of
    each keypoint, so cutting there changes nothing."""
    n = 600
    p, level = stream_pmf(np.array([100, 500]), n, 1e7, floor=1.0)
    frames = np.arange(n)
    direct = sum(np.exp(-0.5 * ((frames - k) / 1e7) ** 2) / (1e7 * np.sqrt(2 * np.pi)) for k in (100, 500))
    direct = direct + 1.0 / n
    np.testing.assert_allclose(p, direct / direct.sum(), rtol=1e-12)
    assert level == pytest.approx((1.0 / n) / direct.sum(), rel=1e-12)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        ((np.array([5]), 0, SIGMA, 1.0), "^n_frames: must be an integer >= 1 and <= 100000000, got 0"),
        # a fractional or NaN keypoint was truncated to some frame
        (
            (np.array([5.5]), T, SIGMA, 1.0),
            r"^keypoints: must hold whole numbers only \(the first bad one is at index 0\), got 5.5",
        ),
        (
            (np.array([3.0, np.nan]), T, SIGMA, 1.0),
            r"^keypoints: must hold whole numbers only \(the first bad one is at index 1\), got nan",
        ),
        # 10**12 frames ran into a MemoryError
        (
            (np.array([5]), 10**12, SIGMA, 1.0),
            "^n_frames: must be an integer >= 1 and <= 100000000, got 10+$",
        ),
        ((np.array([5]), T, 0.0, 1.0), r"^sigma: must be a finite number >= 0.001 samples, got 0.0"),
        ((np.array([], dtype=np.int64), T, SIGMA, 0.0), "^floor: must be a finite number > 0, got 0.0"),
        ((np.array([5, T]), T, SIGMA, 1.0), rf"^keypoints: must be frames in \[0, {T}\), got 5..{T}"),
    ],
)
def test_stream_pmf_refuses_what_would_give_nan_or_a_division_by_zero(args, message) -> None:
    with pytest.raises(ValueError, match=message):
        stream_pmf(*args)


def test_combine_pmfs_refuses_weights_it_would_drop_or_misalign() -> None:
    pmfs, floors = three_pmfs()
    with pytest.raises(ValueError, match=r"^weights: must be >= 0, got \[1.0, -1.0, 1.0\]"):
        combine_pmfs(pmfs, floors, np.array([1.0, -1.0, 1.0]), "linear")
    with pytest.raises(
        ValueError,
        match=r"^weights: must hold finite values only \(the first bad one is at stream 1\), got nan",
    ):
        combine_pmfs(pmfs, floors, np.array([1.0, np.nan, 1.0]), "geometric")
    with pytest.raises(ValueError, match=r"^weights: must have shape \(3,\), got shape \(2,\)"):
        combine_pmfs(pmfs, floors, np.ones(2), "product")
