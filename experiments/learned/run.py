"""Learned baselines: ACT and Diffusion trained with ``lerobot-train`` on the shipped
datasets (all 10 demos, CPU, small configs) and evaluated on the forcemap experiments' seeds.

    python -m experiments.learned --tasks press erase peg_in_hole \
        --methods act diffusion --steps act=4000 diffusion=1500 --out results/learned
    python -m experiments.learned --smoke --tasks press --out /tmp/learned --work /tmp/learned_work   # 3 steps, 2 episodes
    python -m experiments.learned --reevaluate --tasks peg_in_hole --work /tmp/learned_work   # after an env change

Per task: ``datasets/<task>`` -> derived dataset ``<work>/datasets/<task>`` whose
``observation.environment_state`` is ``[object state | ee_pose | force]`` (how force reaches ACT and
Diffusion, see ``experiments/learned/baselines.py``). Per task x method: ``lerobot-train``
(subprocess, checkpoints under ``<work>/<task>__<method>/``, not committed), then ``evaluate_policy``
with the same env processor (``--env.env_state_extras=ee_pose,force`` in ``lerobot-eval`` terms) on
episodes ``seed .. seed + episodes - 1`` (default 1000..1019; torch seeded per episode, so Diffusion's
sampling noise is reproducible) for the forces LeRobot does not record, then ``lerobot-eval`` itself on
the same seeds (its success per seed in ``lerobot_eval``), then one JSON per task x method:

    results/learned/<task>__<method>.json
    {"task", "method", "n", "seeds", "success_rate", "protective_stops",
     "max_contact_force": {"mean", "std"}, "mean_contact_force": {"mean", "std"},
     "max_contact_force_xyz": {"mean": [3], "std": [3]}, "mean_contact_force_xyz": {"mean": [3], "std": [3]},
     "train_steps", "train_wall_time_s", "eval_wall_time_s", "wall_time_s" (train + both evaluations),
     "lerobot_eval": {"n", "seeds", "success_rate", "successes", "wall_time_s", "command"},
     "config", "force_inputs", "episodes": [...]}

(std: sample std over episodes, ddof 1.) Existing JSONs are skipped unless ``--force``. ``--steps``
and ``--batch-size`` take one number for every method or ``method=N`` pairs.

Budgets (defaults): ACT 4000 steps x batch 8, Diffusion 1500 steps x batch 64, the same for every
task. Measured on the shared 2-core machine (median of lerobot-train's logged updt_s + data_s):
ACT 0.08 s/step (~5.5 min per task), Diffusion 0.48 s/step (~12 min per task; its data loading of
16-frame action windows costs as much as the update); the whole 3 x 2 run with both evaluations takes
1-1.5 h. Diffusion's budget is the larger share because it converges more slowly (noise-prediction
loss still falling at 700 steps: 0.15-0.17; at 1500: 0.05-0.06).
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from lerobot_forcemap._validation import check_int, usage_errors

REPO = Path(__file__).resolve().parents[2]
TASKS = ("press", "erase", "peg_in_hole")
METHODS = ("act", "diffusion")
SMOKE_STEPS = 3
DEFAULT_OUT = REPO / "results" / "learned"
DEFAULT_WORK = REPO / "outputs" / "learned"
SMOKE_EPISODES = 2


def parse_steps(items: list[str], methods: list[str], flag: str = "--steps") -> dict[str, int]:
    """``["300"]`` -> every method 300; ``["act=300", "diffusion=100"]`` -> per method. ``flag``: the
    option the items came from (``--steps`` / ``--batch-size``), named in the errors."""
    out: dict[str, int] = {}
    for item in items:
        name, _, value = item.rpartition("=")
        if name and name not in METHODS:
            raise ValueError(f"{flag}: unknown method {name!r} in {item!r} ({', '.join(METHODS)})")
        try:
            number = int(value)
        except ValueError:
            raise ValueError(f"{flag}: {item!r} is not N or method=N with an integer N") from None
        out.update({name: number} if name else dict.fromkeys(methods, number))
    missing = [m for m in methods if m not in out]
    if missing:
        raise ValueError(f"{flag}: no value for {missing}")
    for name, value in out.items():
        check_int(f"{flag} {name}", value, low=1)
    return out


_TQDM = re.compile(r"Training:\s+\d+%\|[^|]*\|\s*(\d+)/(\d+)")
_LOG = re.compile(r"updt_s:([0-9.]+) data_s:([0-9.]+)")


def run_training(argv: list[str], log_path: Path, steps: int, desc: str) -> tuple[float, list[float]]:
    """Run ``lerobot-train`` (argv), stream its output to ``log_path`` with a tqdm bar over steps.
    Returns (wall time s, per-log-interval seconds per step = updt_s + data_s). Raises RuntimeError
    (with the log's tail) on a non-zero exit."""
    from tqdm.auto import tqdm

    log_path.parent.mkdir(parents=True, exist_ok=True)
    per_step: list[float] = []
    t0 = time.perf_counter()
    with open(log_path, "w") as log, tqdm(total=steps, desc=desc, unit="step", leave=False) as bar:
        proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, cwd=REPO, bufsize=0)
        assert proc.stdout is not None
        buf = b""
        while True:
            chunk = proc.stdout.read(4096)
            if not chunk:
                break
            log.write(chunk.decode(errors="replace"))
            buf += chunk
            *lines, buf = re.split(rb"[\r\n]", buf)
            for raw in lines:
                line = raw.decode(errors="replace")
                m = _TQDM.search(line)
                if m:
                    bar.n = int(m.group(1))
                    bar.refresh()
                m = _LOG.search(line)
                if m:
                    per_step.append(float(m.group(1)) + float(m.group(2)))
        rc = proc.wait()
    wall = time.perf_counter() - t0
    if rc != 0:
        tail = log_path.read_text()[-3000:]
        raise RuntimeError(f"lerobot-train failed (exit {rc}); log {log_path}:\n{tail}")
    return wall, per_step


