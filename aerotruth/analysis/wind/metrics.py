"""Wind metrics of aircraft reports against a reference (the wind paper, section 6).

The axis of the longitudinal/transverse split needs each report's ground track: the one
ground track of wind paper section 5.1 (`aerotruth.analysis.wind.heading_errors.ground_track`:
V_G = (P_{k+1} - P_{k-1}) / (t_{k+1} - t_{k-1}) from the neighbouring reports), here with
fixed gates and no minimum baseline (`METRIC_GATES`; thresholds ours, the paper gives
none): collinear when the course changes by at most 10 deg between the legs k-1 -> k and
k -> k+1, constant speed when the two leg ground speeds differ by at most 10 % of their
mean (only ground speed can be checked from reports: TAS is not downlinked), both legs at
most 15 min long, within one flight. With lat/lon quantized to q deg (uniform error,
sigma = q/sqrt(12) per coordinate) and baseline L = |P_{k+1} - P_{k-1}|, the track error
is sigma_eta^2 = 2 (sigma_E^2 cos^2 eta + sigma_N^2 sin^2 eta) / L^2 and the speed error
sigma_V^2 = 2 (sigma_E^2 sin^2 eta + sigma_N^2 cos^2 eta) / T^2 + 2 V^2 sigma_t^2 / T^2
(T = t_{k+1} - t_{k-1}, sigma_t from the time quantization); valid while L >> the step.
Distances are on the ellipsoid's surface: at altitude h the ground speed reads R / (R + h)
of the speed at the aircraft's height (0.2 % slow at FL 400), far below the quantization's
noise.

Metrics (wind paper section 6): per report the vector difference dW = W_report - W_ref
(u east, v north); total = sqrt(mean |dW|^2) (RMS vector magnitude error). Longitudinal
and transverse components project dW on the aircraft axis and its right-hand normal,
the axis being estimated from the report track (section 8.2.1: "the heading is estimated
from the track of the observations"): by default the air track of eq. 3,
V_A = V_G - V_W,TAM, i.e. the heading the aircraft used.

Why the paper's components do not add up (Table II RSS(5.4, 9.8) = 11.2 > 10.8; Table IV
transverse 32.1 > total 30.0): an orthogonal split of the same vectors always adds up,
whatever the axis error. The mechanism modelled here (`total_over="all"`, the default):
the components exist only for reports with a usable 3-report track, the total is over
every report. Climb and descent reports come every 10 hPa, seconds apart, so their
baselines are comparable to the lat/lon step and their tracks fail the gates; the reports
that keep a track are mostly level and fast, where a heading error makes the largest
wind error, so the component RMS can exceed the total. `total_over="track_subset"`
computes the total on the same reports (then RSS = total exactly).

"Combined references" pools every (report, reference) pair: an observation table with one
row per pair (same report, different `ref_source`) summarised without `ref_source` in `by`.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Literal

import numpy as np
import pandas as pd
from numba import njit
from numpy.typing import ArrayLike

from aerotruth.analysis.wind.fast_trig import sin_cos
from aerotruth.analysis.wind.heading_errors import (
    GateSpec,
    ground_track,
    report_flights,
    running_count,
)
from aerotruth.contracts import OBSERVATION_WIND
from aerotruth.sensors.tamdar import wind_components
from aerotruth.units import DEG, KT

AXES = ("air_track", "ground_track", "reported_heading")
GROUPINGS = ("aircraft", "fleet", "phase", "ref_source", "altitude_band")
_OBS_REQUIRED = OBSERVATION_WIND


# the gates of the metrics' axis (module docstring): fixed limits, no minimum baseline
METRIC_GATES = GateSpec(max_gap_s=900.0, min_baseline_km=0.0, noise_sigmas=0.0, max_track_noise=math.inf)


def air_track_heading(vg_east: ArrayLike, vg_north: ArrayLike, u: ArrayLike, v: ArrayLike) -> np.ndarray:
    """Heading (rad, [0, 2 pi)) of V_A = V_G - V_W (wind paper eq. 3 with the reported
    wind, eq. 4 with a reference wind); any consistent speed unit."""
    return np.mod(np.arctan2(np.asarray(vg_east) - np.asarray(u), np.asarray(vg_north) - np.asarray(v)), 2 * np.pi)


def longitudinal_transverse(du: ArrayLike, dv: ArrayLike, axis_rad: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Components of the vector difference (du east, dv north) along the axis (bearing,
    rad from true north) and across it, positive to the right of the axis."""
    s, c = np.sin(axis_rad), np.cos(axis_rad)
    du, dv = np.asarray(du, dtype=float), np.asarray(dv, dtype=float)
    return du * s + dv * c, du * c - dv * s


