"""The paper's experiments (§IV, Tables II–III, grasping) as jobs on fixed seeds, and their statistics.

A :class:`Job` is one method reproducing one demonstration of one task on a list of env seeds:

- ``kind="forcemap"``: fit the forcemap policy one-shot from ``demo`` (``fit_policy`` with the job's
  ``--set`` overrides, the code path of ``lerobot-train --policy.type=forcemap --steps=1``), save the
  checkpoint, load it back as ``lerobot-eval`` does and roll it out;
- ``kind="hybrid"``: the paper's control baseline, ``HybridForcePositionPolicy`` following the same
  demonstration's actions, re-anchored rigidly to the task object's pose in the new scene;
- ``kind="replay"``: the same re-anchored actions open loop (what the demonstrator did, moved to the
  new scene).

:func:`run_job` returns the per-episode records (the fields of ``forcemap eval``: success, protective
stop, max / mean contact force norm and per axis, plus per-finger forces on the grasping tasks) and
the fit diagnostics. Episodes of every method go through one loop (:func:`run_episode`) so their
records are computed identically.

Statistics: :func:`summarize_records` (n, success rate with a Wilson 95 % interval, protective
stops, mean / std / 95 % interval of every force figure), :func:`demo_change` (per-demonstration %
change of a force figure, reproduction vs its own demonstration, with the spread over demonstrations).

Pure orchestration: no numerics beyond statistics; the policy, envs and baseline are used as shipped.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import re
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from lerobot_forcemap import layout
from lerobot_forcemap.evaluation.evaluate import FORCE_KEYS, episode_outcome, to_json

__all__ = [
    "EVAL_SEEDS",
    "TUNE_SEEDS",
    "FORCE_KEYS",
    "FINGER_KEYS",
    "Job",
    "DemoEpisode",
    "load_demo_episode",
    "demo_force_records",
    "reanchor_actions",
    "run_episode",
    "run_job",
    "run_jobs",
    "JobRunner",
    "code_fingerprint",
    "fit_key",
    "fitted_checkpoint",
    "wilson_interval",
    "sample_stats",
    "summarize_records",
    "force_by_gripper_phase",
    "demo_change",
]

#: evaluation seeds of every reported cell (n = 20)
EVAL_SEEDS: tuple[int, ...] = tuple(range(1000, 1020))
#: seeds used only for choosing settings (never reported as results)
TUNE_SEEDS: tuple[int, ...] = (2000, 2001)
FINGER_KEYS = ("max_finger_force", "mean_finger_force")
REPO_ROOT = Path(__file__).resolve().parents[2]
#: version of the episode records and of the episode loop (part of the cache fingerprint)
RECORD_VERSION = 2

Array = NDArray[np.float64]


# ---- jobs -------------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Job:
    """One method, one demonstration, one task, a list of env seeds.

    method: the row label (e.g. ``ours``); kind: ``forcemap`` | ``hybrid`` | ``replay``;
    overrides: ``ForceMapConfig`` fields as ``FIELD=VALUE`` (``forcemap fit --set``);
    hybrid: ``HybridConfig`` keyword arguments as (name, value) pairs; env_kwargs: extra ``gym.make``
    kwargs (e.g. ``(("object", "apple"),)``); trace_first: store a per-step trace of the first episode;
    dataset: the demonstration dataset (default ``datasets/<task>``).
    """

    task: str
    method: str
    kind: str
    demo: int
    seeds: tuple[int, ...]
    overrides: tuple[str, ...] = ()
    hybrid: tuple[tuple[str, Any], ...] = ()
    env_kwargs: tuple[tuple[str, Any], ...] = ()
    trace_first: bool = False
    dataset: str = ""

    def __post_init__(self) -> None:
        if self.kind not in ("forcemap", "hybrid", "replay"):
            raise ValueError(f"Job.kind: expected forcemap, hybrid or replay, got {self.kind!r}")
        if not self.seeds:
            raise ValueError(f"Job {self.task}/{self.method}/demo {self.demo}: no seeds")
        if self.demo < 0:
            raise ValueError(f"Job.demo: must be >= 0, got {self.demo}")

    @property
    def dataset_path(self) -> Path:
        return Path(self.dataset) if self.dataset else REPO_ROOT / "datasets" / self.task

    def spec(self) -> dict[str, Any]:
        """JSON-able description (what the key hashes)."""
        d = asdict(self)
        d["seeds"] = list(self.seeds)
        d["overrides"] = list(self.overrides)
        d["hybrid"] = {k: v for k, v in self.hybrid}
        d["env_kwargs"] = {k: v for k, v in self.env_kwargs}
        d["dataset"] = str(
            self.dataset_path.relative_to(REPO_ROOT)
            if self.dataset_path.is_relative_to(REPO_ROOT)
            else self.dataset_path
        )
        return d

    def key(self) -> str:
        """A file-name-safe id: readable prefix + hash of the full spec."""
        digest = hashlib.sha1(json.dumps(self.spec(), sort_keys=True, default=str).encode()).hexdigest()[:10]
        env = "_".join(str(v) for _, v in self.env_kwargs)
        return f"{self.task}__{self.method}{'__' + env if env else ''}__d{self.demo}__{digest}"


# ---- demonstrations ----------------------------------------------------------------------------------------


@dataclass(frozen=True)
class DemoEpisode:
    """One recorded demonstration: actions (T, 8), environment state (T, E) with its names, fps."""

    episode: int
    actions: Array
    env_state: Array
    state_names: tuple[str, ...]
    fps: float


def _read_columns(meta: Any, keys: Sequence[str]) -> dict[str, np.ndarray]:
    """The ``keys`` columns of every episode as float64 ``(rows, width)``."""
    from lerobot_forcemap.data.reader import read_columns

    cols = read_columns(meta, list(range(meta.total_episodes)), keys)
    return {k: np.asarray(v, dtype=np.float64).reshape(len(v), -1) for k, v in cols.items()}


def load_demo_episode(dataset: str | Path, episode: int) -> DemoEpisode:
    """Actions and environment state of one episode of a LeRobot v3 dataset (read with pyarrow)."""
    from lerobot_forcemap.data.reader import read_meta

    root = Path(dataset)
    meta = read_meta(root)
    features = meta.features
    for key in (layout.ACTION, layout.OBS_ENV_STATE):
        if key not in features:
            raise ValueError(f"{root}: feature {key!r} missing (needed to replay a demonstration)")
    cols = _read_columns(meta, [layout.ACTION, layout.OBS_ENV_STATE, "episode_index", "frame_index"])
    rows = np.flatnonzero(cols["episode_index"][:, 0].astype(int) == int(episode))
    if len(rows) == 0:
        have = sorted(set(cols["episode_index"][:, 0].astype(int).tolist()))
        raise ValueError(f"{root}: episode {episode} not in the dataset (episodes {have})")
    rows = rows[np.argsort(cols["frame_index"][rows, 0], kind="stable")]
    return DemoEpisode(
        episode=int(episode),
        actions=cols[layout.ACTION][rows],
        env_state=cols[layout.OBS_ENV_STATE][rows],
        state_names=tuple(features[layout.OBS_ENV_STATE].get("names") or ()),
        fps=float(meta.fps),
    )


def demo_force_records(dataset: str | Path) -> list[dict[str, Any]]:
    """Per-demonstration env statistics from ``meta/forcemap_episodes.json`` (the recorder's, at physics
    rate, comparable to evaluation records): success, protective stop, force figures, finger forces."""
    path = Path(dataset) / "meta" / "forcemap_episodes.json"
    if not path.is_file():
        raise ValueError(
            f"{dataset}: no meta/forcemap_episodes.json (record the dataset with `forcemap record`)"
        )
    out = []
    for i, ep in enumerate(json.loads(path.read_text())["episodes"]):
        rec = {
            "episode": i,
            "seed": ep.get("seed"),
            "success": bool(ep.get("is_success", True)),
            "protective_stop": bool(ep.get("protective_stop", False)),
        }
        for k in (*FORCE_KEYS, *FINGER_KEYS):
            if k in ep:
                rec[k] = ep[k]
        if "object" in ep:
            rec["object"] = ep["object"]
        out.append(rec)
    return out


def demo_phase_switches(dataset: str | Path) -> dict[int, Array]:
    """Per episode, the frames where the scripted demonstrator's phase (``demo_phase``) changes: the
    reference events for scoring segmentation in simulation (SPEC §2). ``{}`` without that column."""
    from lerobot_forcemap.data.reader import read_meta

    meta = read_meta(dataset)
    if layout.DEMO_PHASE not in meta.features:
        return {}
    cols = _read_columns(meta, [layout.DEMO_PHASE, "episode_index", "frame_index"])
    episode = cols["episode_index"][:, 0].astype(int)
    out = {}
    for e in np.unique(episode):
        rows = np.flatnonzero(episode == e)
        rows = rows[np.argsort(cols["frame_index"][rows, 0], kind="stable")]
        out[int(e)] = np.flatnonzero(np.diff(cols[layout.DEMO_PHASE][rows, 0])) + 1
    return out


def segmentation_score(
    fits: Sequence[Mapping[str, Any]], switches: Mapping[int, Array]
) -> dict[str, Any] | None:
    """Changepoint precision, recall and F1 of one-shot fits (:func:`fitted_checkpoint`'s records)
    against their demonstrations' phase switches, pooled over the fits; tolerance: the segmentation
    window. Segment counts say nothing about quality (SPEC §2). None if no fit can be scored."""
    from lerobot_forcemap.segmentation.evaluation import pooled_score, score_changepoints

    scored = [f for f in fits if "changepoints" in f and f.get("demo") in switches]
    if not scored:
        return None
    precision, recall, f1 = pooled_score(
        score_changepoints(
            f["changepoints"][1:-1], switches[f["demo"]], tolerance=f["segmentation_window_frames"]
        )
        for f in scored
    )
    return {
        "precision": precision,
        "recall": recall,
        "f1": f1,
        "n_fits": len(scored),
        "tolerance_frames": sorted({int(f["segmentation_window_frames"]) for f in scored}),
    }


def reanchor_actions(demo: DemoEpisode, env_state_now: Array, anchor: str) -> Array:
    """The demonstration's actions moved rigidly with object ``anchor``: from its pose at the
    demonstration's first frame to its pose in ``env_state_now (E,)``. Returns (T, 8)."""
    from lerobot_forcemap.skill.placement import (
        from_object_frame,
        object_poses,
        object_slots,
        to_object_frame,
    )

    slots = [s for s in object_slots(demo.state_names) if s.name == anchor]
    if not slots:
        raise ValueError(
            f"reanchor_actions: object {anchor!r} not in the environment state {list(demo.state_names)}"
        )
    before = object_poses(demo.env_state[0], slots)[anchor]
    now = object_poses(env_state_now, slots)[anchor]
    a = demo.actions
    p, _, q = to_object_frame(before, a[:, layout.ACTION_POS], None, a[:, layout.ACTION_QUAT])
    p, q = from_object_frame(now, p, q)
    out = a.copy()
    out[:, layout.ACTION_POS] = p
    out[:, layout.ACTION_QUAT] = q
    return out


# ---- episodes ----------------------------------------------------------------------------------------------


TRACE_COLUMNS = ("t", "fx", "fy", "fz", "x", "y", "z", "target_x", "target_y", "target_z", "gripper")


def run_episode(
    env, reset: Callable[[dict], None], act: Callable[[dict], np.ndarray], seed: int, *, trace: bool = False
) -> dict[str, Any]:
    """One episode: ``reset(obs)`` after ``env.reset(seed=seed)``, then ``act(obs) -> action (8,)``
    until the episode ends. Returns the record (fields of ``forcemap eval`` + per-finger forces)."""
    from lerobot_forcemap.envs.rollout import Step
    from lerobot_forcemap.envs.rollout import run_episode as run_env_episode

    base = env.unwrapped

    def act64(obs: dict) -> np.ndarray:
        return np.asarray(act(obs), dtype=np.float64).reshape(-1)

    def sample(step: Step) -> tuple[np.ndarray, float, list[float] | None]:
        """The contact force after the step (20 Hz samples of the filtered force), the gripper command
        of the step, and the trace row."""
        a = step.action
        row = None
        if trace:
            t = step.index / base.metadata["render_fps"]
            row = [t, *step.info["contact_force"], *step.obs[layout.ENV_EE_POSE][:3], *a[:3], a[7]]
        force = np.asarray(step.next_info["contact_force"], dtype=np.float64)
        return force, float(a[layout.ACTION_GRIPPER]), row

    episode = run_env_episode(env, act64, seed, reset=reset, trace=sample)
    info, obs = episode.info, episode.obs
    forces = [s[0] for s in episode.trace]
    grips = [s[1] for s in episode.trace]
    record = episode_outcome(episode)
    for k in (*FORCE_KEYS, *FINGER_KEYS):
        if k in info:
            record[k] = to_json(info[k])
    record["force_by_gripper_phase"] = force_by_gripper_phase(np.asarray(forces), np.asarray(grips))
    skip = {"is_success", "protective_stop", "termination_reason", "contact_force", *FORCE_KEYS, *FINGER_KEYS}
    record["metrics"] = {
        k: to_json(v)
        for k, v in info.items()
        if k not in skip and not k.startswith("clip_") and np.ndim(v) == 0
    }
    if trace:
        record["trace"] = {
            "columns": list(TRACE_COLUMNS),
            "rows": to_json(np.round(np.asarray([s[2] for s in episode.trace]), 5)),
            "environment_state": to_json(obs[layout.ENV_STATE]) if layout.ENV_STATE in obs else None,
            "environment_state_names": list(base.state_names.get(layout.ENV_STATE, ())),
        }
    return record


GRIPPER_PHASES = ("closed", "moving", "open")


def force_by_gripper_phase(forces: Array, gripper: Array) -> dict[str, Any]:
    """Max |F| per axis ``(3,)`` and step count by gripper-command phase: ``closed`` (command >= 0.95),
    ``moving`` (between), ``open`` (<= 0.05), from the per-step contact force ``forces (T, 3)`` (20 Hz
    samples of the filtered force, so maxima can read below the physics-rate ``max_contact_force_xyz``)
    and the commands ``gripper (T,)``. Says in which phase a force peak happened (e.g. during a release)."""
    forces = np.asarray(forces, dtype=np.float64).reshape(-1, 3)
    g = np.asarray(gripper, dtype=np.float64).reshape(-1)
    if len(forces) != len(g):
        raise ValueError(f"force_by_gripper_phase: {len(forces)} force samples for {len(g)} gripper commands")
    masks = {"closed": g >= 0.95, "open": g <= 0.05}
    masks["moving"] = ~(masks["closed"] | masks["open"])
    out = {}
    for name in GRIPPER_PHASES:
        m = masks[name]
        out[name] = {
            "steps": int(m.sum()),
            "max_xyz": to_json(np.abs(forces[m]).max(axis=0)) if m.any() else [0.0, 0.0, 0.0],
        }
    return out


def _lerobot_actor(policy, pre, post, task_description: str):
    """(reset, act) closures running a LeRobot policy the way ``lerobot-eval`` does."""
    import torch
    from lerobot.envs.utils import preprocess_observation

    def reset(obs: dict) -> None:
        policy.reset()

    def act(obs: dict) -> np.ndarray:
        batch = preprocess_observation(obs)
        batch["task"] = [task_description]
        batch = pre(batch)
        with torch.inference_mode():
            action = policy.select_action(batch)
        return post(action).detach().cpu().numpy().reshape(-1)

    return reset, act


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
    """Fit (or reuse) the job's one-shot checkpoint under ``workdir/checkpoints/<fit_key>``; returns
    (path, fit info). The fit is written to a temporary folder and renamed, so parallel workers that
    race on the same fit leave one complete checkpoint."""
    import os
    import shutil

    from lerobot_forcemap.cli.fit import fit_policy
    from lerobot_forcemap.skill.fit import segmentation_config

    ckpt = Path(workdir) / "checkpoints" / code_fingerprint() / fit_key(job)
    info_file = ckpt / "fit_info.json"
    if info_file.is_file() and not force:
        return ckpt, json.loads(info_file.read_text())
    tmp = ckpt.with_name(f"{ckpt.name}.tmp{os.getpid()}")
    result = fit_policy(job.dataset_path, tmp, episodes=[job.demo], overrides=job.overrides, overwrite=True)
    report = result.policy.fit_report
    rows = report.summary()
    cfg = result.policy.config
    fit = {
        "fit_s": result.fit_s,
        "demo": job.demo,
        "n_segments": len(rows),
        # frames of the demonstration where its segments start (0 and T included), and the window they
        # were found with: scored against the demonstrator's phase switches (segmentation_score)
        "changepoints": [int(c) for c in report.changepoints[0]],
        "segmentation_window_frames": segmentation_config(cfg.skill_params(), cfg.fps).window,
        "segments": to_json(rows),
        "n_force_limit_rows": int(sum(a.n_force_limit_rows for a in report.arm_fits)),
        "checkpoint": str(ckpt),
    }
    (tmp / "fit_info.json").write_text(json.dumps(fit))
    if ckpt.exists():
        shutil.rmtree(ckpt, ignore_errors=True)
    try:
        tmp.rename(ckpt)
    except OSError:  # another worker renamed its copy first: keep that one
        shutil.rmtree(tmp, ignore_errors=True)
    return ckpt, fit


def run_job(job: Job, workdir: str | Path, *, progress: bool = False) -> dict[str, Any]:
    """Run one job (module docstring); returns ``{"job", "key", "records", "fit", "wall_s", "cpu_s"}``
    (``cpu_s``: this process's CPU time for the job, fit included)."""
    import logging

    from tqdm.auto import tqdm

    from lerobot_forcemap.envs import make

    logging.getLogger("lerobot.utils.import_utils").setLevel(logging.ERROR)
    t0 = time.perf_counter()
    cpu0 = time.process_time()
    fit: dict[str, Any] = {}
    env = make(job.task, render_mode=None, **dict(job.env_kwargs))
    try:
        if job.kind == "forcemap":
            from lerobot_forcemap.evaluation.evaluate import load_policy

            ckpt, fit = fitted_checkpoint(job, workdir)
            policy, pre, post = load_policy(ckpt)
            reset, act = _lerobot_actor(policy, pre, post, env.unwrapped.task_description)
        else:
            demo = load_demo_episode(job.dataset_path, job.demo)
            reset, act = _baseline_actor(job, demo)
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


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """Hash of the code and data a result depends on: the policy, the library floors it uses (elmap,
    segmentation, data, envs, layout, geometry), the fit module, the shipped datasets (file sizes and
    meta) and :data:`RECORD_VERSION` (bump it when this module changes what a record holds). Cached runs
    live under ``raw/<fingerprint>/``, so a change to any of them re-runs the jobs instead of reusing
    stale numbers."""
    root = REPO_ROOT
    files = sorted(
        [
            *root.glob("lerobot_policy_forcemap/*.py"),
            *[
                p
                for d in ("elmap", "segmentation", "data", "envs")
                for p in (root / "lerobot_forcemap" / d).rglob("*.py")
            ],
            *[p for d in ("envs",) for p in (root / "lerobot_forcemap" / d).rglob("*.xml")],
            root / "lerobot_forcemap" / "layout.py",
            root / "lerobot_forcemap" / "geometry.py",
            root / "lerobot_forcemap" / "experiments" / "fit.py",
            *root.glob("datasets/*/meta/*.json"),
        ]
    )
    h = hashlib.sha1(f"records v{RECORD_VERSION}".encode())
    for f in files:
        if f.is_file():
            h.update(str(f.relative_to(root)).encode())
            h.update(f.read_bytes())
    for f in sorted(root.glob("datasets/*/data/*/*.parquet")):
        h.update(f"{f.relative_to(root)}:{f.stat().st_size}".encode())
    return h.hexdigest()[:10]


def prune_stale_caches(workdir: str | Path, keep: str | None = None) -> tuple[list[Path], int]:
    """Remove ``workdir/{raw,checkpoints}/<fingerprint>`` folders of every code version but ``keep``
    (default: this one's): no later run can reuse them, and each holds tens of MB. Returns the removed
    folders and the bytes they held. Only folder names shaped like a fingerprint are touched."""
    import shutil

    keep = code_fingerprint() if keep is None else keep
    removed, size = [], 0
    for kind in ("raw", "checkpoints"):
        base = Path(workdir) / kind
        if not base.is_dir():
            continue
        for d in sorted(base.iterdir()):
            if d.is_dir() and d.name != keep and re.fullmatch(r"[0-9a-f]{10}", d.name):
                size += sum(f.stat().st_size for f in d.rglob("*") if f.is_file())
                shutil.rmtree(d)
                removed.append(d)
    return removed, size


def _run_job_cached(args: tuple[Job, str, bool]) -> dict[str, Any]:
    job, workdir, force = args
    path = Path(workdir) / "raw" / code_fingerprint() / f"{job.key()}.json"
    if path.is_file() and not force:
        try:
            out = json.loads(path.read_text())
            out["cached"] = True
            return out
        except json.JSONDecodeError:
            pass
    out = run_job(job, workdir)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(out))
    tmp.replace(path)
    out["cached"] = False
    return out


