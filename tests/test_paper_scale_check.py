"""validation/paper_scale_check.py: the full run's days resampled, against the delta
method's standard deviation of an RMS over days of known mean squares."""

import sys
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "validation"))
import paper_scale_check  # noqa: E402


def _sums(rng, days=60, rows=100):
    """Aircraft-day sums of a poor and a control aircraft over `days` before and after days
    whose mean squares (kt^2) vary from day to day: the day's weather shared by both."""
    out = []
    for period in ("before", "after"):
        shared = rng.gamma(8.0, 10.0, size=days)  # mean 80 kt^2, sd 28
        for group, scale in (("poor", 2.0), ("control", 1.0)):
            m = scale * shared
            out.append(
                pd.DataFrame(
                    {
                        "aircraft": f"{group}-1",
                        "group": group,
                        "period": period,
                        "day": np.arange(days) + (0 if period == "before" else 1000),
                        "n": rows,
                        "ss_kt2": rows * m,
                        "n_components": rows,
                        "ss_longitudinal_kt2": rows * m / 2,
                        "ss_transverse_kt2": rows * m / 2,
                    }
                )
            )
    return pd.concat(out, ignore_index=True)


def test_day_bootstrap_matches_the_delta_method():
    rng = np.random.default_rng(5)
    sums = _sums(rng)
    boot = paper_scale_check.day_bootstrap(sums, 3000, np.random.default_rng(6))
    for period in ("before", "after"):
        s = sums[(sums["group"] == "poor") & (sums["period"] == period)]
        m = (s["ss_kt2"] / s["n"]).to_numpy()
        # RMS = sqrt(mean of m over days, equal rows): sd ~ sd(m) / sqrt(D) / (2 sqrt(mean m))
        expected = m.std(ddof=0) / np.sqrt(len(m)) / (2.0 * np.sqrt(m.mean()))
        got = boot[f"poor.{period}.total"].std(ddof=1)
        assert abs(got / expected - 1.0) < 0.08, (period, got, expected)
    # the control's change shares the days of both periods: a day's weather moves both of
    # its cells together, the change only by its difference
    change = boot["control.change.total"].std(ddof=1)
    assert change > 0


def test_day_bootstrap_without_day_to_day_spread_is_exact():
    rng = np.random.default_rng(7)
    sums = _sums(rng)
    sums["ss_kt2"] = sums["n"] * 64.0
    boot = paper_scale_check.day_bootstrap(sums, 50, np.random.default_rng(8))
    assert np.allclose(boot["poor.before.total"], 8.0)
    assert np.allclose(boot["control.after.total"], 8.0)