def rms_vector_difference(du: ArrayLike, dv: ArrayLike) -> float:
    """sqrt(mean(du^2 + dv^2)) (wind paper section 6, total RMS vector magnitude error)."""
    du, dv = np.asarray(du, dtype=float), np.asarray(dv, dtype=float)
    return float(np.sqrt(np.mean(du * du + dv * dv))) if du.size else float("nan")


def _epoch_seconds(time: pd.Series) -> np.ndarray:
    if pd.api.types.is_numeric_dtype(time):
        return time.to_numpy(dtype=float)
    try:
        stamps = pd.to_datetime(time, utc=True)
    except (ValueError, TypeError) as exc:
        raise ValueError(f"time: expected UTC epoch seconds or ISO-8601 strings ({exc})") from None
    return (stamps - pd.Timestamp("1970-01-01", tz="UTC")).dt.total_seconds().to_numpy()


def wind_errors(obs: pd.DataFrame, axis: str = "air_track", gates: GateSpec = METRIC_GATES) -> pd.DataFrame:
    """Per (report, reference) row: vector difference report - reference (kt), its
    magnitude, the axis (deg) and the longitudinal/transverse components (NaN where the
    report has no axis). Tracks come from the reports of each aircraft in time order (rows
    repeated for several references count once). Keeps the grouping columns present."""
    missing = [c for c in _OBS_REQUIRED if c not in obs.columns]
    if missing:
        raise ValueError(f"observation table: missing columns {missing}")
    if axis not in AXES:
        raise ValueError(f"axis: expected one of {AXES}, got {axis!r}")
    if axis == "reported_heading" and "heading_deg" not in obs.columns:
        raise ValueError("axis='reported_heading' needs a heading_deg column")
    t = _epoch_seconds(obs["time"])
    u_rep, v_rep = wind_components(
        obs["wind_speed_kt"].to_numpy(dtype=float), obs["wind_dir_deg"].to_numpy(dtype=float) * DEG
    )
    u_ref, v_ref = wind_components(
        obs["ref_wind_speed_kt"].to_numpy(dtype=float), obs["ref_wind_dir_deg"].to_numpy(dtype=float) * DEG
    )
    du, dv = u_rep - u_ref, v_rep - v_ref

    if axis == "reported_heading":
        axis_rad = obs["heading_deg"].to_numpy(dtype=float) * DEG
        usable = np.isfinite(axis_rad)
    else:
        rows = pd.DataFrame(
            {
                "aircraft": obs["aircraft"].to_numpy(),
                "t": t,
                "lat": obs["lat"].to_numpy(dtype=float),
                "lon": obs["lon"].to_numpy(dtype=float),
            }
        )
        reports = (
            rows.drop_duplicates(["aircraft", "t"]).sort_values(["aircraft", "t"], kind="stable").reset_index(drop=True)
        )
        lookup = (
            rows[["aircraft", "t"]]
            .merge(reports[["aircraft", "t"]].reset_index(), on=["aircraft", "t"], how="left")["index"]
            .to_numpy()
        )
        rt = reports["t"].to_numpy()
        flight = report_flights(pd.factorize(reports["aircraft"])[0], rt, gates.flight_gap_s)
        gt = ground_track(rt, reports["lat"].to_numpy() * DEG, reports["lon"].to_numpy() * DEG, flight, gates)
        track = np.mod(np.arctan2(gt.vg_e, gt.vg_n), 2 * np.pi)[lookup]
        speed_kt, usable = np.hypot(gt.vg_e, gt.vg_n)[lookup] / KT, (gt.gate == 0)[lookup]
        if axis == "ground_track":
            axis_rad = track
        else:  # wind paper eq. 3: V_A = V_G - V_W,TAM
            axis_rad = air_track_heading(speed_kt * np.sin(track), speed_kt * np.cos(track), u_rep, v_rep)
    axis_rad = np.where(usable, axis_rad, np.nan)
    lon_kt, tra_kt = longitudinal_transverse(du, dv, axis_rad)
    out = pd.DataFrame(
        {
            c: obs[c].to_numpy()
            for c in ("aircraft", "fleet", "phase", "ref_source", "pressure_altitude_ft")
            if c in obs.columns
        }
    )
    out["time_s"] = t
    out["du_kt"], out["dv_kt"], out["error_kt"] = du, dv, np.hypot(du, dv)
    out["axis_deg"] = np.degrees(axis_rad)
    out["longitudinal_kt"], out["transverse_kt"] = lon_kt, tra_kt
    out["has_axis"] = usable
    return out