def run_one(
    task: str,
    method: str,
    steps: int,
    dataset_root: Path,
    work: Path,
    *,
    episodes: int,
    seed: int,
    batch_size: int,
    smoke: bool,
    extras: tuple[str, ...],
) -> dict[str, Any]:
    """Train one method on one task's derived dataset, evaluate it twice; returns its result document."""
    from experiments.learned.baselines import force_inputs_text, policy_config, result_document, train_command

    cfg = policy_config(method, smoke=smoke)
    run_dir = work / f"{task}__{method}"
    if run_dir.exists():
        shutil.rmtree(run_dir)
    train_dir = run_dir / "train"
    argv = train_command(
        method,
        dataset_root,
        train_dir,
        steps=steps,
        config=cfg,
        batch_size=batch_size,
        repo_id=f"local/{task}_learned",
        python=sys.executable,
    )
    train_wall, per_step = run_training(argv, run_dir / "train.log", steps, f"train {task}/{method}")
    ckpt = train_dir / "checkpoints" / "last" / "pretrained_model"
    records, eval_wall, lerobot_eval = evaluate_checkpoint(ckpt, task, run_dir, episodes, seed, extras)
    train_cfg = json.loads((ckpt / "train_config.json").read_text())
    config = {
        "policy": {k: v for k, v in train_cfg["policy"].items() if k in cfg or k in _KEY_POLICY_FIELDS},
        "training": _training_block(train_cfg, argv, batch_size, steps, dataset_root, per_step),
        "eval": {"env_state_extras": list(extras), "episodes": episodes, "first_seed": seed},
    }
    if smoke:
        config["smoke"] = True
    return result_document(
        task,
        method,
        records,
        [seed + i for i in range(episodes)],
        train_steps=steps,
        train_wall_time_s=train_wall,
        eval_wall_time_s=eval_wall,
        config=config,
        force_inputs=force_inputs_text(extras),
        lerobot_eval=lerobot_eval,
    )


