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
  DIR/apply.csv: per aircraft (then `all`) the reports scored and the wind error against
      the references before and after (RMS, longitudinal, transverse, kt; wind paper
      section 6), the table's status and validity dates, and `in_sample` where the reports'
      dates overlap the dates the table was fitted on (an in-sample score flatters it);
  DIR/figures/apply.png: before/after RMS per aircraft (wind paper Fig. 9's bars);
  DIR/report.md.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.heading_correction import FleetHeadingFit
from aerotruth.analysis.heading_errors import heading_errors, towards_from_report
from aerotruth.analysis.heading_fit import read_observation_table, require_used_reports, table_kind
from aerotruth.analysis.wind_metrics import heading_turn, wind_errors_before_after
from aerotruth.errors import DataError, output_folder
from aerotruth.files import atomic_write, atomic_write_text
from aerotruth.markdown import to_markdown
from aerotruth.tables import read_csv_table
from aerotruth.units import DEG, KT

APPLY_COLUMNS = ("aircraft", "status", "n_scored", "rms_before_kt", "rms_after_kt", "longitudinal_before_kt",
                 "longitudinal_after_kt", "transverse_before_kt", "transverse_after_kt", "valid_from", "valid_to",
                 "in_sample")


def read_tables(path: str | Path) -> FleetHeadingFit:
    """The deviation tables of `aerotruth heading fit` (deviation.csv or deviation_mag.csv);
    DataError naming the file on anything else."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file (expected the deviation.csv of `aerotruth heading fit`)")
    try:
        table = read_csv_table(path) if path.suffix.lower() != ".parquet" else pd.read_parquet(path)
    except Exception as e:  # noqa: BLE001 - pandas/pyarrow's many error types: one line naming the file
        raise DataError(f"{path}: not a readable table ({str(e).splitlines()[0]})") from None
    if len(table) == 0:
        raise DataError(f"{path}: no rows")
    twice = table["aircraft"][table["aircraft"].duplicated()] if "aircraft" in table.columns else []
    if len(twice):
        raise DataError(f"{path}: aircraft {twice.iloc[0]!r} has two tables")
    try:
        fleet = FleetHeadingFit.from_table(table)
    except (ValueError, KeyError, TypeError) as e:
        raise DataError(f"{path}: {e}") from None
    frames = {f.heading for f in fleet.fits_.values()}
    if len(frames) > 1:
        raise DataError(f"{path}: column 'heading_frame' mixes {sorted(frames)}; expected one frame per file")
    return fleet


def table_frame(fleet: FleetHeadingFit) -> str:
    """The heading the tables are indexed by ("true" or "magnetic"; one per file, read_tables)."""
    return next(iter(fleet.fits_.values())).heading if fleet.fits_ else "true"


def corrected_wind(wt_e: np.ndarray, wt_n: np.ndarray, va_e: np.ndarray, va_n: np.ndarray,
                   correction_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The wind (towards east, north; the units of the inputs) recomputed with the heading
    turned clockwise by c: V_W' = V_W + V_A - R(c) V_A (wind paper eq. 1)."""
    c = np.asarray(correction_deg, dtype=float) * DEG
    e, n = heading_turn(va_e, va_n, np.sin(c), np.cos(c))
    return wt_e + e, wt_n + n


def _speed_from(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speed (kt) and meteorological direction ("from", deg in [0, 360)) of a wind (m/s)."""
    return np.hypot(u, v) / KT, np.degrees(np.arctan2(-u, -v)) % 360.0


def heading_apply(obs: pd.DataFrame, fleet: FleetHeadingFit, source: str = "observation table"
                  ) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(the rows of `obs`, validated and in its order, with the correction columns; the
    per-aircraft scores, APPLY_COLUMNS). `obs` as validate_observations returns it."""
    rows = heading_errors(obs, source=source)
    require_used_reports(rows, source)
    frame = table_frame(fleet)
    col = "heading_deg" if frame == "true" else "heading_mag_deg"
    z = rows[col].to_numpy()
    used = (rows["gate"] == "used").to_numpy()
    if frame == "magnetic" and not np.isfinite(z[used]).any():
        raise DataError(f"{source}: the tables are indexed by magnetic heading (heading_frame magnetic); the table needs "
                        "a 'heading_mag_deg' or 'declination_deg' column")
    names = obs["aircraft"].astype(str).to_numpy()
    has_table = np.isin(names, [n for n, f in fleet.fits_.items() if f.status_ != "refused"])
    ok = used & np.isfinite(z) & has_table
    corr = np.zeros(len(rows))
    corr[ok] = fleet.correction(names[ok], z[ok])
    # V_A: the aircraft's own TAS and heading where given, else eq. 3's V_G - V_W,TAM
    va_e, va_n = rows["va_e"].to_numpy().copy(), rows["va_n"].to_numpy().copy()
    if "tas_kt" in obs.columns and "heading_deg" in obs.columns:
        tas, hdg = obs["tas_kt"].to_numpy() * KT, obs["heading_deg"].to_numpy() * DEG
        own = np.isfinite(tas) & np.isfinite(hdg)
        va_e[own], va_n[own] = tas[own] * np.sin(hdg[own]), tas[own] * np.cos(hdg[own])
    wt_e, wt_n = towards_from_report(obs["wind_speed_kt"].to_numpy(), obs["wind_dir_deg"].to_numpy())
    we, wn = corrected_wind(wt_e, wt_n, va_e, va_n, corr)
    speed, direction = _speed_from(we, wn)
    out = pd.DataFrame({"gate": rows["gate"].astype(str).to_numpy(), "corrected": ok,
                        "table_heading_deg": np.where(ok, z, np.nan), "correction_deg": corr,
                        "wind_speed_kt_corrected": np.where(ok, speed, obs["wind_speed_kt"].to_numpy()),
                        "wind_dir_deg_corrected": np.where(ok, direction, obs["wind_dir_deg"].to_numpy())})
    # scores on the reports the method uses: wind error against the reference, before and
    # after (the method's rows with this V_A)
    scored = rows[["heading_deg", "dw_e", "dw_n"]].assign(va_e=va_e, va_n=va_n)
    scores = []
    # per aircraft, then the fleet's row "all" (always the last: an aircraft may be named "all")
    groups = [(str(a), used & (names == a), False) for a in pd.unique(names)] + [("all", used, True)]
    for name, sel, whole_fleet in groups:
        fit = None if whole_fleet else fleet.fits_.get(name)
        b, a = wind_errors_before_after(scored[sel], corr[sel])
        t = obs["time_s"].to_numpy()[sel]
        in_sample = ""
        if fit is not None and len(t):
            lo, hi = pd.Timestamp(fit.valid_from_, tz="UTC"), pd.Timestamp(fit.valid_to_, tz="UTC") + pd.Timedelta(days=1)
            first, last = pd.Timestamp(t.min(), unit="s", tz="UTC"), pd.Timestamp(t.max(), unit="s", tz="UTC")
            in_sample = bool(first < hi and last >= lo)
        status = (fit.status_ if fit is not None else ("" if whole_fleet else "no table"))
        scores.append({"aircraft": name, "status": status, "n_scored": int(sel.sum()),
                       "rms_before_kt": b["rms_kt"], "rms_after_kt": a["rms_kt"],
                       "longitudinal_before_kt": b["longitudinal_kt"], "longitudinal_after_kt": a["longitudinal_kt"],
                       "transverse_before_kt": b["transverse_kt"], "transverse_after_kt": a["transverse_kt"],
                       "valid_from": fit.valid_from_ if fit is not None else "",
                       "valid_to": fit.valid_to_ if fit is not None else "", "in_sample": in_sample})
    return out, pd.DataFrame(scores, columns=list(APPLY_COLUMNS))


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
    lines = [f"# Heading tables applied: {src}", "",
             f"Tables: `{tables}` (indexed by {frame} heading). {int(out['corrected'].sum())} of {len(out)} (report, "
             f"reference) rows corrected; {int((out['gate'] != 'used').sum())} outside the method's gates and left as "
             "reported.", "", to_markdown(scores), "", "![before/after per aircraft](figures/apply.png)", ""]
    if (scores["in_sample"] == True).any():  # noqa: E712 - object column of bools and ""
        lines += ["In sample: these reports' dates overlap the dates the tables were fitted on; the after column "
                  "then flatters the tables. Judge them on a later period, with a control group of aircraft "
                  "without tables to take out the model's own change (the wind paper's Tables I-IV).", ""]
    return "\n".join(lines)


def heading_apply_main(obs_path: str, tables_path: str, out_dir: str) -> int:
    """Apply the tables to an observation table and write DIR/corrected.*, apply.csv, the
    figure and report.md. Returns 0; bad input raises DataError with one line."""
    out = output_folder(out_dir)  # before the work
    fleet = read_tables(tables_path)
    obs = read_observation_table(obs_path)
    corrected, scores = heading_apply(obs, fleet, str(obs_path))
    (out / "figures").mkdir(parents=True, exist_ok=True)
    raw = obs.drop(columns=["time_s"]).assign(time=obs["time_s"].to_numpy())
    table = pd.concat([raw.reset_index(drop=True), corrected], axis=1)
    if table_kind(Path(obs_path)) == "csv":
        atomic_write_text(out / "corrected.csv", table.to_csv(index=False))
    else:
        atomic_write(out / "corrected.parquet", lambda tmp: table.to_parquet(tmp, index=False))
    atomic_write_text(out / "apply.csv", scores.to_csv(index=False))
    _figure(scores, out / "figures" / "apply.png")
    atomic_write_text(out / "report.md", _report(str(obs_path), str(tables_path), table_frame(fleet), scores, corrected))
    every = scores.iloc[-1]  # the fleet's row
    print(f"{obs_path}: {len(scores) - 1} aircraft, {int(every['n_scored'])} scored (report, reference) rows; wind RMS "
          f"{every['rms_before_kt']:.2f} -> {every['rms_after_kt']:.2f} kt with the tables of {tables_path} -> {out / 'apply.csv'}")
    return 0