def wind_error_summary(
    errors: pd.DataFrame,
    by: Sequence[str] = (),
    altitude_bands_ft: Sequence[float] | None = None,
    total_over: Literal["all", "track_subset"] = "all",
) -> pd.DataFrame:
    """RMS vector error and its longitudinal/transverse RMS per group of `wind_errors` rows.

    by: any of GROUPINGS ("altitude_band" needs `altitude_bands_ft`, ascending edges; a band
    is [lo, hi)); empty pools every row (all aircraft, all references). total_over: "all"
    (the total over every row, components over rows with an axis; the mechanism by which
    the paper's components need not add up) or "track_subset" (total over the same rows as
    the components). Columns: the group keys, n, n_components, rms_kt, longitudinal_rms_kt,
    transverse_rms_kt, rss_components_kt.
    """
    by = list(by)
    bad = [b for b in by if b not in GROUPINGS]
    if bad:
        raise ValueError(f"by: expected names from {GROUPINGS}, got {bad}")
    if total_over not in ("all", "track_subset"):
        raise ValueError(f"total_over: expected 'all' or 'track_subset', got {total_over!r}")
    df = errors[["error_kt", "longitudinal_kt", "transverse_kt", "has_axis"]].copy()
    for b in by:
        if b == "altitude_band":
            if altitude_bands_ft is None or len(altitude_bands_ft) < 2 or np.any(np.diff(altitude_bands_ft) <= 0):
                raise ValueError(
                    "altitude_bands_ft: expected at least two ascending edges (ft) to group by altitude_band"
                )
            edges = np.asarray(altitude_bands_ft, dtype=float)
            labels = [f"{lo:g}-{hi:g}" for lo, hi in zip(edges[:-1], edges[1:], strict=False)]
            # pandas-stubs take no ndarray `bins` with a Series; pandas takes any array-like
            df[b] = pd.cut(
                errors["pressure_altitude_ft"],
                edges,  # type: ignore[call-overload]
                right=False,
                labels=labels,
            )
        elif b not in errors.columns:
            raise ValueError(f"by: column {b!r} is not in the errors table")
        else:
            df[b] = errors[b].to_numpy()
    e2 = df["error_kt"] ** 2
    df["e2"] = e2.where(df["has_axis"]) if total_over == "track_subset" else e2
    df["l2"], df["t2"] = df["longitudinal_kt"] ** 2, df["transverse_kt"] ** 2
    agg = dict(n=("e2", "count"), e2=("e2", "mean"), n_components=("l2", "count"), l2=("l2", "mean"), t2=("t2", "mean"))
    if by:
        g = df.groupby(by, observed=True, sort=True).agg(**agg).reset_index()
    else:
        g = pd.DataFrame(
            [
                {
                    "n": int(df["e2"].count()),
                    "e2": df["e2"].mean(),
                    "n_components": int(df["l2"].count()),
                    "l2": df["l2"].mean(),
                    "t2": df["t2"].mean(),
                }
            ]
        )
    g["rms_kt"] = np.sqrt(g.pop("e2"))
    g["longitudinal_rms_kt"] = np.sqrt(g.pop("l2"))
    g["transverse_rms_kt"] = np.sqrt(g.pop("t2"))
    g["rss_components_kt"] = np.hypot(g["longitudinal_rms_kt"], g["transverse_rms_kt"])
    return g


# ----------------------------------------------------------------------------- the method's rows
# (aerotruth.analysis.wind.heading_errors: V_A and dw = V_W,TAM - V_W,REF per row, m/s)


def wind_error_components(dw_e, dw_n, heading_deg) -> dict[str, float]:
    """RMS of the wind error vector (reported - reference), and of its longitudinal (along
    the aircraft's heading) and transverse components (wind paper section 6), knots."""
    z = np.asarray(heading_deg) * DEG
    return _components(np.asarray(dw_e, dtype=float), np.asarray(dw_n, dtype=float), *sin_cos(z))


def _components(dw_e: np.ndarray, dw_n: np.ndarray, sz: np.ndarray, cz: np.ndarray) -> dict[str, float]:
    """wind_error_components from the heading's sine and cosine."""
    lon_ = dw_e * sz
    lon_ += dw_n * cz
    return _rms_parts(float(dw_e @ dw_e + dw_n @ dw_n), float(lon_ @ lon_), len(dw_e))


