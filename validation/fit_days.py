"""How many days of reports the heading-deviation fit needs for a given table accuracy, per
fleet, measured on a heading_correction run's own simulated
reports, where the truth heading is known.

For each k in --days, `--reps` times: draw k days of the run's fit period at random, fit
every aircraft (`FleetHeadingFit`, the campaign's `fit_heading` frame), and apply each
table as the TAMDAR does, on the measured magnetic heading, to every steady level report
of that aircraft in the whole run (all periods). The table's accuracy is the RMS of the
residual heading error (reported + table correction - true heading) over those reports;
the floor is the same with the table fitted on every fit day; "none" is without a table.
Aircraft whose fit is refused at k days count with no correction (what would be uploaded).

Prints per fleet and k: `residual_deg.<fleet>.<k>d: median p90` over aircraft x
repetitions (poor-class aircraft only: the ones that get tables), the legs those days
hold, and `days_for.<fleet>.<x>deg:` the smallest k whose median residual is under x.

    python validation/fit_days.py RUN_DIR [--days 1 2 3 5 8] [--reps 20]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

from aerotruth.analysis.wind.heading_correction import FleetHeadingFit, lut_correction
from aerotruth.analysis.wind.heading_errors import GateSpec
from aerotruth.sim.studies.wind_reports import steady_heading_error


def residuals(fit: FleetHeadingFit | None, steady: pd.DataFrame) -> pd.Series:
    """RMS residual heading error per aircraft after uploading `fit`'s tables (None: no table)."""
    out = {}
    for ac, g in steady.groupby("aircraft", observed=True, sort=True):
        d = g["d_deg"].to_numpy()
        f = None if fit is None else fit.fits_.get(str(ac))
        if f is not None and f.status_ != "refused":
            d = d + lut_correction(np.nan_to_num(np.asarray(f.lut_, dtype=float)), g["heading_mag_deg"].to_numpy())
        out[str(ac)] = float(np.sqrt(np.mean(d**2)))
    return pd.Series(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("run", help="run directory of a heading_correction campaign")
    ap.add_argument("--days", type=int, nargs="+", default=[1, 2, 3, 5, 8])
    ap.add_argument("--reps", type=int, default=20)
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    run = Path(a.run)
    path = run / "data" / "heading_correction.observations.parquet"
    if not path.exists():
        sys.exit(f"{run}: no {path.relative_to(run)} (run a heading_correction campaign first)")
    cfg = yaml.safe_load((run / "config.resolved.yaml").read_text())["studies"]["heading_correction"]
    frame, max_roll = cfg.get("fit_heading", "true"), float(cfg.get("max_roll_deg", 10.0))
    obs = pd.read_parquet(path)
    obs = obs[obs["trigger"].notna()] if "trigger" in obs else obs
    fit_obs = obs[obs["stage"] == "fit"]
    steady = steady_heading_error(obs)
    poor = set(obs.loc[obs["heading_class"] == "poor", "aircraft"].astype(str))
    steady = steady[steady["aircraft"].astype(str).isin(poor)]
    dates = np.array(sorted(fit_obs["date"].astype(str).unique()))
    legs_per_day = fit_obs.groupby(["aircraft", "date"], observed=True)["flight"].nunique().mean()
    rng = np.random.default_rng(a.seed)
    est = FleetHeadingFit(heading=frame, gates=GateSpec(max_roll_deg=max_roll))

    def fitted(days):
        sub = fit_obs[fit_obs["date"].astype(str).isin(days)]
        return est.fit(sub.drop(columns=["stage"]), source="fit-period reports")

    for fleet, fl in steady.groupby("fleet", observed=True, sort=True):
        none = residuals(None, fl)
        floor = residuals(fitted(dates), fl)
        print(
            f"fleet: {fleet} ({len(none)} poor aircraft, {len(dates)} fit days, "
            f"{legs_per_day:.1f} legs per aircraft-day)"
        )
        print(f"residual_deg.{fleet}.none: median {none.median():.3f} p90 {none.quantile(0.9):.3f}")
        medians = {}
        for k in sorted(set(d for d in a.days if d < len(dates))):
            vals = pd.concat([residuals(fitted(rng.choice(dates, k, replace=False)), fl) for _ in range(a.reps)])
            medians[k] = vals.median()
            print(
                f"residual_deg.{fleet}.{k}d: median {vals.median():.3f} p90 {vals.quantile(0.9):.3f} "
                f"({k * legs_per_day:.0f} legs per aircraft)"
            )
        medians[len(dates)] = floor.median()
        print(
            f"residual_deg.{fleet}.{len(dates)}d: median {floor.median():.3f} "
            f"p90 {floor.quantile(0.9):.3f} (every fit day)"
        )
        for x in (1.0, 0.75, 0.5):
            k = next((k for k in sorted(medians) if medians[k] < x), None)
            print(f"days_for.{fleet}.{x:g}deg: {k if k is not None else f'> {len(dates)}'}")


if __name__ == "__main__":
    main()
