"""Reading an approach log (CSV or Parquet; docs/data-formats.md, "Approach log") and its
runway geometry: a sidecar `<log>.runway.json` (or `<log stem>.runway.json`) or the Parquet
metadata key `runway` (one object for the whole log, or {"approaches": {id: object}} per
approach); without either, a 3,000 m runway with a standard installation
(aerotruth.analysis.fits.approach_log.DEFAULT_RUNWAY) is assumed and said."""

from __future__ import annotations

import difflib
import json
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.fits.approach_log import (
    DEFAULT_RUNWAY,
    DGPS,
    NUMERIC,
    OPTIONAL_NUMERIC,
    REQUIRED,
    RUNWAY_RANGES,
    event_codes,
)
from aerotruth.errors import DataError
from aerotruth.measured.tables import numeric_column, read_csv_table


def runway_geometry(path: Path) -> tuple[dict, str]:
    """({approach: geometry} or {None: geometry for all}, where it came from) of the log at
    `path` (module docstring): `<log>.runway.json` (or `<stem>.runway.json`) beside it, else
    the Parquet metadata key `runway`; a file may hold one geometry or
    {"approaches": {approach: geometry}}."""
    raw, src = None, ""
    for side in (path.with_name(path.name + ".runway.json"), path.with_suffix(".runway.json")):
        if side.is_file():
            try:
                raw, src = json.loads(side.read_text()), str(side)
            except json.JSONDecodeError as exc:
                raise DataError(f"{side}: not JSON ({exc.msg} at line {exc.lineno})") from None
            break
    if raw is None and path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        meta = pq.read_schema(path).metadata or {}
        if b"runway" in meta:
            src = f"{path} (metadata key 'runway')"
            try:
                raw = json.loads(meta[b"runway"])
            except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                raise DataError(f"{src}: not JSON ({getattr(exc, 'msg', exc)})") from None
    if raw is None:
        return {None: dict(DEFAULT_RUNWAY)}, "assumed (no runway geometry in the log)"
    if not isinstance(raw, dict):
        raise DataError(f"{src}: expected a JSON object with the runway geometry")
    items = raw["approaches"].items() if isinstance(raw.get("approaches"), dict) else [(None, raw)]
    out = {}
    for a, geo in items:
        where = src if a is None else f"{src}: approach {a!r}"
        if not isinstance(geo, dict):
            raise DataError(f"{where}: expected a JSON object with the runway geometry")
        for k in sorted(set(geo) - set(DEFAULT_RUNWAY)):  # other keys describe (airport, runway_frame, ...);
            near = difflib.get_close_matches(k, DEFAULT_RUNWAY, n=1, cutoff=0.8)  # a misspelt one would
            if near:  # silently leave its default in place
                raise DataError(f"{where}: unknown key {k!r}; did you mean {near[0]!r}?")
        g = dict(DEFAULT_RUNWAY)
        for k in DEFAULT_RUNWAY:
            if k in geo:
                try:
                    g[k] = float(geo[k])
                except (TypeError, ValueError):
                    raise DataError(f"{where}: key {k!r}: expected a number, got {geo[k]!r}") from None
        for k, (lo, hi) in RUNWAY_RANGES.items():
            if not lo <= g[k] <= hi:
                raise DataError(f"{where}: key {k!r}: {g[k]:g} outside [{lo:g}, {hi:g}]")
        out[a] = g
    return out, src


def read_approach_log(path: str | Path) -> pd.DataFrame:
    """The log as a DataFrame with its columns checked (names, numbers)."""
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{p}: no such file (expected an approach log, CSV or Parquet)")
    try:
        df = pd.read_parquet(p) if p.suffix.lower() in (".parquet", ".pq") else read_csv_table(p)
    except Exception as exc:  # noqa: BLE001 - any reader failure is one line about the file
        raise DataError(
            f"{p}: cannot be read as CSV/Parquet ({type(exc).__name__}: {str(exc).splitlines()[0]})"
        ) from None
    missing = [c for c in REQUIRED if c not in df.columns]
    if missing:
        raise DataError(f"{p}: missing column {missing[0]!r} (an approach log needs {', '.join(REQUIRED)})")
    if any(c in df.columns for c in DGPS) and not all(c in df.columns for c in DGPS):
        raise DataError(f"{p}: DGPS columns must come together ({', '.join(DGPS)})")
    if len(df) == 0:
        raise DataError(f"{p}: no rows")
    df["event"] = event_codes(df["event"], str(p))
    for c in NUMERIC + OPTIONAL_NUMERIC:
        if c != "event" and c in df.columns:
            df[c] = numeric_column(df, c, str(p))
    if df["time_s"].isna().any():
        raise DataError(
            f"{p}: column 'time_s' data row {int(np.flatnonzero(df['time_s'].isna())[0]) + 1}: missing time"
        )
    for c in ("sv_change", "iono_update"):
        v = df[c].fillna(0.0)
        if not v.isin([0.0, 1.0]).all():
            raise DataError(f"{p}: column {c!r}: expected 0/1 flags, got {v[~v.isin([0.0, 1.0])].iloc[0]!r}")
        df[c] = v
    return df
