"""Time law and orientation of a fitted map.

Node i gets the mean normalised time of its cluster's demo samples, made non-decreasing and
scaled to the segment's demo duration; nodes with empty clusters interpolate between their
neighbours (with a single filled cluster, a demo that does not move, time is spread evenly).
Orientations follow by SLERP of the demo orientations at those times. Building blocks of the fit:
inputs are trusted.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
from numpy.typing import NDArray

from ..geometry import quat_normalize, slerp_sequence

__all__ = ["node_time_law", "node_orientations"]

Array = NDArray[np.float64]


def node_time_law(labels: NDArray[np.intp], normalised_time: Array, n_nodes: int, duration: float) -> Array:
    """Node times (N,) in seconds from the assignment ``labels (M,)`` of samples with times in [0, 1]."""
    counts = np.bincount(labels, minlength=n_nodes)
    sums = np.bincount(labels, weights=normalised_time, minlength=n_nodes)
    filled = counts > 0
    idx = np.arange(n_nodes)
    if filled.sum() < 2:
        # One cluster holds every sample (a demo that does not move: a hold, a rotation in place; the
        # E-step gives tied samples to the lowest node) and says nothing about how time runs along
        # the map: spread it evenly, as the initial map is spread by index when it has no length.
        frac = np.linspace(0.0, 1.0, n_nodes)
    else:
        frac = np.interp(idx, idx[filled], sums[filled] / counts[filled])
    frac = np.maximum.accumulate(np.clip(frac, 0.0, 1.0))
    return frac * duration


def node_orientations(
    node_times: Array, demo_times: Sequence[Array], demo_quats: Sequence[Array], duration: float
) -> Array:
    """Quaternions (N, 4) at the node times: per demo SLERP at the same normalised time, then the
    sign-aligned normalised mean over demos.

    demo_times: per demo normalised times (T_i,) in [0, 1]; demo_quats: per demo (T_i, 4), w first.
    """
    frac = node_times / duration if duration > 0 else np.zeros_like(node_times)
    acc = None
    for u, q in zip(demo_times, demo_quats, strict=True):
        qi = slerp_sequence(u, q, frac)
        if acc is None:
            acc = qi
        else:
            acc = acc + np.where(np.sum(acc * qi, axis=1, keepdims=True) < 0, -qi, qi)
    return quat_normalize(acc)
