"""TAMDAR report generator: turns 10 Hz measured air data, GPS and heading into the
observations an aircraft downlinks (the wind paper, section 2 and section 3).

Onboard wind, per sample (wind paper eq. 1), horizontal, u east / v north, "towards":

    V_W = V_G - V_A,   V_G = (v_E, v_N) from GPS,   V_A = TAS (sin psi, cos psi)

with psi the true heading the system uses (after the onboard correction below). A report
carries the mean of V_W over the trailing averaging window (t_r - W, t_r] (the window
is clipped at the first sample); its speed and meteorological "from" direction are then
quantized. The window length is not given in the paper: `averaging_window_s` (default
10 s) is an assumption to vary.

Report timestamp convention: a report belongs to its trigger sample t_r, the last sample
of the window. Its time (t_r + start_epoch_s), GPS lat/lon, pressure altitude and roll are
those of the trigger sample (roll instantaneous, signed, right wing down positive);
`tas_kt` and `heading_deg` are the window means (circular mean for heading) of the values
used in the wind calculation. Quantization is rounding to the nearest multiple of the
step (unbiased, as the wind paper section 5.1 says of the lat/lon noise).

Trigger rules (wind paper section 2): a report when the static pressure has changed by
10 hPa since the last report while within 100 hPa of the ground pressure (p_ground - p
<= 100 hPa at the sample), by 50 hPa above that; or when no report has been made for
3 min below 20,000 ft pressure altitude / 7 min at or above it (the limit of the current
sample applies). The first sample sets the references and is not a report. Any report
restarts the clock; a time-triggered report also resets the pressure reference to its own
pressure unless `time_report_resets_pressure` is false (then only pressure-triggered
reports do). The pressure used is the measured static pressure.

Phase (ascent/level/descent, as in the paper's figures 13-14): the measured
pressure-altitude rate over the trailing `phase_window_s` against `level_rate_fpm`.

Onboard heading correction (wind paper section 8.1 and 8.4): an uploaded 8-point lookup
table at magnetic headings 0, 45, ..., 315 deg, interpolated piecewise-linearly (and
circularly) at the heading the flux-valve system measures, i.e. magnetic, before the
variation is applied (SAAB 340s): psi_corr = psi + c(psi - var). Aircraft whose avionics
hand over true heading (Chautauqua ERJ-145s, Table IV) can only take an offset:
psi_corr = psi + offset. Both tables hold the correction added to the measured heading
(minus the deviation).
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from pydantic import Field, ValidationInfo, field_validator

from aerotruth.schema import Section
from aerotruth.sensors.air_data import AIR_DATA_COLUMNS, ideal_air_data
from aerotruth.units import DEG, FPM, FT, HPA, KT

LUT_NODES_DEG = np.arange(0.0, 360.0, 45.0)
_TIME_TOLERANCE_S = 1e-6  # sample times like 7795.3 s are inexact in binary: 8215.3 - 7795.3 < 420
REPORT_COLUMNS = (
    "aircraft",
    "time",
    "lat",
    "lon",
    "pressure_altitude_ft",
    "wind_speed_kt",
    "wind_dir_deg",
    "tas_kt",
    "heading_deg",
    "roll_deg",
    "phase",
    "trigger",
    "sample_index",
)


def quantize(x: ArrayLike, step: float) -> np.ndarray:
    """Round to the nearest multiple of step (unbiased quantization)."""
    return np.round(np.asarray(x, dtype=float) / step) * step


def wind_speed_direction(u_mps: ArrayLike, v_mps: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Speed (m/s) and meteorological direction the wind blows FROM (rad, [0, 2 pi)) of a
    "towards" vector (u east, v north): dir = atan2(-u, -v)."""
    u, v = np.asarray(u_mps, dtype=float), np.asarray(v_mps, dtype=float)
    return np.hypot(u, v), np.mod(np.arctan2(-u, -v), 2 * np.pi)


