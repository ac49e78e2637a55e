"""Synthetic multi-aircraft Mode-S traffic with known heading offsets, written in the
`traffic` library's column names (a decoded state table), independent of aerotruth's code:
straight flights across a box in a wind that varies smoothly in space, each aircraft's
BDS 6,0 heading = true heading - IGRF declination (ppigrf directly) + its offset, rounded
to the register's 90/512 deg; TAS to 2 kt (BDS 5,0); ground speed and track from ADS-B."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd
import ppigrf

R_KM = 6371.0088


def wind_kt(lat, lon, alt_ft):
    """A smooth westerly growing with height, turning a little across the box (towards u, v)."""
    u = 30.0 + 0.002 * alt_ft + 5.0 * np.sin(np.radians(lat - 45.0) * 20.0)
    v = 5.0 + 4.0 * np.cos(np.radians(lon + 93.0) * 15.0)
    return u, v


def make_traffic(
    n_aircraft=36,
    seed=0,
    minutes=60,
    box_km=200.0,
    lat0=45.0,
    lon0=-93.0,
    offsets_deg=None,
    date=dt.datetime(2024, 6, 1, 12),
    levels_ft=(20000.0, 24000.0, 28000.0, 30000.0),
    turns=0,
    heading_lag_s=0.0,
):
    """(state table, offsets in deg by icao24). Aircraft start at random times in the hour,
    fly 20 min straight on random headings at FL200-FL300, sampled every second. `turns`:
    each flight turns that many times (60-120 deg either way at a standard-rate 3 deg/s, at
    random moments); `heading_lag_s`: the BDS 6,0 heading is the one of that many seconds
    before the ADS-B velocity's instant (replies sampled at different instants)."""
    rng = np.random.default_rng(seed)
    offsets = rng.uniform(-3.0, 3.0, n_aircraft) if offsets_deg is None else np.asarray(offsets_deg, float)
    rows = []
    t0 = (date - dt.datetime(1970, 1, 1)).total_seconds()
    for i in range(n_aircraft):
        icao = f"a{i:05x}"
        hdg_true = rng.uniform(0.0, 360.0)
        tas = rng.uniform(380.0, 460.0)
        alt = float(rng.choice(levels_ft))
        start = t0 + rng.uniform(0.0, (minutes - 20) * 60.0)
        t = start + np.arange(0.0, 20 * 60.0)
        # start so that the middle of the flight is near the box centre
        half = tas * 0.5144 * 600.0 / 1000.0
        x0 = rng.uniform(-box_km / 4, box_km / 4) - half * np.sin(np.radians(hdg_true))
        y0 = rng.uniform(-box_km / 4, box_km / 4) - half * np.cos(np.radians(hdg_true))
        hdg = np.full(len(t), hdg_true)
        for _ in range(turns):  # drawn after the straight flight's numbers: turns=0 keeps their stream
            at, by = rng.uniform(60.0, len(t) - 120.0), rng.choice([-1.0, 1.0]) * rng.uniform(60.0, 120.0)
            hdg += np.clip((np.arange(len(t)) - at) * 3.0, 0.0, abs(by)) * np.sign(by)
        x, y = np.empty(len(t)), np.empty(len(t))
        x[0], y[0] = x0, y0
        lat = np.empty(len(t))
        lon = np.empty(len(t))
        gs_e = np.empty(len(t))
        gs_n = np.empty(len(t))
        for k in range(len(t)):  # dead reckoning in km with the wind at each position
            lat[k] = lat0 + np.degrees(y[k] / R_KM)
            lon[k] = lon0 + np.degrees(x[k] / (R_KM * np.cos(np.radians(lat0))))
            wu, wv = wind_kt(lat[k], lon[k], alt)
            gs_e[k] = tas * np.sin(np.radians(hdg[k])) + wu
            gs_n[k] = tas * np.cos(np.radians(hdg[k])) + wv
            if k + 1 < len(t):
                x[k + 1] = x[k] + gs_e[k] * 1.852 / 3600.0
                y[k + 1] = y[k] + gs_n[k] * 1.852 / 3600.0
        be, bn, _ = ppigrf.igrf(lon, lat, alt * 0.3048 / 1000.0, date)
        dec = np.degrees(np.arctan2(np.ravel(be), np.ravel(bn)))
        seen = np.interp(np.arange(len(t)) - heading_lag_s, np.arange(len(t)), hdg)  # the reply's instant
        mag = (seen - dec + offsets[i]) % 360.0
        rows.append(
            pd.DataFrame(
                {
                    "icao24": icao,
                    "timestamp": pd.to_datetime(t, unit="s", utc=True),
                    "latitude": lat,
                    "longitude": lon,
                    "altitude": alt,
                    "groundspeed": np.hypot(gs_e, gs_n),
                    "track": np.degrees(np.arctan2(gs_e, gs_n)) % 360.0,
                    "heading": np.round(mag / (90.0 / 512.0)) * (90.0 / 512.0),
                    "TAS": np.round(tas / 2.0) * 2.0,
                }
            )
        )
    return pd.concat(rows, ignore_index=True), dict(zip([f"a{i:05x}" for i in range(n_aircraft)], offsets, strict=True))
