"""Simulated Mode-S data of an aircraft-day, with sensor effects hidden in it, in the form
a receiver's decoder gives (a 1-s Mode-S trajectory): truth from the truth store, the
Mode-S sensor, then `aerotruth.measured.kinds.Measured` as `diagnose` takes real data. Hidden
effects: an error of the aircraft's magnetic-variation table (a heading offset) and a lag
of the heading samples."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd

from aerotruth.analysis.wind.modes_wind import declination_deg
from aerotruth.measured.kinds import Measured
from aerotruth.sensors.modes import (
    ModeSSensor,
    ModeSSpec,
    avionics_from_truth,
    decoded_track,
)
from aerotruth.truth.days import AircraftDay
from aerotruth.truth.store import TruthStore


def simulated_modes_day(
    day: AircraftDay,
    *,
    table_error_deg: float = 0.0,
    heading_lag_s: float = 0.0,
    spec: ModeSSpec | None = None,
    rng: np.random.Generator,
    store: TruthStore | None = None,
) -> Measured:
    """The day's legs as one decoded Mode-S trajectory. table_error_deg: the aircraft's
    variation table minus the true declination (east positive; the reported magnetic
    heading is then that much too small); heading_lag_s: heading samples that old."""
    frames = []
    for out in (store or TruthStore()).day(day):
        if out.track is None:
            continue
        df = out.track.df
        when = dt.datetime.fromisoformat(out.track.meta["departure_utc"])
        step = 100  # declination every 10 s of flight is plenty: it changes over hundreds of km
        dec = declination_deg(
            df["lat_deg"].to_numpy()[::step],
            df["lon_deg"].to_numpy()[::step],
            df["h_ellipsoid_m"].to_numpy()[::step],
            when.replace(tzinfo=None),
        )
        dec = np.interp(np.arange(len(df)), np.arange(0, len(df), step), dec)
        av = avionics_from_truth(df, dec + table_error_deg)
        if heading_lag_s:
            t = av["time_s"].to_numpy()
            h = np.degrees(np.unwrap(np.radians(av["heading_mag_deg"].to_numpy())))
            av["heading_mag_deg"] = np.interp(t - heading_lag_s, t, h) % 360
        msgs = ModeSSensor(spec or ModeSSpec()).apply(av, rng)
        frames.append(decoded_track(msgs, when.timestamp()))
    if not frames:
        raise ValueError(f"aircraft-day {day.aircraft} {day.date}: no leg was flown")
    d = pd.concat(frames, ignore_index=True)
    return Measured("modes_track", d.assign(time_s=d["timestamp"] / 1000.0), f"simulated {day.aircraft} {day.date}")
