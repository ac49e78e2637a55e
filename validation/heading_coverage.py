"""Coverage of the heading-deviation estimator's 95 % intervals on synthetic reports with a
known deviation (tests/obs_generator.py: one SAAB-like aircraft, hub-and-spoke flights,
two reference models with 4-kt errors correlated over 30 min along a flight).

For each repetition: draw a data set, fit A, B, C (terms fixed to the sinusoid), and
check whether the truth lies in (a) the flight-resampling bootstrap-t interval
(`HeadingDeviationFit.bootstrap`) and (b) the Wald interval coef +- 1.96 se (flight-
clustered, CR3). Prints `coverage_A: 0.95` style lines (target 0.93-0.97 over >= 1000
repetitions; the binomial sd at 1000 is 0.007) and `wald_coverage_A: ...`; then the
bootstrap-t intervals of the 8 table entries (lut_k = -d(z_k), the true table the
deviation's values at the nodes): `coverage_lut_000: ...` and their range
`coverage_lut_min/max`.

    python validation/heading_coverage.py [--reps 1000] [--n-boot 200] [--flights 40]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import obs_generator as gen  # noqa: E402

from aerotruth.analysis.wind.heading_correction import LUT_COLUMNS, LUT_HEADINGS_DEG, HeadingDeviationFit  # noqa: E402

TRUTH = gen.AircraftTruth("N418XJ", A=1.2, B=2.0, C=-1.0, cruise_tas_kt=280.0)


def coverage(reps: int, n_boot: int, flights: int, seed: int = 7) -> dict[str, float]:
    """Shares of repetitions whose intervals hold the true A, B, C (and the true table)."""
    hit_b = np.zeros(3)
    hit_w = np.zeros(3)
    hit_lut = np.zeros(8)
    truth = np.array([TRUTH.A, TRUTH.B, TRUTH.C])
    truth_lut = -TRUTH.deviation(LUT_HEADINGS_DEG)
    for r in range(reps):
        rng = np.random.default_rng([seed, r])
        obs = gen.generate([TRUTH], rng, flights=flights)
        fit = HeadingDeviationFit(terms="sinusoid", heading="magnetic").fit(obs)
        ci = fit.bootstrap(n_boot=n_boot, rng=rng)
        abc, lut = ci.loc[list("ABC")], ci.loc[list(LUT_COLUMNS)]
        hit_b += (abc["lo"].to_numpy() <= truth) & (truth <= abc["hi"].to_numpy())
        hit_lut += (lut["lo"].to_numpy() <= truth_lut) & (truth_lut <= lut["hi"].to_numpy())
        est = np.array([fit.coef_[t] for t in "ABC"])
        se = np.array([fit.se_[t] for t in "ABC"])
        hit_w += np.abs(est - truth) <= 1.96 * se
    out = {f"coverage_{t}": float(hit_b[i] / reps) for i, t in enumerate("ABC")}
    out.update({f"wald_coverage_{t}": float(hit_w[i] / reps) for i, t in enumerate("ABC")})
    out.update({f"coverage_lut_{int(h):03d}": float(hit_lut[i] / reps) for i, h in enumerate(LUT_HEADINGS_DEG)})
    out.update(coverage_lut_min=float(hit_lut.min() / reps), coverage_lut_max=float(hit_lut.max() / reps))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=1000, help="synthetic data sets")
    ap.add_argument("--n-boot", type=int, default=200, help="bootstrap resamples per data set")
    ap.add_argument("--flights", type=int, default=40, help="flights per data set")
    ap.add_argument("--seed", type=int, default=7)
    a = ap.parse_args()
    res = coverage(a.reps, a.n_boot, a.flights, a.seed)
    print(f"repetitions: {a.reps}")
    for k, v in res.items():
        print(f"{k}: {v:.3f}")


if __name__ == "__main__":
    main()