def _worker_init() -> None:
    import os

    for k in ("OPENBLAS_NUM_THREADS", "OMP_NUM_THREADS", "MKL_NUM_THREADS"):
        os.environ.setdefault(k, "1")
    os.environ.setdefault("MUJOCO_GL", "egl")
    os.environ.setdefault("HF_HUB_OFFLINE", "1")
    try:
        import torch

        torch.set_num_threads(1)
    except ImportError:  # pragma: no cover
        pass


class JobRunner:
    """Runs jobs in ``workers`` processes (spawned once, reused across calls; ``workers <= 1`` runs in
    this process). Use as a context manager, or call :meth:`close`."""

    def __init__(self, workers: int = 1):
        self.workers = int(workers)
        self._pool = None
        self.n_jobs = 0  # jobs returned by run() so far, cached ones included
        self.n_cached = 0
        self.cpu_s = 0.0  # CPU time of the jobs that ran (not cached), summed over the processes

    def __enter__(self) -> JobRunner:
        return self

    def __exit__(self, *exc) -> None:
        self.close()

    def close(self) -> None:
        if self._pool is not None:
            self._pool.close()
            self._pool.join()
            self._pool = None

    def _get_pool(self):
        if self._pool is None:
            import multiprocessing as mp

            self._pool = mp.get_context("spawn").Pool(self.workers, initializer=_worker_init)
        return self._pool

    def run(
        self, jobs: Iterable[Job], workdir: str | Path, *, force: bool = False, desc: str = "jobs"
    ) -> list[dict[str, Any]]:
        """Run jobs (cached as ``workdir/raw/<code fingerprint>/<key>.json``; ``force`` re-runs the
        episodes); results in the order of ``jobs``. A tqdm bar counts episodes; duplicated jobs run once."""
        from tqdm.auto import tqdm

        jobs = list(jobs)
        unique: dict[str, Job] = {}
        for j in jobs:
            unique.setdefault(j.key(), j)
        order = list(unique)
        args = [(unique[k], str(workdir), force) for k in order]
        done: dict[str, dict[str, Any]] = {}
        total = sum(len(j.seeds) for j in unique.values())
        with tqdm(total=total, desc=desc, unit="ep") as bar:
            if self.workers <= 1:
                _worker_init()
                for k, a in zip(order, args, strict=True):
                    done[k] = _run_job_cached(a)
                    bar.update(len(a[0].seeds))
            else:
                for i, out in self._get_pool().imap_unordered(_indexed, list(enumerate(args)), chunksize=1):
                    done[order[i]] = out
                    bar.update(len(args[i][0].seeds))
        for out in done.values():
            self.n_jobs += 1
            if out.get("cached"):
                self.n_cached += 1
            else:
                self.cpu_s += float(out.get("cpu_s") or 0.0)
        return [done[j.key()] for j in jobs]


