"""Null control of `aerotruth diagnose` on aerotruth's own observation tables: JSBSim
truth from the truth store -> the campaign's wind sensors (flux valve with hard and soft
iron, slaved gyro, air data, TAMDAR reports, RR- and RTFDDA-like analyses) -> diagnose
against the model those sensors imply (analysis.diagnose_wind_model.model_of_sensors,
what `aerotruth diagnose --model CAMPAIGN` assumes when the campaign has no diagnose
section).

The truth (Mesaba schedule days of `--aircraft` aircraft on `--days` dates, six legs at
most) is flown once into the truth store; each dataset is another sensor seed on it: new
airframes (hard and soft iron, mounting, TAS bias), new weather-model errors, new noise.
Nothing is hidden, so every finding is false: nominally 2 % family-wise, <= 5 per 100
required. Power: the share of datasets in which a hidden wind-speed bias of the RR-like
analyses (analysis wind = (1 - k) x smoothed truth, k = 2, 5, 10 %) is ranked first as a
reference bias (a bias along the wind).

    python validation/diagnose_wind_sim_null.py [--datasets 100] [--aircraft 12] [--days 5]
        [--campaign campaigns/mesaba_2009.yaml] [--power 10] [--figure FILE]

Prints `label: value` lines.
"""

from __future__ import annotations

import argparse
import datetime as dt
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

from aerotruth.analysis.diagnose.wind import diagnose_wind, prepare
from aerotruth.analysis.diagnose.wind_model import wind_model_from_campaign
from aerotruth.sim.campaign_loader import load_campaign
from aerotruth.sim.wind_observations import simulated_observations
from aerotruth.truth.days import AircraftDay
from aerotruth.truth.store import TruthStore

ROOT = Path(__file__).resolve().parents[1]


class MemoStore:
    """The truth store with each aircraft-day's legs kept in memory (read once, used by
    every dataset)."""

    def __init__(self, store: TruthStore):
        self.store, self.cache = store, {}

    def day(self, day: AircraftDay):
        key = (day.aircraft, day.date)
        if key not in self.cache:
            self.cache[key] = self.store.day(day)
        return self.cache[key]


def truth_days(n_aircraft: int, n_days: int) -> list[AircraftDay]:
    dates = [dt.date(2009, 8, 17) + dt.timedelta(days=7 * k) for k in range(n_days)]
    return [
        AircraftDay.for_campaign(2009, f"N{401 + i}XJ", d, network="mesaba", max_legs=6)
        for i in range(n_aircraft)
        for d in dates
    ]


def _fly(day: AircraftDay) -> int:
    return len(TruthStore().day(day))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--datasets", type=int, default=100)
    ap.add_argument("--aircraft", type=int, default=12)
    ap.add_argument("--days", type=int, default=5)
    ap.add_argument("--campaign", default=str(ROOT / "campaigns" / "mesaba_2009.yaml"))
    ap.add_argument("--power", type=int, default=10, help="datasets per hidden TAS scale size")
    ap.add_argument("--workers", type=int, default=2, help="processes flying missing truth")
    ap.add_argument("--figure", default=None)
    a = ap.parse_args()
    campaign = load_campaign(a.campaign)
    study = campaign.studies["heading_correction"]
    fleet = study.fleets[0]
    sensors = study.sensors.only(fleet)
    spec = wind_model_from_campaign(campaign)
    print(f"model: {spec.model_dump_json()}")
    days = truth_days(a.aircraft, a.days)
    with ProcessPoolExecutor(a.workers) as ex:
        legs = sum(ex.map(_fly, days))
    print(f"truth_legs: {legs}")
    store = MemoStore(TruthStore())

    found, n_with, sizes = Counter(), 0, []
    for s in range(a.datasets):
        d = prepare(simulated_observations(days, sensors, 50_000 + s, fleet=fleet, store=store))
        sizes.append(d.n)
        f, _, _, _ = diagnose_wind(d, spec)
        n_with += bool(f)
        found.update(x.effect for x in f)
        print(f"# dataset {s}: rows {d.n}, findings {[x.effect for x in f]}", flush=True)
    if a.datasets:
        print(f"null_datasets: {a.datasets}")
        print(f"null_rows_median: {int(np.median(sizes))}")
        print(f"null_findings: {sum(found.values())}")
        print(f"null_datasets_with_a_finding: {n_with}")
        for k, v in sorted(found.items()):
            print(f"null_finding_{k}: {v}")

    curve = []
    fs = sensors.of(fleet)
    for k in (0.02, 0.05, 0.1) if a.power else ():
        refs = [
            r.model_copy(update={"speed_bias_fraction": -k}) if r.name == "rr" else r
            for r in fs.references or sensors.references
        ]
        hidden = sensors.model_copy(update={"fleets": {fleet: fs.model_copy(update={"references": refs})}})
        hit, est = 0, []
        for s in range(a.power):
            f, _, _, _ = diagnose_wind(
                prepare(simulated_observations(days, hidden, 60_000 + s, fleet=fleet, store=store)), spec
            )
            hit += bool(f) and f[0].effect == "reference_bias"
            if f and f[0].effect == "reference_bias":
                est.append(f[0].parameters["bias_kt"]["rr"]["value"])
        curve.append((k, hit / a.power))
        print(f"power_reference_speed_bias_{k:g}: {hit / a.power:.2f}")
        if est:
            print(f"power_reference_speed_bias_{k:g}_estimate_kt_median: {np.median(est):.2f}")
    if a.figure and curve:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, ax = plt.subplots(figsize=(5, 3.5))
        ax.plot([100 * c[0] for c in curve], [c[1] for c in curve], "o-")
        ax.set_xlabel("hidden RR wind-speed underestimate (%)")
        ax.set_ylabel("share ranked first")
        ax.set_ylim(-0.05, 1.05)
        ax.set_title(
            f"aerotruth sensors: {sum(found.values())} false findings in {a.datasets} null datasets", fontsize=9
        )
        fig.tight_layout()
        fig.savefig(a.figure, dpi=120)


if __name__ == "__main__":
    main()
