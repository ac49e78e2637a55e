"""`aerotruth heading apply OBS --tables DEVIATION.csv --out DIR`: the other half of the
wind paper's method on a user's own data — the lookup tables that `aerotruth heading fit`
learned on one period, applied to the reports of another, as the onboard table would have
corrected them (fit on one period, correct another; the tables are read, not refitted).
The reports must have been made without these tables (a period before the upload, or to
see what an upload would do): reports already corrected onboard would be corrected twice.

Per (report, reference) row: the measured heading z' in the table's frame (`heading_frame`
of the deviation file: the true measured heading, or the magnetic one from
`heading_mag_deg` / `declination_deg`), the table's correction c(z') (8 points, linear
round the circle, wind paper section 8.1) and the wind recomputed with the heading
turned by c (wind paper eq. 1 with the rotated air vector):

    V_W' = V_W,TAM + V_A - R(c) V_A

V_A is the aircraft's air vector: TAS and measured true heading where the table has
`tas_kt` and `heading_deg`, else V_G - V_W,TAM from the three-report ground track (eq. 3).
Reports are scored and corrected where the method uses them (the ground-track gates, the
roll and plausibility limits: `gate` = used); the others are carried through uncorrected
(`corrected` false), as are aircraft without a fitted or offset table.

Writes
  DIR/corrected.csv (or .parquet, as OBS): the table as the method reads it (its columns
      of docs/data-formats.md, `time` in UTC epoch seconds, rows sorted by aircraft, time
      and reference, rows with an empty required cell left out), then `gate`,
      `corrected`, `table_heading_deg` (the measured heading the table was read at, in its
      frame), `correction_deg`, `wind_speed_kt_corrected`, `wind_dir_deg_corrected`;
  DIR/apply.csv: per aircraft (then `all`: the aircraft with a table) the reports scored and the wind error against
      the references before and after (RMS, longitudinal, transverse, kt; wind paper
      section 6), the table's status and validity dates, and `in_sample` where the reports'
      times overlap the fit's first to last report (deviation.csv's data_from, data_to;
      tables without them: the validity dates) (an in-sample score flatters it);
  DIR/figures/apply.png: before/after RMS per aircraft (wind paper Fig. 9's bars);
  DIR/report.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.wind.apply import heading_apply, table_frame
from aerotruth.analysis.wind.heading_errors import data_gates
from aerotruth.app.reports import observations_or_traffic_hint
from aerotruth.errors import output_folder
from aerotruth.files import atomic_write, atomic_write_text
from aerotruth.markdown import to_markdown
from aerotruth.measured.deviation_tables import read_tables
from aerotruth.measured.observations import table_kind


def _figure(scores: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s = scores.iloc[:-1].reset_index(drop=True)  # the aircraft, not the fleet's last row
    fig, ax = plt.subplots(figsize=(max(5.0, 0.45 * len(s) + 2), 3.8))
    x = np.arange(len(s))
    ax.bar(x - 0.2, s["rms_before_kt"], 0.4, color="#7b1f2b", label="without the tables")
    ax.bar(x + 0.2, s["rms_after_kt"], 0.4, color="#2e8b57", label="with the tables")
    ax.set_xticks(x, s["aircraft"], rotation=60, fontsize=7)
    ax.set_ylabel("RMS vector difference (kt)")
    ax.set_title("Wind error against the references, per aircraft (wind paper Fig. 9)", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(axis="y", alpha=0.3)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def _report(src: str, tables: str, frame: str, scores: pd.DataFrame, out: pd.DataFrame) -> str:
    lines = [
        f"# Heading tables applied: {src}",
        "",
        f"Tables: `{tables}` (indexed by {frame} heading). {int(out['corrected'].sum())} of {len(out)} (report, "
        f"reference) rows corrected; {int((out['gate'] != 'used').sum())} outside the method's gates and left as "
        "reported.",
        "",
        to_markdown(scores),
        "",
        "![before/after per aircraft](figures/apply.png)",
        "",
    ]
    if (scores["in_sample"] == True).any():  # noqa: E712 - object column of bools and ""
        lines += [
            "In sample: these reports' times overlap the data the tables were fitted on; the after column "
            "then flatters the tables. Judge them on a later period, with a control group of aircraft "
            "without tables to take out the model's own change (the wind paper's Tables I-IV).",
            "",
        ]
    return "\n".join(lines)


def heading_apply_main(obs_path: str, tables_path: str, out_dir: str) -> int:
    """Apply the tables to an observation table and write DIR/corrected.*, apply.csv, the
    figure and report.md. Returns 0; bad input raises DataError with one line."""
    out = output_folder(out_dir)  # before the work
    fleet = read_tables(tables_path)
    obs = observations_or_traffic_hint(obs_path)
    gates = data_gates(obs).gates  # the position resolution of these reports, read off them
    corrected, scores = heading_apply(obs, fleet, str(obs_path), gates)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    raw = obs.drop(columns=["time_s"]).assign(time=obs["time_s"].to_numpy())
    table = pd.concat([raw.reset_index(drop=True), corrected], axis=1)
    if table_kind(Path(obs_path)) == "csv":
        atomic_write_text(out / "corrected.csv", table.to_csv(index=False))
    else:
        atomic_write(out / "corrected.parquet", lambda tmp: table.to_parquet(tmp, index=False))
    atomic_write_text(out / "apply.csv", scores.to_csv(index=False))
    _figure(scores, out / "figures" / "apply.png")
    atomic_write_text(
        out / "report.md", _report(str(obs_path), str(tables_path), table_frame(fleet), scores, corrected)
    )
    every = scores.iloc[-1]  # the fleet's row: the aircraft with a table
    gain = (
        f"wind RMS {every['rms_before_kt']:.2f} -> {every['rms_after_kt']:.2f} kt"
        if every["n_scored"]
        else "no aircraft has a fitted or offset table (every table refused: see apply.csv), nothing corrected"
    )
    print(
        f"{obs_path}: {len(scores) - 1} aircraft, {int(every['n_scored'])} scored (report, reference) rows of "
        f"aircraft with a table; {gain} with the tables of {tables_path} -> {out / 'apply.csv'}"
    )
    return 0
