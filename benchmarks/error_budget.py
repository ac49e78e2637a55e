"""Where a `heading_correction` campaign's wind error comes from, from the truth that a
simulation knows and a real fleet does not: reads each run's observation export
(data/heading_correction.observations.parquet, with the truth wind and heading beside each
report) and the poor/control groups (tables/heading_correction.per_aircraft.parquet), and
splits the RMS vector difference TAMDAR minus reference of each group and period (the
reports the study scores: |roll| <= the study's max_roll_deg) into

* the reference model's own error, reference minus truth wind (`model_kt`), and
* the aircraft's own error, TAMDAR minus truth wind (`own_kt`), along and across the true
  heading (`own_along_kt`: TAS-like; `own_across_kt`: heading-like),

then gives the reported heading's error against the truth heading by flight phase and, in
climbs, by time since the flight's first report (the departure minutes).

    python benchmarks/error_budget.py RUN_DIR [RUN_DIR ...]

Prints `label: mean sd` lines over the runs (one per campaign seed):
`budget.<group>.<period>.<part>_kt`, `heading.<group>.<period>.<phase>_deg` (rms) and
`climb.<group>.<period>.<minutes>_deg` (rms) with `..._share` (the share of the climb's
reports in that bin).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
import pandas as pd
import yaml

CLIMB_BINS_S = (0.0, 60.0, 180.0, 600.0, np.inf)
CLIMB_LABELS = ("0-1min", "1-3min", "3-10min", "10min+")


def _vector(speed_kt: pd.Series, from_deg: pd.Series) -> tuple[np.ndarray, np.ndarray]:
    """(east, north) kt of a wind given as speed and meteorological 'from' direction."""
    a = np.radians(from_deg.to_numpy(float))
    s = speed_kt.to_numpy(float)
    return -s * np.sin(a), -s * np.cos(a)


def scored_reports(run: Path) -> pd.DataFrame:
    """The run's before/after reports as the study scores them, with their group."""
    obs_path = run / "data" / "heading_correction.observations.parquet"
    groups_path = run / "tables" / "heading_correction.per_aircraft.parquet"
    for p in (obs_path, groups_path):
        if not p.exists():
            sys.exit(f"{run}: no {p.relative_to(run)} (a finished heading_correction run is needed)")
    cfg = yaml.safe_load((run / "config.resolved.yaml").read_text()) if (run / "config.resolved.yaml").exists() else {}
    max_roll = float(((cfg.get("studies") or {}).get("heading_correction") or {}).get("max_roll_deg", 10.0))
    obs = pd.read_parquet(obs_path)
    need = ("truth_wind_speed_kt", "truth_wind_dir_deg", "truth_heading_deg", "ref_wind_speed_kt", "stage")
    missing = [c for c in need if c not in obs.columns]
    if missing:
        sys.exit(f"{obs_path}: missing columns {missing} (the export of a simulated run carries the truth)")
    group = pd.read_parquet(groups_path).set_index("aircraft")["group"]
    obs = obs[obs["stage"].isin(["before", "after"]) & (obs["roll_deg"].abs() <= max_roll)].copy()
    obs["group"] = obs["aircraft"].astype(str).map(group)
    return obs[obs["group"].isin(["poor", "control"])]


def budget(obs: pd.DataFrame) -> dict[str, float]:
    """One run's budget and heading-error lines (label -> value)."""
    out: dict[str, float] = {}
    oe, on = _vector(obs["wind_speed_kt"], obs["wind_dir_deg"])
    re_, rn = _vector(obs["ref_wind_speed_kt"], obs["ref_wind_dir_deg"])
    te, tn = _vector(obs["truth_wind_speed_kt"], obs["truth_wind_dir_deg"])
    h = np.radians(obs["truth_heading_deg"].to_numpy(float))
    along = (oe - te) * np.sin(h) + (on - tn) * np.cos(h)
    across = (oe - te) * np.cos(h) - (on - tn) * np.sin(h)
    parts = pd.DataFrame({"total": (oe - re_) ** 2 + (on - rn) ** 2, "model": (re_ - te) ** 2 + (rn - tn) ** 2,
                          "own": (oe - te) ** 2 + (on - tn) ** 2, "own_along": along ** 2, "own_across": across ** 2},
                         index=obs.index)
    dh = (obs["heading_deg"] - obs["truth_heading_deg"] + 180.0) % 360.0 - 180.0
    since = obs["time"] - obs.groupby("flight")["time"].transform("min")
    for (g, st), idx in obs.groupby(["group", "stage"]).groups.items():
        for part, v in parts.loc[idx].mean().items():
            out[f"budget.{g}.{st}.{part}_kt"] = float(np.sqrt(v))
        d = obs.loc[idx]
        for phase, sub in d.groupby("phase"):
            out[f"heading.{g}.{st}.{phase}_deg"] = float(np.sqrt((dh[sub.index] ** 2).mean()))
        climb = d[d["phase"] == "ascent"]
        if len(climb):
            bins = pd.cut(since[climb.index], CLIMB_BINS_S, labels=CLIMB_LABELS, right=False)
            for label in CLIMB_LABELS:
                sel = climb.index[bins == label]
                if len(sel):
                    out[f"climb.{g}.{st}.{label}_deg"] = float(np.sqrt((dh[sel] ** 2).mean()))
                    out[f"climb.{g}.{st}.{label}_share"] = len(sel) / len(climb)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", help="run directories of one heading_correction campaign, one per seed")
    a = ap.parse_args()
    table = pd.DataFrame([budget(scored_reports(Path(r))) for r in a.runs])
    print(f"runs: {len(a.runs)}")
    for label in table.columns:
        v = table[label].dropna()
        sd = v.std() if len(v) > 1 else float("nan")
        print(f"{label}: {v.mean():.2f} {sd:.2f}")


if __name__ == "__main__":
    main()
