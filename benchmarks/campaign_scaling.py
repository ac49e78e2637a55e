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

`--paper-pair N[,N...]` times Mesaba's `paper_pair` size (the paper's own before/after pair)
cold on 2 workers for fractions of its fleet: the first N of its 36 aircraft (the poor and
control counts scaled, 19/36 and 17/36 of N), each into an empty truth store, one after
the other; per fraction `paper_pair_<N>_wall` (s), `_legs_flown` and `_block_hours` (the
legs' planned block times), and over the fractions the seconds per block-hour, a straight
line wall = a + b x block-hours through them and `paper_pair_36_wall_extrapolated` (s).
Two fractions of at least 6 aircraft (1/6) show whether the cost is linear; at the 20 Hz
route step on 2 cores, 6 aircraft took 2,199 s and 9 aircraft 3,401 s (0.91 and 0.94 s a
block-hour; 3.9 h extrapolated to the 36: docs/architecture.md).

    python benchmarks/campaign_scaling.py [--points 12000] [--no-dask] [--truth] [--mesaba]
    python benchmarks/campaign_scaling.py --paper-pair 6,9
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


def _block_hours(campaign) -> float:
    """The planned block time of every leg the heading_correction study flies (hours)."""
    from aerotruth.sim.fleet_days import aircraft_days

    section = campaign.studies["heading_correction"]
    return (
        sum(
            p.plan.block_time_s
            for role in ("fit", "before", "after")
            for _, day in aircraft_days(campaign, section.flights(role))
            for p in day.plans()
        )
        / 3600.0
    )


def paper_pair(root: Path, sizes: list[int]) -> None:
    """Cold wall times of fractions of Mesaba's paper_pair size (module docstring)."""
    import numpy as np

    from aerotruth.sim.campaign_loader import load_campaign

    path = Path(__file__).resolve().parents[1] / "campaigns" / "mesaba_2009.yaml"
    full = load_campaign(path, size="paper_pair")
    fleet = full.fleets[0]
    hours, walls = [], []
    for n in sizes:
        if not 2 <= n <= len(fleet.aircraft):
            raise SystemExit(f"--paper-pair: expected aircraft counts in 2..{len(fleet.aircraft)}, got {n}")
        section = full.studies["heading_correction"]
        poor = max(1, round(19 * n / 36))
        sel = section.selection.model_copy(update={"poor": poor, "control": max(1, min(n - poor, round(17 * n / 36)))})
        part = full.model_copy(
            update={
                "fleets": [fleet.model_copy(update={"aircraft": fleet.aircraft[:n]})],
                "studies": {"heading_correction": section.model_copy(update={"selection": sel})},
            }
        )
        block = _block_hours(part)
        os.environ["AEROTRUTH_CACHE"] = str(root / f"cache-{n}")  # an empty truth store
        t0 = time.perf_counter()
        s = run_campaign(
            part, ExecutorChoice("local", workers=2), out=root / f"pp-{n}", progress=False, log=lambda m: None
        )
        wall = time.perf_counter() - t0
        print(f"paper_pair_{n}_wall: {wall:.0f}")
        print(f"paper_pair_{n}_legs_flown: {s.legs_flown}")
        print(f"paper_pair_{n}_block_hours: {block:.0f}")
        print(f"paper_pair_{n}_seconds_per_block_hour: {wall / block:.2f}", flush=True)
        hours.append(block)
        walls.append(wall)
    if len(sizes) >= 2:
        b, a = np.polyfit(hours, walls, 1)
        full_hours = _block_hours(full)
        print(f"paper_pair_line: wall = {a:.0f} s + {b:.2f} s x block-hours")
        print(f"paper_pair_36_block_hours: {full_hours:.0f}")
        print(f"paper_pair_36_wall_extrapolated: {a + b * full_hours:.0f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--points", type=int, default=12000, help="wind samples per level and hour (task weight)")
    ap.add_argument("--no-dask", action="store_true", help="skip the Dask LocalCluster run")
    ap.add_argument("--truth", action="store_true", help="time truth flights instead of the wind climatology")
    ap.add_argument("--mesaba", action="store_true", help="time the reduced Mesaba campaign cold and warm instead")
    ap.add_argument("--paper-pair", metavar="N[,N...]", help="time fractions of Mesaba's paper_pair size (aircraft)")
    args = ap.parse_args()
    if args.paper_pair:
        try:
            sizes = [int(x) for x in args.paper_pair.split(",")]
        except ValueError:
            raise SystemExit(f"--paper-pair: expected aircraft counts like 6,9, got {args.paper_pair!r}") from None
        with tempfile.TemporaryDirectory() as tmp:
            paper_pair(Path(tmp), sizes)
        return
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
