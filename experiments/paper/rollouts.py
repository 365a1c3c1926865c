"""What one job computes: the method's actor (a fitted forcemap checkpoint or a baseline) and its episodes.

- ``kind="forcemap"``: fit the forcemap policy one-shot from ``demo`` (``fit_policy`` with the job's
  ``--set`` overrides, the code path of ``lerobot-train --policy.type=forcemap --steps=1``), save the
  checkpoint, load it back as ``lerobot-eval`` does and roll it out;
- ``kind="hybrid"``: the paper's control baseline, ``HybridForcePositionPolicy`` following the same
  demonstration's actions, re-anchored rigidly to the task object's pose in the new scene;
- ``kind="replay"``: the same re-anchored actions open loop (what the demonstrator did, moved to the
  new scene).

Every method's episodes go through :func:`run_episode`, so their records (``evaluation/records.py``
with the finger figures and ``force_by_gripper_phase``) are computed identically.
"""

from __future__ import annotations

import hashlib
import json
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from experiments.paper.demos import DemoEpisode, load_demo_episode, reanchor_actions
from experiments.paper.jobs import Job, code_fingerprint
from lerobot_forcemap import layout
from lerobot_forcemap.evaluation.records import (
    ALL_FIGURES,
    episode_record,
    force_by_gripper_phase,
    to_json,
    trace_block,
    trace_row,
)

__all__ = ["run_episode", "run_job", "fit_key", "fitted_checkpoint"]

#: decimals of the stored trace rows (the cached records stay small)
TRACE_DECIMALS = 5


def run_episode(
    env, reset: Callable[[dict], None], act: Callable[[dict], np.ndarray], seed: int, *, trace: bool = False
) -> dict[str, Any]:
    """One episode: ``reset(obs)`` after ``env.reset(seed=seed)``, then ``act(obs) -> action (8,)``
    until the episode ends. Returns its record with the force and finger figures, the per-gripper-phase
    force peaks (from the contact force after each step) and, with ``trace``, the trace."""
    from lerobot_forcemap.envs.rollout import Step
    from lerobot_forcemap.envs.rollout import run_episode as run_env_episode

    base = env.unwrapped
    fps = base.metadata["render_fps"]

    def act64(obs: dict) -> np.ndarray:
        return np.asarray(act(obs), dtype=np.float64).reshape(-1)

    def sample(step: Step) -> tuple[np.ndarray, float, list[float] | None]:
        force = np.asarray(step.next_info["contact_force"], dtype=np.float64)
        return force, float(step.action[layout.ACTION_GRIPPER]), trace_row(step, fps) if trace else None

    episode = run_env_episode(env, act64, seed, reset=reset, trace=sample)
    record = episode_record(episode, ALL_FIGURES)
    forces, grips, rows = zip(*episode.trace, strict=True) if episode.trace else ((), (), ())
    record["force_by_gripper_phase"] = force_by_gripper_phase(np.asarray(forces), np.asarray(grips))
    if trace:
        record["trace"] = trace_block(
            rows,
            episode.obs.get(layout.ENV_STATE),
            base.state_names.get(layout.ENV_STATE, ()),
            decimals=TRACE_DECIMALS,
        )
    return record


def _baseline_actor(job: Job, demo: DemoEpisode):
    """(reset, act) of the hybrid or replay baseline following the re-anchored demonstration."""
    from lerobot_forcemap.envs.hybrid_control import HybridConfig, HybridForcePositionPolicy
    from lerobot_forcemap.envs.registration import task_spec

    anchor = task_spec(job.task).anchor  # the object the demonstration is re-anchored to
    state: dict[str, Any] = {}

    def reset(obs: dict) -> None:
        actions = reanchor_actions(demo, np.asarray(obs[layout.ENV_STATE], dtype=np.float64), anchor)
        state["actions"] = actions
        state["step"] = 0
        if job.kind == "hybrid":
            cfg = dict(job.hybrid)
            if "normal" in cfg and cfg["normal"] is not None:
                cfg["normal"] = tuple(cfg["normal"])
            state["policy"] = HybridForcePositionPolicy(actions, HybridConfig(**cfg))

    def act(obs: dict) -> np.ndarray:
        if job.kind == "hybrid":
            return state["policy"].act(obs)
        a = state["actions"][min(state["step"], len(state["actions"]) - 1)]
        state["step"] += 1
        return a

    return reset, act


