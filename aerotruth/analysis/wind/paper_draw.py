"""One draw of a wind-paper table at the paper's own scale, and a published cell judged as
where it falls among such draws.

The wind paper's Tables I-IV give, for a group of aircraft (poor: the worst by their
before-period RMS, given tables; control: the rest or the best) and a period (before,
after), the RMS vector difference between reported and model winds and its longitudinal and
transverse components, then derived cells: the control's change (after - before), the poor
group's after cell adjusted for it (after - change) and the improvement (before - adjusted
after). A published cell is **one draw**: a few aircraft over one period of weather. A
simulation predicts it when the paper's value falls inside the *predictive* distribution of
that draw at the paper's fleet size and period length, not when it is near the simulated
mean within the mean's standard error.

Sums. A run's scored reports are kept as sums per aircraft, day and period
(`aircraft_day_sums`): rows n, the sum of squared vector errors, rows with a track axis and
the sums of squared longitudinal and transverse errors (kt^2). Every cell is a ratio of such
sums (`cells_from_sums`), as `aerotruth.analysis.wind.metrics.wind_error_summary` computes it.

Variance components (`PaperDraws`). Per period and component the mean square of aircraft a
on day d, m = ss / n, is split as

    m = mu + alpha_a + delta_d + eps_ad

within each run by a two-way additive fit weighted by n (backfitting): alpha the aircraft's
lasting errors (its flux valve, air data), delta the day's weather and model error shared by
the whole fleet, eps the rest. The after period and its untreated twin (the same reports
without the table) are one epoch: they share days, and an aircraft's effects in the before
and after epochs are kept together, so a resampled aircraft carries its own before-after
pairing. Pooled over the runs (a day's effect is its run's mean plus its own, relative to
the pooled mean), the estimates are over-dispersed by the residual they average over (an
aircraft's alpha over its D days carries var(eps)/D, a day's delta over its k aircraft
var(eps)/k) and the residuals under-dispersed by the fit's degrees of freedom; each is
rescaled to its component's method-of-moments variance before resampling (the random
effects bootstrap: Davison & Hinkley, Bootstrap Methods and their Application, 1997,
sec. 3.8; Carpenter, Goldstein & Rasbash, J. R. Stat. Soc. C 52, 431, 2003).

A draw at the paper's scale: k_poor aircraft from the runs' poor aircraft and k_control from
their control aircraft (with replacement: the reduced sizes keep the paper's selection
fraction, so a simulated poor aircraft stands for a paper's poor aircraft), D_before and
D_after day effects drawn once for the whole fleet (the groups fly the same days: the shared
weather is what the adjustment by the control's change removes), and for each aircraft the
mean of D fresh residuals of its group; the cells and the derived cells of that draw follow.
Each aircraft weighs by its mean rows a day. Assumption: an aircraft-day at the paper's scale
is one at the runs' (the reduced sizes fly two legs a day; a full day's schedule has more
reports and a smaller eps), so sd_draw is if anything too wide.

Judgement (`judge`): per cell the draws' mean and sd (sd_draw), the standard error of that
mean from a jackknife over the runs (se), z = (paper - mean) / sqrt(sd_draw^2 + se^2), the PIT
(share of draws below the paper's value) and, over the judged cells, a verdict at a
family-wise level (Bonferroni: |z| <= z_(1 - level / 2m)) and the joint Mahalanobis distance
with the draws' and the jackknife's covariance against chi^2(m).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats

COMPONENTS = (("rms_kt", "total"), ("longitudinal_rms_kt", "longitudinal"), ("transverse_rms_kt", "transverse"))
# (numerator, denominator) sums of each component's mean square
SUMS = {
    "total": ("ss_kt2", "n"),
    "longitudinal": ("ss_longitudinal_kt2", "n_components"),
    "transverse": ("ss_transverse_kt2", "n_components"),
}
SUM_COLUMNS = ("n", "ss_kt2", "n_components", "ss_longitudinal_kt2", "ss_transverse_kt2")
GROUPS = ("poor", "control")
# the epochs: periods flown on the same days (the after period and its untreated twin)
EPOCHS = {"before": ("before",), "after": ("after", "after_untreated")}
DAY_S = 86400.0
SEP = "\x1f"  # joins a run name (a folder path) and an aircraft or a day into one key


def aircraft_day_sums(errors: pd.DataFrame, period: str) -> pd.DataFrame:
    """Sums of a `wind_errors` table per aircraft and UTC day (columns aircraft, period, day,
    and SUM_COLUMNS): rows n and the sum of squared vector errors over every row, rows with an
    axis and the sums of squared longitudinal and transverse errors over those."""
    if errors.empty:
        return pd.DataFrame(columns=["aircraft", "period", "day", *SUM_COLUMNS])
    df = pd.DataFrame(
        {
            "aircraft": errors["aircraft"].astype(str).to_numpy(),
            "day": np.floor(errors["time_s"].to_numpy(dtype=float) / DAY_S).astype(np.int64),
            "e2": errors["error_kt"].to_numpy(dtype=float) ** 2,
            "l2": errors["longitudinal_kt"].to_numpy(dtype=float) ** 2,
            "t2": errors["transverse_kt"].to_numpy(dtype=float) ** 2,
        }
    )
    g = df.groupby(["aircraft", "day"], sort=True)
    out = g.agg(
        n=("e2", "count"),
        ss_kt2=("e2", "sum"),
        n_components=("l2", "count"),
        ss_longitudinal_kt2=("l2", "sum"),
        ss_transverse_kt2=("t2", "sum"),
    ).reset_index()
    out.insert(1, "period", period)
    return out


def derive(cells: Mapping) -> dict:
    """The derived cells of `cells` ((group, period) -> a value, a component vector or an
    array of draws): the control's change, the poor group's after adjusted for it, the
    improvement (before - adjusted after) and, where the untreated twin is there, the
    table's own effect (after untreated - after)."""
    out = {}
    if ("control", "before") in cells and ("control", "after") in cells:
        change = cells[("control", "after")] - cells[("control", "before")]
        out[("control", "change")] = change
        if ("poor", "after") in cells:
            adj = cells[("poor", "after")] - change
            out[("poor", "after_adjusted")] = adj
            out[("poor", "improvement")] = cells[("poor", "before")] - adj
    if ("poor", "after_untreated") in cells and ("poor", "after") in cells:
        out[("poor", "table_effect")] = cells[("poor", "after_untreated")] - cells[("poor", "after")]
    return out


