"""The wind paper's Tables I-IV as predictions over campaign seeds: reads the
`heading_correction` side-by-side table (tables/heading_correction.versus_paper.parquet)
of several run directories of one campaign (one per campaign seed, e.g. made with
`aerotruth run campaigns/mesaba_2009.yaml --size reduced --out runs/m-<seed>` after setting
`seed:`), and prints per cell the mean over the seeds, the seed-to-seed standard deviation
(the reduced run's statistical precision), the standard error of the mean, the paper's
value, the cell's role (calibrated or predicted) and, for the judged cells (the poor group's
adjusted after cell and the improvement, total RMS), whether the mean lands within max(1.0
kn, 2 standard errors) of the paper.

    python validation/paper_tables.py RUN_DIR [RUN_DIR ...] [--markdown]
    python validation/paper_tables.py RUN_DIR ... --baseline BASE_DIR ...
    python validation/paper_tables.py RUN_DIR ... --plan validation/plans/wind-tables-penair-1.yaml

Prints `label: value` lines (`cell.<group>.<period>.<component>: mean sd se paper role`),
`judged.<group>.<period>: pass|fail (|mean - paper| = x <= tol y)` and
`calibration.chi2` (the campaigns' calibration rule: see `calibration_chi2`).

`--plan PLAN` (validation/plans/*.yaml, committed before its runs: see plans.py): each
cell also judged as **one draw** of the paper's table at the paper's own fleet size and
period length (aerotruth.analysis.wind.paper_draw; the runs' aircraft-day sums redrawn by
their variance components): `predictive.<cell>: mean sd_draw se paper z pit role`,
`verdict.<cell>: pass|fail (|z| ... <= z_crit at the family-wise level)` for the plan's
judged cells, `joint: mahalanobis_d2 dof p` over them, and `plan: name commit`. The runs
must carry the plan's record (seed_runs.py --plan writes it); a plan changed since they ran
is refused. `--paper-scale POOR,CONTROL,DAYS_BEFORE,DAYS_AFTER` does the same without a plan
(exploration: nothing judged is written as a verdict of record).

`--baseline`: these runs are a variant (one sensor or method option changed) of baseline
runs on the same campaign seeds, given in the same order. Runs of one seed share their
flights and sensor noise (named random streams), so the per-seed difference cancels most
of the seed-to-seed spread: `paired.<group>.<period>.<component>: difference se` per cell
(variant minus baseline, mean over the seeds and its standard error), a far tighter
measure of what the change does than the difference of the two means.
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path

import numpy as np
import pandas as pd

sys.path.insert(0, str(Path(__file__).resolve().parent))
from plans import Plan, check_runs  # noqa: E402

JUDGED = (("poor", "after_adjusted"), ("poor", "improvement"))
TOLERANCE_KT = 1.0


def _read_tables(run_dirs: list[str], name: str, why: str) -> pd.DataFrame:
    """Table `name` (tables/<name>.parquet) of every run, with the run's directory; a run
    without it is one line saying `why`."""
    parts = []
    for d in run_dirs:
        path = Path(d) / "tables" / f"{name}.parquet"
        if not path.exists():
            sys.exit(f"{d}: no {path.relative_to(d)} ({why})")
        parts.append(pd.read_parquet(path).assign(run=str(d)))
    return pd.concat(parts, ignore_index=True)


def collect(run_dirs: list[str]) -> pd.DataFrame:
    """The versus_paper rows of every run, with the run's directory."""
    return _read_tables(run_dirs, "heading_correction.versus_paper", "was the run finished with a `paper:` section?")


def summarize(rows: pd.DataFrame) -> pd.DataFrame:
    """Mean, seed-to-seed sd, se of the mean per (group, period, component), beside the paper."""
    g = rows.groupby(["group", "period", "component"], sort=False)
    out = g.agg(
        paper_kt=("paper_kt", "first"),
        role=("role", "first"),
        n_seeds=("simulated_kt", "count"),
        mean_kt=("simulated_kt", "mean"),
        sd_kt=("simulated_kt", "std"),
    ).reset_index()
    out["se_kt"] = out["sd_kt"] / out["n_seeds"].clip(lower=1) ** 0.5
    out["difference_kt"] = out["mean_kt"] - out["paper_kt"]
    out["tolerance_kt"] = [max(TOLERANCE_KT, 2 * se) if math.isfinite(se) else TOLERANCE_KT for se in out["se_kt"]]
    judged = [(r.group, r.period) in JUDGED and r.component == "total" for r in out.itertuples()]
    out["verdict"] = [
        "" if not j else ("pass" if abs(r.difference_kt) <= r.tolerance_kt else "fail")
        for j, r in zip(judged, out.itertuples(), strict=False)
    ]
    return out