def run_jobs(
    jobs: Iterable[Job],
    workdir: str | Path,
    *,
    workers: int = 1,
    force: bool = False,
    desc: str = "jobs",
    runner: JobRunner | None = None,
) -> list[dict[str, Any]]:
    """:meth:`JobRunner.run` with ``runner`` (kept open by the caller) or a runner of ``workers`` made
    for this call."""
    if runner is not None:
        return runner.run(jobs, workdir, force=force, desc=desc)
    with JobRunner(workers) as r:
        return r.run(jobs, workdir, force=force, desc=desc)


def _indexed(item: tuple[int, tuple[Job, str, bool]]) -> tuple[int, dict[str, Any]]:
    i, a = item
    return i, _run_job_cached(a)


# ---- statistics ----------------------------------------------------------------------------------------------


def wilson_interval(successes: float, n: int, z: float = 1.959964) -> tuple[float, float]:
    """Wilson score 95 % interval of a success rate (k of n, k may be a sum of rates); (0, 1) when n = 0."""
    if n <= 0:
        return 0.0, 1.0
    p = successes / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / den
    return max(0.0, centre - half), min(1.0, centre + half)


def _t95(df: int) -> float:
    """Two-sided 95 % Student-t quantile."""
    if df <= 0:
        return float("nan")
    from scipy.stats import t

    return float(t.ppf(0.975, df))


