"""Flight-tracker exports read for what they carry, into the state table of
aerotruth.measured.traffic (the `traffic` library's column names; that module makes it the
canonical frame):

* readsb / tar1090 / adsb.lol `trace_full` JSON (readsb's README-json.md, "trace jsons"): an
  object with `icao`, `timestamp` (epoch s) and `trace`, a list of points
  `[seconds after timestamp, lat, lon, altitude in ft or "ground" or null, ground speed kt,
  track deg, flags, vertical rate ft/min, details or null, ...]`. Flags: 8 = the altitude is
  geometric, not barometric (then no pressure altitude); 4 = the vertical rate is geometric.
  On the ground the track is a true heading: such points carry no pressure altitude and are
  left out. The details object (readsb's aircraft.json fields, written on some points only)
  gives `tas`, `mag_heading` (used as the magnetic heading), `true_heading` (readsb's, in the
  air mostly the magnetic heading turned true with its own magnetic model: used only where
  there is no `mag_heading`; the traffic reader turns it magnetic again with the same IGRF
  declination the wind method adds, so the method sees readsb's true heading), `roll`, `ias`,
  `mach`. Points without details carry no TAS or heading: they stay in the table and are
  counted incomplete. Fields after the details object are not read.
* Flightradar24-style track JSON (the playback answer `result.response.data.flight.track`,
  or any object or list holding such a `track`): points with `latitude`, `longitude`,
  `altitude` ({"feet": ..} or ft: FR24's barometric altitude), `speed` ({"kts": ..} or kt:
  ground speed), `heading` (FR24's name for the ground track), `verticalSpeed` ({"fpm": ..}
  or ft/min), `timestamp` and `ems` (enhanced Mode-S: `tas`, `ias`, `mach` (thousandths
  when above 5: 704 = M 0.704), `heading` or `mag_hdg` (the BDS 6,0 magnetic heading),
  `rollAngle` or `roll`, `ts` (its own time), and fields not read here: `oat`, wind
  `windDir`/`windSpd`, GPS altitude `agps`/`altGps`, selected altitudes). EMS values more
  than EMS_AGE_S from their point's time are not taken (counted).

A file whose points never carry both a TAS and a heading is refused in one DataError naming
the file and what it lacks; bad values (text in a number field, a point that is not a list)
are one DataError naming the point and the field.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd

from aerotruth.errors import DataError

EMS_AGE_S = 5.0  # an EMS sample this far from its point's time is not that point's
STATE_COLUMNS = (
    "icao24", "timestamp", "latitude", "longitude", "altitude", "groundspeed", "track", "heading",
    "true_heading", "TAS", "IAS", "Mach", "roll", "vertical_rate",
)  # fmt: skip


def _number(value: Any, where: str, field: str) -> float:
    """A JSON number (None: NaN); DataError naming `where` and `field` for anything else."""
    if value is None:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise DataError(f"{where}, field {field!r}: expected a number, got {value!r}")
    return float(value)


def _table(rows: list[dict[str, Any]]) -> pd.DataFrame:
    out = pd.DataFrame(rows, columns=list(STATE_COLUMNS))
    num = [c for c in STATE_COLUMNS if c != "icao24"]
    out[num] = out[num].astype(float)
    return out


def is_trace_full(doc: Any) -> bool:
    """Whether a JSON document is a readsb trace (an object with `timestamp` and `trace`)."""
    return isinstance(doc, dict) and "timestamp" in doc and isinstance(doc.get("trace"), list)


def read_trace_full(doc: dict[str, Any], source: str) -> pd.DataFrame:
    """A readsb `trace_full` document as the state table (module docstring)."""
    base = _number(doc.get("timestamp"), source, "timestamp")
    if not math.isfinite(base):
        raise DataError(f"{source}: trace_full without a 'timestamp' (epoch s) for its points' offsets")
    icao = str(doc.get("icao") or "").strip().lower()
    rows, with_details = [], 0
    for i, p in enumerate(doc["trace"], 1):
        where = f"{source}: trace point {i}"
        if not isinstance(p, list) or len(p) < 6:
            raise DataError(f"{where}: expected [seconds, lat, lon, altitude, ground speed, track, ...], got {p!r:.80}")
        flags = int(_number(p[6], where, "flags")) if len(p) > 6 and p[6] is not None else 0
        on_ground = p[3] == "ground"
        alt = math.nan if on_ground or flags & 8 else _number(p[3], where, "altitude")
        details = p[8] if len(p) > 8 else None
        if details is not None and not isinstance(details, dict):
            raise DataError(f"{where}: the details object (9th entry) is {type(details).__name__}, expected an object")
        d = details or {}
        with_details += bool(d)
        rows.append(
            {
                "icao24": icao,
                "timestamp": base + _number(p[0], where, "seconds after timestamp"),
                "latitude": _number(p[1], where, "lat"),
                "longitude": _number(p[2], where, "lon"),
                "altitude": alt,
                "groundspeed": _number(p[4], where, "ground speed"),
                "track": math.nan if on_ground else _number(p[5], where, "track"),
                "heading": _number(d.get("mag_heading"), where, "mag_heading"),
                "true_heading": _number(d.get("true_heading"), where, "true_heading"),
                "TAS": _number(d.get("tas"), where, "tas"),
                "IAS": _number(d.get("ias"), where, "ias"),
                "Mach": _number(d.get("mach"), where, "mach"),
                "roll": _number(d.get("roll"), where, "roll"),
                "vertical_rate": _number(p[7], where, "vertical rate") if len(p) > 7 else math.nan,
            }
        )
    out = _table(rows)
    has_tas = np.isfinite(out["TAS"].to_numpy())
    has_hdg = np.isfinite(out["heading"].to_numpy()) | np.isfinite(out["true_heading"].to_numpy())
    if not (has_tas & has_hdg).any():
        what = (
            "TAS or magnetic heading"
            if not has_tas.any() and not has_hdg.any()
            else ("TAS" if not has_tas.any() else ("magnetic heading" if not has_hdg.any() else "TAS with a heading"))
        )
        raise DataError(
            f"{source}: trace_full: no {what} in any point (readsb's details object, in {with_details} of "
            f"{len(out)} points): the wind triangle needs both"
        )
    out.attrs["tracker"] = {"points": len(out), "points with details": with_details}
    return out


def _find_track(doc: Any, depth: int = 0) -> tuple[list[Any], dict[str, Any]] | None:
    """(track points, the object holding them) of a Flightradar24-style document."""
    if depth > 6:
        return None
    if isinstance(doc, list):
        if doc and all(isinstance(p, dict) for p in doc) and any("ems" in p for p in doc):
            return doc, {}
        return None
    if not isinstance(doc, dict):
        return None
    track = doc.get("track")
    if isinstance(track, list) and track and all(isinstance(p, dict) for p in track):
        if any(("latitude" in p or "lat" in p) for p in track):
            return track, doc
    for v in doc.values():
        if isinstance(v, dict | list):
            found = _find_track(v, depth + 1)
            if found is not None:
                return found
    return None


def is_fr24(doc: Any) -> bool:
    """Whether a JSON document holds a Flightradar24-style track (module docstring)."""
    return not is_trace_full(doc) and _find_track(doc) is not None


def _unit(value: Any, key: str, where: str, field: str) -> float:
    """FR24's {"feet": .., "meters": ..} style values, or a bare number."""
    if isinstance(value, dict):
        return _number(value.get(key), where, f"{field}.{key}")
    return _number(value, where, field)