def paired(rows: pd.DataFrame, base: pd.DataFrame) -> pd.DataFrame:
    """Per (group, period, component): mean and standard error over the seeds of variant
    minus baseline, the i-th variant run paired with the i-th baseline run."""
    key = ["group", "period", "component"]
    a, b = rows.copy(), base.copy()
    for t in (a, b):
        t["pair"] = t.groupby(key, sort=False).cumcount()
    m = a.merge(b, on=key + ["pair"], suffixes=("", "_base"))
    m["difference_kt"] = m["simulated_kt"] - m["simulated_kt_base"]
    out = m.groupby(key, sort=False)["difference_kt"].agg(mean_kt="mean", sd_kt="std", n="count").reset_index()
    out["se_kt"] = out["sd_kt"] / out["n"].clip(lower=1) ** 0.5
    return out


def collect_sums(run_dirs: list[str]) -> pd.DataFrame:
    """The aircraft-day sums of every run, each run named by its directory."""
    return _read_tables(
        run_dirs, "heading_correction.aircraft_days", "a run of a version before the aircraft-day sums: run it again"
    )


def predictive_report(
    run_dirs: list[str], rows: pd.DataFrame, scale, judged: list[str], level: float, n_draws: int, seed: int
) -> tuple[pd.DataFrame, dict]:
    """Every published cell judged as one draw at `scale` (module docstring)."""
    from aerotruth.analysis.wind.paper_draw import judge, predictive

    cells = list(rows.drop_duplicates(["group", "period", "component"]).itertuples())
    paper = {f"{r.group}.{r.period}.{r.component}": float(r.paper_kt) for r in cells}
    role = {f"{r.group}.{r.period}.{r.component}": r.role for r in cells}
    draws, loo = predictive(collect_sums(run_dirs), scale, n_draws, np.random.default_rng(seed))
    table, joint = judge(draws, loo, paper, judged, level)
    table["role"] = table["cell"].map(role)
    return table, joint


def print_predictive(table: pd.DataFrame, joint: dict, level: float) -> None:
    for r in table.itertuples():
        print(
            f"predictive.{r.cell}: mean {r.mean:.2f} sd_draw {r.sd_draw:.2f} se {r.se:.2f} paper {r.paper:.1f} "
            f"z {r.z:+.2f} pit {r.pit:.3f} {r.role}"
        )
    for r in table[table["judged"]].itertuples():
        limit = joint["z_critical"]
        print(f"verdict.{r.cell}: {r.verdict} (|z| {abs(r.z):.2f}, limit {limit:.2f} at family-wise {level:g})")
    print(f"joint: mahalanobis_d2 {joint['mahalanobis_d2']:.2f} dof {int(joint['dof'])} p {joint['p']:.3f}")


def calibration_chi2(t: pd.DataFrame) -> tuple[float, int]:
    """The campaigns' calibration rule: over the calibrated cells (the before cells, totals
    and components), the sum of ((mean - paper) / seed-to-seed sd)^2 — each miss in units of
    one campaign's spread, since the paper's cell is itself one draw of a few aircraft. Of
    the parameter variants tried, the one with the smallest value is kept. Returns the
    sum and the number of cells in it."""
    c = t[(t["role"] == "calibrated") & (t["sd_kt"] > 0)]
    return float((((c["mean_kt"] - c["paper_kt"]) / c["sd_kt"]) ** 2).sum()), len(c)


