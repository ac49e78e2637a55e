"""Measured data files: recognise what a file holds from its content and load it as a
table, so that `diagnose` and the tests can take a user's data as it comes.

Kinds (docs/data-formats.md and ../shared/real-data/README.md):

* `observation_table` — aircraft reports (CSV or Parquet): aircraft, time, lat, lon,
  pressure_altitude_ft, wind_speed_kt, wind_dir_deg, ref_wind_speed_kt, ref_wind_dir_deg;
* `approach_log` — FITS approach epochs (CSV or Parquet): approach, time_s, waas_x_m, ...;
* `modes_raw` — decoded Mode-S / ADS-B messages, one JSON object per line (or a JSON
  list), each with `timestamp`, `df` and the hex `frame`;
* `modes_track` — a trajectory with Mode-S enhanced-surveillance fields (JSON list of
  records with `heading` (magnetic, BDS 6,0) and `TAS` (BDS 5,0) besides position);
* `adsb_track` — an ADS-B trajectory (JSON list of records with latitude, longitude,
  groundspeed, track; no heading or TAS);
* `qar` — a flight-data-recorder extract (column-oriented JSON: {column: {row: value}})
  with attitude (`pitch`, `roll`).

Gzip is recognised by its magic bytes. Times become UTC epoch seconds (`time_s`). A file
that is none of these gets one DataError naming the file and what was expected. In the
JSON kinds, text or true/false in a numeric field (NUMERIC_FIELDS), a value outside what the
field can be (FIELD_RANGES: an infinite or huge number, a latitude past the pole), a time
outside the dates aerotruth models, a heading or track column in radians, or a record
without a timestamp is an error naming the record (or line) and field, and so is a file
holding more than one aircraft (several `icao24`): diagnose takes one aircraft's flight.
A null (or NaN) is a missing value. Speeds are checked against each other: the median
ground speed over the TAS (check_speed_units) is about 1 whatever the wind, 0.51 or 1.94
when one of them is in m/s.
"""

from __future__ import annotations

import gzip
import io
import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.contracts import APPROACH_LOG_KEY, OBSERVATION_REQUIRED
from aerotruth.dates import MODEL_DATE_SPAN, MODEL_EPOCH_S
from aerotruth.errors import DataError
from aerotruth.measured.tables import GZIP_MAGIC, CutShort, read_csv_table

OBSERVATION_COLUMNS = OBSERVATION_REQUIRED
APPROACH_COLUMNS = APPROACH_LOG_KEY
KINDS = ("observation_table", "approach_log", "modes_raw", "modes_track", "adsb_track", "qar")
_EXPECTED = (
    "an observation table (CSV/Parquet with columns " + ", ".join(OBSERVATION_COLUMNS) + "), an approach log "
    "(CSV/Parquet with " + ", ".join(APPROACH_COLUMNS) + ", ...), Mode-S/ADS-B messages (JSONL with timestamp, df, "
    "frame), a Mode-S or ADS-B trajectory (JSON records with timestamp, latitude, longitude) or a QAR extract "
    "(column-oriented JSON with timestamp, pitch, roll)"
)


@dataclass
class Measured:
    """A recognised measured-data file: its kind and its rows."""

    kind: str
    df: pd.DataFrame
    path: Path


def real_data_dir() -> Path:
    """$AEROTRUTH_REAL_DATA, else ../shared/real-data beside the project checkout."""
    env = os.environ.get("AEROTRUTH_REAL_DATA")
    if env:
        return Path(env)
    return Path(__file__).resolve().parents[3] / "shared" / "real-data"


def _raw_bytes(path: Path) -> bytes:
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        raise DataError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise DataError(f"{path}: is a folder, expected a data file") from None
    except OSError as e:
        raise DataError(f"{path}: cannot read ({e.strerror})") from None
    if data[:2] == GZIP_MAGIC:
        try:
            data = gzip.decompress(data)
        except (OSError, EOFError) as e:
            raise DataError(f"{path}: a damaged gzip file ({e})") from None
    return data


def _table(path: Path, data: bytes) -> pd.DataFrame | None:
    """A CSV or Parquet table, or None when the bytes are neither."""
    if data[:4] == b"PAR1":
        try:
            return pd.read_parquet(io.BytesIO(data))
        except Exception as e:  # noqa: BLE001 - a damaged Parquet file is one line
            raise DataError(f"{path}: a damaged Parquet file ({e})") from None
    head = data[:4096].decode("utf-8", errors="replace").lstrip()
    if not head or head[0] in "[{":
        return None
    try:
        return read_csv_table(data)
    except CutShort as e:
        raise DataError(f"{path}: not a readable CSV table ({e})") from None
    except (pd.errors.ParserError, pd.errors.EmptyDataError, UnicodeDecodeError):
        return None


