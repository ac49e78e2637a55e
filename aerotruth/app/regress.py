"""Regression of a run's metrics against a baseline with per-metric tolerances.

Baseline file (JSON):

    {"default": {"abs": 0.0, "rel": 0.02},
     "metrics": {"wind_climatology.FL250.speed_mean_mps": {"value": 21.3, "abs": 0.5},
                 "truth.legs": 4}}

A metric passes when |got − value| ≤ abs + rel·|value| (numpy.isclose's rule); a bare
number uses the default tolerances, which are 0 (exact) when not given. A baseline
metric missing from the run fails; run metrics absent from the baseline are not checked.

A baseline that could not fail is refused, not passed: one without metrics (it compares
nothing), a value or tolerance that is not a finite number, a metric given twice. So is a
run whose metrics.json is damaged: each problem is one line naming the file.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from aerotruth.errors import RunDirError, UserError
from aerotruth.files import atomic_write_text
from aerotruth.sim.store import RunStore

REWRITE = "rerun `aerotruth run` on its campaign to rewrite it"


class BaselineError(UserError):
    """A baseline file that cannot be used (one line naming the problem)."""


def unreadable(e: BaseException) -> str:
    """What kept a file from being read, in a few words for a one-line error."""
    if isinstance(e, json.JSONDecodeError):
        return f"not valid JSON, truncated or damaged ({e.msg}: line {e.lineno}, column {e.colno})"
    if isinstance(e, RecursionError):
        return "not valid JSON: nested too deep to read"
    if isinstance(e, UnicodeDecodeError):
        return f"not UTF-8 text (byte {e.object[e.start]:#04x} at offset {e.start})"
    if isinstance(e, IsADirectoryError):
        return "is a folder, expected a file"
    if isinstance(e, FileNotFoundError):
        return "missing"
    if isinstance(e, OSError):
        return f"cannot be read ({e.strerror or e})"
    text = " ".join(str(e).split())
    return text if len(text) <= 160 else text[:157] + "..."


def _no_repeats(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    keys = [k for k, _ in pairs]
    repeated = next((k for i, k in enumerate(keys) if k in keys[:i]), None)
    if repeated is not None:
        raise ValueError(f"key {repeated!r} given twice in one object")
    return dict(pairs)


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _finite(v: int | float) -> bool:
    f = _as_float(v)
    return f is not None and math.isfinite(f)


def _as_float(v: int | float) -> float | None:
    """`v` as a float, None for an integer too large for one (JSON integers have any length)."""
    try:
        return float(v)
    except OverflowError:
        return None


def read_run_metrics(run_dir: str | Path) -> dict[str, Any]:
    """RUN_DIR/metrics.json, checked: an object whose 'metrics' maps names to numbers (or
    null); a missing, truncated, damaged or misshapen file is one RunDirError naming it."""
    store = RunStore(run_dir)
    path = store.metrics_path
    try:
        doc = store.read_metrics()
    except UserError:
        raise
    except (ValueError, OSError, RecursionError) as e:
        raise RunDirError(f"{path}: {unreadable(e)}; {REWRITE}") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("metrics"), dict):
        raise RunDirError(f"{path}: expected an object with a 'metrics' object; {REWRITE}")
    for name, value in doc["metrics"].items():
        if value is not None and (not isinstance(value, (int, float)) or _as_float(value) is None):
            shown = f"an integer of {len(str(value))} digits" if isinstance(value, int) else json.dumps(value)[:40]
            raise RunDirError(f"{path}: metric {name} is {shown}, expected a number or null; {REWRITE}")
    return doc


@dataclass(frozen=True)
class Check:
    """One metric compared with its baseline."""

    metric: str
    baseline: float | None
    got: float | None
    abs_tol: float
    rel_tol: float
    missing: bool = False

    @property
    def tolerance(self) -> float:
        return self.abs_tol + self.rel_tol * abs(self.baseline or 0.0)

    @property
    def diff(self) -> float | None:
        if self.baseline is None or self.got is None:
            return None
        return self.got - self.baseline

    @property
    def ok(self) -> bool:
        if self.missing:
            return False
        if self.baseline is None or self.got is None:  # NaN is written as null
            return self.baseline is None and self.got is None
        return abs(self.got - self.baseline) <= self.tolerance


def _tolerances(spec: dict[str, Any], where: str) -> tuple[float | None, float | None]:
    out = []
    for key in ("abs", "rel"):
        v = spec.get(key)
        if v is not None and (not _is_number(v) or not _finite(v) or v < 0):
            raise BaselineError(f"{where}.{key}: expected a non-negative number, got {_shown(v)}")
        out.append(None if v is None else float(v))
    unknown = set(spec) - {"abs", "rel", "value"}
    if unknown:
        raise BaselineError(f"{where}: unknown key {sorted(unknown)[0]!r} (allowed: value, abs, rel)")
    return out[0], out[1]


def _shown(v: Any) -> str:
    """A JSON value in a message: a long integer by its digits."""
    return f"an integer of {len(str(v))} digits" if isinstance(v, int) and len(str(v)) > 40 else json.dumps(v)[:60]


def load_baseline(path: str | Path) -> dict[str, tuple[float | None, float, float]]:
    """metric -> (value, abs tolerance, rel tolerance) from a baseline file."""
    p = Path(path)
    try:
        text = p.read_bytes().decode("utf-8")
    except FileNotFoundError:
        raise BaselineError(f"{p}: no such baseline file") from None
    except IsADirectoryError:
        raise BaselineError(f"{p}: is a folder, expected a baseline JSON file") from None
    except (UnicodeDecodeError, OSError) as e:
        raise BaselineError(f"{p}: {unreadable(e)}, expected a baseline JSON file") from None
    try:
        doc = json.loads(text, object_pairs_hook=_no_repeats)
    except json.JSONDecodeError as e:
        raise BaselineError(f"{p}: not valid JSON: {e.msg} (line {e.lineno})") from None
    except ValueError as e:  # a key given twice: one of the two would be dropped silently
        raise BaselineError(f"{p}: {e}") from None
    except RecursionError:
        raise BaselineError(f"{p}: not valid JSON: nested too deep to read") from None
    if not isinstance(doc, dict) or not isinstance(doc.get("metrics"), dict):
        raise BaselineError(f"{p}: expected an object with a 'metrics' object")
    if not doc["metrics"]:
        raise BaselineError(
            f"{p}: 'metrics' is empty: a baseline that compares nothing cannot fail "
            "(write one from a run with `aerotruth regress RUN_DIR BASELINE --write`)"
        )
    unknown = set(doc) - {"metrics", "default", "comment"}
    if unknown:
        raise BaselineError(f"{p}: unknown key {sorted(unknown)[0]!r} (allowed: metrics, default, comment)")
    default = doc.get("default") or {}
    if not isinstance(default, dict):
        raise BaselineError(f"{p}: default: expected an object with abs and/or rel, got {json.dumps(default)}")
    d_abs, d_rel = _tolerances(default, f"{p}: default")
    out = {}
    for name, spec in doc["metrics"].items():
        where = f"metrics.{name}"
        if isinstance(spec, dict):
            if "value" not in spec:
                raise BaselineError(f"{p}: {where}.value: required field missing")
            a, r = _tolerances(spec, f"{p}: {where}")
            value = spec["value"]
        else:
            a, r, value = None, None, spec
        if value is not None and (not _is_number(value) or not _finite(value)):
            raise BaselineError(f"{p}: {where}: expected a finite number or null, got {_shown(value)}")
        out[name] = (
            None if value is None else float(value),
            a if a is not None else (d_abs or 0.0),
            r if r is not None else (d_rel or 0.0),
        )
    return out


def compare(metrics: dict[str, Any], baseline: dict[str, tuple[float | None, float, float]]) -> list[Check]:
    """Check every baseline metric against the run's metrics, in name order."""
    checks = []
    for name in sorted(baseline):
        value, a, r = baseline[name]
        if name not in metrics:
            checks.append(Check(name, value, None, a, r, missing=True))
            continue
        got = metrics[name]
        checks.append(Check(name, value, None if got is None else float(got), a, r))
    return checks


