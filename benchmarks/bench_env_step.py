"""Time per ``env.step``: the env's step against the per-physics-step reference, interleaved in one process.

    .venv/bin/python -m benchmarks.bench_env_step [--runs 5] [--episodes 2] [--block 10] [--cores 1]
        [--tasks T ...] [--json out.json]

Per task, the actions of ``--episodes`` scripted demonstrations (env seeds 1000, 1001, ...) are
recorded once. Two envs then replay them in lockstep, ``--runs`` passes over the episodes: the env
(``lerobot_forcemap.envs.make``: the physics of a control step in one ``mujoco.rollout`` call, float
arithmetic around it) and the reference (``tests/envs/reference_step.py``: an ``mj_step`` call per
physics step, NumPy on 3- and 4-vectors). Each episode is cut into blocks of ``--block`` steps (the
last one shorter); a *pair* is one block run in one env, then the same block in the other (which goes
first alternates from pair to pair), each timed in thread CPU time (``time.thread_time``: the work,
without the time the thread waited for a core) and in wall time. Both envs reset at the same episode
starts, outside the clock. After every block the two envs' last step outputs (observation, reward,
flags, ``info``) must pickle to the same bytes, or the script stops: the two did the same work.

A block pair's ratio (reference time / env time) compares the two within milliseconds of each other,
so a change of the machine's speed between pairs (other processes, clock frequency) cancels. Per task:
the median of the per-pair CPU-time ratios, their interquartile range and a bootstrap 95 % interval of
that median (pairs resampled, 2,000 draws); the ratio of the total CPU times (bootstrap interval the
same way); the median of the per-pair wall-time ratios; CPU milliseconds per step of each env. Then,
from one more replay in the env alone, the share of its step spent in the physics (the
``mujoco.rollout`` call, the same ``mj_step`` work the reference does one call at a time) and the bound
that puts on the speed-up: the total CPU-time ratio over that share (the ratio of an env whose work
around the physics cost nothing). The process is pinned to one CPU core (``--cores``) like ``bench_envs.py``.
"""

from __future__ import annotations

import argparse
import pickle
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
BOOTSTRAP_DRAWS = 2000


def record_actions(env, task: str, seeds: list[int]) -> list[list[np.ndarray]]:
    """The float32 actions of one scripted demonstration per seed (demonstrator seeded like the env)."""
    names = env.unwrapped.state_names["environment_state"]
    out = []
    for seed in seeds:
        demo = make_demonstrator(task, np.random.default_rng(seed), state_names=names)
        episode = run_demonstration(env, demo, seed)
        out.append([np.asarray(f.action, dtype=np.float32) for f in episode.trace])
    return out


def _run_block(env, actions: list[np.ndarray]) -> tuple[float, float, tuple]:
    """Thread CPU and wall time (s) of ``env.step`` over ``actions``, and the last step's output."""
    cpu, wall = time.thread_time(), time.perf_counter()
    for a in actions:
        out = env.step(a)
    return time.thread_time() - cpu, time.perf_counter() - wall, out


def time_pairs(envs: dict, seeds: list[int], actions: list[list[np.ndarray]], runs: int, block: int):
    """``(pairs, 2, 2)`` times (s): per block pair, [reference, env] x [CPU, wall]; and the steps and
    resets each env did. ``RuntimeError`` if the two envs' outputs ever differ."""
    times, order = [], ("reference", "env")
    work = {name: [0, 0] for name in envs}  # steps, resets
    for _ in range(runs):
        for seed, episode in zip(seeds, actions, strict=True):
            for name, env in envs.items():
                env.reset(seed=seed)
                work[name][1] += 1
            for start in range(0, len(episode), block):
                chunk = episode[start : start + block]
                pair = {}
                for name in order:
                    pair[name] = _run_block(envs[name], chunk)
                    work[name][0] += len(chunk)
                ref_out, env_out = pickle.dumps(pair["reference"][2]), pickle.dumps(pair["env"][2])
                if ref_out != env_out:
                    raise RuntimeError(f"seed {seed}, steps {start}..: the two envs' outputs differ")
                times.append([pair["reference"][:2], pair["env"][:2]])
                order = order[::-1]
    return np.array(times), work


def physics_share(env, seeds: list[int], actions: list[list[np.ndarray]]) -> float:
    """The share of the env's step CPU time spent in its physics (``BlockStepper.run``: the
    ``mujoco.rollout`` call), over one more replay of ``actions`` in the env alone."""
    stepper = env.unwrapped._stepper
    spent = [0.0, 0.0]  # physics, whole steps

    def timed_run():
        start = time.thread_time()
        rows = type(stepper).run(stepper)
        spent[0] += time.thread_time() - start
        return rows

    stepper.run = timed_run  # an instance attribute over the class's method, deleted below
    try:
        for seed, episode in zip(seeds, actions, strict=True):
            env.reset(seed=seed)
            spent[1] += _run_block(env, episode)[0]
    finally:
        del stepper.run
    return spent[0] / spent[1]


