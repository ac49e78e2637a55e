"""The wind paper's longitudinal/transverse cells on three component axes, from finished
heading_correction runs: is the longitudinal gap an artefact of the axis the error is split
on? The paper splits on "the track of the observations" (section 8.2.1); aerotruth on the
air track of eq. 3 (aerotruth.analysis.wind.metrics). An orthogonal split of the same
vectors adds up whatever the axis, so the axes can only move error between the components.

    python validation/component_axes.py runs/plans/mesaba-1/base-2030 runs/plans/mesaba-1/base-2031 ...

Reads each run's data/heading_correction.observations (every report of the before and
after stages with its reference); the poor group is the aircraft corrected in the after
stage. Prints per axis the poor group's before and after cells, the control's change and
the poor group's improvement (before minus after adjusted by the control's change), each
as the mean and the seed-to-seed sd over the runs given.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.wind.metrics import AXES, wind_error_summary, wind_errors

OBSERVATIONS = Path("data") / "heading_correction.observations.parquet"


def cells(obs: pd.DataFrame, axis: str) -> dict[str, np.ndarray]:
    """(total, longitudinal, transverse) RMS (kn) per cell on `axis`."""
    treated = set(obs.loc[(obs["stage"] == "after") & obs["corrected"].astype(bool), "aircraft"])
    poor = obs["aircraft"].isin(treated)
    out = {}
    for stage in ("before", "after"):
        for group, sel in (("poor", poor), ("control", ~poor)):
            s = wind_error_summary(wind_errors(obs[(obs["stage"] == stage) & sel], axis=axis)).iloc[0]
            out[(group, stage)] = np.array([s["rms_kt"], s["longitudinal_rms_kt"], s["transverse_rms_kt"]])
    change = out[("control", "after")] - out[("control", "before")]
    return {
        "poor before": out[("poor", "before")],
        "poor after": out[("poor", "after")],
        "control change": change,
        "poor improvement": out[("poor", "before")] - (out[("poor", "after")] - change),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("runs", nargs="+", help="finished heading_correction run folders")
    a = ap.parse_args()
    rows = []
    for run in a.runs:
        path = Path(run) / OBSERVATIONS
        if not path.exists():
            sys.exit(f"{run}: no {OBSERVATIONS} (expected a finished heading_correction run folder)")
        obs = pd.read_parquet(path)
        for axis in AXES:
            for cell, v in cells(obs, axis).items():
                rows.append((run, axis, cell, *v))
    df = pd.DataFrame(rows, columns=["run", "component_axis", "cell", "total_kt", "longitudinal_kt", "transverse_kt"])
    stats = df.groupby(["component_axis", "cell"], sort=False)[["total_kt", "longitudinal_kt", "transverse_kt"]]
    for (axis, cell), g in stats:
        m, sd = g.mean(), g.std(ddof=1)
        print(
            f"{axis}.{cell.replace(' ', '_')}: "
            + " ".join(f"{k} {m[k]:.2f} sd {sd[k]:.2f}" for k in ("total_kt", "longitudinal_kt", "transverse_kt"))
        )


if __name__ == "__main__":
    main()
