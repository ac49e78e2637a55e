"""Throughput of `aerotruth reports` on one core: a decoded multi-aircraft state table (in
memory) -> the canonical traffic frame (aerotruth.measured.traffic) -> per-sample winds
(IGRF declination, horizontal TAS) -> the consensus reference (cKDTree neighbourhoods, the
neighbours' offsets estimated jointly) -> the observation table.

Data: the independent traffic generator (tests/traffic_generator.py), `--aircraft` aircraft
(default 60) at four flight levels in a 200-km box over an hour, 1-s samples (20 min each:
72,000 rows at the default), about a busy hour of one receiver's Mode-S traffic. Generated
before the clock starts.

Prints `rows/s` (state-table rows to observation-table rows, end to end), the stage times and
`aircraft`, `rows`, `reports` (rows with a reference).

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

from aerotruth.analysis.wind.consensus import consensus_wind, sample_winds  # noqa: E402
from aerotruth.measured.traffic import canonical_traffic  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--aircraft", type=int, default=60)
    ap.add_argument("--repeat", type=int, default=3)
    args = ap.parse_args()
    df, _ = gen.make_traffic(args.aircraft, seed=11)
    best = None
    for _ in range(args.repeat):
        t0 = time.perf_counter()
        tr = canonical_traffic(df, "bench")
        t1 = time.perf_counter()
        w = sample_winds(tr)
        t2 = time.perf_counter()
        u, _, _, _ = consensus_wind(tr, w)
        t3 = time.perf_counter()
        stages = (t1 - t0, t2 - t1, t3 - t2)
        if best is None or sum(stages) < sum(best):
            best = stages
    assert best is not None
    total = sum(best)
    print(f"aircraft: {args.aircraft}")
    print(f"rows: {len(df)}")
    print(f"reports: {int((u == u).sum())}")
    print(f"read_s: {best[0]:.3f}")
    print(f"winds_s: {best[1]:.3f}")
    print(f"consensus_s: {best[2]:.3f}")
    print(f"rows/s: {len(df) / total:.0f}")


if __name__ == "__main__":
    main()
