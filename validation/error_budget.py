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

Bounds on what any heading table could do (`bound.<case>.<cell>_kt`, the judged cells
poor after, adjusted after, improvement): `scored` as the study scores them (a check:
equals the run's own cells); `full_static_table`: the poor group's remaining heading error
after its table, fitted per aircraft on all its after reports (every phase, every
heading: the coverage a one-axis network does not give the real fit) as A + B sin + C cos
+ D sin 2 + E cos 2 of the measured magnetic heading, and removed - the most a static
table can do; `no_heading_error`: all of that error removed. Removing an error dpsi
rotates the report's air vector: W' = W + TAS (u(psi) - u(psi - dpsi)), u the unit vector
along the heading. Reports banked beyond 5 deg keep their error in both cases (the wind's
heading there is a window average, not the reported sample). `octant.poor.after.<hdg>`:
the poor group's after heading error (rms, deg) by octant of measured magnetic heading,
with its table (`_table_deg`) and with the full static table (`_full_deg`), and the share
of reports there.

    python validation/error_budget.py RUN_DIR [RUN_DIR ...]

The reference error's seasonal law (aerotruth.sensors.weather_model, s(doy) = 1 + A cos(2 pi
(doy - peak) / P) on the analysis error): `season_held.<group>.<period>.<total|longitudinal>_kt`
are the cells with every after report's reference error (reference minus truth) scaled by
s(before) / s(doy), s(before) the mean factor of that reference's before reports - the
after period at the before period's season; `season.control.change_<scored|held>_kt`, the
control's before-to-after change as scored and so held. The whole reference error is
scaled, its unresolved-truth part too (which has no season), so the held change is a lower
bound of what the run would give with A = 0.

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

from aerotruth.analysis.wind.heading_errors import towards_from_report
from aerotruth.analysis.wind.metrics import corrected_wind_error, wind_error_components
from aerotruth.analysis.wind.paper_draw import COMPONENTS, derived_cells
from aerotruth.sensors.weather_model import preset
from aerotruth.sim.studies.wind_reports import unbanked
from aerotruth.units import KT

CLIMB_BINS_S = (0.0, 60.0, 180.0, 600.0, np.inf)
CLIMB_LABELS = ("0-1min", "1-3min", "3-10min", "10min+")


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
    obs = unbanked(obs[obs["stage"].isin(["before", "after"])], max_roll)
    obs["group"] = obs["aircraft"].astype(str).map(group)
    return obs[obs["group"].isin(["poor", "control"])]


def winds(obs: pd.DataFrame) -> dict[str, np.ndarray]:
    """The reported, reference and truth winds (towards, east/north, m/s) and the reported
    heading's error against the truth (deg, wrapped to +-180), once per run."""
    w = {}
    for name, prefix in (("o", ""), ("r", "ref_"), ("t", "truth_")):
        e, n = towards_from_report(obs[f"{prefix}wind_speed_kt"], obs[f"{prefix}wind_dir_deg"])
        w[name + "e"], w[name + "n"] = np.asarray(e), np.asarray(n)
    w["dh"] = ((obs["heading_deg"] - obs["truth_heading_deg"] + 180.0) % 360.0 - 180.0).to_numpy()
    return w


def budget(obs: pd.DataFrame, w: dict[str, np.ndarray]) -> dict[str, float]:
    """One run's budget and heading-error lines (label -> value); `w` = winds(obs)."""
    out: dict[str, float] = {}
    oe, on, re_, rn, te, tn = (w[k] for k in ("oe", "on", "re", "rn", "te", "tn"))
    head = obs["truth_heading_deg"].to_numpy(float)
    dh = pd.Series(w["dh"], index=obs.index)
    since = obs["time"] - obs.groupby("flight")["time"].transform("min")
    one_ref = obs["ref_source"] == obs["ref_source"].iloc[0]  # the heading is the report's: once per report
    for (g, st), idx in obs.groupby(["group", "stage"]).groups.items():
        i = obs.index.get_indexer(idx)
        own = wind_error_components(oe[i] - te[i], on[i] - tn[i], head[i])
        parts = {
            "total": wind_error_components(oe[i] - re_[i], on[i] - rn[i], head[i])["rms_kt"],
            "model": wind_error_components(re_[i] - te[i], rn[i] - tn[i], head[i])["rms_kt"],
            "own": own["rms_kt"],
            "own_along": own["longitudinal_kt"],
            "own_across": own["transverse_kt"],
        }
        for part, v in parts.items():
            out[f"budget.{g}.{st}.{part}_kt"] = float(v)
        d = obs.loc[idx][one_ref[idx]]
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


