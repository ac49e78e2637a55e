"""Mode-S data (a decoded Mode-S trajectory or a raw message log, aerotruth.measured.kinds)
as the Mode-S wind frame that `diagnose` fits (aerotruth.analysis.wind.modes_wind): BDS 6,0
magnetic heading, BDS 5,0 TAS, ADS-B track, ground speed and position per sample, with
the samples left out and why (missing fields, headings off the BDS 6,0 register grid, a
zero-g parabola, a level speed change: the gates of aerotruth.analysis.diagnose.modes)."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd

from aerotruth.analysis.diagnose.modes import (
    LEVEL_FPM,
    PARABOLA_FPM,
    PARABOLA_MARGIN_S,
    SPEED_HALF_WINDOW_S,
    SPEED_RATE_KT_S,
)
from aerotruth.analysis.wind.modes_wind import central_rate, modes_track_to_wind_frame
from aerotruth.errors import DataError
from aerotruth.measured.kinds import Measured


def _on_grid(x: np.ndarray, lsb: float) -> np.ndarray:
    r = np.mod(x / lsb, 1.0)
    return (r < 1e-3) | (r > 1 - 1e-3)


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


def track_from_measured(m: Measured, max_roll_deg: float | None = None) -> tuple[pd.DataFrame, dict]:
    """The Mode-S wind frame of a measured flight and what was excluded (with the reason);
    `max_roll_deg` applies the wind paper's roll filter where the data carry roll."""
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
    if max_roll_deg is not None and "roll" in d:
        banked = keep & (np.abs(d["roll"].to_numpy(float)) > max_roll_deg)
        excluded[f"roll beyond {max_roll_deg:g} deg (wind paper)"] = int(banked.sum())
        keep &= ~banked
    if m.kind == "modes_track":
        fresh = _on_grid(d["heading"].to_numpy(float), 90 / 512) & _on_grid(d["TAS"].to_numpy(float), 2.0)
        excluded["heading or TAS off its register LSB grid (interpolated by the resampler)"] = int(
            (keep & ~fresh).sum()
        )
        keep &= fresh
    d = d[keep]
    if len(d) < 200:
        raise DataError(f"{m.path}: only {len(d)} usable samples after exclusions ({excluded}); need at least 200")
    when = dt.datetime.fromtimestamp(float(d["time_s"].iloc[0]), tz=dt.UTC).replace(tzinfo=None)
    return modes_track_to_wind_frame(d, when), excluded


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
