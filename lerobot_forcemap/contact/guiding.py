"""A model of the guiding hand's force in a kinesthetic recording (pure NumPy).

In freedrive the arm moves because the hand pushes it, so in free space the wrist wrench is the hand's
force and it follows the motion. Per base axis i the model is admittance-like,

    G_i(t) = b_i + d_i v_i(t + lag) + c_i tanh(v_i(t + lag) / v0) + m_i a_i(t + lag),

a bias (the hand's mean push), viscous and Coulomb-like drag of the arm, and an inertia term, with the
motion taken ``lag`` later than the force (the force leads the motion it causes). It is fitted by least
squares on frames away from contact. Each axis uses its own velocity and acceleration; adding the other
axes' terms or a tool-frame constant fits better in-sample and predicts held-out frames worse.

What it cannot do: it explains only part of the hand's force (held-out residual 0.5-0.8 of the measured
wrench on the UR5e recordings: a hand does not push like a damper), and it predicts nothing useful while
the tool is at rest: then v = a = 0 and G = b, whatever the hand does.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import partial

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap._validation import check_fields, check_real
from lerobot_forcemap.contact.kinematics import delayed, sample_rate, smooth_derivatives

__all__ = ["GuidingSettings", "GuidingModel", "fit_guiding_force", "predict_guiding_force"]

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class GuidingSettings:
    """Settings of the guiding-force model: coulomb_speed v0 (m/s) of the tanh term; lag_s, how far the
    motion lags the force (0-0.1 s predict equally well on the UR5e recordings); deriv_window_s, the
    Savitzky-Golay window of velocity and acceleration; ridge, a tiny regularisation relative to each
    column's scale (keeps an axis without motion harmless)."""

    coulomb_speed: float = 0.02
    lag_s: float = 0.05
    deriv_window_s: float = 0.06
    ridge: float = 1e-6

    def __post_init__(self) -> None:
        positive = partial(check_real, low=0.0, low_open=True)
        check_fields(
            type(self).__name__,
            self,
            {
                "coulomb_speed": positive,
                "lag_s": partial(check_real, low=0.0),
                "deriv_window_s": positive,
                "ridge": partial(check_real, low=0.0),
            },
        )


@dataclass(frozen=True)
class GuidingModel:
    """Fitted coefficients ``coef (3, 4)``: per axis [b, d, c, m] (N, N·s/m, N, kg); the settings."""

    coef: F64
    settings: GuidingSettings


def _design(times: F64, positions: F64, s: GuidingSettings) -> F64:
    """Regressors ``(3, T, 4)``: per axis [1, v, tanh(v / v0), a] with the motion taken ``lag_s`` later."""
    v, a = smooth_derivatives(times, positions, s.deriv_window_s)
    lag = int(round(s.lag_s * sample_rate(times)))
    v, a = delayed(v, -lag), delayed(a, -lag)
    ones = np.ones(len(times))
    return np.stack(
        [np.stack([ones, v[:, i], np.tanh(v[:, i] / s.coulomb_speed), a[:, i]], axis=1) for i in range(3)]
    )


def fit_guiding_force(
    times: F64, positions: F64, force: F64, free: NDArray[np.bool_], settings: GuidingSettings
) -> GuidingModel:
    """Least-squares fit on the frames where ``free (T,)`` is True (at least a few dozen).

    times (T,) s, positions (T, 3) m, force (T, 3) N, all base frame. Internal: the caller
    (:func:`~lerobot_forcemap.contact.reaction.estimate_reaction`) has checked the arrays.
    """
    X = _design(times, positions, settings)
    coef = np.empty((3, X.shape[2]))
    for i in range(3):  # axes
        A, y = X[i][free], force[free, i]
        scale = np.sqrt((A**2).mean(axis=0)) + 1e-12
        As = A / scale
        gram = As.T @ As + settings.ridge * len(y) * np.eye(As.shape[1])
        coef[i] = np.linalg.solve(gram, As.T @ y) / scale
    return GuidingModel(coef, settings)


def predict_guiding_force(model: GuidingModel, times: F64, positions: F64) -> F64:
    """The model's guiding force ``(T, 3)`` N over a recording (times (T,) s, positions (T, 3) m)."""
    X = _design(times, positions, model.settings)
    return np.einsum("itp,ip->ti", X, model.coef)
