"""The offset drift's per-aircraft test (aerotruth.analysis.diagnose.wind_model.drift_scan:
the slope of an aircraft's weather-block mean offsets, blocks permuted) against the
normal-theory t test of the same slope, on synthetic block-mean series shaped like the
independent generator's (validation/diagnose_confusion_plan.md): per-aircraft power at the
library's level after Bonferroni over twelve aircraft, and the t test's null rate there.

    python validation/drift_test_power.py [--series 300] [--perms 20000]

Series: `--blocks` weather blocks at uniform times over `--days` days, each block's mean
offset with noise of sd `--sd` deg scaled by sqrt(1.5 / k), k of 1-3 flights a block (the
block means of the diagnosis have residual sd 0.41-0.52 deg), plus a drift of each slope.
Prints `label: value` lines.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy import stats

LEVEL = 0.01 / 8 / 12  # the library's 1 % over eight candidates, Bonferroni over 12 aircraft


def block_noise_sd(rng: np.random.Generator, shape, sd: float) -> np.ndarray:
    return sd * np.sqrt(1.5 / rng.choice([1, 1, 2, 2, 3], shape))


def power(
    rng: np.random.Generator, slope: float, n: int, days: float, sd: float, series: int, perms: int
) -> tuple[float, float]:
    """Shares of series with p < LEVEL: (block permutation, t test)."""
    hit_perm = hit_t = 0
    for _ in range(series):
        t = np.sort(rng.uniform(0.0, days, n))
        tc = t - t.mean()
        x = slope * t + rng.normal(0.0, block_noise_sd(rng, n, sd))
        xc = x - x.mean()
        observed = abs(tc @ xc)
        perm = np.argsort(rng.random((perms, n)), axis=1)
        p_perm = (1 + int((np.abs(xc[perm] @ tc) >= observed - 1e-12).sum())) / (perms + 1)
        hit_perm += p_perm < LEVEL
        hit_t += stats.linregress(t, x).pvalue < LEVEL
    return hit_perm / series, hit_t / series


def t_null_rate(rng: np.random.Generator, n: int, days: float, sd: float, series: int) -> float:
    """The t test's rejection rate at LEVEL under no drift, as a multiple of LEVEL."""
    t = np.sort(rng.uniform(0.0, days, (series, n)), axis=1)
    x = rng.normal(0.0, block_noise_sd(rng, (series, n), sd))
    tc = t - t.mean(axis=1, keepdims=True)
    xc = x - x.mean(axis=1, keepdims=True)
    b = (tc * xc).sum(axis=1) / (tc**2).sum(axis=1)
    res = xc - b[:, None] * tc
    se = np.sqrt((res**2).sum(axis=1) / (n - 2) / (tc**2).sum(axis=1))
    p = 2.0 * stats.t.sf(np.abs(b / se), n - 2)
    return float((p < LEVEL).mean() / LEVEL)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--series", type=int, default=300, help="series per slope (default 300)")
    ap.add_argument("--perms", type=int, default=20000, help="permutations per series (default 20000)")
    ap.add_argument("--null-series", type=int, default=400000, help="series for the t test's null rate")
    ap.add_argument("--blocks", type=int, default=26)
    ap.add_argument("--days", type=float, default=7.4)
    ap.add_argument("--sd", type=float, default=0.45, help="block mean noise, deg (default 0.45)")
    ap.add_argument("--seed", type=int, default=1)
    a = ap.parse_args()
    for name, v in (("series", a.series), ("perms", a.perms), ("null-series", a.null_series), ("blocks", a.blocks)):
        if v < 6:
            raise SystemExit(f"--{name}: expected a whole number >= 6, got {v}")
    rng = np.random.default_rng(a.seed)
    print(f"level_per_aircraft: {LEVEL:.3g}")
    for slope in (0.15, 0.2):
        pp, pt = power(rng, slope, a.blocks, a.days, a.sd, a.series, a.perms)
        print(f"power.{slope:g}_deg_per_day: permutation {pp:.3f} t_test {pt:.3f}")
    print(f"t_test_null_rate_over_level: {t_null_rate(rng, a.blocks, a.days, a.sd, a.null_series):.2f}")


if __name__ == "__main__":
    main()
