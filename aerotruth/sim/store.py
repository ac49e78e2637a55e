"""The result store: one run directory per campaign.

    RUN_DIR/config.resolved.yaml   the campaign with every default filled in
    RUN_DIR/manifest.json          config hash, seed, task ids, package versions
    RUN_DIR/tasks/<task_id>.parquet  one table per finished task, tagged with its key
    RUN_DIR/learned/<study>.<name>.parquet  a fitted state (and .csv), tagged with its input digest
    RUN_DIR/failed/<task_id>.log   traceback of a task that raised
    RUN_DIR/metrics.json           aggregated metrics (deterministic bytes)
    RUN_DIR/tables/<study>.<name>.parquet|.csv|.md, tables/index.json   the studies' tables
    RUN_DIR/data/<study>.<name>.parquet|.csv   the studies' data exports (e.g. observation tables)
    RUN_DIR/figures/*.png|*.pdf, RUN_DIR/report.md

A run folder is recognised by its manifest.json (`is_run_folder`); `check_out_folder`
refuses, before anything is written, to run into a non-empty folder that is not one, so
that a user's own report.md or metrics.json is never replaced (with --force a run writes
beside the folder's files only when none of its names, RUN_FOLDER_NAMES, is taken).

Every file is written through aerotruth.files (temporary name, then rename), so a run
killed at any moment leaves either a complete file or none; temporaries are never read
and are removed on resume. A stored task table is reused only when its key (task
identity, the study's resolved configuration, campaign seed, the digest of the code and
data the study depends on, library versions, learned states it applied) matches: an
edited configuration, source constant or XML file reruns exactly the tasks it affects.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from aerotruth.digests import library_versions
from aerotruth.errors import RunDirError, UserError, output_folder
from aerotruth.files import (
    atomic_write_bytes,
    atomic_write_text,
    remove_stale_temporaries,
)
from aerotruth.sim.campaign_file import Campaign
from aerotruth.sim.campaign_loader import load_campaign
from aerotruth.sim.tasks import Task
from aerotruth.sim.worker import META_TASK_ID, META_TASK_KEY

METRIC_SIGNIFICANT_DIGITS = 10
_VERSIONED = (
    "aerotruth",
    "numpy",
    "scipy",
    "pandas",
    "pyarrow",
    "pydantic",
    "jsbsim",
    "ppigrf",
    "dask",
    "distributed",
    "pyproj",
    "numba",
    "llvmlite",
)
META_INPUT_DIGEST = b"aerotruth.input_digest"

RUN_FOLDER_NAMES = (
    ".lock",
    "config.resolved.yaml",
    "manifest.json",
    "metrics.json",
    "report.md",
    "tasks",
    "learned",
    "failed",
    "tables",
    "data",
    "figures",
)
"""What a run writes at the top of its folder (RUN_DIR/.lock is campaign.py's run lock)."""

_MANIFEST_KEYS = ("campaign", "config_hash", "tasks", "versions")
_MANIFEST_MAX_BYTES = 256 * 2**20
# what a run leaves when it is stopped between taking its lock and writing its manifest
_BEFORE_MANIFEST = {".lock", "tasks", "config.resolved.yaml"}
_PROBE = re.compile(r"^\.aerotruth-probe\..*\.tmp$")  # aerotruth.errors.check_writable's, should a kill leave one
_EARLY_TEMPORARY = re.compile(r"^(?:config\.resolved\.yaml|manifest\.json)\.\d+\.[0-9a-f]{8}\.tmp$")


def is_run_folder(root: str | Path) -> bool:
    """True for a folder aerotruth runs into: its manifest.json is a run's (a JSON object
    with campaign, config_hash, tasks and versions), or it holds nothing but what a run
    stopped before its manifest leaves (.lock, tasks/, config.resolved.yaml)."""
    root = Path(root)
    manifest = root / "manifest.json"
    try:
        if manifest.is_file():
            if manifest.stat().st_size > _MANIFEST_MAX_BYTES:
                return False
            doc = json.loads(manifest.read_bytes())
            return isinstance(doc, dict) and all(k in doc for k in _MANIFEST_KEYS)
        names = [p.name for p in root.iterdir()]
    except (OSError, ValueError):  # unreadable, not JSON, not UTF-8
        return False
    return (
        ".lock" in names
        and all(n in _BEFORE_MANIFEST or _EARLY_TEMPORARY.match(n) or _PROBE.match(n) for n in names)
        and (root / ".lock").is_file()
        and (not (root / "tasks").exists() or (root / "tasks").is_dir())
    )


def check_out_folder(path: str | Path, force: bool = False, option: str = "--out") -> Path:
    """The folder a run writes into, checked before anything is written (a UserError of one
    line naming `option` otherwise). Accepted: a folder that does not exist yet (made with
    its parents), an empty folder, or an aerotruth run folder (resumed). A non-empty folder
    that is not a run folder is refused; with `force` it is accepted when none of
    RUN_FOLDER_NAMES is in it, so that no file aerotruth did not write is ever replaced or
    deleted. Then aerotruth.errors.output_folder: no file in the folder's place, and the
    folder (or the nearest existing one it will be made in) must be writable."""
    out = Path(path)
    if out.is_dir():
        try:
            names = sorted(p.name for p in out.iterdir() if not _PROBE.match(p.name))
        except OSError as e:
            raise UserError(f"{option}: cannot read folder {out} ({e.strerror or e})") from None
        if names and not is_run_folder(out):
            if not force:
                raise RunDirError(
                    f"{option}: {out} is not empty and is not an aerotruth run folder (no run's manifest.json); "
                    "give a new or empty folder (or, to write the run beside its files, --force)"
                )
            taken = [n for n in names if n in RUN_FOLDER_NAMES]
            if taken:
                raise RunDirError(
                    f"{option}: {out} is not an aerotruth run folder and already holds {', '.join(taken)}, "
                    "which a run writes; a file aerotruth did not write is never replaced, even with --force: "
                    "give a new or empty folder"
                )
    return output_folder(out, option)


def round_significant(x: float, digits: int = METRIC_SIGNIFICANT_DIGITS) -> float | None:
    """x rounded to `digits` significant digits; None for NaN (JSON has no NaN)."""
    if math.isnan(x):
        return None
    if math.isinf(x) or x == 0.0:
        return float(x)
    return float(f"{x:.{digits}g}")


def metrics_json(metrics: dict[str, Any]) -> str:
    """Canonical JSON of a metrics document: sorted keys, floats to fixed significant digits,
    so identical results give identical bytes whatever executor produced them."""

    def clean(v: Any) -> Any:
        if isinstance(v, dict):
            return {str(k): clean(x) for k, x in v.items()}
        if isinstance(v, (list, tuple)):
            return [clean(x) for x in v]
        if isinstance(v, (bool, np.bool_)):
            return bool(v)
        if isinstance(v, (int, np.integer)):
            return int(v)
        if isinstance(v, (float, np.floating)):
            return round_significant(float(v))
        if v is None or isinstance(v, str):
            return v
        raise TypeError(f"metric value of type {type(v).__name__} cannot be written to metrics.json: {v!r}")

    return json.dumps(clean(metrics), sort_keys=True, indent=2, allow_nan=False) + "\n"


def package_versions() -> dict[str, str]:
    """Versions of the packages that shape results (and of aerotruth, Dask, pydantic), plus Python's."""
    return library_versions(_VERSIONED)


def _table_bytes(df: pd.DataFrame, meta: dict[bytes, bytes] | None = None) -> bytes:
    table = pa.Table.from_pandas(df, preserve_index=False)
    if meta:
        table = table.replace_schema_metadata({**(table.schema.metadata or {}), **meta})
    sink = pa.BufferOutputStream()
    pq.write_table(table, sink)
    return sink.getvalue().to_pybytes()


class RunStore:
    """A run directory (see the module docstring)."""

    def __init__(self, root: str | Path):
        self.root = Path(root)

    tasks_dir = property(lambda self: self.root / "tasks")
    learned_dir = property(lambda self: self.root / "learned")
    failed_dir = property(lambda self: self.root / "failed")
    tables_dir = property(lambda self: self.root / "tables")
    data_dir = property(lambda self: self.root / "data")
    figures_dir = property(lambda self: self.root / "figures")
    manifest_path = property(lambda self: self.root / "manifest.json")
    config_path = property(lambda self: self.root / "config.resolved.yaml")
    metrics_path = property(lambda self: self.root / "metrics.json")
    report_path = property(lambda self: self.root / "report.md")

    def task_path(self, task_id: str) -> Path:
        """Where the finished table of `task_id` lives."""
        return self.tasks_dir / f"{task_id}.parquet"

    # -- opening a run ---------------------------------------------------------------

    def prepare(self, campaign: Campaign, tasks: list[Task]) -> None:
        """Create or reopen the run directory for `campaign`: write the resolved config and
        the manifest, drop temporaries (of any file a killed run was writing) and the tables
        of tasks the campaign no longer has."""
        if not self.manifest_path.exists() and self.tasks_dir.exists() and any(self.tasks_dir.glob("*.parquet")):
            raise RunDirError(
                f"{self.root} has task results but no manifest.json; choose another --out or delete the directory"
            )
        self.tasks_dir.mkdir(parents=True, exist_ok=True)
        # a run killed while writing any of its files leaves that file's temporary: the
        # resumed run (under the run lock: no other writer is live) starts without them
        remove_stale_temporaries(self.root)
        for name in RUN_FOLDER_NAMES:
            if (self.root / name).is_dir():
                remove_stale_temporaries(self.root / name, recursive=True)
        ids = sorted(t.id for t in tasks)
        if len(set(ids)) != len(ids):
            raise RunDirError("campaign expands into repeated task identities")
        keep = set(ids)
        for old in self.tasks_dir.glob("*.parquet"):
            if old.stem not in keep:
                old.unlink()
        manifest = {
            "campaign": campaign.name,
            "config_hash": campaign.config_hash(),
            "seed": campaign.seed,
            "studies": {s: sum(t.study == s for t in tasks) for s in campaign.studies},
            "tasks": ids,
            "versions": package_versions(),
        }
        atomic_write_text(self.config_path, campaign.to_yaml())
        atomic_write_text(self.manifest_path, json.dumps(manifest, indent=2, sort_keys=True) + "\n")
        if self.metrics_path.exists():
            self.metrics_path.unlink()

    def read_manifest(self) -> dict[str, Any]:
        """manifest.json of this run."""
        try:
            return json.loads(self.manifest_path.read_text())
        except FileNotFoundError:
            raise RunDirError(
                f"{self.root} is not a run directory (no manifest.json); run `aerotruth run CAMPAIGN.yaml` first"
            ) from None

    def campaign(self) -> Campaign:
        """The resolved campaign stored with the run."""
        if not self.config_path.exists():
            raise RunDirError(f"{self.root} is not a run directory (no config.resolved.yaml)")
        return load_campaign(self.config_path)

    # -- task results ----------------------------------------------------------------

    def is_done(self, task: Task, key: str) -> bool:
        """True if the task's table exists, is readable and was made with `key`; any other
        file is removed (the task reruns)."""
        path = self.task_path(task.id)
        if not path.exists():
            return False
        try:
            meta = pq.read_schema(path).metadata or {}
        except (pa.ArrowInvalid, OSError):
            meta = {}
        if meta.get(META_TASK_ID) == task.id.encode() and meta.get(META_TASK_KEY) == key.encode():
            return True
        path.unlink()
        return False

    def write_task(self, task_id: str, parquet_bytes: bytes) -> None:
        """Store a finished task's table atomically."""
        atomic_write_bytes(self.task_path(task_id), parquet_bytes)

    # -- learned states ----------------------------------------------------------------

    def learned_path(self, study: str, name: str) -> Path:
        return self.learned_dir / f"{study}.{name}.parquet"

    def read_learned(self, study: str, name: str, digest: str | None = None) -> pd.DataFrame | None:
        """A stored fitted state; with `digest`, only if it was fitted on those inputs."""
        path = self.learned_path(study, name)
        if not path.exists():
            return None
        try:
            table = pq.read_table(path)
        except (pa.ArrowInvalid, OSError):
            return None
        if digest is not None and (table.schema.metadata or {}).get(META_INPUT_DIGEST) != digest.encode():
            return None
        return table.to_pandas()

    def write_learned(self, study: str, name: str, digest: str, state: pd.DataFrame) -> None:
        """Store a fitted state (Parquet for the program, CSV for people)."""
        self.learned_dir.mkdir(parents=True, exist_ok=True)
        atomic_write_bytes(self.learned_path(study, name), _table_bytes(state, {META_INPUT_DIGEST: digest.encode()}))
        atomic_write_text(self.learned_dir / f"{study}.{name}.csv", state.to_csv(index=False))

    def learned_of(self, study: str) -> dict[str, pd.DataFrame]:
        """Every stored state of `study`, by name."""
        out = {}
        for p in sorted(self.learned_dir.glob(f"{study}.*.parquet")) if self.learned_dir.exists() else []:
            out[p.stem[len(study) + 1 :]] = pq.read_table(p).to_pandas()
        return out

    # -- tables ------------------------------------------------------------------------

    def write_tables(self, study: str, tables: dict[str, pd.DataFrame], to_markdown) -> None:
        """A study's summary tables: Parquet (read back by figures and report), CSV, Markdown."""
        self.tables_dir.mkdir(parents=True, exist_ok=True)
        for name, table in tables.items():
            base = self.tables_dir / f"{study}.{name}"
            atomic_write_bytes(f"{base}.parquet", _table_bytes(table))
            atomic_write_text(f"{base}.csv", table.to_csv(index=False))
            atomic_write_text(f"{base}.md", to_markdown(table) + "\n")
        index_path = self.tables_dir / "index.json"
        index = json.loads(index_path.read_text()) if index_path.exists() else {}
        index[study] = list(tables)
        atomic_write_text(index_path, json.dumps(index, indent=2, sort_keys=True) + "\n")

    def write_exports(self, study: str, exports: dict[str, pd.DataFrame]) -> None:
        """A study's data exports: Parquet and CSV under RUN_DIR/data. A table may carry
        `attrs["sidecars"]` ({suffix: text}, written as <base>.<suffix>, e.g. the approach
        log's runway.json) and `attrs["parquet_metadata"]` ({key: text}, into the Parquet file)."""
        if not exports:
            return
        self.data_dir.mkdir(parents=True, exist_ok=True)
        for name, table in exports.items():
            base = self.data_dir / f"{study}.{name}"
            meta = {k.encode(): v.encode() for k, v in table.attrs.get("parquet_metadata", {}).items()}
            atomic_write_bytes(f"{base}.parquet", _table_bytes(table, meta or None))
            atomic_write_text(f"{base}.csv", table.to_csv(index=False))
            for suffix, text in table.attrs.get("sidecars", {}).items():
                atomic_write_text(f"{base}.{suffix}", text)

    def read_tables(self, study: str) -> dict[str, pd.DataFrame]:
        """The summary tables of `study`, in the order the study gave them."""
        index_path = self.tables_dir / "index.json"
        names = json.loads(index_path.read_text()).get(study, []) if index_path.exists() else []
        return {n: pq.read_table(self.tables_dir / f"{study}.{n}.parquet").to_pandas() for n in names}

    def write_failure(self, task_id: str, text: str) -> Path:
        """Keep the traceback of a failed task; returns its path."""
        self.failed_dir.mkdir(parents=True, exist_ok=True)
        path = self.failed_dir / f"{task_id}.log"
        atomic_write_text(path, text)
        return path

    def missing(self, tasks: list[Task]) -> list[str]:
        """Ids of tasks without a stored table."""
        return sorted(t.id for t in tasks if not self.task_path(t.id).exists())

    def read_rows(self, tasks: list[Task]) -> pd.DataFrame:
        """All tables of `tasks` concatenated in task-id order, with leading task_id and
        stage columns."""
        frames = []
        for t in sorted(tasks, key=lambda t: t.id):
            df = pq.read_table(self.task_path(t.id)).to_pandas()
            df.insert(0, "task_id", t.id)
            df.insert(1, "stage", t.stage)
            frames.append(df)
        if not frames:
            return pd.DataFrame({"task_id": pd.Series([], dtype=str), "stage": pd.Series([], dtype=str)})
        return pd.concat(frames, ignore_index=True)

    # -- metrics ---------------------------------------------------------------------

    def write_metrics(self, document: dict[str, Any]) -> None:
        """metrics.json (canonical bytes, see metrics_json)."""
        atomic_write_text(self.metrics_path, metrics_json(document))

    def read_metrics(self) -> dict[str, Any]:
        """metrics.json of a finished run."""
        try:
            return json.loads(self.metrics_path.read_text())
        except FileNotFoundError:
            if not self.root.is_dir():
                raise RunDirError(f"{self.root}: no such run directory") from None
            if not self.config_path.exists():
                raise RunDirError(f"{self.root} is not a run directory (no config.resolved.yaml)") from None
            raise RunDirError(
                f"{self.root} has no metrics.json: the run is unfinished; rerun `aerotruth run` to complete it"
            ) from None
