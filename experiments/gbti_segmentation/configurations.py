"""One segmentation configuration (:class:`RunSpec`) run over every demo and seed."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from lerobot_forcemap.segmentation import SegmentationConfig, SegmentationResult, Stream, segment_streams

from .data import STREAMS, TABLE_I, THRESHOLDS, WINDOW, Demo


@dataclass(frozen=True)
class RunSpec:
    table: str  # "paper" (Table II reproduction) or "f1"
    derivative: str
    weighting: str
    mode: str
    method: str
    min_segment_length: int | None

    @property
    def label(self) -> str:
        msl = "default" if self.min_segment_length is None else str(self.min_segment_length)
        return f"{self.table}|{self.derivative}|{self.weighting}|{self.mode}|{self.method}|msl={msl}"


@dataclass
class RunResult:
    spec: RunSpec
    changepoints: list[list[np.ndarray]]  # [demo][seed] interior changepoints
    n_segments: np.ndarray  # (D, S)
    keypoint_counts: dict[str, np.ndarray] | None = None  # stream -> (D,) keypoints (seed 0)
    keypoints: list[dict[str, np.ndarray]] | None = None  # [demo] stream -> keypoint frames


def streams_for(demo: Demo, weights: dict[str, float]) -> list[Stream]:
    return [
        Stream(n, demo.values[n], demo.times, weight=weights[n], threshold=THRESHOLDS[n]) for n in STREAMS
    ]


def weights_of(weighting: str, demo: Demo, derivative: str) -> dict[str, float]:
    if weighting in TABLE_I:
        return dict(zip(STREAMS, TABLE_I[weighting], strict=True))
    if weighting == "auto":
        return demo.auto[derivative]
    if weighting == "gripper_only":
        return {n: (1.0 if n == "gripper" else 0.0) for n in STREAMS}
    if weighting.startswith("only:"):
        name = weighting.split(":", 1)[1]
        return {n: (1.0 if n == name else 0.0) for n in STREAMS}
    raise ValueError(f"unknown weighting {weighting!r}")


def config_for(spec: RunSpec, seed: np.random.Generator | int) -> SegmentationConfig:
    return SegmentationConfig(
        window=WINDOW,
        min_run=64,
        grace=4,
        mode=spec.mode,
        changepoints=spec.method,
        n_samples=20,
        n_pass=3,
        seed=seed,
        min_segment_length=spec.min_segment_length,
        derivative=spec.derivative,
    )


def segment_once(demo: Demo, spec: RunSpec, seed: np.random.Generator | int) -> SegmentationResult:
    config = config_for(spec, seed)
    if spec.weighting == "flat":
        flat = Stream("flat", np.zeros(demo.times.size), demo.times, weight=1.0, threshold=0.5)
        return segment_streams([flat], config)
    return segment_streams(streams_for(demo, weights_of(spec.weighting, demo, spec.derivative)), config)


def run(demos: list[Demo], spec: RunSpec, seeds: int, keep_keypoints: bool = False) -> RunResult:
    n_seeds = seeds if spec.method == "sample" else 1
    cps: list[list[np.ndarray]] = []
    counts = np.zeros((len(demos), n_seeds), dtype=np.int64)
    kp_counts = {n: np.zeros(len(demos), dtype=np.int64) for n in STREAMS} if keep_keypoints else None
    kps: list[dict[str, np.ndarray]] | None = [] if keep_keypoints else None
    for d, demo in enumerate(demos):
        row = []
        for s in range(n_seeds):
            # One generator per (seed, demo): the same draws for every weighting / mode (paired comparisons).
            seg = segment_once(demo, spec, np.random.default_rng([s, d]))
            row.append(seg.changepoints[1:-1].copy())
            counts[d, s] = seg.n_segments
            if s == 0 and keep_keypoints:
                for n in STREAMS:
                    kp_counts[n][d] = seg.keypoints[n].size
                kps.append({n: seg.keypoints[n].copy() for n in STREAMS})
        cps.append(row)
    return RunResult(spec, cps, counts, kp_counts, kps)
