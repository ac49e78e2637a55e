"""Report-generation speed: 10 Hz truth samples turned into TAMDAR reports, one process.

A synthetic truth-like track (TruthTrack columns, 10 Hz, `--hours` long: climb from
1000 hPa at ~1800 ft/min, cruise at FL220 with gentle heading changes, descent) goes
through the air-data/GPS sensor and the report generator with a lookup-table correction.
Times are this process's CPU time (time.process_time), fastest of `--rounds`.

Prints `label: value` lines: `samples/s` (heading system + air data + reports, target
>= 1,000,000 per core), `samples/s_reports_only` (report generator alone), `magnetic_share`
(fraction of the samples/s time spent on the Earth's field and the flux valve: IGRF grid
lookup along the track, valve measurement, slaved gyro), `samples`, `reports`.

    python benchmarks/report_speed.py [--hours 3] [--rounds 5]
"""

from __future__ import annotations

import argparse
import datetime as dt
import time

import numpy as np
import pandas as pd

from aerotruth.ellipsoid import radii
from aerotruth.sensors.air_data import AirDataSpec
from aerotruth.sensors.magnetics import FluxValveSpec, GeomagneticField, HeadingSystem
from aerotruth.sensors.tamdar import LookupTableCorrection, ReportSpec, generate_reports
from aerotruth.truth.isa import isa_pressure_pa, pressure_altitude_m
from aerotruth.units import DEG, FPM, FT, KT


def synthetic_track(hours: float, rng: np.random.Generator) -> pd.DataFrame:
    """A 10 Hz truth-like flight with every TruthTrack column."""
    t = np.arange(int(hours * 36000)) / 10.0
    top = 22000 * FT
    climb_s, descent_s = top / (1800 * FPM), top / (1500 * FPM)
    descent_start = t[-1] - descent_s
    h_p = np.clip(np.minimum(t * 1800 * FPM, (t[-1] - t) * 1500 * FPM), 0.0, top)
    phase = np.where(t < climb_s, "climb", np.where(t < descent_start, "cruise", "descent"))
    vd = np.where(phase == "climb", -1800 * FPM, np.where(phase == "descent", 1500 * FPM, 0.0))
    tas0 = np.interp(h_p, [0.0, top], [150 * KT, 260 * KT])
    heading = np.mod(40 * DEG + 0.6 * np.sin(2 * np.pi * t / 2400.0), 2 * np.pi)
    roll = np.clip(np.gradient(heading, t) * tas0 / 9.80665, -0.5, 0.5)
    # the aircraft's heading and ground velocity are smooth (inertia: JSBSim legs show
    # 0.3-0.5 m/s^2 sd of horizontal acceleration at 10 Hz); 10-Hz gusts of 0.5 m/s go
    # into the wind and so into the air-relative velocity (TAS and sideslip)
    u0, v0 = 15.0 + 3.0 * np.sin(2 * np.pi * t / 900.0), np.full(t.size, -5.0)
    ve, vn = tas0 * np.sin(heading) + u0, tas0 * np.cos(heading) + v0
    wind_u = u0 + 0.5 * rng.standard_normal(t.size)
    wind_v = v0 + 0.5 * rng.standard_normal(t.size)
    air_e, air_n = ve - wind_u, vn - wind_v
    tas = np.hypot(air_e, air_n)
    beta = np.mod(np.arctan2(air_e, air_n) - heading + np.pi, 2 * np.pi) - np.pi
    m, n = radii(45.0 * DEG)
    lat = 45.0 + np.degrees(np.cumsum(vn) * 0.1 / m)
    lon = -93.0 + np.degrees(np.cumsum(ve) * 0.1 / (n * np.cos(45.0 * DEG)))
    p = isa_pressure_pa(h_p)
    zeros = np.zeros(t.size)
    return pd.DataFrame(
        {
            "time_s": t,
            "lat_deg": lat,
            "lon_deg": lon,
            "h_ellipsoid_m": h_p + 30.0,
            "pressure_altitude_m": pressure_altitude_m(p),
            "vn_mps": vn,
            "ve_mps": ve,
            "vd_mps": vd,
            "roll_rad": roll,
            "pitch_rad": zeros,
            "heading_rad": heading,
            "tas_mps": tas,
            "cas_mps": tas,
            "alpha_rad": zeros,
            "beta_rad": beta,
            "p_radps": zeros,
            "q_radps": zeros,
            "r_radps": zeros,
            "wind_u_mps": wind_u,
            "wind_v_mps": wind_v,
            "wind_w_mps": zeros,
            "static_pressure_pa": p,
            "temperature_k": np.full(t.size, 250.0),
            "leg_index": np.zeros(t.size, dtype=np.int32),
            "phase": pd.Categorical(phase, categories=["climb", "cruise", "descent", "approach"]),
        }
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--hours", type=float, default=3.0, help="length of the synthetic flight")
    ap.add_argument("--rounds", type=int, default=5, help="timed repetitions (the fastest counts)")
    args = ap.parse_args()
    rng = np.random.default_rng(340)
    truth = synthetic_track(args.hours, rng)
    field = GeomagneticField.covering(
        truth["lat_deg"].to_numpy()[::100], truth["lon_deg"].to_numpy()[::100], dt.date(2009, 8, 15)
    )  # built once per day and region in a study
    system = HeadingSystem(FluxValveSpec(hard_iron_nT=(400.0, -250.0, 100.0), mounting_deg=1.0))
    spec = ReportSpec()
    lut = LookupTableCorrection(lut_deg=[-2.0, -1.5, -1.0, -1.5, -2.0, -2.5, -3.0, -2.5])
    errors = AirDataSpec(tas_bias_kt=1.0, tas_scale_sigma=0.005).draw(rng)

    best_all = best_reports = best_mag = float("inf")
    n_reports = 0
    for _ in range(args.rounds):
        c0 = time.process_time()
        heading = system.apply(truth, field)
        cm = time.process_time()
        air = errors.apply(truth, rng)
        c1 = time.process_time()
        reports = generate_reports(
            truth,
            heading["heading_rad"].to_numpy(),
            spec,
            ground_pressure_hpa=1013.0,
            air=air,
            correction=lut,
            variation_rad=heading["declination_rad"].to_numpy(),
            aircraft="N340AT",
        )
        c2 = time.process_time()
        if c2 - c0 < best_all:
            best_all, best_mag = c2 - c0, cm - c0
        best_reports = min(best_reports, c2 - c1)
        n_reports = len(reports)
    n = len(truth)
    print(f"samples: {n}")
    print(f"reports: {n_reports}")
    print(f"samples/s: {n / best_all:.0f}")
    print(f"samples/s_reports_only: {n / best_reports:.0f}")
    print(f"magnetic_share: {best_mag / best_all:.3f}")


if __name__ == "__main__":
    main()
