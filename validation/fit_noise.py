"""How much of a `heading_correction` campaign's judged cells is the fit noise of its size:
a reduced run fits each table on a few days (PenAir: 10 fit days, two legs each; the paper
13 months), so its tables carry a statistical error the paper's hardly had.

For each run (one per campaign seed): the poor aircraft's tables are fitted again, as the
study does (its gates and heading frame, from the run's resolved config), on the whole fit
period (a check: equals the stored tables) and on random halves of each aircraft's fit
days (both halves of `--splits` splits; `--by flight` splits flights instead); the poor
group's after reports are re-scored
with each table - the uploaded table undone and the new one applied at the heading the
firmware indexes (measured magnetic heading for an 8-point table, the offset for
true-heading avionics), a rotation of the air vector: W' = W + TAS (u(psi_c) - u(psi_n)),
u the unit vector along the heading. With n fit flights RMS^2(n) = R + k / n, so
R = 2 RMS^2(n) - RMS^2(n / 2) is the cell with the fit noise gone (infinite fit data,
every other error kept). The control cells do not depend on the tables.

The halves are whole days by default: the reference model's error is correlated for hours
(`aerotruth.sensors.weather_model`: L_t 3 h, L_h 150 km for RR), so a day's out and back
legs on one route see much the same model error - which a one-axis fit reads as the same
error of its along-axis sinusoid term from either leg (the cross-track component of a
wind error flips sign with the heading, and so does the term). Halves that split a day's
legs share that error, understate the half-data noise and with it k.

    python validation/fit_noise.py RUN_DIR [RUN_DIR ...] [--splits 4] [--by day|flight]

Prints per run `run.<name>.poor_after_kt: stored reproduced half infinite` and over the
runs `mean.<cell>_kt: mean se` for poor after and adjusted after (as fitted, with half
the data, extrapolated) and `paired.after_adjusted_kt: difference se` (extrapolated minus
as fitted, per seed).
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.wind.heading_correction import LUT_COLUMNS, FleetHeadingFit
from aerotruth.sim.store import RunStore
from aerotruth.sim.studies.heading_correction import group_rms, reported, uploaded_correction
from aerotruth.sim.studies.wind_reports import unbanked

STUDY = "heading_correction"


def onboard_correction(
    tables: pd.DataFrame, aircraft: np.ndarray, psi_deg: np.ndarray, var_deg: np.ndarray
) -> np.ndarray:
    """The correction (deg) each report's aircraft adds onboard with the learned `tables`
    (the study's `corrections` rows): what the study uploads (`uploaded_correction`: the
    8-point table at the magnetic heading psi - var, the offset for true-heading avionics,
    nothing for other groups or refused fits) applied as the sensor applies it."""
    out = np.zeros(len(psi_deg))
    for ac in np.unique(aircraft):
        c = uploaded_correction(tables, ac)
        if c is not None:
            k = aircraft == ac
            psi = np.radians(psi_deg[k])
            out[k] = np.degrees(c.apply(psi, np.radians(var_deg[k])) - psi)
    return out


def uncorrected_heading(psi_c: np.ndarray, tables: pd.DataFrame, aircraft: np.ndarray, var: np.ndarray) -> np.ndarray:
    """The heading before the uploaded table (deg): psi_u solving psi_c = psi_u + c(psi_u),
    c = onboard_correction. A contraction (the table's slope is far below 1): 30 iterations
    to ~1e-12 deg."""
    psi_u = np.array(psi_c, dtype=float)
    for _ in range(30):
        psi_u = psi_c - onboard_correction(tables, aircraft, psi_u, var)
    return psi_u


def rescored_wind(
    speed_kt: np.ndarray, dir_deg: np.ndarray, tas_kt: np.ndarray, psi_c: np.ndarray, psi_n: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The reported wind (speed kt, direction from, deg) had the heading been psi_n instead
    of psi_c: W' = W + TAS (u(psi_c) - u(psi_n)), u the unit vector along the heading (in
    double precision: `corrected_wind_error` is the same rotation with the method's
    single-precision trigonometry)."""
    d = np.radians(dir_deg)
    we, wn = -speed_kt * np.sin(d), -speed_kt * np.cos(d)  # towards
    pc, pn = np.radians(psi_c), np.radians(psi_n)
    we = we + tas_kt * (np.sin(pc) - np.sin(pn))
    wn = wn + tas_kt * (np.cos(pc) - np.cos(pn))
    return np.hypot(we, wn), np.degrees(np.arctan2(-we, -wn)) % 360.0


def half_splits(aircraft: np.ndarray, unit: np.ndarray, rng: np.random.Generator, n: int):
    """`n` random halvings of each aircraft's units (days or flights), one boolean per row
    (True: the row's unit is in the first half; ties at an odd count go to the second)."""
    code = pd.factorize(pd.Series(aircraft) + "\x1f" + pd.Series(unit))[0]  # first-appearance order
    first_row = np.unique(code, return_index=True)[1]  # each unit's first row, in code order
    unit_ac = aircraft[first_row]
    size = pd.Series(unit_ac).groupby(unit_ac).transform("size").to_numpy()
    for _ in range(n):
        rank = pd.Series(rng.random(len(unit_ac))).groupby(unit_ac).rank().to_numpy()
        yield (rank <= size / 2)[code]


class Refused(Exception):
    """A (half) fit the method refuses: the split cannot be scored."""


class Rescorer:
    """One run's after reports, re-scored with other tables for its poor group."""

    def __init__(self, run: Path):
        store = RunStore(run)
        self.section = store.campaign().section(STUDY)
        obs = pd.read_parquet(run / "data" / f"{STUDY}.observations.parquet")
        self.corr = store.learned_of(STUDY)["corrections"].set_index("aircraft")
        self.poor = sorted(self.corr.index[self.corr["group"] == "poor"])
        group = self.corr["group"]
        self.fit_obs = obs[(obs["stage"] == "fit") & obs["aircraft"].isin(self.poor)].reset_index(drop=True)
        self.before = unbanked(reported(obs[obs["stage"] == "before"]), self.section.max_roll_deg)
        self.after = unbanked(reported(obs[obs["stage"] == "after"]), self.section.max_roll_deg).reset_index(drop=True)
        for o in (self.before, self.after):
            o["group"] = o["aircraft"].astype(str).map(group).fillna("other")
        a = self.after
        self.aircraft = a["aircraft"].astype(str).to_numpy()
        self.var = a["declination_deg"].to_numpy()
        self.psi_c = a["heading_deg"].to_numpy()
        self.psi_u = uncorrected_heading(self.psi_c, self.stored, self.aircraft, self.var)

    @property
    def stored(self) -> pd.DataFrame:
        """The learned corrections the run uploaded from."""
        return self.corr.reset_index()

    def with_tables(self, luts: dict[str, np.ndarray]) -> pd.DataFrame:
        """The learned corrections with the poor aircraft's tables replaced by `luts`."""
        t = self.corr.copy()
        for ac, lut in luts.items():
            t.loc[ac, LUT_COLUMNS] = lut
            if t.loc[ac, "status"] == "refused":  # a refit that the method accepted
                t.loc[ac, "status"] = "fitted"
        return t.reset_index()

    def fit(self, rows: np.ndarray | None = None) -> pd.DataFrame:
        """The learned corrections with the poor aircraft's tables fitted again on their fit
        reports (or the rows `rows` of them)."""
        obs = self.fit_obs if rows is None else self.fit_obs[rows].reset_index(drop=True)
        f = FleetHeadingFit(heading=self.section.fit_heading, gates=self.section.gates()).fit(obs, source="fit reports")
        for ac in self.poor:
            if ac not in f.fits_ or f.fits_[ac].status_ == "refused":
                why = f.fits_[ac].reason_ if ac in f.fits_ else "no fit reports"
                raise Refused(f"{ac}: {why}")
        return self.with_tables({ac: np.asarray(f.fits_[ac].lut_, dtype=float) for ac in self.poor})

    def cells(self, tables: pd.DataFrame) -> dict[tuple[str, str], float]:
        """Total RMS per group and period with the learned corrections `tables` uploaded
        for the after period."""
        psi_n = self.psi_u + onboard_correction(tables, self.aircraft, self.psi_u, self.var)
        a = self.after.copy()
        a["wind_speed_kt"], a["wind_dir_deg"] = rescored_wind(
            a["wind_speed_kt"].to_numpy(), a["wind_dir_deg"].to_numpy(), a["tas_kt"].to_numpy(), self.psi_c, psi_n
        )
        out = {}
        for period, obs in (("before", self.before), ("after", a)):
            for g in ("poor", "control"):
                out[(g, period)] = group_rms(obs[obs["group"] == g])["rms_kt"]
        return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+")
    ap.add_argument("--splits", type=int, default=4, help="random half splits of each aircraft's fit days (or flights)")
    ap.add_argument(
        "--by",
        choices=("day", "flight"),
        default="day",
        help="the unit a half takes whole (default day: the model error is correlated within a day)",
    )
    ap.add_argument("--seed", type=int, default=7)
    a = ap.parse_args()
    rng = np.random.default_rng(a.seed)
    res = []
    for run in map(Path, a.runs):
        for p in (run / "data" / f"{STUDY}.observations.parquet", run / "learned"):
            if not p.exists():
                sys.exit(f"{run}: no {p.relative_to(run)} (a finished {STUDY} run?)")
        r = Rescorer(run)
        stored = r.cells(r.stored)
        try:
            full = r.cells(r.fit())
        except Refused as e:
            print(f"run.{run.name}.skipped: a poor aircraft's fit is refused ({e})")
            continue
        if not math.isclose(stored[("poor", "after")], full[("poor", "after")], rel_tol=1e-6):
            sys.exit(
                f"{run}: the refitted tables do not reproduce the stored poor after cell "
                f"({full[('poor', 'after')]:.4f} vs {stored[('poor', 'after')]:.4f} kn)"
            )
        unit_col = "date" if a.by == "day" else "flight"
        half_sq = []
        try:
            for in_first in half_splits(
                r.fit_obs["aircraft"].astype(str).to_numpy(), r.fit_obs[unit_col].astype(str).to_numpy(), rng, a.splits
            ):
                for part in (in_first, ~in_first):
                    half_sq.append(r.cells(r.fit(part))[("poor", "after")] ** 2)
        except Refused as e:
            print(f"run.{run.name}.skipped: half the fit {a.by}s is too little for the method ({e})")
            continue
        after, half = full[("poor", "after")], math.sqrt(float(np.mean(half_sq)))
        inf = math.sqrt(max(2 * after**2 - half**2, 0.0))
        change = full[("control", "after")] - full[("control", "before")]
        res.append(
            {
                "after": after,
                "after_half": half,
                "after_inf": inf,
                "adjusted": after - change,
                "adjusted_half": half - change,
                "adjusted_inf": inf - change,
            }
        )
        print(
            f"run.{run.name}.poor_after_kt: {stored[('poor', 'after')]:.3f} {after:.3f} {half:.3f} {inf:.3f}",
            flush=True,
        )
    if not res:
        sys.exit("fit_noise: no run could be split")
    t = pd.DataFrame(res)
    n = len(t)
    for c in t.columns:
        se = t[c].std() / math.sqrt(n) if n > 1 else math.nan
        print(f"mean.{c}_kt: {t[c].mean():.3f} {se:.3f}")
    d = t["adjusted_inf"] - t["adjusted"]
    print(f"paired.after_adjusted_kt: {d.mean():.3f} {d.std() / math.sqrt(n) if n > 1 else math.nan:.3f}")


if __name__ == "__main__":
    main()
