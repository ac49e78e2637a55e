"""What a frozen calibration leaves uncertain in the wind paper's predicted cells, beyond
the standard error of the seeds' mean that paper_tables.py judges with.

1. **Calibration.** The free parameters are set on the before cells, and those cells are
   one draw of a few aircraft (their seed-to-seed sd), so a parameter the cells hardly
   move is hardly known. From variant runs on the same seeds (one parameter changed,
   `--variant NAME=VALUE RUN...`; paired with the frozen runs seed by seed), the
   sensitivity of every cell to each parameter, J (calibrated cells) and g (a predicted
   cell), by least squares through the frozen point. The calibration rule (the least
   sum of ((mean - paper) / sd)^2 over the calibrated cells, weights W = diag(1 / sd^2))
   then errs, linearized, by

       cov(theta) = H^-1 J' W S W J H^-1,   H = J' W J

   with S the seeds' covariance of the calibrated cells (the spread of the paper's draw;
   the sandwich, because the rule weighs the cells as if independent and totals and
   components are not), and a predicted cell by sd_cal = sqrt(g' cov(theta) g). The
   prediction's standard error is then sqrt(se^2 + sd_cal^2).
2. **The paper's realization.** The paper's predicted cells were drawn together with its
   before cells (the same aircraft and the same season's model error). Over the frozen
   seeds each predicted total cell is regressed on the two before totals (poor and control
   group); at the paper's before totals that gives the prediction for the paper's own
   draw, its standard error, and the scatter left about it (`conditional.*`). Fixed
   before any run: the two totals, nothing else.

Neither changes a verdict: the judged numbers are paper_tables.py's.

    python validation/prediction_uncertainty.py RUN... [--frozen NAME=VALUE ...]
        [--variant NAME=VALUE RUN... ...]

Prints `label: value` lines: `sensitivity.<cell>.<name>: slope se (kn per unit)`,
`calibration.<name>: value se`, `prediction.<cell>: mean se sd_cal total_se paper`,
`conditional.<cell>: value se scatter paper`.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from paper_tables import collect, summarize  # noqa: E402

KEY = ["group", "period", "component"]
CONDITION_ON = (("poor", "before", "total"), ("control", "before", "total"))


def per_seed(rows: pd.DataFrame) -> pd.DataFrame:
    """Cells as columns (group, period, component), one row per run in the given order."""
    wide = rows.pivot_table(index="run", columns=KEY, values="simulated_kt", sort=False)
    return wide.loc[list(dict.fromkeys(rows["run"]))]


def sensitivities(
    frozen: pd.DataFrame, variants: list[tuple[str, float, pd.DataFrame]], at: dict[str, float]
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Per cell and parameter: the least-squares slope through the frozen point of the
    seed-paired differences (variant - frozen) against the parameter's change, and its
    standard error from the seeds' scatter of the per-seed slopes."""
    slope, se = {}, {}
    for name in dict.fromkeys(n for n, _, _ in variants):
        if name not in at:
            sys.exit(f"--variant {name}=...: give the frozen value with --frozen {name}=VALUE")
        d, x = [], []
        for n, value, runs in variants:
            if n != name:
                continue
            if len(runs) != len(frozen):
                sys.exit(
                    f"--variant {name}={value:g}: expected {len(frozen)} runs (the frozen runs' seeds, same order), "
                    f"got {len(runs)}"
                )
            if value == at[name]:
                sys.exit(f"--variant {name}={value:g}: the frozen value itself")
            d.append(runs[frozen.columns].to_numpy() - frozen.to_numpy())
            x.append(value - at[name])
        d, x = np.array(d), np.array(x)  # (variants, seeds, cells), (variants,)
        per = np.einsum("k,ksc->sc", x, d) / (x @ x)  # each seed's slope
        slope[name] = per.mean(axis=0)
        se[name] = per.std(axis=0, ddof=1) / np.sqrt(len(per)) if len(per) > 1 else np.full(per.shape[1], np.nan)
    return (pd.DataFrame(slope, index=frozen.columns), pd.DataFrame(se, index=frozen.columns))


def calibration_covariance(J: np.ndarray, sd: np.ndarray, S: np.ndarray) -> np.ndarray:
    """cov(theta) of the chi2 rule linearized: H^-1 J' W S W J H^-1, H = J' W J, W = diag(sd^-2)."""
    W = np.diag(1.0 / sd**2)
    H_inv = np.linalg.inv(J.T @ W @ J)
    return H_inv @ J.T @ W @ S @ W @ J @ H_inv


