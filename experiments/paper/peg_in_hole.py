"""Stage 2 — peg-in-hole (paper Table III): demonstration, hybrid force/position control and ours.

Rows (``hybrid``, ``ours_default`` and ``ours``: demonstrations 0..9 x seeds 1000..1019, n = 200; the
reference ``replay``: the 20 seeds dealt over the demonstrations, n = 20): ``replay`` (the
demonstration's actions re-anchored to the peg, open loop: the demonstrator's bump included),
``hybrid`` (tuned threshold and normal), ``ours_default`` (the package defaults as a user gets them: the
main row), ``ours`` (the paper's law with force weights + ``force_limit`` = the hybrid threshold, tuned
stiffness and f_contact: the reference). The demonstrations' own figures come from the dataset.
"""

from __future__ import annotations

from typing import Any

from .cells import Cell
from .common import Settings, hybrid_kwargs, make_jobs


def cells(tuning: dict[str, Any], s: Settings) -> list[Cell]:
    task = "peg_in_hole"
    h = tuning["hybrid"]["chosen"]
    o = tuning["ours"]["chosen"]
    hy = hybrid_kwargs(h["force_threshold"], h["normal"])
    ov = (
        f"stiffness={o['stiffness']:g}",
        f"force_limit={o['force_limit']:g}",
        f"f_contact={o['f_contact']:g}",
    )
    return [
        Cell(
            "peg", task, "replay", "demonstration replayed open loop (re-anchored to the peg)",
            make_jobs(task, "replay", "replay", s.demos, s.eval_seeds, design="split", trace_demo=s.demos[0]),
            settings={}, design="split",
        ),
        Cell(
            "peg", task, "hybrid",
            f"hybrid force/position control (threshold {h['force_threshold']:g} N, normal {h['normal']})",
            make_jobs(task, "hybrid", "hybrid", s.demos, s.eval_seeds, hybrid=hy, trace_demo=s.demos[0]),
            settings={"hybrid": {**h}},
        ),
        Cell(
            "peg", task, "ours", f"ours (force_limit = {o['force_limit']:g} N = the hybrid threshold; tuned k = {o['stiffness']:g} N/m, f_contact = {o['f_contact']:g} N)",
            make_jobs(task, "ours", "forcemap", s.demos, s.eval_seeds, overrides=ov, trace_demo=s.demos[0]),
            settings={"overrides": list(ov)},
        ),
        Cell(
            "peg", task, "ours_default", "ours, package defaults (k = 0.8 K_demo, force feedback)",
            make_jobs(task, "ours_default", "forcemap", s.demos, s.eval_seeds, trace_demo=s.demos[0], law=()),
            settings={"overrides": []},
        ),
    ]  # fmt: skip
