"""Contact events, surfaces and the contact reaction on synthetic kinesthetic recordings whose hand
force and contact are known (``synthetic.py``)."""

from __future__ import annotations

import numpy as np
import pytest

from lerobot_forcemap.contact import (
    DetectorSettings,
    ReactionSettings,
    contact_surfaces,
    detect_contacts,
    estimate_reaction,
    event_errors,
    force_intervals,
    guiding_share,
    intervals_to_mask,
    mask_to_intervals,
    rms_ratio,
)

from .synthetic import HAND_BIAS, IMPACT_N, STEADY_N, free_motion, kinesthetic_press


@pytest.fixture(scope="module")
def press():
    return kinesthetic_press()


@pytest.mark.parametrize("rate", [500.0, 166.0, 100.0])
def test_touch_down_and_lift_off_are_found_at_the_source_rate(rate):
    rec = kinesthetic_press(rate=rate)
    found = detect_contacts(rec.times, rec.positions, rec.force)
    assert len(found) == 1
    assert abs(found.touch_down[0] - rec.touch_down) <= 0.01
    assert abs(found.lift_off[0] - rec.lift_off) <= 1.5 / rate  # the rule itself, up to a sample
    assert np.min(np.abs(found.impacts - rec.touch_down)) <= 0.01


def test_no_contact_in_free_motion_whatever_the_hand_does():
    rec = free_motion()
    assert len(detect_contacts(rec.times, rec.positions, rec.force)) == 0
    est = estimate_reaction(rec.times, rec.positions, rec.force)
    assert not est.surfaces and not est.reaction.any()


def test_the_hand_model_is_recovered_away_from_contact(press):
    est = estimate_reaction(press.times, press.positions, press.force)
    np.testing.assert_allclose(est.model.coef[:, 0], HAND_BIAS, atol=0.3)  # the hand's push
    np.testing.assert_allclose(est.model.coef[:, 1], 30.0, rtol=0.15)  # its drag
    free = est.free & ~intervals_to_mask(press.times, est.contacts.intervals, 0.3)
    assert rms_ratio(press.force - est.guiding, press.force, free) < 0.1
    assert not est.free[intervals_to_mask(press.times, est.contacts.intervals)].any()


def test_the_reaction_is_recovered_in_contact_and_zero_outside(press):
    est = estimate_reaction(press.times, press.positions, press.force)
    (surface,) = est.surfaces
    assert surface.kind == "approach"
    np.testing.assert_allclose(surface.normal, [0.0, 0.0, 1.0], atol=0.02)  # the reverse of the descent
    inside = intervals_to_mask(press.times, est.contacts.intervals)
    along = est.reaction @ surface.normal
    error = along[inside] - press.reaction[inside, 2]
    assert np.sqrt(np.mean(error**2)) < 0.5  # N
    assert along.max() >= 0.8 * IMPACT_N
    assert np.median(along[inside]) == pytest.approx(STEADY_N, abs=0.5)
    assert not est.reaction[~inside].any()
    # the hand's share of the measured wrench: most of it, free motion included
    assert 0.5 < guiding_share(press.force, est.reaction) < 1.0


def test_an_unmodelled_push_into_the_surface_reads_as_no_reaction_but_the_impact_survives():
    """A static press is not observable: the hand pushing harder than the table pushes back makes the
    residual point into the surface, which the estimate clips to 0; the impact transient stays."""
    rec = kinesthetic_press(push_into=20.0)
    est = estimate_reaction(rec.times, rec.positions, rec.force)
    along = est.reaction @ est.surfaces[0].normal
    dwell = (rec.times > rec.touch_down + 0.1) & (rec.times < rec.lift_off - 0.1)
    assert np.median(along[dwell]) == 0.0
    assert along.min() >= 0.0  # never into the surface
    assert along.max() >= 0.5 * IMPACT_N


