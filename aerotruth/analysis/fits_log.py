"""`aerotruth fits LOG --out DIR`: the WAAS-aided FITS (aerotruth.analysis.fits) on an
approach log (docs/data-formats.md, "Approach log").

Reads CSV or Parquet, checks it (one error naming the file, approach and column), runs
the FITS per approach and writes into DIR:

* trajectory.csv: approach, time_s, x_m, y_m, z_m (runway frame, eq. 19) at every WAAS epoch;
* trajectory_8hz.csv: the same on the paper's 8 Hz grid (carried by the INS between epochs);
* cyclic_noise.csv: approach, time_s, n_x_m, n_y_m, n_z_m (the estimated cyclic noise);
* bias.csv: approach, bias_x_m, bias_y_m, bias_z_m (eq. 18), jumps (flagged epochs compensated);
* where the log holds DGPS (dgps_x_m, dgps_y_m, dgps_z_m): errors.csv (FITS minus DGPS at
  the WAAS epochs, angular errors and requirement verdicts from aerotruth.analysis.ils_metrics)
  and requirement.png (cross-track and vertical errors against the 0.015/0.05 deg lines).

Handling of the log: rows are grouped by `approach` (any order of approaches); within one
approach time_s must increase strictly (unsorted or repeated times are an error, not
re-sorted); a gap (a row step or a WAAS-epoch step over 1.5 times the typical one) is an
error; WAAS columns are finite on WAAS epochs and NaN elsewhere (all three together); the
INS on every row except event rows; a receiver flag on a row between WAAS epochs belongs
to the next epoch; missing RA or TVPS near the threshold is an error (the bias cannot be
fixed). Units are checked from the physics: an approach whose WAAS ground speed (median over
its epochs) is outside 10-130 m/s is refused as not in metres (a log in km or feet), a
radar-altimeter reading below -3 m as no height (a sign or a unit), and an approach whose
WAAS height over the runway differs from the radar altimeter's (plus its lever arm) by more
than 10 m in the median (RA in feet, or z not from the threshold). A log of 3 or more
approaches whose INS columns are not in the runway frame (an axis of the other sign, two
swapped, the horizontal axes turned: aerotruth.analysis.ins_frame, from the aircraft's
motion beyond a drift) is
refused naming the columns; fewer approaches are not checked (a single approach can
mislead).

Events (the contract): `event` is empty on ordinary rows; a pilot mark is a row of its
own at its exact time with the code `thr` (threshold) or `end` (stop end), its other
columns may be NaN. The first `thr` is the threshold crossing plus the pilot's delay;
`end` marks are read but not used by the WAAS-aided FITS (the AFIS uses them). A numeric
0/1 column is also read (1 = on the first row at or after the press; the half row is
then taken off the time).

Runway geometry (localizer and glide-path antennas for the angular errors) comes from a
sidecar `<log>.runway.json` (or `<log stem>.runway.json`) or the Parquet metadata key
`runway` (keys `length_m`, `loc_x_m`, `gp_x_m`, `gp_y_m`, `glide_path_deg`, `tch_m`,
runway frame; one object for the whole log, or {"approaches": {id: object}} per
approach); without either, a 3,000 m runway with a standard installation is assumed and
said in the output.
"""

from __future__ import annotations

import difflib
import json
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.fits import FitsResult, FitsSpec, fits_approach
from aerotruth.analysis.ins_frame import frame_error
from aerotruth.analysis.ils_metrics import (FLOOR_HORIZONTAL_M, FLOOR_VERTICAL_M, REQUIREMENTS, approach_errors,
                                            approach_verdict, required_error_m)
from aerotruth.errors import DataError, output_folder
from aerotruth.files import atomic_write_bytes, atomic_write_text
from aerotruth.tables import read_csv_table
from aerotruth.units import NM

REQUIRED = ("approach", "time_s", "waas_x_m", "waas_y_m", "waas_z_m", "ins_x_m", "ins_y_m", "ins_z_m",
            "ra_m", "tvps_y_m", "event", "sv_change", "iono_update")
