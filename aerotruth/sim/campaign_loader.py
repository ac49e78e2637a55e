"""Loading a campaign YAML file: the YAML read (no timestamps or base-60 numbers, duplicate
keys refused, `sizes:` overrides applied), the schema of aerotruth.sim.campaign_file, the
checks across its blocks, and each study's own section validated by that study's schema
(the registry of aerotruth.sim.studies, with the campaign's `study_modules:`). Every problem
is one ConfigError naming the YAML path of the field and its line.

The read is bounded before anything is built from it, whatever the file holds: at most
MAX_FILE_BYTES of a regular file; at most MAX_NODES values once every alias (`*name`) is
expanded (a few hundred bytes of nested aliases, a "billion laughs", would otherwise expand
to billions); at most MAX_DEPTH levels of nesting (YAML or JSON; a deeper file would exhaust
Python's stack); no recursive alias; integers of at most 64 bits and finite numbers; only
the YAML tags a campaign can mean (strings, numbers, booleans, null, lists, mappings).

It sits above both the schema and the study registry, which needs the schema's types."""

from __future__ import annotations

import math
import re
import stat
from pathlib import Path
from typing import Any

import yaml
from pydantic import ValidationError

from aerotruth.errors import ConfigError
from aerotruth.schema import Section
from aerotruth.sim.campaign_file import (
    Campaign,
    References,
    check_duplicate_keys,
    describe_value,
    format_path,
    line_of,
    one_line_error,
)


def _check_campaign(c: Campaign, root: yaml.Node | None) -> None:
    """Checks across the campaign's own blocks: unique fleet and period names, known route
    networks and aircraft types."""
    for what, items in (("fleets", c.fleets), ("periods", c.periods)):
        seen: set[str] = set()
        for i, item in enumerate(items):
            if item.name in seen:
                loc = (what, i, "name")
                raise ConfigError(f"{format_path(loc)}: duplicate name {item.name!r} (line {line_of(root, loc)})")
            seen.add(item.name)
    if any(f.network is not None for f in c.fleets):
        from aerotruth.truth.airports import networks

        known_networks = networks()
        for i, f in enumerate(c.fleets):
            if f.network is not None and f.network not in known_networks:
                loc = ("fleets", i, "network")
                raise ConfigError(
                    f"{format_path(loc)}: expected a route network ({', '.join(sorted(known_networks))}), "
                    f"got {describe_value(f.network)} (line {line_of(root, loc)})"
                )
    if any(f.aircraft_type is not None for f in c.fleets):
        from aerotruth.truth.airframes import airframe_names

        known = airframe_names()
        for i, f in enumerate(c.fleets):
            if f.aircraft_type is not None and f.aircraft_type not in known:
                loc = ("fleets", i, "aircraft_type")
                raise ConfigError(
                    f"{format_path(loc)}: expected an aircraft type ({', '.join(known)}), "
                    f"got {describe_value(f.aircraft_type)} (line {line_of(root, loc)})"
                )


def _resolve_study_modules(c: Campaign, root: yaml.Node | None, base_dir: Path | None) -> list[str]:
    """`study_modules:` entries as import sources: a `.py` file becomes `file:<absolute
    path>` (relative to the YAML file's folder), anything else `module:<name>`."""
    from aerotruth.sim.studies import source_for

    out = []
    for i, entry in enumerate(c.study_modules):
        try:
            out.append(source_for(entry, base_dir))
        except ValueError as e:
            loc = ("study_modules", i)
            raise ConfigError(f"{format_path(loc)}: {e} (line {line_of(root, loc)})") from None
    return out


