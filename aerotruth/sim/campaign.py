"""Running a campaign: expand into tasks, skip those whose stored result is still valid,
execute the rest on the chosen executor while storing each result as it arrives, fit the
learned states once their stages are done (then run the tasks that apply them), and
reduce every study to metrics and tables.

Aggregation always reads the stored tables back in task-id order, so a fresh run, a
resumed run and runs on any executor or worker count reduce exactly the same bytes.
"""

from __future__ import annotations

import contextlib
import dataclasses
import fcntl
import hashlib
import json
import sys
import time
import traceback
from collections.abc import Iterator
from concurrent.futures import FIRST_COMPLETED, Future, wait
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from aerotruth.digests import code_digest
from aerotruth.errors import RunDirError, UserError, output_folder
from aerotruth.markdown import to_markdown
from aerotruth.seeds import generator, named_sequence
from aerotruth.sim.campaign_file import Campaign, ConfigError
from aerotruth.sim.executors import ExecutorChoice, open_executor
from aerotruth.sim.store import RunStore
from aerotruth.sim.studies import Registry, Study, campaign_registry
from aerotruth.sim.tasks import Task
from aerotruth.sim.worker import execute_task, parquet_bytes


class TaskFailed(UserError):
    """A task raised; its traceback is kept in RUN_DIR/failed/<task_id>.log."""


class RunPaused(Exception):
    """The run stopped submitting tasks at its time limit (`stop_after_s`), stored every task
    it had started, and left the rest for the next call with the same campaign and folder."""

    def __init__(self, run_dir: Path, stored: int, n_tasks: int, seconds: float, legs_flown: int):
        self.run_dir, self.stored, self.n_tasks = run_dir, stored, n_tasks
        self.seconds, self.legs_flown = seconds, legs_flown
        super().__init__(
            f"paused after {seconds / 3600:.2f} h: {stored} of {n_tasks} tasks stored in {run_dir} "
            f"({legs_flown} legs flown in this part); the same command goes on from there"
        )


@dataclass(frozen=True)
class RunSummary:
    """What `run_campaign` did."""

    run_dir: Path
    n_tasks: int
    reused: int
    ran: int
    seconds: float
    legs_flown: int = 0


def default_run_dir(campaign: Campaign) -> Path:
    """runs/<name> unless the campaign's outputs.dir says otherwise."""
    return Path(campaign.outputs.dir) if campaign.outputs.dir else Path("runs") / campaign.name


def expand(campaign: Campaign, reg: Registry | None = None) -> list[Task]:
    """All tasks of all studies of the campaign (each carrying its study's source), sorted by id."""
    reg = reg or campaign_registry(campaign)
    tasks: list[Task] = []
    for name, section in campaign.studies.items():
        study = reg.get(name)
        try:
            got = study.expand(campaign, section)
        except ValueError as e:  # a study's own check of its section
            raise ConfigError(f"studies.{name}: {e}") from None
        for t in got:
            missing = [n for n in t.needs if n not in study.learns]
            if missing:
                raise ConfigError(
                    f"studies.{name}: task {t.id} needs learned state {missing[0]!r}, which the study does not declare"
                )
        tasks.extend(dataclasses.replace(t, source=reg.sources[name]) for t in got)
    ids = [t.id for t in tasks]
    if len(set(ids)) != len(ids):
        dup = sorted({i for i in ids if ids.count(i) > 1})
        raise ConfigError(f"campaign {campaign.name}: repeated task identities {dup[:3]}")
    return sorted(tasks, key=lambda t: t.id)