DGPS = ("dgps_x_m", "dgps_y_m", "dgps_z_m")
NUMERIC = REQUIRED[1:] + DGPS
EVENT_CODES = ("thr", "end")
# Ground-antenna positions when the log carries no runway geometry (runway frame): a
# localizer 300 m beyond the stop end of a 3000 m runway, the glide-path mast 300 m in and
# 120 m aside.
DEFAULT_RUNWAY = {"length_m": 3000.0, "loc_x_m": 3300.0, "gp_x_m": 300.0, "gp_y_m": -120.0, "glide_path_deg": 3.0,
                  "tch_m": 15.0}
# plausible ranges (runway frame, m and deg): a runway 0.5-6 km long, the localizer beyond
# its far threshold, the glide path antenna beside the touchdown zone, ICAO Annex 10 path
# angles and threshold crossing heights with margin
RUNWAY_RANGES = {"length_m": (500.0, 6000.0), "loc_x_m": (0.0, 8000.0), "gp_x_m": (0.0, 2000.0),
                 "gp_y_m": (-500.0, 500.0), "glide_path_deg": (1.0, 10.0), "tch_m": (0.0, 50.0)}
# An approach's median ground speed (m/s) from its WAAS epochs: flight-inspection aircraft fly
# approaches at 90-200 kt (46-103 m/s); a log in km, or in feet, moves 1000x or 3.3x off
APPROACH_SPEED_MS = (10.0, 130.0)
# A radar-altimeter reading below this (m) is no height above the runway (noise 0.15 m, a
# bias of a metre or two at most): a sign or a unit
RA_MIN_M = -3.0
# |median(WAAS z - RA - lever arm)| over the runway above this (m) is no WAAS bias (1-2 m
# 95 %, a jump of a metre or two): RA in feet, or z not from the threshold elevation
RA_WAAS_MAX_M = 10.0
OPTIONAL_NUMERIC = ("ra_lever_arm_m", "tvps_lever_arm_m")
SUMMARY_FROM_NM = 10.0  # the command line's summary: from the threshold out to this distance


def event_codes(values: pd.Series, where: str) -> pd.Series:
    """The `event` column as codes: '' on ordinary rows, 'thr' or 'end' on marks, '1' for
    a legacy numeric mark (see the module docstring)."""
    def code(v) -> str:
        if v is None or (isinstance(v, float) and np.isnan(v)):
            return ""
        t = str(v).strip().lower()
        if t in ("", "0", "0.0", "nan", "none"):
            return ""
        if t in ("1", "1.0"):
            return "1"
        if t in EVENT_CODES:
            return t
        raise DataError(f"{where}: column 'event': expected empty, 'thr' or 'end' (or 0/1), got {v!r}")
    return values.map(code)


def runway_geometry(path: Path) -> tuple[dict, str]:
    """({approach: geometry} or {None: geometry for all}, where it came from) of the log at
    `path` (module docstring): `<log>.runway.json` (or `<stem>.runway.json`) beside it, else
    the Parquet metadata key `runway`; a file may hold one geometry or
    {"approaches": {approach: geometry}}."""
    raw, src = None, ""
    for side in (path.with_name(path.name + ".runway.json"), path.with_suffix(".runway.json")):
        if side.is_file():
            try:
                raw, src = json.loads(side.read_text()), str(side)
            except json.JSONDecodeError as exc:
                raise DataError(f"{side}: not JSON ({exc.msg} at line {exc.lineno})") from None
            break
    if raw is None and path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        meta = pq.read_schema(path).metadata or {}
        if b"runway" in meta:
            src = f"{path} (metadata key 'runway')"
            try:
                raw = json.loads(meta[b"runway"])
            except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                raise DataError(f"{src}: not JSON ({getattr(exc, 'msg', exc)})") from None
    if raw is None:
        return {None: dict(DEFAULT_RUNWAY)}, "assumed (no runway geometry in the log)"
    if not isinstance(raw, dict):
        raise DataError(f"{src}: expected a JSON object with the runway geometry")
    items = raw["approaches"].items() if isinstance(raw.get("approaches"), dict) else [(None, raw)]
    out = {}
    for a, geo in items:
        where = src if a is None else f"{src}: approach {a!r}"
        if not isinstance(geo, dict):
            raise DataError(f"{where}: expected a JSON object with the runway geometry")
        for k in sorted(set(geo) - set(DEFAULT_RUNWAY)):  # other keys describe (airport, runway_frame, ...);
            near = difflib.get_close_matches(k, DEFAULT_RUNWAY, n=1, cutoff=0.8)  # a misspelt one would
            if near:  # silently leave its default in place
                raise DataError(f"{where}: unknown key {k!r}; did you mean {near[0]!r}?")
        g = dict(DEFAULT_RUNWAY)
        for k in DEFAULT_RUNWAY:
            if k in geo:
                try:
                    g[k] = float(geo[k])
                except (TypeError, ValueError):
                    raise DataError(f"{where}: key {k!r}: expected a number, got {geo[k]!r}") from None
        for k, (lo, hi) in RUNWAY_RANGES.items():
            if not lo <= g[k] <= hi:
                raise DataError(f"{where}: key {k!r}: {g[k]:g} outside [{lo:g}, {hi:g}]")
        out[a] = g
    return out, src


