"""Time per ``env.step``: the env's step against the per-physics-step reference, in one run.

    .venv/bin/python -m benchmarks.bench_env_step [--runs 5] [--episodes 2] [--cores 1] [--json out.json]

Per task, the actions of ``--episodes`` scripted demonstrations (env seeds 1000, 1001, ...) are
recorded once, then replayed ``--runs`` times through each of two envs: the env
(``lerobot_forcemap.envs.make``: the physics of a control step in one ``mujoco.rollout`` call, float
arithmetic around it) and the reference (``tests/envs/reference_step.py``: an ``mj_step`` call per
physics step, NumPy on 3- and 4-vectors). Both give the same episodes (checked by
``tests/envs/test_step_reference.py``, not here). A run replays all episodes in one env, then in the
other (which one first alternates between runs), as an env runs in practice: alone in its process.
Per run and env the median time of one ``env.step`` (reset excluded), in thread CPU time (the work,
without the time the process waited for a core: the steadier figure on a shared machine) and in wall
time; the table shows the medians over runs and the median of the per-run ratios (CPU time: with
their range). Compare ratios, not times. The process is pinned to one CPU core (``--cores``) like
``bench_envs.py``.
"""

from __future__ import annotations

import argparse
import time

import mujoco
import numpy as np

import lerobot_forcemap.envs as E
from benchmarks._common import add_cores_argument, pin_cores, print_table, write_json
from lerobot_forcemap._validation import check_int, usage_errors
from lerobot_forcemap.envs.demonstrators import make_demonstrator, run_demonstration
from tests.envs.reference_step import make_reference  # the reference step lives with the tests

TASKS = ("press", "erase", "peg_in_hole", "grasp_push", "grasp_flip")
FIRST_SEED = 1000


def record_actions(env, task: str, seeds: list[int]) -> list[list[np.ndarray]]:
    """The float32 actions of one scripted demonstration per seed (demonstrator seeded like the env)."""
    names = env.unwrapped.state_names["environment_state"]
    out = []
    for seed in seeds:
        demo = make_demonstrator(task, np.random.default_rng(seed), state_names=names)
        episode = run_demonstration(env, demo, seed)
        out.append([np.asarray(f.action, dtype=np.float32) for f in episode.trace])
    return out


def step_times(env, seeds: list[int], actions: list[list[np.ndarray]]) -> np.ndarray:
    """``(steps, 2)``: thread CPU and wall time (s) of every ``env.step``, replaying ``actions`` from
    ``reset(seed)``."""
    times = []
    for seed, episode in zip(seeds, actions, strict=True):
        env.reset(seed=seed)
        for a in episode:
            cpu, wall = time.thread_time(), time.perf_counter()
            env.step(a)
            times.append((time.thread_time() - cpu, time.perf_counter() - wall))
    return np.array(times)


def bench_task(task: str, runs: int, episodes: int) -> dict:
    seeds = list(range(FIRST_SEED, FIRST_SEED + episodes))
    envs = {"env": E.make(task, render_mode=None), "reference": make_reference(task, render_mode=None)}
    actions = record_actions(envs["env"], task, seeds)
    medians: dict[str, list[np.ndarray]] = {"env": [], "reference": []}
    for run in range(runs):
        for path in ("reference", "env") if run % 2 == 0 else ("env", "reference"):
            medians[path].append(np.median(step_times(envs[path], seeds, actions), axis=0))
    for env in envs.values():
        env.close()
    ref, new = np.array(medians["reference"]), np.array(medians["env"])  # (runs, [cpu, wall])
    ratios = ref / new
    return {
        "task": task,
        "steps": sum(len(a) for a in actions),
        "reference_ms": 1e3 * float(np.median(ref[:, 0])),
        "env_ms": 1e3 * float(np.median(new[:, 0])),
        "speedup": float(np.median(ratios[:, 0])),
        "speedup_min": float(ratios[:, 0].min()),
        "speedup_max": float(ratios[:, 0].max()),
        "speedup_wall": float(np.median(ratios[:, 1])),
    }


def _cells(r: dict) -> list[str]:
    return [
        r["task"], str(r["steps"]), f"{r['reference_ms']:.3f}", f"{r['env_ms']:.3f}",
        f"{r['speedup']:.2f}x ({r['speedup_min']:.2f}..{r['speedup_max']:.2f})", f"{r['speedup_wall']:.2f}x",
    ]  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="timing runs per task (>= 1)")
    parser.add_argument("--episodes", type=int, default=2, help="scripted episodes per task (>= 1)")
    parser.add_argument("--tasks", nargs="+", default=list(TASKS), choices=TASKS)
    add_cores_argument(parser)
    parser.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    args = parser.parse_args(argv)
    with usage_errors(parser):
        check_int("--runs", args.runs, low=1)
        check_int("--episodes", args.episodes, low=1)
        pinned = pin_cores(args.cores)
    rows = [bench_task(task, args.runs, args.episodes) for task in args.tasks]
    print(
        f"mujoco {mujoco.__version__}; {args.episodes} scripted episodes per task (seeds {FIRST_SEED}..), "
        f"{args.runs} runs, cores pinned: {pinned or 'no'}; medians of the per-step time\n"
    )
    header = ["task", "steps per run", "reference (ms/step, CPU)", "env (ms/step, CPU)"]
    header += ["speed-up, CPU time (min..max over runs)", "speed-up, wall time"]
    print_table(header, [_cells(r) for r in rows])
    write_json(args.json, {"mujoco": mujoco.__version__, "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