def _training_block(
    train_cfg: dict, argv: list[str], batch_size: int, steps: int, dataset_root: Path, per_step: list[float]
) -> dict[str, Any]:
    """The result's ``config.training``: what ``lerobot-train`` ran with and its median s per step."""
    return {
        "batch_size": batch_size,
        "steps": steps,
        "seed": train_cfg.get("seed"),
        "optimizer": (train_cfg.get("optimizer") or {}).get("type"),
        "scheduler": (train_cfg.get("scheduler") or {}).get("type"),
        "device": "cpu",
        "dataset": str(dataset_root),
        "demos": "all 10",
        "median_s_per_step": float(np.median(per_step)) if per_step else None,
        "command": " ".join(argv[1:]),
    }


def evaluate_checkpoint(
    ckpt: Path, task: str, run_dir: Path, episodes: int, seed: int, extras: tuple[str, ...]
) -> tuple[list[dict[str, Any]], float, dict[str, Any]]:
    """Our rollout (records with forces) and its wall time, then ``lerobot-eval`` on the same seeds."""
    from lerobot_forcemap.evaluation.evaluate import evaluate_policy

    t0 = time.perf_counter()
    records = evaluate_policy(ckpt, task, episodes, seed, env_state_extras=",".join(extras), progress=True)
    eval_wall = time.perf_counter() - t0
    lerobot_eval = run_lerobot_eval(
        ckpt, task, run_dir / "lerobot_eval", episodes=episodes, seed=seed, extras=extras
    )
    return records, eval_wall, lerobot_eval


def reevaluate_one(task: str, method: str, work: Path, old: dict[str, Any]) -> dict[str, Any]:
    """Both evaluations again on the checkpoint ``work`` holds, with the seeds and env-state extras of
    ``old`` (its JSON), keeping its training figures: how an env change reaches the learned rows without
    an hour of retraining. Raises ValueError when the checkpoint is missing or is not the one ``old`` reports."""
    from experiments.learned.baselines import result_document

    ckpt = work / f"{task}__{method}" / "train" / "checkpoints" / "last" / "pretrained_model"
    if not (ckpt / "train_config.json").is_file():
        raise ValueError(
            f"--reevaluate {task}/{method}: no checkpoint at {ckpt} (point --work at the training's)"
        )
    trained = json.loads((ckpt / "train_config.json").read_text())
    if (
        trained.get("steps") != old["train_steps"]
        or trained.get("batch_size") != old["config"]["training"]["batch_size"]
    ):
        raise ValueError(
            f"--reevaluate {task}/{method}: {ckpt} was trained {trained.get('steps')} steps x batch "
            f"{trained.get('batch_size')}, its JSON reports {old['train_steps']} x {old['config']['training']['batch_size']}"
        )
    seeds = [int(s) for s in old["seeds"]]
    records, eval_wall, lerobot_eval = evaluate_checkpoint(
        ckpt,
        task,
        work / f"{task}__{method}",
        len(seeds),
        seeds[0],
        tuple(old["config"]["eval"]["env_state_extras"]),
    )
    return result_document(
        task,
        method,
        records,
        seeds,
        train_steps=old["train_steps"],
        train_wall_time_s=old["train_wall_time_s"],
        eval_wall_time_s=eval_wall,
        config={**old["config"], "reevaluated": True},
        force_inputs=old["force_inputs"],
        lerobot_eval=lerobot_eval,
    )


