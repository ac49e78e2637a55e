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
from pathlib import Path
from typing import Any, Literal

import yaml
from pydantic import BaseModel, ConfigDict, Field, StrictBool, StrictInt, ValidationError, field_validator, model_validator

# ----------------------------------------------------------------------------- schema


class Section(BaseModel):
    """Base of every schema block: unknown keys are errors, values are immutable."""

    model_config = ConfigDict(extra="forbid", frozen=True, populate_by_name=True)


class ExecutorConfig(Section):
    """Where tasks run. The command line (--executor, --workers, --scheduler) overrides it."""

    kind: Literal["local", "dask"] = "local"
    workers: StrictInt | None = Field(default=None, ge=1, description="local: processes (default: cores); dask: LocalCluster workers (default 2)")
    scheduler: str | None = Field(default=None, description="address of a running Dask scheduler (implies kind: dask)")


class OutputsConfig(Section):
    """What a run writes besides the per-task tables and metrics.json."""

    dir: str | None = Field(default=None, description="run directory (default runs/<name>)")
    figures: StrictBool = True
    report: StrictBool = True


class Period(Section):
    """A named set of UTC days: either `dates:` (a list) or `start:`/`end:` (inclusive)."""

    name: str = Field(min_length=1)
    dates: list[_dt.date] | None = None
    start: _dt.date | None = None
    end: _dt.date | None = None

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
        return self

    def days(self) -> list[_dt.date]:
        """The period's days in calendar order, each once."""
        if self.dates is not None:
            return sorted(set(self.dates))
        n = (self.end - self.start).days + 1  # type: ignore[operator]
        return [self.start + _dt.timedelta(days=i) for i in range(n)]  # type: ignore[operator]


class Fleet(Section):
    """A group of aircraft flying one route network."""

    name: str = Field(min_length=1)
    aircraft_type: str | None = Field(default=None, description="aircraft model name (default: the project default)")
    network: str | None = Field(default=None, description="route network for the daily schedule (aerotruth.truth.routes)")
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


class LegSpec(Section):
    """One fixed leg: departure and arrival airports (ICAO) and the departure time (UTC)."""

    origin: str = Field(alias="from", min_length=3)
    destination: str = Field(alias="to", min_length=3)
    departure_utc: _dt.time = Field(default=_dt.time(12, 0), description="HH:MM UTC")


class TruthStudyConfig(Section):
    """Truth flights: every aircraft of the named fleets flies each day of the named periods,
    either its generated daily schedule or the fixed `legs:` list."""

    fleets: list[str] = Field(min_length=1)
    periods: list[str] = Field(min_length=1)
    legs: list[LegSpec] | None = Field(default=None, description="fly these legs every aircraft-day instead of a schedule")
    max_legs_per_day: StrictInt | None = Field(default=None, ge=1, description="keep only the first N legs of each day")
    turbulence: StrictBool = False


class RegionBox(Section):
    """A latitude/longitude box (degrees) sampled by the wind climatology: given as
    `lat_deg: [south, north]` and `lon_deg: [west, east]`, or as `network:` (the box around
    that route network's airports, NETWORK_MARGIN_DEG wider on each side)."""

    name: str = Field(min_length=1)
    network: str | None = None
    lat_deg: tuple[float, float] | None = None
    lon_deg: tuple[float, float] | None = None

    @model_validator(mode="after")
    def _ordered(self) -> RegionBox:
        if self.network is not None:
            if self.lat_deg is not None or self.lon_deg is not None:
                raise ValueError("give either network or lat_deg/lon_deg, not both")
            return self
        if self.lat_deg is None or self.lon_deg is None:
            raise ValueError("expected network: NAME or both lat_deg: [south, north] and lon_deg: [west, east]")
        (la0, la1), (lo0, lo1) = self.lat_deg, self.lon_deg
        if not (-90.0 <= la0 < la1 <= 90.0):
            raise ValueError(f"lat_deg: expected [south, north] within [-90, 90], got [{la0}, {la1}]")
        if not (-180.0 <= lo0 < lo1 <= 180.0):
            raise ValueError(f"lon_deg: expected [west, east] within [-180, 180], got [{lo0}, {lo1}]")
        return self


