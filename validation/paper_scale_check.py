"""A wind-paper table's predictive distribution, made from reduced runs, checked against a
run flown whole at the paper's own scale (a campaign's `paper_pair` size), and the table's
own effect at that scale.

The plan runs (reduced size: a few days a period) give the predictive distribution of one
draw of the paper's table at its scale (aerotruth.analysis.wind.paper_draw: the runs'
aircraft-day sums split into the aircraft's lasting errors, the days' shared weather and
the rest, and redrawn at the paper's fleet size and period lengths). A `paper_pair` run
*is* one such draw, flown: every day of both periods on the full daily schedule, its poor
group selected on all its before days. This script places that draw in the predictive
distribution as the paper's own value is placed (the same `judge`: z, PIT, and a joint
Mahalanobis distance over the four base total cells, poor and control before and after),
and sets sd_draw beside two estimates the full run makes by itself:

* `sd_own`: the same variance-component draw at the same scale from the full run's sums
  alone (its 60-odd days a period and full days' schedules; 4 + 3 aircraft, so its
  aircraft part is rough);
* `sd_days`: the full run's days resampled with replacement within each period, its
  aircraft as flown (the before period's days and the after period's, each shared by both
  groups and by the untreated twin): the weather's share alone, a floor under sd_draw.

The paper_draw module assumes an aircraft-day of the paper's is one of the reduced runs'
(two legs), whose residual is larger than a full day's: sd_draw is then if anything too
wide, so sd_own <= sd_draw is expected, and the full run's z should be modest.

The table's own effect (`poor.table_effect`: the poor group's untreated twin after the
table less its reports with the table, the same reports) beside the improvement the paper
reads (before - adjusted after): their difference is what the improvement owes to
selecting the worst aircraft on noisy before cells and to the periods' weather (regression
to the mean and season), at the reduced size (mean over the plan's runs) and at the
paper's.

    python validation/paper_scale_check.py runs/penair_2010-paper_pair \\
        --plan validation/plans/wind-tables-penair-2.yaml --reduced runs/plans/penair-2/base-204?

Prints `label: value` lines.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from paper_tables import collect_sums  # noqa: E402
from plans import Plan, check_runs  # noqa: E402

BASE_TOTALS = ["poor.before.total", "poor.after.total", "control.before.total", "control.after.total"]
# the day's epoch: the after period and its untreated twin are the same days
EPOCH = {"before": "before", "after": "after", "after_untreated": "after"}


def cell_series(cells: pd.DataFrame) -> pd.Series:
    """cells_from_sums rows as one series "<group>.<period>.<component>" -> kt."""
    from aerotruth.analysis.wind.paper_draw import COMPONENTS

    out = {}
    for r in cells.itertuples():
        for col, lab in COMPONENTS:
            out[f"{r.group}.{r.period}.{lab}"] = float(getattr(r, col))
    return pd.Series(out)


def day_bootstrap(sums: pd.DataFrame, n_boot: int, rng: np.random.Generator) -> pd.DataFrame:
    """The full run's cells with its days resampled with replacement within each epoch
    (before; after with its twin), the aircraft and their groups as flown: one row a
    resample."""
    from aerotruth.analysis.wind.paper_draw import COMPONENTS, SUM_COLUMNS, SUMS, derive

    s = sums[sums["group"].isin(["poor", "control"])].copy()
    s["epoch"] = s["period"].map(EPOCH)
    cols = list(SUM_COLUMNS)
    cells: dict[tuple[str, str], dict[str, np.ndarray]] = {}
    for _epoch, part in s.groupby("epoch", sort=True):
        days = np.sort(part["day"].unique())
        counts = rng.multinomial(len(days), np.full(len(days), 1.0 / len(days)), size=n_boot)  # n_boot x D
        for (g, p), gp in part.groupby(["group", "period"], sort=False):
            per_day = gp.groupby("day")[cols].sum().reindex(days, fill_value=0.0)
            tot = pd.DataFrame(counts @ per_day.to_numpy(), columns=cols)  # n_boot x sums
            cells[(g, p)] = {lab: np.sqrt(tot[SUMS[lab][0]] / tot[SUMS[lab][1]]).to_numpy() for _, lab in COMPONENTS}
    out = {}
    for _, lab in COMPONENTS:
        mine = {key: v[lab] for key, v in cells.items()}
        mine.update(derive(mine))
        out.update({f"{g}.{p}.{lab}": v for (g, p), v in mine.items()})
    return pd.DataFrame(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("full", help="the run flown at the paper's scale (a campaign's paper_pair size)")
    ap.add_argument("--plan", required=True, help="the committed plan the reduced runs were made under")
    ap.add_argument("--reduced", nargs="+", required=True, help="the plan's runs (two or more)")
    ap.add_argument("--boot", type=int, default=1000, help="day resamples of the full run (default 1000)")
    a = ap.parse_args()
    from aerotruth.analysis.wind.paper_draw import cells_from_sums, judge, predictive

    if len(a.reduced) < 2:
        sys.exit("--reduced: expected two runs or more (the mean's standard error is a jackknife over runs)")
    plan = Plan.load(a.plan)
    check_runs(plan, a.reduced)
    full_sums = collect_sums([a.full])
    for g in ("poor", "control"):
        if not (full_sums["group"] == g).any():
            sys.exit(f"{a.full}: tables/heading_correction.aircraft_days has no {g} aircraft: is the run whole?")
    reduced_sums = collect_sums(a.reduced)
    scale = plan.scale
    print(f"plan: {plan.name} {plan.commit}")
    print(f"paper_scale: poor {scale.poor} control {scale.control} days {scale.days_before} / {scale.days_after}")
    shape = full_sums.groupby("period").agg(
        days=("day", "nunique"), aircraft=("aircraft", "nunique"), rows=("n", "sum")
    )
    for p, r in shape.iterrows():
        print(f"full_run.{p}: days {r.days} aircraft {r.aircraft} rows {r.rows}")

    full = cell_series(cells_from_sums(full_sums))
    rng = np.random.default_rng(2026)
    draws, loo = predictive(reduced_sums, scale, plan.draws, rng)
    table, joint = judge(draws, loo, full.to_dict(), BASE_TOTALS, level=0.05)
    own, _ = predictive(full_sums, scale, plan.draws, rng)
    boot = day_bootstrap(full_sums, a.boot, rng)
    for r in table.itertuples():
        sd_own = float(own[r.cell].std(ddof=1)) if r.cell in own else math.nan
        sd_days = float(boot[r.cell].std(ddof=1)) if r.cell in boot else math.nan
        print(
            f"check.{r.cell}: full {r.paper:.2f} predictive_mean {r.mean:.2f} sd_draw {r.sd_draw:.2f} se {r.se:.2f} "
            f"z {r.z:+.2f} pit {r.pit:.3f} sd_own {sd_own:.2f} sd_days {sd_days:.2f}"
        )
    z = table["z"].to_numpy()
    worst = table.iloc[int(np.nanargmax(np.abs(z)))]
    print(f"check.cells: {len(table)}")
    print(f"check.abs_z_over_2: {int((np.abs(z) > 2).sum())} of {len(table)}")
    print(f"check.largest_abs_z: {abs(worst.z):.2f} ({worst.cell})")
    print(
        f"check.joint_base_totals: mahalanobis_d2 {joint['mahalanobis_d2']:.2f} dof {int(joint['dof'])} "
        f"p {joint['p']:.3f}"
    )
    ratio = np.array(
        [
            table.set_index("cell").loc[c, "sd_draw"] / own[c].std(ddof=1)
            for c in table["cell"]
            if c in own and own[c].std(ddof=1) > 0
        ]
    )
    print(f"check.sd_draw_over_sd_own: median {np.median(ratio):.2f} range {ratio.min():.2f}-{ratio.max():.2f}")

    per_run = pd.DataFrame([cell_series(cells_from_sums(part)) for _, part in reduced_sums.groupby("run", sort=False)])
    for lab in ("total", "longitudinal", "transverse"):
        eff, imp = f"poor.table_effect.{lab}", f"poor.improvement.{lab}"
        if eff not in full or eff not in per_run:
            print(f"table_effect.{lab}: no untreated twin in the runs")
            continue
        n = len(per_run)
        rm = per_run[imp] - per_run[eff]
        se_eff = per_run[eff].std(ddof=1) / n**0.5
        print(
            f"table_effect.{lab}: paper_scale {full[eff]:.2f} of improvement {full[imp]:.2f} (the rest "
            f"{full[imp] - full[eff]:+.2f}); reduced {per_run[eff].mean():.2f} se {se_eff:.2f}"
            f" of improvement {per_run[imp].mean():.2f} (the rest {rm.mean():+.2f} se {rm.std(ddof=1) / n**0.5:.2f})"
        )


if __name__ == "__main__":
    main()