def _json(path: Path, data: bytes):
    """The file's JSON document, or its JSON lines as a list; None when it is neither. A
    JSON-lines file with a line that does not parse (after one that did) is a DataError
    naming the line: a capture cut short is said so, not dropped."""
    text = data.decode("utf-8", errors="replace").strip()
    if not text:
        return None
    try:
        return _loads(text, path)
    except json.JSONDecodeError:
        pass
    lines = text.splitlines()  # JSON lines; `text` is stripped: its last line is not blank
    records = []
    for i, line in enumerate(lines, 1):
        if not line.strip():
            continue
        try:
            records.append(_loads(line, path, f" line {i}"))
        except json.JSONDecodeError as e:
            if not records:
                return None
            cut = " (the last line: a capture cut short?)" if i == len(lines) else ""
            raise DataError(
                f"{path}: line {i} is not valid JSON ({e.msg}){cut}; expected one JSON object per line"
            ) from None
    return records


def _loads(text: str, path: Path, where: str = ""):
    """json.loads, with what it cannot hold as a DataError naming the file: a number of more
    than 4,300 digits (Python's bound for int()), nesting deeper than its stack. A text that
    is not JSON raises json.JSONDecodeError, for the caller to try other kinds."""
    try:
        return json.loads(text)
    except json.JSONDecodeError:
        raise
    except ValueError as e:  # "Exceeds the limit (4300 digits) for integer string conversion ..."
        raise DataError(f"{path}:{where} a number too long to read ({str(e).split(':')[0]})") from None
    except RecursionError:
        raise DataError(f"{path}:{where} JSON nested too deep to read") from None


def _epoch_seconds(ts: pd.Series) -> pd.Series:
    """Epoch times in s or ms (recognised by size) as seconds."""
    t = pd.to_numeric(ts, errors="coerce").astype(float)
    return t / 1000.0 if t.abs().median() > 1e11 else t


def file_bytes(path: Path) -> bytes:
    """A data file's bytes, gunzipped when they are gzip (by the magic bytes, whatever the
    name); DataError naming the file when it cannot be read."""
    return _raw_bytes(path)


def table_of(path: Path, data: bytes) -> pd.DataFrame | None:
    """The bytes as a CSV or Parquet table, None when they are JSON (or empty)."""
    return _table(path, data)


def json_of(path: Path, data: bytes):
    """The bytes as one JSON document, or JSON lines as a list; None when neither."""
    return _json(path, data)


def epoch_seconds(values: pd.Series, where: str, column: str) -> pd.Series:
    """A time column as UTC epoch seconds: numbers in s or ms (told apart by size), or
    ISO-8601 text; DataError naming `where`, the column and the first value that is neither."""
    epoch = pd.Timestamp("1970-01-01", tz="UTC")
    if pd.api.types.is_datetime64_any_dtype(values):
        return (pd.to_datetime(values, utc=True) - epoch).dt.total_seconds()
    if pd.api.types.is_numeric_dtype(values) and not pd.api.types.is_bool_dtype(values):
        return _epoch_seconds(values)
    num = pd.to_numeric(values, errors="coerce")
    if values.notna().any() and num.notna().sum() == values.notna().sum():
        return _epoch_seconds(num)
    parsed = pd.to_datetime(values, utc=True, errors="coerce", format="mixed")
    bad = values[parsed.isna() & values.notna()]
    if len(bad):
        got = bad.iloc[0]
        raise DataError(f"{where}: column {column!r}: expected UTC epoch seconds or ISO-8601 times, got {got!r}")
    return (parsed - epoch).dt.total_seconds()


# fields the Mode-S / ADS-B / QAR kinds read as numbers (README of ../shared/real-data)
NUMERIC_FIELDS = (
    "timestamp",
    "latitude",
    "longitude",
    "altitude",
    "groundspeed",
    "track",
    "vertical_rate",
    "heading",
    "TAS",
    "IAS",
    "Mach",
    "roll",
    "pitch",
    "track_rate",
    "CAS",
    "drift",
)


