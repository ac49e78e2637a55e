"""Air data and GNSS as TAMDAR's wind calculation sees them: true airspeed, pressure
altitude (and the static pressure behind it), GPS position and ground velocity.

Measurement equations, per 10 Hz truth sample k (SI):

    TAS_m[k]  = (1 + s) TAS[k] + b + n_tas[k]          n_tas ~ N(0, sigma_tas^2), white
    h_p,m[k]  = h_p[k] + n_h[k]                         n_h ~ N(0, sigma_h^2), white
    p_m[k]    = p_ISA(h_p,m[k])                         the static pressure that reads h_p,m
    lat_m[k]  = lat[k] + n_N[k] / (M + h)               n_N, n_E ~ N(0, sigma_pos^2) per axis
    lon_m[k]  = lon[k] + n_E[k] / ((N + h) cos lat)
    v_N,m[k]  = v_N[k] + n_vN[k],  v_E,m[k] = v_E[k] + n_vE[k]   ~ N(0, sigma_vel^2) per axis

b (TAS bias) and s (scale factor) are constant over a realization (one aircraft, one
period): drawn once by `AirDataSpec.draw` from N(mean, sigma^2); the white terms are
drawn per sample by `AirDataErrors.apply`. M and N are the WGS-84 meridional and
prime-vertical radii of curvature. Why these terms: the wind paper (section 3) names TAS
and heading as the largest wind errors and takes GPS ground speed and track as "very
accurate"; TAS enters the wind calculation (wind paper eq. 1) along the aircraft axis, so
b and s show up in the longitudinal wind error (section 6). Pressure altitude is
ISA geopotential height (aerotruth.truth.isa), so p_m is the exact inverse of h_p,m.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, get_args

import numpy as np
import pandas as pd
from pydantic import Field

from aerotruth.ellipsoid import radii
from aerotruth.schema import Section
from aerotruth.truth.isa import isa_pressure_pa
from aerotruth.units import FT, KT

AIR_DATA_COLUMNS = (
    "time_s",
    "tas_mps",
    "pressure_altitude_m",
    "static_pressure_pa",
    "lat_deg",
    "lon_deg",
    "vn_mps",
    "ve_mps",
)
_TRUTH_INPUTS = ("time_s", "tas_mps", "pressure_altitude_m", "lat_deg", "lon_deg", "h_ellipsoid_m", "vn_mps", "ve_mps")


class AirDataSpec(Section):
    """Error model of TAS, pressure altitude and GPS (1 sigma values; knots and feet at
    this edge, converted to SI in `draw`)."""

    tas_bias_kt: float = Field(default=0.0, description="mean TAS bias b over realizations")
    tas_bias_sigma_kt: float = Field(default=0.0, ge=0, description="spread of b between realizations (aircraft)")
    tas_scale_factor: float = Field(
        default=0.0, gt=-1, description="mean TAS scale-factor error s (0.01 = reads 1 % high)"
    )
    tas_scale_sigma: float = Field(default=0.0, ge=0, description="spread of s between realizations")
    tas_noise_kt: float = Field(default=0.5, ge=0, description="white TAS noise per 10 Hz sample")
    pressure_altitude_noise_ft: float = Field(default=5.0, ge=0, description="white pressure-altitude noise per sample")
    gps_position_sigma_m: float = Field(default=3.0, ge=0, description="white GPS position noise per horizontal axis")
    gps_velocity_sigma_mps: float = Field(default=0.1, ge=0, description="white GPS velocity noise per horizontal axis")

    def draw(self, rng: np.random.Generator) -> AirDataErrors:
        """One realization: the constant TAS bias and scale factor of one aircraft."""
        bias = (self.tas_bias_kt + self.tas_bias_sigma_kt * rng.standard_normal()) * KT
        scale = self.tas_scale_factor + self.tas_scale_sigma * rng.standard_normal()
        return AirDataErrors(spec=self, tas_bias_mps=float(bias), tas_scale=float(scale))


@dataclass(frozen=True)
class AirDataErrors:
    """A drawn air-data/GPS error realization; `apply` corrupts a truth track."""

    spec: AirDataSpec
    tas_bias_mps: float
    tas_scale: float

    def apply(self, truth: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
        """Measured air data and GPS at every truth sample: a DataFrame with the columns
        AIR_DATA_COLUMNS (SI; lat/lon in degrees), white noise drawn from `rng`."""
        missing = [c for c in _TRUTH_INPUTS if c not in truth.columns]
        if missing:
            raise ValueError(f"truth: missing columns {missing} (expected TruthTrack columns)")
        s = self.spec
        n = len(truth)
        col = {c: truth[c].to_numpy(dtype=float) for c in _TRUTH_INPUTS}
        noise = rng.standard_normal((6, n))
        tas = (1.0 + self.tas_scale) * col["tas_mps"] + self.tas_bias_mps + s.tas_noise_kt * KT * noise[0]
        h_p = col["pressure_altitude_m"] + s.pressure_altitude_noise_ft * FT * noise[1]
        lat = np.radians(col["lat_deg"])
        m, nn = radii(lat)
        h = col["h_ellipsoid_m"]
        sp = s.gps_position_sigma_m
        lat_m = col["lat_deg"] + np.degrees(sp * noise[2] / (m + h))
        lon_m = col["lon_deg"] + np.degrees(sp * noise[3] / ((nn + h) * np.cos(lat)))
        sv = s.gps_velocity_sigma_mps
        return pd.DataFrame(
            {
                "time_s": col["time_s"],
                "tas_mps": tas,
                "pressure_altitude_m": h_p,
                "static_pressure_pa": isa_pressure_pa(h_p),
                "lat_deg": lat_m,
                "lon_deg": lon_m,
                "vn_mps": col["vn_mps"] + sv * noise[4],
                "ve_mps": col["ve_mps"] + sv * noise[5],
            }
        )


def ideal_air_data(truth: pd.DataFrame) -> pd.DataFrame:
    """Error-free air data and GPS (the truth columns under the AIR_DATA_COLUMNS names)."""
    missing = [c for c in AIR_DATA_COLUMNS if c not in truth.columns]
    if missing:
        raise ValueError(f"truth: missing columns {missing} (expected TruthTrack columns)")
    return pd.DataFrame({c: truth[c].to_numpy(dtype=float) for c in AIR_DATA_COLUMNS})


BaroTemperature = Literal["none", "uncorrected", "oat_corrected"]
BARO_TEMPERATURE: tuple[str, ...] = get_args(BaroTemperature)


def barometric_height_error(static_pressure_pa, temperature_k, height_m, ref_index: int, correction: str) -> np.ndarray:
    """Error (m) of a barometric height against the truth atmosphere, its reading set to
    the true height at sample `ref_index` (a QNH set at the field, or an AFIS's runway
    update at the threshold).

    The altimeter turns pressure into height with the ISA: its height change from the
    reference is the pressure-altitude difference dH = H(p) - H(p_ref) (ISA geopotential,
    aerotruth.truth.isa.pressure_altitude_m). By the hypsometric equation a layer's
    thickness is proportional to its mean temperature, so in air warmer than the ISA the
    true climb dh is larger: dH - dh ~ -dh (T - T_ISA) / T, 3.5 % of the height above the
    reference at ISA + 10 K (~34 m at 10 nm on a 3 deg path). A horizontal pressure gradient
    along the path adds its own error (the truth atmosphere has both).

    `correction`: "uncorrected" (the error above), "oat_corrected" (the usual ratio
    correction with the outside air temperature measured at the aircraft, dH x T /
    T_ISA(H): exact in an ISA + dT column, what is left is the column's departure from a
    constant dT and the pressure gradient), "none" (no atmosphere error: zeros). The
    geopotential-to-geometric difference (0.03 % at 1 km) is left out."""
    from aerotruth.truth.isa import isa_temperature_k, pressure_altitude_m

    if correction not in BARO_TEMPERATURE:
        raise ValueError(f"correction: expected one of {', '.join(BARO_TEMPERATURE)}, got {correction!r}")
    h = np.asarray(height_m, float)
    if correction == "none":
        return np.zeros_like(h)
    p = np.asarray(static_pressure_pa, float)
    hp = pressure_altitude_m(p)
    dh_ind = hp - hp[ref_index]
    if correction == "oat_corrected":
        t = np.asarray(temperature_k, float)
        dh_ind = dh_ind * t / isa_temperature_k(hp)
    return dh_ind - (h - h[ref_index])


def baro_error_from_truth(df: pd.DataFrame, rows, x_m, correction: str) -> np.ndarray | None:
    """`barometric_height_error` on a truth track's `rows` (indices into `df`, or None for
    all), referred to the row nearest the threshold (runway-frame x_m = 0, given per row),
    from the truth's static pressure, temperature and ellipsoidal height (height, not the
    runway frame's z: the tangent plane leaves the Earth by d^2 / 2R, 27 m at 10 nm);
    None when `correction` is none."""
    if correction == "none":
        return None
    missing = [c for c in ("static_pressure_pa", "temperature_k", "h_ellipsoid_m") if c not in df.columns]
    if missing:
        raise ValueError(f"track: the barometer's atmosphere error needs the truth columns {missing}")

    def col(name: str) -> np.ndarray:
        v = df[name].to_numpy(float)
        return v if rows is None else v[rows]

    ref = int(np.argmin(np.abs(np.asarray(x_m, float))))
    return barometric_height_error(
        col("static_pressure_pa"), col("temperature_k"), col("h_ellipsoid_m"), ref, correction
    )
