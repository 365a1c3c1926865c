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

from ..geometry import quat_rows_to_matrix, quat_to_matrix

GRAVITY = 9.81


def _skew(v: np.ndarray) -> np.ndarray:
    return np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])


@dataclass
class Payload:
    """Rigid payload below the F/T site: mass (kg) and centre of mass in the site frame (m)."""

    mass: float
    com_site: np.ndarray  # (3,)

    def __post_init__(self):
        self.cross_com_t = _skew(self.com_site).T  # f @ this = c x f, row-wise

    def expected_wrench(self, quat_site: np.ndarray) -> np.ndarray:
        """Sensor reading ``(n, 6)`` (site frame) of the payload at rest for site orientations ``(n, 4)``.

        The arm supports the payload: force ``m g z_world`` (up), torque ``c x f`` about the site.
        """
        return self.expected_wrench_from_mat(quat_to_matrix(np.atleast_2d(quat_site)))

    def expected_wrench_from_mat(self, rot: np.ndarray) -> np.ndarray:
        f_site = self.mass * GRAVITY * rot[:, 2, :]  # R^T (0, 0, m g): the third row of R
        t_site = f_site @ self.cross_com_t  # c x f
        return np.concatenate([f_site, t_site], axis=1)


def reaction_wrench_base(
    raw_site: np.ndarray,
    quat_site: np.ndarray,
    payload: Payload,
    bias_site: np.ndarray,
    base_rot_inv: np.ndarray | None = None,
    out: np.ndarray | None = None,
) -> np.ndarray:
    """Tared reaction wrench in the base frame ``(n, 6)`` from raw sensor rows ``(n, 6)`` (site frame).

    ``quat_site (n, 4)``: site orientation in the world (unit quaternions, as the sensor gives them); ``bias_site (6,)``: tare in the site frame;
    ``base_rot_inv (3, 3)``: world-to-base rotation (None: the base frame is the world frame); ``out``:
    an ``(n, 6)`` array to write into.
    """
    rot = quat_rows_to_matrix(quat_site)  # the sensor's quaternions: unit, no check needed
    tool_site = raw_site - payload.expected_wrench_from_mat(rot)
    tool_site -= bias_site  # what the tool applies, site frame
    if base_rot_inv is not None:
        rot = base_rot_inv[None] @ rot
    n = len(rot)
    # force and torque rows rotated in one call: (n, 2, 3) rows, each sum in the order of "nij,nj->ni"
    rotated = np.einsum("nij,nkj->nki", rot, tool_site.reshape(n, 2, 3)).reshape(n, 6)
    return np.negative(rotated, out=np.empty((n, 6)) if out is None else out)


class LowPass:
    """First-order low-pass (exponential smoothing) with state, applied to blocks of samples.

    ``y_k = y_{k-1} + a (x_k - y_{k-1})`` with ``a = 1 - exp(-2 pi f_c dt)``; one scipy ``lfilter`` call
    per block (no Python loop over samples), each column on its own.
    """

    def __init__(self, cutoff_hz: float, dt: float, dim: int):
        """``cutoff_hz`` > 0 and ``dt`` > 0 (s): checked by the env that makes the filter."""
        # imported with the first env, not with the package
        try:  # lfilter's own C routine: lfilter minus its array-API dispatch, which costs more per block
            from scipy.signal._sigtools import _linear_filter

            self._lfilter = _linear_filter
        except ImportError:  # pragma: no cover - a SciPy that moved it
            from scipy.signal import lfilter

            self._lfilter = lambda b, a, x, axis, zi: lfilter(b, a, x, axis=axis, zi=zi)
        self.alpha = 1.0 - float(np.exp(-2.0 * np.pi * cutoff_hz * dt))
        self._b = np.array([self.alpha])
        self._a = np.array([1.0, self.alpha - 1.0])
        self.dim = dim
        self._state = np.zeros(dim)

    @property
    def state(self) -> np.ndarray:
        """The last output ``(dim,)``: one array for the filter's life (the env's compiled force loops
        hold its address); assigning copies into it."""
        return self._state

    @state.setter
    def state(self, value: np.ndarray | float) -> None:
        self._state[...] = value

    def reset(self, value: np.ndarray | float = 0.0) -> None:
        self.state = value

    def __call__(self, block: np.ndarray) -> np.ndarray:
        """Filter ``block (n, dim)``; returns ``(n, dim)`` and advances the state."""
        zi = ((1.0 - self.alpha) * self.state)[None, :]
        out, _ = self._lfilter(self._b, self._a, block, 0, zi)
        self.state = out[-1]
        return out


def force_norms(force: np.ndarray) -> np.ndarray:
    """Euclidean norms ``(...)`` of 3-vectors ``(..., 3)`` (the sums and roots of ``np.linalg.norm``)."""
    return np.sqrt(np.add.reduce(force * force, axis=-1))


class ForceStats:
    """Running max / mean of ``n_signals`` force signals (base frame): norm and per-axis absolute values.

    :meth:`update` takes a block ``(n, n_signals, 3)``; ``max_norm``, ``mean_norm`` are ``(n_signals,)``,
    ``max_abs``, ``mean_abs`` ``(n_signals, 3)``, all 0 before the first sample. The four running arrays
    are updated in place (the env's compiled force loops hold their addresses): copy what you keep.
    """

    def __init__(self, n_signals: int = 1):
        self.n_signals = n_signals
        m = n_signals
        self.max_norm, self.sum_norm = np.zeros(m), np.zeros(m)
        self.max_abs, self.sum_abs = np.zeros((m, 3)), np.zeros((m, 3))
        self.count = 0

    def update(self, force: np.ndarray, norm: np.ndarray | None = None) -> None:
        """Add the samples ``force (n, n_signals, 3)``; ``norm``: their :func:`force_norms` if known."""
        if len(force) == 0:
            return
        if norm is None:
            norm = force_norms(force)
        absf = np.abs(force)
        np.maximum(self.max_norm, norm.max(axis=0), out=self.max_norm)
        # each signal's sum over its own contiguous row: NumPy's pairwise sum, as for one signal alone
        self.sum_norm += np.ascontiguousarray(norm.T).sum(axis=1)
        np.maximum(self.max_abs, absf.max(axis=0), out=self.max_abs)
        self.sum_abs += absf.sum(axis=0)
        self.count += len(force)

    @property
    def mean_norm(self) -> np.ndarray:
        return self.sum_norm / self.count if self.count else np.zeros(self.n_signals)

    @property
    def mean_abs(self) -> np.ndarray:
        return self.sum_abs / self.count if self.count else np.zeros((self.n_signals, 3))
