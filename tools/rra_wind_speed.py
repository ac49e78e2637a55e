"""Wind-speed climatology cells from a Range Reference Atmosphere (RRA) site: the speed's
mean, standard deviation, median and 90th percentile at given pressure levels over a
campaign period, for the `references:` of campaigns/wind_climatology.yaml.

The RRA tables (U.S. Air Force 14th Weather Squadron, formerly the Air Force Combat
Climatology Center; the database NASA MSFC's Earth-GRAM reads, GRAM's `RRAdata` folder)
give per site, month and 0.25-0.5 km of height: the mean and standard deviation of the
wind's east (U) and north (V) components, their correlation R(U,V), the mean, standard
deviation and skewness of the speed, and the number of soundings (table I, file T1<site>);
and the mean pressure (table II, file T2<site>). The data are not in this repository:
give the folder holding them.

Method:
* a pressure level's height in a month is the height where the month's mean pressure
  equals it (log-linear between the table's heights); the wind statistics are
  interpolated linearly in height there;
* the month's speed distribution is the Pearson type III distribution (a shifted gamma)
  with the table's mean, standard deviation and skewness of the speed: the three moments
  the soundings give, matched exactly; a period's distribution is the mixture of its
  months, each weighted by the period's days in it, and its median and 90th percentile
  are the mixture's (its CDF inverted numerically);
* the check: the same statistics from (u, v) bivariate normal with the table's component
  means, standard deviations and correlation (a Rice-like speed; drawn, fixed seed). It
  matches the table's mean speed within ~5 % but not its spread (10-15 % low at 300 hPa:
  the soundings' speeds are more skewed, ~0.9 against ~0.5), so the cells come from the
  speed's own moments, and the Gaussian model's figures are printed beside them. (A
  Pearson III with a large skewness may put a little probability below 0 kt at the lowest
  level; its median and 90th percentile are not affected.)

    python tools/rra_wind_speed.py RRA_DIR SITE PERIOD=YYYY-MM-DD:YYYY-MM-DD ... \
        [--levels 843,506,301] [--region NAME]

Prints the cells as YAML lines (speeds in kt) and the check as `check:` lines.
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
import sys
from pathlib import Path

import numpy as np

KT = 0.514444  # m/s per knot
MONTHS = [dt.date(2001, m, 1).strftime("%B").lower() for m in range(1, 13)]
DRAWS = 400_000
# table I columns after Z: mean U, SD U, R(U,V), mean V, SD V, mean WS, SD WS, skew WS, NOBS
COLUMNS = ("mean_u", "sd_u", "r_uv", "mean_v", "sd_v", "mean_ws", "sd_ws", "skew_ws", "nobs")


def read_tables(path: Path) -> dict[str, np.ndarray]:
    """{month name: rows (height km first, then the table's columns)} of an RRA table file."""
    out: dict[str, list[list[float]]] = {}
    month = None
    for line in path.read_text(errors="replace").splitlines():
        s = line.strip()
        if s.lower() in MONTHS or s.lower() == "annual":
            month = s.lower()
            out[month] = []
            continue
        if month is None:
            continue
        try:
            vals = [float(x) for x in s.split()]
        except ValueError:
            continue
        if len(vals) >= 10:
            out[month].append(vals[:10])
    if not out:
        raise ValueError(f"{path}: no monthly RRA tables found")
    return {m: np.asarray(rows) for m, rows in out.items()}


def height_of_pressure(t2: np.ndarray, p_hpa: float) -> float:
    """Height (km) where the month's mean pressure (table II column 2) is p_hpa."""
    z, p = t2[:, 0], t2[:, 1]
    ok = p > 0
    z, p = z[ok], p[ok]
    for i in range(len(p) - 1):
        if p[i] >= p_hpa >= p[i + 1]:
            w = math.log(p[i] / p_hpa) / math.log(p[i] / p[i + 1])
            return float(z[i] + w * (z[i + 1] - z[i]))
    raise ValueError(f"{p_hpa} hPa is outside the table's pressures ({p.min():.0f}-{p.max():.0f} hPa)")


def wind_at(t1: np.ndarray, z_km: float) -> dict[str, float]:
    """Table I interpolated linearly in height (rows with more than 10 soundings)."""
    rows = t1[t1[:, 9] > 10]
    return {c: float(np.interp(z_km, rows[:, 0], rows[:, i + 1])) for i, c in enumerate(COLUMNS)}


def speed_draws(w: dict[str, float], rng: np.random.Generator, n: int = DRAWS) -> np.ndarray:
    """Speeds of n draws of (u, v), bivariate normal with the month's moments."""
    cov = [
        [w["sd_u"] ** 2, w["r_uv"] * w["sd_u"] * w["sd_v"]],
        [w["r_uv"] * w["sd_u"] * w["sd_v"], w["sd_v"] ** 2],
    ]
    uv = rng.multivariate_normal([w["mean_u"], w["mean_v"]], cov, size=n)
    return np.hypot(uv[:, 0], uv[:, 1])


def month_days(start: dt.date, end: dt.date) -> dict[int, int]:
    """{month number: days of [start, end] in it}."""
    out: dict[int, int] = {}
    d = start
    while d <= end:
        out[d.month] = out.get(d.month, 0) + 1
        d += dt.timedelta(days=1)
    return out


def pearson3_mixture(moments: list[tuple[float, float, float]], weights: list[float]):
    """(mean, sd, p50, p90) of the weighted mixture of Pearson type III distributions with
    the given (mean, sd, skewness)."""
    from scipy import optimize, stats

    w = np.asarray(weights, float) / np.sum(weights)
    dists = [stats.pearson3(g, loc=m, scale=s) for m, s, g in moments]
    mean = float(sum(wi * m for wi, (m, _, _) in zip(w, moments, strict=True)))
    second = float(sum(wi * (s * s + m * m) for wi, (m, s, _) in zip(w, moments, strict=True)))

    def cdf(x: float) -> float:
        return float(sum(wi * d.cdf(x) for wi, d in zip(w, dists, strict=True)))

    hi = max(m + 10 * s for m, s, _ in moments)
    q = [optimize.brentq(lambda x, p=p: cdf(x) - p, 0.0, hi) for p in (0.5, 0.9)]
    return mean, math.sqrt(second - mean * mean), q[0], q[1]


def period_cell(t1s, t2s, p_hpa: float, start: dt.date, end: dt.date, seed: int = 2010, check: bool = True):
    """(cell statistics in kt from the speed's moments, the same from the Gaussian (u, v)
    model, per-month rows) of one level and period; `check=False` skips the Gaussian model
    (its figures None and NaN)."""
    rng = np.random.default_rng(seed)
    days = month_days(start, end)
    moments, weights, draws, months = [], [], [], []
    for m, n in sorted(days.items()):
        name = MONTHS[m - 1]
        z = height_of_pressure(t2s[name], p_hpa)
        w = wind_at(t1s[name], z)
        moments.append((w["mean_ws"], w["sd_ws"], w["skew_ws"]))
        weights.append(n)
        if not check:
            months.append((name, z, w, math.nan, math.nan))
            continue
        s = speed_draws(w, rng)
        months.append((name, z, w, float(s.mean()), float(s.std())))
        draws.append(rng.choice(s, size=int(round(DRAWS * n / sum(days.values()))), replace=False))
    mean, sd, p50, p90 = pearson3_mixture(moments, weights)
    cell = {"mean_speed_kt": mean / KT, "sd_speed_kt": sd / KT, "p50_speed_kt": p50 / KT, "p90_speed_kt": p90 / KT}
    if not check:
        return cell, None, months
    g = np.concatenate(draws)
    gauss = {
        "mean": g.mean() / KT,
        "sd": g.std() / KT,
        "p50": np.percentile(g, 50) / KT,
        "p90": np.percentile(g, 90) / KT,
    }
    return cell, gauss, months


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rra_dir", type=Path, help="folder holding T1<site>.txt and T2<site>.txt")
    ap.add_argument("site", help="RRA site and edition, e.g. kod13 (Kodiak, 2013 edition)")
    ap.add_argument("periods", nargs="+", help="NAME=YYYY-MM-DD:YYYY-MM-DD, the campaign's periods")
    ap.add_argument("--levels", default="843,506,301", help="hPa (flight levels 50, 180, 300)")
    ap.add_argument("--flight-levels", default="50,180,300", help="the flight level of each pressure")
    ap.add_argument("--region", default="REGION", help="the study's region name the cells are for")
    a = ap.parse_args()
    try:
        t1s = read_tables(a.rra_dir / f"T1{a.site}.txt")
        t2s = read_tables(a.rra_dir / f"T2{a.site}.txt")
        levels = [float(x) for x in a.levels.split(",")]
        fls = [int(x) for x in a.flight_levels.split(",")]
        if len(levels) != len(fls):
            raise ValueError("--levels and --flight-levels: expected as many of each")
        periods = []
        for spec in a.periods:
            name, _, span = spec.partition("=")
            s, _, e = span.partition(":")
            periods.append((name, dt.date.fromisoformat(s), dt.date.fromisoformat(e)))
    except (OSError, ValueError) as e:
        sys.exit(f"rra_wind_speed: {e}")
    for name, start, end in periods:
        for p, fl in zip(levels, fls, strict=True):
            try:
                if end < start:
                    raise ValueError(f"{name}: the period ends before it starts")
                cell, gauss, months = period_cell(t1s, t2s, p, start, end)
            except (KeyError, ValueError) as e:
                sys.exit(f"rra_wind_speed: {a.site} {name} {p:g} hPa: {e}")
            print(
                f"      - {{region: {a.region}, period: {name}, flight_level: {fl}, "
                + ", ".join(f"{k}: {v:.1f}" for k, v in cell.items())
                + "}"
            )
            print(
                f"check: {a.site} {name} {p:.0f} hPa Gaussian (u, v) model: mean {gauss['mean']:.1f} "
                f"sd {gauss['sd']:.1f} p50 {gauss['p50']:.1f} p90 {gauss['p90']:.1f} kt"
            )
            for m, z, w, mean, sd in months:
                print(
                    f"check: {a.site} {m[:3]} {p:.0f} hPa z {z:.2f} km nobs {w['nobs']:.0f}: table mean/sd/skew "
                    f"{w['mean_ws']:.2f}/{w['sd_ws']:.2f}/{w['skew_ws']:.2f} m/s, Gaussian model mean/sd "
                    f"{mean:.2f}/{sd:.2f} ({mean / w['mean_ws'] - 1:+.1%}/{sd / w['sd_ws'] - 1:+.1%})"
                )


if __name__ == "__main__":
    main()
