"""Turns of the truth flights against the real A320 recorder extract
(../shared/real-data/fuelflow_a320.json.gz; not the A310 file, a zero-g flight with
interpolated samples): roll rate differenced at 1 Hz below and above 10,000 ft (p95 and
max; the truth's roll rounded to the recorder's resolution first, as the A320's is), the
share of samples banked more than 10 deg, and the sideslip of the truth in steady turns
and at turn entry (no real data for it): `turn_entry` every 10-Hz sample rolling faster
than 1 deg/s (in turbulence, gusts too), `roll_in` only those banked more than 3 deg and
rolling further away from wings level.

The truth side: the legs of Mesaba aircraft-days (the campaign's daily schedules in the
day's truth weather; turbulence and light chop on unless `--calm`; the steering wander is in every flight),
resampled to 1 Hz as the recorder is.

Prints `label: value` lines (A320 and truth side by side, and the truth/A320 ratios).
`wings_level.*`: 10-s windows above 10,000 ft with |roll| < 3 deg, the small bank angles of
straight flight (the truth's roll and track rounded to the recorder's steps, 0.35 and 0.088
deg): their rms, the rms track rate, and how far they are coordinated turning
(the regression of the window's track rate on g tan(roll) / V: slope and correlation; 1 and
1 for pure turning, ~0 for roll that does not turn the aircraft); and the bank's
autocorrelation at 1, 2, 5 and 10 s in straight stretches of >= 60 s (how long the weave lasts).

    python validation/turn_stats.py [--days 3] [--turbulence]
"""

from __future__ import annotations

import argparse
import datetime as dt
import gzip
import json
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.truth.days import AircraftDay
from aerotruth.truth.flight import FlightDiverged, fly_leg
from aerotruth.units import DEG, FT

REAL = Path(__file__).resolve().parents[1].parent / "shared" / "real-data" / "fuelflow_a320.json.gz"


def roll_stats(roll_deg: np.ndarray, alt_ft: np.ndarray, lsb_deg: float | None = None) -> dict[str, float]:
    """p95/max of |roll(k+1) - roll(k)| (1 Hz samples) and share |roll| > 10 deg, below and
    above 10,000 ft; with the recorder's resolution `lsb_deg`, also the share of 1-s roll
    changes of 2 or more steps (at 0.35 deg steps p95 can only be 0.35 or 0.70: it is 0.70
    exactly when this share exceeds 5 %)."""
    rr = np.abs(np.diff(roll_deg))
    al = alt_ft[1:]
    out = {}
    for name, sel in (("below_10000ft", al < 10000), ("above_10000ft", al >= 10000)):
        r = rr[sel & np.isfinite(rr)]
        out[f"{name}.roll_rate_p95_deg_s"] = float(np.percentile(r, 95)) if len(r) else float("nan")
        if lsb_deg:
            out[f"{name}.share_roll_change_ge_2_steps"] = float(np.mean(r >= 1.5 * lsb_deg)) if len(r) else float("nan")
        out[f"{name}.roll_rate_max_deg_s"] = float(r.max()) if len(r) else float("nan")
        rl = roll_deg[1:][sel]
        out[f"{name}.share_roll_over_10deg"] = float(np.mean(np.abs(rl[np.isfinite(rl)]) > 10.0))
    return out


def wings_level_stats(
    roll_deg: np.ndarray, track_deg: np.ndarray, gs_mps: np.ndarray, alt_ft: np.ndarray, window_s: int = 10
) -> dict[str, float]:
    """1-Hz samples (NaN between legs): rms roll and track rate of straight-flight windows
    above 10,000 ft, and the slope and correlation of track rate on g tan(roll) / V."""
    ok = (alt_ft > 10000.0) & (np.abs(roll_deg) < 3.0)
    trk = np.radians(track_deg)
    phi, rate, v = [], [], []
    for i in range(0, len(roll_deg) - window_s, window_s):
        if not ok[i : i + window_s + 1].all():
            continue
        turn = np.angle(np.exp(1j * (trk[i + window_s] - trk[i])))  # wrapped to (-pi, pi]
        phi.append(np.radians(roll_deg[i : i + window_s]).mean())
        rate.append(turn / window_s)
        v.append(gs_mps[i : i + window_s].mean())
    phi, rate, v = map(np.asarray, (phi, rate, v))
    if len(phi) < 3:
        return {}
    coordinated = 9.81 * np.tan(phi) / v
    return {
        "windows": float(len(phi)),
        "roll_rms_deg": float(np.degrees(np.sqrt(np.mean(phi**2)))),
        "track_rate_rms_deg_min": float(np.degrees(np.sqrt(np.mean(rate**2))) * 60.0),
        "turning_slope": float(np.polyfit(coordinated, rate, 1)[0]),
        "turning_corr": float(np.corrcoef(coordinated, rate)[0, 1]),
    }


def wings_level_acf(
    roll_deg: np.ndarray, alt_ft: np.ndarray, lags=(1, 2, 5, 10), min_len: int = 60
) -> dict[str, float]:
    """Autocorrelation of the bank in straight flight above 10,000 ft (1-Hz samples, stretches
    of >= `min_len` s with |roll| < 2 deg, each stretch's mean removed): how long the weave
    lasts."""
    ok = (alt_ft >= 10000) & (np.abs(roll_deg) < 2.0) & np.isfinite(roll_deg)
    edges = np.flatnonzero(np.diff(np.r_[0, ok.astype(int), 0]))
    parts = [
        roll_deg[a:b] - roll_deg[a:b].mean() for a, b in zip(edges[::2], edges[1::2], strict=False) if b - a >= min_len
    ]
    var = sum(float(np.sum(x * x)) for x in parts)
    out = {}
    for lag in lags:
        out[f"roll_acf_{lag}s"] = (
            sum(float(np.sum(x[:-lag] * x[lag:])) for x in parts) / var if var > 0 else float("nan")
        )
    return out


