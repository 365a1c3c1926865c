"""The yield rule (pure NumPy): against an object that does not give way, with the force slanted from
the demonstrated normal (a peg on the hole's rim), the map's press is held back after the touch
whatever the controller's stiffness; its motion along the surface is kept, the feedback's own
correction is not held back, a force along the normal is left to the feedback, and the offset returns
to the map once the force is gone. Only in a contact met at a slant, and only while the map's step
goes into the surface (a wipe's sliding against friction is not held back)."""

from __future__ import annotations

import numpy as np

from lerobot_forcemap.skill.contact_yield import TAU, ContactYield

DT = 0.05
F_REF = np.array([6.5])
YES = np.array([True])
#: the peg demonstration's normal: 53 degrees off the vertical
TILTED = np.array([-0.76, 0.24, 0.60]) / np.linalg.norm([-0.76, 0.24, 0.60])
UP = np.array([0.0, 0.0, 1.0])


def _rule(level: float = 0.25, normal=TILTED) -> ContactYield:
    return ContactYield(normal, level, 0.01, 1.0, DT, 1)


def _press(
    k_ctrl: float, level: float, steps: int = 12, give_way_at: int | None = None, normal=TILTED, slanted=YES
):
    """The map descends 3 mm per step along -z (and 1 mm per step along +x) onto a rigid rim at z = 0
    held by a controller of stiffness ``k_ctrl`` N/m (reaction on the robot: +z); from step
    ``give_way_at`` on the rim is gone. Returns the forces (N) and the offsets ``(steps, 3)`` m."""
    rule = _rule(level, normal)
    f = np.zeros((1, 3))
    forces, offsets = [], []
    for k in range(steps):
        target = np.array([[0.001 * k, 0.0, 0.0045 - 0.003 * k]])
        target = target + rule.step(target, target, f, F_REF, slanted)
        rim = give_way_at is None or k < give_way_at
        f = np.array([[0.0, 0.0, k_ctrl * max(-target[0, 2], 0.0) if rim else 0.0]])
        forces.append(f[0, 2])
        offsets.append(rule.w[0].copy())
    return np.array(forces), np.array(offsets)


def test_the_press_on_a_rigid_object_stops_growing_with_the_controller():
    for k_ctrl in (1500.0, 6000.0):
        plain, _ = _press(k_ctrl, 0.0, steps=6)
        held, _ = _press(k_ctrl, 0.25, steps=6)  # 9 mm past the rim: within the 1 cm bound
        assert plain[-1] > 5 * plain[2]  # without the rule the force grows by k x 3 mm a step
        first = np.flatnonzero(held > 1.0)[0]
        # once the force is felt and rising the target goes no deeper: the force stays
        assert held[first + 1 :].max() <= 2 * held[first] + 1e-9, (k_ctrl, held)
        _, offsets = _press(k_ctrl, 0.25, steps=20)
        assert np.linalg.norm(offsets, axis=1).max() == np.float64(0.01)  # then the bound holds


def test_the_motion_along_the_surface_is_kept():
    _, offsets = _press(6000.0, 0.25)
    np.testing.assert_allclose(offsets[:, :2], 0.0, atol=1e-15)  # the force is along z only
    assert offsets[:, 2].max() > 0.005


def test_a_force_along_the_demonstrated_normal_is_left_to_the_feedback():
    _, offsets = _press(6000.0, 0.25, normal=UP)
    np.testing.assert_array_equal(offsets, 0.0)


def test_what_the_feedback_takes_back_or_pushes_is_not_held_back():
    rule = _rule()
    f = np.array([[0.0, 0.0, 5.0]])
    for k in range(4):  # the map steps 3 mm down; the feedback takes 1 mm of it back, then all of it
        planned = np.array([[0.0, 0.0, -0.003 * k]])
        corrected = planned + np.array([[0.0, 0.0, 0.001 * k if k < 3 else 0.003 * k]])
        rule.step(planned, corrected, f, F_REF, YES)
        if k == 2:
            np.testing.assert_allclose(rule.w[0], [0.0, 0.0, 0.004])  # 2 mm a step, twice
    np.testing.assert_allclose(rule.w[0], [0.0, 0.0, 0.004])  # the step all taken back: no more
    rule = _rule()
    for k in range(4):  # the map is still, the feedback pushes in: its push is its own
        rule.step(np.zeros((1, 3)), np.array([[0.0, 0.0, -0.002 * k]]), f, F_REF, YES)
    np.testing.assert_array_equal(rule.w, 0.0)


def test_the_offset_returns_to_the_map_once_the_force_is_gone():
    forces, offsets = _press(6000.0, 0.25, steps=40, give_way_at=8)
    assert offsets[8, 2] > 0.005 and np.all(forces[8:] == 0.0)  # step 8 still reads step 7's force
    np.testing.assert_allclose(offsets[-1, 2], offsets[8, 2] * (1 - DT / TAU) ** 31, rtol=1e-9)


def test_no_expected_contact_or_no_level_means_off():
    rule = _rule()
    for k in range(5):
        target = np.array([[0.0, 0.0, -0.003 * k]])
        w = rule.step(target, target, np.array([[0.0, 0.0, 20.0]]), np.array([0.5]), YES)
        np.testing.assert_array_equal(w, 0.0)
    _, offsets = _press(6000.0, 0.0)
    np.testing.assert_array_equal(offsets, 0.0)


def test_a_contact_met_along_the_normal_is_left_to_the_feedback():
    _, offsets = _press(6000.0, 0.25, slanted=np.array([False]))
    np.testing.assert_array_equal(offsets, 0.0)


def test_a_wipe_sliding_against_friction_is_not_held_back():
    """The map slides 3 mm a step along +x on a board (n up) while friction tilts the reaction 50
    degrees back (a tool that sticks for a moment): its step goes along the surface, not into it."""
    rule = _rule(normal=UP)
    f = np.array([[-6.0, 0.0, 5.0]])  # friction against +x, larger than the 27-degree slant
    for k in range(6):
        target = np.array([[0.003 * k, 0.0, -0.0002 * k]])  # a little into the board as it goes
        rule.step(target, target, f, F_REF, YES)
    np.testing.assert_array_equal(rule.w, 0.0)
