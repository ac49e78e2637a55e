"""What a worker process executes for one task: run the study, return the table as
Parquet bytes. The driver alone writes run-directory files, under the run's lock, so a
cluster needs no shared run directory (the truth store is a shared cache folder on this
machine) and a worker can never write a task result the run does not hold the lock for.

A local pool's workers also end with their driver (`start_local_worker`): killed with
SIGKILL, the driver cannot stop them, and they would otherwise wait for work forever,
keeping the fork server and multiprocessing's resource tracker alive with them."""

from __future__ import annotations

import io
import os
import select
import signal
import threading
import time

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from aerotruth.sim.context import TaskContext
from aerotruth.sim.studies import load_study
from aerotruth.sim.tasks import Task

META_TASK_ID = b"aerotruth.task_id"
META_IDENTITY = b"aerotruth.identity"
META_TASK_KEY = b"aerotruth.task_key"


def as_arrow(table: pd.DataFrame | pa.Table) -> pa.Table:
    """A study's output as an Arrow table (pandas index dropped)."""
    if isinstance(table, pa.Table):
        return table
    if isinstance(table, pd.DataFrame):
        return pa.Table.from_pandas(table, preserve_index=False)
    raise TypeError(f"a study's run() must return a pandas DataFrame or pyarrow Table, got {type(table).__name__}")


def parquet_bytes(table: pa.Table) -> bytes:
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


def read_parquet_bytes(data: bytes) -> pd.DataFrame:
    return pq.read_table(io.BytesIO(data)).to_pandas()


def execute_task(
    task: Task, campaign_seed: int, task_key: str, learned: dict[str, bytes], truth_root: str | None
) -> tuple[bytes, int]:
    """Run `task` with its named streams; return its table as Parquet bytes, tagged with
    the task id, identity and key (checked when a run resumes), and the number of legs it
    flew into the truth store (the store's log also holds other processes' flights)."""
    study = load_study(task.source)
    ctx = TaskContext(task, campaign_seed, truth_root, {k: read_parquet_bytes(v) for k, v in learned.items()})
    table = as_arrow(study.run(task, ctx))
    meta = dict(table.schema.metadata or {})
    meta.update(
        {META_TASK_ID: task.id.encode(), META_IDENTITY: task.identity_json.encode(), META_TASK_KEY: task_key.encode()}
    )
    return parquet_bytes(table.replace_schema_metadata(meta)), ctx.legs_flown


def ignore_sigint() -> None:
    """Pool-worker initializer: Ctrl-C is the driver's to handle (it stops the workers);
    a worker interrupted mid-task would only send back a KeyboardInterrupt as a result."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


DRIVER_GONE_EXIT = 75  # a worker's exit status when its driver died (EX_TEMPFAIL: rerun resumes)
_POLL_S = 0.2  # where the process cannot be watched through a pidfd


def start_local_worker(driver_pid: int) -> None:
    """Local-pool initializer: Ctrl-C is the driver's (`ignore_sigint`), and the worker
    ends as soon as the driver process `driver_pid` does, whatever killed it.

    The worker's parent is multiprocessing's fork server, not the driver, so neither
    os.getppid() nor PR_SET_PDEATHSIG sees the driver die; a daemon thread watches the
    driver itself and ends the worker with os._exit (mid-task too: its result could only
    go to a driver that no longer exists, and the truth store's writes are atomic)."""
    ignore_sigint()
    threading.Thread(target=_end_with, args=(driver_pid,), name="aerotruth-driver-watch", daemon=True).start()


def _end_with(pid: int) -> None:
    """Block until process `pid` has ended, then end this process at once."""
    try:
        fd = os.pidfd_open(pid)  # Linux >= 5.3: readable once the process has exited
    except ProcessLookupError:
        os._exit(DRIVER_GONE_EXIT)
    except (AttributeError, OSError):
        fd = None
    if fd is not None:
        while not select.select([fd], [], [])[0]:
            pass
        os._exit(DRIVER_GONE_EXIT)
    while _alive(pid):  # elsewhere: poll
        time.sleep(_POLL_S)
    os._exit(DRIVER_GONE_EXIT)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # the pid now belongs to another user's process
        return False
    return True