def sample_stats(values: Array) -> dict[str, Any]:
    """``{mean, std (ddof 1; 0 for one value), ci95 (t half-width; NaN for one value), min, max}`` over the
    first axis of ``values`` (per column for vectors), as plain JSON numbers."""
    v = np.asarray(values, dtype=np.float64)
    n = len(v)
    mean = v.mean(axis=0)
    std = v.std(axis=0, ddof=1) if n > 1 else np.zeros_like(mean)
    half = _t95(n - 1) * std / math.sqrt(n) if n > 1 else np.full_like(mean, np.nan)
    return to_json({"mean": mean, "std": std, "ci95": half, "min": v.min(axis=0), "max": v.max(axis=0)})


def success_interval(records: Sequence[Mapping[str, Any]]) -> tuple[tuple[float, float], str, int]:
    """Wilson 95 % interval of the success rate, its unit and the number of units.

    Episodes of one demonstration's policy are not independent (it re-anchors to the object, so its
    outcome hardly changes with the seed): when a demonstration ran several episodes, the unit is
    the demonstration, with its success rate over its episodes (Wilson on the sum of the rates out of
    the number of demonstrations). Otherwise each episode is a unit.
    """
    demos = [r.get("demo") for r in records]
    if all(d is not None for d in demos) and len(set(demos)) < len(records):
        by_demo: dict[Any, list[bool]] = {}
        for d, r in zip(demos, records, strict=True):
            by_demo.setdefault(d, []).append(bool(r["success"]))
        rates = [float(np.mean(v)) for v in by_demo.values()]
        return wilson_interval(sum(rates), len(rates)), "demonstration", len(rates)
    k = sum(bool(r["success"]) for r in records)
    return wilson_interval(k, len(records)), "episode", len(records)


