"""Campaign scaling: the same campaign run with 1 and 2 local worker processes (and on a
2-worker Dask LocalCluster), timed end to end through `run_campaign` (pool start-up,
task dispatch, result storage and aggregation included; report not included).

Prints `label: value` lines:
  wall_1, wall_2, wall_dask: seconds;
  efficiency = wall_1 / (2 * wall_2) (target >= 0.8), efficiency_dask likewise;
  identical_metrics: 1 when the three metrics.json files are byte-identical.

The default campaign is a wind climatology with tasks of ~5 s each (8 tasks:
2 regions x 4 days). `--truth` uses truth flights instead (4 aircraft-days of 2 legs:
heavier, JSBSim).

`--mesaba` instead times the reduced Mesaba campaign (campaigns/mesaba_2009.yaml --size
reduced) on 2 workers twice, into an empty truth store: `mesaba_cold` (every leg flown)
and `mesaba_warm` (a sensor parameter changed: the poor hard-iron sigma; every leg from
the truth store, every report, fit and metric recomputed), plus `mesaba_legs_flown_warm`
(0 when truth is reused).

    python benchmarks/campaign_scaling.py [--points 12000] [--no-dask] [--truth] [--mesaba]
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from aerotruth.sim.campaign import run_campaign
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.executors import ExecutorChoice

WIND = """\
name: scaling
seed: 3
periods:
  - {{name: p, start: 2009-08-12, end: 2009-08-15}}
studies:
  wind_climatology:
    regions:
      - {{name: upper_midwest, network: mesaba}}
      - {{name: alaska, network: penair}}
    periods: [p]
    flight_levels: [50, 100, 150, 200, 250]
    hours_utc: [0, 6, 12, 18]
    points: {points}
"""

TRUTH = """\
name: scaling_truth
seed: 3
fleets:
  - {name: mesaba, network: mesaba, aircraft: [N401XJ, N402XJ, N403XJ, N404XJ]}
periods:
  - {name: p, dates: [2009-08-15]}
studies:
  truth:
    fleets: [mesaba]
    periods: [p]
    max_legs_per_day: 2
"""


def timed_run(text: str, choice: ExecutorChoice, out: Path) -> float:
    """Wall seconds of one complete run into a fresh directory with an empty truth store
    of its own (a cold run: every leg is flown)."""
    text += f"truth_store: {{path: {out / 'truth'}}}\n"
    t0 = time.perf_counter()
    run_campaign(parse_campaign(text), choice, out=out, progress=False, log=lambda msg: None)
    return time.perf_counter() - t0


def mesaba(root: Path) -> None:
    """Cold and warm wall times of the reduced Mesaba campaign (module docstring)."""
    from aerotruth.sim.campaign_loader import load_campaign

    os.environ["AEROTRUTH_CACHE"] = str(root / "cache")  # an empty truth store
    path = Path(__file__).resolve().parents[1] / "campaigns" / "mesaba_2009.yaml"
    cold = load_campaign(path, size="reduced")
    section = cold.studies["heading_correction"]
    fleet = section.sensors.fleets["mesaba"]
    heading = fleet.heading.model_copy(update={"poor_hard_iron_sigma_nT": fleet.heading.poor_hard_iron_sigma_nT * 1.2})
    sensors = section.sensors.model_copy(update={"fleets": {"mesaba": fleet.model_copy(update={"heading": heading})}})
    warm = cold.model_copy(update={"studies": {"heading_correction": section.model_copy(update={"sensors": sensors})}})
    for label, campaign, out in (("cold", cold, "cold"), ("warm", warm, "warm")):
        t0 = time.perf_counter()
        s = run_campaign(
            campaign, ExecutorChoice("local", workers=2), out=root / out, progress=False, log=lambda m: None
        )
        print(f"mesaba_{label}: {time.perf_counter() - t0:.1f}")
        print(f"mesaba_legs_flown_{label}: {s.legs_flown}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=int, default=12000, help="wind samples per level and hour (task weight)")
    ap.add_argument("--no-dask", action="store_true", help="skip the Dask LocalCluster run")
    ap.add_argument("--truth", action="store_true", help="time truth flights instead of the wind climatology")
    ap.add_argument("--mesaba", action="store_true", help="time the reduced Mesaba campaign cold and warm instead")
    args = ap.parse_args()
    if args.mesaba:
        with tempfile.TemporaryDirectory() as tmp:
            mesaba(Path(tmp))
        return
    text = TRUTH if args.truth else WIND.format(points=args.points)
    n_tasks = 4 if args.truth else 8
    with tempfile.TemporaryDirectory() as tmp:
        root = Path(tmp)
        wall_1 = timed_run(text, ExecutorChoice("local", workers=1), root / "w1")
        wall_2 = timed_run(text, ExecutorChoice("local", workers=2), root / "w2")
        print(f"tasks: {n_tasks}")
        print(f"task_seconds: {wall_1 / n_tasks:.2f}")
        print(f"wall_1: {wall_1:.2f}")
        print(f"wall_2: {wall_2:.2f}")
        print(f"efficiency: {wall_1 / (2 * wall_2):.3f}")
        runs = ["w1", "w2"]
        if not args.no_dask:
            wall_d = timed_run(text, ExecutorChoice("dask", workers=2), root / "wd")
            print(f"wall_dask: {wall_d:.2f}")
            print(f"efficiency_dask: {wall_1 / (2 * wall_d):.3f}")
            runs.append("wd")
        metrics = {(root / r / "metrics.json").read_bytes() for r in runs}
        print(f"identical_metrics: {int(len(metrics) == 1)}")


if __name__ == "__main__":
    main()