def conditional(frozen: pd.DataFrame, paper: pd.Series, cells: list[tuple]) -> pd.DataFrame:
    """Each of `cells` regressed over the seeds on the CONDITION_ON cells, read at the
    paper's values of those: value, its standard error, the residual scatter."""
    X = frozen[list(CONDITION_ON)].to_numpy()
    x_star = paper[list(CONDITION_ON)].to_numpy(dtype=float)
    n, p = X.shape
    if n <= p + 1:
        sys.exit(f"conditional: {n} seeds cannot fit {p} slopes and a scatter; need at least {p + 2}")
    Xc = X - X.mean(axis=0)
    A = np.column_stack([np.ones(n), Xc])
    a_star = np.r_[1.0, x_star - X.mean(axis=0)]
    AtA_inv = np.linalg.inv(A.T @ A)
    out = []
    for c in cells:
        y = frozen[c].to_numpy()
        b = AtA_inv @ A.T @ y
        resid = y - A @ b
        s2 = resid @ resid / (n - p - 1)
        out.append(
            {
                "cell": c,
                "value": a_star @ b,
                "se": float(np.sqrt(s2 * a_star @ AtA_inv @ a_star)),
                "scatter": float(np.sqrt(s2)),
                "paper": float(paper[c]),
            }
        )
    return pd.DataFrame(out)


def parse_assignment(text: str, what: str) -> tuple[str, float]:
    name, eq, value = text.partition("=")
    try:
        if not eq or not name:
            raise ValueError
        return name, float(value)
    except ValueError:
        sys.exit(f"{what}: expected NAME=VALUE (e.g. hard_iron_nT=740), got {text!r}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", help="the frozen calibration's runs, one per seed")
    ap.add_argument("--frozen", action="append", default=[], help="NAME=VALUE: a calibrated parameter's frozen value")
    ap.add_argument(
        "--variant",
        action="append",
        nargs="+",
        default=[],
        metavar="NAME=VALUE RUN",
        help="one parameter changed: NAME=VALUE, then its runs on the frozen runs' seeds, same order",
    )
    a = ap.parse_args()
    rows = collect(a.runs)
    frozen = per_seed(rows)
    cells = summarize(rows).set_index(KEY)  # per cell: the paper's value, role, mean, sd, se over the seeds
    paper = cells["paper_kt"]
    calibrated = [c for c in frozen.columns if cells.at[c, "role"] == "calibrated" and cells.at[c, "sd_kt"] > 0]
    predicted = [c for c in frozen.columns if cells.at[c, "role"] == "predicted"]
    print(f"seeds: {len(frozen)}")

    sd_cal = pd.Series(0.0, index=frozen.columns)
    if a.variant:
        at = dict(parse_assignment(t, "--frozen") for t in a.frozen)
        variants = []
        for v in a.variant:
            name, value = parse_assignment(v[0], "--variant")
            variants.append((name, value, per_seed(collect(v[1:]))))
        slope, slope_se = sensitivities(frozen, variants, at)
        for c in frozen.columns:
            for name in slope.columns:
                print(f"sensitivity.{'.'.join(c)}.{name}: {slope.at[c, name]:+.4g} se {slope_se.at[c, name]:.2g}")
        J = slope.loc[calibrated].to_numpy()
        S = np.cov(frozen[calibrated].to_numpy(), rowvar=False)
        cov = calibration_covariance(J, cells.loc[calibrated, "sd_kt"].to_numpy(), S)
        for i, name in enumerate(slope.columns):
            print(f"calibration.{name}: {at[name]:g} se {np.sqrt(cov[i, i]):.3g}")
        g = slope.to_numpy()
        sd_cal = pd.Series(np.sqrt(np.einsum("ci,ij,cj->c", g, cov, g)), index=frozen.columns)
    for c in predicted:
        mean, se = cells.at[c, "mean_kt"], cells.at[c, "se_kt"]
        print(
            f"prediction.{'.'.join(c)}: mean {mean:.2f} se {se:.2f} sd_cal {sd_cal[c]:.2f} "
            f"total_se {np.hypot(se, sd_cal[c]):.2f} paper {paper[c]:.1f}"
        )
    totals = [c for c in predicted if c[2] == "total"]
    for r in conditional(frozen, paper, totals).itertuples():
        print(
            f"conditional.{'.'.join(r.cell)}: {r.value:.2f} se {r.se:.2f} scatter {r.scatter:.2f} paper {r.paper:.1f}"
        )


if __name__ == "__main__":
    main()
