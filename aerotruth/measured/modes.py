"""Mode-S data (a decoded Mode-S trajectory or a raw message log, aerotruth.measured.kinds)
as the Mode-S wind frame that `diagnose` fits (aerotruth.analysis.wind.modes_wind): BDS 6,0
magnetic heading, BDS 5,0 TAS, ADS-B track, ground speed and position per sample, with
the samples left out and why (missing fields, a zero-g parabola, a climb, a level speed
change: the gates of aerotruth.analysis.diagnose.modes), the aircraft's type and the
registers' resolution.

Values come at any resolution: a register's LSB (BDS 6,0 heading 90/512 deg, BDS 5,0 TAS
2 kt) is a property of the source, inferred from the values (`register_lsb`) or given,
and reported; a value between grid points (a resampler's interpolation, a decoder that
rounds to 0.1 deg) is kept.

The aircraft type (aerotruth.truth.aircraft_types, for the angle of attack of the air
track) is, in this order: the one given (`aircraft_type`, an ICAO designator, with
`engine_type` for a type not listed), the data's own type designator field (TYPE_FIELDS),
the generic class of the data's engine field, or, from the data's speed, the generic jet
for a flight above Mach JET_MACH (a turboprop does not fly that fast) and otherwise the
simulation's SAAB 340B."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd

from aerotruth.analysis.diagnose.modes import (
    HELD_APART_DEG,
    LEVEL_FPM,
    PARABOLA_FPM,
    PARABOLA_MARGIN_S,
    SPEED_HALF_WINDOW_S,
    SPEED_RATE_KT_S,
)
from aerotruth.analysis.wind.modes_wind import central_rate, modes_track_to_wind_frame
from aerotruth.errors import DataError, UserError
from aerotruth.measured.kinds import Measured
from aerotruth.truth.aircraft_types import (
    GENERIC,
    GENERIC_JET,
    GENERIC_TURBOPROP,
    SAAB340,
    AircraftType,
    aircraft_type,
    engine_class,
)
from aerotruth.truth.isa import ISA_R_AIR, isa_temperature_k
from aerotruth.units import FT, KT

# the grids a field's values are tried on, coarse to fine: the Mode-S registers' LSBs
# (BDS 6,0 heading 90/512 deg; BDS 5,0 TAS 2 kt) and the decimal ones of decoders and exports
LSB_CANDIDATES = {
    "heading": ((1.0, 0.5, 90 / 512, 0.1, 0.05, 0.01), "deg"),
    "TAS": ((2.0, 1.0, 0.5, 0.1, 0.05, 0.01), "kt"),
}
ON_GRID_MIN = 0.25  # a source's grid holds at least this share of its values ...
COARSER_KEEPS = 0.8  # ... and at least this share of those on each finer candidate it is a multiple of
TYPE_FIELDS = ("typecode", "aircraft_type", "icao_type")  # an ICAO type designator per record
ENGINE_FIELDS = ("engine_type",)  # jet / turboprop, or an ICAO Doc 8643 description (L2J)
# A flight whose 95th percentile of Mach is above this is a jet's: turboprop airliners
# cruise below Mach 0.65 (ATR 72 and SAAB 340 about 0.45-0.5, Dash 8-400 0.6)
JET_MACH = 0.65


def on_grid(x: np.ndarray, lsb: float) -> np.ndarray:
    """Which values lie on the grid of step `lsb` (within 1e-3 of a step)."""
    r = np.mod(np.asarray(x, float) / lsb, 1.0)
    return (r < 1e-3) | (r > 1 - 1e-3)


def register_lsb(values: np.ndarray, candidates: tuple[float, ...]) -> tuple[float | None, float]:
    """The resolution a source gave a field at, from its values, and the share of the
    values on it: the coarsest candidate grid holding at least ON_GRID_MIN of the values
    that keeps COARSER_KEEPS of those on every finer candidate it is a multiple of (values
    sent in 1-deg steps lie half on a 2-deg grid: the 2-deg grid keeps half of the 1-deg
    grid's, so the LSB is 1 deg). (None, 0) when no candidate holds: a finer or no grid."""
    x = np.asarray(values, float)
    x = x[np.isfinite(x)]
    if len(x) == 0:
        return None, 0.0
    share = {c: float(on_grid(x, c).mean()) for c in candidates}
    for i, c in enumerate(candidates):
        finer = [f for f in candidates[i + 1 :] if on_grid(np.array([c]), f)[0]]
        if share[c] >= ON_GRID_MIN and all(share[c] >= COARSER_KEEPS * share[f] for f in finer):
            return c, share[c]
    return None, 0.0


def registers(d: pd.DataFrame, given: dict[str, float] | None = None) -> dict:
    """Each field's LSB (given, else inferred by `register_lsb`) and the share of the
    samples on its grid (the rest: between grid points, e.g. a resampler's interpolation)."""
    out = {}
    for name, (cands, unit) in LSB_CANDIDATES.items():
        x = d[name].to_numpy(float)
        lsb: float | None
        if given and name in given:
            lsb, src = float(given[name]), "given"
            share = float(on_grid(x[np.isfinite(x)], lsb).mean()) if np.isfinite(x).any() else 0.0
        else:
            lsb, share = register_lsb(x, cands)
            src = "inferred from the values"
        out[name] = {"lsb": lsb, "unit": unit, "source": src, "share_on_grid": share}
    return out


def _one_value(m: Measured, fields: tuple[str, ...]) -> tuple[str, str] | None:
    """(field, value) of the first of `fields` the records carry, one value for them all."""
    for f in fields:
        if f in m.df.columns:
            vals = sorted({str(v).strip() for v in m.df[f].dropna() if str(v).strip()})
            if len(vals) > 1:
                raise DataError(
                    f"{m.path}: field {f!r} names {len(vals)} values ({', '.join(vals[:5])}); diagnose takes "
                    "one aircraft's flight"
                )
            if vals:
                return f, vals[0]
    return None


def mach_p95(d: pd.DataFrame) -> float:
    """95th percentile of the flight's Mach: the data's (BDS 6,0) where it has it, else TAS
    over the ISA speed of sound at the pressure altitude."""
    if "Mach" in d and d["Mach"].notna().any():
        mach = d["Mach"].to_numpy(float)
    else:
        temp = isa_temperature_k(np.clip(d["altitude"].to_numpy(float) * FT, -500.0, 20000.0))
        mach = d["TAS"].to_numpy(float) * KT / np.sqrt(1.4 * ISA_R_AIR * temp)
    mach = mach[np.isfinite(mach)]
    return float(np.quantile(mach, 0.95)) if len(mach) else float("nan")


def aircraft_of(
    m: Measured, d: pd.DataFrame, designator: str | None = None, engine: str | None = None
) -> tuple[AircraftType, str]:
    """The flight's aircraft type and how it was chosen (module docstring); d: the joined
    samples (TAS, altitude, and Mach where the data have it)."""
    data_type = _one_value(m, TYPE_FIELDS)
    data_engine = _one_value(m, ENGINE_FIELDS)
    eng, eng_where = (engine, "--engine-type") if engine else (None, "")
    if eng is None and data_engine is not None:
        eng, eng_where = data_engine[1], f"{m.path}: field {data_engine[0]!r}"
    if designator:
        t, note = aircraft_type(designator, eng, "--aircraft-type")
        if data_type is not None and data_type[1].upper() != designator.strip().upper():
            return t, f"{note} (given; the data's {data_type[0]} says {data_type[1]})"
        return t, f"{note} (given)"
    if data_type is not None:
        field, value = data_type
        try:
            t, note = aircraft_type(value, eng, f"{m.path}: field {field!r}: aircraft type")
        except UserError as e:
            raise DataError(str(e)) from None
        return t, f"{note} (the data's {field})"
    if eng is not None:
        cls = engine_class(eng)
        if cls is None:
            error = UserError if engine else DataError
            raise error(f"{eng_where}: engine type {eng!r} is neither jet nor turboprop")
        return GENERIC[cls], f"{GENERIC[cls].name}, by its engines ({eng})"
    mach = mach_p95(d)
    if mach > JET_MACH:
        return GENERIC_JET, (
            f"{GENERIC_JET.name}: the data name no type, and a flight at Mach {mach:.2f} (95th percentile) is a "
            f"jet's (turboprops cruise below {JET_MACH}); give --aircraft-type for its own"
        )
    return SAAB340, (
        f"{SAAB340.name}, the simulation's aircraft: the data name no type and fly below Mach {JET_MACH} "
        f"(the {GENERIC_TURBOPROP.name} differs little); give --aircraft-type for its own"
    )


def held_apart(d: pd.DataFrame) -> np.ndarray:
    """Samples (d sorted by time) whose heading has stood still since the track moved more
    than HELD_APART_DEG, or whose track has since the heading did: the held value is of
    another instant than its partner (aerotruth.analysis.diagnose.modes.HELD_APART_DEG)."""
    h_raw, g_raw = d["heading"].to_numpy(float), d["track"].to_numpy(float)
    h, g = np.degrees(np.unwrap(np.radians(h_raw))), np.degrees(np.unwrap(np.radians(g_raw)))
    idx = np.arange(len(d))

    def last_change(x: np.ndarray) -> np.ndarray:  # index where each sample's value was first sent
        return np.maximum.accumulate(np.where(np.r_[True, np.diff(x) != 0], idx, 0))

    jh, jg = last_change(h_raw), last_change(g_raw)
    return (np.abs(g - g[jh]) > HELD_APART_DEG) | (np.abs(h - h[jg]) > HELD_APART_DEG)


def lacking(df: pd.DataFrame) -> str:
    """What a flight's table lacks for the Mode-S wind test (position, true airspeed, heading),
    and what it carries instead: one clause for the refusal."""
    cols = {str(c).lower() for c in df.columns}
    missing = []
    if not {"latitude", "longitude"} <= cols:
        missing.append("position (latitude, longitude)")
    if "tas" not in cols:
        missing.append(
            "true airspeed (TAS" + ("; it has CAS, but no air temperature to convert it" if "cas" in cols else "") + ")"
        )
    if "heading" not in cols and not {"track", "drift"} <= cols:
        missing.append("heading (or track and drift)")
    if not missing:
        return "its fields are not those of a Mode-S trajectory"
    return f"it lacks {', '.join(missing)}; Mode-S data, observation tables and approach logs are supported"


def track_from_measured(
    m: Measured,
    max_roll_deg: float | None = None,
    aircraft_type: str | None = None,
    engine_type: str | None = None,
    lsb: dict[str, float] | None = None,
) -> tuple[pd.DataFrame, dict]:
    """The Mode-S wind frame of a measured flight and what was excluded (with the reason);
    `max_roll_deg` applies the wind paper's roll filter where the data carry roll;
    `aircraft_type` / `engine_type` name the aircraft (module docstring), `lsb` the
    registers' resolution ({"heading": deg, "TAS": kt}; else inferred). The frame's
    attrs carry "aircraft" (designator, name, how it was chosen) and "registers"."""
    if m.kind == "modes_track":
        d = m.df.dropna(subset=["heading", "TAS", "track", "groundspeed", "latitude", "longitude", "altitude"])
        excluded = {"missing fields": int(len(m.df) - len(d))}
    elif m.kind == "modes_raw":
        d = _track_from_raw(*_raw_registers(m))
        excluded = {"BDS 6,0 replies without BDS 5,0 / ADS-B neighbours": int((m.df["bds"] == "60").sum() - len(d))}
    else:
        what = {"adsb_track": "an ADS-B track", "qar": "a flight-data-recorder extract"}.get(
            m.kind, f"a {m.kind.replace('_', ' ')}"
        )
        raise DataError(f"{m.path}: diagnose of {what} is not possible: {lacking(m.df)}")
    if len(d) < 200:  # before the exclusions, which need samples to work on
        raise DataError(
            f"{m.path}: only {len(d)} samples carry heading, TAS, track, ground speed and position "
            f"({excluded}); need at least 200"
        )
    vr = d["vertical_rate"].to_numpy(float) if "vertical_rate" in d else np.zeros(len(d))
    t = d["time_s"].to_numpy(float)
    steep = np.abs(vr) > PARABOLA_FPM
    near = np.zeros(len(d), bool)
    for ts in t[steep]:
        near |= np.abs(t - ts) <= PARABOLA_MARGIN_S
    excluded[
        f"within {PARABOLA_MARGIN_S:.0f} s of |vertical rate| > {PARABOLA_FPM:.0f} ft/min "
        "(parabolas, steep climbs and descents)"
    ] = int(near.sum())
    keep = ~near
    climbing = keep & (np.abs(vr) > LEVEL_FPM)
    excluded[f"climbing or descending faster than {LEVEL_FPM:.0f} ft/min (wind shear with height)"] = int(
        climbing.sum()
    )
    keep &= ~climbing
    tas = d["TAS"].to_numpy(float)
    order = np.argsort(t, kind="stable")
    ts, vs = t[order], tas[order]
    rate = np.empty(len(t))
    rate[order] = central_rate(ts, vs, SPEED_HALF_WINDOW_S)
    changing = keep & (np.abs(rate) > SPEED_RATE_KT_S)
    excluded[
        f"airspeed changing faster than {SPEED_RATE_KT_S:g} kt/s "
        "(held TAS and fresh ground speed of different instants)"
    ] = int(changing.sum())
    keep &= ~changing
    apart = keep & held_apart(d)
    excluded[
        f"heading held while the track moved over {HELD_APART_DEG:g} deg, or the track while the heading did "
        "(values of different instants)"
    ] = int(apart.sum())
    keep &= ~apart
    if max_roll_deg is not None and "roll" in d:
        banked = keep & (np.abs(d["roll"].to_numpy(float)) > max_roll_deg)
        excluded[f"roll beyond {max_roll_deg:g} deg (wind paper)"] = int(banked.sum())
        keep &= ~banked
    aircraft, note = aircraft_of(m, d, aircraft_type, engine_type)
    regs = registers(d, lsb)
    d = d[keep]
    if len(d) < 200:
        raise DataError(f"{m.path}: only {len(d)} usable samples after exclusions ({excluded}); need at least 200")
    when = dt.datetime.fromtimestamp(float(d["time_s"].iloc[0]), tz=dt.UTC).replace(tzinfo=None)
    frame = modes_track_to_wind_frame(d, when, aircraft)
    frame.attrs["aircraft"] = {"designator": aircraft.designator, "name": aircraft.name, "chosen": note}
    frame.attrs["registers"] = regs
    return frame, excluded


# what the wind frame is built from in a raw message log: (downlink formats, BDS, fields, what it is)
RAW_REGISTERS = (
    (("20", "21"), "60", ("heading",), "Comm-B BDS 6,0 replies (magnetic heading)"),
    (("20", "21"), "50", ("TAS",), "Comm-B BDS 5,0 replies (true airspeed)"),
    (("17",), "09", ("groundspeed", "track", "vertical_rate"), "ADS-B airborne velocity messages (DF 17, BDS 0,9)"),
    (("17",), "05", ("latitude", "longitude", "altitude"), "ADS-B airborne position messages (DF 17, BDS 0,5)"),
)


def _raw_registers(m: Measured) -> list[pd.DataFrame]:
    """The messages of each RAW_REGISTERS entry, in time order; a log without one of them
    decoded is one DataError naming it."""
    raw = m.df
    if "bds" not in raw.columns:
        raise DataError(f"{m.path}: messages without a 'bds' field; expected decoded Mode-S (BDS 0,5, 0,9, 5,0, 6,0)")
    out = []
    for dfs, bds, fields, what in RAW_REGISTERS:
        sel = raw[raw["df"].astype(str).isin(dfs) & (raw["bds"] == bds)].sort_values("time_s")
        missing = [f for f in fields if f not in sel.columns or sel[f].isna().all()]
        if len(sel) == 0 or missing:
            got = f"{len(sel)} of them, none with {missing[0]!r} decoded" if len(sel) else "none"
            raise DataError(f"{m.path}: no usable {what}: {got}; diagnose needs them with {', '.join(fields)}")
        out.append(sel)
    return out


def _track_from_raw(b60: pd.DataFrame, b50: pd.DataFrame, vel: pd.DataFrame, pos: pd.DataFrame) -> pd.DataFrame:
    """One row per BDS 6,0 reply: its heading, the latest BDS 5,0 TAS, the ADS-B velocity
    and position interpolated to the reply time (the registers of `_raw_registers`)."""
    b60 = b60.dropna(subset=["heading"])
    t = b60["time_s"].to_numpy(float)
    out = pd.DataFrame({"time_s": t, "heading": b60["heading"].to_numpy(float)})
    i = np.searchsorted(b50["time_s"].to_numpy(), t, side="right") - 1
    ok = i >= 0
    out["TAS"] = np.where(ok, b50["TAS"].to_numpy(float)[np.clip(i, 0, None)], np.nan)
    if "roll" in b50:
        out["roll"] = np.where(ok, b50["roll"].to_numpy(float)[np.clip(i, 0, None)], np.nan)
    vt = vel["time_s"].to_numpy(float)
    trk = np.unwrap(np.radians(vel["track"].to_numpy(float)))
    out["track"] = np.degrees(np.interp(t, vt, trk)) % 360
    out["groundspeed"] = np.interp(t, vt, vel["groundspeed"].to_numpy(float))
    out["vertical_rate"] = np.interp(t, vt, vel["vertical_rate"].to_numpy(float))
    pt = pos["time_s"].to_numpy(float)
    for c in ("latitude", "longitude", "altitude"):
        out[c] = np.interp(t, pt, pos[c].to_numpy(float))
    # keep replies with fresh neighbours: ADS-B velocity within 1 s, BDS 5,0 within 5 s
    near_v = np.abs(vt[np.clip(np.searchsorted(vt, t), 0, len(vt) - 1)] - t) <= 1.0
    age50 = np.where(ok, t - b50["time_s"].to_numpy(float)[np.clip(i, 0, None)], np.inf)
    return out[near_v & (age50 <= 5.0)].dropna().reset_index(drop=True)