def format_checks(checks: list[Check], only_failures: bool = True) -> str:
    """A plain-text table of the checks (the moved ones only, by default)."""
    from aerotruth.markdown import format_value

    rows = [c for c in checks if not (only_failures and c.ok)]
    head = ("metric", "baseline", "got", "diff", "tolerance", "status")
    body = [
        (
            c.metric,
            format_value(c.baseline, 6),
            "missing" if c.missing else format_value(c.got, 6),
            format_value(c.diff, 3),
            format_value(c.tolerance, 3),
            "ok" if c.ok else "MOVED",
        )
        for c in rows
    ]
    widths = [max(len(h), *(len(r[i]) for r in body)) if body else len(h) for i, h in enumerate(head)]
    fmt = "  ".join(f"{{:<{w}}}" for w in widths)
    lines = [fmt.format(*head), fmt.format(*("-" * w for w in widths))] + [fmt.format(*r) for r in body]
    return "\n".join(lines)


def regress(run_dir: str | Path, baseline_path: str | Path) -> list[Check]:
    """Compare the metrics of a finished run with a baseline file."""
    metrics = read_run_metrics(run_dir)["metrics"]
    return compare(metrics, load_baseline(baseline_path))


def write_baseline(run_dir: str | Path, path: str | Path, *, abs_tol: float = 0.0, rel_tol: float = 0.0) -> int:
    """Write the run's metrics as a baseline with default tolerances; returns the count."""
    target = Path(path)
    if target.is_dir():
        raise BaselineError(
            f"{target}: is a folder, expected the baseline's file name (e.g. {target / 'baseline.json'})"
        )
    if not target.parent.is_dir():
        raise BaselineError(f"{target}: folder {target.parent} does not exist")
    metrics = read_run_metrics(run_dir)["metrics"]
    if not metrics:
        raise BaselineError(f"{run_dir}: the run has no metrics; a baseline of it would compare nothing")
    bad = [k for k, v in metrics.items() if v is not None and (not isinstance(v, (int, float)) or isinstance(v, bool))]
    if bad:
        raise BaselineError(
            f"{run_dir}: metric {bad[0]} is {json.dumps(metrics[bad[0]])}; a baseline holds numbers or null "
            "(the study should report flags as 1.0/0.0)"
        )
    doc = {
        "default": {"abs": abs_tol, "rel": rel_tol},
        "metrics": {k: {"value": v} for k, v in sorted(metrics.items())},
    }
    atomic_write_text(target, json.dumps(doc, indent=2, sort_keys=True) + "\n")
    return len(metrics)