def _first(d: dict[str, Any], names: tuple[str, ...]) -> tuple[str, Any]:
    for n in names:
        if n in d:
            return n, d[n]
    return names[0], None


def _seconds(t: float) -> float:
    return t / 1000.0 if abs(t) > 1e11 else t


def read_fr24(doc: Any, source: str, aircraft: str) -> pd.DataFrame:
    """A Flightradar24-style track (module docstring) as the state table; `aircraft` labels it
    when the document names no Mode-S address."""
    found = _find_track(doc)
    if found is None:
        raise DataError(f"{source}: no Flightradar24 track (a list of points with latitude, longitude, ems)")
    track, holder = found
    air = holder.get("aircraft")
    ident: dict[str, Any] = {}
    if isinstance(air, dict):
        ident = air["identification"] if isinstance(air.get("identification"), dict) else air
    label = str(ident.get("modes") or ident.get("hex") or holder.get("icao24") or aircraft).strip().lower()
    rows, with_ems, stale = [], 0, 0
    ems_keys: set[str] = set()
    for i, p in enumerate(track, 1):
        where = f"{source}: track point {i}"
        ems = p.get("ems")
        if ems is not None and not isinstance(ems, dict):
            raise DataError(f"{where}: 'ems' is {type(ems).__name__}, expected an object or null")
        t = _seconds(_number(p.get("timestamp"), where, "timestamp"))
        e = {str(k).lower().replace("_", ""): v for k, v in (ems or {}).items()}
        ems_keys |= set((ems or {}).keys())
        if e and "ts" in e and e["ts"] is not None:
            if abs(_seconds(_number(e["ts"], where, "ems.ts")) - t) > EMS_AGE_S:
                stale += 1
                e = {}
        with_ems += bool(e)
        mach = _number(e.get("mach"), where, "ems.mach")
        hk, hv = _first(e, ("maghdg", "magheading", "heading", "hdg"))
        rk, rv = _first(e, ("rollangle", "roll"))
        lat_k, lat_v = _first(p, ("latitude", "lat"))
        lon_k, lon_v = _first(p, ("longitude", "lon", "lng"))
        trk_k, trk_v = _first(p, ("heading", "track"))
        vs_k, vs_v = _first(p, ("verticalSpeed", "vspeed", "vertical_rate"))
        rows.append(
            {
                "icao24": label,
                "timestamp": t,
                "latitude": _number(lat_v, where, lat_k),
                "longitude": _number(lon_v, where, lon_k),
                "altitude": _unit(p.get("altitude"), "feet", where, "altitude"),
                "groundspeed": _unit(p.get("speed", p.get("groundspeed")), "kts", where, "speed"),
                "track": _number(trk_v, where, trk_k),
                "heading": _number(hv, where, f"ems.{hk}"),
                "true_heading": math.nan,
                "TAS": _number(e.get("tas"), where, "ems.tas"),
                "IAS": _number(e.get("ias"), where, "ems.ias"),
                "Mach": mach / 1000.0 if mach > 5 else mach,
                "roll": _number(rv, where, f"ems.{rk}"),
                "vertical_rate": _unit(vs_v, "fpm", where, vs_k),
            }
        )
    out = _table(rows)
    has_tas, has_hdg = np.isfinite(out["TAS"].to_numpy()), np.isfinite(out["heading"].to_numpy())
    if not (has_tas & has_hdg).any():
        lacks = [n for n, has in (("TAS", has_tas.any()), ("magnetic heading", has_hdg.any())) if not has]
        what = " and ".join(lacks) if lacks else "TAS together with a magnetic heading"
        keys = ", ".join(sorted(ems_keys)) or "none"
        raise DataError(
            f"{source}: Flightradar24 track: no {what} in any point's ems (ems in {with_ems} of {len(out)} "
            f"points, fields {keys}): the wind triangle needs both"
        )
    out.attrs["tracker"] = {"points": len(out), "points with ems": with_ems, "ems more than 5 s off": stale}
    return out
