"""What the magnetic-latitude-aware correction gains over the constant 8-point table.

Two sources of reports:

* default: the independent generator (tests/obs_generator.py), `--reps` fleets of 4
  aircraft whose hard iron scales with 1/H (spokes 300-1200 km from Minneapolis, H from
  ~14,800 to ~22,700 nT), fit on 60 flights, tested on 40 others;
* `--obs FILE`: an exported observation table of a heading_correction run
  (RUN_DIR/data/heading_correction.observations.parquet): fit on its `fit` stage, tested
  on its `before` stage (uncorrected reports, other days).

Prints `label: value` lines: RMS vector difference (kt) uncorrected, with the constant
table and with the field-aware correction (pooled over aircraft), and `gain_kt`
(constant minus field-aware) with its standard error over repetitions (generator) or over
aircraft (run).

    python validation/field_aware_gain.py [--reps 5] [--obs FILE]
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.wind.field_aware_correction import compare_on


def generator_runs(reps: int) -> pd.DataFrame:
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
    import obs_generator as gen

    out = []
    for rep in range(reps):
        rng = np.random.default_rng(1000 + rep)
        truths = [gen.AircraftTruth(f"N{i}", *rng.uniform(-3, 3, 3), h0_nT=17000.0) for i in range(4)]
        fit = gen.generate(truths, rng, flights=60, spoke_km=(300.0, 1200.0))
        test = gen.generate(truths, rng, flights=40, t_start=1_250_294_400.0, spoke_km=(300.0, 1200.0))
        out.append(compare_on(fit, test).set_index("aircraft").loc["all"])
    return pd.DataFrame(out)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--reps", type=int, default=5, help="generator fleets")
    ap.add_argument("--obs", default=None, help="observation table of a heading_correction run")
    ap.add_argument("--heading", default="magnetic", choices=["magnetic", "true"], help="frame of both fits")
    args = ap.parse_args()
    if args.obs:
        obs = pd.read_parquet(args.obs)
        c = compare_on(obs[obs["stage"] == "fit"], obs[obs["stage"] == "before"], heading=args.heading)
        per = c[c["aircraft"] != "all"]
        row = c.set_index("aircraft").loc["all"]
        gains = per["constant_table_rms_kt"] - per["field_aware_rms_kt"]
        n = len(per)
    else:
        runs = generator_runs(args.reps)
        row = runs.mean()
        gains = runs["constant_table_rms_kt"] - runs["field_aware_rms_kt"]
        n = len(runs)
    for k in ("uncorrected_rms_kt", "constant_table_rms_kt", "field_aware_rms_kt"):
        print(f"{k}: {row[k]:.3f}")
    print(f"gain_kt: {row['constant_table_rms_kt'] - row['field_aware_rms_kt']:.3f}")
    print(f"gain_se_kt: {gains.std(ddof=1) / np.sqrt(n):.3f}")
    print(f"units: {n}")


if __name__ == "__main__":
    main()
