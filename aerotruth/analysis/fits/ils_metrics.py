"""Flight-inspection accuracy of a truth system along an ILS approach (FITS paper
section III-A, Figs. 3 and 4).

An ILS deviation is an angle seen from a ground antenna, so a position error e of the
truth system at range R from that antenna is an angular error atan(e / R): horizontal
(cross-track) errors are seen from the localizer array beyond the stop end, vertical
errors from the glide-path mast abeam the touchdown zone. The requirement on the
position error at range R is

    e_req(R) = max(floor, R tan(alpha)),   alpha = 0.015 deg (desired) or 0.05 deg (minimum),

with floors of 1 ft vertical and 2 ft horizontal (FITS paper: "the two accuracy
requirements are limited to 1 ft and 2 ft in vertical and horizontal"). Positions are in
the runway frame (docs/conventions.md: x along the approach course, < 0 before the threshold;
y left; z up; metres); the antenna positions come from the facility geometry
(aerotruth.truth.ils.IlsFacility: localizer at x_L, glide path at (x_G, y_G)).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

from aerotruth.units import FT, NM

DESIRED_DEG, MINIMUM_DEG = 0.015, 0.05
FLOOR_VERTICAL_M, FLOOR_HORIZONTAL_M = 1 * FT, 2 * FT
REQUIREMENTS = {"desired": DESIRED_DEG, "minimum": MINIMUM_DEG}


def required_error_m(range_m, alpha_deg: float, floor_m: float) -> np.ndarray:
    """Largest acceptable position error at range R from the antenna: max(floor, R tan alpha)."""
    return np.maximum(floor_m, np.asarray(range_m, float) * math.tan(math.radians(alpha_deg)))


def approach_errors(x, est, truth, *, loc_x_m: float, gp_x_m: float, gp_y_m: float) -> pd.DataFrame:
    """Per-epoch errors of a truth system: along-track, cross-track and vertical (m,
    estimate minus truth), the ranges to the localizer and glide-path antennas, the
    angular errors seen from them (deg) and, per requirement, whether the epoch meets it.
    `est` and `truth` are (n, 3) runway-frame positions; `x` is the true x (m)."""
    est, truth = np.asarray(est, float), np.asarray(truth, float)
    if est.shape != truth.shape or est.ndim != 2 or est.shape[1] != 3:
        raise ValueError(f"est, truth: expected two (n, 3) arrays of the same shape, got {est.shape} and {truth.shape}")
    x = np.asarray(x, float)
    err = est - truth
    r_loc = loc_x_m - x
    r_gp = np.hypot(x - gp_x_m, truth[:, 1] - gp_y_m)
    out = {
        "x_m": x,
        "distance_to_threshold_m": -x,
        "along_m": err[:, 0],
        "cross_m": err[:, 1],
        "vertical_m": err[:, 2],
        "range_loc_m": r_loc,
        "range_gp_m": r_gp,
        "cross_deg": np.degrees(np.arctan2(err[:, 1], r_loc)),
        "vertical_deg": np.degrees(np.arctan2(err[:, 2], r_gp)),
    }
    for name, alpha in REQUIREMENTS.items():
        out[f"cross_meets_{name}"] = np.abs(err[:, 1]) <= required_error_m(r_loc, alpha, FLOOR_HORIZONTAL_M)
        out[f"vertical_meets_{name}"] = np.abs(err[:, 2]) <= required_error_m(r_gp, alpha, FLOOR_VERTICAL_M)
    return pd.DataFrame(out)  # built at once: column-by-column insertion costs more than the arithmetic


def approach_verdict(errors: pd.DataFrame, from_nm: float = 10.0) -> dict[str, float | bool | int]:
    """Per approach, over the epochs from `from_nm` to the threshold: whether every epoch
    meets each requirement (cross-track and vertical), and the distance from the
    threshold (nm) beyond which every epoch meets it (0 when all do, `from_nm` when even
    the farthest fails) — where along the approach the truth system stops being good enough."""
    dist = errors["distance_to_threshold_m"].to_numpy()
    seg = np.flatnonzero((dist >= 0) & (dist <= from_nm * NM))
    d = dist[seg]
    out: dict[str, float | bool | int] = {"epochs": int(len(seg))}
    for axis in ("cross", "vertical"):
        for name in REQUIREMENTS:
            ok = errors[f"{axis}_meets_{name}"].to_numpy(bool)[seg]
            out[f"{axis}_meets_{name}"] = bool(len(ok) and ok.all())
            out[f"{axis}_{name}_met_beyond_nm"] = (
                float(d[~ok].max() / NM) if (~ok).any() else (0.0 if len(ok) else from_nm)
            )
    return out


def percentile_by_distance(errors: pd.DataFrame, column: str, edges_nm, q: float = 95.0) -> pd.DataFrame:
    """The q-th percentile of |column| in distance bins (nm from the threshold)."""
    d = errors["distance_to_threshold_m"].to_numpy() / NM
    v = np.abs(errors[column].to_numpy(float))
    edges = np.asarray(edges_nm, float)
    idx = np.digitize(d, edges) - 1
    rows = []
    for i in range(len(edges) - 1):
        sel = idx == i
        rows.append(
            {
                "from_nm": edges[i],
                "to_nm": edges[i + 1],
                "n": int(sel.sum()),
                f"{column}_p{q:g}": float(np.percentile(v[sel], q)) if sel.any() else float("nan"),
            }
        )
    return pd.DataFrame(rows)


PAPER_WAAS_95_M = {"cross": 3 * FT, "vertical": 6 * FT}  # FITS paper section III-A: "assumed to be 3ft ... and 6ft"


def waas_alone_by_distance(errors: pd.DataFrame, from_nm: float = 10.0, bin_nm: float = 0.25) -> pd.DataFrame:
    """The WAAS alone against the requirement (FITS paper Figs. 3/4), in distance bins from
    the threshold out to `from_nm`: per bin the 95th percentile of the WAAS's |cross-track|
    and |vertical| error (columns `waas_err_y_m`, `waas_err_z_m` of the epochs), the median
    ranges to the localizer and glide-path antennas, and the requirement there for each
    line (`req_{axis}_{desired|minimum}_m`, floors included)."""
    d = errors["distance_to_threshold_m"].to_numpy(float)
    edges = np.arange(0.0, from_nm + 1e-9, bin_nm) * NM
    idx = np.digitize(d, edges) - 1
    rows = []
    for i in range(len(edges) - 1):
        sel = idx == i
        if not sel.any():
            continue
        r_loc = float(np.median(errors["range_loc_m"].to_numpy(float)[sel]))
        r_gp = float(np.median(errors["range_gp_m"].to_numpy(float)[sel]))
        row = {
            "from_nm": edges[i] / NM,
            "to_nm": edges[i + 1] / NM,
            "epochs": int(sel.sum()),
            "range_loc_m": r_loc,
            "range_gp_m": r_gp,
            "waas_cross_p95_m": float(np.percentile(np.abs(errors["waas_err_y_m"].to_numpy(float)[sel]), 95)),
            "waas_vertical_p95_m": float(np.percentile(np.abs(errors["waas_err_z_m"].to_numpy(float)[sel]), 95)),
        }
        for name, alpha in REQUIREMENTS.items():
            row[f"req_cross_{name}_m"] = float(required_error_m(r_loc, alpha, FLOOR_HORIZONTAL_M))
            row[f"req_vertical_{name}_m"] = float(required_error_m(r_gp, alpha, FLOOR_VERTICAL_M))
        rows.append(row)
    return pd.DataFrame(rows)


def fails_within_nm(by_distance: pd.DataFrame, axis: str, requirement: str, error_95_m: float | None = None) -> float:
    """The distance (nm) from the threshold inside which the 95 % error exceeds the
    requirement: the outer edge of the farthest bin that fails (0 when none does). The
    error is the bin's simulated WAAS 95 % or, given, a constant (the paper's assumption)."""
    req = by_distance[f"req_{axis}_{requirement}_m"].to_numpy(float)
    err = by_distance[f"waas_{axis}_p95_m"].to_numpy(float) if error_95_m is None else np.full(len(req), error_95_m)
    fail = err > req
    return float(by_distance["to_nm"].to_numpy(float)[fail].max()) if fail.any() else 0.0