def summarize_records(records: Sequence[Mapping[str, Any]]) -> dict[str, Any]:
    """n, seeds, success rate (+ Wilson 95 % interval, see :func:`success_interval`), protective stops,
    and per force figure ``{mean, std (ddof 1), ci95 (half-width, t), min, max}`` over episodes (per
    axis / finger for vectors)."""
    if not records:
        return {"n": 0}
    n = len(records)
    k = int(sum(bool(r["success"]) for r in records))
    (lo, hi), unit, n_units = success_interval(records)
    out: dict[str, Any] = {
        "n": n,
        "seeds": sorted({int(r["seed"]) for r in records if r.get("seed") is not None}),
        "success_rate": k / n,
        "success_ci95": [lo, hi],
        "success_ci95_unit": unit,
        "success_ci95_n": n_units,
        "protective_stops": int(sum(bool(r.get("protective_stop")) for r in records)),
    }
    for key in (*FORCE_KEYS, *FINGER_KEYS):
        vals = [r[key] for r in records if key in r]
        if len(vals) == n:
            out[key] = sample_stats(vals)
    return out


def demo_change(
    records: Sequence[Mapping[str, Any]], demos: Sequence[Mapping[str, Any]], key: str
) -> dict[str, Any]:
    """% change of force figure ``key`` (a scalar one) of each reproduction vs its own demonstration.

    ``records`` carry ``demo`` (the episode they were learned from); ``demos`` are
    :func:`demo_force_records`. Per demonstration d: ``100 (mean_seeds(rep) / demo_d - 1)``; returns
    ``{"per_demo": {d: pct}, "mean", "std", "ci95", "min", "max", "n_demos", "pooled"}`` where pooled is
    ``100 (mean over all episodes / mean over the used demonstrations - 1)``.
    """
    by_demo: dict[int, list[float]] = {}
    for r in records:
        by_demo.setdefault(int(r["demo"]), []).append(float(r[key]))
    ref = {int(d["episode"]): float(d[key]) for d in demos}
    missing = sorted(set(by_demo) - set(ref))
    if missing:
        raise ValueError(f"demo_change: demonstrations {missing} have no {key!r} figure")
    per = {d: 100.0 * (np.mean(v) / ref[d] - 1.0) for d, v in sorted(by_demo.items()) if ref[d] > 0}
    vals = np.array(list(per.values()))
    if len(vals) == 0:
        return {"per_demo": {}, "n_demos": 0}
    rep_all = np.mean([float(r[key]) for r in records])
    demo_all = np.mean([ref[d] for d in by_demo])
    out = {
        "per_demo": {str(d): v for d, v in per.items()},
        "n_demos": len(vals),
        **sample_stats(vals),
        "pooled": float(100.0 * (rep_all / demo_all - 1.0)) if demo_all > 0 else float("nan"),
    }
    return out


