"""The approach log (docs/data-formats.md, "Approach log") as the FITS takes it: its
columns and codes, the checks of one approach's rows against the physics (one DataError
naming the log, approach and column), and the FITS inputs of an approach.

The contract: rows are grouped by `approach` (any order of approaches); within one
approach time_s must increase strictly (unsorted or repeated times are an error, not
re-sorted); a gap (a row step or a WAAS-epoch step over 1.5 times the typical one) is an
error; WAAS columns are finite on WAAS epochs and NaN elsewhere (all three together); the
INS on every row except event rows; a receiver flag on a row between WAAS epochs belongs
to the next epoch; missing RA or TVPS near the threshold is an error (the bias cannot be
fixed). Units are checked from the physics: an approach whose WAAS ground speed (median over
its epochs) is outside 10-130 m/s is refused as not in metres (a log in km or feet), a
radar-altimeter reading below -3 m as no height (a sign or a unit), and an approach whose
WAAS height over the runway differs from the radar altimeter's (plus its lever arm) by more
than 10 m in the median (RA in feet, or z not from the threshold).

Events: `event` is empty on ordinary rows; a pilot mark is a row of its own at its exact
time with the code `thr` (threshold) or `end` (stop end), its other columns may be NaN. The
first `thr` is the threshold crossing plus the pilot's delay; `end` marks are read but not
used by the WAAS-aided FITS (the AFIS uses them). A numeric 0/1 column is also read (1 = on
the first row at or after the press; the half row is then taken off the time).

Runway geometry (localizer and glide-path antennas for the angular errors): keys
`length_m`, `loc_x_m`, `gp_x_m`, `gp_y_m`, `glide_path_deg`, `tch_m` in the runway frame;
DEFAULT_RUNWAY where a log gives none (read by aerotruth.measured.approach_log).
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from typing import TypeVar

import numpy as np
import pandas as pd

from aerotruth.analysis.fits.filter import FitsResult, FitsSpec, fits_approach
from aerotruth.contracts import (
    APPROACH_LOG_DGPS,
    APPROACH_LOG_OPTIONAL_NUMERIC,
    APPROACH_LOG_REQUIRED,
)
from aerotruth.errors import DataError

REQUIRED = APPROACH_LOG_REQUIRED
DGPS = APPROACH_LOG_DGPS
NUMERIC = REQUIRED[1:] + DGPS
EVENT_CODES = ("thr", "end")
# Ground-antenna positions when the log carries no runway geometry (runway frame): a
# localizer 300 m beyond the stop end of a 3000 m runway, the glide-path mast 300 m in and
# 120 m aside.
DEFAULT_RUNWAY = {
    "length_m": 3000.0,
    "loc_x_m": 3300.0,
    "gp_x_m": 300.0,
    "gp_y_m": -120.0,
    "glide_path_deg": 3.0,
    "tch_m": 15.0,
}
# plausible ranges (runway frame, m and deg): a runway 0.5-6 km long, the localizer beyond
# its far threshold, the glide path antenna beside the touchdown zone, ICAO Annex 10 path
# angles and threshold crossing heights with margin
RUNWAY_RANGES = {
    "length_m": (500.0, 6000.0),
    "loc_x_m": (0.0, 8000.0),
    "gp_x_m": (0.0, 2000.0),
    "gp_y_m": (-500.0, 500.0),
    "glide_path_deg": (1.0, 10.0),
    "tch_m": (0.0, 50.0),
}
# An approach's median ground speed (m/s) from its WAAS epochs: flight-inspection aircraft fly
# approaches at 90-200 kt (46-103 m/s); a log in km, or in feet, moves 1000x or 3.3x off
APPROACH_SPEED_MS = (10.0, 130.0)
# A radar-altimeter reading below this (m) is no height above the runway (noise 0.15 m, a
# bias of a metre or two at most): a sign or a unit
RA_MIN_M = -3.0
# |median(WAAS z - RA - lever arm)| over the runway above this (m) is no WAAS bias (1-2 m
# 95 %, a jump of a metre or two): RA in feet, or z not from the threshold elevation
RA_WAAS_MAX_M = 10.0
OPTIONAL_NUMERIC = APPROACH_LOG_OPTIONAL_NUMERIC


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


def geometry_of(geoms: dict, approach) -> dict | None:
    """The geometry of one approach (by its id, as text too), else the log's common one;
    None when a file of per-approach geometries has none for it."""
    for key in (approach, str(approach)):
        if key in geoms:
            return geoms[key]
    return geoms.get(None)


def split_events(g: pd.DataFrame) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(data rows, event-only rows) of one approach: a row with an event code and neither
    WAAS nor INS positions is an event row of its own."""
    pos = g[["waas_x_m", "waas_y_m", "waas_z_m", "ins_x_m", "ins_y_m", "ins_z_m"]].to_numpy()
    own = (g["event"] != "").to_numpy() & ~np.isfinite(pos).any(axis=1)
    return g[~own], g[own]


