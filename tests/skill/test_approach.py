"""The approach rule (pure NumPy): the contacts it reads from a profile, and the skill clock it slows
near the slanted ones until a force is felt."""

from __future__ import annotations

import numpy as np

from lerobot_forcemap.skill.approach import ApproachLimit, contact_starts

DT = 0.05
DOWN = 0.05  # m/s, the map's descent
#: a demonstrated normal 53 degrees off the vertical descent (the peg's): the touch-down is slanted
TILTED = np.array([-0.76, 0.24, 0.60]) / np.linalg.norm([-0.76, 0.24, 0.60])
UP = np.array([0.0, 0.0, 1.0])


def _descent(speeds=(DOWN,)):
    """``positions_at`` of rows descending along -z at ``speeds`` (m/s), at z = 0 at t = 2 s (the
    contact), then wiping along +x at 5 cm/s."""
    v = np.asarray(speeds, dtype=np.float64)

    def positions_at(times):
        t = np.asarray(times, dtype=np.float64)
        p = np.zeros((len(v), len(t), 3))
        p[:, :, 0] = 0.05 * np.maximum(t - 2.0, 0.0)
        p[:, :, 2] = v[:, None] * np.maximum(2.0 - t, 0.0)
        return p

    return positions_at


def _run(limit, positions_at, felt_at=None, steps=200):
    """The clock's times and the rates, ``felt`` from step ``felt_at`` on."""
    t, times, rates = 0.0, [], []
    n = limit.done.shape[0]
    for k in range(steps):
        felt = np.full(n, felt_at is not None and k >= felt_at)
        r = limit.rate(positions_at, t, DT, felt)
        times.append(t)
        rates.append(r)
        t += r * DT
    return np.array(times), np.array(rates)


def test_contact_starts_are_the_rising_crossings():
    along = np.array([0.0, 3.0, 5.0, 1.0, 0.0, 2.5, 2.5, 0.0])
    np.testing.assert_allclose(contact_starts(along, 20.0, 2.0), [1 / 20, 5 / 20])
    np.testing.assert_allclose(contact_starts(np.array([3.0, 0.0]), 20.0, 2.0), [0.0])
    assert contact_starts(np.zeros(5), 20.0, 2.0).size == 0


def test_the_clock_slows_to_the_speed_within_the_zone_only():
    speed, zone = 0.01, 0.01
    limit = ApproachLimit(np.array([2.0]), TILTED, speed, zone, 1)
    times, rates = _run(limit, _descent())
    z = DOWN * (2.0 - times)
    in_zone = z < zone - DOWN * DT  # steps wholly inside the zone
    np.testing.assert_allclose(rates[in_zone & (times < 2.0 - DT)], speed / DOWN)  # exactly the speed
    assert np.all(rates[z > zone + DOWN * DT] == 1.0)  # far before: the map's own pace
    assert np.all(rates[times > 2.0 + DT] == 1.0)  # the wipe along the surface: its own pace
    # the approach through the zone takes zone / speed instead of zone / DOWN
    assert abs(np.sum(rates < 1) * DT - zone / speed) < 5 * DT  # give or take the edge steps


def test_a_felt_force_ends_the_slow_approach():
    limit = ApproachLimit(np.array([2.0]), TILTED, 0.01, 0.01, 1)
    times, rates = _run(limit, _descent(), felt_at=45)
    slow = np.flatnonzero(rates < 1)
    assert slow.size and slow[-1] < 45  # slowed before the touch, never after it
    assert limit.done.all()


def test_rows_share_the_slowest_rows_clock_and_no_speed_means_off():
    normal = TILTED
    limit = ApproachLimit(np.array([2.0]), normal, 0.01, 0.01, 2)
    _, rates = _run(limit, _descent((DOWN, 2 * DOWN)))  # row 1 comes down twice as fast
    np.testing.assert_allclose(rates.min(), 0.01 / (2 * DOWN))
    off = ApproachLimit(np.array([2.0]), normal, 0.0, 0.01, 1)
    assert np.all(_run(off, _descent(), steps=60)[1] == 1.0)


def test_a_touch_down_along_the_normal_is_left_to_the_feedback():
    """Coming down along -n (a press), the clock keeps the map's pace and the contact is not slanted;
    the same descent against a tilted normal is, and ``slanted_at`` names it around its time."""
    along = ApproachLimit(np.array([2.0]), UP, 0.01, 0.01, 1)
    assert np.all(_run(along, _descent())[1] == 1.0)
    assert not along.slanted.any() and not along.slanted_at(2.0).any()
    slanted = ApproachLimit(np.array([2.0, 6.0]), TILTED, 0.0, 0.01, 1)  # speed 0: classified, not slowed
    assert np.all(_run(slanted, _descent(), steps=60)[1] == 1.0)
    # the first contact: a descent (slanted from -n); the second, at 6 s: a wipe along +x (slanted too,
    # 90 degrees from -n), so both are True; none of a contact-free profile
    np.testing.assert_array_equal(slanted.slanted, [[True, True]])
    assert slanted.slanted_at(1.0)[0] and slanted.slanted_at(5.0)[0]
    assert ApproachLimit(np.array([]), UP, 0.01, 0.01, 2).slanted_at(1.0).tolist() == [False, False]