class WindClimatologyConfig(Section):
    """Wind statistics of the truth atmosphere: each region is sampled at random points at the
    given flight levels and UTC hours, one task per region and day."""

    regions: list[RegionBox] = Field(min_length=1)
    periods: list[str] = Field(min_length=1)
    flight_levels: list[StrictInt] = Field(default=[50, 100, 150, 200, 250], min_length=1, description="hundreds of feet")
    hours_utc: list[float] = Field(default=[0.0, 6.0, 12.0, 18.0], min_length=1)
    points: StrictInt = Field(default=36, ge=1, le=1_000_000, description="random sample points per level and hour, uniform over the box area")

    @field_validator("flight_levels")
    @classmethod
    def _levels(cls, v: list[int]) -> list[int]:
        for fl in v:
            if not 0 <= fl <= 450:
                raise ValueError(f"expected flight levels within 0..450, got {fl}")
        if len(set(v)) != len(v):
            raise ValueError("flight levels must be unique")
        return v

    @field_validator("hours_utc")
    @classmethod
    def _hours(cls, v: list[float]) -> list[float]:
        for h in v:
            if not 0.0 <= h < 24.0:
                raise ValueError(f"expected hours within [0, 24), got {h}")
        return v


class StudiesConfig(Section):
    """One optional section per study type (aerotruth.sim.studies registers their runners)."""

    truth: TruthStudyConfig | None = None
    wind_climatology: WindClimatologyConfig | None = None

    @model_validator(mode="after")
    def _at_least_one(self) -> StudiesConfig:
        if all(getattr(self, f) is None for f in type(self).model_fields):
            raise ValueError(f"expected at least one study ({', '.join(type(self).model_fields)})")
        return self

    def present(self) -> dict[str, Section]:
        """The configured study sections by name, in schema order."""
        return {f: getattr(self, f) for f in type(self).model_fields if getattr(self, f) is not None}


class Campaign(Section):
    """A whole campaign file."""

    name: str = Field(pattern=r"^[A-Za-z0-9][A-Za-z0-9_.-]*$", description="also the default run directory runs/<name>")
    seed: StrictInt = Field(ge=0, description="campaign seed: every task stream is SeedSequence(seed, spawn_key=digest(task))")
    description: str = ""
    fleets: list[Fleet] = Field(default_factory=list)
    periods: list[Period] = Field(min_length=1)
    studies: StudiesConfig
    executor: ExecutorConfig = ExecutorConfig()
    outputs: OutputsConfig = OutputsConfig()

    def fleet(self, name: str) -> Fleet:
        """The fleet called `name`."""
        return next(f for f in self.fleets if f.name == name)

    def period(self, name: str) -> Period:
        """The period called `name`."""
        return next(p for p in self.periods if p.name == name)

    def days(self, period_names) -> list:
        """The sorted distinct dates of the named periods (what a study's tasks span)."""
        return sorted({d for name in period_names for d in self.period(name).days()})

    def config_hash(self) -> str:
        """sha256 of everything that determines results (not executor or outputs)."""
        data = self.model_dump(mode="json", by_alias=True, exclude={"executor", "outputs", "description"})
        return hashlib.sha256(json.dumps(data, sort_keys=True, separators=(",", ":")).encode()).hexdigest()

    def to_yaml(self) -> str:
        """The resolved campaign (all defaults filled in) as YAML that load_campaign reads back."""
        return yaml.safe_dump(self.model_dump(mode="json", by_alias=True), sort_keys=False, allow_unicode=True)


# ----------------------------------------------------------------------------- errors


class ConfigError(ValueError):
    """A campaign file problem, already worded as one line: `path: what was expected (line N)`."""


class _NoTimestampLoader(yaml.SafeLoader):
    """SafeLoader that leaves dates as strings so that pydantic reports a bad date by path
    (PyYAML would otherwise fail on 2009-02-30 with its own message)."""


