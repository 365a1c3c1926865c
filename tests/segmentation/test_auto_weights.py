"""Label-free stream weights from the jerk contrast."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.segmentation import (
    SegmentationConfig,
    Stream,
    auto_weights,
    jerk_contrast,
    reweighted,
    segment_streams,
)
from tests.segmentation.helpers import DT, jerk_bursts, random_events


def streams(seed: int = 0) -> list[Stream]:
    rng = np.random.default_rng(seed)
    onsets, lengths, jerks = random_events(rng)
    clean, t = jerk_bursts(2400, onsets, lengths, jerks, rng, n_cols=3, rel_noise=0.02)
    noisy, _ = jerk_bursts(
        2400, onsets, lengths, jerks, rng, n_cols=3, rel_noise=3.0
    )  # noise swamps the jerk
    return [
        Stream("clean", clean, t, weight=0.5),
        Stream("noisy", noisy, t, weight=0.5),
        Stream("still", np.full(2400, 3.0), t, weight=0.5),
    ]


def test_weights_sum_to_one_and_rank_streams_by_contrast() -> None:
    w = auto_weights(streams())
    assert set(w) == {"clean", "noisy", "still"}
    assert sum(w.values()) == pytest.approx(1.0)
    assert w["still"] == 0.0  # flat: nothing to offer
    assert w["clean"] > 2 * w["noisy"] > 0


def test_weights_ignore_units_and_given_weights() -> None:
    base = auto_weights(streams())
    scaled = [
        Stream(s.name, s.values * 1000.0 + 5.0, s.times, weight=0.01 + i, threshold=s.threshold)
        for i, s in enumerate(streams())
    ]
    for name, value in auto_weights(scaled).items():
        assert value == pytest.approx(base[name], rel=1e-6)


def test_jerk_contrast_law() -> None:
    signal = np.full(100, 0.05)
    signal[10] = 1.0
    assert jerk_contrast(signal) == pytest.approx(np.log(20.0))
    assert jerk_contrast(np.zeros(10)) == 0.0
    quiet = np.zeros(100)
    quiet[3] = 1.0
    assert jerk_contrast(quiet) == pytest.approx(np.log(1000.0))  # capped


def test_all_flat_gives_uniform_weights_with_a_warning() -> None:
    t = np.arange(300) * DT
    with pytest.warns(UserWarning, match="all flat"):
        w = auto_weights([Stream("a", np.zeros(300), t), Stream("b", np.ones((300, 2)), t)])
    assert w == {"a": 0.5, "b": 0.5}


def test_reweighted_feeds_segment_streams() -> None:
    s = streams()
    w = auto_weights(s, SegmentationConfig())
    seg = segment_streams(reweighted(s, w), SegmentationConfig())
    assert seg.streams["clean"].weight == pytest.approx(w["clean"])
    assert not seg.streams["still"].used
    with pytest.raises(
        ValueError, match=r"^weights: must give a weight for every stream, got none for \['noisy', 'still'\]"
    ):
        reweighted(s, {"clean": 1.0})
    with pytest.raises(
        ValueError, match=r"^weights: must name only the given streams, got unknown streams \['ghost'\]"
    ):
        reweighted(s, {**w, "ghost": 1.0})
    with pytest.raises(
        ValueError, match=r"^reweighted\(streams=...\): must hold Stream objects, got ndarray at \[0\]"
    ):
        reweighted([np.zeros(10)], {})


def test_auto_weights_takes_stream_objects() -> None:
    # a bare array used to fail with AttributeError: 'numpy.ndarray' object has no attribute 'name'
    with pytest.raises(
        ValueError, match=r"^auto_weights\(streams=...\): must hold Stream objects, got ndarray at \[0\]"
    ):
        auto_weights([np.zeros((100, 3))])
    with pytest.raises(
        ValueError, match=r"^auto_weights\(streams=...\): must hold Stream objects, got str at \[3\]"
    ):
        auto_weights([*streams(), "still"])
    with pytest.raises(ValueError, match=r"^auto_weights\(streams=...\): must hold at least one stream"):
        auto_weights([])
