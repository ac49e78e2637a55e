"""Study registry: a study type turns its campaign section into tasks, runs one task into a
table, reduces all tables to metrics and draws its figures.

A study module exposes `STUDY`, an object with

* `name` (the section name under `studies:`) and `title` (for the report);
* `expand(campaign) -> list[Task]` — independent tasks, each with a stable identity;
* `run(task, rng) -> pandas.DataFrame | pyarrow.Table` — pure: everything random comes
  from `rng` (the task's stream) or from seeds derived from the campaign seed and names;
* `aggregate(rows) -> dict[str, float | int]` — `rows` is every task's table concatenated
  in task-id order with a leading `task_id` column; the reduction must not depend on how
  the tasks were scheduled (it never sees that);
* `tables(rows, metrics) -> dict[str, DataFrame]` — named tables for CSV and the report;
* `figures(rows, metrics, out_dir) -> list[Figure]` — saves `out_dir/<stem>.png` and `.pdf`;
* optionally `cost(task) -> float` — a rough estimate of the task's run time (s): the
  longest tasks are submitted first, so that one long task does not finish alone at the
  end (results never depend on the order).

Modules are imported only when their study is used, so a wind-only campaign never loads
JSBSim.
"""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd
    import pyarrow as pa

    from aerotruth.config import Campaign
    from aerotruth.sim.tasks import Task


@dataclass(frozen=True)
class Figure:
    """A figure written by a study: `stem` names figures/<stem>.png and .pdf."""

    stem: str
    caption: str


class Study(Protocol):
    """What a study type provides (see the module docstring)."""

    name: str
    title: str

    def expand(self, campaign: Campaign) -> list[Task]: ...

    def run(self, task: Task, rng: np.random.Generator) -> pd.DataFrame | pa.Table: ...

    def aggregate(self, rows: pd.DataFrame) -> dict[str, Any]: ...

    def tables(self, rows: pd.DataFrame, metrics: dict[str, Any]) -> dict[str, pd.DataFrame]: ...

    def figures(self, rows: pd.DataFrame, metrics: dict[str, Any], out_dir: Path) -> list[Figure]: ...


_MODULES: dict[str, str] = {
    "truth": "aerotruth.sim.studies.truth",
    "wind_climatology": "aerotruth.sim.studies.wind_climatology",
}


def register(name: str, module: str) -> None:
    """Make the study `name` available; `module` is the import path of a module defining STUDY."""
    if name in _MODULES and _MODULES[name] != module:
        raise ValueError(f"study {name!r} is already registered by {_MODULES[name]}")
    _MODULES[name] = module


def study_names() -> list[str]:
    """Registered study names."""
    return sorted(_MODULES)


def get_study(name: str) -> Study:
    """The study object registered under `name`."""
    if name not in _MODULES:
        raise ValueError(f"unknown study {name!r}; registered: {', '.join(study_names())}")
    study = importlib.import_module(_MODULES[name]).STUDY
    if study.name != name:
        raise ValueError(f"module {_MODULES[name]} defines study {study.name!r}, registered as {name!r}")
    return study


def task_cost(task: Task) -> float:
    """The study's run-time estimate for `task` (1.0 when the study gives none)."""
    cost = getattr(get_study(task.study), "cost", None)
    return float(cost(task)) if cost is not None else 1.0