def _validate_studies(c: Campaign, root: yaml.Node | None, base_dir: Path | None) -> Campaign:
    """Validate each `studies:` section with its study's own schema and run its checks."""
    from aerotruth.sim.studies import StudyError, registry

    sources = _resolve_study_modules(c, root, base_dir)
    try:
        reg = registry(sources)
    except StudyError as e:
        raise ConfigError(f"study_modules: {e}") from None
    if not c.studies:
        raise ConfigError(
            f"studies: expected at least one study ({', '.join(reg)}) (line {line_of(root, ('studies',))})"
        )
    sections: dict[str, Section] = {}
    for name, value in c.studies.items():
        loc = ("studies", name)
        if name not in reg:
            raise ConfigError(
                f"{format_path(loc)}: unknown study (available: {', '.join(sorted(reg))}) (line {line_of(root, loc)})"
            )
        study = reg.get(name)
        try:
            sections[name] = study.Config.model_validate(
                {} if value is None else value, context={"base_dir": base_dir}
            )  # relative data files: the YAML's folder
        except ValidationError as e:
            raise ConfigError(one_line_error(e, root, study.Config, prefix=loc)) from None
    c = c.model_copy(update={"studies": sections, "study_modules": [s.split(":", 1)[1] for s in sources]})
    for name in sections:
        reg.get(name).check(c, References(c, root, ("studies", name)))
    return c


MAX_FILE_BYTES = 8 * 2**20
"""The largest campaign file read (8 MiB; the campaigns shipped are 1-12 kB)."""

MAX_NODES = 100_000
"""The most values (scalars, lists, mappings) a campaign file may hold with its aliases
expanded; the campaigns shipped hold 80-500."""

MAX_DEPTH = 40
"""The deepest nesting of a campaign file (the campaigns shipped nest 7-9 levels)."""

_TAG = "tag:yaml.org,2002:"
_PLAIN_TAGS = {_TAG + t for t in ("str", "int", "float", "bool", "null", "seq", "map", "merge")}


class _CampaignLoader(yaml.SafeLoader):
    """SafeLoader that leaves dates as strings (so that pydantic reports a bad date by its
    path; PyYAML would fail on 2009-02-30 with its own message), reads no YAML 1.1
    sexagesimal numbers (unquoted `13:00` would otherwise be the integer 780), and bounds
    what it composes (the module docstring): each node's expanded size and height are
    counted as it is composed, so an alias adds what it stands for without being walked."""

    def __init__(self, stream: str):
        super().__init__(stream)
        self._path: list[Any] = []
        self._stats: dict[int, tuple[int, int]] = {}  # id(node) -> (expanded size, height)
        self._expanded = 0

    def _refuse(self, text: str, mark: Any) -> ConfigError:
        path = tuple(self._path)
        shown = format_path(path[:4]) + ("..." if len(path) > 4 else "") if path else "(top level)"
        return ConfigError(f"{shown}: {text}" + (f" (line {mark.line + 1})" if mark is not None else ""))

    def _count(self, n: int, mark: Any) -> None:
        self._expanded += n
        if self._expanded > MAX_NODES:
            raise self._refuse(
                f"the file expands to more than {MAX_NODES:,} values with its aliases (*name) repeated; "
                "a campaign holds a few hundred",
                mark,
            )

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:
        if parent is None:
            part = None
        elif isinstance(index, yaml.ScalarNode):
            part = index.value
        elif isinstance(index, int):
            part = index
        else:
            part = "<key>"
        if part is not None:
            self._path.append(part)
        try:
            event = self.peek_event()
            if len(self._path) > MAX_DEPTH:
                raise self._refuse(
                    f"nested more than {MAX_DEPTH} levels deep; a campaign nests under 12", event.start_mark
                )
            if isinstance(event, yaml.AliasEvent):
                node = super().compose_node(parent, index)
                known = self._stats.get(id(node))
                if known is None:
                    raise self._refuse(
                        f"the alias *{event.anchor} refers to a block that contains it", event.start_mark
                    )
                if len(self._path) + known[1] - 1 > MAX_DEPTH:
                    raise self._refuse(
                        f"nested more than {MAX_DEPTH} levels deep through the alias *{event.anchor}", event.start_mark
                    )
                self._count(known[0], event.start_mark)
                return node
            self._count(1, event.start_mark)
            node = super().compose_node(parent, index)
            assert node is not None  # an event other than an alias always makes a node
            self._check_node(node)
            if isinstance(node, yaml.ScalarNode):
                self._stats[id(node)] = (1, 1)
            else:
                kids = [x for item in node.value for x in (item if isinstance(item, tuple) else (item,))]
                stats = [self._stats[id(k)] for k in kids]
                self._stats[id(node)] = (1 + sum(s[0] for s in stats), 1 + max((s[1] for s in stats), default=0))
            return node
        finally:
            if part is not None:
                self._path.pop()

    def _check_node(self, node: yaml.Node) -> None:
        """Only the plain tags; integers of at most 64 bits, finite numbers, true/false."""
        mark = node.start_mark
        if node.tag not in _PLAIN_TAGS:
            tag = "!!" + node.tag[len(_TAG) :] if node.tag.startswith(_TAG) else node.tag
            raise self._refuse(
                f"the YAML tag {tag} is not one a campaign uses (strings, numbers, lists, mappings)", mark
            )
        if not isinstance(node, yaml.ScalarNode) or node.tag not in (_TAG + "int", _TAG + "float", _TAG + "bool"):
            return
        shown = describe_value(node.value)
        if node.tag == _TAG + "int":
            value = None
            if len(node.value) <= 100:  # int() of a longer text is slow, beyond 4,300 digits an error
                try:
                    value = self.construct_yaml_int(node)
                except ValueError:
                    raise self._refuse(f"expected an integer, got {shown}", mark) from None
            if value is None or abs(value).bit_length() > 64:
                digits = len(node.value.lstrip("+-").replace("_", ""))
                raise self._refuse(
                    f"expected an integer of at most 64 bits (every campaign integer fits one), got {digits} digits",
                    mark,
                )
        elif node.tag == _TAG + "float":
            try:
                number = self.construct_yaml_float(node)
            except ValueError:
                raise self._refuse(f"expected a number, got {shown}", mark) from None
            if not math.isfinite(number):
                raise self._refuse(f"expected a finite number, got {shown}", mark)
        elif node.value.lower() not in self.bool_values:
            raise self._refuse(f"expected true or false, got {shown}", mark)