def figure(t: pd.DataFrame, path: str, title: str = "") -> None:
    """Total-RMS cells: the paper's value and the seeds' mean +- 2 se, calibrated cells grey."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tot = t[t["component"] == "total"].reset_index(drop=True)
    fig, ax = plt.subplots(figsize=(7, 3.6))
    x = range(len(tot))
    ax.bar([i - 0.2 for i in x], tot["paper_kt"], 0.4, color="0.6", label="paper")
    colors = ["0.35" if r == "calibrated" else "tab:blue" for r in tot["role"]]
    ax.bar(
        [i + 0.2 for i in x],
        tot["mean_kt"],
        0.4,
        color=colors,
        yerr=2 * tot["se_kt"].fillna(0),
        capsize=3,
        label=f"simulated, mean of {int(tot['n_seeds'].max())} seeds +- 2 se (dark: calibrated)",
    )
    ax.set_xticks(
        list(x), [f"{g}\n{p.replace('_', ' ')}" for g, p in zip(tot["group"], tot["period"], strict=False)], fontsize=7
    )
    ax.set_ylabel("RMS vector difference (kn)")
    ax.set_title(title, fontsize=9)
    ax.legend(fontsize=7)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", help="run directories of one campaign, one per seed")
    ap.add_argument("--markdown", action="store_true", help="also print the table as Markdown")
    ap.add_argument("--figure", help="also draw the total cells, paper vs mean +- 2 se, to this PNG")
    ap.add_argument(
        "--baseline",
        nargs="+",
        help="baseline runs on the same seeds, in the same order: also print "
        "the paired differences (these runs minus the baseline)",
    )
    ap.add_argument(
        "--plan", help="a committed plan (validation/plans/*.yaml): judge each cell as one draw at its scale"
    )
    ap.add_argument(
        "--paper-scale",
        metavar="POOR,CONTROL,DAYS_BEFORE,DAYS_AFTER",
        help="without a plan: each cell as one draw at this scale (exploration)",
    )
    a = ap.parse_args()
    if a.baseline and len(a.baseline) != len(a.runs):
        sys.exit(
            f"--baseline: expected {len(a.runs)} run directories (one per run, same seeds, same order), "
            f"got {len(a.baseline)}"
        )
    rows = collect(a.runs)
    t = summarize(rows)
    print(f"seeds: {len(a.runs)}")
    for r in t.itertuples():
        print(
            f"cell.{r.group}.{r.period}.{r.component}: mean {r.mean_kt:.2f} sd {r.sd_kt:.2f} se {r.se_kt:.2f} "
            f"paper {r.paper_kt:.1f} {r.role}"
        )
    for r in t[t["verdict"] != ""].itertuples():
        print(
            f"judged.{r.group}.{r.period}: {r.verdict} (|mean - paper| = {abs(r.difference_kt):.2f}, tolerance "
            f"{r.tolerance_kt:.2f})"
        )
    chi2, n_cells = calibration_chi2(t)
    print(f"calibration.chi2: {chi2:.2f} over {n_cells} calibrated cells")
    if a.plan or a.paper_scale:
        from aerotruth.analysis.wind.paper_draw import PaperScale

        if len(a.runs) < 2:
            sys.exit(
                "--plan / --paper-scale: expected two runs or more (the mean's standard error is a jackknife over runs)"
            )

        if a.plan:
            plan = Plan.load(a.plan)
            check_runs(plan, a.runs)
            print(f"plan: {plan.name} {plan.commit}")
            scale, judged, level, n_draws = plan.scale, list(plan.judged), plan.level, plan.draws
        else:
            try:
                scale = PaperScale(*(int(x) for x in a.paper_scale.split(",")))
            except (TypeError, ValueError) as exc:
                sys.exit(f"--paper-scale: expected four whole numbers POOR,CONTROL,DAYS_BEFORE,DAYS_AFTER ({exc})")
            judged, level, n_draws = [], 0.05, 4000
            print("plan: none (exploration)")
        print(f"paper_scale: poor {scale.poor} control {scale.control} days {scale.days_before} / {scale.days_after}")
        table, joint = predictive_report(a.runs, rows, scale, judged, level, n_draws, seed=2026)
        print_predictive(table, joint, level)
        if a.markdown:
            from aerotruth.markdown import to_markdown

            cols = ["cell", "role", "paper", "mean", "sd_draw", "se", "z", "pit", "verdict"]
            print(to_markdown(table[cols].round(3)))
    if a.baseline:
        for r in paired(rows, collect(a.baseline)).itertuples():
            print(f"paired.{r.group}.{r.period}.{r.component}: {r.mean_kt:+.2f} se {r.se_kt:.2f}")
    if a.figure:
        figure(t, a.figure, title=str(rows["source"].iloc[0]) if "source" in rows else "")
    if a.markdown:
        cols = [
            "group",
            "period",
            "component",
            "role",
            "paper_kt",
            "mean_kt",
            "sd_kt",
            "se_kt",
            "difference_kt",
            "verdict",
        ]
        from aerotruth.markdown import to_markdown

        print(to_markdown(t[cols].round(2)))


if __name__ == "__main__":
    main()
