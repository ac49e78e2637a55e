"""Throughput of `aerotruth reports` on one core: a decoded multi-aircraft state table (in
memory) -> the canonical traffic frame (aerotruth.measured.traffic) -> per-sample winds
(IGRF declination, horizontal TAS) -> the consensus reference (cKDTree neighbourhoods on one
sample per aircraft and 20 s, every aircraft's heading offset solved jointly by Gauss-Newton
on a sparse least-squares system) -> the observation table.

Data: the independent traffic generator (tests/traffic_generator.py), `--aircraft` aircraft
(default 60) at four flight levels in a 200-km box over an hour, 1-s samples (20 min each:
72,000 rows at the default), about a busy hour of one receiver's Mode-S traffic. Generated
before the clock starts.

Prints `rows/s` (state-table rows to observation-table rows, end to end: the reader, the
roll gate and observation_table), the stage times (`read_s`, reader and roll gate;
`winds_s` and `consensus_s`, timed again apart; `table_s`, what observation_table takes
beyond them) and `aircraft`, `rows`, `reports` (rows with a reference). The best of
`--repeat` runs.

    python benchmarks/reports_speed.py [--aircraft 60] [--repeat 3]
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"  # per core

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))

import traffic_generator as gen  # noqa: E402

from aerotruth.analysis.wind.consensus import (  # noqa: E402
    consensus_wind,
    observation_table,
    sample_winds,
    straight_samples,
)
from aerotruth.measured.traffic import canonical_traffic  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--aircraft", type=int, default=60)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    df, _ = gen.make_traffic(args.aircraft, seed=11)
    best: tuple[float, float, float, float] | None = None
    reports = 0
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        tr = straight_samples(canonical_traffic(df, "bench"))  # read, and the roll gate `reports` applies
        t1 = time.perf_counter()
        obs = observation_table(tr)
        t2 = time.perf_counter()
        w = sample_winds(tr)  # the stages again, apart, for their times
        t3 = time.perf_counter()
        consensus_wind(tr, w)
        t4 = time.perf_counter()
        run = (t1 - t0, t2 - t1, t3 - t2, t4 - t3)
        if best is None or run[0] + run[1] < best[0] + best[1]:
            best, reports = run, len(obs)
    assert best is not None
    read_s, table_all_s, winds_s, consensus_s = best
    print(f"aircraft: {args.aircraft}")
    print(f"rows: {len(df)}")
    print(f"reports: {reports}")
    print(f"read_s: {read_s:.3f}")
    print(f"winds_s: {winds_s:.3f}")
    print(f"consensus_s: {consensus_s:.3f}")
    print(f"table_s: {max(table_all_s - winds_s - consensus_s, 0.0):.3f}")
    print(f"rows/s: {len(df) / (read_s + table_all_s):.0f}")


if __name__ == "__main__":
    main()