def geometry_of(geoms: dict, approach) -> dict | None:
    """The geometry of one approach (by its id, as text too), else the log's common one;
    None when a file of per-approach geometries has none for it."""
    for key in (approach, str(approach)):
        if key in geoms:
            return geoms[key]
    return geoms.get(None)


def read_approach_log(path: str | Path) -> pd.DataFrame:
    """The log as a DataFrame with its columns checked (names, numbers)."""
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{p}: no such file (expected an approach log, CSV or Parquet)")
    try:
        df = pd.read_parquet(p) if p.suffix.lower() in (".parquet", ".pq") else read_csv_table(p)
    except Exception as exc:  # noqa: BLE001 - any reader failure is one line about the file
        raise DataError(f"{p}: cannot be read as CSV/Parquet ({type(exc).__name__}: {str(exc).splitlines()[0]})") from None
    missing = [c for c in REQUIRED if c not in df.columns]
    if missing:
        raise DataError(f"{p}: missing column {missing[0]!r} (an approach log needs {', '.join(REQUIRED)})")
    if any(c in df.columns for c in DGPS) and not all(c in df.columns for c in DGPS):
        raise DataError(f"{p}: DGPS columns must come together ({', '.join(DGPS)})")
    if len(df) == 0:
        raise DataError(f"{p}: no rows")
    df["event"] = event_codes(df["event"], str(p))
    for c in NUMERIC + OPTIONAL_NUMERIC:
        if c != "event" and c in df.columns:
            num = pd.to_numeric(df[c], errors="coerce")
            bad = num.isna() & df[c].notna()
            if bad.any():
                raise DataError(f"{p}: column {c!r} data row {int(np.flatnonzero(bad)[0]) + 1}: expected a number, got {df[c][bad].iloc[0]!r}")
            df[c] = num.astype(float)
    if df["time_s"].isna().any():
        raise DataError(f"{p}: column 'time_s' data row {int(np.flatnonzero(df['time_s'].isna())[0]) + 1}: missing time")
    for c in ("sv_change", "iono_update"):
        v = df[c].fillna(0.0)
        if not v.isin([0.0, 1.0]).all():
            raise DataError(f"{p}: column {c!r}: expected 0/1 flags, got {v[~v.isin([0.0, 1.0])].iloc[0]!r}")
        df[c] = v
    return df


