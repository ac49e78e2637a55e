"""The result store: one run directory per campaign.

    RUN_DIR/config.resolved.yaml   the campaign with every default filled in
    RUN_DIR/manifest.json          config hash, seed, task ids, package versions
    RUN_DIR/tasks/<task_id>.parquet  one table per finished task
    RUN_DIR/failed/<task_id>.log   traceback of a task that raised
    RUN_DIR/metrics.json           aggregated metrics (deterministic bytes)
    RUN_DIR/tables/*.csv|*.md      metric and per-task tables
    RUN_DIR/figures/*.png|*.pdf, RUN_DIR/report.md

Every file is written to a temporary name in the same directory and renamed over the
final name (os.replace is atomic on POSIX), so a run killed at any moment leaves either a
complete file or none; temporaries (`*.tmp`) are never read and are removed on resume. A
run directory belongs to one configuration: resuming it with a different config hash is
refused.
"""

from __future__ import annotations

import json
import math
import os
import platform
import uuid
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from aerotruth.config import Campaign, load_campaign
from aerotruth.sim.tasks import Task
from aerotruth.sim.worker import META_CONFIG_HASH, META_TASK_ID

METRIC_SIGNIFICANT_DIGITS = 10
_VERSIONED = ("aerotruth", "numpy", "pandas", "pyarrow", "pydantic", "jsbsim", "dask", "distributed", "pyproj")


class RunDirError(ValueError):
    """A run directory that cannot be used as asked (other config, incomplete run, ...)."""


def atomic_write_bytes(path: Path, data: bytes) -> None:
    """Write `data` to `path` via a temporary file in the same directory and os.replace."""
    tmp = path.with_name(f"{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def atomic_write_text(path: Path, text: str) -> None:
    """Text version of atomic_write_bytes (UTF-8)."""
    atomic_write_bytes(path, text.encode("utf-8"))


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
    """Versions of the packages that shape results, plus Python's."""
    out = {"python": platform.python_version()}
    for name in _VERSIONED:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "absent"
    return out


class RunStore:
    """A run directory (see the module docstring)."""

    def __init__(self, root: str | Path):
        self.root = Path(root)

    tasks_dir = property(lambda self: self.root / "tasks")
    failed_dir = property(lambda self: self.root / "failed")
    tables_dir = property(lambda self: self.root / "tables")
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
        """Create or reopen the run directory for `campaign`; refuse one of another config."""
        config_hash = campaign.config_hash()
        if self.manifest_path.exists():
            old = self.read_manifest()
            if old.get("config_hash") != config_hash:
                raise RunDirError(
                    f"{self.root} holds a run of a different configuration (config hash {str(old.get('config_hash'))[:12]}, "
                    f"this campaign {config_hash[:12]}); choose another --out or delete the directory"
                )
        elif self.tasks_dir.exists() and any(self.tasks_dir.glob("*.parquet")):
            raise RunDirError(f"{self.root} has task results but no manifest.json; choose another --out or delete the directory")
        self.tasks_dir.mkdir(parents=True, exist_ok=True)
        for stale in self.tasks_dir.glob("*.tmp"):
            stale.unlink()
        ids = sorted(t.id for t in tasks)
        if len(set(ids)) != len(ids):
            raise RunDirError("campaign expands into repeated task identities")
        manifest = {
            "campaign": campaign.name,
            "config_hash": config_hash,
            "seed": campaign.seed,
            "studies": {s: sum(t.study == s for t in tasks) for s in campaign.studies.present()},
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
            raise RunDirError(f"{self.root} is not a run directory (no manifest.json); run `aerotruth run CAMPAIGN.yaml` first") from None

    def campaign(self) -> Campaign:
        """The resolved campaign stored with the run."""
        if not self.config_path.exists():
            raise RunDirError(f"{self.root} is not a run directory (no config.resolved.yaml)")
        return load_campaign(self.config_path)

    # -- task results ----------------------------------------------------------------

    def is_done(self, task: Task, config_hash: str) -> bool:
        """True if the task's table exists, is readable and belongs to this config; a file
        that fails these checks is removed (it will be recomputed)."""
        path = self.task_path(task.id)
        if not path.exists():
            return False
        try:
            meta = pq.read_schema(path).metadata or {}
        except (pa.ArrowInvalid, OSError):
            path.unlink()
            return False
        if meta.get(META_TASK_ID) != task.id.encode() or meta.get(META_CONFIG_HASH) != config_hash.encode():
            raise RunDirError(f"{path} was written by another task or configuration; delete the run directory or choose another --out")
        return True

    def write_task(self, task_id: str, parquet_bytes: bytes) -> None:
        """Store a finished task's table atomically."""
        atomic_write_bytes(self.task_path(task_id), parquet_bytes)

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
        """All tables of `tasks` concatenated in task-id order, with a leading task_id column."""
        frames = []
        for t in sorted(tasks, key=lambda t: t.id):
            df = pq.read_table(self.task_path(t.id)).to_pandas()
            df.insert(0, "task_id", t.id)
            frames.append(df)
        if not frames:
            return pd.DataFrame({"task_id": pd.Series([], dtype=str)})
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
            raise RunDirError(f"{self.root} has no metrics.json: the run is unfinished; rerun `aerotruth run` to complete it") from None
