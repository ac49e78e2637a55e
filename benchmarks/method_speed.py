"""Throughput of the wind paper's method on one core: observation table (in memory) ->
validation -> three-report ground tracks and air vectors (eqs. 3, 4) -> per-aircraft
robust fit with D/E test and cross-model check -> lookup-table correction and the wind
error metrics before/after (RMS, longitudinal, transverse).

Data: the independent test generator (tests/obs_generator.py), a fleet of 12 aircraft
with two reference models, 40 flights each `--copies` times (default 25: 1000 flights per
aircraft, ~1.1 M rows, about what a season of such a fleet sends), each batch of flights
later in time with its own random stream (new flights and reference errors: repeating one
batch would repeat its errors, and the two models' fits would then differ by 5x their
standard errors), held in memory as read back from Parquet (~30 s to generate). The table
is generated in a child process and read from a temporary Parquet file by the reader of
`aerotruth heading fit` (`read_observation_file`: label columns as categoricals); its
read time is printed (`read_s`), not counted in the rates. Generated in this process, the
generator's freed objects leave the heap fragmented and every later array allocation
slower (measured: the method ~20 % slower on the same table).

Prints `reports/s` (aircraft reports, each with its reference rows), `rows/s` ((report,
reference) rows), and the stage times; then `one_model.*`: the same reports against the
first reference model only (no consistency check), for scale.

    python benchmarks/method_speed.py [--copies 25] [--repeat 3]
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_v] = "1"  # per core

import argparse  # noqa: E402
import io  # noqa: E402
import multiprocessing  # noqa: E402
import sys  # noqa: E402
import tempfile  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import obs_generator as gen  # noqa: E402

from aerotruth.analysis.wind.heading_correction import FleetHeadingFit  # noqa: E402
from aerotruth.analysis.wind.heading_errors import heading_errors  # noqa: E402
from aerotruth.analysis.wind.metrics import wind_errors_before_after  # noqa: E402
from aerotruth.analysis.wind.observations import validate_observations  # noqa: E402
from aerotruth.measured.observations import read_observation_file  # noqa: E402


def table(copies: int) -> pd.DataFrame:
    rng = np.random.default_rng(2009)
    fleet = gen.fleet(12, rng, tas_kt=(400.0, 460.0))
    parts, t0 = [], 1_249_084_800.0
    for c in range(copies):  # the same aircraft flying on, new flights and reference errors: a season
        p = gen.generate(
            fleet, np.random.default_rng([2009, c]), spoke_km=(700.0, 1500.0), cruise_ft=(25000.0, 35000.0), t_start=t0
        )
        t0 = p["time"].max() + 86400.0
        parts.append(p)
    # as a user's table arrives, read from a file (one Arrow chunk per string column, not the
    # 24,000 chunks the concatenation leaves, which cost 4x in factorising the labels)
    buf = io.BytesIO()
    pd.concat(parts, ignore_index=True).to_parquet(buf)
    return pd.read_parquet(buf)


def _write_table(copies: int, path: str) -> None:
    table(copies).to_parquet(path)


def fresh_table(copies: int) -> tuple[pd.DataFrame, float]:
    """table(copies) made in a child process, read back here from a temporary Parquet file
    as `aerotruth heading fit` reads a user's; and the fastest of three reads (s)."""
    with tempfile.TemporaryDirectory() as d:
        path = str(Path(d) / "obs.parquet")
        child = multiprocessing.get_context("spawn").Process(target=_write_table, args=(copies, path))
        child.start()
        child.join()
        if child.exitcode != 0:
            raise SystemExit(f"method_speed: generating the table failed (exit code {child.exitcode})")
        read_s, obs = [], None
        for _ in range(3):
            obs = None  # the previous read freed first (else each read faults in fresh pages)
            t0 = time.perf_counter()
            obs = read_observation_file(path)
            read_s.append(time.perf_counter() - t0)
        return obs, min(read_s)


def run(obs: pd.DataFrame) -> dict[str, float]:
    t0 = time.perf_counter()
    v = validate_observations(obs, "benchmark")
    t1 = time.perf_counter()
    rows = heading_errors(v)
    t2 = time.perf_counter()
    fleet = FleetHeadingFit().fit(rows)
    t3 = time.perf_counter()
    m = np.flatnonzero(rows["gate"].cat.codes.to_numpy() == 0)  # "used" (a gather by index: 5x a boolean mask's speed)
    used = pd.DataFrame(
        {c: rows[c].array.take(m) for c in ("aircraft", "heading_deg", "va_e", "va_n", "dw_e", "dw_n")}, copy=False
    )  # only the columns the metrics read
    before, after = wind_errors_before_after(
        used, fleet.correction(used["aircraft"].array, used["heading_deg"].to_numpy())
    )
    t4 = time.perf_counter()
    return {
        "validate_s": t1 - t0,
        "tracks_s": t2 - t1,
        "fit_s": t3 - t2,
        "metrics_s": t4 - t3,
        "total_s": t4 - t0,
        "rms_before_kt": before["rms_kt"],
        "rms_after_kt": after["rms_kt"],
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--copies", type=int, default=25, help="repeats of the 40 flights, later in time")
    ap.add_argument("--repeat", type=int, default=3, help="timed runs; the fastest counts")
    a = ap.parse_args()
    obs, read_s = fresh_table(a.copies)
    best = min((run(obs) for _ in range(a.repeat)), key=lambda r: r["total_s"])
    n_rows = len(obs)
    n_reports = len(obs.drop_duplicates(["aircraft", "time"]))  # after the timed runs: its copies fragment the heap
    print(f"rows: {n_rows}")
    print(f"reports: {n_reports}")
    print(f"read_s: {read_s:.3f}")
    for k in ("validate_s", "tracks_s", "fit_s", "metrics_s", "total_s"):
        print(f"{k}: {best[k]:.3f}")
    print(f"rms_before_kt: {best['rms_before_kt']:.2f}")
    print(f"rms_after_kt: {best['rms_after_kt']:.2f}")
    print(f"rows/s: {n_rows / best['total_s']:.0f}")
    print(f"reports/s: {n_reports / best['total_s']:.0f}")
    # the same reports against one reference model (PenAir's case: RR only), for scale; the
    # `reports/s` line above, with two models and their consistency check, is the one judged
    one = obs[obs["ref_source"] == obs["ref_source"].iloc[0]].reset_index(drop=True)
    best1 = min((run(one) for _ in range(a.repeat)), key=lambda r: r["total_s"])
    print(f"one_model.total_s: {best1['total_s']:.3f}")
    print(f"one_model.reports/s: {len(one) / best1['total_s']:.0f}")


if __name__ == "__main__":
    main()
