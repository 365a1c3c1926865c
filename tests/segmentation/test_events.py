"""Reference events from gripper and finger-force arrays (segmentation/events.py)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from lerobot_forcemap.segmentation.events import (
    EventThresholds,
    gripper_intervals,
    merge_events,
    reference_events,
)

DT = 0.015  # a 15 s demo resampled to 1000 frames


def ramp(n: int, segments: list[tuple[int, int, float, float]], base: float) -> np.ndarray:
    """Piecewise-linear signal: `base`, then for each (start, stop, from, to) a ramp, held at `to` afterwards."""
    x = np.full(n, base)
    for a, b, v0, v1 in segments:
        x[a:b] = np.linspace(v0, v1, b - a, endpoint=False)
        x[b:] = v1
    return x


def grasp(n: int = 1000, close_at: int = 300, open_at: int = 700, level: float = 0.44) -> np.ndarray:
    """Gripper opening 0.01 (open), closing over 20 frames from close_at, opening over 15 frames from open_at."""
    return ramp(n, [(close_at, close_at + 20, 0.01, level), (open_at, open_at + 15, level, 0.01)], 0.01)


def finger(
    n: int, contact_at: int, release_at: int, rng: np.random.Generator, rise: float = 250.0
) -> np.ndarray:
    f = ramp(
        n,
        [
            (contact_at, contact_at + 5, 370.0, 370.0 + rise),
            (release_at, release_at + 5, 370.0 + rise, 370.0),
        ],
        370.0,
    )
    return f + rng.normal(0.0, 3.0, n)


def test_single_grasp_events_land_on_the_constructed_frames() -> None:
    rng = np.random.default_rng(0)
    t = np.arange(1000) * DT
    ev = reference_events(t, grasp(), finger(1000, 312, 705, rng))
    assert ev.gripper_ok and ev.finger_force_ok
    assert ev.kinds.tolist() == ["close", "contact", "open"]
    # Ramp 300..320 from g_n = 0 to 1: the last frame with g_n <= 0.1 is 302.
    assert ev.of_kind("close").tolist() == [302]
    # Opening ramp 700..715 from the plateau (g_n = 1): the last frame with g_n >= 0.9 is 701.
    assert ev.of_kind("open").tolist() == [701]
    # Finger force steps up over 312..317 by 250 counts, noise 3: 0.2 of the rise is crossed at frame 313 (+-1).
    assert abs(int(ev.of_kind("contact")[0]) - 313) <= 1
    np.testing.assert_allclose(ev.times, t[ev.frames])
    assert ev.contact_contrast > 50
    # Closed while g_n >= 0.5: from the middle of the closing ramp to the middle of the opening one (+-1 for round-off).
    assert np.all(np.abs(ev.closed_intervals - np.array([[310, 708]])) <= 1)


def test_two_grasps_and_a_debounced_blip() -> None:
    rng = np.random.default_rng(1)
    t = np.arange(1200) * DT
    g = ramp(
        1200,
        [(200, 220, 0.01, 0.87), (400, 415, 0.87, 0.01), (700, 720, 0.01, 0.87), (950, 965, 0.87, 0.01)],
        0.01,
    )
    g[600:605] = 0.87  # 5 frames = 0.075 s < min_hold_s: not a grasp
    f = finger(1200, 212, 402, rng) + finger(1200, 712, 952, rng) - 370.0
    ev = reference_events(t, g, f)
    assert ev.of_kind("close").size == 2 and ev.of_kind("open").size == 2 and ev.of_kind("contact").size == 2
    assert np.all(np.abs(ev.of_kind("close") - [202, 702]) <= 1)
    assert np.all(np.abs(ev.of_kind("contact") - [213, 713]) <= 1)


def test_grasp_held_to_the_end_has_no_open_event() -> None:
    t = np.arange(800) * DT
    g = ramp(800, [(500, 520, 0.01, 0.43)], 0.01)
    ev = reference_events(t, g, None)
    assert ev.of_kind("close").tolist() == [502]
    assert ev.of_kind("open").size == 0 and ev.of_kind("contact").size == 0
    assert not ev.finger_force_ok


def test_gripper_that_never_moves_gives_no_events() -> None:
    t = np.arange(500) * DT
    ev = reference_events(t, np.full(500, 0.01), np.full(500, 370.0))
    assert not ev.gripper_ok and ev.frames.size == 0
    tiny = gripper_intervals(t, 0.01 + 0.02 * (np.arange(500) > 250))  # span 0.02 < min_span 0.05
    assert not tiny.ok and tiny.starts.size == 0


def test_unusable_finger_force_gives_no_contact() -> None:
    rng = np.random.default_rng(2)
    t = np.arange(1000) * DT
    broken = np.full(1000, -645.0)  # the Mug/User4 channel: constant with sparse spikes
    broken[rng.choice(1000, 25, replace=False)] = rng.uniform(-600, 27000, 25)
    ev = reference_events(t, grasp(), broken)
    assert not ev.finger_force_ok and ev.of_kind("contact").size == 0
    assert ev.contact_contrast == 0.0
    # Rise 5 counts, noise 2: contrast 2.5.
    untouched = 370.0 + rng.normal(0, 2.0, 1000) + 5.0 * (grasp() > 0.2)
    ev2 = reference_events(t, grasp(), untouched)
    assert not ev2.finger_force_ok and 1.0 < ev2.contact_contrast < EventThresholds().min_contrast
    # The gripper events do not depend on the finger force.
    np.testing.assert_array_equal(ev.of_kind("close"), ev2.of_kind("close"))


def test_merge_events() -> None:
    np.testing.assert_array_equal(merge_events([500, 100, 130], 64), [115, 500])
    np.testing.assert_array_equal(merge_events([100, 150, 200], 64), [150])  # chains
    np.testing.assert_array_equal(merge_events([100, 150], 10), [100, 150])
    assert merge_events([], 64).size == 0
    with pytest.raises(ValueError, match="^within: must be a finite number >= 0, got -1"):
        merge_events([1], -1)


def test_bad_input_names_the_array_and_frame() -> None:
    t = np.arange(100) * DT
    g = grasp(100, 30, 70)
    bad = g.copy()
    bad[42] = np.nan
    with pytest.raises(
        ValueError, match=r"^gripper: must hold finite values only \(the first bad one is at frame 42\)"
    ):
        reference_events(t, bad)
    with pytest.raises(
        ValueError, match=r"^finger_force: must have shape \(100,\) to match times, got shape \(99,\)"
    ):
        reference_events(t, g, np.zeros(99))
    t_bad = t.copy()
    t_bad[10] = t_bad[9]
    with pytest.raises(ValueError, match=r"^times: must be strictly increasing, got .* at frame 10$"):
        reference_events(t_bad, g)
    with pytest.raises(
        ValueError, match=r"^EventThresholds.onset_fraction: must be a finite number > 0 and < 0.5, got 0.6"
    ):
        EventThresholds(onset_fraction=0.6)


@pytest.mark.realdata
def test_real_gbti_demos(shared_data: Path) -> None:
    from lerobot_forcemap.data.recorder import GbtiKey, iter_gbti_demos
    from lerobot_forcemap.data.transforms import align_recording

    keys = [GbtiKey("Mug", 1, 1), GbtiKey("Mug", 4, 1), GbtiKey("Cube", 3, 2)]
    demos = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # tare-window notes from align_recording
        for key, rec in iter_gbti_demos(shared_data / "gbti" / "Grasping_Demos.h5", keys):
            demos[str(key)] = align_recording(rec, n_samples=1000)

    a = demos["Mug/User1/Position1"]
    ev = reference_events(a.times, a.gripper, a.finger_force)
    assert ev.kinds.tolist() == ["close", "contact", "open"]
    close, contact, open_ = (int(ev.of_kind(k)[0]) for k in ("close", "contact", "open"))
    # The gripper is still open at the close onset and closed (over half way) 30 frames later.
    g_n = (a.gripper - np.percentile(a.gripper, 1)) / ev.gripper_span
    assert g_n[close] <= 0.1 and g_n[close + 30] >= 0.5
    # Contact follows the close onset within a second, and the finger force is well up 20 frames later.
    assert 0 < (contact - close) * (a.times[1] - a.times[0]) < 1.0
    baseline = np.median(a.finger_force[:close])
    assert a.finger_force[contact + 20] > baseline + 0.5 * (
        np.median(a.finger_force[contact:open_]) - baseline
    )
    # Opening starts after at least a second of holding, and the gripper is open (below half) 40 frames later.
    assert (open_ - close) * (a.times[1] - a.times[0]) > 1.0
    assert g_n[open_] >= 0.8 and g_n[open_ + 40] < 0.5

    broken = demos["Mug/User4/Position1"]  # constant -645 counts with spikes: no contact events
    ev4 = reference_events(broken.times, broken.gripper, broken.finger_force)
    assert not ev4.finger_force_ok and ev4.of_kind("contact").size == 0
    assert ev4.of_kind("close").size == 1 and ev4.of_kind("open").size == 1

    held = demos["Cube/User3/Position2"]  # the recording stops while the cube is still held
    ev3 = reference_events(held.times, held.gripper, held.finger_force)
    assert (
        ev3.of_kind("close").size == 1 and ev3.of_kind("open").size == 0 and ev3.of_kind("contact").size == 1
    )