_NoTimestampLoader.yaml_implicit_resolvers = {
    ch: [(tag, rx) for tag, rx in resolvers if tag != "tag:yaml.org,2002:timestamp"]
    for ch, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}

_EXPECTED = {
    "int_parsing": "an integer",
    "int_type": "an integer",
    "int_from_float": "an integer",
    "float_parsing": "a number",
    "float_type": "a number",
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


def _describe(value: Any) -> str:
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


def _line_of(root: yaml.Node | None, loc: tuple[Any, ...]) -> int | None:
    """1-based line of the YAML node at `loc`; the deepest existing ancestor when the path
    does not exist in the file (a missing field points at its parent mapping)."""
    if root is None:
        return None
    node = root
    line = node.start_mark.line + 1
    for part in loc:
        if isinstance(node, yaml.MappingNode):
            match = next(((k, v) for k, v in node.value if isinstance(k, yaml.ScalarNode) and k.value == str(part)), None)
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


def _check_duplicate_keys(node: yaml.Node | None, loc: tuple[Any, ...] = ()) -> None:
    """PyYAML keeps the last of repeated keys silently; a campaign file must not."""
    if isinstance(node, yaml.MappingNode):
        seen: set[str] = set()
        for k, v in node.value:
            key = k.value if isinstance(k, yaml.ScalarNode) else str(k)
            if key in seen:
                raise ConfigError(f"{format_path(loc + (key,))}: duplicate key (line {k.start_mark.line + 1})")
            seen.add(key)
            _check_duplicate_keys(v, loc + (key,))
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            _check_duplicate_keys(v, loc + (i,))


def _one_line(err: ValidationError, root: yaml.Node | None, fields_of: type[BaseModel]) -> str:
    """The first validation error as `path: expected ..., got ... (line N)`."""
    errors = err.errors(include_url=False)
    e = errors[0]
    loc = tuple(e["loc"])
    kind = e["type"]
    path = format_path(loc)
    if kind == "missing":
        text = "required field missing"
    elif kind == "extra_forbidden":
        parent = _model_at(fields_of, loc[:-1])
        allowed = f" (allowed: {', '.join(_field_names(parent))})" if parent is not None else ""
        text = f"unknown key{allowed}"
    elif kind in _EXPECTED:
        text = f"expected {_EXPECTED[kind]}, got {_describe(e.get('input'))}"
    elif kind == "literal_error":
        text = f"expected one of {e['ctx']['expected']}, got {_describe(e.get('input'))}"
    elif kind == "too_short":
        n = e["ctx"]["min_length"]
        text = f"expected at least {n} item{'s' if n != 1 else ''}, got {e['ctx'].get('actual_length', 0)}"
    elif kind == "too_long":
        n = e["ctx"]["max_length"]
        text = f"expected at most {n} item{'s' if n != 1 else ''}, got {e['ctx'].get('actual_length')}"
    elif kind in _BOUNDS:
        bound = next(v for k, v in e["ctx"].items() if k in ("ge", "gt", "le", "lt"))
        text = f"expected a number {_BOUNDS[kind]} {bound}, got {_describe(e.get('input'))}"
    elif kind == "string_pattern_mismatch" and loc == ("name",):
        text = f"expected a name of letters, digits, '_', '.' and '-' (it names the run directory), got {_describe(e.get('input'))}"
    elif kind == "value_error":
        text = str(e["ctx"]["error"])
    else:
        text = f"{e['msg'][0].lower()}{e['msg'][1:]}, got {_describe(e.get('input'))}"
    line = _line_of(root, loc)
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


def _check_references(c: Campaign, root: yaml.Node | None) -> None:
    """Names used under studies must be defined under fleets/periods; names must be unique."""
    for what, items in (("fleets", c.fleets), ("periods", c.periods)):
        seen: set[str] = set()
        for i, item in enumerate(items):
            if item.name in seen:
                loc = (what, i, "name")
                raise ConfigError(f"{format_path(loc)}: duplicate name {item.name!r} (line {_line_of(root, loc)})")
            seen.add(item.name)
    fleets = {f.name for f in c.fleets}
    periods = {p.name for p in c.periods}
    for study, section in c.studies.present().items():
        for field, known in (("fleets", fleets), ("periods", periods)):
            for i, ref in enumerate(getattr(section, field, None) or []):
                if ref not in known:
                    loc = ("studies", study, field, i)
                    have = ", ".join(sorted(known)) or "none defined"
                    raise ConfigError(f"{format_path(loc)}: expected the name of one of the {field} ({have}), got {_describe(ref)} (line {_line_of(root, loc)})")
        regions = getattr(section, "regions", None)
        if regions:
            names = [r.name for r in regions]
            for i, n in enumerate(names):
                if names.index(n) != i:
                    loc = ("studies", study, "regions", i, "name")
                    raise ConfigError(f"{format_path(loc)}: duplicate name {n!r} (line {_line_of(root, loc)})")
    from aerotruth.truth.airports import networks

    known_networks = networks()
    named = [(("fleets", i, "network"), f.network) for i, f in enumerate(c.fleets)]
    wind = c.studies.wind_climatology
    if wind is not None:
        named += [(("studies", "wind_climatology", "regions", i, "network"), r.network) for i, r in enumerate(wind.regions)]
    for loc, net in named:
        if net is not None and net not in known_networks:
            raise ConfigError(
                f"{format_path(loc)}: expected a route network ({', '.join(sorted(known_networks))}), got {_describe(net)} (line {_line_of(root, loc)})"
            )
    truth = c.studies.truth
    if truth is not None and truth.legs is not None:
        from aerotruth.truth.airports import airports

        known_airports = airports()
        for i, leg in enumerate(truth.legs):
            for key, code in (("from", leg.origin), ("to", leg.destination)):
                if code not in known_airports:
                    loc = ("studies", "truth", "legs", i, key)
                    raise ConfigError(
                        f"{format_path(loc)}: expected the ICAO code of an airport in the embedded table, got {_describe(code)} (line {_line_of(root, loc)})"
                    )
            if leg.origin == leg.destination:
                loc = ("studies", "truth", "legs", i)
                raise ConfigError(f"{format_path(loc)}: from and to are the same airport {leg.origin} (line {_line_of(root, loc)})")
    if truth is not None and truth.legs is None:
        for i, name in enumerate(truth.fleets):
            if c.fleet(name).network is None:
                j = next(k for k, f in enumerate(c.fleets) if f.name == name)
                loc = ("fleets", j, "network")
                raise ConfigError(
                    f"{format_path(loc)}: required by studies.truth (no fixed legs given), expected a route network name (line {_line_of(root, ('fleets', j))})"
                )


def parse_campaign(text: str) -> Campaign:
    """Validate campaign YAML text; any problem raises ConfigError with one line."""
    try:
        root = yaml.compose(text, Loader=_NoTimestampLoader)
        data = yaml.load(text, Loader=_NoTimestampLoader)
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
        raise ConfigError(f"not valid YAML: {e.problem or e.context}{where}") from None
    except yaml.YAMLError as e:
        raise ConfigError(f"not valid YAML: {e}") from None
    if not isinstance(data, dict):
        raise ConfigError(f"expected a mapping of campaign fields at the top level, got {_describe(data)}")
    _check_duplicate_keys(root)
    try:
        campaign = Campaign.model_validate(data)
    except ValidationError as e:
        raise ConfigError(_one_line(e, root, Campaign)) from None
    _check_references(campaign, root)
    return campaign


def load_campaign(path: str | Path) -> Campaign:
    """Read and validate a campaign YAML file (ConfigError with one line on any problem)."""
    p = Path(path)
    try:
        text = p.read_text(encoding="utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such campaign file") from None
    except (IsADirectoryError, UnicodeDecodeError) as e:
        raise ConfigError(f"{p}: cannot read campaign file ({e})") from None
    try:
        return parse_campaign(text)
    except ConfigError as e:
        raise ConfigError(f"{p}: {e}") from None