def check_approach(p, a, g: pd.DataFrame) -> None:
    """One approach's rows (`g`, approach `a` of the log `p`) against the contract (module
    docstring): DataError naming the log, the approach and the column."""
    where = f"{p}: approach {a!r}"
    tt = g["time_s"].to_numpy()
    dtt = np.diff(tt)
    if len(tt) < 2 or (dtt <= 0).any():
        i = int(np.flatnonzero(dtt <= 0)[0]) + 1 if len(tt) >= 2 else 0
        raise DataError(
            f"{where}: column 'time_s' must increase strictly (data row {g.index[i] + 1}: {tt[i]:g} after "
            f"{tt[max(i - 1, 0)]:g})"
        )
    marks = g["event"].isin(["thr", "1"]).any()
    g, _ = split_events(g)
    t = g["time_s"].to_numpy()
    dt = np.diff(t)
    if len(t) < 2:
        raise DataError(f"{where}: fewer than 2 rows with positions")
    step = float(np.median(dt))
    if (dt > 1.5 * step).any():
        i = int(np.argmax(dt > 1.5 * step))
        raise DataError(
            f"{where}: column 'time_s' has a gap of {dt[i]:g} s after t = {t[i]:g} s (rows every {step:g} s)"
        )
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
        raise DataError(
            f"{where}: columns ins_*: data row {g.index[i] + 1} (t = {t[i]:g} s): the INS position must be "
            f"finite on every row (event rows of their own excepted)"
        )
    ww = w[fin[:, 0]]  # WAAS, not the INS: a poor INS may drift by kilometres in an approach
    held = (np.diff(ww, axis=0) == 0).all(axis=1)  # a moving aircraft's fixes never repeat exactly
    if held.mean() > 0.5:
        raise DataError(
            f"{where}: columns waas_*: the WAAS position repeats unchanged on {100 * held.mean():.0f} % of "
            f"its rows (held between the receiver's epochs?); expected values at the WAAS epochs only "
            f"and NaN between them"
        )
    speed = float(np.median(np.hypot(np.diff(ww[:, 0]), np.diff(ww[:, 1])) / dtw))
    lo, hi = APPROACH_SPEED_MS
    if not lo <= speed <= hi:
        raise DataError(
            f"{where}: columns waas_x_m/waas_y_m: the aircraft moves at {speed:.3g} m/s (median over the "
            f"WAAS epochs); expected an approach at {lo:g}-{hi:g} m/s: are the positions in metres?"
        )
    ra = g["ra_m"].to_numpy()
    with np.errstate(invalid="ignore"):
        low = ra < RA_MIN_M
    if low.any():
        i = int(np.flatnonzero(low)[0])
        raise DataError(
            f"{where}: column 'ra_m' data row {g.index[i] + 1}: {ra[i]:g} m; a radar-altimeter height "
            f"above the runway cannot be below {RA_MIN_M:g} m (sign? units?)"
        )
    lever = g["ra_lever_arm_m"].to_numpy(dtype=float) if "ra_lever_arm_m" in g.columns else np.zeros(len(g))
    both = fin[:, 2] & np.isfinite(ra) & np.isfinite(lever)
    if both.sum() >= 3:  # the WAAS height over the runway against the RA's: WAAS is good to metres
        gap = float(np.median(w[both, 2] - ra[both] - lever[both]))
        if abs(gap) > RA_WAAS_MAX_M:
            raise DataError(
                f"{where}: column 'ra_m': the WAAS height is {gap:+.1f} m off the radar altimeter's over the "
                f"runway (median of {int(both.sum())} epochs); WAAS is good to a few metres: is ra_m in feet, "
                f"or the log's z not from the threshold?"
            )
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
    col = {c: g[c].to_numpy(dtype=float) for c in REQUIRED if c not in ("approach", "event")}
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
    dgps = (
        g[list(DGPS)].to_numpy(dtype=float)[keep] if all(c in g.columns for c in DGPS) else np.full((len(t), 3), np.nan)
    )
    return ApproachInputs(
        tw,
        waas[is_w],
        ins[is_w],
        flags,
        t,
        ins,
        col["ra_m"][keep],
        col["tvps_y_m"][keep],
        t_mark,
        ra_lever,
        tvps_lever,
        dgps[is_w],
        dgps,
    )


def at_times(t_rows: np.ndarray, rows: np.ndarray, t: np.ndarray) -> np.ndarray:
    """Columns of `rows` (n, 3) linearly interpolated at times t (held at the ends); NaN
    where a neighbouring row is NaN."""
    i = np.clip(np.searchsorted(t_rows, t), 1, len(t_rows) - 1)
    w = np.clip((t - t_rows[i - 1]) / (t_rows[i] - t_rows[i - 1]), 0.0, 1.0)[:, None]
    return (1.0 - w) * rows[i - 1] + w * rows[i]


_Inputs = TypeVar("_Inputs", bound="ApproachInputs")


def retagged(a: _Inputs, latency_s: float) -> _Inputs:
    """The inputs with each WAAS epoch put at its time tag minus `latency_s` (a receiver
    that stamps its positions that late): the INS and the DGPS taken at the new times from
    their rows. The same inputs when the latency is 0."""
    if latency_s == 0.0:
        return a
    t_w = a.t_w - latency_s
    return replace(a, t_w=t_w, ins_w=at_times(a.t_rows, a.ins_rows, t_w), dgps_w=at_times(a.t_rows, a.dgps_rows, t_w))


def fits_of(a: ApproachInputs, spec: FitsSpec, extra_flags: np.ndarray | None = None) -> FitsResult:
    """The FITS (analysis.fits.fits_approach) on an approach's inputs; `extra_flags` adds
    flagged WAAS epochs (a jump diagnose found)."""
    flags = a.flags if extra_flags is None else np.maximum(a.flags, extra_flags)
    return fits_approach(
        a.t_w,
        a.waas,
        a.ins_w,
        flags,
        a.t_rows,
        a.ins_rows,
        a.ra,
        a.tvps,
        a.t_mark,
        spec,
        ra_lever_m=a.ra_lever,
        tvps_lever_m=a.tvps_lever,
    )


def run_approach(g: pd.DataFrame, spec: FitsSpec) -> FitsResult:
    """The FITS on one approach's rows (already checked; event rows of their own allowed),
    its WAAS epochs re-tagged by spec.waas_latency_s."""
    return fits_of(retagged(approach_inputs(g), spec.waas_latency_s), spec)
