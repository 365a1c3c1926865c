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


def _stiffer_object(
    depth_ratio: float, k_env: float = 6000.0, steps: int = 150
) -> tuple[float, float, float]:
    """The demonstration's path against a 3x stiffer contact; returns (the farthest the TCP went past
    the first contact, the demonstration's depth, the last force)."""
    force, cmd, measured = _demo()
    profile = force_profile(force, cmd, measured, FPS)
    fb = ForceFeedback(profile, FeedbackGains(tare_steps=0, depth_ratio=depth_ratio), FPS, FPS, 1)
    f, x, first, went = np.zeros((1, 3)), cmd[:1].copy(), None, 0.0
    for t in range(steps):
        target = fb.step(cmd[min(t, len(cmd) - 1)][None], f, x)
        x = target.copy()
        x[0, 2] = target[0, 2] * 2000.0 / (2000.0 + k_env) if target[0, 2] < 0 else target[0, 2]
        f = np.array([[0.0, 0.0, max(-x[0, 2], 0.0) * k_env]])
        if first is None and f[0, 2] > 1.0:
            first = x[0, 2]
        went = max(went, 0.0 if first is None else first - x[0, 2])
    return went, profile.depth, f[0, 2]


def test_depth_ratio_raises_the_budget_until_the_demonstrated_depth():
    went, depth, _ = _stiffer_object(0.0)
    assert went < 0.3 * depth  # the fixed budget stops far short on a stiffer object
    went, depth, force = _stiffer_object(0.3)
    assert went >= 0.3 * depth - 1e-3  # pressed on until it went as far
    assert abs(force - FeedbackGains().budget) <= FeedbackGains().deadband + 0.5  # then back to the budget
