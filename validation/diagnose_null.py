"""Null control and detection power of `diagnose` on simulated Mode-S data (JSBSim truth
from the truth store -> Mode-S sensor -> decoded 1-s trajectory).

Prints `label: value` lines:
  null_datasets, null_findings (target: <= 5 per 100 with nothing hidden), null_false_rate;
  power_<effect>_<size>: the share of datasets in which the hidden effect is ranked first;
  wrong_cause_<effect>_<size>: the share in which a finding of another effect is named (and which).
Datasets: Mesaba schedule days (first 6 legs) of distinct aircraft on distinct dates
spread over a year (every 23rd day from 15 Aug 2009: each its own truth weather, so the
null is not one day's wind), each with `--seeds` sensor seeds; truth is flown once into
the truth store and reused. The sensor seeds of one day share its flights and weather: a
finding that recurs across a day's seeds is the day's structure, not the sensors' noise
(printed per day).

    python validation/diagnose_null.py [--days 20] [--seeds 5] [--power 10]
"""

from __future__ import annotations

import argparse
import datetime as dt
import time

import numpy as np

from aerotruth.analysis.diagnose.modes import diagnose_track
from aerotruth.errors import DataError
from aerotruth.measured.modes import track_from_measured
from aerotruth.sim.modes_data import simulated_modes_day
from aerotruth.truth.days import AircraftDay


def days(n: int) -> list[AircraftDay]:
    first = dt.date(2009, 8, 15)
    return [
        AircraftDay.for_campaign(2009, f"N{400 + i}XJ", first + dt.timedelta(days=23 * i), network="mesaba", max_legs=6)
        for i in range(n)
    ]


def findings(day, rng, **hidden):
    try:
        frame, _ = track_from_measured(simulated_modes_day(day, rng=rng, **hidden))
    except DataError:
        return None
    return diagnose_track(frame)[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--days", type=int, default=20)
    ap.add_argument("--seeds", type=int, default=5)
    ap.add_argument("--power", type=int, default=10, help="datasets per effect size")
    args = ap.parse_args()
    ds = days(args.days)
    n = k = any_ = 0
    t0 = time.perf_counter()
    for i, day in enumerate(ds):
        named = []
        for s in range(args.seeds):
            got = findings(day, np.random.default_rng(1000 * i + s))
            if got is None:
                continue
            n += 1
            k += len(got)
            any_ += bool(got)
            named += [f.effect for f in got]
        print(f"null_day_{day.date.isoformat()}_{day.aircraft}: {','.join(named) or 'none'}")
    print(f"null_datasets: {n}")
    print(f"null_findings: {k}")
    print(f"null_any: {any_}")
    print(f"null_false_rate: {any_ / max(n, 1):.3f}")
    print(f"null_wall_s_per_dataset: {(time.perf_counter() - t0) / max(n, 1):.1f}")
    for effect, key, sizes in (
        ("heading_offset", "table_error_deg", (0.25, 0.5, 1.0, 2.0)),
        ("heading_time_offset", "heading_lag_s", (0.5, 1.0, 2.0)),
    ):
        for size in sizes:
            hit = m = wrong = 0
            others: list[str] = []
            for i, day in enumerate(ds[: args.power]):
                got = findings(day, np.random.default_rng(7 + i), **{key: size})
                if got is None:
                    continue
                m += 1
                hit += bool(got) and got[0].effect == effect
                bad = [f.effect for f in got if f.effect != effect]
                wrong += bool(bad)
                others += bad
            if m:  # with --power 0 (or no usable day) there is no share to print
                print(f"power_{effect}_{size:g}: {hit / m:.2f} ({hit} of {m})")
                print(f"wrong_cause_{effect}_{size:g}: {wrong / m:.2f} ({wrong} of {m}; {','.join(others) or 'none'})")


if __name__ == "__main__":
    main()
