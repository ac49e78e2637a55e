"""Studies: each is one module that owns its campaign section, its reference checks and
its stages. The campaign schema is assembled from the registry, so adding a study touches
its own module (and its tests) only.

A study module defines `STUDY`, an instance of a `Study` subclass with

* `name` (its section under `studies:`), `title` (for the report) and `Config` (the
  pydantic schema of its section, a subclass of `aerotruth.schema.Section`);
* `check(campaign, refs)` — cross-references of its section (fleets, periods, airports),
  raising `refs.error(loc, text)` so that the message names the YAML path and line;
* `expand(campaign, section) -> list[Task]` — independent tasks, each with a stable
  identity and, for a study that learns, a `stage` and the learned states it `needs`;
* `run(task, ctx) -> DataFrame | pyarrow.Table` — pure: everything random comes from the
  task's named streams (`ctx.rng("sensor.heading")`), truth from `ctx.truth`, learned
  state from `ctx.learned[name]`;
* `learns` — {state name: stages it is fitted on}, and `fit(name, rows, section, rng) ->
  DataFrame`: the runner calls it once every task of those stages is done, stores the
  table in the run directory and hands it to the tasks that need it (fit on a "before"
  period, apply to an "after" period); never recomputed while its inputs are unchanged;
* `summarize(rows, learned, section) -> Summary` — metrics (numbers), named tables and data
  exports from
  every task's rows (concatenated in task-id order with a leading `task_id` column and a
  `stage` column); written once to the run directory and read back by figures and report;
* optionally `figures(rows, summary, learned, out_dir) -> list[Figure]` (each figure drawn
  with matplotlib and handed to `out_dir.save(fig, stem)`) and `cost(task)`
  (a run-time estimate: the longest tasks are submitted first).

Where studies come from: the built-in ones are entry points of the group
`aerotruth.studies` (pyproject.toml); others are listed in a campaign's `study_modules:`
(an importable module name or a .py file). Tasks carry the study's source, so worker
processes (local pool or Dask) import the same module without any registration.
"""

from __future__ import annotations

import hashlib
import importlib
import importlib.util
import re
import sys
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from aerotruth.errors import UserError

if TYPE_CHECKING:
    import numpy as np
    import pandas as pd

    from aerotruth.schema import Section
    from aerotruth.sim.campaign_file import Campaign, References
    from aerotruth.sim.context import TaskContext
    from aerotruth.sim.tasks import Task

ENTRY_POINT_GROUP = "aerotruth.studies"


class StudyError(UserError):
    """A study module that cannot be found or does not define a usable STUDY."""


@dataclass(frozen=True)
class Figure:
    """A figure written by a study: `stem` names figures/<stem>.png and .pdf."""

    stem: str
    caption: str


@dataclass
class Summary:
    """What a study's reduction produces: metrics (numbers or None, keyed without the study
    prefix) and named tables, in the order the report shows them."""

    metrics: dict[str, Any]
    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    exports: dict[str, pd.DataFrame] = field(default_factory=dict)
    """Data products for the user (e.g. the observation table), written to
    RUN_DIR/data/<study>.<name>.parquet and .csv but not shown in the report."""


class Study(ABC):
    """Base of every study (see the module docstring)."""

    name: ClassVar[str]
    title: ClassVar[str]
    Config: ClassVar[type[Section]]
    learns: ClassVar[dict[str, tuple[str, ...]]] = {}

    # an optional hook (a no-op unless a study overrides it), deliberately not abstract
    def check(self, campaign: Campaign, refs: References) -> None:  # noqa: B027
        """Cross-reference checks of the section (none by default)."""

    @abstractmethod
    def expand(self, campaign: Campaign, section: Any) -> list[Task]:
        """The study's tasks."""

    @abstractmethod
    def run(self, task: Task, ctx: TaskContext) -> Any:
        """One task's table."""

    def fit(self, name: str, rows: pd.DataFrame, section: Any, rng: np.random.Generator) -> pd.DataFrame:
        """Learn the state `name` from the rows of the stages in `learns[name]`."""
        raise StudyError(f"study {self.name} declares learned state {name!r} but defines no fit()")

    @abstractmethod
    def summarize(self, rows: pd.DataFrame, learned: dict[str, pd.DataFrame], section: Any) -> Summary:
        """Metrics and tables from all rows."""

    def figures(
        self, rows: pd.DataFrame, summary: Summary, learned: dict[str, pd.DataFrame], out_dir: Any
    ) -> list[Figure]:
        """The study's figures, each drawn with matplotlib and handed to `out_dir.save(fig,
        stem)` (aerotruth.app.figures.FigureFolder: the application writes it as PNG and
        PDF); none by default."""
        return []

    def cost(self, task: Task) -> float:
        """Rough run-time estimate of `task` in seconds (equal by default)."""
        return 1.0


