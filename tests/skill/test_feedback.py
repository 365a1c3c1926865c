"""The force feedback law (pure NumPy): profile from a demonstration, and the closed loop against a
spring contact behind a stiff and a soft position controller."""

from __future__ import annotations

import numpy as np

from lerobot_forcemap.skill.feedback import FeedbackGains, ForceFeedback, dilate, force_profile

FPS = 20.0


def _demo(k_ctrl: float = 2000.0, k_env: float = 2000.0, depth: float = 0.025, frames: int = 100):
    """A demonstration pressing a spring surface at z = 0 with a commanded depth ramp (T = frames)."""
    cmd = np.zeros((frames, 3))
    cmd[:, 2] = 0.05 - np.clip(np.arange(frames) / 40.0, 0, 1) * (0.05 + depth)
    k_series = k_ctrl * k_env / (k_ctrl + k_env)
    force = np.zeros((frames, 3))
    force[:, 2] = np.maximum(-cmd[:, 2], 0.0) * k_series  # reaction on the robot, +z
    measured = cmd.copy()
    measured[:, 2] += force[:, 2] / k_ctrl  # the controller lags its target by F / K
    return force, cmd, measured


def test_profile_reads_the_normal_the_force_and_the_demonstration_stiffness():
    force, cmd, measured = _demo()
    p = force_profile(force, cmd, measured, FPS)
    np.testing.assert_allclose(p.normal, [0.0, 0.0, 1.0])
    np.testing.assert_allclose(p.stiffness, 2000.0, rtol=1e-9)
    assert p.expected.shape == (100,)
    assert np.all(p.expected >= force[:, 2] - 1e-12)  # dilated: never below the demonstration
    assert np.isnan(force_profile(force, cmd, None, FPS).stiffness)  # no measured pose: unknown


def test_dilate_is_a_running_max():
    np.testing.assert_array_equal(dilate(np.array([0.0, 0.0, 3.0, 0.0, 0.0, 0.0]), 1), [0, 3, 3, 3, 0, 0])


def _closed_loop(k_ctrl: float, k_env: float = 2000.0, steps: int = 150) -> tuple[np.ndarray, np.ndarray]:
    """The demonstration's own path replayed against a controller of stiffness ``k_ctrl`` with the
    feedback on; returns the contact forces (N) without and with the feedback."""
    force, cmd, measured = _demo()
    profile = force_profile(force, cmd, measured, FPS)
    fb = ForceFeedback(profile, FeedbackGains(tare_steps=0), FPS, FPS, 1)
    k_series = k_ctrl * k_env / (k_ctrl + k_env)
    open_loop, closed = [], []
    f = np.zeros((1, 3))
    for t in range(steps):
        target = fb.step(cmd[min(t, len(cmd) - 1)][None], f)
        f = np.array([[0.0, 0.0, max(-target[0, 2], 0.0) * k_series]])
        closed.append(f[0, 2])
        open_loop.append(max(-cmd[min(t, len(cmd) - 1), 2], 0.0) * k_series)
    return np.array(open_loop), np.array(closed)


def test_feedback_holds_the_budget_against_a_stiff_and_a_soft_controller():
    budget, deadband = FeedbackGains().budget, FeedbackGains().deadband
    for k_ctrl in (1000.0, 4000.0):  # x0.5 and x2 of the demonstration's 2000 N/m
        open_loop, closed = _closed_loop(k_ctrl)
        assert open_loop[-1] > 2 * budget  # without the feedback the path presses far harder
        # settled: within the deadband of the budget (plus the lifting loop's last step)
        assert abs(closed[-1] - budget) <= deadband + 0.5, (k_ctrl, closed[-1])


def test_feedback_pushes_in_where_the_map_stops_short():
    force, cmd, measured = _demo()
    profile = force_profile(force, cmd, measured, FPS)
    fb = ForceFeedback(profile, FeedbackGains(tare_steps=0), FPS, FPS, 1)
    shallow = cmd.copy()
    shallow[:, 2] = np.maximum(cmd[:, 2], -0.004)  # the path ends 4 mm into the contact: 4 N
    k_series = 1000.0  # 2000 N/m in series with 2000 N/m
    f = np.zeros((1, 3))
    for t in range(len(cmd) + 60):
        target = fb.step(shallow[min(t, len(cmd) - 1)][None], f)
        f = np.array([[0.0, 0.0, max(-target[0, 2], 0.0) * k_series]])
    assert f[0, 2] > FeedbackGains().budget - FeedbackGains().deadband - 0.5
    assert -fb.u[0] <= FeedbackGains().max_push + 1e-12  # bounded


