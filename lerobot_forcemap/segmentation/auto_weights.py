"""Automatic, label-free stream weights (the method's open question of how to weigh the streams).

Criterion: the **jerk contrast** of each stream, the peak-to-baseline ratio of the very signal its
keypoints are thresholded on, in nepers:

    s_i       = moving-average jerk norm of stream i divided by its maximum   (in [0, 1], max 1)
    c_i       = ln(1 / max(median(s_i), eps)),   eps = 1e-3  (so 0 <= c_i <= ln 1000 ≈ 6.9)
    v_i       = c_i / Σ_j c_j                    (weights sum to 1, like the paper's Table I)

Why this one: thresholds are fractions of each stream's own maximum, so a keypoint means something
only when the stream's typical level sits far below its peaks. A stream whose jerk is dominated by
sensor noise (raw differences of 166 Hz positions) has median(s) of 0.5–0.7 and c ≈ 0.3–0.7;
a stream that is quiet between distinct events (gripper, finger force) has median(s) near 0 and
c near the cap. The median is the robust "baseline" (events occupy a minority of frames in these
demonstrations); eps caps the contrast of almost-always-still streams (a gripper that moves twice)
so one stream cannot take all the weight. A flat stream (zero jerk everywhere, no keypoints possible)
gets c = 0. The weights given on the streams are ignored.

Other label-free criteria were considered: agreement of a stream's keypoints with the other streams'
(penalises exactly the force-only events the paper wants force streams for), and the entropy of the
stream pmf (cannot tell "no events" from "events everywhere").
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping, Sequence
from dataclasses import replace

import numpy as np

from .._validation import check_array, check_real, fail
from .config import SegmentationConfig, Stream, check_config, stream_list
from .segment import _analyse, checked_streams

CONTRAST_EPS = 1e-3


def jerk_contrast(signal: np.ndarray, eps: float = CONTRAST_EPS) -> float:
    """ln(1 / max(median(signal), eps)) for a normalised signal (max 1, finite, non-empty) and eps > 0;
    0.0 for an all-zero signal."""
    # the median of NaN would be a NaN weight
    signal = check_array("signal", signal, min_len=1, axes=("index",)).reshape(-1)
    if not signal.size:
        fail("signal", "be a non-empty finite array, got no values")
    return _contrast(signal, check_real("eps", eps, low=0.0, low_open=True))


def _contrast(signal: np.ndarray, eps: float) -> float:
    """:func:`jerk_contrast` of a checked signal."""
    if not signal.any():
        return 0.0
    return float(np.log(1.0 / max(float(np.median(signal)), eps)))


def auto_weights(streams: Sequence[Stream], config: SegmentationConfig | None = None) -> dict[str, float]:
    """Label-free weights v_i (summing to 1) from each stream's jerk contrast (see module doc).

    Uses the config's derivative, window, polyorder and duplicated-timestamp policy. When every
    stream is flat (no contrast anywhere) it warns and returns uniform weights.
    """
    config = check_config(config, "auto_weights")
    streams, _ = checked_streams(streams, config, "auto_weights")
    names = [s.name for s in streams]
    contrast = np.array([_contrast(_analyse(s, config).signal, CONTRAST_EPS) for s in streams])
    total = float(contrast.sum())
    if total <= 0.0:
        warnings.warn(
            f"auto_weights: no stream of {names} has any jerk contrast (all flat); returning uniform weights",
            UserWarning,
            stacklevel=2,
        )
        return {n: 1.0 / len(names) for n in names}
    return {n: float(c / total) for n, c in zip(names, contrast, strict=True)}


def reweighted(streams: Sequence[Stream], weights: Mapping[str, float]) -> list[Stream]:
    """The same streams with the given weights: ``weights`` maps every stream's name (and no other) to
    its weight (checked as `Stream.weight`)."""
    streams = stream_list(streams, "reweighted")
    if not isinstance(weights, Mapping):
        fail("weights", f"be a mapping of stream name to weight, got {type(weights).__name__}")
    missing = [s.name for s in streams if s.name not in weights]
    if missing:
        fail("weights", f"give a weight for every stream, got none for {missing}")
    unknown = sorted(set(weights) - {s.name for s in streams}, key=str)
    if unknown:
        fail("weights", f"name only the given streams, got unknown streams {unknown}")
    return [replace(s, weight=weights[s.name]) for s in streams]