def wind_components(speed_mps: ArrayLike, direction_from_rad: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Inverse of `wind_speed_direction`: u = -s sin(dir), v = -s cos(dir)."""
    s, d = np.asarray(speed_mps, dtype=float), np.asarray(direction_from_rad, dtype=float)
    return -s * np.sin(d), -s * np.cos(d)


class ReportSpec(Section):
    """TAMDAR reporting rules, averaging and quantization (hPa, s, ft, kt, deg at this edge)."""

    pressure_step_low_hpa: float = Field(default=10.0, gt=0, description="pressure trigger near the ground")
    pressure_step_high_hpa: float = Field(default=50.0, gt=0, description="pressure trigger above the low zone")
    low_zone_above_ground_hpa: float = Field(
        default=100.0, ge=0, description="depth of the low zone above ground pressure"
    )
    time_limit_low_s: float = Field(
        default=180.0, gt=0, description="report after this long without one, below the boundary"
    )
    time_limit_high_s: float = Field(default=420.0, gt=0, description="the same at or above the boundary")
    time_limit_boundary_ft: float = Field(
        default=20000.0, description="pressure altitude separating the two time limits"
    )
    time_report_resets_pressure: bool = Field(
        default=True, description="a time-triggered report resets the pressure reference"
    )
    averaging_window_s: float = Field(default=10.0, gt=0, description="trailing window of the reported wind (assumed)")
    phase_window_s: float = Field(default=30.0, gt=0, description="window of the vertical rate that sets the phase")
    level_rate_fpm: float = Field(default=300.0, gt=0, description="|rate| below this is level flight")
    lat_lon_step_deg: float = Field(default=0.01, description="quantization of reported lat and lon")
    time_step_s: float = Field(default=1.0, description="quantization of reported time")
    wind_speed_step_kt: float = Field(default=1.0, description="quantization of reported wind speed")
    wind_dir_step_deg: float = Field(default=1.0, description="quantization of reported wind direction")

    @field_validator("lat_lon_step_deg", "time_step_s", "wind_speed_step_kt", "wind_dir_step_deg")
    @classmethod
    def _positive_step(cls, value: float, info: ValidationInfo) -> float:
        if not (value > 0 and np.isfinite(value)):
            raise ValueError(f"{info.field_name}: quantization step must be a finite number > 0, got {value!r}")
        return value


class LookupTableCorrection(Section):
    """Uploaded 8-point heading correction (deg) at magnetic headings 0, 45, ..., 315."""

    lut_deg: list[float] = Field(description="correction added to the measured magnetic heading at 0, 45, ..., 315 deg")

    @field_validator("lut_deg")
    @classmethod
    def _eight_finite(cls, value: list[float]) -> list[float]:
        if len(value) != 8 or not np.all(np.isfinite(value)):
            raise ValueError(f"lut_deg: expected 8 finite values (at 0, 45, ..., 315 deg), got {value!r}")
        return value

    def correction_rad(self, heading_mag_rad: ArrayLike) -> np.ndarray:
        """Piecewise-linear circular interpolation of the table at magnetic heading (rad)."""
        x = np.mod(np.degrees(np.asarray(heading_mag_rad, dtype=float)), 360.0)
        nodes = np.append(LUT_NODES_DEG, 360.0)
        values = np.append(self.lut_deg, self.lut_deg[0])
        return np.interp(x, nodes, values) * DEG

    def apply(self, heading_rad: ArrayLike, variation_rad: ArrayLike) -> np.ndarray:
        """Corrected true heading: psi + c(psi - var) (the table is indexed by magnetic heading)."""
        psi = np.asarray(heading_rad, dtype=float)
        return psi + self.correction_rad(psi - np.asarray(variation_rad, dtype=float))


class OffsetCorrection(Section):
    """Offset-only correction for avionics that hand TAMDAR true heading (wind paper Table IV)."""

    offset_deg: float

    def apply(self, heading_rad: ArrayLike, variation_rad: ArrayLike | None = None) -> np.ndarray:
        """Corrected true heading psi + offset (the variation is not known to TAMDAR here)."""
        return np.asarray(heading_rad, dtype=float) + self.offset_deg * DEG


HeadingCorrection = LookupTableCorrection | OffsetCorrection


def report_schedule(
    time_s: ArrayLike,
    static_pressure_pa: ArrayLike,
    pressure_altitude_m: ArrayLike,
    ground_pressure_pa: ArrayLike,
    spec: ReportSpec,
) -> tuple[np.ndarray, np.ndarray]:
    """Sample indices of the reports and whether each was pressure-triggered (else time).

    Rules in the module docstring. Work is one vectorised scan per report over the samples
    up to the longest time limit after the previous report.
    """
    t = np.asarray(time_s, dtype=float)
    p = np.asarray(static_pressure_pa, dtype=float)
    n = t.size
    step = np.where(
        np.broadcast_to(np.asarray(ground_pressure_pa, dtype=float), (n,)) - p <= spec.low_zone_above_ground_hpa * HPA,
        spec.pressure_step_low_hpa * HPA,
        spec.pressure_step_high_hpa * HPA,
    )
    limit = np.where(
        np.asarray(pressure_altitude_m, dtype=float) < spec.time_limit_boundary_ft * FT,
        spec.time_limit_low_s,
        spec.time_limit_high_s,
    )
    longest = max(spec.time_limit_low_s, spec.time_limit_high_s)
    indices: list[int] = []
    by_pressure: list[bool] = []
    i, ref_p, ref_t = 0, p[0] if n else 0.0, t[0] if n else 0.0
    while i < n - 1:
        # the scan reaches past the first sample at the longest limit, so "no hit" means end of track
        end = min(n, int(np.searchsorted(t, ref_t + longest - _TIME_TOLERANCE_S, side="left")) + 2)
        hit_p = np.abs(p[i + 1 : end] - ref_p) >= step[i + 1 : end]
        hit = hit_p | (t[i + 1 : end] - ref_t >= limit[i + 1 : end] - _TIME_TOLERANCE_S)
        k = int(hit.argmax())
        if not hit[k]:
            break  # end of track before the next trigger
        i = i + 1 + k
        indices.append(i)
        by_pressure.append(bool(hit_p[k]))
        if hit_p[k] or spec.time_report_resets_pressure:
            ref_p = p[i]
        ref_t = t[i]
    return np.asarray(indices, dtype=np.int64), np.asarray(by_pressure, dtype=bool)


def _window_means(t: np.ndarray, idx: np.ndarray, window_s: float, *series: np.ndarray) -> list[np.ndarray]:
    """Means of each series over the samples with t in (t[idx] - window, t[idx]]."""
    start = np.searchsorted(t, t[idx] - window_s, side="right")
    count = (idx + 1 - start).astype(float)
    out = []
    for x in series:
        c = np.concatenate(([0.0], np.cumsum(x)))
        out.append((c[idx + 1] - c[start]) / count)
    return out


def generate_reports(
    truth: pd.DataFrame,
    heading_rad: ArrayLike,
    spec: ReportSpec,
    *,
    ground_pressure_hpa: ArrayLike,
    air: pd.DataFrame | None = None,
    correction: HeadingCorrection | None = None,
    variation_rad: ArrayLike = 0.0,
    aircraft: str = "",
    start_epoch_s: float = 0.0,
) -> pd.DataFrame:
    """TAMDAR reports of one flight, in the observation-table columns (REPORT_COLUMNS).

    truth: TruthTrack samples (time_s, roll_rad; and the air-data columns when `air` is
    None, which means ideal air data and GPS). heading_rad: the true heading the aircraft
    system measures at each sample (e.g. flux valve + slaved gyro, variation applied).
    air: measured air data/GPS (aerotruth.sensors.air_data.AirDataErrors.apply), one row
    per truth sample. ground_pressure_hpa: scalar or per-sample ground (field) pressure.
    correction: onboard heading correction; variation_rad (east positive, true = magnetic
    + variation) is the variation the system applied, needed by the lookup table.
    Extra columns: `trigger` ("pressure"/"time") and `sample_index` (row of the trigger
    sample in `truth`). The ref_* columns are left to the weather-model sensor.
    """
    if "roll_rad" not in truth.columns:
        raise ValueError("truth: missing column 'roll_rad'")
    air = ideal_air_data(truth) if air is None else air
    missing = [c for c in AIR_DATA_COLUMNS if c not in air.columns]
    if missing:
        raise ValueError(f"air: missing columns {missing}")
    n = len(air)
    if len(truth) != n:
        raise ValueError(f"air: expected one row per truth sample ({len(truth)}), got {n}")
    t = air["time_s"].to_numpy(dtype=float)
    if np.any(np.diff(t) <= 0):
        raise ValueError("air.time_s: expected strictly increasing times")
    psi = np.asarray(heading_rad, dtype=float)
    if psi.shape != (n,):
        raise ValueError(f"heading_rad: expected an array of {n} headings (one per sample), got shape {psi.shape}")
    ground = np.asarray(ground_pressure_hpa, dtype=float)
    variation = np.asarray(variation_rad, dtype=float)
    for name, value in (("ground_pressure_hpa", ground), ("variation_rad", variation)):
        if value.shape not in ((), (n,)):
            raise ValueError(f"{name}: expected a scalar or {n} values (one per sample), got shape {value.shape}")
    if correction is not None:
        psi = correction.apply(psi, variation)
    h_p = air["pressure_altitude_m"].to_numpy(dtype=float)
    idx, by_pressure = report_schedule(t, air["static_pressure_pa"].to_numpy(dtype=float), h_p, ground * HPA, spec)
    tas = air["tas_mps"].to_numpy(dtype=float)
    sin_psi, cos_psi = np.sin(psi), np.cos(psi)
    u = air["ve_mps"].to_numpy(dtype=float) - tas * sin_psi  # wind paper eq. 1 (east)
    v = air["vn_mps"].to_numpy(dtype=float) - tas * cos_psi  # wind paper eq. 1 (north)
    u_m, v_m, tas_m, s_m, c_m = _window_means(t, idx, spec.averaging_window_s, u, v, tas, sin_psi, cos_psi)
    speed, direction = wind_speed_direction(u_m, v_m)

    j0 = np.searchsorted(t, t[idx] - spec.phase_window_s, side="left")
    dt = t[idx] - t[j0]
    rate = np.divide(h_p[idx] - h_p[j0], dt, out=np.zeros(idx.size), where=dt > 0)
    level = spec.level_rate_fpm * FPM
    phase = np.where(rate > level, "ascent", np.where(rate < -level, "descent", "level"))

    return pd.DataFrame(
        {
            "aircraft": np.full(idx.size, aircraft, dtype=object),
            "time": quantize(start_epoch_s + t[idx], spec.time_step_s),
            "lat": quantize(air["lat_deg"].to_numpy(dtype=float)[idx], spec.lat_lon_step_deg),
            "lon": quantize(air["lon_deg"].to_numpy(dtype=float)[idx], spec.lat_lon_step_deg),
            "pressure_altitude_ft": h_p[idx] / FT,
            "wind_speed_kt": quantize(speed / KT, spec.wind_speed_step_kt),
            "wind_dir_deg": np.mod(quantize(np.degrees(direction), spec.wind_dir_step_deg), 360.0),
            "tas_kt": tas_m / KT,
            "heading_deg": np.mod(np.degrees(np.arctan2(s_m, c_m)), 360.0),
            "roll_deg": np.degrees(truth["roll_rad"].to_numpy(dtype=float)[idx]),
            "phase": phase,
            "trigger": np.where(by_pressure, "pressure", "time"),
            "sample_index": idx,
        }
    )