_NUMBER_TAGS = ("tag:yaml.org,2002:int", "tag:yaml.org,2002:float")


_CampaignLoader.yaml_implicit_resolvers = {
    ch: [
        (tag, rx)
        for tag, rx in resolvers
        if tag != "tag:yaml.org,2002:timestamp" and not (tag in _NUMBER_TAGS and ":" in rx.pattern)
    ]
    for ch, resolvers in yaml.SafeLoader.yaml_implicit_resolvers.items()
}
# YAML 1.1 ints and floats again, without their base-60 alternatives
_CampaignLoader.add_implicit_resolver(
    "tag:yaml.org,2002:int",
    re.compile(r"^(?:[-+]?0b[0-1_]+|[-+]?0[0-7_]+|[-+]?(?:0|[1-9][0-9_]*)|[-+]?0x[0-9a-fA-F_]+)$"),
    list("-+0123456789"),
)
_CampaignLoader.add_implicit_resolver(
    "tag:yaml.org,2002:float",
    re.compile(
        r"^(?:[-+]?[0-9][0-9_]*\.[0-9_]*(?:[eE][-+][0-9]+)?|\.[0-9][0-9_]*(?:[eE][-+][0-9]+)?|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN))$"
    ),
    list("-+0123456789."),
)


def _merged(base: Any, override: Any) -> Any:
    """`override` merged into `base`: mappings key by key, anything else replaced."""
    if isinstance(base, dict) and isinstance(override, dict):
        out = dict(base)
        for k, v in override.items():
            out[k] = _merged(base.get(k), v) if k in base else v
        return out
    return override


