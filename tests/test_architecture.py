"""The package's layers, read from its source: every import statement of aerotruth/ (lazy
ones inside functions included; `if TYPE_CHECKING:` blocks, which never run, left out of the
layer check but not of the cycle check) must
point down the order leaf -> truth -> sensors -> analysis -> measured -> sim -> app, form no
cycle, and name no private (underscore) name of another module; the library layers (truth,
sensors, analysis) neither draw (matplotlib), parse command lines (argparse) nor write
files, except the truth layer's persistence: the truth store (aerotruth.truth.store),
TruthTrack's own Parquet writer (aerotruth.truth.track) and the cached JSBSim aircraft
folder (aerotruth.truth.airframes). docs/architecture.md
states the same rules."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1] / "aerotruth"
ORDER = ("leaf", "truth", "sensors", "analysis", "measured", "sim", "app")
# the public import path users' studies know (aerotruth.config) and `python -m aerotruth`
# re-export the application's names: they sit in the application layer
APP_ALIASES = {"aerotruth.config", "aerotruth.__main__"}
LIBRARY = ("truth", "sensors", "analysis")
# the truth layer's own persistence: the truth store, TruthTrack's Parquet writer, and the
# JSBSim aircraft folder with the autopilot wrapped in (aerotruth.truth.airframes, a cache)
WRITERS_ALLOWED = {"aerotruth.truth.store", "aerotruth.truth.track", "aerotruth.truth.airframes"}


def layer(module: str) -> str:
    if module in APP_ALIASES:
        return "app"
    parts = module.split(".")
    return parts[1] if len(parts) > 2 or (len(parts) == 2 and parts[1] in ORDER) else "leaf"


def modules() -> dict[str, Path]:
    out = {}
    for p in ROOT.rglob("*.py"):
        name = ".".join(p.relative_to(ROOT.parent).with_suffix("").parts)
        out[name.removesuffix(".__init__")] = p
    return out


MODULES = modules()


def _runtime_nodes(tree: ast.AST):
    """Every node outside `if TYPE_CHECKING:` blocks."""
    stack = [tree]
    while stack:
        node = stack.pop()
        yield node
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.If) and "TYPE_CHECKING" in ast.unparse(child.test):
                stack.extend(child.orelse)
                continue
            stack.append(child)


def imports(name: str, type_checking: bool = False) -> list[tuple[str, str | None, int]]:
    """(imported aerotruth module, name taken from it or None, line) of module `name`; with
    `type_checking`, the imports of `if TYPE_CHECKING:` blocks too."""
    path = MODULES[name]
    out = []
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree) if type_checking else _runtime_nodes(tree):
        if isinstance(node, ast.Import):
            out += [(a.name, None, node.lineno) for a in node.names if a.name.split(".")[0] == "aerotruth"]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = name.split(".") if path.name == "__init__.py" else name.split(".")[:-1]
                base = base[: len(base) - node.level + 1]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            if mod.split(".")[0] != "aerotruth":
                continue
            for a in node.names:
                sub = f"{mod}.{a.name}"
                out.append((sub, None, node.lineno) if sub in MODULES else (mod, a.name, node.lineno))
    return out


def _owner(mod: str) -> str:
    while mod not in MODULES and "." in mod:
        mod = mod.rsplit(".", 1)[0]
    return mod


def graph(type_checking: bool = False) -> dict[str, set[str]]:
    return {m: {_owner(t) for t, _, _ in imports(m, type_checking)} - {m} for m in MODULES}


def test_the_walker_sees_lazy_imports_and_skips_type_checking_blocks(tmp_path):
    src = (
        "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from aerotruth.sim.campaign_file import Campaign\n"
        "def f():\n    from aerotruth.units import KT\n    import aerotruth.geo\n"
    )
    tree = ast.parse(src)
    seen = [n for n in _runtime_nodes(tree) if isinstance(n, (ast.Import, ast.ImportFrom))]
    assert sorted(ast.unparse(n) for n in seen) == [
        "from aerotruth.units import KT",
        "from typing import TYPE_CHECKING",
        "import aerotruth.geo",
    ]
    assert layer("aerotruth.units") == "leaf" and layer("aerotruth.analysis.wind.robust_fit") == "analysis"
    assert layer("aerotruth.truth") == "truth" and layer("aerotruth.config") == "app"


def test_no_import_cycle():
    """Type-only imports included: a cycle through them still ties the modules together."""
    g = graph(type_checking=True)
    index, low, stack, on, cycles, counter = {}, {}, [], set(), [], [0]

    def visit(v):  # Tarjan's strongly connected components
        index[v] = low[v] = counter[0]
        counter[0] += 1
        stack.append(v)
        on.add(v)
        for w in sorted(g[v]):
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                cycles.append(sorted(comp))

    for v in sorted(g):
        if v not in index:
            visit(v)
    assert cycles == []


def test_layers_import_only_downwards():
    up = []
    for m in sorted(MODULES):
        for target, _, line in imports(m):
            t = _owner(target)
            if t != m and ORDER.index(layer(t)) > ORDER.index(layer(m)):
                up.append(f"{m}:{line} ({layer(m)}) imports {t} ({layer(t)})")
    assert up == []


def test_no_private_name_is_imported_across_modules():
    private = [
        f"{m}:{line} takes {name} from {target}"
        for m in sorted(MODULES)
        for target, name, line in imports(m)
        if name and name.startswith("_") and not name.startswith("__") and _owner(target) != m
    ]
    assert private == []


FORBIDDEN = ("matplotlib", "argparse")
WRITE_CALLS = (
    "write_text",
    "write_bytes",
    "to_csv",
    "to_parquet",
    "savefig",
    "atomic_write",
    "atomic_write_text",
    "atomic_write_bytes",
    "mkdir",
    "write_table",
    "to_json",
)


def _library_offences(name: str, path: Path) -> list[str]:
    out = []
    tree = ast.parse(path.read_text())
    for node in ast.walk(tree):  # TYPE_CHECKING imports included: a library module names no drawing at all
        if isinstance(node, ast.Import):
            out += [f"{name}:{node.lineno} imports {a.name}" for a in node.names if a.name.split(".")[0] in FORBIDDEN]
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] in FORBIDDEN:
            out.append(f"{name}:{node.lineno} imports {node.module}")
        elif name not in WRITERS_ALLOWED and isinstance(node, ast.Call):
            f = node.func
            called = f.attr if isinstance(f, ast.Attribute) else f.id if isinstance(f, ast.Name) else ""
            if called in WRITE_CALLS:
                out.append(f"{name}:{node.lineno} calls {called}")
            if called == "open" and any(
                isinstance(a, ast.Constant) and isinstance(a.value, str) and set(a.value) & set("wax+")
                for a in list(node.args[1:2]) + [k.value for k in node.keywords if k.arg == "mode"]
            ):
                out.append(f"{name}:{node.lineno} opens a file for writing")
    return out


@pytest.mark.parametrize("layer_name", LIBRARY)
def test_library_layers_neither_draw_nor_parse_arguments_nor_write_files(layer_name):
    offences = [o for m, p in sorted(MODULES.items()) if layer(m) == layer_name for o in _library_offences(m, p)]
    assert offences == []


def test_the_offence_finder_catches_a_drawing_writing_module(tmp_path):
    p = tmp_path / "bad.py"
    p.write_text(
        "import matplotlib.pyplot as plt\ndef f(df, path):\n    df.to_csv(path)\n    with open(path, 'w') as fh:\n"
        "        fh.write('x')\n    open(path, mode='ab')\n    open(path)\n"
    )
    assert sorted(_library_offences("aerotruth.analysis.bad", p)) == [
        "aerotruth.analysis.bad:1 imports matplotlib.pyplot",
        "aerotruth.analysis.bad:3 calls to_csv",
        "aerotruth.analysis.bad:4 opens a file for writing",
        "aerotruth.analysis.bad:6 opens a file for writing",
    ]


def test_the_public_import_paths_of_users_studies_still_work():
    import aerotruth.config as public
    from aerotruth.schema import Section
    from aerotruth.sim.campaign_file import Campaign
    from aerotruth.sim.campaign_loader import load_campaign
    from aerotruth.sim.studies import Study, Summary

    assert public.Section is Section and public.Campaign is Campaign and public.load_campaign is load_campaign
    assert issubclass(Campaign, Section) and Study.__module__ == "aerotruth.sim.studies" and Summary is not None
