"""Grasping the unseen objects: the scripted demonstrator, and a simple re-anchored replay of the shipped demos.

    .venv/bin/python -m experiments.grasp_unseen_objects [--seeds 20] [--json out.json]

Per task (``grasp_push``, ``grasp_flip``) and object (the demonstration object, ``apple``, ``banana``):

- ``demonstrator``: the object-aware scripted demonstrator (it sees the object's pose and size), seeds
  ``100 .. 100 + n``;
- ``replay``: each of the 10 shipped demonstrations (``datasets/<task>``, recorded on the demonstration
  object) replayed open-loop on the object, episode seed ``200 + k``. Re-anchoring, the simplest a
  segment-wise policy can do: the pre-grasp frames (approach, push/flip, retreat) are shifted by the
  difference of the objects' initial centres (x, y); the grasp frames (reach .. hold) by the difference
  of the object centres (x, y, z) observed when the reach begins. Orientation and gripper command are
  replayed unchanged, at the dataset's frame rate; after the last frame the last action is held until
  the episode's time limit.

Prints a markdown table: success rate, protective stops, per-finger max force (mean over episodes) and
max contact force. Numbers depend on the MuJoCo version (MuJoCo is bitwise deterministic within one
version only).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

import numpy as np
from tqdm import tqdm

import lerobot_forcemap.envs as E
from lerobot_forcemap import layout
from lerobot_forcemap._validation import check_int, usage_errors
from lerobot_forcemap.data.reader import read_columns, read_meta
from lerobot_forcemap.envs.demonstrators import make_demonstrator, run_demonstration
from lerobot_forcemap.evaluation.records import FINGER_KEYS, FORCE_KEYS, to_json
from lerobot_forcemap.evaluation.stats import failure_counts, summarize

REPO = Path(__file__).resolve().parents[1]
TASKS = ("grasp_push", "grasp_flip")
GRASP_PHASES = ("reach", "descend", "grasp", "lift", "hold")


def load_demos(task: str) -> tuple[list[dict[str, np.ndarray]], list[str]]:
    root = REPO / "datasets" / task
    meta = read_meta(root)
    keys = (layout.ACTION, layout.OBS_ENV_STATE, layout.DEMO_PHASE)
    cols = read_columns(meta, list(range(meta.total_episodes)), [*keys, "episode_index"])
    episode = cols.pop("episode_index")
    phases = json.loads((root / "meta" / layout.EPISODES_FILE).read_text())["phases"]
    demos = [{k: v[episode == e] for k, v in cols.items()} for e in np.unique(episode)]
    return demos, phases


def replay(env, demo: dict[str, np.ndarray], phases: list[str], seed: int) -> dict:
    """One re-anchored open-loop replay (see the module docstring); returns the final info."""
    obs, info = env.reset(seed=seed)
    actions = demo[layout.ACTION].astype(float)
    state = demo[layout.OBS_ENV_STATE].astype(float)
    phase = np.array([phases[int(p)] for p in demo[layout.DEMO_PHASE].ravel()])
    first_grasp = int(np.argmax(np.isin(phase, GRASP_PHASES)))
    shift = np.zeros(3)
    shift[:2] = obs[layout.ENV_STATE][:2] - state[0, :2]
    limit = env.unwrapped.task_impl.spec.max_episode_steps
    for k in range(limit):  # after the last frame: hold it (a policy's reproduction ends the same way)
        i = min(k, len(actions) - 1)
        if k == first_grasp:
            shift = obs[layout.ENV_STATE][:3] - state[k, :3]
        a = actions[i].copy()
        a[:3] += shift
        obs, _, terminated, truncated, info = env.step(a)
        if terminated or truncated:
            break
    return info


def summarise(infos: list[dict]) -> dict:
    """n, success rate, protective stops, mean per-finger and contact max force, the failure reasons."""
    records = [
        {
            "success": bool(i["is_success"]),
            "protective_stop": bool(i["protective_stop"]),
            "termination_reason": i["termination_reason"],
            **{k: to_json(i[k]) for k in (*FORCE_KEYS, *FINGER_KEYS) if k in i},
        }
        for i in infos
    ]
    s = summarize(records, ("max_contact_force", "max_finger_force"), clipped=False)
    return {
        "n": s["n"],
        "success": s["success_rate"],
        "protective_stops": s["protective_stops"],
        "max_finger_force": s["max_finger_force"]["mean"],
        "max_contact_force": s["max_contact_force"]["mean"],
        "failures": sorted(failure_counts(records)),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--seeds", type=int, default=20, help="demonstrator episodes per task and object (>= 1)"
    )
    parser.add_argument("--json", default=None, help="also write the numbers to this JSON file")
    args = parser.parse_args(argv)
    with usage_errors(parser):
        check_int("--seeds", args.seeds, low=1)
    rows = []
    for task in TASKS:
        demos, phases = load_demos(task)
        for obj in E.task_spec(task).objects:  # the demonstration object first, then the unseen ones
            env = E.make(task, object=obj, render_mode=None)
            names = env.unwrapped.state_names[layout.ENV_STATE]
            infos = []
            for seed in tqdm(range(100, 100 + args.seeds), desc=f"{task} {obj} demonstrator", leave=False):
                demo = make_demonstrator(task, np.random.default_rng(seed), state_names=names)
                infos.append(run_demonstration(env, demo, seed).info)
            rows.append({"task": task, "object": obj, "method": "demonstrator", **summarise(infos)})
            infos = [
                replay(env, d, phases, 200 + k)
                for k, d in enumerate(tqdm(demos, desc=f"{task} {obj} replay", leave=False))
            ]
            rows.append({"task": task, "object": obj, "method": "re-anchored replay", **summarise(infos)})
            env.close()
    print(
        "| task | object | method | n | success | protective stops | max finger force f0 / f1 / f2 (N) | max contact force (N) | failures |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        f = " / ".join(f"{x:.1f}" for x in r["max_finger_force"])
        print(
            f"| {r['task']} | {r['object']} | {r['method']} | {r['n']} | {100 * r['success']:.0f}% | "
            f"{r['protective_stops']} | {f} | {r['max_contact_force']:.1f} | {', '.join(r['failures']) or '-'} |"
        )
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
