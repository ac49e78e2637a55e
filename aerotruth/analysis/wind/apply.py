"""The other half of the wind paper's method: the lookup tables `heading fit` learned on one
period applied to the reports of another, as the onboard table would correct them (wind
paper eq. 1 with the air vector turned by the table's correction), and the wind error
against the references before and after, per aircraft and for the fleet."""

from __future__ import annotations

import numpy as np
import pandas as pd

from aerotruth.analysis.wind.fleet_checks import require_used_reports
from aerotruth.analysis.wind.heading_correction import FleetHeadingFit, HeadingDeviationFit
from aerotruth.analysis.wind.heading_errors import GateSpec, heading_errors, towards_from_report
from aerotruth.analysis.wind.metrics import heading_turn, wind_errors_before_after
from aerotruth.errors import DataError
from aerotruth.units import DEG, KT

APPLY_COLUMNS = (
    "aircraft",
    "status",
    "n_scored",
    "rms_before_kt",
    "rms_after_kt",
    "longitudinal_before_kt",
    "longitudinal_after_kt",
    "transverse_before_kt",
    "transverse_after_kt",
    "valid_from",
    "valid_to",
    "in_sample",
)


def table_frame(fleet: FleetHeadingFit) -> str:
    """The heading the tables are indexed by ("true" or "magnetic"; one per file, read_tables)."""
    return next(iter(fleet.fits_.values())).heading if fleet.fits_ else "true"


def corrected_wind(
    wt_e: np.ndarray, wt_n: np.ndarray, va_e: np.ndarray, va_n: np.ndarray, correction_deg: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The wind (towards east, north; the units of the inputs) recomputed with the heading
    turned clockwise by c: V_W' = V_W + V_A - R(c) V_A (wind paper eq. 1)."""
    c = np.asarray(correction_deg, dtype=float) * DEG
    e, n = heading_turn(va_e, va_n, np.sin(c), np.cos(c))
    return wt_e + e, wt_n + n


def _speed_from(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speed (kt) and meteorological direction ("from", deg in [0, 360)) of a wind (m/s)."""
    return np.hypot(u, v) / KT, np.degrees(np.arctan2(-u, -v)) % 360.0


def in_sample(fit: HeadingDeviationFit, t: np.ndarray) -> bool:
    """Whether reports at times `t` (s, UTC) overlap the data a table was fitted on: its first
    to last report (data_from, data_to) where the table says them, else its validity dates
    (whole days, for tables that do not)."""
    if getattr(fit, "data_from_", "") and getattr(fit, "data_to_", ""):
        lo, hi = pd.Timestamp(fit.data_from_), pd.Timestamp(fit.data_to_)
        first, last = pd.Timestamp(t.min(), unit="s", tz="UTC"), pd.Timestamp(t.max(), unit="s", tz="UTC")
        return bool(first <= hi and last >= lo)
    lo = pd.Timestamp(fit.valid_from_, tz="UTC")
    hi = pd.Timestamp(fit.valid_to_, tz="UTC") + pd.Timedelta(days=1)
    first, last = pd.Timestamp(t.min(), unit="s", tz="UTC"), pd.Timestamp(t.max(), unit="s", tz="UTC")
    return bool(first < hi and last >= lo)


def heading_apply(
    obs: pd.DataFrame, fleet: FleetHeadingFit, source: str = "observation table", gates: GateSpec | None = None
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(the rows of `obs`, validated and in its order, with the correction columns; the
    per-aircraft scores, APPLY_COLUMNS). `obs` as validate_observations returns it; `gates`
    those of the reports (heading_errors.data_gates), default GateSpec()."""
    rows = heading_errors(obs, gates, source=source)
    require_used_reports(rows, source)
    frame = table_frame(fleet)
    col = "heading_deg" if frame == "true" else "heading_mag_deg"
    z = rows[col].to_numpy()
    used = (rows["gate"] == "used").to_numpy()
    if frame == "magnetic" and not np.isfinite(z[used]).any():
        raise DataError(
            f"{source}: the tables are indexed by magnetic heading (heading_frame magnetic); the table needs "
            "a 'heading_mag_deg' or 'declination_deg' column"
        )
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
    out = pd.DataFrame(
        {
            "gate": rows["gate"].astype(str).to_numpy(),
            "corrected": ok,
            "table_heading_deg": np.where(ok, z, np.nan),
            "correction_deg": corr,
            "wind_speed_kt_corrected": np.where(ok, speed, obs["wind_speed_kt"].to_numpy()),
            "wind_dir_deg_corrected": np.where(ok, direction, obs["wind_dir_deg"].to_numpy()),
        }
    )
    # scores on the reports the method uses: wind error against the reference, before and
    # after (the method's rows with this V_A)
    scored = rows[["heading_deg", "dw_e", "dw_n"]].assign(va_e=va_e, va_n=va_n)
    scores = []
    # per aircraft, then the fleet's row "all" (always the last: an aircraft may be named "all")
    # over the aircraft with a table: the others' reports are not corrected and would only
    # dilute the gain the tables make
    groups = [(str(a), used & (names == a), False) for a in pd.unique(names)] + [("all", used & has_table, True)]
    for name, sel, whole_fleet in groups:
        fit = None if whole_fleet else fleet.fits_.get(name)
        b, a = wind_errors_before_after(scored[sel], corr[sel])
        t = obs["time_s"].to_numpy()[sel]
        overlap: str | bool = ""  # "" without a table or scored reports
        if fit is not None and len(t):
            overlap = in_sample(fit, t)
        status = fit.status_ if fit is not None else ("" if whole_fleet else "no table")
        scores.append(
            {
                "aircraft": name,
                "status": status,
                "n_scored": int(sel.sum()),
                "rms_before_kt": b["rms_kt"],
                "rms_after_kt": a["rms_kt"],
                "longitudinal_before_kt": b["longitudinal_kt"],
                "longitudinal_after_kt": a["longitudinal_kt"],
                "transverse_before_kt": b["transverse_kt"],
                "transverse_after_kt": a["transverse_kt"],
                "valid_from": fit.valid_from_ if fit is not None else "",
                "valid_to": fit.valid_to_ if fit is not None else "",
                "in_sample": overlap,
            }
        )
    return out, pd.DataFrame(scores, columns=list(APPLY_COLUMNS))
