"""Approach acceptance: N ILS approaches to runways of the three networks, in
the day's truth atmosphere with JSBSim turbulence, AFIS profile (every 5th a
go-around). Prints `label: value` lines: the share stabilised at 1,000 ft (within 1 dot
on localizer and glide slope, Vref -5/+10 kt, sink <= 1,000 fpm), medians, worst cases
(farthest from the median, either side) and maxima of the figures, divergences by seed
(none dropped silently), and the path while configuring: the CG height against the
distance to the threshold 1.5-6 nm out fitted by a straight line (runway frame,
geometric: its angle against the glide slope, the 95th percentile and largest |residual|;
the slowing to Vapp and flaps 35 fall inside).

    python validation/approaches.py [--n 50]
"""

from __future__ import annotations

import argparse
import datetime as dt

import numpy as np

from aerotruth.seeds import child, named_sequence
from aerotruth.truth.approach import approach_metrics, approach_spec, fly_approach
from aerotruth.truth.days import day_atmosphere
from aerotruth.truth.flight import FlightDiverged
from aerotruth.truth.weather import region_for_airport
from aerotruth.units import NM

RUNWAYS = [
    ("KDLH", "27"),
    ("KMSP", "30L"),
    ("KRST", "31"),
    ("KATW", "03"),
    ("PADL", "19"),
    ("PANC", "07R"),
    ("KIND", "23L"),
    ("KCMH", "28L"),
]
DAYS = [dt.date(2009, 8, 15), dt.date(2009, 9, 20), dt.date(2010, 1, 20), dt.date(2010, 3, 25), dt.date(2010, 10, 30)]


def path_fit(track) -> dict[str, float]:
    """Straight-line fit of z on x, 1.5-6 nm before the threshold (runway frame)."""
    x, z = track.df["x_m"].to_numpy(float), track.df["z_m"].to_numpy(float)
    sel = (x <= -1.5 * NM) & (x >= -6.0 * NM)
    coef = np.polyfit(x[sel], z[sel], 1)
    r = np.abs(z[sel] - np.polyval(coef, x[sel]))
    return {
        "path_angle_deg_1p5_6nm": float(np.degrees(np.arctan(-coef[0]))),  # z falls as x grows
        "path_resid_p95_m_1p5_6nm": float(np.percentile(r, 95)),
        "path_resid_max_m_1p5_6nm": float(r.max()),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--n", type=int, default=50)
    args = ap.parse_args()
    rows, diverged, skipped = [], [], []
    for i in range(args.n):
        icao, rwy = RUNWAYS[i % len(RUNWAYS)]
        day = DAYS[(i // len(RUNWAYS)) % len(DAYS)]
        try:
            atm = day_atmosphere(day, i, region_for_airport(icao))
            spec = approach_spec(icao, rwy, day, turbulence=True, profile="go-around" if i % 5 == 4 else "afis")
        except ValueError as e:
            skipped.append(f"{icao} {rwy}: {e}")
            continue
        try:
            t = fly_approach(spec, seed=child(named_sequence(i, "approach", icao, rwy), "flight"), atmosphere=atm)
            rows.append(approach_metrics(t) | path_fit(t))
        except FlightDiverged as e:
            diverged.append(f"{icao} {rwy} seed {i}: {e.reason}")
    keys = rows[0].keys()
    m = {k: np.array([r[k] for r in rows]) for k in keys}
    print(f"approaches: {len(rows)}")
    print(f"runways: {len({(a, b) for a, b in RUNWAYS[: min(args.n, len(RUNWAYS))]})}")
    print(f"diverged: {len(diverged)}")
    for d in diverged:
        print(f"# diverged {d}")
    for s in skipped:
        print(f"# skipped {s}")
    print(f"stabilised_share: {m['stabilised'].mean():.3f}")
    for k in (
        "loc_dots_1000ft",
        "gs_dots_1000ft",
        "cas_minus_vref_kt_1000ft",
        "sink_fpm_1000ft",
        "lateral_rms_m_1nm",
        "vertical_rms_m_1nm",
        "height_over_threshold_ft",
        "cas_threshold_kt",
        "pitch_threshold_deg",
        "roll_threshold_deg",
        "recorded_past_threshold_s",
        "path_angle_deg_1p5_6nm",
        "path_resid_p95_m_1p5_6nm",
        "path_resid_max_m_1p5_6nm",
    ):
        v = m[k]
        print(f"{k}_median: {np.median(v):.3f}")
        print(f"{k}_worst: {v[np.argmax(np.abs(v - np.median(v)))]:.3f}")  # farthest from the median
        print(f"{k}_max: {np.max(v):.3f}")


if __name__ == "__main__":
    main()