def test_profile_reads_the_depth_at_a_force_between_frames():
    force, cmd, measured = _demo()
    p = force_profile(force, cmd, measured, FPS)
    # a 2000 N/m contact: the TCP is F / 2000 m past the surface at force F; the origin of the depth
    # (the force-position line through 2 N and 4 N, at zero force) is the surface
    assert abs(p.depth_at(7.0) - 7.0 / 2000.0) < 1e-4
    assert p.depth_at(1e6) == p.depth[np.argmax(p.along)]  # above its max: the depth at the max
    assert np.isnan(force_profile(force, cmd, None, FPS).depth_at(7.0))  # no measured pose


def _press(k_ctrl: float, k_env: float, depth_gain: float, steps: int = 150) -> tuple[float, float, float]:
    """The demonstration's path (recorded on 2000 N/m behind 2000 N/m) replayed with the feedback
    against a contact of stiffness ``k_env`` behind a controller of stiffness ``k_ctrl``; returns
    (how far past the surface the TCP holds at the end, the depth the demonstration had at the
    budget, the last force)."""
    force, cmd, measured = _demo()
    profile = force_profile(force, cmd, measured, FPS)
    fb = ForceFeedback(profile, FeedbackGains(tare_steps=0, depth_gain=depth_gain), FPS, FPS, 1)
    f, x = np.zeros((1, 3)), cmd[:1].copy()
    for t in range(steps):
        target = fb.step(cmd[min(t, len(cmd) - 1)][None], f, x)
        x = target.copy()  # the TCP settles where the controller and the contact balance
        if target[0, 2] < 0:
            x[0, 2] = target[0, 2] * k_ctrl / (k_ctrl + k_env)
        f = np.array([[0.0, 0.0, max(-x[0, 2], 0.0) * k_env]])
    return -x[0, 2], fb.depth_ref, f[0, 2]


def test_the_depth_law_presses_a_stiffer_object_as_deep_as_the_demonstration():
    budget = FeedbackGains().budget
    for k_ctrl in (1000.0, 4000.0):  # a soft and a stiff controller
        went, _, _ = _press(k_ctrl, 6000.0, depth_gain=0.0)
        assert went < 0.5 * budget / 2000.0  # the force law alone holds the budget: far short
        went, depth, force = _press(k_ctrl, 6000.0, depth_gain=FeedbackGains().depth_gain)
        assert abs(went - depth) < 2e-4, (k_ctrl, went, depth)  # as deep as the demonstration went
        assert force > 2 * budget  # with the force that takes, more than the budget


def test_the_depth_law_holds_the_budget_on_a_softer_object():
    budget, deadband = FeedbackGains().budget, FeedbackGains().deadband
    for k_ctrl in (1000.0, 4000.0):
        went, depth, force = _press(k_ctrl, 1000.0, depth_gain=FeedbackGains().depth_gain)
        assert went > depth  # deeper than the demonstration: the budget is reached later
        assert abs(force - budget) <= deadband + 0.5, (k_ctrl, force)


def test_the_depth_law_stays_off_where_the_demonstration_moved_the_object():
    # a soft contact (200 N/m behind the controller): the budget is reached 3 cm past the origin, a
    # travel no press makes (a pushed object slides); a stiff one stays in reach
    for k_env, on in ((200.0, False), (6000.0, True)):
        force, cmd, measured = _demo(k_env=k_env, depth=0.06)
        profile = force_profile(force, cmd, measured, FPS)
        gains = FeedbackGains(tare_steps=0)
        assert bool(profile.depth_at(gains.budget) > gains.max_push) is not on
        fb = ForceFeedback(profile, gains, FPS, FPS, 1)
        assert bool(np.isfinite(fb.depth_ref)) is on, (k_env, fb.depth_ref)
        assert fb.moved_object is not on  # the policy's approach rule reads it: no touch-down to slow