def test_a_wipe_takes_the_plane_of_its_travel_as_the_surface():
    rec = kinesthetic_press(wipe=0.05)
    est = estimate_reaction(rec.times, rec.positions, rec.force)
    (surface,) = est.surfaces
    assert surface.kind == "plane"
    np.testing.assert_allclose(surface.normal, [0.0, 0.0, 1.0], atol=0.02)
    assert surface.offset == pytest.approx(rec.positions[:, 2].min(), abs=1e-4)
    depth = surface.depth_below(np.array([[0.5, 0.0, 0.09], [0.5, 0.0, 0.11]]))
    np.testing.assert_allclose(depth, [0.01, -0.01], atol=2e-4)


def test_without_a_hand_the_wrench_is_the_reaction(press):
    force = press.reaction + 0.05
    est = estimate_reaction(press.times, press.positions, force, kinesthetic=False)
    np.testing.assert_array_equal(est.reaction, force)
    assert est.model is None and not est.guiding.any() and not est.free.any()
    pressing = np.flatnonzero(np.linalg.norm(force, axis=1) > 2.0)
    np.testing.assert_allclose(est.contacts.intervals, [press.times[pressing[[0, -1]]]])


def test_force_intervals_bridge_short_gaps_and_drop_short_runs():
    t = np.arange(1000) / 100.0
    f = np.zeros((1000, 3))
    f[100:200, 2] = 10.0  # 1 s
    f[205:300, 2] = 10.0  # 50 ms later: the same contact
    f[500:503, 2] = 10.0  # 30 ms: a knock, not a contact
    iv = force_intervals(t, f, threshold_n=2.0, min_duration_s=0.05, merge_gap_s=0.1).intervals
    np.testing.assert_allclose(iv, [[1.0, 2.99]])


def test_intervals_and_masks_round_trip():
    t = np.arange(100) / 10.0
    iv = np.array([[1.0, 2.0], [5.5, 7.0]])
    mask = intervals_to_mask(t, iv)
    np.testing.assert_allclose(mask_to_intervals(t, mask), iv)
    assert intervals_to_mask(t, iv, pad_s=0.3).sum() == mask.sum() + 12
    assert mask_to_intervals(t, np.zeros(100, bool)).shape == (0, 2)
    np.testing.assert_allclose(event_errors([1.02, 5.0], [1.0, 4.9, 9.0]), [0.02, 0.1, -4.0])
    assert np.isnan(event_errors([], [1.0])).all()


def test_contact_surfaces_of_given_intervals(press):
    (surface,) = contact_surfaces(press.times, press.positions, [[press.touch_down, press.lift_off]])
    assert surface.kind == "approach" and surface.normal[2] > 0.99
    with pytest.raises(ValueError, match=r"^intervals: must hold finite \[start, stop\] rows"):
        contact_surfaces(press.times, press.positions, [[2.0, 1.0]])


def test_bad_inputs_are_named(press):
    t, p, f = press.times, press.positions, press.force
    with pytest.raises(ValueError, match=r"^positions: must have shape"):
        estimate_reaction(t, p[:, :2], f)
    with pytest.raises(ValueError, match=r"^force: must have shape"):
        detect_contacts(t, p, f[:-1])
    with pytest.raises(ValueError, match=r"^times: must increase strictly \(frame 3 does not\)"):
        detect_contacts(np.r_[t[:3], t[2:]][:-1], p, f)
    with pytest.raises(ValueError, match=r"^force: must hold finite values only"):
        estimate_reaction(t, p, np.where(np.arange(len(t))[:, None] == 7, np.nan, f))
    with pytest.raises(ValueError, match=r"^DetectorSettings.min_decel: must be a finite number > 0"):
        DetectorSettings(min_decel=0.0)
    with pytest.raises(ValueError, match=r"^ReactionSettings.travel_m: must be a finite number > 0"):
        ReactionSettings(travel_m=-1.0)
    with pytest.raises(ValueError, match=r"^settings: must be a ReactionSettings or None"):
        estimate_reaction(t, p, f, settings=DetectorSettings())
    with pytest.raises(ValueError, match=r"^kinesthetic: must be true or false"):
        estimate_reaction(t, p, f, kinesthetic=1)
