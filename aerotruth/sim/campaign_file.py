"""Schema of a campaign YAML file (pydantic): the one place where campaign defaults live.

A campaign names its random seed, the fleets and periods it draws on and one section per
study type under `studies:`. Unknown keys are errors. `load_campaign(path)` turns every
problem (YAML syntax, wrong type, unknown key, missing field, bad date, empty fleet, a
reference to an undefined fleet or period) into one `ConfigError` whose message names
the YAML path of the field and its line, e.g.
`fleets[2].aircraft[0]: expected a string, got 17 (line 12)`.

Units at this edge follow the aviation habit of the users (flight levels, UTC hours,
degrees); studies convert to SI with aerotruth.units.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import json
import typing
from typing import Annotated, Any, Literal

import yaml
from pydantic import (
    AfterValidator,
    BaseModel,
    Field,
    StrictBool,
    StrictInt,
    ValidationError,
    field_validator,
    model_validator,
)

from aerotruth.dates import MODEL_DATE_SPAN, MODEL_DAYS, check_model_date
from aerotruth.schema import Section  # re-exported: studies' sections derive from it

SEED_MAX = 2**63 - 1
"""The largest seed: seeds are 63-bit, like those aerotruth.seeds.int_seed derives for each
day and flight (the `--seed` values of a truth row's fly_command), so that every seed fits a
signed 64-bit column."""

MAX_WORKERS = 1024
"""The most worker processes a campaign may ask for: processes of one machine or of one
in-process Dask cluster (the largest hosts have a few hundred cores)."""

MAX_STORE_GB = 1e6
"""The largest truth-store cap in GB (a petabyte; a reduced campaign's truth is a few GB)."""


def _at_most(limit: int, why: str) -> AfterValidator:
    """An upper bound checked after the type (its refusal says why the bound is what it is)."""

    def check(value: int) -> int:
        if value > limit:
            raise ValueError(f"expected at most {limit} ({why}), got {describe_value(value)}")
        return value

    return AfterValidator(check)


# ----------------------------------------------------------------------------- schema


class ExecutorConfig(Section):
    """Where tasks run. The command line (--executor, --workers, --scheduler) overrides it."""

    kind: Literal["local", "dask"] = "local"
    workers: Annotated[StrictInt, _at_most(MAX_WORKERS, "the processes one machine can run")] | None = Field(
        default=None,
        ge=1,
        description="local: processes (default: cores); dask: LocalCluster workers (default 2); at most "
        f"{MAX_WORKERS}, the processes one machine can run",
    )
    scheduler: str | None = Field(default=None, description="address of a running Dask scheduler (implies kind: dask)")


class OutputsConfig(Section):
    """What a run writes besides the per-task tables and metrics.json."""

    dir: str | None = Field(default=None, description="run directory (default runs/<name>)")
    figures: StrictBool = True
    report: StrictBool = True


def _model_day(value: _dt.date) -> _dt.date:
    return check_model_date(value)


ModelDate = Annotated[_dt.date, AfterValidator(_model_day)]
"""A date of a campaign: in aerotruth.dates.MODEL_DATES (1900-01-01 to 2029-12-31)."""


class Period(Section):
    """A named set of UTC days: either `dates:` (a list) or `start:`/`end:` (inclusive),
    optionally every `every_days`-th day from start. Every day lies in 1900-01-01 to
    2029-12-31, the span of IGRF-14, the magnetic field model every flux valve and
    declination comes from (aerotruth.dates)."""

    name: str = Field(min_length=1, max_length=100)
    dates: list[ModelDate] | None = Field(default=None, description=f"the days, each in {MODEL_DATE_SPAN}")
    start: ModelDate | None = Field(default=None, description=f"first day (inclusive), in {MODEL_DATE_SPAN}")
    end: ModelDate | None = Field(default=None, description=f"last day (inclusive), in {MODEL_DATE_SPAN}")
    every_days: Annotated[StrictInt, _at_most(MODEL_DAYS, "the days from 1900 to 2029 that the models cover")] = Field(
        default=1,
        ge=1,
        description="with start/end: keep every N-th day from start (a long period subsampled); at most "
        f"{MODEL_DAYS}, the days from 1900 to 2029 that the models cover",
    )

    @model_validator(mode="after")
    def _one_form(self) -> Period:
        if self.dates is not None:
            if self.start is not None or self.end is not None:
                raise ValueError("give either dates or start/end, not both")
            if not self.dates:
                raise ValueError("dates: expected at least one date, got an empty list")
        elif self.start is None or self.end is None:
            raise ValueError("expected dates: [...] or both start: and end:")
        elif self.end < self.start:
            raise ValueError(f"end {self.end} is before start {self.start}")
        if self.dates is not None and self.every_days != 1:
            raise ValueError("every_days subsamples start/end periods; list the dates instead")
        return self

    def days(self) -> list[_dt.date]:
        """The period's days in calendar order, each once."""
        if self.dates is not None:
            return sorted(set(self.dates))
        n = (self.end - self.start).days + 1  # type: ignore[operator]
        return [self.start + _dt.timedelta(days=i) for i in range(0, n, self.every_days)]  # type: ignore[operator]


class Fleet(Section):
    """A group of aircraft flying one route network."""

    name: str = Field(min_length=1, max_length=100)
    aircraft_type: str | None = Field(default=None, description="aircraft model name (default: the project default)")
    network: str | None = Field(
        default=None, description="route network for the daily schedule (aerotruth.truth.routes)"
    )
    aircraft: list[str] = Field(description="tail numbers or other unique aircraft ids")

    @field_validator("aircraft")
    @classmethod
    def _not_empty(cls, v: list[str]) -> list[str]:
        if not v:
            raise ValueError("expected at least one aircraft, got an empty list")
        if len(set(v)) != len(v):
            dup = sorted({a for a in v if v.count(a) > 1})
            raise ValueError(f"aircraft ids must be unique, repeated: {', '.join(dup)}")
        return v


class TruthStoreConfig(Section):
    """Where flown truth is cached (shared by every run and campaign on this machine)."""

    path: str | None = Field(
        default=None, description="folder (default $AEROTRUTH_CACHE/truth, else the user's cache folder)"
    )
    max_gb: float = Field(
        default=20.0,
        gt=0,
        le=MAX_STORE_GB,
        allow_inf_nan=False,
        description="size cap; least recently used flights are evicted after a run; at most a petabyte "
        "(a reduced campaign's truth is a few GB)",
    )


class Campaign(Section):
    """A whole campaign file."""

    name: str = Field(
        pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$",
        max_length=100,
        description="also the default run directory runs/<name> (at most 100 characters: a folder name)",
    )
    seed: Annotated[StrictInt, _at_most(SEED_MAX, "2^63 - 1: seeds are 63-bit")] = Field(
        ge=0,
        description="campaign seed: every task stream is SeedSequence(seed, spawn_key=digest(task)); 0 to "
        "2^63 - 1, the 63-bit seeds `aerotruth fly --seed` takes",
    )
    description: str = ""
    fleets: list[Fleet] = Field(default_factory=list)
    periods: list[Period] = Field(min_length=1)
    study_modules: list[str] = Field(
        default_factory=list,
        description="extra study modules: importable module names or .py files (relative to the YAML file). "
        "They are code: each is imported, and so runs, whenever the campaign is read (`aerotruth validate`, "
        "`run`, `diagnose --model`); name only modules you trust",
    )
    studies: dict[str, Any] = Field(description="one section per study, validated by that study's own schema")
    truth_store: TruthStoreConfig = TruthStoreConfig()
    executor: ExecutorConfig = ExecutorConfig()
    outputs: OutputsConfig = OutputsConfig()
    sizes: dict[str, dict[str, Any]] = Field(
        default_factory=dict,
        description="named reduced (or other) sizes: overrides merged into the campaign by "
        "`aerotruth run --size NAME` (mappings merge key by key, lists and values replace)",
    )
    size: str | None = Field(default=None, description="the size applied (set by --size; not written by hand)")
    diagnose: dict[str, Any] = Field(
        default_factory=dict,
        description="what `aerotruth diagnose` assumes beyond the "
        "studies' sensors (wind: aerotruth.analysis.diagnose.wind.WindModelSpec); written by "
        "diagnose into the extended model",
    )

    @field_validator("diagnose")
    @classmethod
    def _diagnose_models(cls, v: dict) -> dict:
        unknown = set(v) - {"wind"}
        if unknown:
            raise ValueError(f"unknown diagnose model {sorted(unknown)[0]!r}, expected 'wind'")
        if "wind" in v:
            from aerotruth.analysis.diagnose.wind import WindModelSpec

            WindModelSpec.model_validate(v["wind"])
        return v

    def fleet(self, name: str) -> Fleet:
        """The fleet called `name`."""
        return next(f for f in self.fleets if f.name == name)

    def period(self, name: str) -> Period:
        """The period called `name`."""
        return next(p for p in self.periods if p.name == name)

    def days(self, period_names) -> list:
        """The sorted distinct dates of the named periods (what a study's tasks span)."""
        return sorted({d for name in period_names for d in self.period(name).days()})

    def section(self, study: str) -> Section:
        """The validated section of `study`."""
        return self.studies[study]

    def results_json(self, study: str | None = None) -> str:
        """Canonical JSON of what determines results: seed, fleets, periods and the study
        sections (all of them, or only `study`'s); not the executor, outputs, description
        or where truth is cached."""
        data = self.model_dump(
            mode="json",
            by_alias=True,
            exclude={"executor", "outputs", "description", "truth_store", "study_modules", "diagnose"},
        )
        if study is not None:
            data["studies"] = {study: data["studies"][study]}
        return json.dumps(data, sort_keys=True, separators=(",", ":"))

    def config_hash(self) -> str:
        """sha256 of everything that determines results (not executor or outputs)."""
        return hashlib.sha256(self.results_json().encode()).hexdigest()

    def to_yaml(self) -> str:
        """The resolved campaign (all defaults filled in) as YAML that load_campaign reads back."""
        return yaml.safe_dump(self.model_dump(mode="json", by_alias=True), sort_keys=False, allow_unicode=True)


# ----------------------------------------------------------------------------- errors


from aerotruth.errors import ConfigError  # noqa: E402  (re-exported: campaign problems are user errors)

_EXPECTED = {
    "int_parsing": "an integer",
    "int_type": "an integer",
    "int_from_float": "an integer",
    "float_parsing": "a number",
    "float_type": "a number",
    "finite_number": "a finite number",
    "bool_parsing": "true or false",
    "bool_type": "true or false",
    "string_type": "a string",
    "date_parsing": "a date YYYY-MM-DD",
    "date_from_datetime_parsing": "a date YYYY-MM-DD",
    "date_from_datetime_inexact": "a date YYYY-MM-DD",
    "date_type": "a date YYYY-MM-DD",
    "time_parsing": "a time HH:MM",
    "time_type": "a time HH:MM",
    "list_type": "a list",
    "tuple_type": "a list",
    "model_type": "a mapping",
    "model_attributes_type": "a mapping",
    "dict_type": "a mapping",
}


_BOUNDS = {"greater_than_equal": ">=", "greater_than": ">", "less_than_equal": "<=", "less_than": "<"}


def describe_value(value: Any) -> str:
    """A short rendering of the offending YAML value."""
    if isinstance(value, str):
        s = value if len(value) <= 40 else value[:37] + "..."
        return json.dumps(s, ensure_ascii=False)
    if isinstance(value, dict):
        return "a mapping"
    if isinstance(value, list):
        return f"a list of {len(value)}"
    if value is None:
        return "nothing (null)"
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**20:
        return f"an integer of {len(str(abs(value)))} digits"
    return json.dumps(value) if isinstance(value, (int, float, bool)) else repr(value)


def format_path(loc: tuple[Any, ...]) -> str:
    """('fleets', 2, 'heading', 'hard_iron_nT') -> 'fleets[2].heading.hard_iron_nT'."""
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out or "(top level)"


def line_of(root: yaml.Node | None, loc: tuple[Any, ...]) -> int | None:
    """1-based line of the YAML node at `loc`; the deepest existing ancestor when the path
    does not exist in the file (a missing field points at its parent mapping)."""
    if root is None:
        return None
    node = root
    line = node.start_mark.line + 1
    for part in loc:
        if isinstance(node, yaml.MappingNode):
            match = next(
                ((k, v) for k, v in node.value if isinstance(k, yaml.ScalarNode) and k.value == str(part)), None
            )
            if match is None:
                return line
            line = match[0].start_mark.line + 1
            node = match[1]
        elif isinstance(node, yaml.SequenceNode) and isinstance(part, int) and 0 <= part < len(node.value):
            node = node.value[part]
            line = node.start_mark.line + 1
        else:
            return line
    return line


def _key_name(key: yaml.Node) -> str:
    """A mapping key as a path part: a scalar's text; a list or mapping used as a key (YAML
    allows it, no campaign field is one) by its kind and line, never by its contents."""
    if isinstance(key, yaml.ScalarNode):
        return str(key.value)
    return f"<{'list' if isinstance(key, yaml.SequenceNode) else 'mapping'} key of line {key.start_mark.line + 1}>"


def check_duplicate_keys(node: yaml.Node | None, loc: tuple[Any, ...] = ()) -> None:
    """PyYAML keeps the last of repeated keys silently; a campaign file must not.

    Each node is visited once, at the first path that reaches it: a block that aliases
    (`*name`) repeat is one node in the composed graph, so the walk is linear in the file,
    never in the expanded document (an alias bomb), and ends on recursive aliases."""
    visited: set[int] = set()
    stack: list[tuple[yaml.Node | None, tuple[Any, ...]]] = [(node, loc)]
    while stack:
        current, where = stack.pop()
        if current is None or id(current) in visited:
            continue
        visited.add(id(current))
        if isinstance(current, yaml.MappingNode):
            seen: set[str] = set()
            keys = [_key_name(k) for k, _ in current.value]
            for key, (k, _) in zip(keys, current.value, strict=True):
                if key in seen:
                    raise ConfigError(f"{format_path(where + (key,))}: duplicate key (line {k.start_mark.line + 1})")
                seen.add(key)
            stack.extend((v, where + (key,)) for key, (_, v) in reversed(list(zip(keys, current.value, strict=True))))
        elif isinstance(current, yaml.SequenceNode):
            stack.extend((v, where + (i,)) for i, v in reversed(list(enumerate(current.value))))


def one_line_error(
    err: ValidationError, root: yaml.Node | None, fields_of: type[BaseModel], prefix: tuple[Any, ...] = ()
) -> str:
    """The first validation error as `path: expected ..., got ... (line N)`; `prefix` is
    the YAML path of the block `fields_of` validated (e.g. ("studies", "truth"))."""
    errors = err.errors(include_url=False)
    e = errors[0]
    loc = tuple(e["loc"])
    kind = e["type"]
    path = format_path(prefix + loc)
    if kind == "missing":
        text = "required field missing"
    elif kind == "extra_forbidden":
        parent = _model_at(fields_of, loc[:-1])
        allowed = f" (allowed: {', '.join(_field_names(parent))})" if parent is not None else ""
        text = f"unknown key{allowed}"
    elif kind in _EXPECTED:
        text = f"expected {_EXPECTED[kind]}, got {describe_value(e.get('input'))}"
    elif kind == "literal_error":
        text = f"expected one of {e['ctx']['expected']}, got {describe_value(e.get('input'))}"
    elif kind == "too_short":
        n = e["ctx"]["min_length"]
        text = f"expected at least {n} item{'s' if n != 1 else ''}, got {e['ctx'].get('actual_length', 0)}"
    elif kind == "string_too_long":
        n = e["ctx"]["max_length"]
        got = e.get("input")
        text = f"expected at most {n} characters, got {len(got) if isinstance(got, str) else describe_value(got)}"
    elif kind == "too_long":
        n = e["ctx"]["max_length"]
        text = f"expected at most {n} item{'s' if n != 1 else ''}, got {e['ctx'].get('actual_length')}"
    elif kind in _BOUNDS:
        bound = next(v for k, v in e["ctx"].items() if k in ("ge", "gt", "le", "lt"))
        text = f"expected a number {_BOUNDS[kind]} {bound}, got {describe_value(e.get('input'))}"
    elif kind == "string_pattern_mismatch" and loc == ("name",):
        text = (
            "expected a name of letters, digits, '_', '.' and '-' (it names the run directory), "
            f"got {describe_value(e.get('input'))}"
        )
    elif kind == "value_error":
        text = str(e["ctx"]["error"])
    else:
        text = f"{e['msg'][0].lower()}{e['msg'][1:]}, got {describe_value(e.get('input'))}"
    line = line_of(root, prefix + loc)
    more = f"; and {len(errors) - 1} more error{'s' if len(errors) > 2 else ''}" if len(errors) > 1 else ""
    return f"{path}: {text}" + (f" (line {line})" if line is not None else "") + more


def _field_names(model: type[BaseModel]) -> list[str]:
    return [(f.alias or name) for name, f in model.model_fields.items()]


def _model_at(model: type[BaseModel], loc: tuple[Any, ...]) -> type[BaseModel] | None:
    """The schema class found at `loc` (for naming the allowed keys of an unknown key)."""
    current: Any = model
    for part in loc:
        if isinstance(part, int):
            continue
        if not (isinstance(current, type) and issubclass(current, BaseModel)):
            return None
        field = next((f for n, f in current.model_fields.items() if part in (n, f.alias)), None)
        if field is None:
            return None
        current = field.annotation
        # unwrap Optional[...] and list[...] down to a model class
        for _ in range(3):
            args = [a for a in typing.get_args(current) if a is not type(None)]
            if isinstance(current, type) and issubclass(current, BaseModel):
                break
            if not args:
                break
            current = args[0]
    return current if isinstance(current, type) and issubclass(current, BaseModel) else None


class References:
    """What a study's `check` uses to test the names in its section against the campaign
    (fleets, periods, airports, ...) and to word a problem as one line with its YAML line."""

    def __init__(self, campaign: Campaign, root: yaml.Node | None, prefix: tuple[Any, ...]):
        self.campaign = campaign
        self._root = root
        self._prefix = prefix

    def error(self, loc: tuple[Any, ...], text: str, *, absolute: bool = False) -> ConfigError:
        """ConfigError `path: text (line N)`; `loc` is relative to the section unless absolute."""
        full = tuple(loc) if absolute else self._prefix + tuple(loc)
        line = line_of(self._root, full)
        return ConfigError(f"{format_path(full)}: {text}" + (f" (line {line})" if line is not None else ""))

    @property
    def where(self) -> str:
        """The YAML path of the section, e.g. `studies.truth`."""
        return format_path(self._prefix)

    def names(self, field: str | tuple[Any, ...], kind: str) -> None:
        """Each name in the section's `field` (a name or a list of names; a path relative
        to the section) must be that of one of the campaign's `kind` ("fleets" or "periods")."""
        path = (field,) if isinstance(field, str) else tuple(field)
        values: Any = self.campaign.section(self._prefix[-1])
        for part in path:
            values = values[part] if isinstance(part, int) else getattr(values, part, None)
        known = {x.name for x in getattr(self.campaign, kind)}
        items = [values] if isinstance(values, str) else list(values or [])
        for i, ref in enumerate(items):
            if ref not in known:
                have = ", ".join(sorted(known)) or "none defined"
                loc = path if isinstance(values, str) else path + (i,)
                raise self.error(loc, f"expected the name of one of the {kind} ({have}), got {describe_value(ref)}")

    def fleets(self, field: str = "fleets") -> None:
        """The section's `field` names defined fleets."""
        self.names(field, "fleets")

    def periods(self, field: str = "periods") -> None:
        """The section's `field` names defined periods."""
        self.names(field, "periods")

    def value(self, value: Any) -> str:
        """A short rendering of an offending value for a message."""
        return describe_value(value)