# what each numeric field can be, in the units of its name (the `traffic` library's: ft,
# kt, deg, ft/min, deg/s); beyond it a value is no measurement (an overflow, a swapped field)
FIELD_RANGES = {
    "latitude": (-90.0, 90.0),
    "longitude": (-180.0, 360.0),
    "altitude": (-2000.0, 70000.0),
    "groundspeed": (0.0, 1000.0),
    "track": (-180.0, 360.0),
    "vertical_rate": (-50000.0, 50000.0),
    "heading": (-180.0, 360.0),
    "TAS": (0.0, 1000.0),
    "IAS": (0.0, 1000.0),
    "CAS": (0.0, 1000.0),
    "Mach": (0.0, 5.0),
    "roll": (-180.0, 180.0),
    "pitch": (-90.0, 90.0),
    "track_rate": (-180.0, 180.0),
    "drift": (-180.0, 180.0),
}
ANGLE_FIELDS = ("heading", "track")  # read in degrees: a column of them all within [0, 2 pi] is radians
RADIANS_MIN_VALUES = 200  # as the observation table's wind directions (aerotruth.analysis.wind.observations)
# the median ground speed over the TAS of a flight or a fleet: about 1 in any wind a
# winds-aloft method can use (a 40 % headwind gives 0.6); 0.51 or 1.94 for a speed in m/s
SPEED_RATIO = (0.55, 1.8)


def check_speed_units(gs_kt, tas_kt, where: str, gs: str, tas: str) -> None:
    """DataError naming both columns when the median of ground speed / TAS (rows with both,
    at least RADIANS_MIN_VALUES of them) is outside SPEED_RATIO: one of them is in other units."""
    g, a = np.asarray(gs_kt, float), np.asarray(tas_kt, float)
    ok = np.isfinite(g) & np.isfinite(a) & (a > 0)
    if ok.sum() < RADIANS_MIN_VALUES:
        return
    r = float(np.median(g[ok] / a[ok]))
    lo, hi = SPEED_RATIO
    if not lo <= r <= hi:
        likely = f"{gs!r} in m/s or {tas!r} in km/h" if r < lo else f"{tas!r} in m/s or {gs!r} in km/h"
        raise DataError(
            f"{where}: columns {gs!r}, {tas!r}: the ground speed is {r:.3g} times the TAS (median of {int(ok.sum())} "
            f"samples; about 1 in any wind): {likely}? expected knots"
        )


def check_values(
    where: str, values: pd.Series, field: str, what: str = "data row", shown: str | None = None
) -> np.ndarray:
    """A numeric field's values (already numbers, in the units of `field`'s name) within
    FIELD_RANGES (NaN, a missing value, passes); an angle field not in radians. DataError
    naming the row and the field (as `shown`, the file's own name for it, when given)."""
    name = field if shown is None else shown
    v = values.to_numpy(dtype=float)
    lo, hi = FIELD_RANGES.get(field, (-np.inf, np.inf))
    with np.errstate(invalid="ignore"):
        bad = np.isinf(v) | (v < lo) | (v > hi)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        raise DataError(f"{where}: {what} {i + 1}, field {name!r}: {v[i]:g} outside [{lo:g}, {hi:g}]")
    fin = v[np.isfinite(v)]
    if field in ANGLE_FIELDS and len(fin) >= RADIANS_MIN_VALUES:
        if fin.min() >= 0.0 and fin.max() <= 2 * np.pi and fin.max() - fin.min() > 0.2:
            raise DataError(
                f"{where}: field {name!r}: all {len(fin)} values lie within [{fin.min():.3g}, {fin.max():.3g}]: "
                "in radians? expected degrees"
            )
    return v


def _checked_records(path: Path, df: pd.DataFrame, what: str) -> pd.DataFrame:
    """Numbers as numbers within their ranges (text or true/false in a numeric field is an
    error naming record and field), every record timed within the dates aerotruth models,
    one aircraft."""
    for c in NUMERIC_FIELDS:
        if c not in df.columns:
            continue
        if df[c].dtype.kind == "b" or (df[c].dtype == object and df[c].map(lambda v: isinstance(v, bool)).any()):
            i = int(np.flatnonzero(df[c].map(lambda v: isinstance(v, bool)).to_numpy())[0])
            raise DataError(f"{path}: {what} {i + 1}, field {c!r}: {df[c].iloc[i]!r} is not a number")
        if df[c].dtype.kind not in "iuf":
            num = pd.to_numeric(df[c], errors="coerce")
            bad = num.isna() & df[c].notna()
            if bad.any():
                i = int(bad.to_numpy().nonzero()[0][0])
                raise DataError(f"{path}: {what} {i + 1}, field {c!r}: {df[c].iloc[i]!r} is not a number")
            df[c] = num.astype(float)
        if c != "timestamp":
            check_values(str(path), df[c], c, what)
    if df["timestamp"].isna().any():
        i = int(df["timestamp"].isna().to_numpy().nonzero()[0][0])
        raise DataError(f"{path}: {what} {i + 1}: no timestamp")
    t = _epoch_seconds(df["timestamp"]).to_numpy()
    lo, hi = MODEL_EPOCH_S
    with np.errstate(invalid="ignore"):
        late = ~((t >= lo) & (t < hi))
    if late.any():
        i = int(np.flatnonzero(late)[0])
        raise DataError(
            f"{path}: {what} {i + 1}, field 'timestamp': {df['timestamp'].iloc[i]!r} is not a time from "
            f"{MODEL_DATE_SPAN} (epoch seconds or milliseconds)"
        )
    if "groundspeed" in df.columns and "TAS" in df.columns:
        check_speed_units(df["groundspeed"], df["TAS"], str(path), "groundspeed", "TAS")
    if "icao24" in df.columns:
        ids = pd.unique(df["icao24"].dropna().astype(str).str.lower())
        if len(ids) > 1:
            raise DataError(
                f"{path}: data of {len(ids)} aircraft (icao24 {', '.join(sorted(ids)[:5])}"
                f"{', ...' if len(ids) > 5 else ''}); diagnose takes one aircraft's flight: keep the "
                f"records of one icao24"
            )
    return df


