"""What a worker process executes for one task: run the study, return the table as
Parquet bytes. The driver alone writes files, so a cluster needs no shared filesystem."""

from __future__ import annotations

import signal

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from aerotruth.sim.studies import get_study
from aerotruth.sim.tasks import Task

META_TASK_ID = b"aerotruth.task_id"
META_IDENTITY = b"aerotruth.identity"
META_CONFIG_HASH = b"aerotruth.config_hash"


def as_arrow(table: pd.DataFrame | pa.Table) -> pa.Table:
    """A study's output as an Arrow table (pandas index dropped)."""
    if isinstance(table, pa.Table):
        return table
    if isinstance(table, pd.DataFrame):
        return pa.Table.from_pandas(table, preserve_index=False)
    raise TypeError(f"a study's run() must return a pandas DataFrame or pyarrow Table, got {type(table).__name__}")


def execute_task(task: Task, campaign_seed: int, config_hash: str) -> bytes:
    """Run `task` with its own random stream and return its table as Parquet bytes, tagged
    with the task id, identity and campaign config hash (checked when a run resumes)."""
    study = get_study(task.study)
    table = as_arrow(study.run(task, task.rng(campaign_seed)))
    meta = dict(table.schema.metadata or {})
    meta.update(
        {
            META_TASK_ID: task.id.encode(),
            META_IDENTITY: task.identity_json.encode(),
            META_CONFIG_HASH: config_hash.encode(),
        }
    )
    table = table.replace_schema_metadata(meta)
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


def ignore_sigint() -> None:
    """Pool-worker initializer: Ctrl-C is the driver's to handle (it stops the workers);
    a worker interrupted mid-task would only send back a KeyboardInterrupt as a result."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