def recorder_step_deg(roll_deg: np.ndarray) -> float:
    """A recorded parameter's resolution: the smallest non-zero change between samples (the
    A320 extract's roll: 0.352 deg, an ARINC 429 word's least significant bit; track 0.088)."""
    d = np.abs(np.diff(roll_deg[np.isfinite(roll_deg)]))
    return float(d[d > 1e-9].min())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--days", type=int, default=3, help="Mesaba aircraft-days (up to 6 legs each)")
    ap.add_argument("--calm", action="store_true", help="no JSBSim turbulence (the coordination of the turns alone)")
    args = ap.parse_args()
    args.turbulence = not args.calm
    a = pd.DataFrame(json.load(gzip.open(REAL))).sort_values("timestamp")
    lsb = recorder_step_deg(a["roll"].to_numpy(float))
    real = roll_stats(a["roll"].to_numpy(float), a["altitude"].to_numpy(float), lsb)
    real_wl = wings_level_stats(
        a["roll"].to_numpy(float),
        a["track"].to_numpy(float),
        a["groundspeed"].to_numpy(float) * 0.514444,
        a["altitude"].to_numpy(float),
    )
    real_wl.update(wings_level_acf(a["roll"].to_numpy(float), a["altitude"].to_numpy(float)))
    rolls, alts, betas, tracks, speeds = [], [], [], [], []
    n_legs = n_div = 0
    for k in range(args.days):
        day = AircraftDay.for_campaign(
            2009,
            f"N40{k + 1}XJ",
            dt.date(2009, 8, 15) + dt.timedelta(days=k),
            network="mesaba",
            turbulence=args.turbulence,
        )
        for leg in day.plans():
            n_legs += 1
            try:
                df = fly_leg(leg.plan, seed=leg.flight_seed, turbulence=args.turbulence, atmosphere=leg.atmosphere()).df
            except FlightDiverged:
                n_div += 1
                continue
            one = df.iloc[::10]  # 10 Hz -> 1 Hz, as the recorder samples
            rolls += [one["roll_rad"].to_numpy() / DEG, [np.nan]]
            alts += [one["pressure_altitude_m"].to_numpy() / FT, [np.nan]]
            tracks += [np.degrees(np.arctan2(one["ve_mps"].to_numpy(), one["vn_mps"].to_numpy())), [np.nan]]
            speeds += [np.hypot(one["ve_mps"].to_numpy(), one["vn_mps"].to_numpy()), [np.nan]]
            betas.append(df[["roll_rad", "beta_rad", "p_radps"]].to_numpy())
    roll_1hz = np.concatenate(rolls)
    truth = roll_stats(
        np.round(roll_1hz / lsb) * lsb, np.concatenate(alts), lsb
    )  # recorded as the A320's recorder would
    print(f"a320.roll_resolution_deg: {lsb:.4f}")
    print(f"legs: {n_legs}")
    print(f"legs_diverged: {n_div}")
    for k in real:
        print(f"a320.{k}: {real[k]:.3f}")
        print(f"truth.{k}: {truth[k]:.3f}")
        if "rate" in k:
            print(f"ratio.{k}: {truth[k] / real[k]:.2f}")
    trk_lsb = recorder_step_deg(a["track"].to_numpy(float))  # 0.088 deg: as recorded, like the roll
    truth_wl = wings_level_stats(
        np.round(roll_1hz / lsb) * lsb,
        np.round(np.concatenate(tracks) / trk_lsb) * trk_lsb,
        np.concatenate(speeds),
        np.concatenate(alts),
    )
    truth_wl.update(wings_level_acf(np.round(roll_1hz / lsb) * lsb, np.concatenate(alts)))
    for k in real_wl:
        print(f"a320.wings_level.{k}: {real_wl[k]:.3f}")
        print(f"truth.wings_level.{k}: {truth_wl.get(k, float('nan')):.3f}")
    b = np.vstack(betas)
    roll, beta, p = np.degrees(b[:, 0]), np.degrees(b[:, 1]), np.degrees(b[:, 2])
    steady = (np.abs(roll) > 15.0) & (np.abs(p) < 0.5)
    entry = np.abs(p) > 1.0  # any roll rate above 1 deg/s: gusts included
    roll_in = (np.abs(roll) > 3.0) & (p * np.sign(roll) > 1.0)  # banking further away from wings level
    print(f"truth.sideslip_steady_turn_p95_deg: {np.percentile(np.abs(beta[steady]), 95):.3f}")
    print(f"truth.sideslip_turn_entry_max_deg: {np.abs(beta[entry]).max():.3f}")
    print(f"truth.sideslip_turn_entry_p99_deg: {np.percentile(np.abs(beta[entry]), 99):.3f}")
    print(f"truth.sideslip_roll_in_max_deg: {np.abs(beta[roll_in]).max():.3f}")
    print(f"truth.sideslip_roll_in_p99_deg: {np.percentile(np.abs(beta[roll_in]), 99):.3f}")
    print(f"truth.max_bank_deg: {np.abs(roll).max():.2f}")


if __name__ == "__main__":
    main()