def _judged_cells(e2: pd.Series, obs: pd.DataFrame) -> dict[str, float]:
    """Poor after, adjusted after and improvement (kn) from the squared wind errors (m/s)^2
    of the scored reports, adjusted as the study adjusts (derived_cells)."""
    r = np.sqrt(e2.groupby([obs["group"], obs["stage"]]).mean()) / KT
    cells = derived_cells(
        pd.DataFrame(
            [
                {"group": g, "period": p, **{c: (v if c == "rms_kt" else np.nan) for c, _ in COMPONENTS}}
                for (g, p), v in r.items()
            ]
        )
    ).set_index(["group", "period"])["rms_kt"]
    return {
        "poor_after": cells["poor", "after"],
        "adjusted_after": cells["poor", "after_adjusted"],
        "improvement": cells["poor", "improvement"],
    }


def table_bounds(obs: pd.DataFrame, w: dict[str, np.ndarray]) -> dict[str, float]:
    """The judged cells as scored, with a full static table and with no heading error on
    the poor group's after reports (module docstring); `w` = winds(obs)."""
    dh = w["dh"]
    tas = obs["tas_kt"].to_numpy(float) * KT
    psi = np.radians(obs["heading_deg"].to_numpy(float))
    rows = pd.DataFrame(
        {"va_e": tas * np.sin(psi), "va_n": tas * np.cos(psi), "dw_e": w["oe"] - w["re"], "dw_n": w["on"] - w["rn"]}
    )
    mag = obs["heading_mag_deg"] if "heading_mag_deg" in obs else obs["heading_deg"]
    hm = np.radians(mag.to_numpy(float))
    poor_after = ((obs["group"] == "poor") & (obs["stage"] == "after")).to_numpy()
    eligible = poor_after & (obs["roll_deg"].abs() <= 5.0).to_numpy()
    design = np.column_stack([np.ones(len(obs)), np.sin(hm), np.cos(hm), np.sin(2 * hm), np.cos(2 * hm)])
    full = np.zeros(len(obs))  # the full static table's fitted heading error
    aircraft = obs["aircraft"].astype(str).to_numpy()
    for ac in np.unique(aircraft[eligible]):
        k = eligible & (aircraft == ac)
        coef, *_ = np.linalg.lstsq(design[k], dh[k], rcond=None)
        full[k] = design[k] @ coef
    out: dict[str, float] = {}
    for case, removed in (
        ("scored", np.zeros(len(obs))),
        ("full_static_table", full),
        ("no_heading_error", np.where(eligible, dh, 0.0)),
    ):
        ex, ey = corrected_wind_error(rows, -removed)  # the heading corrected by -removed
        for cell, v in _judged_cells(pd.Series(ex**2 + ey**2, index=obs.index), obs).items():
            out[f"bound.{case}.{cell}_kt"] = float(v)
    octant = (np.round(np.degrees(hm) / 45.0).astype(int) % 8) * 45
    one_ref = (obs["ref_source"] == obs["ref_source"].iloc[0]).to_numpy()
    sel = eligible & one_ref
    for o in range(0, 360, 45):
        k = sel & (octant == o)
        if k.any():
            out[f"octant.poor.after.{o:03d}_table_deg"] = float(np.sqrt(np.mean(dh[k] ** 2)))
            out[f"octant.poor.after.{o:03d}_full_deg"] = float(np.sqrt(np.mean((dh[k] - full[k]) ** 2)))
            out[f"octant.poor.after.{o:03d}_share"] = float(k.sum() / sel.sum())
    return out