def split_events(g: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(data rows, event-only rows) of one approach: a row with an event code and neither
    WAAS nor INS positions is an event row of its own."""
    pos = g[["waas_x_m", "waas_y_m", "waas_z_m", "ins_x_m", "ins_y_m", "ins_z_m"]].to_numpy()
    own = (g["event"] != "").to_numpy() & ~np.isfinite(pos).any(axis=1)
    return g[~own], g[own]


def _check_approach(p: Path, a, g: pd.DataFrame) -> None:
    where = f"{p}: approach {a!r}"
    tt = g["time_s"].to_numpy()
    dtt = np.diff(tt)
    if len(tt) < 2 or (dtt <= 0).any():
        i = int(np.flatnonzero(dtt <= 0)[0]) + 1 if len(tt) >= 2 else 0
        raise DataError(f"{where}: column 'time_s' must increase strictly (data row {g.index[i] + 1}: {tt[i]:g} after "
                        f"{tt[max(i - 1, 0)]:g})")
    marks = g["event"].isin(["thr", "1"]).any()
    g, _ = split_events(g)
    t = g["time_s"].to_numpy()
    dt = np.diff(t)
    if len(t) < 2:
        raise DataError(f"{where}: fewer than 2 rows with positions")
    step = float(np.median(dt))
    if (dt > 1.5 * step).any():
        i = int(np.argmax(dt > 1.5 * step))
        raise DataError(f"{where}: column 'time_s' has a gap of {dt[i]:g} s after t = {t[i]:g} s (rows every {step:g} s)")
    w = g[["waas_x_m", "waas_y_m", "waas_z_m"]].to_numpy()
    fin = np.isfinite(w)
    if (fin.any(axis=1) != fin.all(axis=1)).any():
        raise DataError(f"{where}: columns waas_x_m/waas_y_m/waas_z_m must be all finite or all NaN on a row")
    tw = t[fin[:, 0]]
    if len(tw) < 2:
        raise DataError(f"{where}: columns waas_*: fewer than 2 WAAS epochs")
    dtw = np.diff(tw)
    if (dtw > 1.5 * np.median(dtw)).any():
        i = int(np.argmax(dtw > 1.5 * np.median(dtw)))
        raise DataError(f"{where}: columns waas_*: a gap of {dtw[i]:g} s between WAAS epochs after t = {tw[i]:g} s")
    if np.median(dtw) > 1.0 + 1e-6:
        raise DataError(f"{where}: columns waas_*: WAAS epochs every {np.median(dtw):g} s; expected 1 Hz or faster")
    ins = g[["ins_x_m", "ins_y_m", "ins_z_m"]].to_numpy()
    fin_i = np.isfinite(ins).all(axis=1)
    if not fin_i.all():
        i = int(np.flatnonzero(~fin_i)[0])
        raise DataError(f"{where}: columns ins_*: data row {g.index[i] + 1} (t = {t[i]:g} s): the INS position must be "
                        f"finite on every row (event rows of their own excepted)")
    ww = w[fin[:, 0]]  # WAAS, not the INS: a poor INS may drift by kilometres in an approach
    held = (np.diff(ww, axis=0) == 0).all(axis=1)  # a moving aircraft's fixes never repeat exactly
    if held.mean() > 0.5:
        raise DataError(f"{where}: columns waas_*: the WAAS position repeats unchanged on {100 * held.mean():.0f} % of "
                        f"its rows (held between the receiver's epochs?); expected values at the WAAS epochs only "
                        f"and NaN between them")
    speed = float(np.median(np.hypot(np.diff(ww[:, 0]), np.diff(ww[:, 1])) / dtw))
    lo, hi = APPROACH_SPEED_MS
    if not lo <= speed <= hi:
        raise DataError(f"{where}: columns waas_x_m/waas_y_m: the aircraft moves at {speed:.3g} m/s (median over the "
                        f"WAAS epochs); expected an approach at {lo:g}-{hi:g} m/s: are the positions in metres?")
    ra = g["ra_m"].to_numpy()
    with np.errstate(invalid="ignore"):
        low = ra < RA_MIN_M
    if low.any():
        i = int(np.flatnonzero(low)[0])
        raise DataError(f"{where}: column 'ra_m' data row {g.index[i] + 1}: {ra[i]:g} m; a radar-altimeter height "
                        f"above the runway cannot be below {RA_MIN_M:g} m (sign? units?)")
    lever = g["ra_lever_arm_m"].to_numpy(dtype=float) if "ra_lever_arm_m" in g.columns else np.zeros(len(g))
    both = fin[:, 2] & np.isfinite(ra) & np.isfinite(lever)
    if both.sum() >= 3:  # the WAAS height over the runway against the RA's: WAAS is good to metres
        gap = float(np.median(w[both, 2] - ra[both] - lever[both]))
        if abs(gap) > RA_WAAS_MAX_M:
            raise DataError(f"{where}: column 'ra_m': the WAAS height is {gap:+.1f} m off the radar altimeter's over the "
                            f"runway (median of {int(both.sum())} epochs); WAAS is good to a few metres: is ra_m in feet, "
                            f"or the log's z not from the threshold?")
    if not marks:
        raise DataError(f"{where}: column 'event': no threshold mark ('thr')")


@dataclass
class ApproachInputs:
    """One approach's log as the FITS takes it: WAAS epochs and their flags, the INS at
    those epochs and at every row, the radar altimeter and TVPS rows with their lever arms
    (None: the log gives none), the pilot's threshold mark, and the rows' DGPS (NaN where
    the log has none) at the WAAS epochs."""

    t_w: np.ndarray
    waas: np.ndarray
    ins_w: np.ndarray
    flags: np.ndarray
    t_rows: np.ndarray
    ins_rows: np.ndarray
    ra: np.ndarray
    tvps: np.ndarray
    t_mark: float
    ra_lever: np.ndarray | None
    tvps_lever: np.ndarray | None
    dgps_w: np.ndarray  # DGPS at the WAAS epochs
    dgps_rows: np.ndarray  # DGPS at every row (NaN where the log has none)


def approach_inputs(g: pd.DataFrame) -> ApproachInputs:
    """The FITS inputs of one approach's rows (already checked; event rows of their own allowed)."""
    ev = g["event"].to_numpy(dtype=object)
    col = {c: g[c].to_numpy(dtype=float) for c in ("time_s", "waas_x_m", "waas_y_m", "waas_z_m", "ins_x_m", "ins_y_m",
                                                    "ins_z_m", "ra_m", "tvps_y_m", "sv_change", "iono_update")}
    ins = np.column_stack([col["ins_x_m"], col["ins_y_m"], col["ins_z_m"]])
    waas = np.column_stack([col["waas_x_m"], col["waas_y_m"], col["waas_z_m"]])
    keep = (ev == "") | np.isfinite(np.hstack([ins, waas])).any(axis=1)  # event rows of their own off
    t = col["time_s"][keep]
    row_dt = float(np.median(np.diff(t)))
    ins, waas = ins[keep], waas[keep]
    is_w = np.isfinite(waas[:, 0])
    tw = t[is_w]
    flag_rows = (col["sv_change"][keep] > 0) | (col["iono_update"][keep] > 0)
    flags = np.zeros(len(tw), np.int8)
    k = np.searchsorted(tw, t[flag_rows], side="left")  # a flag between epochs: the next epoch
    flags[k[k < len(tw)]] = 1
    marks = np.flatnonzero((ev == "thr") | (ev == "1"))
    first = marks[np.argmin(col["time_s"][marks])]
    t_mark = float(col["time_s"][first]) - (0.5 * row_dt if ev[first] == "1" else 0.0)
    ra_lever = g["ra_lever_arm_m"].to_numpy(dtype=float)[keep] if "ra_lever_arm_m" in g.columns else None
    tvps_lever = g["tvps_lever_arm_m"].to_numpy(dtype=float)[keep] if "tvps_lever_arm_m" in g.columns else None
    dgps = (g[list(DGPS)].to_numpy(dtype=float)[keep] if all(c in g.columns for c in DGPS)
            else np.full((len(t), 3), np.nan))
    return ApproachInputs(tw, waas[is_w], ins[is_w], flags, t, ins, col["ra_m"][keep], col["tvps_y_m"][keep], t_mark,
                          ra_lever, tvps_lever, dgps[is_w], dgps)


def _at(t_rows: np.ndarray, rows: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Columns of `rows` (n, 3) linearly interpolated at times t (held at the ends); NaN
    where a neighbouring row is NaN."""
    i = np.clip(np.searchsorted(t_rows, t), 1, len(t_rows) - 1)
    w = np.clip((t - t_rows[i - 1]) / (t_rows[i] - t_rows[i - 1]), 0.0, 1.0)[:, None]
    return (1.0 - w) * rows[i - 1] + w * rows[i]


def retagged(a: ApproachInputs, latency_s: float) -> ApproachInputs:
    """The inputs with each WAAS epoch put at its time tag minus `latency_s` (a receiver
    that stamps its positions that late): the INS and the DGPS taken at the new times from
    their rows. The same inputs when the latency is 0."""
    if latency_s == 0.0:
        return a
    t_w = a.t_w - latency_s
    return replace(a, t_w=t_w, ins_w=_at(a.t_rows, a.ins_rows, t_w), dgps_w=_at(a.t_rows, a.dgps_rows, t_w))


def fits_of(a: ApproachInputs, spec: FitsSpec, extra_flags: np.ndarray | None = None) -> FitsResult:
    """The FITS (analysis.fits.fits_approach) on an approach's inputs; `extra_flags` adds
    flagged WAAS epochs (a jump diagnose found)."""
    flags = a.flags if extra_flags is None else np.maximum(a.flags, extra_flags)
    return fits_approach(a.t_w, a.waas, a.ins_w, flags, a.t_rows, a.ins_rows, a.ra, a.tvps, a.t_mark, spec,
                         ra_lever_m=a.ra_lever, tvps_lever_m=a.tvps_lever)


def run_approach(g: pd.DataFrame, spec: FitsSpec) -> FitsResult:
    """The FITS on one approach's rows (already checked; event rows of their own allowed),
    its WAAS epochs re-tagged by spec.waas_latency_s."""
    return fits_of(retagged(approach_inputs(g), spec.waas_latency_s), spec)


def _requirement_figure(errors: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    d_nm = errors["distance_to_threshold_m"] / NM
    for ax, col, rng_col, floor, label in ((axes[0], "cross_m", "range_loc_m", FLOOR_HORIZONTAL_M, "cross-track"),
                                           (axes[1], "vertical_m", "range_gp_m", FLOOR_VERTICAL_M, "vertical")):
        for a, e in errors.groupby("approach"):
            ax.plot(d_nm[e.index], e[col], lw=0.8, label=f"approach {a}" if errors["approach"].nunique() <= 8 else None)
        order = np.argsort(d_nm.to_numpy())
        for name, alpha in REQUIREMENTS.items():
            req = required_error_m(errors[rng_col].to_numpy()[order], alpha, floor)
            ls = "--" if name == "desired" else "-"
            ax.plot(d_nm.to_numpy()[order], req, "k", ls=ls, lw=1, label=f"{alpha} deg ({name})")
            ax.plot(d_nm.to_numpy()[order], -req, "k", ls=ls, lw=1)
        lim = max(1.0, 3.0 * float(np.nanpercentile(np.abs(errors[col]), 99)))
        ax.set(ylabel=f"{label} error (m)", title=f"WAAS-aided FITS minus DGPS, {label}", ylim=(-lim, lim))
        ax.legend(fontsize=7, loc="upper right")
    axes[1].set_xlabel("distance to threshold (NM)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def fits_main(log_path: str, out_dir: str, spec: FitsSpec | None = None) -> int:
    """Run the FITS on every approach of the log at `log_path`; write the files listed in
    the module docstring into `out_dir`. Bad input raises DataError (a ValueError) with one
    line naming the file, approach and column."""
    spec = spec or FitsSpec()
    p, out = Path(log_path), output_folder(out_dir)  # the output checked before the work
    df = read_approach_log(p)
    has_dgps = all(c in df.columns for c in DGPS) and np.isfinite(df[list(DGPS)].to_numpy()).any()
    geoms, geom_src = runway_geometry(p)
    missing = [a for a in df["approach"].unique() if geometry_of(geoms, a) is None]
    if missing:  # a file of per-approach geometries: every approach of the log needs its own
        a = missing[0].item() if isinstance(missing[0], np.generic) else missing[0]
        raise DataError(f"{geom_src}: no runway geometry for approach {a!r} (it has "
                        f"{', '.join(map(str, geoms))}); give every approach one, or one for the whole log")
    approaches = []
    for a, g in df.groupby("approach", sort=False):
        _check_approach(p, a, g)
        approaches.append((a, g, retagged(approach_inputs(g), spec.waas_latency_s)))
    fe = frame_error([inputs for _, _, inputs in approaches])  # needs 3 approaches: a single one can mislead
    if fe is not None:
        raise DataError(f"{p}: columns ins_x_m/ins_y_m/ins_z_m: {'; '.join(fe.said())} (beyond a drift the INS follows "
                        f"the aircraft's motion as the WAAS sees it with loadings {fe.loads()}, over {len(approaches)} "
                        "approaches); expected the runway frame, x along the course, y left, z up")
    traj, grid, noise, bias, errs = [], [], [], [], []
    for a, g, inputs in approaches:
        try:
            r = fits_of(inputs, spec)
        except ValueError as exc:
            raise DataError(f"{p}: approach {a!r}: {exc}") from None
        nl = r.noiseless
        g, _ = split_events(g)
        traj.append(pd.DataFrame({"approach": a, "time_s": nl.t_s, "x_m": r.xyz_m[:, 0], "y_m": r.xyz_m[:, 1], "z_m": r.xyz_m[:, 2]}))
        tg, pg = r.on_grid(g["time_s"].to_numpy(), g[["ins_x_m", "ins_y_m", "ins_z_m"]].to_numpy(), spec.grid_rate_hz)
        grid.append(pd.DataFrame({"approach": a, "time_s": tg, "x_m": pg[:, 0], "y_m": pg[:, 1], "z_m": pg[:, 2]}))
        noise.append(pd.DataFrame({"approach": a, "time_s": nl.t_s, "n_x_m": nl.n_hat[:, 0], "n_y_m": nl.n_hat[:, 1], "n_z_m": nl.n_hat[:, 2]}))
        bias.append({"approach": a, "bias_x_m": r.bias_m[0], "bias_y_m": r.bias_m[1], "bias_z_m": r.bias_m[2], "jumps": len(nl.jump_idx)})
        if has_dgps:
            d = inputs.dgps_w  # at the (re-tagged) WAAS epochs
            ok = np.isfinite(d).all(axis=1)
            if ok.any():
                geom = geometry_of(geoms, a)
                e = approach_errors(d[ok, 0], r.xyz_m[ok], d[ok], loc_x_m=geom["loc_x_m"], gp_x_m=geom["gp_x_m"],
                                    gp_y_m=geom["gp_y_m"])
                e.insert(0, "time_s", nl.t_s[ok])
                e.insert(0, "approach", a)
                errs.append(e)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "trajectory.csv", pd.concat(traj, ignore_index=True).to_csv(index=False))
    atomic_write_text(out / "trajectory_8hz.csv", pd.concat(grid, ignore_index=True).to_csv(index=False))
    atomic_write_text(out / "cyclic_noise.csv", pd.concat(noise, ignore_index=True).to_csv(index=False))
    atomic_write_text(out / "bias.csv", pd.DataFrame(bias).to_csv(index=False))
    epochs = sum(len(t) for t in traj)
    jumps = sum(b["jumps"] for b in bias)
    print(f"{p}: {len(traj)} approaches, {epochs} WAAS epochs, {jumps} flagged bias jumps compensated -> "
          f"{out / 'trajectory.csv'}")
    if errs:
        errors = pd.concat(errs, ignore_index=True)
        atomic_write_text(out / "errors.csv", errors.to_csv(index=False))
        print(f"runway geometry for the angular errors: {geom_src}")
        verdicts = [approach_verdict(e, SUMMARY_FROM_NM) for e in errs]  # errs: one frame per approach
        met = {f"{axis}_{name}": sum(v[f"{axis}_meets_{name}"] for v in verdicts)
               for axis in ("cross", "vertical") for name in REQUIREMENTS}
        d = errors["distance_to_threshold_m"].to_numpy()
        inside = errors[(d >= 0.0) & (d <= SUMMARY_FROM_NM * NM)]
        print(f"FITS - DGPS, threshold to {SUMMARY_FROM_NM:g} nm: cross-track RMS {np.sqrt(np.mean(inside['cross_m'] ** 2)):.2f} m, "
              f"vertical RMS {np.sqrt(np.mean(inside['vertical_m'] ** 2)):.2f} m; approaches meeting "
              + ", ".join(f"{name} ({REQUIREMENTS[name]:g} deg) cross {met['cross_' + name]}/{len(verdicts)} vertical "
                          f"{met['vertical_' + name]}/{len(verdicts)}" for name in REQUIREMENTS)
              + f" -> {out / 'errors.csv'}")
        tmp = out / "requirement.png.part.png"
        _requirement_figure(errors, tmp)
        atomic_write_bytes(out / "requirement.png", tmp.read_bytes())
        tmp.unlink()
    return 0
