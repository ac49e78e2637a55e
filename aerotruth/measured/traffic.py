"""Multi-aircraft traffic as decoders write it: a decoded Mode-S / ADS-B state table (CSV,
gzip CSV or Parquet), any number of aircraft per file, read into one canonical frame.

Column names are matched case-insensitively through ALIASES, each with its source's
meaning and unit (the `traffic` library's names: icao24, timestamp, latitude, longitude,
altitude in ft, groundspeed in kt, track in deg, heading = BDS 6,0 *magnetic* heading, TAS in
kt, vertical_rate in ft/min, roll in deg; OpenSky's state vectors: time, lat, lon,
baroaltitude in m, velocity in m/s, heading = the true *track*, vertrate in m/s). A winds-aloft
method needs, per sample, position, pressure altitude, ground speed and track (ADS-B) and
the aircraft's own true airspeed and magnetic heading (BDS 5,0 and 6,0): a table without
them is refused naming the column it lacks (OpenSky's state vectors carry no TAS or
heading, so they are). Values at any resolution are taken as they are (a register's LSB is
the source's, never a reason to drop a row); rows missing one of the needed values are left
out and counted.

The canonical frame (SI at the boundary only where the contract's names say so):
aircraft, time_s (UTC epoch s), lat, lon (deg), pressure_altitude_ft, gs_kt, track_deg
(true), heading_mag_deg, tas_kt, and where the table has them vertical_rate_fpm and roll_deg.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.errors import DataError
from aerotruth.measured.observations import table_kind
from aerotruth.measured.tables import numeric_column, read_csv_table, read_parquet_table
from aerotruth.units import FT, KT

# canonical name -> [(source column name, factor to the canonical unit), ...] in order of
# preference; a name's meaning must match (OpenSky's `heading` is a track, so it maps to track)
ALIASES: dict[str, list[tuple[str, float]]] = {
    "aircraft": [("icao24", 1.0), ("aircraft", 1.0), ("callsign", 1.0)],
    "time": [("timestamp", 1.0), ("time", 1.0), ("time_s", 1.0)],
    "lat": [("latitude", 1.0), ("lat", 1.0)],
    "lon": [("longitude", 1.0), ("lon", 1.0)],
    "pressure_altitude_ft": [("altitude", 1.0), ("pressure_altitude_ft", 1.0), ("baroaltitude", 1.0 / FT)],
    "gs_kt": [("groundspeed", 1.0), ("gs_kt", 1.0), ("velocity", 1.0 / KT)],
    "track_deg": [("track", 1.0), ("track_deg", 1.0)],
    "heading_mag_deg": [("heading_mag_deg", 1.0)],
    "tas_kt": [("tas", 1.0), ("tas_kt", 1.0)],
    "vertical_rate_fpm": [("vertical_rate", 1.0), ("vertrate", 60.0 / FT)],
    "roll_deg": [("roll", 1.0), ("roll_deg", 1.0)],
}
REQUIRED = ("aircraft", "time", "lat", "lon", "pressure_altitude_ft", "gs_kt", "track_deg", "heading_mag_deg", "tas_kt")
NUMERIC = tuple(c for c in ALIASES if c not in ("aircraft", "time"))


def _source_columns(columns) -> dict[str, str]:
    """{lower-case name: the table's own spelling}."""
    return {str(c).strip().lower(): c for c in columns}


def canonical_traffic(df: pd.DataFrame, source: str) -> pd.DataFrame:
    """The canonical frame (module docstring) of a decoded state table; DataError naming the
    source and the column on anything a winds-aloft method cannot use."""
    cols = _source_columns(df.columns)
    kind = "OpenSky state vectors" if "baroaltitude" in cols or "vertrate" in cols else "state table"
    out = {}
    for name, options in ALIASES.items():
        for alias, factor in options:
            if alias in cols:
                out[name] = (cols[alias], factor)
                break
        if name == "heading_mag_deg" and name not in out and "heading" in cols and kind != "OpenSky state vectors":
            out[name] = (cols["heading"], 1.0)  # traffic's `heading`: BDS 6,0, magnetic
        if name == "track_deg" and name not in out and "heading" in cols and kind == "OpenSky state vectors":
            out[name] = (cols["heading"], 1.0)  # OpenSky's `heading` is the true track
    missing = [c for c in REQUIRED if c not in out]
    if missing:
        what = {
            "heading_mag_deg": "the aircraft's magnetic heading (Mode-S BDS 6,0, `heading` in traffic's names)",
            "tas_kt": "the true airspeed (Mode-S BDS 5,0, `TAS`)",
        }.get(missing[0], f"'{missing[0]}'")
        raise DataError(
            f"{source}: {kind} without {what}; a winds-aloft method needs position, pressure altitude, "
            f"ground speed and track with each aircraft's own true airspeed and heading "
            f"(columns {', '.join(sorted(cols))})"
        )
    frame = pd.DataFrame({"aircraft": df[out["aircraft"][0]].astype(str).str.strip().str.lower()})
    t = df[out["time"][0]]
    if pd.api.types.is_numeric_dtype(t):
        frame["time_s"] = t.to_numpy(dtype=float)
    else:
        parsed = pd.to_datetime(t, utc=True, errors="coerce", format="mixed")
        if parsed.isna().any() and t.notna().any():
            bad = t[parsed.isna() & t.notna()]
            if len(bad):
                raise DataError(
                    f"{source}: column {out['time'][0]!r}: expected UTC epoch seconds or ISO-8601 times, "
                    f"got {bad.iloc[0]!r}"
                )
        frame["time_s"] = (parsed - pd.Timestamp("1970-01-01", tz="UTC")).dt.total_seconds().to_numpy()
    for name in NUMERIC:
        if name not in out:
            continue
        col, factor = out[name]
        frame[name] = numeric_column(df, col, source).to_numpy() * factor
    need = ["time_s", *REQUIRED[2:]]
    keep = np.isfinite(frame[need].to_numpy(dtype=float)).all(axis=1) & (frame["aircraft"] != "")
    frame = frame[keep].sort_values(["aircraft", "time_s"], kind="stable").reset_index(drop=True)
    frame.attrs["rows_read"] = int(len(keep))
    frame.attrs["rows_incomplete"] = int((~keep).sum())
    if len(frame) == 0:
        raise DataError(f"{source}: no row has every value a winds-aloft method needs ({', '.join(REQUIRED)})")
    return frame


def read_traffic(path: str | Path) -> pd.DataFrame:
    """Read a decoded state table file into the canonical frame."""
    p = Path(path)
    kind = table_kind(p)
    if kind is None:
        raise DataError(f"{p}: expected a .csv, .csv.gz or .parquet state table, got '{p.suffix or 'no extension'}'")
    if not p.is_file():
        raise DataError(f"{p}: no such file")
    try:
        df = read_csv_table(p) if kind == "csv" else read_parquet_table(p)
    except Exception as e:  # noqa: BLE001 - any reader failure is one line about the file
        raise DataError(f"{p}: not a readable table ({str(e).splitlines()[0]})") from None
    return canonical_traffic(df, str(p))
