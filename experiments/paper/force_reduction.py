"""Stage 1 — force reduction (paper Table II): ``press`` and ``erase``, one-shot from each demonstration.

Rows per task (``full``: demonstrations 0..9 x seeds 1000..1019, n = 200; ``split``: the 20 seeds dealt
over the 10 demonstrations, n = 20 — ``erase`` episodes cost 3x a ``press`` one, so its reference rows
are split; the trace of demo 0's first episode is kept for the force-profile figure):

- ``elmap``: the plain elastic map (forces off: delta = 0), the same segmentation and anchoring;
- ``ours_default``: the package defaults as a user gets them (k = 0.8 x the stiffness read from the
  demonstration, force feedback on, the package's segmentation window): the main row;
- ``ours_k3000``: the earlier defaults (the paper's law at k = 3000 N/m = 1.5 x the sim impedance);
- ``ours``: force weights alone, stiffness chosen in tuning;
- ``ours_limit``: force weights + ``force_limit`` half-spaces (chosen in tuning);
- ``limit_alone``: ``force_limit`` half-spaces without force weights (delta = 0);
- ``hybrid``: hybrid force/position control following the same demonstration (re-anchored to the
  object), threshold = setpoint from ``TABLE2_HYBRID``.
"""

from __future__ import annotations

from typing import Any

from .cells import Cell
from .common import TABLE2_HYBRID, Settings, make_jobs

TASKS = ("press", "erase")
#: rows run in the ``full`` design (the others ``split``)
FULL_ROWS = {
    "press": {"elmap", "ours_default", "ours", "ours_limit", "limit_alone", "hybrid"},
    "erase": {"ours_default", "ours", "ours_limit", "limit_alone"},
}


def _overrides(params: dict[str, Any] | None) -> tuple[str, ...]:
    if not params:
        return ()
    return tuple(
        f"{k}={'null' if v is None else f'{v:g}'}"
        for k, v in params.items()
        if not (k == "force_limit" and v is None)
    )


def _cell(task: str, method: str, label: str, kind: str, s: Settings, settings: dict, **job_kwargs) -> Cell:
    """A Table II row: ``full`` design for the rows in ``FULL_ROWS``, else ``split``."""
    design = "full" if method in FULL_ROWS[task] else "split"
    jobs = make_jobs(
        task, method, kind, s.demos, s.eval_seeds, design=design, trace_demo=s.demos[0], **job_kwargs
    )
    return Cell("table2", task, method, label, jobs, settings=settings, design=design)


def cells(tuning: dict[str, dict[str, Any]], s: Settings) -> list[Cell]:
    out: list[Cell] = []
    for task in TASKS:
        t = tuning[task]
        w, wl, la = (_overrides(t[p]["chosen"]) for p in ("weights", "weights_limit", "limit_alone"))
        variants = [
            ("elmap", "plain elastic map (forces off, delta = 0)", ("delta=0",)),
            ("ours_k3000", "ours, earlier defaults (k = 3000 N/m, no feedback)", ()),
            ("ours", f"ours, force weights (tuned: {', '.join(w)})", w),
            ("ours_limit", f"ours, force weights + force_limit (tuned: {', '.join(wl)})", wl),
            ("limit_alone", f"ours, force_limit alone (tuned: {', '.join(la)})", la),
        ]
        for method, label, ov in variants:
            out.append(_cell(task, method, label, "forcemap", s, {"overrides": list(ov)}, overrides=ov))
        label = "ours, package defaults (k = 0.8 K_demo, force feedback)"
        out.append(_cell(task, "ours_default", label, "forcemap", s, {"overrides": []}, law=()))
        hy = TABLE2_HYBRID[task]
        label = f"hybrid force/position control (threshold {hy['force_threshold']:g} N)"
        out.append(_cell(task, "hybrid", label, "hybrid", s, {"hybrid": hy}, hybrid=hy))
    return out