def split_seeds(seeds: Sequence[int], demos: Sequence[int]) -> dict[int, tuple[int, ...]]:
    """Deal ``seeds`` round-robin over ``demos`` (episode i of the cell -> demo ``demos[i % len]``): n stays
    ``len(seeds)`` while every demonstration is used. E.g. 20 seeds over 10 demos: 2 seeds each."""
    if not demos:
        raise ValueError("split_seeds: no demos")
    out: dict[int, list[int]] = {int(d): [] for d in demos}
    for i, s in enumerate(seeds):
        out[int(demos[i % len(demos)])].append(int(s))
    return {d: tuple(v) for d, v in out.items() if v}


def auto_stream_weights(dataset: str | Path, episode: int, overrides: Sequence[str] = ()) -> dict[str, float]:
    """Label-free segmentation weights (``lerobot_forcemap.segmentation.auto_weights``: jerk contrast)
    of one demonstration's streams, as the policy builds them (window scaled to the dataset fps).
    Streams the dataset lacks get weight 0. Returns ``{stream: weight}`` for ``stream_weights``."""
    from lerobot_forcemap.cli.fit import make_config
    from lerobot_forcemap.segmentation import auto_weights
    from lerobot_forcemap.skill.fit import episode_streams, segmentation_config
    from lerobot_policy_forcemap.modeling_forcemap import load_episodes

    cfg = make_config([episode], overrides)
    root = Path(dataset)
    episodes, _, fps, _ = load_episodes(root, cfg)
    params = cfg.skill_params()
    streams = episode_streams(episodes[0], params)
    weights = auto_weights(streams, segmentation_config(params, fps))
    return {name: float(weights.get(name, 0.0)) for name in cfg.stream_weights}


__all__ += ["split_seeds", "TRACE_COLUMNS", "auto_stream_weights"]