def derived_cells(cells: pd.DataFrame) -> pd.DataFrame:
    """`cells` (group, period and the COMPONENTS columns) with the derived rows added
    (`derive`). Every component is derived from the same component (the paper's
    subtraction: its components need not add up)."""
    if cells.empty:
        return cells
    idx = cells.set_index(["group", "period"])
    cols = [c for c, _ in COMPONENTS]
    extra = [
        {"group": g, "period": p, **v.to_dict()}
        for (g, p), v in derive({key: idx.loc[key, cols] for key in idx.index}).items()
    ]
    return pd.concat([cells, pd.DataFrame(extra)], ignore_index=True)


def cells_from_sums(sums: pd.DataFrame) -> pd.DataFrame:
    """The groups' cells (group, period, n, COMPONENTS) of an aircraft-day sums table with a
    group column (poor, control; others ignored), then the derived cells."""
    rows = []
    for (g, p), part in sums[sums["group"].isin(GROUPS)].groupby(["group", "period"], sort=False):
        tot = part[list(SUM_COLUMNS)].sum()
        rows.append(
            {
                "group": g,
                "period": p,
                "n": int(tot["n"]),
                **{col: math.sqrt(tot[SUMS[lab][0]] / tot[SUMS[lab][1]]) for col, lab in COMPONENTS},
            }
        )
    return derived_cells(pd.DataFrame(rows))


@dataclass(frozen=True)
class PaperScale:
    """The paper's own draw: aircraft in each group and days in each period."""

    poor: int
    control: int
    days_before: int
    days_after: int

    def __post_init__(self):
        for name in ("poor", "control", "days_before", "days_after"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name}: expected a whole number >= 1, got {getattr(self, name)}")


