"""FITS speed: approaches per second through the inspection sensors (WAAS, one INS, RA,
TVPS, DGPS, pilot marks), the WAAS-aided FITS (as `aerotruth fits` runs it) and the
scoring (residual, errors against the requirement), from truth already in memory (a
cached approach, read once from the truth store's Parquet), on one core.

Prints `label: value` lines:
* `ins_path`: the INS path of the main rate (error_model: FITS paper eq. 4);
* `approaches/s`: sensors + FITS + metrics per second of this process's CPU time
  (target >= 50 per core);
* `message_stream_approaches/s` (and its ratio to the main rate): the same with the WAAS
  built from the message stream (aerotruth.sensors.waas_messages);
* `strapdown_approaches/s`: the same with the INS integrated by the strapdown of the
  50 Hz IMU record;
* `sensors_share`, `fits_share`: where the time goes on the main path.
Best of `--rounds` (noise only slows); CPU time (time.process_time).

    python benchmarks/fits_speed.py [--rounds 3] [--n 40]
"""

from __future__ import annotations

import argparse
import datetime as dt
import tempfile
import time
from pathlib import Path

import numpy as np

from aerotruth.analysis.fits.approach_log import run_approach
from aerotruth.analysis.fits.filter import FitsSpec, period_samples
from aerotruth.analysis.fits.scoring import approach_summary, dgps_noise, epoch_rows, segment_rows, waas_at_epochs
from aerotruth.sensors.ins import InsSpec
from aerotruth.sensors.inspection_log import InspectionSensors, approach_logs
from aerotruth.sensors.waas import WaasSpec
from aerotruth.truth.approach import approach_spec, fly_approach
from aerotruth.truth.track import TruthTrack


def one(track, sensors, spec, k):
    t0 = time.process_time()
    logs = approach_logs(track, sensors, lambda *n: np.random.default_rng([k, hash(n) & 0xFFFF]), f"A{k}")
    t1 = time.process_time()
    for log in logs.logs.values():
        r = run_approach(log, spec)
        T = period_samples(r.noiseless.t_s, spec.period_s)
        waas = waas_at_epochs(log)
        ep = epoch_rows(r, logs.truth, logs.geometry, waas, T)
        approach_summary(ep, r.bias_m, segment_rows(r, logs.truth), 10.0)
        dgps_noise(r, log, ep, 10.0, waas)
    return t1 - t0, time.process_time() - t1


def rate(track, sensors, n, rounds):
    spec = FitsSpec()
    best, parts = 0.0, (0.0, 0.0)
    for _ in range(rounds):
        s = f = 0.0
        for k in range(n):
            a, b = one(track, sensors, spec, k)
            s, f = s + a, f + b
        if n / (s + f) > best:
            best, parts = n / (s + f), (s / (s + f), f / (s + f))
    return best, parts


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--n", type=int, default=40, help="approaches per round")
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as d:
        path = Path(d) / "a.parquet"
        fly_approach(approach_spec("KDLH", "27", dt.date(2009, 8, 15), turbulence=True), seed=1).to_parquet(path)
        track = TruthTrack.read_parquet(path)  # what a study gets from the truth store
    main_sensors = InspectionSensors(ins=[InsSpec(grade="tactical")])
    r, (s_share, f_share) = rate(track, main_sensors, args.n, args.rounds)
    print("ins_path: error_model")
    print(f"approaches/s: {r:.1f}")
    print(f"sensors_share: {s_share:.2f}")
    print(f"fits_share: {f_share:.2f}")
    ms_sensors = InspectionSensors(ins=[InsSpec(grade="tactical")], waas=WaasSpec(model="message_stream"))
    r_ms, _ = rate(track, ms_sensors, args.n, args.rounds)
    print(f"message_stream_approaches/s: {r_ms:.1f}")
    print(f"message_stream_over_eq6: {r_ms / r:.2f}")
    sd_sensors = InspectionSensors(ins=[InsSpec(grade="tactical", mechanization="strapdown")])
    r_sd, _ = rate(track, sd_sensors, max(3, args.n // 10), args.rounds)
    print(f"strapdown_approaches/s: {r_sd:.2f}")


if __name__ == "__main__":
    main()