def seasonal_laws(run: Path) -> dict[str, tuple[float, float, float]]:
    """Reference name -> (amplitude, period days, peak day of year) from the run's resolved
    configuration (every `references` list in it; one law per name)."""
    cfg = yaml.safe_load((run / "config.resolved.yaml").read_text())
    laws: dict[str, tuple[float, float, float]] = {}

    def walk(node) -> None:
        if isinstance(node, dict):
            for key, value in node.items():
                if key == "references" and isinstance(value, list):
                    for ref in value:
                        if isinstance(ref, dict) and "seasonal_amplitude" in ref:
                            law = (
                                float(ref["seasonal_amplitude"]),
                                float(ref["seasonal_period_days"]),
                                float(ref["seasonal_peak_doy"]),
                            )
                            if laws.setdefault(str(ref["name"]), law) != law:
                                sys.exit(f"{run}/config.resolved.yaml: reference {ref['name']!r} has two seasonal laws")
                walk(value)
        elif isinstance(node, list):
            for value in node:
                walk(value)

    walk(cfg)
    return laws


def season_held(obs: pd.DataFrame, w: dict[str, np.ndarray], laws: dict) -> dict[str, float]:
    """The cells with the after period's reference error at the before period's seasonal
    factor (module docstring); `w` = winds(obs)."""
    dates = pd.to_datetime(obs["time"], unit="s", utc=True).dt.date.to_numpy()
    src = obs["ref_source"].astype(str).to_numpy()
    before = (obs["stage"] == "before").to_numpy()
    k = np.ones(len(obs))
    for name in np.unique(src):
        if name not in laws:
            sys.exit(f"config.resolved.yaml: no seasonal law for reference {name!r} of the observations")
        a, period, peak = laws[name]
        spec = preset(name, seasonal_amplitude=a, seasonal_period_days=period, seasonal_peak_doy=peak)
        by_date = {day: spec.seasonal_factor(day) for day in set(dates)}  # the law as the sensors apply it
        factor = np.array([by_date[day] for day in dates])
        rows = src == name
        k[rows & ~before] = factor[rows & before].mean() / factor[rows & ~before]
    head = obs["truth_heading_deg"].to_numpy(float)
    out: dict[str, float] = {}
    total = {}
    for (g, st), idx in obs.groupby(["group", "stage"]).groups.items():
        i = obs.index.get_indexer(idx)
        me, mn = (w["re"][i] - w["te"][i]) * k[i], (w["rn"][i] - w["tn"][i]) * k[i]
        held = wind_error_components(w["oe"][i] - w["te"][i] - me, w["on"][i] - w["tn"][i] - mn, head[i])
        scored = wind_error_components(w["oe"][i] - w["re"][i], w["on"][i] - w["rn"][i], head[i])
        out[f"season_held.{g}.{st}.total_kt"] = float(held["rms_kt"])
        out[f"season_held.{g}.{st}.longitudinal_kt"] = float(held["longitudinal_kt"])
        total[g, st] = (float(scored["rms_kt"]), float(held["rms_kt"]))
    if ("control", "before") in total and ("control", "after") in total:
        out["season.control.change_scored_kt"] = total["control", "after"][0] - total["control", "before"][0]
        out["season.control.change_held_kt"] = total["control", "after"][1] - total["control", "before"][1]
    return out


def run_lines(run: Path) -> dict[str, float]:
    """All of one run's lines: the budget, the table bounds and the season held."""
    obs = scored_reports(run)
    w = winds(obs)
    return {**budget(obs, w), **table_bounds(obs, w), **season_held(obs, w, seasonal_laws(run))}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("runs", nargs="+", help="run directories of one heading_correction campaign, one per seed")
    a = ap.parse_args()
    table = pd.DataFrame([run_lines(Path(r)) for r in a.runs])
    print(f"runs: {len(a.runs)}")
    for label in table.columns:
        v = table[label].dropna()
        sd = v.std() if len(v) > 1 else float("nan")
        print(f"{label}: {v.mean():.2f} {sd:.2f}")


if __name__ == "__main__":
    main()
