"""Multimodal probabilistic segmentation (``docs/segmentation.md``). NumPy/SciPy only (floor 1).

    from lerobot_forcemap.segmentation import Stream, SegmentationConfig, segment_streams
    seg = segment_streams([Stream("wrist_force", f, t, weight=0.35, threshold=0.15), ...],
                          SegmentationConfig(mode="geometric", changepoints="peaks", seed=0))
    seg.changepoints   # sorted frame indices, first 0 and last T
    seg.pmf            # combined changepoint pmf (T,)
    seg.keypoints      # stream name -> keypoint frames

An `EventStream("touch_down", event_times_s, t, weight=4)` joins the others with keypoints at given
events (contact touch-downs and lift-offs found by ``lerobot_forcemap.contact``).

`auto_weights(streams, config)` proposes label-free stream weights (see its docstring).
"""

from .auto_weights import auto_weights, jerk_contrast, reweighted
from .changepoints import enforce_min_segment_length, peak_changepoints, sample_changepoints
from .combine import combine_pmfs, stream_pmf
from .config import (
    AUTHORS_RATE_HZ,
    AUTHORS_WINDOW_S,
    DEFAULT_TIMING,
    EVENT_STREAM_WEIGHT,
    EVENT_STREAMS,
    SIGNAL_STREAM_THRESHOLDS,
    EventStream,
    SegmentationConfig,
    SegmentationTiming,
    Stream,
    contact_event_streams,
)
from .keypoints import StreamKeypoints, savgol_third_derivative, stream_keypoints, threshold_runs
from .segment import SegmentationResult, StreamAnalysis, StreamResult, analyse_stream, segment_streams
from .timebase import TimeRepair, TimeRepairWarning, UnevenTimeWarning

__all__ = [
    "AUTHORS_RATE_HZ",
    "AUTHORS_WINDOW_S",
    "DEFAULT_TIMING",
    "EVENT_STREAMS",
    "EVENT_STREAM_WEIGHT",
    "SIGNAL_STREAM_THRESHOLDS",
    "EventStream",
    "SegmentationConfig",
    "SegmentationResult",
    "SegmentationTiming",
    "Stream",
    "StreamAnalysis",
    "StreamKeypoints",
    "StreamResult",
    "TimeRepair",
    "TimeRepairWarning",
    "UnevenTimeWarning",
    "analyse_stream",
    "auto_weights",
    "combine_pmfs",
    "contact_event_streams",
    "enforce_min_segment_length",
    "jerk_contrast",
    "peak_changepoints",
    "reweighted",
    "sample_changepoints",
    "savgol_third_derivative",
    "segment_streams",
    "stream_keypoints",
    "stream_pmf",
    "threshold_runs",
]
