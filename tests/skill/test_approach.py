"""The approach rule (pure NumPy): the contacts it reads from a profile, and the skill clock it slows
near them until a force is felt."""

from __future__ import annotations

import numpy as np

from lerobot_forcemap.skill.approach import ApproachLimit, contact_starts

DT = 0.05
DOWN = 0.05  # m/s, the map's descent


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
    limit = ApproachLimit(np.array([2.0]), np.array([0.0, 0.0, 1.0]), speed, zone, 1)
    times, rates = _run(limit, _descent())
    z = DOWN * (2.0 - times)
    in_zone = z < zone - DOWN * DT  # steps wholly inside the zone
    np.testing.assert_allclose(rates[in_zone & (times < 2.0 - DT)], speed / DOWN)  # exactly the speed
    assert np.all(rates[z > zone + DOWN * DT] == 1.0)  # far before: the map's own pace
    assert np.all(rates[times > 2.0 + DT] == 1.0)  # the wipe along the surface: its own pace
    # the approach through the zone takes zone / speed instead of zone / DOWN
    assert abs(np.sum(rates < 1) * DT - zone / speed) < 5 * DT  # give or take the edge steps


def test_a_felt_force_ends_the_slow_approach():
    limit = ApproachLimit(np.array([2.0]), np.array([0.0, 0.0, 1.0]), 0.01, 0.01, 1)
    times, rates = _run(limit, _descent(), felt_at=45)
    slow = np.flatnonzero(rates < 1)
    assert slow.size and slow[-1] < 45  # slowed before the touch, never after it
    assert limit.done.all()


def test_rows_share_the_slowest_rows_clock_and_no_speed_means_off():
    normal = np.array([0.0, 0.0, 1.0])
    limit = ApproachLimit(np.array([2.0]), normal, 0.01, 0.01, 2)
    _, rates = _run(limit, _descent((DOWN, 2 * DOWN)))  # row 1 comes down twice as fast
    np.testing.assert_allclose(rates.min(), 0.01 / (2 * DOWN))
    off = ApproachLimit(np.array([2.0]), normal, 0.0, 0.01, 1)
    assert np.all(_run(off, _descent(), steps=60)[1] == 1.0)
