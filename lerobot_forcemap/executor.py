"""Run one function over many jobs: in this process, on a local process pool, or on Ray.

    with make_executor(workers=2) as ex:                 # a pool of 2 spawned processes
        results = ex.map(fit_one, episodes, desc="fit")  # in the order of ``episodes``
    with make_executor(ray=True, workers=4) as ex: ...   # a local Ray instance of 4 CPUs
    with make_executor(ray_address="auto") as ex: ...    # join a running Ray cluster

``fn`` and the jobs must be picklable (a module-level function; plain data), and a job's result may
depend only on the job itself (its seeds travel with it): then the results are the same whichever
executor runs them, and :meth:`Executor.map` returns them in the order of the jobs whatever order they
finish in. An exception raised by a job propagates from ``map`` (the other jobs' results are dropped):
a caller that must outlive a bad job catches inside ``fn`` and returns the failure as a result.

Workers run one BLAS / OpenMP / torch thread each (the jobs are small; several threads per worker only
fight for the cores). Ray is an optional extra (``pip install "lerobot_forcemap[ray]"``); asking for it
without it installed raises :class:`MissingRayError` with that line.
"""

from __future__ import annotations

import argparse
import os
from collections.abc import Callable, Iterable, Sequence
from typing import Any

from ._validation import check_int

__all__ = [
    "Executor",
    "MissingRayError",
    "RAY_INSTALL_HINT",
    "make_executor",
    "single_thread_env",
    "add_arguments",
    "from_args",
]

RAY_INSTALL_HINT = 'Ray is not installed: pip install "lerobot_forcemap[ray]"'

#: what each worker runs with (set before NumPy / torch load there): one thread per worker
_THREAD_ENV = {"OPENBLAS_NUM_THREADS": "1", "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}


#: tries at starting a local Ray instance (see :meth:`_RayExecutor._init`)
_LOCAL_START_ATTEMPTS = 3


class MissingRayError(ImportError):
    """Ray was asked for but is not installed; the message says how to install it (an ImportError:
    ``forcemap`` reports it as one error line, like every missing optional dependency)."""


def single_thread_env() -> dict[str, str]:
    """The thread settings every worker starts with: this process's values where set, else one thread."""
    return {name: os.environ.get(name, value) for name, value in _THREAD_ENV.items()}


def _worker_init() -> None:
    """One torch thread per worker, where torch is installed (NumPy's BLAS follows the environment)."""
    for name, value in single_thread_env().items():
        os.environ.setdefault(name, value)
    try:
        import torch
    except ImportError:
        return
    torch.set_num_threads(1)


class Executor:
    """Maps a function over jobs; results in the order of the jobs. Use as a context manager (or call
    :meth:`close`): a process pool is spawned on the first :meth:`map` and reused by later ones."""

    kind = "serial"

    def __init__(self, workers: int = 1):
        self.workers = workers

    def __enter__(self) -> Executor:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        """Release the workers (nothing to release in this process)."""

    def map(
        self,
        fn: Callable[[Any], Any],
        jobs: Iterable[Any],
        *,
        desc: str | None = None,
        weights: Sequence[int] | None = None,
        unit: str = "job",
        progress: bool = True,
    ) -> list[Any]:
        """``[fn(job) for job in jobs]``, run by this executor's workers. A tqdm bar (``desc``) counts
        the jobs, or ``weights[i]`` per finished job ``i`` (e.g. its episodes) when given."""
        from tqdm.auto import tqdm

        jobs = list(jobs)
        steps = [1] * len(jobs) if weights is None else list(weights)
        results: list[Any] = [None] * len(jobs)
        with tqdm(total=sum(steps), desc=desc, unit=unit, disable=not progress or not jobs) as bar:
            for i, result in self._run(fn, jobs):
                results[i] = result
                bar.update(steps[i])
        return results

    def _run(self, fn: Callable[[Any], Any], jobs: list[Any]) -> Iterable[tuple[int, Any]]:
        """``(index, result)`` pairs as the jobs finish."""
        _worker_init()
        for i, job in enumerate(jobs):
            yield i, fn(job)


class _PoolExecutor(Executor):
    """``workers`` spawned processes (a fresh interpreter each: no state forked from the caller)."""

    kind = "pool"

    def __init__(self, workers: int):
        super().__init__(workers)
        self._pool = None

    def close(self) -> None:
        if self._pool is not None:
            self._pool.shutdown()
            self._pool = None

    def _run(self, fn, jobs):
        import concurrent.futures as cf
        import multiprocessing as mp

        if self._pool is None:
            self._pool = cf.ProcessPoolExecutor(
                self.workers, mp_context=mp.get_context("spawn"), initializer=_worker_init
            )
        futures = {self._pool.submit(fn, job): i for i, job in enumerate(jobs)}
        try:
            for future in cf.as_completed(futures):
                yield futures[future], future.result()
        finally:
            for future in futures:
                future.cancel()


class _RayExecutor(Executor):
    """Tasks on Ray: a local instance of ``workers`` CPUs started here, or the cluster at ``address``
    (``"auto"``: the one this machine belongs to). Each task asks for one CPU. Ray is shut down on
    :meth:`close` only if this executor started or joined it."""

    kind = "ray"

    def __init__(self, workers: int, address: str | None):
        super().__init__(workers)
        try:
            import ray
        except ImportError as err:
            raise MissingRayError(RAY_INSTALL_HINT) from err
        self._ray = ray
        self._owns = not ray.is_initialized()
        if self._owns:
            self._init(workers, address)
        self.address = address

    def _init(self, workers: int, address: str | None) -> None:
        """Start a local instance (``address`` None) or join one. Ray gives a local raylet 30 s to
        register, which a machine busy with other work can miss: a local start is tried 3 times."""
        ray = self._ray
        runtime_env = {"env_vars": single_thread_env()}
        if address is not None:
            ray.init(address=address, runtime_env=runtime_env, log_to_driver=False)
            return
        for attempt in range(_LOCAL_START_ATTEMPTS):
            try:
                ray.init(
                    num_cpus=workers, runtime_env=runtime_env, include_dashboard=False, log_to_driver=False
                )
                return
            except Exception as err:  # Ray raises a bare Exception for this
                if "timed out during startup" not in str(err) or attempt == _LOCAL_START_ATTEMPTS - 1:
                    raise
                ray.shutdown()

    def close(self) -> None:
        if self._owns and self._ray.is_initialized():
            self._ray.shutdown()
        self._owns = False

    def _run(self, fn, jobs):
        ray = self._ray
        remote = ray.remote(num_cpus=1)(_call)
        refs = {remote.remote(fn, job): i for i, job in enumerate(jobs)}
        pending = list(refs)
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1)
                for ref in done:
                    yield refs[ref], ray.get(ref)
        finally:
            for ref in pending:
                ray.cancel(ref)