def run_lerobot_eval(
    ckpt: Path, task: str, out_dir: Path, *, episodes: int, seed: int, extras: tuple[str, ...]
) -> dict[str, Any]:
    """``lerobot-eval`` of the checkpoint on the same seeds (success only: LeRobot records no forces);
    its log goes to ``out_dir``.log. Raises RuntimeError with the log's tail on a non-zero exit."""
    from experiments.learned.baselines import eval_command, read_lerobot_eval

    if out_dir.exists():
        shutil.rmtree(out_dir)
    seeds = [seed + i for i in range(episodes)]
    env = {"env_state_extras": ",".join(extras)}
    argv = eval_command(ckpt, task, out_dir, seeds, env, python=sys.executable)
    log_path = out_dir.with_suffix(".log")
    print(f"lerobot-eval {task}: {episodes} episodes (log {log_path})", flush=True)
    t0 = time.perf_counter()
    with open(log_path, "w") as log:
        rc = subprocess.run(argv, stdout=log, stderr=subprocess.STDOUT, cwd=REPO).returncode
    wall = time.perf_counter() - t0
    if rc != 0:
        raise RuntimeError(
            f"lerobot-eval failed (exit {rc}); log {log_path}:\n{log_path.read_text()[-3000:]}"
        )
    result = read_lerobot_eval(out_dir, seeds)
    return {**result, "wall_time_s": wall, "command": " ".join(argv[1:])}


_KEY_POLICY_FIELDS = {"type", "n_obs_steps", "input_features", "output_features", "temporal_ensemble_coeff"}


def table(docs: list[dict[str, Any]]) -> str:
    """A Markdown table of result documents: success, stops, forces, train and eval time."""
    rows = [
        "| task | method | steps | n | success | protective stops | max force N (mean ± std) | mean force N (mean ± std) | train s | eval s |",
        "|---|---|---|---|---|---|---|---|---|---|",
    ]
    for d in docs:
        rows.append(
            f"| {d['task']} | {d['method']} | {d['train_steps']} | {d['n']} | {100 * d['success_rate']:.0f}% | "
            f"{d['protective_stops']} | {d['max_contact_force']['mean']:.1f} ± {d['max_contact_force']['std']:.1f} | "
            f"{d['mean_contact_force']['mean']:.2f} ± {d['mean_contact_force']['std']:.2f} | "
            f"{d['train_wall_time_s']:.0f} | {d['eval_wall_time_s']:.0f} |"
        )
    return "\n".join(rows)


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("--tasks", nargs="+", default=list(TASKS), choices=TASKS)
    p.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    p.add_argument("--steps", nargs="+", default=["act=4000", "diffusion=1500"], help="N or method=N ...")
    p.add_argument("--batch-size", nargs="+", default=["act=8", "diffusion=64"], help="N or method=N ...")
    p.add_argument("--episodes", type=int, default=20)
    p.add_argument(
        "--seed", type=int, default=1000, help="env seed of the first episode (episode i: seed + i)"
    )
    p.add_argument("--out", type=Path, default=DEFAULT_OUT)
    p.add_argument("--work", type=Path, default=DEFAULT_WORK, help="datasets and checkpoints")
    p.add_argument(
        "--datasets", type=Path, default=REPO / "datasets", help="folder with the shipped datasets"
    )
    p.add_argument(
        "--extras", default="ee_pose,force", help="appended to environment_state (see env_state.py)"
    )
    p.add_argument("--force", action="store_true", help="redo tasks whose JSON exists")
    p.add_argument(
        "--smoke", action="store_true", help=f"{SMOKE_STEPS} steps, {SMOKE_EPISODES} episodes, tiny models"
    )
    p.add_argument(
        "--reevaluate",
        action="store_true",
        help="no training: evaluate the checkpoints under --work again (seeds and extras from the JSONs "
        "in --out, training figures kept), e.g. after an env change",
    )
    return p


