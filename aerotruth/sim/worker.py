"""What a worker process executes for one task: run the study, return the table as
Parquet bytes. The driver alone writes run-directory files, so a cluster needs no shared
run directory (the truth store is a shared cache folder on this machine)."""

from __future__ import annotations

import io
import signal

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