def _call(fn: Callable[[Any], Any], job: Any) -> Any:
    """A Ray task: ``fn(job)`` with one thread per worker."""
    _worker_init()
    return fn(job)


def make_executor(workers: int = 1, *, ray: bool = False, ray_address: str | None = None) -> Executor:
    """The executor the caller asked for: Ray when ``ray`` or ``ray_address`` is given (a local
    instance of ``workers`` CPUs, or the cluster at ``ray_address``), else a pool of ``workers``
    processes, else (``workers == 1``) this process. ``MissingRayError`` when Ray is asked for and not
    installed; ``ValueError`` for ``workers < 1``."""
    check_int("workers", workers, low=1)
    if ray or ray_address is not None:
        return _RayExecutor(workers, ray_address)
    if workers > 1:
        return _PoolExecutor(workers)
    return Executor(1)


def add_arguments(parser: argparse.ArgumentParser, *, workers: int = 1) -> None:
    """The flags that choose the executor: ``--workers N`` (default ``workers``), ``--ray``,
    ``--ray-address ADDR``."""
    parser.add_argument(
        "--workers",
        type=int,
        default=workers,
        help=f"worker processes, or with --ray the CPUs of the local Ray instance (default {workers})",
    )
    parser.add_argument(
        "--ray",
        action="store_true",
        help='run the jobs on a local Ray instance (pip install "lerobot_forcemap[ray]")',
    )
    parser.add_argument(
        "--ray-address",
        default=None,
        metavar="ADDR",
        help="run the jobs on the Ray cluster at ADDR (e.g. auto, or ray://HEAD:10001)",
    )


def from_args(args: argparse.Namespace) -> Executor:
    """:func:`make_executor` from the flags of :func:`add_arguments` (``--workers`` named in its error)."""
    check_int("--workers", args.workers, low=1)
    return make_executor(args.workers, ray=args.ray, ray_address=args.ray_address)
