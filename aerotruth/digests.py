"""What a stored result depends on, as digests: the source of a study and of every
aerotruth module it imports (found by reading the import statements, lazy ones inside
functions included), the data files beside those modules (aircraft and autopilot XML,
airport tables), and the versions of the libraries that shape numbers. A stored task
result or fitted state is reused only while its digest matches: an edited constant or
XML file reruns what depends on it, with no version bump."""

from __future__ import annotations

import ast
import hashlib
import importlib.util
import platform
from functools import cache, lru_cache
from importlib import metadata
from pathlib import Path

import aerotruth

PACKAGE_ROOT = Path(aerotruth.__file__).resolve().parent
# numba and llvmlite too: the wind method's compiled loops (analysis.wind.robust_fit,
# fast_trig) use fastmath, whose results are fixed only per compiler build and processor
RESULT_LIBRARIES = ("jsbsim", "numpy", "scipy", "pandas", "pyarrow", "ppigrf", "pyproj", "numba", "llvmlite")
# Orchestration: how tasks are scheduled, stored and reported never changes a task's
# numbers (the resolved configuration is digested separately), so these are not followed.
ORCHESTRATION = frozenset(
    {
        "aerotruth.app.cli",
        "aerotruth.sim.campaign_file",
        "aerotruth.sim.campaign_loader",
        "aerotruth.sim.campaign",
        "aerotruth.app.campaign_commands",
        "aerotruth.sim.executors",
        "aerotruth.app.figures",
        "aerotruth.markdown",
        "aerotruth.app.regress",
        "aerotruth.app.report",
        "aerotruth.sim.store",
        "aerotruth.sim.worker",
        "aerotruth.digests",
    }
)


def _module_file(name: str, root: Path = PACKAGE_ROOT) -> Path | None:
    """File of an aerotruth module name, without importing it."""
    parts = name.split(".")
    if parts[0] != "aerotruth":
        return None
    base = root.joinpath(*parts[1:])
    for cand in (base.with_suffix(".py"), base / "__init__.py"):
        if cand.is_file():
            return cand
    return None


def _module_name(path: Path, root: Path = PACKAGE_ROOT) -> str | None:
    try:
        rel = path.resolve().relative_to(root)
    except ValueError:
        return None
    parts = list(rel.with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(["aerotruth", *parts])


def _is_type_checking(node: ast.AST) -> bool:
    return isinstance(node, ast.If) and (
        (isinstance(node.test, ast.Name) and node.test.id == "TYPE_CHECKING")
        or (isinstance(node.test, ast.Attribute) and node.test.attr == "TYPE_CHECKING")
    )


def _walk_runtime(tree: ast.AST):
    """ast.walk without `if TYPE_CHECKING:` blocks (imports for type hints never run)."""
    todo = [tree]
    while todo:
        node = todo.pop()
        yield node
        todo.extend(c for c in ast.iter_child_nodes(node) if not _is_type_checking(c))


def _imports(path: Path, own_name: str | None) -> set[str]:
    """Absolute names of the aerotruth modules `path` imports at run time (module-level or
    inside functions; not under `if TYPE_CHECKING:`)."""
    tree = ast.parse(path.read_text(encoding="utf-8"), filename=str(path))
    is_package = path.name == "__init__.py"
    out: set[str] = set()
    for node in _walk_runtime(tree):
        if isinstance(node, ast.Import):
            out.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                if own_name is None:
                    continue
                pkg = own_name.split(".") if is_package else own_name.split(".")[:-1]
                pkg = pkg[: len(pkg) - (node.level - 1)]
                base = ".".join(pkg + ([node.module] if node.module else []))
            else:
                base = node.module or ""
            out.add(base)
            out.update(f"{base}.{a.name}" for a in node.names)
    return {n for n in out if (n == "aerotruth" or n.startswith("aerotruth.")) and n not in ORCHESTRATION}


def dependency_files(start: Path, root: Path = PACKAGE_ROOT) -> list[Path]:
    """`start` and every aerotruth module it reaches by imports (with their parent
    packages' __init__; orchestration modules excluded), plus the data files those
    modules name: a file beside a module whose name appears as a string in it, or a
    whole non-package subfolder (truth/aircraft/**, truth/data/*) whose name appears as
    a string in a module of that folder."""
    seen: set[Path] = set()
    todo = [start.resolve()]
    while todo:
        p = todo.pop()
        if p in seen:
            continue
        seen.add(p)
        name = _module_name(p, root)
        for dep in _imports(p, name):
            parts = dep.split(".")
            for i in range(1, len(parts) + 1):  # parent packages run on import too
                if ".".join(parts[:i]) in ORCHESTRATION:
                    break
                f = _module_file(".".join(parts[:i]), root)
                if f is not None and f.resolve() not in seen:
                    todo.append(f.resolve())
    files = set(seen)
    for p in list(seen):
        if _module_name(p, root) is not None:
            files.update(_named_data_files(p))
    return sorted(files)


def _strings(path: Path) -> set[str]:
    return {
        n.value
        for n in ast.walk(ast.parse(path.read_text(encoding="utf-8")))
        if isinstance(n, ast.Constant) and isinstance(n.value, str)
    }


def _named_data_files(module: Path) -> list[Path]:
    """Data files beside `module` (or in non-package subfolders) that it names in a string."""
    folder, names = module.parent, _strings(module)
    out = []
    for item in folder.iterdir():
        if item.is_file() and item.suffix not in (".py", ".pyc") and item.name in names:
            out.append(item)
        elif item.is_dir() and item.name in names and not (item / "__init__.py").exists():
            out += [f for f in item.rglob("*") if f.is_file() and f.suffix != ".pyc" and "__pycache__" not in f.parts]
    return out


@lru_cache(maxsize=1)
def cpu_name() -> str:
    """The host processor's model name (/proc/cpuinfo on Linux, else the platform's word for
    it): fastmath-compiled loops may round differently on another processor."""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.lower().startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown"


def library_versions(names: tuple[str, ...] = RESULT_LIBRARIES) -> dict[str, str]:
    """Versions of Python and of the named installed packages (default: those that shape
    results), and the processor's name (`cpu`)."""
    out = {"python": platform.python_version(), "cpu": cpu_name()}
    for name in names:
        try:
            out[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            out[name] = "absent"
    return out


def source_file(source: str) -> Path:
    """The file behind a study source (`module:NAME` or `file:PATH`)."""
    kind, _, ref = source.partition(":")
    if kind == "file":
        return Path(ref)
    f = _module_file(ref)
    if f is not None:
        return f
    spec = importlib.util.find_spec(ref)
    if spec is None or spec.origin is None:
        raise ValueError(f"study module {ref}: not found")
    return Path(spec.origin)


@cache
def code_digest(source: str) -> str:
    """sha256 over the files a study's results depend on and the library versions."""
    h = hashlib.sha256()
    for f in dependency_files(source_file(source)):
        try:
            label = f.relative_to(PACKAGE_ROOT).as_posix()
        except ValueError:
            label = f.name
        h.update(label.encode() + b"\0" + f.read_bytes() + b"\0")
    for k, v in sorted(library_versions().items()):
        h.update(f"{k}={v}\n".encode())
    return h.hexdigest()
