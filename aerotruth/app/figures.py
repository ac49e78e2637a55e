"""Figures of a finished run: each study draws its own into RUN_DIR/figures (PNG + PDF)
from its stored rows, summary tables and learned states (nothing is recomputed).

Every file of the run that the figures and the report read is checked before anything is
written (`read_run`): a missing, truncated or damaged file is one RunDirError naming it.
The figures are drawn into a hidden folder of the run and moved into RUN_DIR/figures only
once every study has drawn, so a task table found damaged half-way, a study that raises or
a kill leave RUN_DIR/figures as it was."""

from __future__ import annotations

import json
import os
import re
import shutil
import tempfile
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from aerotruth.app.regress import REWRITE, read_run_metrics, unreadable
from aerotruth.errors import RunDirError, UserError, check_writable
from aerotruth.sim.campaign import expand
from aerotruth.sim.campaign_file import Campaign
from aerotruth.sim.store import RunStore
from aerotruth.sim.studies import Figure, Registry, Summary, campaign_registry
from aerotruth.sim.tasks import Task

_STAGING = ".figures-"  # RUN_DIR/.figures-<pid>-<random>: figures being drawn
_DAMAGE = (pa.ArrowException, OSError, ValueError)  # what reading a damaged file raises


@dataclass(frozen=True)
class FinishedRun:
    """The stored results of a finished run, read and checked (see `read_run`); the task
    rows, the largest part, are read study by study while drawing."""

    store: RunStore
    campaign: Campaign
    registry: Registry
    tasks: list[Task]
    manifest: dict[str, Any]
    metrics: dict[str, Any]  # the metrics.json document
    tables: dict[str, dict[str, pd.DataFrame]]  # study -> name -> table, in the study's order
    learned: dict[str, dict[str, pd.DataFrame]]  # study -> name -> state

    def study_metrics(self, study: str) -> dict[str, Any]:
        prefix = f"{study}."
        return {k[len(prefix) :]: v for k, v in self.metrics["metrics"].items() if k.startswith(prefix)}

    def rows(self, study: str) -> pd.DataFrame:
        """The study's task rows; a missing or damaged task table is one RunDirError naming it."""
        mine = [t for t in self.tasks if t.study == study]
        try:
            return self.store.read_rows(mine)
        except UserError:
            raise
        except _DAMAGE as e:
            for t in sorted(mine, key=lambda t: t.id):  # which file: read each alone
                try:
                    self.store.read_rows([t])
                except _DAMAGE as one:
                    raise RunDirError(f"{self.store.task_path(t.id)}: {_parquet_problem(one)}; {REWRITE}") from None
            raise RunDirError(f"{self.store.tasks_dir}: {unreadable(e)}; {REWRITE}") from None


def _parquet_problem(e: BaseException) -> str:
    if isinstance(e, (FileNotFoundError, IsADirectoryError)):
        return unreadable(e)
    # pyarrow names the file again and adds advice: keep its first finding only
    why = re.sub(r"^Could not open Parquet input source '.*?': ", "", unreadable(e)).split(". ")[0].rstrip(".")
    return f"not a readable Parquet table, truncated or damaged ({why})"


def _parquet(path: Path) -> pd.DataFrame:
    try:
        return pq.read_table(path).to_pandas()
    except _DAMAGE as e:
        raise RunDirError(f"{path}: {_parquet_problem(e)}; {REWRITE}") from None


def _json_of(path: Path, read: Callable[[], Any]) -> Any:
    try:
        return read()
    except UserError:
        raise
    except (ValueError, OSError, RecursionError) as e:
        raise RunDirError(f"{path}: {unreadable(e)}; {REWRITE}") from None


def _read_tables(store: RunStore, campaign: Campaign) -> dict[str, dict[str, pd.DataFrame]]:
    if not store.tables_dir.is_dir():
        raise RunDirError(f"{store.tables_dir}: missing (the run's summary tables); {REWRITE}")
    index_path = store.tables_dir / "index.json"
    index = _json_of(index_path, lambda: json.loads(index_path.read_bytes().decode("utf-8")))
    if not isinstance(index, dict) or not all(
        isinstance(v, list) and all(isinstance(n, str) for n in v) for v in index.values()
    ):
        raise RunDirError(f"{index_path}: expected an object of study: [table names]; {REWRITE}")
    out = {}
    for study in campaign.studies:
        if study not in index:
            raise RunDirError(f"{index_path}: no entry for study {study}, whose tables the run wrote; {REWRITE}")
        out[study] = {n: _parquet(store.tables_dir / f"{study}.{n}.parquet") for n in index[study]}
    return out