def _backfit(m: np.ndarray, w: np.ndarray, ia: np.ndarray, idd: np.ndarray, na: int, nd: int, sweeps: int = 30):
    """Weighted two-way additive fit m ~ mu + a[ia] + d[idd] (columns independently; rows
    with w = 0 are absent). Returns mu (per column), a (na x cols), d (nd x cols)."""
    cols = m.shape[1]
    wsum = w.sum(axis=0)
    mu = (w * m).sum(axis=0) / wsum
    a, d = np.zeros((na, cols)), np.zeros((nd, cols))
    wa = np.zeros((na, cols))
    wd = np.zeros((nd, cols))
    np.add.at(wa, ia, w)
    np.add.at(wd, idd, w)
    for _ in range(sweeps):
        num = np.zeros((na, cols))
        np.add.at(num, ia, w * (m - mu - d[idd]))
        a = np.divide(num, wa, out=np.zeros_like(num), where=wa > 0)
        a -= (wa * a).sum(axis=0) / wsum
        num = np.zeros((nd, cols))
        np.add.at(num, idd, w * (m - mu - a[ia]))
        d = np.divide(num, wd, out=np.zeros_like(num), where=wd > 0)
        d -= (wd * d).sum(axis=0) / wsum
    return mu, a, d


def _psd_sqrt(c: np.ndarray, inverse: bool = False) -> np.ndarray:
    """Symmetric square root (or its pseudo-inverse) of a symmetric matrix, negative
    eigenvalues clipped to zero."""
    vals, vecs = np.linalg.eigh((c + c.T) / 2.0)
    vals = np.clip(vals, 0.0, None)
    top = vals.max(initial=0.0)
    if inverse:
        root = np.divide(1.0, np.sqrt(vals), out=np.zeros_like(vals), where=vals > 1e-12 * max(top, 1e-300))
    else:
        root = np.sqrt(vals)
    return (vecs * root) @ vecs.T


def _pooled_within(x: np.ndarray, labels: np.ndarray) -> np.ndarray:
    """Covariance of the rows of x about their own label's mean, pooled over the labels
    (each label's n - 1 degrees of freedom): free of what the labels (runs) share."""
    cols = x.shape[1]
    ss, df = np.zeros((cols, cols)), 0
    for lab in np.unique(labels):
        part = x[labels == lab]
        if len(part) < 2:
            continue
        c = part - part.mean(axis=0)
        ss += c.T @ c
        df += len(part) - 1
    return ss / df if df else ss


