"""Executors: where tasks run, behind the one `concurrent.futures.Executor` interface.

* local: a `ProcessPoolExecutor` (default one process per core) started with the
  'forkserver' method — every worker is a fresh process, never a fork of a parent that
  may hold JSBSim state (JSBSim wants one FGFDMExec per process) — each with one
  BLAS/OpenMP thread;
* dask: `distributed.Client(...).get_executor()`, whose futures are
  `concurrent.futures.Future`s — on a running scheduler (`--scheduler ADDRESS`) or on an
  in-process `LocalCluster` of worker *processes* (`--executor dask`).

The campaign runner only calls `submit` and waits on futures, so both take the same path.
Workers of an external Dask cluster must have the same aerotruth and dependency
versions installed (tasks are pickled by reference to aerotruth.sim.worker).
"""

from __future__ import annotations

import multiprocessing
import os
from collections.abc import Iterator
from concurrent.futures import Executor, ProcessPoolExecutor
from contextlib import contextmanager
from dataclasses import dataclass

from aerotruth.errors import UserError
from aerotruth.sim.worker import start_local_worker

DEFAULT_DASK_LOCAL_WORKERS = 2
_THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


class ExecutorError(UserError):
    """Executor settings that cannot be used (bad combination, unreachable scheduler)."""


@dataclass(frozen=True)
class ExecutorChoice:
    """Resolved executor settings (command line over YAML over defaults)."""

    kind: str  # "local" or "dask"
    workers: int | None = None
    scheduler: str | None = None

    def describe(self) -> str:
        """One phrase for logs."""
        if self.kind == "local":
            return f"local pool, {self.workers or os.cpu_count()} processes"
        if self.scheduler:
            return f"dask scheduler {self.scheduler}"
        return f"dask LocalCluster, {self.workers or DEFAULT_DASK_LOCAL_WORKERS} worker processes"


def resolve(
    yaml_kind: str,
    yaml_workers: int | None,
    yaml_scheduler: str | None,
    *,
    kind: str | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
) -> ExecutorChoice:
    """Merge command-line options over the campaign's `executor:` block; a scheduler address
    implies dask."""
    if workers is not None and workers < 1:
        raise ExecutorError(f"--workers: expected a positive integer, got {workers}")
    sched = scheduler if scheduler is not None else (yaml_scheduler if kind in (None, "dask") else None)
    k = kind or ("dask" if sched else yaml_kind)
    if sched and k != "dask":
        raise ExecutorError("--scheduler needs --executor dask")
    return ExecutorChoice(
        kind=k, workers=workers if workers is not None else yaml_workers, scheduler=sched if k == "dask" else None
    )


@contextmanager
def open_executor(choice: ExecutorChoice) -> Iterator[tuple[Executor, int]]:
    """Yield (executor, parallel slots). Slots bound how many tasks are kept in flight."""
    if choice.kind == "local":
        n = choice.workers or os.cpu_count() or 1
        # Parallelism comes from processes: one BLAS/OpenMP thread per worker (as Dask's
        # nanny does), else each worker's OpenBLAS spins on every core, doubling CPU time
        # for no gain and spoiling the scaling. The fork server inherits this environment.
        for var in _THREAD_VARS:
            os.environ.setdefault(var, "1")
        ctx = multiprocessing.get_context("forkserver")
        # Import the worker's dependencies once in the fork server, not in every worker.
        ctx.set_forkserver_preload(["aerotruth.sim.worker"])
        # Each worker ends with this process, even when it is killed with SIGKILL and cannot
        # stop them (start_local_worker); the fork server and resource tracker follow.
        pool = ProcessPoolExecutor(
            max_workers=n, mp_context=ctx, initializer=start_local_worker, initargs=(os.getpid(),)
        )
        try:
            yield pool, n
        except BaseException:
            # interrupted (Ctrl-C) or the driver failed: stop the workers now rather than
            # wait for their tasks; finished tasks are already stored, the rest rerun
            workers = list((getattr(pool, "_processes", None) or {}).values())
            pool.shutdown(wait=False, cancel_futures=True)
            for proc in workers:
                proc.terminate()
            raise
        finally:
            pool.shutdown(wait=True, cancel_futures=True)
        return
    if choice.kind != "dask":
        raise ExecutorError(f"executor: expected 'local' or 'dask', got {choice.kind!r}")
    from distributed import Client, LocalCluster

    cluster = None
    if choice.scheduler:
        try:
            client = Client(choice.scheduler, timeout="20s")
        except OSError as e:
            raise ExecutorError(f"--scheduler {choice.scheduler}: cannot connect ({e})") from None
    else:
        import dask

        # Dask's nanny sets MALLOC_TRIM_THRESHOLD_ in its workers by default; setting it fixes
        # glibc's mmap threshold, so every temporary array over 128 kB is mapped and unmapped
        # afresh (page faults): numpy-heavy tasks ran 15-20 % slower than in the local pool
        # (measured: 1.6-1.9 s against 1.3-1.6 s per task). Workers here keep glibc's default,
        # and no statistical profiler (it samples the task thread every 10 ms for a dashboard
        # this cluster does not serve).
        with dask.config.set(
            {
                "distributed.nanny.pre-spawn-environ.MALLOC_TRIM_THRESHOLD_": None,
                "distributed.worker.profile.enabled": False,
            }
        ):
            cluster = LocalCluster(
                n_workers=choice.workers or DEFAULT_DASK_LOCAL_WORKERS,
                threads_per_worker=1,
                processes=True,
                dashboard_address=None,
                host="127.0.0.1",
            )
        client = Client(cluster)
    try:
        slots = sum(w.get("nthreads", 1) for w in client.scheduler_info().get("workers", {}).values()) or 1
        executor = client.get_executor(pure=False)
        yield executor, slots
    finally:
        client.close()
        if cluster is not None:
            cluster.close()