def main(argv: list[str] | None = None) -> int:
    p = _parser()
    args = p.parse_args(argv)
    if args.reevaluate:
        return _reevaluate(args, p)
    if args.smoke and (args.out == DEFAULT_OUT or args.work == DEFAULT_WORK):
        # the default --work holds the trained checkpoints (run_one replaces a task's folder) and the
        # default --out the results the report merges: a smoke run must not overwrite either
        p.error("--smoke needs --out and --work outside results/learned and outputs/learned")
    with usage_errors(p):
        plan = _plan(args)
    args.out.mkdir(parents=True, exist_ok=True)
    docs = []
    for task in args.tasks:
        docs += _train_task(task, args, plan)
    print(table(docs))
    return 0


def _plan(args: argparse.Namespace) -> dict[str, Any]:
    """The checked datasets and settings: env-state extras, steps and batch size per method, episodes
    (the ``--smoke`` sizes under ``--smoke``)."""
    from lerobot_env_forcemap.env_state import parse_env_state_extras
    from lerobot_forcemap.data.schema import require_dataset_root

    for task in args.tasks:
        require_dataset_root(args.datasets / task, "--datasets")
    check_int("--episodes", args.episodes, low=1)
    check_int("--seed", args.seed, low=0)
    plan = {
        "extras": parse_env_state_extras(args.extras),
        "steps": parse_steps(args.steps, args.methods),
        "batch": parse_steps(args.batch_size, args.methods, "--batch-size"),
        "episodes": args.episodes,
    }
    if args.smoke:
        plan["steps"] = dict.fromkeys(args.methods, SMOKE_STEPS)
        plan["batch"] = dict.fromkeys(args.methods, 4)
        plan["episodes"] = min(args.episodes, SMOKE_EPISODES)
    return plan


def _train_task(task: str, args: argparse.Namespace, plan: dict[str, Any]) -> list[dict[str, Any]]:
    """Train and evaluate the methods of one task whose result is missing (or all with ``--force``) on
    its derived dataset; returns every method's result document."""
    from experiments.learned.baselines import derive_env_state_dataset

    todo = [m for m in args.methods if args.force or not (args.out / f"{task}__{m}.json").is_file()]
    for m in args.methods:
        if m not in todo:
            print(f"skip {task}/{m}: {args.out / f'{task}__{m}.json'} exists (--force to redo)")
    ds_root = args.work / "datasets" / task
    if todo:
        derive_env_state_dataset(args.datasets / task, ds_root, plan["extras"], overwrite=True)
    for method in todo:
        doc = run_one(
            task,
            method,
            plan["steps"][method],
            ds_root,
            args.work,
            episodes=plan["episodes"],
            seed=args.seed,
            batch_size=plan["batch"][method],
            smoke=args.smoke,
            extras=plan["extras"],
        )
        path = args.out / f"{task}__{method}.json"
        path.write_text(json.dumps(doc, indent=1))
        print(
            f"{task}/{method}: success {100 * doc['success_rate']:.0f}% of {doc['n']}, "
            f"max force {doc['max_contact_force']['mean']:.1f} N, train {doc['train_wall_time_s']:.0f} s -> {path}"
        )
    paths = [args.out / f"{task}__{m}.json" for m in args.methods]
    return [json.loads(path.read_text()) for path in paths if path.is_file()]


def _reevaluate(args: argparse.Namespace, p: argparse.ArgumentParser) -> int:
    docs = []
    for task in args.tasks:
        for method in args.methods:
            path = args.out / f"{task}__{method}.json"
            if not path.is_file():
                p.error(f"--reevaluate: {path} not found (train {task}/{method} first)")
            try:
                doc = reevaluate_one(task, method, args.work, json.loads(path.read_text()))
            except ValueError as err:
                p.error(str(err))
            path.write_text(json.dumps(doc, indent=1))
            print(
                f"{task}/{method} re-evaluated: success {100 * doc['success_rate']:.0f}% of {doc['n']}, "
                f"max force {doc['max_contact_force']['mean']:.1f} N -> {path}"
            )
            docs.append(doc)
    print(table(docs))
    return 0


if __name__ == "__main__":
    sys.exit(main())