def _match_covariance(x: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Rows of x moved to the covariance `target` (clipped to be positive semi-definite),
    their mean kept (Carpenter, Goldstein & Rasbash 2003: estimated effects carry the
    residual they average over; their spread and correlations are set to the components')."""
    if len(x) < 2:
        return x.copy()
    mean = x.mean(axis=0)
    c = np.cov(x, rowvar=False)
    return mean + (x - mean) @ (_psd_sqrt(c, inverse=True) @ _psd_sqrt(target))


def _epoch_fit(sums: pd.DataFrame, runs: list[str], periods: tuple[str, ...]):
    """Per run, the two-way fit of the epoch's aircraft-day mean squares (module docstring).
    Returns columns, alpha (DataFrame by (run, aircraft)), per-day weights, the day effects
    (centred in their run) with their runs, the residual rows (NaN where absent) with their
    aircraft keys, the pooled mean, and each aircraft's days and each day's aircraft."""
    cols = [f"{p}.{lab}" for p in periods for _, lab in COMPONENTS]
    part = sums[sums["period"].isin(periods)].copy()
    if part.empty:
        raise ValueError(f"sums: no rows of period {periods[0]}")
    part["key"] = part["run"].astype(str) + SEP + part["aircraft"].astype(str)
    part["dkey"] = part["run"].astype(str) + SEP + part["day"].astype(str)
    wide_m, wide_w = {}, {}
    for p in periods:
        q = part[part["period"] == p].set_index(["key", "dkey"])
        for _, lab in COMPONENTS:
            num, den = SUMS[lab]
            wide_m[f"{p}.{lab}"] = q[num] / q[den].where(q[den] > 0)
            wide_w[f"{p}.{lab}"] = q[den].astype(float)
    m = pd.DataFrame(wide_m).reindex(columns=cols)
    w = pd.DataFrame(wide_w).reindex(index=m.index, columns=cols).fillna(0.0)
    w = w.where(m.notna(), 0.0)
    m = m.fillna(0.0)
    keys = m.index.get_level_values(0).to_numpy()
    dkeys = m.index.get_level_values(1).to_numpy()
    run_of = np.array([k.split(SEP, 1)[0] for k in keys])
    alphas, resid, res_keys, deltas, mus, day_runs = [], [], [], [], [], []
    ids: list[str] = []
    days_of, ac_of = [], []
    for r in runs:
        sel = run_of == r
        if not sel.any():
            continue
        ka, ia = np.unique(keys[sel], return_inverse=True)
        kd, idd = np.unique(dkeys[sel], return_inverse=True)
        mm, ww = m.to_numpy()[sel], w.to_numpy()[sel]
        mu, a, d = _backfit(mm, ww, ia, idd, len(ka), len(kd))
        mus.append(mu)
        alphas.append(a)
        deltas.append(d)
        day_runs.extend([r] * len(kd))
        ids.extend(ka)
        resid.append(np.where(ww > 0, mm - mu - a[ia] - d[idd], np.nan))
        res_keys.extend(keys[sel])
        days_of.append(np.bincount(ia, minlength=len(ka)))
        ac_of.append(np.bincount(idd, minlength=len(kd)))
    mu_all = np.mean(mus, axis=0)
    alpha = pd.DataFrame(np.vstack(alphas), index=ids, columns=cols)
    per_day = w.groupby(level=0).mean().iloc[:, 0]
    n_days = pd.Series(np.concatenate(days_of).astype(float), index=ids)
    delta = (np.vstack(deltas), np.array(day_runs))
    return cols, alpha, per_day, delta, np.vstack(resid), np.array(res_keys), mu_all, n_days, np.concatenate(ac_of)


@dataclass
class _Epoch:
    columns: list[str]  # "<period>.<component>"
    alpha: dict[str, np.ndarray]  # group -> (aircraft x cols) effects, rows in PaperDraws.aircraft order
    weight: dict[str, np.ndarray]  # group -> mean rows a day per aircraft, same order
    delta: np.ndarray  # (days x cols) day effects with their run's offset, covariance matched
    eps: dict[str, np.ndarray]  # group -> (aircraft-days x cols) residuals, dof-corrected (0 where unused)
    mu: np.ndarray  # (cols,) pooled mean


class PaperDraws:
    """Variance components of aircraft-day sums from several runs (module docstring); `draw`
    makes tables at a PaperScale.

    `sums`: aircraft_day_sums rows with columns run, group (poor, control, other), period
    (before, after, after_untreated), aircraft, day and SUM_COLUMNS. Aircraft are told apart by
    (run, aircraft), days by (run, day); an aircraft enters the draws when it has reports in
    both epochs. An aircraft's effects in the two epochs are one vector: their covariance
    (before with after: the lasting errors) is matched jointly."""

    def __init__(self, sums: pd.DataFrame):
        need = {"run", "group", "period", "aircraft", "day", *SUM_COLUMNS}
        missing = sorted(need - set(sums.columns))
        if missing:
            raise ValueError(f"sums: missing columns {missing}")
        runs = sorted(sums["run"].astype(str).unique())
        self.runs = runs
        keyed = sums.assign(key=sums["run"].astype(str) + SEP + sums["aircraft"].astype(str))
        group_of = keyed.drop_duplicates("key").set_index("key")["group"]
        fits = {e: _epoch_fit(sums, runs, periods) for e, periods in EPOCHS.items()}
        self.aircraft: dict[str, list[str]] = {}
        for g in GROUPS:
            have = [set(f[1].index[group_of.reindex(f[1].index).to_numpy() == g]) for f in fits.values()]
            keys = sorted(set.intersection(*have))
            if not keys:
                raise ValueError(f"sums: no {g} aircraft with reports before and after")
            self.aircraft[g] = keys
        # residual covariances per group and epoch, corrected for the fit's degrees of freedom
        eps: dict[str, dict[str, np.ndarray]] = {}
        noise: dict[str, dict[str, np.ndarray]] = {}
        for e, (cols, _alpha, _w, _delta, res, res_keys, _mu, n_days, n_ac) in fits.items():
            dof = max(1e-9, (1.0 - (1.0 / n_days).mean()) * (1.0 - (1.0 / n_ac).mean()))
            eps[e], noise[e] = {}, {}
            groups = group_of.reindex(res_keys).to_numpy()
            for g in (*GROUPS, "all"):
                r = res if g == "all" else res[groups == g]
                used = np.isfinite(r).any(axis=0)
                r = r[np.isfinite(r[:, used]).all(axis=1)] if len(r) else r
                r = np.where(np.isfinite(r), r, 0.0)
                if len(r) < 2:
                    eps[e][g], noise[e][g] = np.zeros((1, len(cols))), np.zeros((len(cols), len(cols)))
                    continue
                r = (r - r.mean(axis=0)) / math.sqrt(dof)
                eps[e][g] = r
                noise[e][g] = np.cov(r, rowvar=False)
        self.epochs: dict[str, _Epoch] = {}
        alpha_joint = {}
        for g in GROUPS:
            blocks, noise_blocks = [], []
            for e, f in fits.items():
                cols, alpha, _w, _d, _r, _k, _m, n_days, _n = f
                blocks.append(alpha.loc[self.aircraft[g]].to_numpy())
                noise_blocks.append(noise[e][g] * (1.0 / n_days.loc[self.aircraft[g]]).mean())
            x = np.hstack(blocks)
            nz = np.zeros((x.shape[1], x.shape[1]))
            at = 0
            for nb in noise_blocks:
                nz[at : at + len(nb), at : at + len(nb)] = nb
                at += len(nb)
            # the aircraft's spread within its run (a run's fleet mean is shared with its days)
            run_of = np.array([k.split(SEP, 1)[0] for k in self.aircraft[g]])
            alpha_joint[g] = _match_covariance(x, _pooled_within(x, run_of) - nz)
        at = 0
        for e, f in fits.items():
            cols, _alpha, per_day, delta, _r, _k, mu, _nd, n_ac = f
            width = len(cols)
            self.epochs[e] = _Epoch(
                cols,
                {g: alpha_joint[g][:, at : at + width] for g in GROUPS},
                {g: per_day.reindex(self.aircraft[g]).fillna(0.0).to_numpy() for g in GROUPS},
                _match_covariance(delta[0], _pooled_within(*delta) - noise[e]["all"] * (1.0 / n_ac).mean()),
                {g: eps[e][g] for g in GROUPS},
                mu,
            )
            at += width

    def draw(self, scale: PaperScale, n_draws: int, rng: np.random.Generator) -> pd.DataFrame:
        """`n_draws` tables at `scale`: one row a draw, one column a cell
        ("<group>.<period>.<component>", the derived cells included)."""
        sizes = {"poor": scale.poor, "control": scale.control}
        days = {"before": scale.days_before, "after": scale.days_after}
        picks = {g: rng.integers(0, len(self.aircraft[g]), size=(n_draws, sizes[g])) for g in GROUPS}
        cells: dict[tuple[str, str, str], np.ndarray] = {}
        for e, ep in self.epochs.items():
            dd = ep.delta[rng.integers(0, len(ep.delta), size=(n_draws, days[e]))].mean(axis=1)
            for g in GROUPS:
                k = sizes[g]
                res = ep.eps[g][rng.integers(0, len(ep.eps[g]), size=(n_draws, k, days[e]))].mean(axis=2)
                m = np.maximum(ep.mu + ep.alpha[g][picks[g]] + dd[:, None, :] + res, 1e-6)
                wt = ep.weight[g][picks[g]][:, :, None] + 1e-12
                ms = (wt * m).sum(axis=1) / wt.sum(axis=1)  # draws x cols
                for j, col in enumerate(ep.columns):
                    period, lab = col.split(".")
                    if period == "after_untreated" and g != "poor":
                        continue
                    cells[(g, period, lab)] = np.sqrt(ms[:, j])
        out = {f"{g}.{p}.{lab}": v for (g, p, lab), v in cells.items()}
        for _, lab in COMPONENTS:
            mine = {(g, p): v for (g, p, c), v in cells.items() if c == lab}
            out.update({f"{g}.{p}.{lab}": v for (g, p), v in derive(mine).items()})
        return pd.DataFrame(out)


def predictive(
    sums: pd.DataFrame, scale: PaperScale, n_draws: int, rng: np.random.Generator
) -> tuple[pd.DataFrame, list[pd.Series]]:
    """Draws at `scale` from every run's sums, and the draws' means with each run left out in
    turn (for the jackknife standard error of the mean; empty with one run)."""
    draws = PaperDraws(sums).draw(scale, n_draws, rng)
    runs = sorted(sums["run"].astype(str).unique())
    loo = []
    if len(runs) > 1:
        for r in runs:
            loo.append(PaperDraws(sums[sums["run"].astype(str) != r]).draw(scale, n_draws, rng).mean())
    return draws, loo


def judge(
    draws: pd.DataFrame,
    loo_means: Sequence[pd.Series],
    paper: Mapping[str, float],
    judged: Sequence[str],
    level: float = 0.05,
) -> tuple[pd.DataFrame, dict[str, float]]:
    """Every cell of `paper` found in `draws` judged as one draw (module docstring). Returns
    (table: cell, paper, mean, sd_draw, se, z, pit, judged, verdict) and the joint check over
    the judged cells (mahalanobis_d2, dof, p, z_critical)."""
    n = len(loo_means)
    mean = draws.mean()
    sd = draws.std(ddof=1)
    if n > 1:
        loo = pd.DataFrame(list(loo_means))
        se = np.sqrt((n - 1) / n * ((loo - loo.mean()) ** 2).sum())
    else:
        loo = None
        se = pd.Series(0.0, index=draws.columns)
    judged = [c for c in judged if c in draws.columns and c in paper]
    m = max(len(judged), 1)
    z_crit = float(stats.norm.ppf(1.0 - level / (2.0 * m)))
    rows = []
    for c, p in paper.items():
        if c not in draws.columns or p is None or not math.isfinite(p):
            continue
        x = draws[c].to_numpy()
        z = (p - mean[c]) / math.sqrt(sd[c] ** 2 + se[c] ** 2) if sd[c] > 0 else math.nan
        pit = float(((x < p).sum() + 0.5 * (x == p).sum()) / len(x))
        is_j = c in judged
        rows.append(
            {
                "cell": c,
                "paper": float(p),
                "mean": float(mean[c]),
                "sd_draw": float(sd[c]),
                "se": float(se[c]),
                "z": float(z),
                "pit": pit,
                "judged": is_j,
                "verdict": ("pass" if abs(z) <= z_crit else "fail") if is_j else "",
            }
        )
    table = pd.DataFrame(rows)
    joint = {"dof": float(len(judged)), "z_critical": z_crit, "mahalanobis_d2": math.nan, "p": math.nan}
    if judged:
        r = np.array([paper[c] - mean[c] for c in judged])
        cov = np.atleast_2d(np.cov(draws[judged].to_numpy(), rowvar=False))
        if loo is not None:
            dl = (loo[judged] - loo[judged].mean()).to_numpy()
            cov = cov + (n - 1) / n * dl.T @ dl
        d2 = float(r @ np.linalg.solve(cov, r))
        joint.update({"mahalanobis_d2": d2, "p": float(stats.chi2.sf(d2, len(judged)))})
    return table, joint
