"""Running a campaign: expand into tasks, skip the finished ones, execute the rest on the
chosen executor while storing each result as it arrives, then aggregate.

Aggregation always reads the stored tables back in task-id order, so a fresh run, a
resumed run and runs on any executor or worker count reduce exactly the same bytes.
"""

from __future__ import annotations

import fcntl
import sys
import time
import traceback
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, Future, wait
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerotruth.config import Campaign, ConfigError
from aerotruth.sim.executors import ExecutorChoice, open_executor
from aerotruth.sim.markdown import to_markdown
from aerotruth.sim.store import RunDirError, RunStore
from aerotruth.sim.studies import get_study, task_cost
from aerotruth.sim.tasks import Task
from aerotruth.sim.worker import execute_task


class TaskFailed(RuntimeError):
    """A task raised; its traceback is kept in RUN_DIR/failed/<task_id>.log."""


@dataclass(frozen=True)
class RunSummary:
    """What `run_campaign` did."""

    run_dir: Path
    n_tasks: int
    reused: int
    ran: int
    seconds: float


def default_run_dir(campaign: Campaign) -> Path:
    """runs/<name> unless the campaign's outputs.dir says otherwise."""
    return Path(campaign.outputs.dir) if campaign.outputs.dir else Path("runs") / campaign.name


def expand(campaign: Campaign) -> list[Task]:
    """All tasks of all studies of the campaign, sorted by task id."""
    tasks: list[Task] = []
    for name in campaign.studies.present():
        try:
            tasks.extend(get_study(name).expand(campaign))
        except ValueError as e:  # a study's own check of its section (e.g. an unknown aircraft type)
            raise ConfigError(f"studies.{name}: {e}") from None
    ids = [t.id for t in tasks]
    if len(set(ids)) != len(ids):
        dup = sorted({i for i in ids if ids.count(i) > 1})
        raise ConfigError(f"campaign {campaign.name}: repeated task identities {dup[:3]}")
    return sorted(tasks, key=lambda t: t.id)


@contextmanager
def _locked(root: Path) -> Iterator[None]:
    """Hold an exclusive lock on RUN_DIR/.lock (released by the OS even on SIGKILL)."""
    root.mkdir(parents=True, exist_ok=True)
    with open(root / ".lock", "w") as fh:
        try:
            fcntl.flock(fh, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise RunDirError(f"{root} is in use by another `aerotruth run`") from None
        try:
            yield
        finally:
            fcntl.flock(fh, fcntl.LOCK_UN)


class _Progress:
    """A rich progress bar on stderr (tasks done/total, ETA); silent when stderr is not a TTY."""

    def __init__(self, total: int, done: int, enabled: bool):
        self._bar = None
        if enabled and total:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn, TimeRemainingColumn

            console = Console(stderr=True)
            if console.is_terminal:
                self._bar = Progress(
                    TextColumn("[bold]{task.description}"), BarColumn(), MofNCompleteColumn(),
                    TimeElapsedColumn(), TextColumn("ETA"), TimeRemainingColumn(), console=console,
                )
                self._id = self._bar.add_task("tasks", total=total, completed=done)

    def __enter__(self) -> _Progress:
        if self._bar is not None:
            self._bar.start()
        return self

    def advance(self) -> None:
        if self._bar is not None:
            self._bar.advance(self._id)

    def __exit__(self, *exc: object) -> None:
        if self._bar is not None:
            self._bar.stop()


def _execute(todo: list[Task], choice: ExecutorChoice, store: RunStore, seed: int, config_hash: str, progress: _Progress) -> None:
    """Run `todo`, keeping at most 2 × slots tasks in flight, and store each result as it
    arrives. After a failure nothing new is submitted; tasks in flight are still stored."""
    failure: tuple[Task, BaseException] | None = None
    with open_executor(choice) as (executor, slots):
        window = max(2 * slots, 4)
        queue = iter(sorted(todo, key=lambda t: (-task_cost(t), t.id)))  # longest first
        pending: dict[Future, Task] = {}

        def fill() -> None:
            while failure is None and len(pending) < window:
                task = next(queue, None)
                if task is None:
                    return
                pending[executor.submit(execute_task, task, seed, config_hash)] = task

        fill()
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in sorted(done, key=lambda f: pending[f].id):
                task = pending.pop(fut)
                try:
                    data = fut.result()
                except Exception as e:  # noqa: BLE001 - any task error stops the run, with its traceback kept
                    if failure is None:
                        failure = (task, e)
                    continue
                store.write_task(task.id, data)
                progress.advance()
            fill()
    if failure is not None:
        task, e = failure
        log = store.write_failure(task.id, "".join(traceback.format_exception(e)))
        raise TaskFailed(f"task {task.id} failed: {type(e).__name__}: {e} (traceback in {log})")


def aggregate(store: RunStore, campaign: Campaign, tasks: list[Task]) -> dict[str, Any]:
    """Reduce the stored tables to the metrics document and write the study tables."""
    missing = store.missing(tasks)
    if missing:
        raise RunDirError(f"{store.root}: {len(missing)} of {len(tasks)} tasks have no result (first: {missing[0]}); rerun to complete")
    metrics: dict[str, Any] = {}
    counts: dict[str, int] = {}
    store.tables_dir.mkdir(parents=True, exist_ok=True)
    for name in campaign.studies.present():
        study = get_study(name)
        mine = [t for t in tasks if t.study == name]
        counts[name] = len(mine)
        rows = store.read_rows(mine)
        got = study.aggregate(rows)
        for key, value in got.items():
            if value is not None and not isinstance(value, (int, float)):
                raise TypeError(f"study {name}: metric {key} must be a number, got {type(value).__name__}")
            metrics[f"{name}.{key}"] = value
        for tname, table in study.tables(rows, got).items():
            table.to_csv(store.tables_dir / f"{name}.{tname}.csv", index=False)
            (store.tables_dir / f"{name}.{tname}.md").write_text(to_markdown(table) + "\n")
    return {
        "campaign": campaign.name,
        "config_hash": campaign.config_hash(),
        "seed": campaign.seed,
        "tasks": counts,
        "metrics": metrics,
    }


def run_campaign(campaign: Campaign, choice: ExecutorChoice, *, out: str | Path | None = None, progress: bool = True,
                 log=None) -> RunSummary:
    """Run (or resume) `campaign` into its run directory and write metrics.json and tables."""
    log = log or (lambda msg: print(msg, file=sys.stderr))
    t0 = time.monotonic()
    store = RunStore(out if out is not None else default_run_dir(campaign))
    tasks = expand(campaign)
    with _locked(store.root):
        store.prepare(campaign, tasks)
        config_hash = campaign.config_hash()
        todo = [t for t in tasks if not store.is_done(t, config_hash)]
        reused = len(tasks) - len(todo)
        log(f"{campaign.name}: {len(tasks)} tasks ({reused} already done) on {choice.describe()} -> {store.root}")
        if todo:
            with _Progress(len(tasks), reused, progress) as bar:
                _execute(todo, choice, store, campaign.seed, config_hash, bar)
        store.write_metrics(aggregate(store, campaign, tasks))
    return RunSummary(store.root, len(tasks), reused, len(todo), time.monotonic() - t0)
