"""The paper's experiments as jobs on fixed seeds, run by an executor with a record cache.

A :class:`Job` is one method reproducing one demonstration of one task on a list of env seeds
(``rollouts.run_job`` says what it computes). :func:`run_jobs` runs jobs on a
:mod:`lerobot_forcemap.executor` (this process, a process pool, or Ray) and caches each job's result as
``workdir/raw/<code fingerprint>/<job key>.json``: the fingerprint (:func:`code_fingerprint`) hashes
the code and data a record depends on, so a change to any of them re-runs the jobs instead of reusing
stale numbers; :func:`prune_stale_caches` removes the caches of other code versions. The cache earns
its keep: a full run takes minutes of rollouts while the report, tables and analysis built from the
records re-run in seconds, and tuning, the tables and the ablations share jobs (each runs once). On
Ray, ``workdir`` must be a folder every node can reach.
"""

from __future__ import annotations

import functools
import hashlib
import json
import re
from collections.abc import Iterable
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Any

from lerobot_forcemap._validation import check_choice, check_int, check_int_list
from lerobot_forcemap.executor import Executor

__all__ = [
    "EVAL_SEEDS",
    "TUNE_SEEDS",
    "Job",
    "JobStats",
    "run_jobs",
    "code_fingerprint",
    "prune_stale_caches",
]

#: evaluation seeds of every reported cell (n = 20)
EVAL_SEEDS: tuple[int, ...] = tuple(range(1000, 1020))
#: seeds used only for choosing settings (never reported as results)
TUNE_SEEDS: tuple[int, ...] = (2000, 2001)
REPO_ROOT = Path(__file__).resolve().parents[2]
#: version of the cached job results (part of the cache fingerprint): bump it when what a cached result
#: holds changes without a change to the fingerprinted files
RECORD_VERSION = 3


# ---- jobs -------------------------------------------------------------------------------------------------


#: what a job runs (``rollouts.py``)
KINDS = ("forcemap", "hybrid", "replay")


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
        check_choice("Job.kind", self.kind, KINDS)
        check_int_list("Job.seeds", self.seeds)
        check_int("Job.demo", self.demo, low=0)

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


#: what a cached record depends on besides the datasets: the policy, the library (floor-0 modules, the
#: math core, the skill, data and envs, the compiled loops' sources), the fit, the evaluation's records
#: and actor, the jobs themselves
FINGERPRINTED_CODE = (
    "lerobot_policy_forcemap/*.py",
    "lerobot_forcemap/*.py",
    "lerobot_forcemap/**/*.c",
    "lerobot_forcemap/elmap/**/*.py",
    "lerobot_forcemap/segmentation/**/*.py",
    "lerobot_forcemap/skill/**/*.py",
    "lerobot_forcemap/contact/**/*.py",
    "lerobot_forcemap/data/**/*.py",
    "lerobot_forcemap/envs/**/*.py",
    "lerobot_forcemap/envs/**/*.xml",
    "lerobot_forcemap/cli/fit.py",
    "lerobot_forcemap/evaluation/records.py",
    "lerobot_forcemap/evaluation/evaluate.py",
    "experiments/paper/rollouts.py",
    "experiments/paper/demos.py",
    "datasets/*/meta/*.json",
)


@functools.lru_cache(maxsize=1)
def code_fingerprint() -> str:
    """Hash (10 hex digits) of the files :data:`FINGERPRINTED_CODE` names, the shipped datasets' data
    file sizes and :data:`RECORD_VERSION`. Cached results live under ``raw/<fingerprint>/``, so a
    change to any of them re-runs the jobs instead of reusing stale numbers."""
    root = REPO_ROOT
    files = sorted({p for pattern in FINGERPRINTED_CODE for p in root.glob(pattern)})
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
    """One job's result: read from the cache, else run and cached (written whole, then renamed)."""
    job, workdir, force = args
    path = Path(workdir) / "raw" / code_fingerprint() / f"{job.key()}.json"
    if path.is_file() and not force:
        try:
            out = json.loads(path.read_text())
            out["cached"] = True
            return out
        except json.JSONDecodeError:
            pass
    from experiments.paper.rollouts import run_job

    out = run_job(job, workdir)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    tmp.write_text(json.dumps(out))
    tmp.replace(path)
    out["cached"] = False
    return out


@dataclass
class JobStats:
    """What :func:`run_jobs` did: jobs returned (cached ones included), cached ones, and the CPU time
    (s) of the jobs that ran, summed over the workers."""

    n_jobs: int = 0
    n_cached: int = 0
    cpu_s: float = 0.0


def run_jobs(
    jobs: Iterable[Job],
    workdir: str | Path,
    executor: Executor,
    *,
    force: bool = False,
    desc: str = "jobs",
    stats: JobStats | None = None,
) -> list[dict[str, Any]]:
    """Run ``jobs`` on ``executor`` (cached as ``workdir/raw/<code fingerprint>/<key>.json``; ``force``
    re-runs the episodes); results in the order of ``jobs``, duplicated jobs run once. A tqdm bar
    counts episodes; ``stats`` (if given) adds up what ran."""
    jobs = list(jobs)
    unique: dict[str, Job] = {}
    for j in jobs:
        unique.setdefault(j.key(), j)
    args = [(job, str(workdir), force) for job in unique.values()]
    results = executor.map(
        _run_job_cached, args, desc=desc, unit="ep", weights=[len(a[0].seeds) for a in args]
    )
    done = dict(zip(unique, results, strict=True))
    if stats is not None:
        for out in results:
            stats.n_jobs += 1
            if out.get("cached"):
                stats.n_cached += 1
            else:
                stats.cpu_s += float(out.get("cpu_s") or 0.0)
    return [done[j.key()] for j in jobs]