def _read_learned(store: RunStore, study: str) -> dict[str, pd.DataFrame]:
    paths = sorted(store.learned_dir.glob(f"{study}.*.parquet")) if store.learned_dir.is_dir() else []
    return {p.stem[len(study) + 1 :]: _parquet(p) for p in paths}


def read_run(run_dir: str | Path) -> FinishedRun:
    """Read and check what the figures and the report of the run in `run_dir` are made of:
    its resolved campaign, manifest.json, metrics.json, tables/ and learned states. Each
    problem is one RunDirError (or ConfigError) naming the file and what is wrong; nothing
    is written."""
    store = RunStore(run_dir)
    campaign = store.campaign()
    manifest = _json_of(store.manifest_path, store.read_manifest)
    if not isinstance(manifest, dict) or not isinstance(manifest.get("versions", {}), dict):
        raise RunDirError(f"{store.manifest_path}: expected an object with a 'versions' object; {REWRITE}")
    doc = read_run_metrics(store.root)
    if not isinstance(doc.get("config_hash"), str) or not isinstance(doc.get("tasks"), dict):
        raise RunDirError(f"{store.metrics_path}: expected 'config_hash' and 'tasks' beside 'metrics'; {REWRITE}")
    reg = campaign_registry(campaign)
    tasks = expand(campaign, reg)
    tables = _read_tables(store, campaign)
    learned = {study: _read_learned(store, study) for study in campaign.studies}
    return FinishedRun(store, campaign, reg, tasks, manifest, doc, tables, learned)


def check_output(path: Path, folder: bool) -> None:
    """Refuse, before anything is drawn, an output whose place is taken by the other kind."""
    if folder and path.exists() and not path.is_dir():
        raise RunDirError(f"{path}: exists and is not a folder; cannot write the figures into it")
    if not folder and path.is_dir():
        raise RunDirError(f"{path}: is a folder; cannot write the report in its place")


@contextmanager
def drawn_figures(run: FinishedRun) -> Iterator[dict[str, list[Figure]]]:
    """Draw every study's figures into a hidden folder of the run and yield them by study
    name; when the `with` body ends without an error they are moved into RUN_DIR/figures,
    else nothing of them is kept."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    store = run.store
    check_output(store.figures_dir, folder=True)
    check_writable(store.root, "RUN_DIR")  # a full or read-only disk: one line before anything is drawn
    _remove_stale_staging(store.root)
    try:
        staging = Path(tempfile.mkdtemp(prefix=f"{_STAGING}{os.getpid()}-", dir=store.root))
    except OSError as e:
        raise RunDirError(f"{store.root}: cannot write the figures ({e.strerror or e})") from None
    try:
        out: dict[str, list[Figure]] = {}
        for name in run.campaign.studies:
            study = run.registry.get(name)
            rows = run.rows(name)
            summary = Summary(run.study_metrics(name), run.tables[name])
            try:
                out[name] = study.figures(rows, summary, run.learned[name], FigureFolder(staging))
            finally:
                plt.close("all")
        yield out
        _publish(staging, store.figures_dir)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _publish(staging: Path, figures_dir: Path) -> None:
    try:
        figures_dir.mkdir(exist_ok=True)
        for f in sorted(staging.iterdir()):
            os.replace(f, figures_dir / f.name)  # each file whole: the old one or the new
    except OSError as e:
        raise RunDirError(f"{figures_dir}: cannot write the figures ({e.strerror or e})") from None


def _remove_stale_staging(root: Path) -> None:
    """Drop the staging folders of figure drawings whose process is gone (killed)."""
    for d in root.glob(f"{_STAGING}*"):
        pid = d.name[len(_STAGING) :].split("-")[0]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(d, ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


def make_figures(run_dir: str | Path) -> dict[str, list[Figure]]:
    """Draw every study's figures of the run in `run_dir`; returns them by study name.
    Nothing is written unless every file they are drawn from is readable."""
    with drawn_figures(read_run(run_dir)) as figures:
        pass
    return figures


class FigureFolder:
    """Where a study's figures go: `save(fig, stem)` writes the matplotlib figure as
    <folder>/<stem>.png (150 dpi) and .pdf. A study draws; the application decides where and
    in which formats figures are written. Path-like (`folder / name`, os.fspath) for studies
    that write a file of their own."""

    def __init__(self, path: Path):
        self.path = Path(path)

    def save(self, fig, stem: str) -> None:
        fig.savefig(self.path / f"{stem}.png", dpi=150, bbox_inches="tight")
        fig.savefig(self.path / f"{stem}.pdf", bbox_inches="tight")

    def __truediv__(self, name: str) -> Path:
        return self.path / name

    def __fspath__(self) -> str:
        return str(self.path)