def _one_state_per_time(path: Path, df: pd.DataFrame) -> pd.DataFrame:
    """A trajectory's records (sorted by time) with exact repeats dropped; two records of one
    instant that differ in a numeric field are a DataError naming them: which is the
    aircraft's state cannot be told."""
    fields = [c for c in NUMERIC_FIELDS if c in df.columns]
    v = df[fields].to_numpy(dtype=float)
    t = df["time_s"].to_numpy()
    same = np.flatnonzero(t[1:] == t[:-1])
    if not len(same):
        return df
    a, b = v[same], v[same + 1]
    differs = ~((a == b) | (np.isnan(a) & np.isnan(b)))
    if differs.any():
        k = int(np.flatnonzero(differs.any(axis=1))[0])
        f = fields[int(np.flatnonzero(differs[k])[0])]
        rows = df.index.to_numpy()[[same[k], same[k] + 1]] + 1
        raise DataError(
            f"{path}: records {min(rows)} and {max(rows)} have the same timestamp and different {f!r} "
            f"({a[k, fields.index(f)]:g} vs {b[k, fields.index(f)]:g}); expected one state per instant"
        )
    keep = np.ones(len(df), dtype=bool)
    keep[same + 1] = False
    return df[keep]


def load_measured(path: str | Path) -> Measured:
    """Recognise and load a measured-data file (see the module docstring)."""
    path = Path(path)
    data = _raw_bytes(path)
    table = _table(path, data)
    if table is not None:
        cols = set(table.columns)
        if set(OBSERVATION_COLUMNS) <= cols:
            return Measured("observation_table", table, path)
        if set(APPROACH_COLUMNS) <= cols:
            return Measured("approach_log", table, path)
        raise DataError(f"{path}: a table with columns {', '.join(map(str, table.columns[:12]))}; expected {_EXPECTED}")
    obj = _json(path, data)
    if (
        isinstance(obj, dict)
        and {"timestamp", "pitch", "roll"} <= set(obj)
        and all(isinstance(v, dict) for v in obj.values())
    ):
        df = pd.DataFrame({k: pd.Series(v) for k, v in obj.items()})
        df.index = df.index.astype(int)
        df = _checked_records(path, df.sort_index().reset_index(drop=True), "row")
        df.insert(0, "time_s", _epoch_seconds(df["timestamp"]))
        return Measured("qar", df, path)
    if isinstance(obj, list) and obj and all(isinstance(r, dict) for r in obj):
        df = pd.DataFrame(obj)
        cols = set(df.columns)
        if {"timestamp", "df", "frame"} <= cols:
            kind = "modes_raw"
        elif {"timestamp", "latitude", "longitude", "heading", "TAS"} <= cols:
            kind = "modes_track"
        elif {"timestamp", "latitude", "longitude", "groundspeed", "track"} <= cols:
            kind = "adsb_track"
        else:
            raise DataError(f"{path}: JSON records with keys {', '.join(sorted(cols)[:12])}; expected {_EXPECTED}")
        df = _checked_records(path, df, "line" if kind == "modes_raw" else "record")
        df.insert(0, "time_s", _epoch_seconds(df["timestamp"]))
        df = df.sort_values("time_s", kind="stable")
        if kind != "modes_raw":  # one state per instant (raw messages share instants)
            df = _one_state_per_time(path, df)
        return Measured(kind, df.reset_index(drop=True), path)
    raise DataError(f"{path}: not measured data aerotruth knows; expected {_EXPECTED}")
