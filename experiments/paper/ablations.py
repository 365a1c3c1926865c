"""Stage 4 — ablations on ``press`` and ``erase``: what each part of the method contributes.

Base: ours with the tuned force weights (``ours`` of Table II). Each row changes one thing; the 20
evaluation seeds are dealt over the 10 demonstrations (n = 20 per cell):

- ``base``: the tuned setting itself (same design, for a like-for-like comparison);
- ``forces off``: delta = 0 (the plain elastic map — the policy's cleanest switch: no force points);
- ``rho_max cap off``: rho_max = None (without the cap a node's push grows without bound as r -> 1
  and flips sign for r > 1);
- ``3-D map``: time_scale = 0 (the paper's map, no time coordinate);
- ``one segment``: segments = none;
- ``ground-truth segments``: the demonstrator's phase labels (``demo_phase``);
- segmentation weightings of the paper's Table I: ``position only``, ``uniform``, ``custom``
  (force-heavy), and ``auto`` (label-free jerk-contrast weights computed per demonstration).
"""

from __future__ import annotations

import json
from typing import Any

from experiments.paper.demos import auto_stream_weights
from experiments.paper.jobs import Job

from .cells import Cell
from .common import REPO, WEIGHTINGS, Settings, make_jobs
from .force_reduction import _overrides

TASKS = ("press", "erase")


def _weights(w: dict[str, float]) -> str:
    return "stream_weights=" + json.dumps(w)


def cells(tuning: dict[str, dict[str, Any]], s: Settings) -> list[Cell]:
    out: list[Cell] = []
    for task in TASKS:
        base = _overrides(tuning[task]["weights"]["chosen"])
        variants: list[tuple[str, str, tuple[str, ...]]] = [
            ("base", "ours (tuned force weights)", ()),
            ("forces_off", "forces off (delta = 0)", ("delta=0",)),
            ("rho_off", "rho_max cap off", ("rho_max=null",)),
            ("map3d", "3-D map (time_scale = 0)", ("time_scale=0",)),
            ("one_segment", "one segment (segments = none)", ("segments=none",)),
            (
                "gt_segments",
                "ground-truth segments (demo_phase)",
                ("segments=dataset", "segment_column=demo_phase"),
            ),
        ]
        variants += [
            (f"seg_{name.replace(' ', '_')}", f"segmentation: {name}", (_weights(w),))
            for name, w in WEIGHTINGS.items()
        ]
        for method, label, extra in variants:
            ov = (*base, *extra)
            out.append(
                Cell("ablation", task, method, label, make_jobs(task, method, "forcemap", s.demos, s.eval_seeds, design="split", overrides=ov),
                     settings={"overrides": list(ov)}, design="split")
            )  # fmt: skip
        # auto weights: computed per demonstration, so one job per demonstration with its own weights
        jobs = []
        auto: dict[int, dict[str, float]] = {}
        for job in make_jobs(
            task, "seg_auto", "forcemap", s.demos, s.eval_seeds, design="split", overrides=base
        ):
            w = auto_stream_weights(REPO / "datasets" / task, job.demo, base)
            auto[job.demo] = {k: round(v, 3) for k, v in w.items()}
            jobs.append(
                Job(
                    task,
                    "seg_auto",
                    "forcemap",
                    job.demo,
                    job.seeds,
                    overrides=(*job.overrides, _weights(auto[job.demo])),
                )
            )
        out.append(
            Cell("ablation", task, "seg_auto", "segmentation: auto (jerk contrast)", jobs,
                 settings={"overrides": list(base), "auto_weights": {str(k): v for k, v in auto.items()}}, design="split")
        )  # fmt: skip
    return out
