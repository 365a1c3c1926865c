"""Wrist wrench and contact-force processing, vectorised over the physics steps of one control step.

Conventions: every force the env reports is the *reaction on the robot* (the environment's
force on the robot, pointing away from a contact surface), in the robot base frame. MuJoCo's
``force``/``torque`` sensors at the F/T site report what the arm exerts on the sensor-and-tool subtree
in the site frame, i.e. the opposite sign plus the payload's weight; this module removes the payload
(a gravity model from the subtree mass and centre of mass, valid at any orientation), removes the
remaining bias measured at reset (the "tare", e.g. a held object's weight), negates, and rotates to the
base frame. Torques are about the F/T site origin, expressed in base-frame axes.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..geometry import quat_to_matrix

GRAVITY = 9.81


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@dataclass
class Payload:
    """Rigid payload below the F/T site: mass (kg) and centre of mass in the site frame (m)."""

    mass: float
    com_site: np.ndarray  # (3,)

    def expected_wrench(self, quat_site: np.ndarray) -> np.ndarray:
        """Sensor reading ``(n, 6)`` (site frame) of the payload at rest for site orientations ``(n, 4)``.

        The arm supports the payload: force ``m g z_world`` (up), torque ``c x f`` about the site.
        """
        return self.expected_wrench_from_mat(quat_to_matrix(np.atleast_2d(quat_site)))

    def expected_wrench_from_mat(self, rot: np.ndarray) -> np.ndarray:
        f_site = self.mass * GRAVITY * rot[:, 2, :]  # R^T (0, 0, m g): the third row of R
        t_site = f_site @ _skew(self.com_site).T  # c x f
        return np.concatenate([f_site, t_site], axis=1)


def reaction_wrench_base(
    raw_site: np.ndarray,
    quat_site: np.ndarray,
    payload: Payload,
    bias_site: np.ndarray,
    base_rot_inv: np.ndarray | None = None,
) -> np.ndarray:
    """Tared reaction wrench in the base frame ``(n, 6)`` from raw sensor rows ``(n, 6)`` (site frame).

    ``quat_site (n, 4)``: site orientation in the world; ``bias_site (6,)``: tare in the site frame;
    ``base_rot_inv (3, 3)``: world-to-base rotation (None: the base frame is the world frame).
    """
    rot = quat_to_matrix(quat_site)
    tool_site = (
        raw_site - payload.expected_wrench_from_mat(rot) - bias_site
    )  # what the tool applies, site frame
    if base_rot_inv is not None:
        rot = base_rot_inv[None] @ rot
    force = -np.einsum("nij,nj->ni", rot, tool_site[:, :3])
    torque = -np.einsum("nij,nj->ni", rot, tool_site[:, 3:])
    return np.concatenate([force, torque], axis=1)


class LowPass:
    """First-order low-pass (exponential smoothing) with state, applied to blocks of samples.

    ``y_k = y_{k-1} + a (x_k - y_{k-1})`` with ``a = 1 - exp(-2 pi f_c dt)``; one scipy ``lfilter`` call
    per block (no Python loop over samples).
    """

    def __init__(self, cutoff_hz: float, dt: float, dim: int):
        """``cutoff_hz`` > 0 and ``dt`` > 0 (s): checked by the env that makes the filter."""
        from scipy.signal import lfilter  # imported with the first env, not with the package

        self._lfilter = lfilter
        self.alpha = 1.0 - float(np.exp(-2.0 * np.pi * cutoff_hz * dt))
        self._b = np.array([self.alpha])
        self._a = np.array([1.0, self.alpha - 1.0])
        self.dim = dim
        self.state = np.zeros(dim)

    def reset(self, value: np.ndarray | float = 0.0) -> None:
        self.state = np.broadcast_to(np.asarray(value, dtype=float), (self.dim,)).copy()

    def __call__(self, block: np.ndarray) -> np.ndarray:
        """Filter ``block (n, dim)``; returns ``(n, dim)`` and advances the state."""
        zi = ((1.0 - self.alpha) * self.state)[None, :]
        out, _ = self._lfilter(self._b, self._a, block, axis=0, zi=zi)
        self.state = out[-1].copy()
        return out


@dataclass
class ForceStats:
    """Running max / mean of a force signal ``(n, 3)`` (base frame): norm and per-axis absolute values."""

    max_norm: float = 0.0
    sum_norm: float = 0.0
    max_abs: np.ndarray | None = None
    sum_abs: np.ndarray | None = None
    count: int = 0

    def reset(self) -> None:
        self.max_norm = self.sum_norm = 0.0
        self.max_abs = np.zeros(3)
        self.sum_abs = np.zeros(3)
        self.count = 0

    def update(self, force: np.ndarray) -> None:
        if len(force) == 0:
            return
        norm = np.linalg.norm(force, axis=1)
        absf = np.abs(force)
        self.max_norm = max(self.max_norm, float(norm.max()))
        self.sum_norm += float(norm.sum())
        self.max_abs = np.maximum(self.max_abs, absf.max(axis=0))
        self.sum_abs = self.sum_abs + absf.sum(axis=0)
        self.count += len(force)

    @property
    def mean_norm(self) -> float:
        return self.sum_norm / self.count if self.count else 0.0

    @property
    def mean_abs(self) -> np.ndarray:
        return self.sum_abs / self.count if self.count else np.zeros(3)
