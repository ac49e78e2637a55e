"""The inspection: what an ILS's errors look like through a truth system, and the verdict.

The ILS error at each epoch is the deviation the receiver measured minus the deviation a
perfect ILS would give at the position the truth system reports:

    e_LOC = DDM_meas - DDM_nominal(p_hat),   e_GS likewise (aerotruth.truth.ils.nominal).

A truth-system position error dp becomes an apparent ILS error of the angle it subtends
at the antenna (aerotruth.analysis.fits.ils_metrics), so the estimates below carry the truth
system's error into the facility's parameters — which is what inspection accuracy means.

Estimates (segment choices follow the usual flight-inspection practice of averaging the
course near the threshold and the path over the final approach segment; stated here,
not taken from a document):
* localizer alignment at the threshold (m, + left): the mean course error in angle over
  the `alignment_window_m` before the threshold, times the range from the localizer to
  the threshold: e_a = -mean(e_LOC / S_L) x_L with S_L = (1 + s_L) 0.155 / phi_hs DDM per
  radian, s_L the displacement-sensitivity error measured on crossing runs (given);
* glide-path angle (deg): the mean over the path segment of the angle theta' whose path
  gives the measured DDM at the reported elevation with the nominal relative
  sensitivity: DDM = 0.0875 (eps_hat - theta') / (0.12 theta'), so
  theta' = eps_hat / (1 + 0.12 DDM / 0.0875);
* course bends (deg): the amplitude of the course error after removing its mean,
  sqrt(2) x RMS over the bend segment (a sinusoid's amplitude);
* each with its standard error from the scatter (independent epochs assumed; the
  truth system's own correlated error makes these optimistic — the campaign measures
  the real spread across approaches).
"""

from __future__ import annotations

import math

import numpy as np

from aerotruth.truth.ils import (
    GS_HALF_SECTOR_DDM,
    GS_HALF_SECTOR_FRACTION,
    LOC_HALF_SECTOR_DDM,
    TOLERANCES,
    IlsFacility,
    nominal,
)


def inspect_approach(
    loc_xyz,
    gs_xyz,
    loc_ddm,
    gs_ddm,
    facility: IlsFacility,
    *,
    alignment_window_m: float = 1050.0,
    path_segment_m: tuple[float, float] = (1050.0, 7400.0),
    bend_segment_m: tuple[float, float] = (0.0, 7400.0),
    loc_sensitivity_rel: float = 0.0,
) -> dict[str, float]:
    """Facility estimates from one approach. loc_xyz, gs_xyz: the truth system's (n, 3)
    runway-frame positions of the localizer and glide-slope antennas; loc_ddm, gs_ddm: the
    receiver's readings; `facility` gives the installation geometry (its errors are not
    used: they are what is being measured). Distances in the segments are before the
    threshold (m)."""
    ref = nominal(facility)
    loc_xyz, gs_xyz = np.asarray(loc_xyz, float), np.asarray(gs_xyz, float)
    d_loc, d_gs = -loc_xyz[:, 0], -gs_xyz[:, 0]
    s_loc = (1 + loc_sensitivity_rel) * LOC_HALF_SECTOR_DDM / ref.loc_half_sector_rad  # DDM per rad of course angle
    course_err = (np.asarray(loc_ddm, float) - ref.localizer_ddm(loc_xyz[:, 0], loc_xyz[:, 1])) / s_loc  # rad, + left

    out: dict[str, float] = {}
    sel = (d_loc >= 0) & (d_loc <= alignment_window_m)
    a = -course_err[sel] * ref.loc_x_m
    out["alignment_m"], out["alignment_se_m"] = _mean_se(a)

    eps = ref.elevation_rad(gs_xyz[:, 0], gs_xyz[:, 1], gs_xyz[:, 2])
    path = eps / (1.0 + GS_HALF_SECTOR_FRACTION * np.asarray(gs_ddm, float) / GS_HALF_SECTOR_DDM)
    lo, hi = path_segment_m
    sel = (d_gs >= lo) & (d_gs <= hi)
    ang, ang_se = _mean_se(np.degrees(path[sel]))
    out["gp_angle_deg"], out["gp_angle_se_deg"] = ang, ang_se
    out["gp_angle_error_deg"] = ang - facility.spec.glide_path_deg

    lo, hi = bend_segment_m
    sel = (d_loc >= lo) & (d_loc <= hi)
    c = np.degrees(course_err[sel])
    out["bend_amplitude_deg"] = float(math.sqrt(2.0) * np.std(c)) if sel.sum() > 2 else float("nan")
    out["epochs"] = int(len(course_err))
    return out


def _mean_se(x: np.ndarray) -> tuple[float, float]:
    x = x[np.isfinite(x)]
    if len(x) < 2:
        return float("nan"), float("nan")
    return float(np.mean(x)), float(np.std(x, ddof=1) / math.sqrt(len(x)))


def verdict(estimates: dict[str, float], category: str = "I", glide_path_deg: float = 3.0) -> dict[str, bool]:
    """Pass/fail of each estimated parameter against the Annex 10 tolerance of the category."""
    tol = TOLERANCES[category]
    return {
        "alignment": abs(estimates["alignment_m"]) <= tol["alignment_m"],
        "gp_angle": abs(estimates["gp_angle_error_deg"]) <= tol["gp_angle_rel"] * glide_path_deg,
    }
