"""``lerobot_forcemap.evaluation.stats`` and the per-episode gripper-phase figure: the one summariser of
``forcemap eval``, the experiments and the studies."""

from __future__ import annotations

import math

import numpy as np
import pytest

from lerobot_forcemap.evaluation.records import force_by_gripper_phase
from lerobot_forcemap.evaluation.stats import demo_change, summarize, wilson_interval


def test_wilson_interval_known_values_and_symmetry():
    lo, hi = wilson_interval(20, 20)
    assert lo == pytest.approx(0.8389, abs=1e-4) and hi == 1.0
    lo, hi = wilson_interval(10, 20)
    assert (lo + hi) / 2 == pytest.approx(0.5) and lo == pytest.approx(0.2993, abs=1e-4)
    a, b = wilson_interval(3, 17)
    c, d = wilson_interval(14, 17)
    assert a == pytest.approx(1 - d) and b == pytest.approx(1 - c)
    assert wilson_interval(0, 0) == (0.0, 1.0)


def _rec(seed, demo, fmax, fmean, ok=True, stop=False):
    return {
        "seed": seed,
        "demo": demo,
        "success": ok,
        "protective_stop": stop,
        "max_contact_force": fmax,
        "mean_contact_force": fmean,
        "max_contact_force_xyz": [fmax / 2, 0.0, fmax],
        "mean_contact_force_xyz": [fmean, fmean / 2, 0.0],
    }


def test_summarize_records_statistics():
    recs = [_rec(1, 0, 10.0, 2.0), _rec(2, 0, 12.0, 4.0), _rec(3, 1, 14.0, 6.0, ok=False, stop=True)]
    s = summarize(recs)
    assert s["n"] == 3 and s["seeds"] == [1, 2, 3]
    assert s["success_rate"] == pytest.approx(2 / 3) and s["protective_stops"] == 1
    m = s["max_contact_force"]
    assert m["mean"] == pytest.approx(12.0) and m["std"] == pytest.approx(2.0)  # ddof 1
    assert m["ci95"] == pytest.approx(4.302653 * 2.0 / math.sqrt(3), rel=1e-5)  # t(0.975, 2)
    assert m["min"] == 10.0 and m["max"] == 14.0
    np.testing.assert_allclose(s["mean_contact_force_xyz"]["mean"], [4.0, 2.0, 0.0])
    assert summarize([]) == {"n": 0}


def test_the_success_interval_counts_demonstrations_when_they_repeat():
    """20 seeds of one demonstration's policy share its outcome: 10 demonstrations x 20 seeds is 10
    units, not 200 (the interval of 8/10, not of 160/200)."""
    recs = [_rec(s, d, 1.0, 1.0, ok=d < 8) for d in range(10) for s in range(20)]
    s = summarize(recs)
    assert s["n"] == 200 and s["success_rate"] == pytest.approx(0.8)
    assert s["success_ci95_unit"] == "demonstration" and s["success_ci95_n"] == 10
    assert s["success_ci95"] == pytest.approx(list(wilson_interval(8, 10)))
    assert s["success_ci95"][0] == pytest.approx(0.4902, abs=1e-4)  # [49, 94] %, not [74, 85] %
    # one episode per demonstration (or no demonstration): each episode is a unit
    single = summarize([_rec(s, s, 1.0, 1.0, ok=s < 16) for s in range(20)])
    assert single["success_ci95_unit"] == "episode" and single["success_ci95"] == pytest.approx(
        list(wilson_interval(16, 20))
    )
    # a demonstration whose seeds disagree counts with its rate
    mixed = summarize([_rec(0, 0, 1.0, 1.0), _rec(1, 0, 1.0, 1.0, ok=False), _rec(2, 1, 1.0, 1.0)])
    assert mixed["success_ci95"] == pytest.approx(list(wilson_interval(1.5, 2)))


def test_demo_change_is_per_demonstration():
    demos = [{"episode": 0, "max_contact_force": 20.0}, {"episode": 1, "max_contact_force": 40.0}]
    recs = [_rec(1, 0, 10.0, 1.0), _rec(2, 0, 12.0, 1.0), _rec(3, 1, 30.0, 1.0)]
    c = demo_change(recs, demos, "max_contact_force")
    assert c["per_demo"] == {"0": pytest.approx(-45.0), "1": pytest.approx(-25.0)}
    assert c["mean"] == pytest.approx(-35.0) and c["std"] == pytest.approx(math.sqrt(200.0))
    assert c["pooled"] == pytest.approx(100 * ((52 / 3) / 30 - 1))
    with pytest.raises(ValueError, match="demonstrations \\[7\\]"):
        demo_change([_rec(1, 7, 1.0, 1.0)], demos, "max_contact_force")


def test_force_by_gripper_phase_splits_the_peaks():
    forces = np.array([[1.0, 0, 5], [-3.0, 1, 2], [0.5, -2, 0], [2.0, 0, 1]])
    grip = np.array([1.0, 0.5, 0.0, 0.97])
    out = force_by_gripper_phase(forces, grip)
    assert out["closed"] == {"steps": 2, "max_xyz": [2.0, 0.0, 5.0]}
    assert out["moving"] == {"steps": 1, "max_xyz": [3.0, 1.0, 2.0]}
    assert out["open"] == {"steps": 1, "max_xyz": [0.5, 2.0, 0.0]}
    assert force_by_gripper_phase(np.zeros((0, 3)), np.zeros(0))["moving"]["steps"] == 0
    with pytest.raises(ValueError, match="3 force samples for 2"):
        force_by_gripper_phase(forces[:3], grip[:2])
