"""Streams with given keypoints (contact events) and the segmentation's settings in seconds."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.segmentation import (
    DEFAULT_TIMING,
    EVENT_STREAM_WEIGHT,
    EventStream,
    SegmentationConfig,
    SegmentationTiming,
    Stream,
    contact_event_streams,
    segment_streams,
)
from lerobot_forcemap.segmentation.combine import stream_pmf


def _motion(times: np.ndarray) -> np.ndarray:
    """A smooth reach with no jerk burst near the contacts: the signal streams find nothing there."""
    s = np.clip(times / times[-1], 0.0, 1.0)
    return np.stack([0.3 * s**3 * (10 - 15 * s + 6 * s**2), np.zeros_like(s)], axis=1)


def test_event_keypoints_are_the_frames_nearest_to_the_events():
    t = np.arange(100) / 50.0
    stream = EventStream("touch_down", [0.5, 0.519, 0.9, -1.0, 99.0], t)
    np.testing.assert_array_equal(stream.keypoints(), [0, 25, 26, 45, 99])
    assert stream.sigma_frames(7.0) == 7.0  # the config's sigma unless the stream has its own
    assert EventStream("x", [], t, sigma_s=0.05).sigma_frames(7.0) == pytest.approx(2.5)
    assert EventStream("x", [], t).keypoints().size == 0


@pytest.mark.parametrize("fps", [20.0, 50.0, 166.0])
def test_both_edges_of_a_short_contact_become_changepoints_at_any_rate(fps):
    """A 0.34 s press (the shortest of the UR5e recordings) in a motion the signal streams do not cut:
    the two event streams put changepoints on touch-down and lift-off, within a frame, at any rate."""
    t = np.arange(int(6 * fps)) / fps
    contacts = np.array([[2.0, 2.34], [4.1, 4.8]])
    streams = [Stream("position", _motion(t), t), *contact_event_streams(t, contacts)]
    result = segment_streams(streams, DEFAULT_TIMING.config(fps))
    found = t[result.changepoints[1:-1]]
    for event in contacts.ravel():
        assert np.min(np.abs(found - event)) <= 1.0 / fps
    # the event streams' pmfs are Gaussians exactly at the events (no lead to correct)
    pmf = result.streams["lift_off"].pmf
    assert np.argmax(pmf) in np.searchsorted(t, contacts[:, 1] - 0.5 / fps) + np.array([[0], [1]])


def test_a_contact_stream_without_events_is_flat_and_changes_nothing():
    t = np.arange(300) / 50.0
    config = DEFAULT_TIMING.config(50.0)
    alone = segment_streams([Stream("position", _motion(t), t)], config)
    both = segment_streams(
        [Stream("position", _motion(t), t), *contact_event_streams(t, np.zeros((0, 2)))], config
    )
    np.testing.assert_array_equal(alone.changepoints, both.changepoints)
    assert both.streams["touch_down"].flat and both.streams["touch_down"].keypoints.size == 0
    flat, _ = stream_pmf(np.zeros(0, dtype=np.int64), 300, 2.5, 1.0)
    np.testing.assert_allclose(both.streams["touch_down"].pmf, flat)


def test_contact_event_streams_weights():
    t = np.arange(100) / 50.0
    streams = contact_event_streams(t, [[0.5, 1.0]])
    assert [(s.name, s.weight, s.sigma_s) for s in streams] == [
        ("touch_down", EVENT_STREAM_WEIGHT, DEFAULT_TIMING.event_sigma_s),
        ("lift_off", EVENT_STREAM_WEIGHT, DEFAULT_TIMING.event_sigma_s),
    ]
    (only,) = contact_event_streams(t, [[0.5, 1.0]], weights={"touch_down": 0.0, "lift_off": 2.0})
    assert only.name == "lift_off" and only.weight == 2.0 and list(only.events) == [1.0]


@pytest.mark.parametrize(
    ("fps", "window", "min_run", "grace", "shortest"),
    [(20.0, 6, 6, 0, 3), (50.0, 15, 15, 1, 7), (166.0, 50, 50, 3, 25), (5.0, 5, 5, 0, 2)],
)
def test_the_default_timing_in_frames(fps, window, min_run, grace, shortest):
    config = DEFAULT_TIMING.config(fps, mode="linear", seed=3)
    assert (config.window, config.min_run, config.grace, config.min_segment_frames) == (
        window,
        min_run,
        grace,
        shortest,
    )
    assert config.mode == "linear" and config.seed == 3


def test_timing_in_seconds_converts_every_count():
    timing = SegmentationTiming(window_s=0.4, min_run_s=0.2, grace_s=0.05, min_segment_s=0.15)
    config = timing.config(100.0)
    assert (config.window, config.min_run, config.grace, config.min_segment_length) == (40, 20, 5, 15)
    assert isinstance(config, SegmentationConfig)


def test_bad_settings_are_named():
    t = np.arange(10) / 10.0
    with pytest.raises(ValueError, match=r"^SegmentationTiming.window_s: must be a finite number > 0 s"):
        SegmentationTiming(window_s=0.0)
    with pytest.raises(ValueError, match=r"^SegmentationTiming.grace_s: must be a finite number >= 0 s"):
        SegmentationTiming(grace_s=-1.0)
    with pytest.raises(ValueError, match=r"^fps: must be a finite number > 0 Hz"):
        DEFAULT_TIMING.config(0.0)
    with pytest.raises(ValueError, match=r"^EventStream\('td'\).events: must hold finite values only"):
        EventStream("td", [0.1, np.nan], t)
    with pytest.raises(ValueError, match=r"^EventStream\('td'\).times: must be non-decreasing"):
        EventStream("td", [0.1], t[::-1])
    with pytest.raises(ValueError, match=r"^EventStream\('td'\).sigma_s: must be a finite number > 0 s"):
        EventStream("td", [0.1], t, sigma_s=0.0)
    with pytest.raises(ValueError, match=r"^EventStream.name: must be a non-empty string"):
        EventStream("", [0.1], t)
    with pytest.raises(ValueError, match=r"^intervals: must have 1 or 2 dimension"):
        contact_event_streams(t, np.zeros((1, 2, 2)))
    with pytest.raises(ValueError, match=r"^segment_streams\(streams=...\): must hold Stream or EventStream"):
        segment_streams([Stream("a", t, t), "td"])