def _bootstrap_ci(values: np.ndarray, stat, rng: np.random.Generator) -> list[float]:
    """95 % percentile interval of ``stat`` over resamples (with replacement) of the rows of ``values``."""
    draws = rng.integers(0, len(values), size=(BOOTSTRAP_DRAWS, len(values)))
    return [float(v) for v in np.percentile([stat(values[d]) for d in draws], [2.5, 97.5])]


def summarise(times: np.ndarray, steps: int) -> dict:
    """The figures of one task from :func:`time_pairs`'s times; ``steps``: steps per env in them."""
    cpu = times[:, :, 0]  # (pairs, [reference, env])
    ratios = cpu[:, 0] / cpu[:, 1]
    rng = np.random.default_rng(0)
    q1, q3 = np.percentile(ratios, [25, 75])
    return {
        "reference_ms": 1e3 * float(cpu[:, 0].sum()) / steps,
        "env_ms": 1e3 * float(cpu[:, 1].sum()) / steps,
        "speedup": float(np.median(ratios)),
        "speedup_iqr": [float(q1), float(q3)],
        "speedup_ci": _bootstrap_ci(ratios, np.median, rng),
        "speedup_total": float(cpu[:, 0].sum() / cpu[:, 1].sum()),
        "speedup_total_ci": _bootstrap_ci(cpu, lambda c: c[:, 0].sum() / c[:, 1].sum(), rng),
        "speedup_wall": float(np.median(times[:, 0, 1] / times[:, 1, 1])),
    }


def bench_task(task: str, runs: int, episodes: int, block: int) -> dict:
    seeds = list(range(FIRST_SEED, FIRST_SEED + episodes))
    envs = {"reference": make_reference(task, render_mode=None), "env": E.make(task, render_mode=None)}
    actions = record_actions(envs["env"], task, seeds)  # also the env's warm-up
    time_pairs(envs, seeds[:1], actions[:1], 1, block)  # the reference's warm-up (and a first check)
    times, work = time_pairs(envs, seeds, actions, runs, block)
    share = physics_share(envs["env"], seeds, actions)
    for env in envs.values():
        env.close()
    if work["reference"] != work["env"]:
        raise RuntimeError(f"{task}: the envs did unequal work (steps, resets): {work}")
    steps, resets = work["env"]
    row = {"task": task, "steps": steps, "resets": resets, "pairs": len(times), **summarise(times, steps)}
    # the env's physics share, and the speed-up an env with no work around its physics would reach
    row["env_physics_share"] = share
    row["speedup_bound"] = row["speedup_total"] / share
    return row


def _cells(r: dict) -> list[str]:
    (q1, q3), (lo, hi), (tlo, thi) = r["speedup_iqr"], r["speedup_ci"], r["speedup_total_ci"]
    return [
        r["task"], str(r["steps"]), str(r["pairs"]), f"{r['reference_ms']:.3f}", f"{r['env_ms']:.3f}",
        f"{r['speedup']:.2f}x ({q1:.2f}..{q3:.2f}) [{lo:.2f}..{hi:.2f}]",
        f"{r['speedup_total']:.2f}x [{tlo:.2f}..{thi:.2f}]", f"{r['speedup_wall']:.2f}x",
        f"{100 * r['env_physics_share']:.0f} %", f"{r['speedup_bound']:.2f}x",
    ]  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5, help="passes over the episodes (>= 1)")
    parser.add_argument("--episodes", type=int, default=2, help="scripted episodes per task (>= 1)")
    parser.add_argument("--block", type=int, default=10, help="steps per timed block (>= 1)")
    parser.add_argument("--tasks", nargs="+", default=list(TASKS), choices=TASKS)
    add_cores_argument(parser)
    parser.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    args = parser.parse_args(argv)
    with usage_errors(parser):
        check_int("--runs", args.runs, low=1)
        check_int("--episodes", args.episodes, low=1)
        check_int("--block", args.block, low=1)
        pinned = pin_cores(args.cores)
    rows = [bench_task(task, args.runs, args.episodes, args.block) for task in args.tasks]
    print(
        f"mujoco {mujoco.__version__}; {args.episodes} scripted episodes per task (seeds {FIRST_SEED}..), "
        f"{args.runs} passes, blocks of {args.block} steps, reference and env alternating per block, "
        f"cores pinned: {pinned or 'no'}\n"
    )
    header = ["task", "steps per env", "block pairs", "reference (ms/step, CPU)", "env (ms/step, CPU)"]
    header += ["speed-up, CPU: median of pair ratios (IQR) [95 % CI]", "speed-up, total CPU [95 % CI]"]
    header += ["speed-up, wall: median of pair ratios", "env's physics share", "bound: physics only"]
    print_table(header, [_cells(r) for r in rows])
    method = {"runs": args.runs, "episodes": args.episodes, "block": args.block, "cores": pinned}
    write_json(args.json, {"mujoco": mujoco.__version__, "method": method, "rows": rows})
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
