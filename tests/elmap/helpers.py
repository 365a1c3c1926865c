"""Synthetic demos for the elastic-map tests."""

import numpy as np


def line_demo(n=400, length=0.4, noise=0.0, seed=0, d=3):
    """A straight stroke along x at height 0 (a wipe on a table), (n, d)."""
    rng = np.random.default_rng(seed)
    x = np.zeros((n, d))
    x[:, 0] = np.linspace(0.0, length, n)
    return x + noise * rng.normal(size=x.shape)


def s_curve(n=600, seed=0, noise=5e-4):
    rng = np.random.default_rng(seed)
    t = np.linspace(0, 1, n)
    x = np.stack([0.3 * t, 0.05 * np.sin(2 * np.pi * t), 0.02 * t**2], axis=1)
    return x + noise * rng.normal(size=x.shape)


def dense_m_step(W, b, S, lam, mu):
    """The normal equations solved densely, with E and R built from their definition."""
    n, d = W.shape
    E = np.zeros((n - 1, n))
    E[np.arange(n - 1), np.arange(n - 1)] = -1
    E[np.arange(n - 1), np.arange(1, n)] = 1
    R = np.zeros((n - 2, n))
    R[np.arange(n - 2), np.arange(n - 2)] = 1
    R[np.arange(n - 2), np.arange(1, n - 1)] = -2
    R[np.arange(n - 2), np.arange(2, n)] = 1
    out = np.empty((n, d))
    for q in range(d):
        A = np.diag(W[:, q] ** 2) / S + lam * E.T @ E + mu * R.T @ R
        out[:, q] = np.linalg.solve(A, W[:, q] * b[:, q] / S)
    return out