def _apply_size(data: dict, size: str) -> dict:
    """The campaign data with the overrides of `sizes[size]` merged in, named <name>-<size>."""
    sizes = data.get("sizes") or {}
    if not isinstance(sizes, dict) or size not in sizes:
        have = ", ".join(sorted(sizes)) if isinstance(sizes, dict) and sizes else "none"
        raise ConfigError(f"--size {size}: the campaign defines no such size (sizes: {have})")
    override = sizes[size]
    if not isinstance(override, dict):
        raise ConfigError(
            f"sizes.{size}: expected a mapping of campaign fields to override, got {describe_value(override)}"
        )
    bad = sorted(set(override) - {"fleets", "periods", "studies", "description", "executor", "truth_store", "outputs"})
    if bad:
        raise ConfigError(
            f"sizes.{size}: cannot override {', '.join(bad)} (fleets, periods, studies, description, "
            "executor, truth_store, outputs)"
        )
    out = _merged(data, override)  # a new mapping: `data` is left as it was
    out["name"] = f"{data.get('name')}-{size}"
    out["size"] = size
    return out


def parse_campaign(text: str, base_dir: str | Path | None = None, size: str | None = None) -> Campaign:
    """Validate campaign YAML text; any problem raises ConfigError with one line.
    `base_dir` is where relative `study_modules:` files are found (the YAML's folder);
    `size` applies the overrides of that entry of `sizes:` (a reduced campaign)."""
    try:
        loader = _CampaignLoader(text)  # its reader refuses characters YAML does not allow (a NUL, ...)
    except yaml.reader.ReaderError as e:
        ch = chr(e.character) if isinstance(e.character, int) else e.character
        raise ConfigError(
            f"not valid YAML: the character {ch!r} at offset {e.position} is not allowed in YAML text"
        ) from None
    try:
        root = loader.get_single_node()  # composed within the bounds of _CampaignLoader
        check_duplicate_keys(root)
        data = loader.construct_document(root) if root is not None else None
    except yaml.MarkedYAMLError as e:
        mark = e.problem_mark or e.context_mark
        where = f" (line {mark.line + 1}, column {mark.column + 1})" if mark is not None else ""
        raise ConfigError(f"not valid YAML: {e.problem or e.context}{where}") from None
    except yaml.YAMLError as e:  # a reader error met later in the text, ...
        raise ConfigError(f"not valid YAML: {' '.join(str(e).split())}") from None
    finally:
        loader.dispose()
    if not isinstance(data, dict):
        raise ConfigError(f"expected a mapping of campaign fields at the top level, got {describe_value(data)}")
    if size is not None:
        data = _apply_size(data, size)
    try:
        campaign = Campaign.model_validate(data)
    except ValidationError as e:
        raise ConfigError(one_line_error(e, root, Campaign)) from None
    _check_campaign(campaign, root)
    return _validate_studies(campaign, root, Path(base_dir) if base_dir is not None else None)


def load_campaign(path: str | Path, size: str | None = None) -> Campaign:
    """Read and validate a campaign YAML file (ConfigError with one line on any problem);
    `size` as in parse_campaign."""
    p = Path(path)
    try:
        mode = p.stat().st_mode
        if stat.S_ISDIR(mode):
            raise ConfigError(f"{p}: is a folder, expected a campaign YAML file")
        if not stat.S_ISREG(mode):  # a FIFO or a device would block or never end
            raise ConfigError(f"{p}: is not a regular file, expected a campaign YAML file")
        with p.open("rb") as fh:
            raw = fh.read(MAX_FILE_BYTES + 1)
        if len(raw) > MAX_FILE_BYTES:
            raise ConfigError(
                f"{p}: larger than {MAX_FILE_BYTES // 2**20} MiB, expected a campaign YAML file (a few kB)"
            )
        text = raw.decode("utf-8")
    except FileNotFoundError:
        raise ConfigError(f"{p}: no such campaign file") from None
    except NotADirectoryError:
        raise ConfigError(f"{p}: no such campaign file ({p.parent} is not a folder)") from None
    except IsADirectoryError:
        raise ConfigError(f"{p}: is a folder, expected a campaign YAML file") from None
    except UnicodeDecodeError as e:
        raise ConfigError(f"{p}: not a UTF-8 text file, expected a campaign YAML file (byte {e.start})") from None
    except OSError as e:
        raise ConfigError(f"{p}: cannot read campaign file ({e.strerror or e})") from None
    try:
        return parse_campaign(text, base_dir=p.resolve().parent, size=size)
    except ConfigError as e:
        raise ConfigError(f"{p}: {e}") from None