def _rms_parts(total: float, along: float, n: int) -> dict[str, float]:
    """The RMS of wind_error_components from the sums of squares of the error vector and of
    its longitudinal component over n rows."""
    if n == 0:
        return {"rms_kt": math.nan, "longitudinal_kt": math.nan, "transverse_kt": math.nan}
    across = max(total - along, 0.0)  # a rotation keeps the sum of squares: the transverse part is the rest
    rms = lambda ss: math.sqrt(ss / n) / KT  # noqa: E731
    return {"rms_kt": rms(total), "longitudinal_kt": rms(along), "transverse_kt": rms(across)}


def corrected_wind_error(rows: pd.DataFrame, correction_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Wind error after correcting the heading by c: the wind recomputed with V_A rotated by
    c (wind paper eq. 1), V_W' = V_W,TAM + V_A - R(c) V_A."""
    c = np.asarray(correction_deg) * DEG
    return _rotated_error(rows, *sin_cos(c))


def heading_turn(va_e: np.ndarray, va_n: np.ndarray, sc: np.ndarray, cc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """V_A - R(c) V_A: what the wind of eq. 1 gains when the heading is turned clockwise by
    c (sine sc, cosine cc). Rotating clockwise by c: (E, N) -> (E cos c + N sin c,
    N cos c - E sin c), so V_A - R(c) V_A = (E (1 - cos c) - N sin c, N (1 - cos c) + E sin c)."""
    one_c = 1.0 - cc
    e = va_e * one_c
    e -= va_n * sc
    n = va_n * one_c
    n += va_e * sc
    return e, n


def _rotated_error(rows: pd.DataFrame, sc: np.ndarray, cc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    e, n = heading_turn(rows["va_e"].to_numpy(), rows["va_n"].to_numpy(), sc, cc)
    e += rows["dw_e"].to_numpy()
    n += rows["dw_n"].to_numpy()
    return e, n


def wind_errors_before_after(rows: pd.DataFrame, correction_deg: np.ndarray) -> tuple[dict, dict]:
    """wind_error_components of the `heading_errors` rows as reported and after correcting
    their heading (`heading_deg`) by c (corrected_wind_error), the corrected heading's sine
    and cosine by the angle-sum identities (no second evaluation). The sines and cosines once
    per run of rows with equal heading and correction (the rows of one report, one per
    reference model, are adjacent), the rest in one compiled pass (_before_after_sums)."""
    z = rows["heading_deg"].to_numpy()
    c = np.asarray(correction_deg, dtype=float)
    head = np.ones(len(z), dtype=bool)
    head[1:] = (z[1:] != z[:-1]) | (c[1:] != c[:-1])
    first = np.flatnonzero(head)
    run = running_count(head)
    run -= 1  # each row's run
    sz, cz = sin_cos(z.take(first) * DEG)
    sc, cc = sin_cos(c.take(first) * DEG)
    dw_e, dw_n, va_e, va_n = (
        np.ascontiguousarray(rows[k].to_numpy(), dtype=float) for k in ("dw_e", "dw_n", "va_e", "va_n")
    )
    tb, ab, ta, aa = _before_after_sums(dw_e, dw_n, va_e, va_n, sz, cz, sc, cc, run)
    return _rms_parts(tb, ab, len(z)), _rms_parts(ta, aa, len(z))


@njit(cache=True, nogil=True, fastmath={"reassoc", "contract"}, error_model="numpy")
def _before_after_sums(
    dw_e: np.ndarray,
    dw_n: np.ndarray,
    va_e: np.ndarray,
    va_n: np.ndarray,
    sz: np.ndarray,
    cz: np.ndarray,
    sc: np.ndarray,
    cc: np.ndarray,
    run: np.ndarray,
) -> tuple[float, float, float, float]:
    """Sums of squares of the wind error and of its longitudinal component, as reported and
    after the heading turn (heading_turn; the heading's sine and cosine of row i at run[i],
    the correction's likewise): (total, along) before, then after."""
    tb = ab = ta = aa = 0.0
    for i in range(len(dw_e)):
        j = run[i]
        s_z, c_z, s_c, c_c = sz[j], cz[j], sc[j], cc[j]
        e, n = dw_e[i], dw_n[i]
        along = e * s_z + n * c_z
        tb += e * e + n * n
        ab += along * along
        one_c = 1.0 - c_c
        ae = e + va_e[i] * one_c - va_n[i] * s_c  # + V_A - R(c) V_A (heading_turn)
        an = n + va_n[i] * one_c + va_e[i] * s_c
        along = ae * (s_z * c_c + c_z * s_c) + an * (c_z * c_c - s_z * s_c)  # along z + c
        ta += ae * ae + an * an
        aa += along * along
    return tb, ab, ta, aa
