"""Speed of the MuJoCo force tasks: real-time factor, model build time, rendering cost.

    .venv/bin/python -m benchmarks.bench_envs [--episodes 5] [--cores 1] [--no-render] [--json out.json]

Per task, in one process pinned to one CPU core (``--cores``):
- build: median time to construct the env (MjSpec scene + compile + index), ms;
- real-time factor without rendering: simulated time / wall time of whole scripted demonstrations
  (reset included), median over episodes; and, as the baseline measured in the same run, bare
  ``mj_step`` on the same model from the episode's start state with the target parked (robot at rest,
  no Python in the loop, no task contacts), so "env / bare" is the share of the bare physics' speed
  the env keeps;
- ms per rendered frame at 256 px (the ``render()`` size for videos) and 128 px (camera observations),
  median of 30 frames.
Prints a markdown table (medians; timings are noisy on shared machines).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import mujoco
import numpy as np
from tqdm import tqdm

import lerobot_forcemap.envs as E
from benchmarks._common import add_cores_argument, pin_cores, print_table, write_json
from lerobot_forcemap._validation import check_int, usage_errors
from lerobot_forcemap.envs.demonstrators import make_demonstrator
from lerobot_forcemap.envs.registration import TASKS


def env_class(task: str):
    import importlib

    module, cls = TASKS[task].entry_point.split(":")
    return getattr(importlib.import_module(module), cls)


def bench_build(task: str, n: int = 5) -> float:
    cls = env_class(task)
    times = []
    for _ in range(n):
        t = time.perf_counter()
        env = cls()
        times.append(time.perf_counter() - t)
        env.close()
    return 1e3 * statistics.median(times)


def bench_rtf(task: str, episodes: int) -> tuple[float, float, int]:
    """(median env RTF, median bare mj_step RTF on the same episodes, total steps)."""
    env = E.make(task, render_mode=None)
    base = env.unwrapped
    names = base.state_names["environment_state"]
    env_rtf, bare_rtf, steps = [], [], 0
    for seed in range(episodes):
        demo = make_demonstrator(task, np.random.default_rng(seed), state_names=names)
        t = time.perf_counter()
        obs, _ = env.reset(seed=seed)
        demo.reset(obs)
        n = 0
        state0 = None
        for _ in range(TASKS[task].max_episode_steps):
            if state0 is None:
                state0 = np.empty(mujoco.mj_stateSize(base.model, mujoco.mjtState.mjSTATE_INTEGRATION))
                mujoco.mj_getState(base.model, base.data, state0, mujoco.mjtState.mjSTATE_INTEGRATION)
            obs, _, term, trunc, _ = env.step(demo.act(obs))
            n += 1
            if term or trunc:
                break
        wall = time.perf_counter() - t
        sim = n * base.control_dt
        env_rtf.append(sim / wall)
        steps += n
        # baseline: bare mj_step on the same model from the episode's start state, target parked (robot at
        # rest, no task contacts): the physics' own speed for this model, no Python in the loop
        m, d = base.model, mujoco.MjData(base.model)
        mujoco.mj_setState(m, d, state0, mujoco.mjtState.mjSTATE_INTEGRATION)
        n_phys = n * base.n_substeps
        t = time.perf_counter()
        for _ in range(n_phys):
            mujoco.mj_step(m, d)
        bare_rtf.append(n_phys * base.timestep / (time.perf_counter() - t))
    env.close()
    return statistics.median(env_rtf), statistics.median(bare_rtf), steps


def bench_render(task: str, size: int, n: int = 30) -> float:
    env = E.make(task, render_size=size)
    env.reset(seed=0)
    env.render()  # create the GL context and renderer (not timed)
    times = []
    for _ in range(n):
        t = time.perf_counter()
        env.render()
        times.append(time.perf_counter() - t)
    env.close()
    return 1e3 * statistics.median(times)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=5, help="scripted episodes per task (>= 1)")
    add_cores_argument(parser)
    parser.add_argument("--no-render", action="store_true")
    parser.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    args = parser.parse_args(argv)
    with usage_errors(parser):
        check_int("--episodes", args.episodes, low=1)
        pinned = pin_cores(args.cores)
    rows = []
    tasks = [t for t in TASKS if t in ("press", "erase", "peg_in_hole", "grasp_push", "grasp_flip")]
    for task in tqdm(tasks, desc="bench_envs", unit="task", file=sys.stderr):
        build = bench_build(task)
        rtf, bare, steps = bench_rtf(task, args.episodes)
        r256 = r128 = float("nan")
        if not args.no_render:
            r256 = bench_render(task, 256)
            r128 = bench_render(task, 128)
        rows.append(
            {
                "task": task,
                "build_ms": build,
                "rtf": rtf,
                "bare_rtf": bare,
                "env_over_bare": rtf / bare,
                "steps": steps,
                "render_ms_256": r256,
                "render_ms_128": r128,
            }  # fmt: skip
        )
    print(
        f"mujoco {mujoco.__version__}, {args.episodes} scripted episodes per task, cores pinned: {pinned or 'no'}\n"
    )
    header = ["task", "build (ms)", "real-time factor (env)", "bare mj_step RTF (at rest)", "env / bare"]
    header += ["render 256 px (ms)", "render 128 px (ms)"]
    cells = [
        [r["task"], f"{r['build_ms']:.1f}", f"{r['rtf']:.1f}x", f"{r['bare_rtf']:.1f}x", f"{r['env_over_bare']:.2f}",
         f"{r['render_ms_256']:.1f}", f"{r['render_ms_128']:.1f}"]
        for r in rows
    ]  # fmt: skip
    print_table(header, cells)
    write_json(args.json, {"mujoco": mujoco.__version__, "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