def fit_key(job: Job) -> str:
    """Checkpoint id of a job's fit: task, demonstration, dataset and overrides (not the seeds or the
    env kwargs), so jobs that differ only in evaluation share one fit."""
    spec = {"dataset": job.spec()["dataset"], "demo": job.demo, "overrides": list(job.overrides)}
    digest = hashlib.sha1(json.dumps(spec, sort_keys=True).encode()).hexdigest()[:12]
    return f"{job.task}__d{job.demo}__{digest}"


def fitted_checkpoint(job: Job, workdir: str | Path, *, force: bool = False) -> tuple[Path, dict[str, Any]]:
    """Fit (or reuse) the job's one-shot checkpoint under ``workdir/checkpoints/<fingerprint>/<fit_key>``;
    returns (path, fit info). The fit is written to a temporary folder and renamed, so parallel workers
    that race on the same fit leave one complete checkpoint."""
    import os
    import shutil

    from lerobot_forcemap.cli.fit import fit_policy

    ckpt = Path(workdir) / "checkpoints" / code_fingerprint() / fit_key(job)
    info_file = ckpt / "fit_info.json"
    if info_file.is_file() and not force:
        return ckpt, json.loads(info_file.read_text())
    tmp = ckpt.with_name(f"{ckpt.name}.tmp{os.getpid()}")
    result = fit_policy(job.dataset_path, tmp, episodes=[job.demo], overrides=job.overrides, overwrite=True)
    fit = _fit_info(result, job.demo, ckpt)
    (tmp / "fit_info.json").write_text(json.dumps(fit))
    if info_file.is_file() and not force:  # another worker finished first; it may be loading that copy
        shutil.rmtree(tmp, ignore_errors=True)
        return ckpt, json.loads(info_file.read_text())
    if ckpt.exists():  # an incomplete folder, or the fit being replaced (force)
        shutil.rmtree(ckpt, ignore_errors=True)
    try:
        tmp.rename(ckpt)
    except OSError:  # another worker renamed its copy first: keep that one
        shutil.rmtree(tmp, ignore_errors=True)
    return ckpt, fit


def _fit_info(result, demo: int, ckpt: Path) -> dict[str, Any]:
    """What the experiments keep of a fit: its time, segments, changepoints and force-limit rows."""
    from lerobot_forcemap.skill.fit import segmentation_config

    report = result.policy.fit_report
    rows = report.summary()
    cfg = result.policy.config
    return {
        "fit_s": result.fit_s,
        "demo": demo,
        "n_segments": len(rows),
        # frames of the demonstration where its segments start (0 and T included), and the window they
        # were found with: scored against the demonstrator's phase switches (demos.segmentation_score)
        "changepoints": [int(c) for c in report.changepoints[0]],
        "segmentation_window_frames": segmentation_config(cfg.skill_params(), cfg.fps).window,
        "segments": to_json(rows),
        "n_force_limit_rows": int(sum(a.n_force_limit_rows for a in report.arm_fits)),
        "checkpoint": str(ckpt),
    }


def run_job(job: Job, workdir: str | Path, *, progress: bool = False) -> dict[str, Any]:
    """Run one job (module docstring); returns ``{"job", "key", "records", "fit", "wall_s", "cpu_s"}``
    (``cpu_s``: this process's CPU time for the job, fit included)."""
    import logging

    from tqdm.auto import tqdm

    from lerobot_forcemap.envs import make
    from lerobot_forcemap.evaluation.evaluate import lerobot_actor, load_policy

    logging.getLogger("lerobot.utils.import_utils").setLevel(logging.ERROR)
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    fit: dict[str, Any] = {}
    env = make(job.task, render_mode=None, **dict(job.env_kwargs))
    try:
        if job.kind == "forcemap":
            ckpt, fit = fitted_checkpoint(job, workdir)
            reset, act = lerobot_actor(*load_policy(ckpt), env.unwrapped.task_description)
        else:
            reset, act = _baseline_actor(job, load_demo_episode(job.dataset_path, job.demo))
        records = []
        for i, seed in enumerate(tqdm(job.seeds, desc=job.key()[:40], disable=not progress, leave=False)):
            records.append(run_episode(env, reset, act, seed, trace=job.trace_first and i == 0))
            records[-1]["demo"] = job.demo
    finally:
        env.close()
    return {
        "job": job.spec(),
        "key": job.key(),
        "records": records,
        "fit": fit,
        "wall_s": time.perf_counter() - t0,
        "cpu_s": time.process_time() - cpu0,
    }