def _canonical(obj: Any) -> Any:
    """JSON form of task parameters: dataclasses, pydantic sections, dates, tuples."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {"__type__": type(obj).__name__, **{f.name: getattr(obj, f.name) for f in dataclasses.fields(obj)}}
    if hasattr(obj, "model_dump"):
        return obj.model_dump(mode="json", by_alias=True)
    if hasattr(obj, "isoformat"):
        return obj.isoformat()
    if isinstance(obj, (set, frozenset)):
        return sorted(obj)
    raise TypeError(f"task parameter of type {type(obj).__name__} has no canonical form: {obj!r}")


def _digest(obj: Any) -> str:
    return hashlib.sha256(
        json.dumps(obj, sort_keys=True, separators=(",", ":"), default=_canonical).encode()
    ).hexdigest()


def task_key(campaign: Campaign, task: Task, learned_digests: dict[str, str]) -> str:
    """What a stored task table must have been made from to be reused: everything `run`
    receives (identity, parameters, campaign seed, learned states) and the digest of the
    code and data the study depends on. A change elsewhere in the campaign (another
    study, a day added to a period) leaves the task's stored table valid."""
    return _digest(
        {
            "task": task.identity_json,
            "params": task.params,
            "seed": campaign.seed,
            "code": code_digest(task.source),
            "learned": {n: learned_digests[n] for n in task.needs},
        }
    )


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
            from rich.progress import (
                BarColumn,
                MofNCompleteColumn,
                Progress,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )

            console = Console(stderr=True)
            if console.is_terminal:
                self._bar = Progress(
                    TextColumn("[bold]{task.description}"),
                    BarColumn(),
                    MofNCompleteColumn(),
                    TimeElapsedColumn(),
                    TextColumn("ETA"),
                    TimeRemainingColumn(),
                    console=console,
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


class _Runner:
    """One run: waves of ready tasks on one executor (opened when first needed), fits in between."""

    def __init__(
        self,
        campaign: Campaign,
        reg: Registry,
        store: RunStore,
        choice: ExecutorChoice,
        truth_root: str | None,
        progress: _Progress,
        deadline: float | None = None,
    ):
        self.campaign, self.reg, self.store, self.choice = campaign, reg, store, choice
        self.deadline = deadline  # time.monotonic() after which no task is started (one is, each call)
        self.truth_root = truth_root
        self.progress = progress
        self.learned: dict[tuple[str, str], tuple[str, pd.DataFrame]] = {}
        self.keys: dict[str, str] = {}
        self.ran = 0
        self.legs_flown = 0
        self._stack = contextlib.ExitStack()
        self._executor = None

    def run(self, tasks: list[Task]) -> None:
        with self._stack:
            pending = list(tasks)
            while pending:
                ready = [t for t in pending if all((t.study, n) in self.learned for n in t.needs)]
                if not ready:
                    t = pending[0]
                    raise ConfigError(
                        f"studies.{t.study}: task {t.id} needs {', '.join(t.needs)}, "
                        "which no stage of the study can fit"
                    )
                todo = []
                for t in ready:
                    digests = {n: self.learned[(t.study, n)][0] for n in t.needs}
                    self.keys[t.id] = key = task_key(self.campaign, t, digests)
                    if self.store.is_done(t, key):
                        self.progress.advance()
                    else:
                        todo.append(t)
                if todo:
                    self._execute(todo)
                done_ids = {t.id for t in ready}
                pending = [t for t in pending if t.id not in done_ids]
                self._fit_ready(tasks, {t.id for t in pending})

    def _fit_ready(self, tasks: list[Task], pending_ids: set[str]) -> None:
        for name in self.campaign.studies:
            study = self.reg.get(name)
            for state, stages in study.learns.items():
                if (name, state) in self.learned:
                    continue
                inputs = [t for t in tasks if t.study == name and t.stage in stages]
                if any(t.id in pending_ids for t in inputs):
                    continue
                digest = _digest(
                    {
                        "inputs": sorted(self.keys[t.id] for t in inputs),
                        "code": code_digest(self.reg.sources[name]),
                        "config": self.campaign.results_json(name),
                    }
                )
                got = self.store.read_learned(name, state, digest)
                if got is None:
                    rows = self.store.read_rows(inputs)
                    rng = generator(named_sequence(self.campaign.seed, name, "fit", state))
                    got = study.fit(state, rows, self.campaign.section(name), rng)
                    if not isinstance(got, pd.DataFrame):
                        raise TypeError(
                            f"study {name}: fit({state!r}) must return a pandas DataFrame, got {type(got).__name__}"
                        )
                    self.store.write_learned(name, state, digest, got)
                self.learned[(name, state)] = (digest, got)

    def _execute(self, todo: list[Task]) -> None:
        """Run `todo`, keeping at most 2 x slots tasks in flight, and store each result as
        it arrives. After a failure nothing new is submitted; tasks in flight are still stored."""
        if self._executor is None:
            self._executor, self._slots = self._stack.enter_context(open_executor(self.choice))
        executor, window = self._executor, max(2 * self._slots, 4)
        failure: tuple[Task, BaseException] | None = None
        queue = sorted(todo, key=lambda t: (-self.reg.get(t.study).cost(t), t.id))[::-1]  # longest first (popped)
        pending: dict[Future, Task] = {}

        def fill() -> None:
            while failure is None and len(pending) < window and queue:
                if self.deadline is not None and (self.ran or pending) and time.monotonic() > self.deadline:
                    return  # past the time limit: what is in flight finishes, nothing new starts
                task = queue.pop()
                learned = {n: parquet_bytes(_arrow(self.learned[(task.study, n)][1])) for n in task.needs}
                pending[
                    executor.submit(
                        execute_task, task, self.campaign.seed, self.keys[task.id], learned, self.truth_root
                    )
                ] = task

        fill()
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in sorted(done, key=lambda f: pending[f].id):
                task = pending.pop(fut)
                try:
                    data, flown = fut.result()
                except Exception as e:  # noqa: BLE001 - any task error stops the run, with its traceback kept
                    if failure is None:
                        failure = (task, e)
                    continue
                self.store.write_task(task.id, data)
                self.ran += 1
                self.legs_flown += flown
                self.progress.advance()
            fill()
        if failure is not None:
            task, e = failure
            log = self.store.write_failure(task.id, "".join(traceback.format_exception(e)))
            raise TaskFailed(f"task {task.id} failed: {type(e).__name__}: {e} (traceback in {log})")
        if queue:
            raise _Paused


class _Paused(Exception):
    """Raised inside the runner at its time limit, with tasks left (run_campaign's RunPaused)."""


def _arrow(df: pd.DataFrame):
    import pyarrow as pa

    return pa.Table.from_pandas(df, preserve_index=False)


def summarize(store: RunStore, campaign: Campaign, reg: Registry, tasks: list[Task]) -> dict[str, Any]:
    """Reduce the stored tables to the metrics document and write the study tables."""
    missing = store.missing(tasks)
    if missing:
        raise RunDirError(
            f"{store.root}: {len(missing)} of {len(tasks)} tasks have no result (first: {missing[0]}); "
            "rerun to complete"
        )
    metrics: dict[str, Any] = {}
    counts: dict[str, int] = {}
    for name, section in campaign.studies.items():
        study: Study = reg.get(name)
        mine = [t for t in tasks if t.study == name]
        counts[name] = len(mine)
        summary = study.summarize(store.read_rows(mine), store.learned_of(name), section)
        for key, value in summary.metrics.items():
            if value is not None and not isinstance(value, (int, float)):
                raise TypeError(f"study {name}: metric {key} must be a number, got {type(value).__name__}")
            metrics[f"{name}.{key}"] = value
        store.write_tables(name, summary.tables, to_markdown)
        store.write_exports(name, summary.exports)
    return {
        "campaign": campaign.name,
        "config_hash": campaign.config_hash(),
        "seed": campaign.seed,
        "tasks": counts,
        "metrics": metrics,
    }


def run_campaign(
    campaign: Campaign,
    choice: ExecutorChoice,
    *,
    out: str | Path | None = None,
    progress: bool = True,
    log=None,
    stop_after_s: float | None = None,
) -> RunSummary:
    """Run (or resume) `campaign` into its run directory and write metrics.json and tables.
    `stop_after_s`: start no task after this many seconds (at least one each call), store the
    ones in flight and raise RunPaused; the same call again goes on from the stored tasks."""
    from aerotruth.truth.store import TruthStore

    log = log or (lambda msg: print(msg, file=sys.stderr))
    t0 = time.monotonic()
    store = RunStore(output_folder(out if out is not None else default_run_dir(campaign)))
    reg = campaign_registry(campaign)
    tasks = expand(campaign, reg)
    truth = TruthStore(campaign.truth_store.path)
    output_folder(truth.root, "truth_store.path")  # flights are written there: writable before any is flown
    with _locked(store.root):
        store.prepare(campaign, tasks)
        log(f"{campaign.name}: {len(tasks)} tasks on {choice.describe()} -> {store.root}")
        with _Progress(len(tasks), 0, progress) as bar:
            deadline = None if stop_after_s is None else t0 + stop_after_s
            runner = _Runner(campaign, reg, store, choice, str(truth.root), bar, deadline)
            try:
                runner.run(tasks)
            except _Paused:
                stored = sum(store.is_done(t, runner.keys[t.id]) for t in tasks if t.id in runner.keys)
                raise RunPaused(store.root, stored, len(tasks), time.monotonic() - t0, runner.legs_flown) from None
        store.write_metrics(summarize(store, campaign, reg, tasks))
    flown = runner.legs_flown
    if flown:
        removed, freed = truth.evict(int(campaign.truth_store.max_gb * 1e9))
        log(
            f"truth store {truth.root}: {flown} legs flown, {truth.size_bytes() / 1e6:.1f} MB"
            + (f" ({removed} least recently used flights evicted, {freed / 1e6:.1f} MB)" if removed else "")
        )
    return RunSummary(store.root, len(tasks), len(tasks) - runner.ran, runner.ran, time.monotonic() - t0, flown)
