"""Heading spread of the climb and descent samples per leg, with and without the terminal
procedures of aerotruth.truth.routes (a 5-nm straight-out climb on the runway course,
then direct to the arrival's intermediate fix on the extended centreline, with a base
point when the join would turn more than 90 deg), against the same legs flown as single
great circles from the departure runway's end to the final point.

The wind paper's climb and descent reports see the heading system at the headings these
phases are flown on; a single great circle flies them all at one heading.

Prints `label: value` lines: the median over legs of the circular standard deviation
(deg) of the true heading in the climb (before the first cruise sample) and the descent
(after the last), both ways, and the legs flown.

    python validation/heading_spread.py [--days 3]
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt

import numpy as np

from aerotruth.geo import inverse
from aerotruth.truth.days import AircraftDay
from aerotruth.truth.flight import FlightDiverged, fly_leg


def circular_std_deg(angles_rad: np.ndarray) -> float:
    """sqrt(-2 ln R), R the mean resultant length (Mardia & Jupp, Directional Statistics, 2.3.4)."""
    r = np.hypot(np.mean(np.cos(angles_rad)), np.mean(np.sin(angles_rad)))
    return float(np.degrees(np.sqrt(-2.0 * np.log(max(r, 1e-12)))))


def great_circle(plan):
    """The same leg as one great circle from the first to the last waypoint."""
    a, b = plan.waypoints[0], plan.waypoints[-1]
    return dataclasses.replace(
        plan, waypoints=(a, b), segment_lengths_m=(float(inverse(a.lat, a.lon, b.lat, b.lon)[2]),)
    )


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--days", type=int, default=3)
    args = ap.parse_args()
    spread = {(w, ph): [] for w in ("procedures", "great_circle") for ph in ("climb", "descent")}
    n = 0
    for k in range(args.days):
        day = AircraftDay.for_campaign(
            2009, f"N40{k + 1}XJ", dt.date(2009, 8, 15) + dt.timedelta(days=k), network="mesaba"
        )
        for leg in day.plans():
            for way, plan in (("procedures", leg.plan), ("great_circle", great_circle(leg.plan))):
                try:
                    df = fly_leg(plan, seed=leg.flight_seed, atmosphere=leg.atmosphere()).df
                except FlightDiverged:
                    continue
                cruise = np.flatnonzero((df["phase"] == "cruise").to_numpy())
                if len(cruise) == 0:
                    continue
                k = np.arange(len(df))
                # climb: before the first cruise sample; descent: after the last (the loop's
                # phase label turns to "approach" on the final segment, which differs by plan)
                for ph, sel in (("climb", k < cruise[0]), ("descent", k > cruise[-1])):
                    if sel.sum() > 50:
                        spread[(way, ph)].append(circular_std_deg(df["heading_rad"].to_numpy()[sel]))
            n += 1
    print(f"legs: {n}")
    for (way, ph), v in spread.items():
        print(f"{way}.{ph}.heading_circular_std_median_deg: {np.median(v):.2f}")
        print(f"{way}.{ph}.heading_circular_std_p90_deg: {np.percentile(v, 90):.2f}")


if __name__ == "__main__":
    main()