# ----------------------------------------------------------------------------- sources

_MODULE_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_]*(\.[A-Za-z_][A-Za-z0-9_]*)*$")
_LOADED: dict[str, Study] = {}


def builtin_sources() -> dict[str, str]:
    """Study name -> source of the studies installed as `aerotruth.studies` entry points."""
    return {ep.name: f"module:{ep.value}" for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)}


def source_for(entry: str, base_dir: Path | None) -> str:
    """The source of a `study_modules:` entry: `file:<absolute path>` for a .py file
    (relative to base_dir), `module:<name>` for an importable module name."""
    if entry.endswith(".py"):
        path = Path(entry).expanduser()
        if not path.is_absolute():
            path = (base_dir or Path.cwd()) / path
        if not path.is_file():
            raise ValueError(f"expected a study module file, {path} does not exist")
        return f"file:{path.resolve()}"
    if not _MODULE_NAME.match(entry):
        raise ValueError(f"expected an importable module name or a .py file, got {entry!r}")
    return f"module:{entry}"


def load_study(source: str) -> Study:
    """The STUDY of `source` (imported once per process)."""
    if source in _LOADED:
        return _LOADED[source]
    kind, _, ref = source.partition(":")
    try:
        if kind == "module":
            module = importlib.import_module(ref)
        elif kind == "file":
            path = Path(ref)
            name = (
                f"aerotruth_study_{re.sub(r'[^A-Za-z0-9_]', '_', path.stem)}"
                f"_{hashlib.sha256(ref.encode()).hexdigest()[:8]}"
            )
            module = sys.modules.get(name)
            if module is None:
                spec = importlib.util.spec_from_file_location(name, path)
                if spec is None or spec.loader is None:
                    raise StudyError(f"{path}: not a Python module")
                module = importlib.util.module_from_spec(spec)
                sys.modules[name] = module
                spec.loader.exec_module(module)
        else:
            raise StudyError(f"study source {source!r}: expected module:NAME or file:PATH")
    except StudyError:
        raise
    except Exception as e:  # noqa: BLE001 - any import failure becomes one line naming the module
        raise StudyError(f"cannot import study module {ref}: {type(e).__name__}: {e}") from None
    study = getattr(module, "STUDY", None)
    if not isinstance(study, Study):
        raise StudyError(f"study module {ref} defines no STUDY (an instance of aerotruth.sim.studies.Study)")
    _LOADED[source] = study
    return study


class Registry:
    """The studies a campaign can use: name -> source, loaded on demand."""

    def __init__(self, sources: dict[str, str]):
        self.sources = dict(sources)

    def __contains__(self, name: str) -> bool:
        return name in self.sources

    def __iter__(self):
        return iter(sorted(self.sources))

    def get(self, name: str) -> Study:
        """The study called `name`."""
        if name not in self.sources:
            raise StudyError(f"unknown study {name!r}; available: {', '.join(sorted(self.sources))}")
        study = load_study(self.sources[name])
        if study.name != name:
            raise StudyError(f"{self.sources[name]} defines study {study.name!r}, registered as {name!r}")
        return study


def registry(extra_sources: list[str] = ()) -> Registry:
    """Built-in studies plus those of `extra_sources` (each is imported to learn its name)."""
    sources = builtin_sources()
    for src in extra_sources:
        study = load_study(src)
        if study.name in sources and sources[study.name] != src:
            raise StudyError(
                f"{src.partition(':')[2]} defines study {study.name!r}, "
                f"which {sources[study.name].partition(':')[2]} already provides"
            )
        sources[study.name] = src
    return Registry(sources)


def campaign_registry(campaign: Campaign) -> Registry:
    """The registry of a validated campaign (its study_modules are already resolved)."""
    return registry([source_for(m, None) for m in campaign.study_modules])
