"""Benchmark: what the active-set polish of the Clarabel M-step costs and what it corrects.

    .venv/bin/python -m benchmarks.bench_clarabel_polish [--repeats 7] [--episodes 3]

The inequality path (``force_limit`` half-spaces, a floor half-space) on the shipped press, erase and
peg-in-hole demonstrations (wrist position and force), plus the audit's demo at rest under a binding
box. Every M-step a fit makes is recorded once (its cluster sums and constraint rows), then replayed
through ``clarabel_m_step`` with ``polish=False`` (Clarabel's interior-point answer) and
``polish=True`` (the same, refined to the exact minimiser): median time per M-step over --repeats
replays, their ratio, and the largest node difference between the two answers.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import numpy as np
import pandas as pd

import lerobot_forcemap.elmap.fit as fit_module
from lerobot_forcemap._validation import check_int, usage_errors
from lerobot_forcemap.elmap import Constraints, fit_force_elastic_map
from lerobot_forcemap.elmap.mstep import clarabel_m_step

REPO = Path(__file__).resolve().parents[1]


def recorded_m_steps(fit_kwargs: dict) -> list[tuple]:
    """The arguments of every Clarabel M-step one fit makes."""
    calls: list[tuple] = []

    def record(*args, **kwargs):
        calls.append((args, kwargs))
        return clarabel_m_step(*args, **kwargs)

    fit_module.clarabel_m_step = record
    try:
        fit_force_elastic_map(**fit_kwargs)
    finally:
        fit_module.clarabel_m_step = clarabel_m_step
    return calls


def demo_problems(episodes: int) -> list[tuple[str, dict]]:
    problems = []
    for task in ("press", "erase", "peg_in_hole"):
        files = sorted((REPO / "datasets" / task / "data").glob("*/*.parquet"))
        frame = pd.concat(pd.read_parquet(f) for f in files)
        for ep in sorted(frame.episode_index.unique())[:episodes]:
            d = frame[frame.episode_index == ep]
            x = np.stack(d["observation.ee_pose"].to_numpy())[:, :3]
            f = np.stack(d["observation.force"].to_numpy())[:, :3]
            floor = Constraints(halfspaces=[((0.0, 0.0, -1.0), -(x[:, 2].min() - 0.001))])
            kwargs = dict(
                positions=x,
                forces=f,
                n_nodes=60,
                delta=0.05,
                stiffness=2000.0,
                force_limit=5.0,
                constraints=floor,
            )
            problems.append((f"{task} episode {ep}", kwargs))
    at_rest = dict(
        positions=np.tile([0.3, 0.1, 0.2], (1000, 1)),
        n_nodes=100,
        constraints=Constraints(box=([-1, -1, 0.21], [1, 1, 1])),
    )
    problems.append(("demo at rest, box 1 cm above", at_rest))
    return problems


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=7, help="replays of each fit's M-steps (median taken)")
    ap.add_argument("--episodes", type=int, default=3, help="demonstrations per task")
    args = ap.parse_args(argv)
    with usage_errors(ap):
        check_int("--repeats", args.repeats, low=1)
        check_int("--episodes", args.episodes, low=1)
    print("| problem | M-steps | raw ms/step | polished ms/step | ratio | max node change |")
    print("|---|---:|---:|---:|---:|---:|")
    ratios = []
    for name, kwargs in demo_problems(args.episodes):
        calls = recorded_m_steps(kwargs)
        per_mode = {}
        for polish in (False, True):
            times = []
            for _ in range(args.repeats):
                t0 = time.perf_counter()
                nodes = [clarabel_m_step(*a, **{**k, "polish": polish}) for a, k in calls]
                times.append((time.perf_counter() - t0) / len(calls))
            per_mode[polish] = (float(np.median(times)), nodes)
        change = max(
            float(np.max(np.abs(a - b))) for a, b in zip(per_mode[False][1], per_mode[True][1], strict=True)
        )
        ratio = per_mode[True][0] / per_mode[False][0]
        ratios.append(ratio)
        print(
            f"| {name} | {len(calls)} | {1e3 * per_mode[False][0]:.2f} | {1e3 * per_mode[True][0]:.2f} | "
            f"{ratio:.2f}x | {1e3 * change:.3g} mm |"
        )
    print(
        f"polish cost: {min(ratios):.2f}x to {max(ratios):.2f}x the raw Clarabel M-step (median {np.median(ratios):.2f}x)"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
