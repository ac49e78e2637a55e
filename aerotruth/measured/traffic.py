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
(true), heading_mag_deg, tas_kt, flight (1, 2, ... per aircraft: a new flight after a pause
of over 30 min, or when it is airborne again after samples on the ground), and where the
table has them vertical_rate_fpm and roll_deg. Samples the table flags as on the ground
(`onground`, `on_ground`) are left out and counted; a flag-less table is taken as airborne
(ground samples then fail the wind method's TAS gate, 60 kt).
Numeric times are epoch seconds, or milliseconds (told apart by size). A table with a
`true_heading` column (readsb's name) and no magnetic heading on a row takes the true heading
less the IGRF declination the wind method adds back (aerotruth.analysis.wind.consensus).

`read_traffic` recognises a file from its content (FORMATS; gzip by its magic bytes): a
decoded state table as CSV, Parquet, JSON records or JSON lines (in the names above; a
file without an aircraft column is one aircraft, labelled by the file's name), raw Mode-S
frames (aerotruth.measured.frames, with the optional pyModeS), a readsb/tar1090 trace or a
Flightradar24 track with EMS fields (aerotruth.measured.trackers). Anything else is one
DataError naming the formats accepted; a file of a known kind that lacks what the wind
method needs is one DataError naming everything it lacks.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.dates import MODEL_DATE_SPAN, MODEL_EPOCH_S
from aerotruth.errors import DataError
from aerotruth.measured import frames, trackers
from aerotruth.measured.kinds import check_speed_units, check_values, epoch_seconds, file_bytes, json_of, table_of
from aerotruth.measured.observations import table_kind
from aerotruth.measured.tables import numeric_column, read_csv_table, read_parquet_table
from aerotruth.units import FT, KT

FORMATS = (
    "a decoded Mode-S/ADS-B state table (CSV, Parquet or JSON records: icao24, timestamp, latitude, longitude, "
    "altitude, groundspeed, track, heading, TAS), raw Mode-S frames (CSV, JSON lines or Parquet: a hex message "
    "column rawmsg/msg/message/hex/frame and a timestamp), a readsb/tar1090 trace_full JSON or a Flightradar24 "
    "track JSON with ems fields"
)

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
    "true_heading_deg": [("true_heading", 1.0), ("true_heading_deg", 1.0)],
}
REQUIRED = ("aircraft", "time", "lat", "lon", "pressure_altitude_ft", "gs_kt", "track_deg", "heading_mag_deg", "tas_kt")
NUMERIC = tuple(c for c in ALIASES if c not in ("aircraft", "time"))


def _source_columns(columns) -> dict[str, str]:
    """{lower-case name: the table's own spelling}."""
    return {str(c).strip().lower(): c for c in columns}


def _lacks(cols: dict[str, str], missing: list[str]) -> str:
    """The refusal's clause naming all that a table lacks, in the words of
    aerotruth.measured.modes.lacking (diagnose's refusal)."""
    words = []
    if "lat" in missing or "lon" in missing:
        words.append("position (latitude, longitude)")
    if "pressure_altitude_ft" in missing:
        words.append("pressure altitude (altitude, ft)")
    if "gs_kt" in missing:
        words.append("ground speed (groundspeed)")
    if "track_deg" in missing:
        words.append("track")
    drift = "track" in cols and "drift" in cols  # track - drift is a heading, of the track's reference
    if "heading_mag_deg" in missing and (not drift or missing == ["heading_mag_deg"]):
        words.append(
            "the aircraft's magnetic heading (Mode-S BDS 6,0, `heading` in traffic's names"
            + ("; its track - drift is a heading in the track's reference, not known magnetic)" if drift else ")")
        )
    if "tas_kt" in missing:
        other = [n.upper() for n in ("cas", "ias") if n in cols] + (["Mach"] if "mach" in cols else [])
        has = f"; it has {' and '.join(other)}, but no air temperature to convert it" if other else ""
        words.append(f"the true airspeed (Mode-S BDS 5,0, `TAS`{has})")
    if "aircraft" in missing:
        words.append("an aircraft identifier (icao24)")
    if "time" in missing:
        words.append("a time (timestamp)")
    return ", ".join(words[:-1]) + (" and " if len(words) > 1 else "") + words[-1]


def canonical_traffic(
    df: pd.DataFrame, source: str, kind: str | None = None, default_aircraft: str | None = None
) -> pd.DataFrame:
    """The canonical frame (module docstring) of a decoded state table; DataError naming the
    source and all the columns a winds-aloft method needs and the table lacks. `kind` names
    the table in that message; `default_aircraft` labels a table without an aircraft column
    (one aircraft's flight)."""
    cols = _source_columns(df.columns)
    opensky = "baroaltitude" in cols or "vertrate" in cols
    kind = "OpenSky state vectors" if opensky else (kind or "state table")
    out = {}
    for name, options in ALIASES.items():
        for alias, factor in options:
            if alias in cols:
                out[name] = (cols[alias], factor)
                break
        if name == "heading_mag_deg" and name not in out and "heading" in cols and not opensky:
            out[name] = (cols["heading"], 1.0)  # traffic's `heading`: BDS 6,0, magnetic
        if name == "track_deg" and name not in out and "heading" in cols and opensky:
            out[name] = (cols["heading"], 1.0)  # OpenSky's `heading` is the true track
    if "aircraft" not in out and default_aircraft is not None:
        df = df.assign(_aircraft=default_aircraft)
        out["aircraft"] = ("_aircraft", 1.0)
    if "heading_mag_deg" not in out and "true_heading_deg" in out:
        df = df.assign(_heading_mag=np.nan)
        out["heading_mag_deg"] = ("_heading_mag", 1.0)
    missing = [c for c in REQUIRED if c not in out]
    if missing:
        raise DataError(
            f"{source}: {kind} without {_lacks(cols, missing)}; a winds-aloft method needs position, "
            f"pressure altitude, ground speed and track with each aircraft's own true airspeed and heading "
            f"(columns {', '.join(sorted(cols))})"
        )
    frame = pd.DataFrame({"aircraft": df[out["aircraft"][0]].astype(str).str.strip().str.lower()})
    frame["time_s"] = epoch_seconds(df[out["time"][0]], source, str(out["time"][0])).to_numpy(dtype=float)
    _check_times(frame["time_s"].to_numpy(), df[out["time"][0]], source, str(out["time"][0]))
    for name in NUMERIC:
        if name not in out:
            continue
        col, factor = out[name]
        if df[col].dtype.kind == "b" or (df[col].dtype == object and df[col].map(lambda v: isinstance(v, bool)).any()):
            raise DataError(f"{source}: column {str(col)!r} holds true/false, expected numbers")
        frame[name] = numeric_column(df, col, source).to_numpy() * factor
        check_values(source, frame[name], RANGE_OF[name], "data row", shown=str(col))
    if "true_heading_deg" in frame:
        take = ~np.isfinite(frame["heading_mag_deg"].to_numpy()) & np.isfinite(frame["true_heading_deg"].to_numpy())
        take &= np.isfinite(frame[["time_s", "lat", "lon", "pressure_altitude_ft"]].to_numpy(dtype=float)).all(axis=1)
        if take.any():
            from aerotruth.analysis.wind.consensus import declination_deg

            true_heading = frame.loc[take, "true_heading_deg"].to_numpy()
            frame.loc[take, "heading_mag_deg"] = (true_heading - declination_deg(frame[take])) % 360.0
        frame = frame.drop(columns="true_heading_deg")
        frame.attrs["headings_from_true"] = int(take.sum())
    ground = np.zeros(len(frame), dtype=bool)
    flag = next((cols[c] for c in GROUND_FLAGS if c in cols), None)
    if flag is not None:  # the table's airborne/ground state (ADS-B surface vs airborne messages)
        ground = df[flag].map(_truthy).to_numpy(dtype=bool)
    need = ["time_s", *REQUIRED[2:]]
    complete = np.isfinite(frame[need].to_numpy(dtype=float)).all(axis=1) & (frame["aircraft"] != "")
    attrs = dict(frame.attrs)
    frame["_ground"] = ground
    frame = frame[complete].sort_values(["aircraft", "time_s"], kind="stable").reset_index(drop=True)
    _check_repeats(frame, source, {name: str(col) for name, (col, _) in out.items()})
    check_speed_units(frame["gs_kt"], frame["tas_kt"], source, str(out["gs_kt"][0]), str(out["tas_kt"][0]))
    frame["flight"] = flight_numbers(
        frame["aircraft"].to_numpy(), frame["time_s"].to_numpy(), frame["_ground"].to_numpy(dtype=bool)
    )
    on_ground = frame["_ground"].to_numpy(dtype=bool)
    frame = frame[~on_ground].drop(columns="_ground").reset_index(drop=True)
    frame.attrs.update(attrs)
    frame.attrs["rows_read"] = int(len(complete))
    frame.attrs["rows_incomplete"] = int((~complete).sum())
    frame.attrs["rows_on_ground"] = int(on_ground.sum())
    if len(frame) == 0:
        raise DataError(f"{source}: no airborne row has every value a winds-aloft method needs ({', '.join(REQUIRED)})")
    return frame


# each canonical column's range: that of the Mode-S field of its unit (aerotruth.measured.kinds.FIELD_RANGES)
RANGE_OF = {
    "lat": "latitude",
    "lon": "longitude",
    "pressure_altitude_ft": "altitude",
    "gs_kt": "groundspeed",
    "track_deg": "track",
    "heading_mag_deg": "heading",
    "tas_kt": "TAS",
    "vertical_rate_fpm": "vertical_rate",
    "roll_deg": "roll",
    "true_heading_deg": "heading",
}


def _check_times(t: np.ndarray, given: pd.Series, source: str, column: str) -> None:
    """Times within the dates aerotruth models (the declination comes from IGRF); empty passes."""
    lo, hi = MODEL_EPOCH_S
    with np.errstate(invalid="ignore"):
        bad = np.isinf(t) | (t < lo) | (t >= hi)
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        v = given.iloc[i]
        raise DataError(
            f"{source}: column {column!r} data row {i + 1}: {v.item() if isinstance(v, np.generic) else v!r} "
            f"is not a time from {MODEL_DATE_SPAN}"
        )


def _check_repeats(frame: pd.DataFrame, source: str, shown: dict[str, str]) -> None:
    """Two rows of one aircraft at one time must agree (an exact repeat is harmless; two
    different states of one instant cannot both be the aircraft's)."""
    a, t = frame["aircraft"].to_numpy(), frame["time_s"].to_numpy()
    same = np.flatnonzero((a[1:] == a[:-1]) & (t[1:] == t[:-1]))
    if not len(same):
        return
    values = frame[list(REQUIRED[2:])].to_numpy(dtype=float)
    differs = ~((values[same] == values[same + 1]) | (np.isnan(values[same]) & np.isnan(values[same + 1])))
    if differs.any():
        i = int(same[np.flatnonzero(differs.any(axis=1))[0]])
        col = REQUIRED[2:][int(np.flatnonzero(differs[np.flatnonzero(differs.any(axis=1))[0]])[0])]
        when = pd.Timestamp(t[i], unit="s", tz="UTC").isoformat()
        raise DataError(
            f"{source}: aircraft {a[i]!r} has two samples at {when} with different {shown.get(col, col)!r} "
            f"({values[i, REQUIRED[2:].index(col)]:g} vs {values[i + 1, REQUIRED[2:].index(col)]:g}); "
            "expected one state per aircraft and time"
        )


# the airborne/ground flag under the names decoders write (traffic, OpenSky: onground)
GROUND_FLAGS = ("onground", "on_ground", "ground")
FLIGHT_GAP_S = 1800.0  # a longer pause in an aircraft's samples starts a new flight (as heading fit's)


def _truthy(v) -> bool:
    if isinstance(v, str):
        return v.strip().lower() in ("true", "1", "yes", "t", "ground")
    return bool(v) if v is not None and v == v else False


def flight_numbers(aircraft: np.ndarray, t: np.ndarray, ground: np.ndarray) -> np.ndarray:
    """Flight number (1, 2, ...) of each sample of an aircraft, samples in time order within
    each aircraft: a new flight after a pause of more than FLIGHT_GAP_S, or where the
    aircraft is airborne again after samples on the ground (it landed and left again)."""
    n = len(t)
    out = np.ones(n, dtype=np.int64)
    if n == 0:
        return out
    new_ac = np.r_[True, aircraft[1:] != aircraft[:-1]]
    took_off = np.r_[False, ground[:-1] & ~ground[1:]] & ~new_ac
    gap = np.r_[False, np.diff(t) > FLIGHT_GAP_S] & ~new_ac
    step = (took_off | gap).astype(np.int64)
    count = np.cumsum(step)
    first = np.maximum.accumulate(np.where(new_ac, np.arange(n), 0))
    return count - count[first] + 1


def _json_table(doc) -> tuple[str, pd.DataFrame] | None:
    """(kind, table) of a JSON document that is a table: records, or columns of {row: value}."""
    if isinstance(doc, list) and doc and all(isinstance(r, dict) for r in doc):
        return "trajectory records", pd.DataFrame(doc)
    if isinstance(doc, dict) and doc and all(isinstance(v, dict) for v in doc.values()):
        table = pd.DataFrame({k: pd.Series(v) for k, v in doc.items()})
        try:
            table.index = table.index.astype(int)
        except (TypeError, ValueError):
            return None
        return "flight-data-recorder extract", table.sort_index().reset_index(drop=True)
    return None


def _looks_like_traffic(table: pd.DataFrame) -> bool:
    """A time column and at least one column of an aircraft's state: a state table, complete or not."""
    cols = set(_source_columns(table.columns))
    state = {alias for name, options in ALIASES.items() if name not in ("aircraft", "time") for alias, _ in options}
    return bool(cols & {alias for alias, _ in ALIASES["time"]}) and bool(cols & (state | {"heading", "cas", "drift"}))


def read_traffic(path: str | Path) -> pd.DataFrame:
    """Read a traffic file (module docstring: FORMATS, recognised from the content) into the
    canonical frame; a file of raw frames carries its decoding counts in attrs["frames"]."""
    p = Path(path)
    source = str(p)
    if not p.exists():
        raise DataError(f"{p}: no such file")
    kind = table_kind(p)
    table: pd.DataFrame | None = None
    what = "state table"
    if kind is not None:
        try:
            table = read_csv_table(p) if kind == "csv" else read_parquet_table(p)
        except Exception as e:  # noqa: BLE001 - any reader failure is one line about the file
            raise DataError(f"{p}: not a readable table ({str(e).splitlines()[0]})") from None
    else:
        data = file_bytes(p)
        table = table_of(p, data)
        if table is None:
            doc = json_of(p, data)
            if trackers.is_trace_full(doc):
                trace = trackers.read_trace_full(doc, source)
                return _carry(canonical_traffic(trace, source, "trace_full"), trace)
            if trackers.is_fr24(doc):
                fr24 = trackers.read_fr24(doc, source, p.name.split(".")[0])
                return _carry(canonical_traffic(fr24, source, "Flightradar24 track"), fr24)
            found = _json_table(doc)
            if found is not None:
                what, table = found
    if table is None or not len(table.columns):
        raise DataError(f"{p}: not traffic aerotruth reads; expected {FORMATS}")
    if frames.frame_columns(table) is not None:
        states = frames.read_frames(table, source)
        return _carry(canonical_traffic(states, source, "raw Mode-S frames"), states)
    if not _looks_like_traffic(table):
        shown = ", ".join(map(str, table.columns[:8])) + (", ..." if len(table.columns) > 8 else "")
        raise DataError(f"{p}: a table with columns {shown}: not traffic aerotruth reads; expected {FORMATS}")
    return canonical_traffic(table, source, what, default_aircraft=p.name.split(".")[0])


def _carry(frame: pd.DataFrame, states: pd.DataFrame) -> pd.DataFrame:
    """The canonical frame with the reader's counts of its input (attrs "frames", "tracker")."""
    frame.attrs.update(states.attrs)
    return frame
