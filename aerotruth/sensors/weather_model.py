"""Weather-model analyses derived from the truth atmosphere: the reference wind V_W,REF of
the wind paper (eq. 4, V_A' = V_G - V_W,REF) at each aircraft report.

The paper compares TAMDAR winds with the NOAA GSD Rapid Refresh / RUC ("RR") and AirDat's
RTFDDA (MM5) analyses, and checks with NAM (too sparse and noisy for the fits). Here each
model is a spec (`WeatherModelSpec`, presets `preset("rr" | "rtfdda" | "nam")`) and one
realization per atmosphere (`WeatherModelAnalysis.draw(spec, atmosphere, rng)`):

    V_REF(x, t) = (1 + f) [(1 - a) S(x, t_k) + a S(x, t_k+1)] + b
                  + sigma(p) s(doy) [(1 - a) e(x, t_k) + a e(x, t_k+1)]
    t_k = k T <= t < t_k+1,   a = (t - t_k) / T

* S: the truth wind smoothed to the model's effective resolution, at the analysis times
  t_k (multiples of the analysis interval T after 00:00 UTC), interpolated linearly in time
  between them. The truth is bl(z) [u_syn + env(z) u_meso] (`aerotruth.truth.atmosphere`):
  the synoptic part is evaluated exactly (its shortest wave, 3500 km, passes the filter
  below with H >= 0.9995 for lambda_e <= 91 km); the mesoscale part is a sum of plane waves
  of known wavenumber k_j (`aerotruth.truth.mesoscale`), each multiplied by the low-pass
  response of the model
      H(k) = 2^(-(k lambda_e / 2 pi)^2) = exp(-ln 2 (lambda_e / lambda)^2),
  half amplitude at the effective resolution lambda_e, 0.926 at 3 lambda_e, 0.0625 at
  lambda_e / 2. Modes with H < 1e-3 are dropped. lambda_e = 7 dx: WRF-ARW kinetic-energy
  spectra fall below the observed k^-5/3 at about 7 dx (Skamarock 2004, Mon. Wea. Rev. 132,
  3019-3032); the same factor is used for RUC and MM5/NMM for want of a model-specific one.
  Vertical structure is not filtered (truth vertical scale 1.5 km, model levels 0.3-0.5 km).
* e: analysis error, two independent unit-variance Gaussian fields (u and v) with Gaussian
  covariance in space and time,
      E[e(x1) e(x2)] = exp(-r^2 / (2 L_h^2) - dz^2 / (2 L_z^2) - dt^2 / (2 L_t^2)),
  realized with random Fourier features (Rahimi & Recht 2007): e = sqrt(2/N) sum_j
  cos(k_j . x + m_j z + w_j t + phi_j) with k_j ~ N(0, I/L_h^2), m_j ~ N(0, 1/L_z^2),
  w_j ~ N(0, 1/L_t^2), phi_j ~ U(0, 2 pi): the ensemble covariance is exactly the Gaussian
  above, and the mean of e^2 over one realization tends to exactly 1 as the region grows. L is the
  Gaussian's standard deviation: correlation 0.61 at L, 1/e at sqrt(2) L. The error exists
  at the analysis times and is interpolated with the analysis (at mid-interval its variance
  is (1 + rho(T)) / 2 of sigma^2: 0.97 for RR, 0.80 for NAM).
* sigma(p): per-component error standard deviation, linear in ln p between the levels of
  `sigma_levels`, constant beyond them, times `sigma_scale` (e.g. 1.4 for Alaska: below).
* s(doy) = 1 + A cos(2 pi (doy - d_peak) / P): seasonal factor on sigma.
* b: optional constant bias vector; f: optional relative speed bias (model too slow if < 0).

Numbers (per-component sigma; vector RMS is sqrt(2) sigma):
* Shape: errors grow from the lower troposphere to a maximum at jet level (~250 hPa) and
  with wind speed (RUC verification against rawinsondes, Benjamin et al. 2004, Mon. Wea.
  Rev. 132, 495-518; RUC-1/RUC-2 against ACARS, Schwartz et al. 2000, Wea. Forecasting 15,
  313-326). RR: 2.0 m/s at 850-700 hPa, 2.3 at 500, 3.0 at 300, 3.2 at 250 hPa.
* Size (own budget from the paper): the healthy controls of Tables II and IV show 8.8 kn
  vector RMS TAMDAR-minus-model. If TAMDAR's own vector error is ~6 kn (3.1 m/s), the model
  part is sqrt(8.8^2 - 6^2) = 6.4 kn = 3.3 m/s vector; the RR table gives 2.8-3.4 m/s at the
  SAAB-340's 850-400 hPa, plus the truth the model does not resolve: the Nastrom-Gage
  mesoscale below ~91 km, 0.7-1.0 m/s vector from 1.5 to 7 km at analysis times, and the
  truth's change between analyses, 0.8-1.1 m/s at mid-interval for the hourly models (1.8-2.5
  m/s for 6-hourly NAM: its "noise"); together 3.0-3.6 m/s for RR. Alaska (PenAir, Table
  III): control 11.0 kn -> model sqrt(11^2 - 6^2) = 9.2 kn, 1.4 times Mesaba's:
  `ALASKA_SIGMA_SCALE` (the paper: "lower model accuracy" in Alaska).
* RR: 13-km grid (operational RUC13 since June 2005; GSD's RR development runs also 13 km),
  hourly analyses (Benjamin et al. 2004). RTFDDA: continuous Newtonian-relaxation
  assimilation with hourly output (Liu et al. 2008, J. Appl. Meteor. Climatol. 47,
  1077-1092); AirDat's grid spacing is not in the paper, 12 km assumed; no published
  verification at hand, so the RR error table. NAM: 12-km WRF-NMM with NDAS/GSI analyses
  every 6 h (00, 06, 12, 18 UTC; the 3-hourly fields between are forecasts, not used);
  sigma 1.15 times RR (own choice: 6-h cycle and fewer aircraft data), the paper's
  "sparse and noisy" being mostly the 6-h interval.
* Correlation scales (own choice within published background-error scales of 100-300 km,
  Hollingsworth & Loennberg 1986, Tellus 38A, 111-136): L_h 150 km (RR), 120 km (RTFDDA),
  200 km (NAM); L_z 1.5 km (2 km NAM); L_t 3 h for the hourly systems (errors persist through
  cycles via the background but are carried off by the flow, ~15 m/s across L_h in ~3 h),
  6 h for NAM.
* Season: the paper's controls all got worse in the later period: Mesaba 15 Aug-15 Sep ->
  21 Oct-21 Nov 2009 +0.6 kn (Table II), PenAir 9 Jan-9 Mar -> 27 Mar-27 May 2010 +0.9 kn
  (Table III), Chautauqua 10 Jan-10 Mar -> 11 Mar-11 May 2010 +1.3 kn (Table IV). A
  winter-maximum annual law (Schwartz et al. 2000: RUC errors larger in winter, with the
  stronger winds) gets Mesaba's sign and misses the other two. The presets use a
  semiannual law, period 182.625 d, peak on day 106 (16 April and 16 October), A = 0.11,
  fitted to the three changes assuming they are model changes alone and TAMDAR's own error
  6 kn: it predicts +0.4, +1.2, +0.8 kn (all signs right, each within 0.5 kn; the annual law
  with the same amplitude predicts +0.6, -0.75, -0.3 kn). It is phenomenological (it puts a
  minimum in mid-winter, against Schwartz et al.); set `seasonal_amplitude: 0` to leave the
  control changes unmodelled (the paper subtracts them), or period 365.25 d with peak day 20
  for the annual law.

Heights: reports carry pressure altitude. `apply` converts it to the pressure p (ISA, exact)
and to the geometric height where the truth atmosphere has that pressure (Newton on the
hypsometric equation of the ISA + dT column, < 1e-10 m measured). Taking the ISA height
instead is off by up to 120-135 m on the test days (a dT of 10 K moves 8 km by ~300 m; each
hPa of sea-level pressure ~8 m): up to ~0.4-1 m/s in a 3-8 m/s/km shear. Sigma uses p.

Precision: mode phases are reduced per analysis time in float64 and summed in float32
(float32 cosines are ~25 times faster here): the smoothed truth agrees with the atmosphere's
own float64 evaluation to ~2e-5 m/s. About 2e5 report evaluations per second on one core
(RR, ~400 kept mesoscale modes + 512 error features).
"""

from __future__ import annotations

import datetime as _dt
import math
from typing import Any

import numpy as np
import pandas as pd
from pydantic import Field, StrictInt, field_validator, model_validator

from aerotruth.schema import Section
from aerotruth.truth.atmosphere import TruthAtmosphere
from aerotruth.truth.isa import (
    ISA_R_AIR,
    geometric_altitude_m,
    isa_pressure_pa,
    isa_temperature_k,
    pressure_altitude_m,
)
from aerotruth.units import FT, G0, HPA, KT

_LN2 = math.log(2.0)
_DROP_RESPONSE = 1e-3  # mesoscale modes attenuated below this are left out
_CHUNK = 2048  # points per block: bounds the (points x modes) float32 work arrays
_HYPSOMETRIC_ITERATIONS = 4

ALASKA_SIGMA_SCALE = 1.4  # model error in Alaska / Mesaba region, from Tables II and III (docstring)

_RR_SIGMA = (
    (1000.0, 2.1),
    (850.0, 2.0),
    (700.0, 2.0),
    (500.0, 2.3),
    (300.0, 3.0),
    (250.0, 3.2),
    (200.0, 3.0),
    (100.0, 2.5),
)
_SEASON = {"seasonal_amplitude": 0.11, "seasonal_period_days": 182.625, "seasonal_peak_doy": 106.0}
PRESETS: dict[str, dict[str, Any]] = {
    "rr": {
        "grid_spacing_m": 13e3,
        "effective_resolution_m": 7 * 13e3,
        "analysis_interval_s": 3600.0,
        "sigma_levels": _RR_SIGMA,
        "horizontal_correlation_m": 150e3,
        "vertical_correlation_m": 1500.0,
        "temporal_correlation_s": 3 * 3600.0,
        **_SEASON,
    },
    "rtfdda": {
        "grid_spacing_m": 12e3,
        "effective_resolution_m": 7 * 12e3,
        "analysis_interval_s": 3600.0,
        "sigma_levels": _RR_SIGMA,
        "horizontal_correlation_m": 120e3,
        "vertical_correlation_m": 1500.0,
        "temporal_correlation_s": 3 * 3600.0,
        **_SEASON,
    },
    "nam": {
        "grid_spacing_m": 12e3,
        "effective_resolution_m": 7 * 12e3,
        "analysis_interval_s": 6 * 3600.0,
        "sigma_levels": tuple((p, round(1.15 * s, 4)) for p, s in _RR_SIGMA),
        "horizontal_correlation_m": 200e3,
        "vertical_correlation_m": 2000.0,
        "temporal_correlation_s": 6 * 3600.0,
        **_SEASON,
    },
}


class WeatherModelSpec(Section):
    """A weather model's analyses: resolution, analysis times, error size and correlation.

    `name: rr | rtfdda | nam` fills every field not given from that preset; any other name
    is a custom model and must give every field without a default.
    """

    name: str = Field(min_length=1, description="rr, rtfdda, nam (presets) or a custom model name")
    grid_spacing_m: float = Field(
        gt=0, description="grid spacing dx (m), for the record: the smoothing uses effective_resolution_m"
    )
    effective_resolution_m: float = Field(gt=0, description="lambda_e (m): response 1/2 at this wavelength (~7 dx)")
    analysis_interval_s: float = Field(
        gt=0, description="time between analyses (s); analyses at multiples of it after 00 UTC"
    )
    sigma_levels: tuple[tuple[float, float], ...] = Field(
        min_length=1, description="(pressure hPa, per-component error sigma m/s), pressure decreasing"
    )
    sigma_scale: float = Field(default=1.0, ge=0, description="multiplies every sigma (regional accuracy)")
    horizontal_correlation_m: float = Field(gt=0, description="L_h (m) of the Gaussian error correlation")
    vertical_correlation_m: float = Field(gt=0, description="L_z (m)")
    temporal_correlation_s: float = Field(gt=0, description="L_t (s)")
    seasonal_amplitude: float = Field(default=0.0, ge=0, lt=1, description="A of s(doy) = 1 + A cos(...)")
    seasonal_period_days: float = Field(default=365.25, gt=0)
    seasonal_peak_doy: float = Field(default=20.0, ge=1, le=366)
    bias_ms: tuple[float, float] = Field(default=(0.0, 0.0), description="constant (u, v) bias, m/s (towards)")
    speed_bias_fraction: float = Field(default=0.0, gt=-1, description="analysis wind = (1 + this) x smoothed truth")
    n_features: StrictInt = Field(default=256, ge=16, description="random Fourier features per error component")

    @model_validator(mode="before")
    @classmethod
    def _fill_from_preset(cls, data: Any) -> Any:
        if not isinstance(data, dict) or "name" not in data:
            return data
        name = data["name"]
        if isinstance(name, str) and name in PRESETS:
            return {**PRESETS[name], **data}
        required = [k for k, f in cls.model_fields.items() if f.is_required() and k not in data]
        if required:
            raise ValueError(
                f"name: {name!r} is not a preset ({', '.join(PRESETS)}); a custom model must "
                f"give every field, missing: {', '.join(required)}"
            )
        return data

    @field_validator("sigma_levels")
    @classmethod
    def _levels(cls, v: tuple[tuple[float, float], ...]) -> tuple[tuple[float, float], ...]:
        p = [a for a, _ in v]
        for pr, s in v:
            if not (0 < pr <= 1100):
                raise ValueError(f"pressure must be in (0, 1100] hPa, got {pr}")
            if not (s >= 0 and math.isfinite(s)):
                raise ValueError(f"sigma must be a finite number >= 0 m/s, got {s} at {pr} hPa")
        if any(b >= a for a, b in zip(p, p[1:], strict=False)):
            raise ValueError(f"pressures must decrease strictly (surface first), got {p}")
        return v

    def seasonal_factor(self, date: _dt.date) -> float:
        """s(doy) = 1 + A cos(2 pi (doy - peak) / period) for the day of year of `date`."""
        doy = date.timetuple().tm_yday
        return 1.0 + self.seasonal_amplitude * math.cos(
            2 * math.pi * (doy - self.seasonal_peak_doy) / self.seasonal_period_days
        )

    def sigma_ms(self, pressure_pa, date: _dt.date) -> np.ndarray:
        """Per-component error sigma (m/s) at pressure p (Pa) on `date`: table (linear in
        ln p, constant beyond its ends) x sigma_scale x seasonal factor."""
        p = np.asarray(pressure_pa, dtype=float)
        if np.any(~(p > 0)):
            raise ValueError("pressure_pa must be > 0")
        lnp = -np.log(np.array([a for a, _ in self.sigma_levels]) * HPA)
        sig = np.array([s for _, s in self.sigma_levels])
        return np.interp(-np.log(p), lnp, sig) * self.sigma_scale * self.seasonal_factor(date)

    def response(self, k_rad_per_m) -> np.ndarray:
        """Amplitude response H(k) = exp(-ln 2 (k lambda_e / 2 pi)^2) of the model's smoothing."""
        k = np.asarray(k_rad_per_m, dtype=float)
        return np.exp(-_LN2 * (k * self.effective_resolution_m / (2 * np.pi)) ** 2)


def preset(name: str, **overrides: Any) -> WeatherModelSpec:
    """The spec of a named model (rr, rtfdda, nam), with optional field overrides."""
    if name not in PRESETS:
        raise ValueError(f"name: unknown weather model {name!r}, expected one of {', '.join(PRESETS)}")
    return WeatherModelSpec(name=name, **overrides)


def _column(name: str, x) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite numbers")
    return a


class WeatherModelAnalysis:
    """One model's analyses of one truth atmosphere (one day and region) with one drawn error.

    Mode arrays (float64, over modes: the kept mesoscale modes, then N u-error and N v-error
    features): `kx, ky, kz` (rad/m), `omega` (rad/s), `phase` (rad), `amplitude` (modes x 4:
    columns smoothed mesoscale u, v and unit error fields e_u, e_v).
    """

    def __init__(self, spec: WeatherModelSpec, atmosphere: TruthAtmosphere, kx, ky, kz, omega, phase, amplitude):
        self.spec, self.atmosphere = spec, atmosphere
        self.kx, self.ky, self.kz = (np.ascontiguousarray(a, dtype=float) for a in (kx, ky, kz))
        self.omega = np.ascontiguousarray(omega, dtype=float)
        self.phase = np.ascontiguousarray(phase, dtype=float)
        self.amplitude = np.ascontiguousarray(amplitude, dtype=float)
        self.seasonal_factor = spec.seasonal_factor(atmosphere.date)
        T = spec.analysis_interval_s
        self._coef32 = np.stack([self.kx, self.ky, self.kz, np.zeros_like(self.kx)]).astype(np.float32)
        # value at t_k: cos(P) @ A; at t_k + T: cos(P + wT) = cos P cos wT - sin P sin wT
        # columns 0-3 give the sums at t_k, 4-7 the cosine part of those at t_k + T
        self._amp_cos = np.concatenate(
            [self.amplitude, self.amplitude * np.cos(self.omega * T)[:, None]], axis=1
        ).astype(np.float32)
        self._amp_sin = (-self.amplitude * np.sin(self.omega * T)[:, None]).astype(np.float32)

    @classmethod
    def draw(
        cls, spec: WeatherModelSpec, atmosphere: TruthAtmosphere, rng: np.random.Generator
    ) -> WeatherModelAnalysis:
        """Filter the atmosphere's mesoscale modes and draw the error features from `rng`."""
        if not isinstance(spec, WeatherModelSpec):
            raise ValueError(f"spec must be a WeatherModelSpec, got {type(spec).__name__}")
        if not isinstance(atmosphere, TruthAtmosphere):
            raise ValueError(f"atmosphere must be a TruthAtmosphere, got {type(atmosphere).__name__}")
        m = atmosphere.mesoscale
        h = spec.response(np.hypot(m.kx, m.ky))
        amp_uv = m.amplitude[:, :2] * h[:, None]
        keep = (h >= _DROP_RESPONSE) & np.any(m.amplitude[:, :2] != 0, axis=1)
        n = int(spec.n_features)
        lh, lz, lt = spec.horizontal_correlation_m, spec.vertical_correlation_m, spec.temporal_correlation_s
        fk = rng.normal(0.0, 1.0, (4, 2 * n)) / np.array([lh, lh, lz, lt])[:, None]
        fphase = rng.uniform(0.0, 2 * np.pi, 2 * n)
        famp = np.zeros((2 * n, 4))
        famp[:n, 2] = famp[n:, 3] = math.sqrt(2.0 / n)
        mamp = np.zeros((int(keep.sum()), 4))
        mamp[:, :2] = amp_uv[keep]
        return cls(
            spec,
            atmosphere,
            np.concatenate([m.kx[keep], fk[0]]),
            np.concatenate([m.ky[keep], fk[1]]),
            np.concatenate([m.kz[keep], fk[2]]),
            np.concatenate([m.omega[keep], fk[3]]),
            np.concatenate([m.phase[keep], fphase]),
            np.concatenate([mamp, famp]),
        )

    # evaluation --------------------------------------------------------------------
    def _mode_sums(self, x, y, z, t) -> np.ndarray:
        """(points x 4) mode sums interpolated linearly in time between the analysis times
        bracketing t: smoothed mesoscale u, v and unit error e_u, e_v."""
        T = self.spec.analysis_interval_s
        k = np.floor(t / T)
        alpha = (t / T - k)[:, None].astype(np.float32)
        out = np.empty((x.size, 4), dtype=np.float32)
        keys, inverse = np.unique(k, return_inverse=True)
        for g, kk in enumerate(keys):
            idx = np.flatnonzero(inverse == g)
            coef = self._coef32.copy()
            coef[3] = np.remainder(self.omega * (kk * T) + self.phase, 2 * np.pi)  # phases at t_k
            for s in range(0, idx.size, _CHUNK):
                sel = idx[s : s + _CHUNK]
                pts = np.stack([x[sel], y[sel], z[sel], np.ones(sel.size)], axis=1).astype(np.float32)
                ph = pts @ coef
                vc = np.cos(ph) @ self._amp_cos
                va = vc[:, :4]
                vb = vc[:, 4:] + np.sin(ph, out=ph) @ self._amp_sin
                a = alpha[sel]
                out[sel] = va + a * (vb - va)
        return out.astype(float)

    def _evaluate(self, lat, lon, z, t, zg, pressure_pa, biased: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Analysis wind; without error when pressure_pa is None, without biases unless biased."""
        atm, spec = self.atmosphere, self.spec
        T = spec.analysis_interval_s
        tk = np.floor(t / T) * T
        alpha = (t - tk) / T
        ua, va = atm.synoptic_wind(lat, lon, z, tk)
        ub, vb = atm.synoptic_wind(lat, lon, z, tk + T)
        x, y = atm.plane_xy(lat, lon)
        sums = self._mode_sums(x.ravel(), y.ravel(), z.ravel(), t.ravel()).reshape(lat.shape + (4,))
        env, bl, _ = atm.profiles(z, zg)
        scale, (bu, bv) = (1.0 + spec.speed_bias_fraction, spec.bias_ms) if biased else (1.0, (0.0, 0.0))
        sig = spec.sigma_ms(pressure_pa, atm.date) if pressure_pa is not None else 0.0
        # wind paper eq. 4's V_W,REF: smoothed truth interpolated in time, biases, error
        u = scale * bl * (ua + alpha * (ub - ua) + env * sums[..., 0]) + bu + sig * sums[..., 2]
        v = scale * bl * (va + alpha * (vb - va) + env * sums[..., 1]) + bv + sig * sums[..., 3]
        return u, v

    def _inputs(self, lat_deg, lon_deg, alt_m, t_s, ground_elevation_m=0.0):
        lat, lon, z, t, zg = np.broadcast_arrays(
            *(
                _column(n, a)
                for n, a in (
                    ("lat_deg", lat_deg),
                    ("lon_deg", lon_deg),
                    ("alt_m", alt_m),
                    ("t_s", t_s),
                    ("ground_elevation_m", ground_elevation_m),
                )
            )
        )
        return (np.array(a, dtype=float) for a in (lat, lon, z, t, zg))

    def wind(self, lat_deg, lon_deg, alt_m, t_s, ground_elevation_m=0.0) -> tuple[np.ndarray, np.ndarray]:
        """Analysis wind (u east, v north; m/s, towards) at geometric altitude alt_m (MSL) and
        t_s (s after 00:00 UTC of the atmosphere's date); sigma from the truth's pressure there."""
        lat, lon, z, t, zg = self._inputs(lat_deg, lon_deg, alt_m, t_s, ground_elevation_m)
        p = self.atmosphere.static_pressure(lat, lon, z, t)
        return self._evaluate(lat, lon, z, t, zg, p)

    def smoothed_truth(self, lat_deg, lon_deg, alt_m, t_s, ground_elevation_m=0.0):
        """The analysis without error and biases: smoothed truth interpolated between analyses."""
        lat, lon, z, t, zg = self._inputs(lat_deg, lon_deg, alt_m, t_s, ground_elevation_m)
        return self._evaluate(lat, lon, z, t, zg, None, biased=False)

    def analysis_error(self, lat_deg, lon_deg, alt_m, t_s, pressure_pa) -> tuple[np.ndarray, np.ndarray]:
        """The drawn error (u, v; m/s) at the points, with sigma at pressure_pa (Pa), interpolated
        between analysis times like the analysis itself."""
        lat, lon, z, t, _ = self._inputs(lat_deg, lon_deg, alt_m, t_s)
        p = np.broadcast_to(_column("pressure_pa", pressure_pa), lat.shape)
        x, y = self.atmosphere.plane_xy(lat, lon)
        sums = self._mode_sums(x.ravel(), y.ravel(), z.ravel(), t.ravel()).reshape(lat.shape + (4,))
        sig = self.spec.sigma_ms(p, self.atmosphere.date)
        return sig * sums[..., 2], sig * sums[..., 3]

    # observation tables ---------------------------------------------------------------
    def geometric_altitude_of_pressure_m(self, lat_deg, lon_deg, pressure_pa, t_s) -> np.ndarray:
        """Geometric altitude (m MSL) at which the truth atmosphere has pressure p: Newton on
        the hypsometric equation of its ISA + dT column, H <- H + (R T(H) / g0) ln(p(H) / p)."""
        atm = self.atmosphere
        lat, lon, p, t = np.broadcast_arrays(
            *(
                _column(n, a)
                for n, a in (("lat_deg", lat_deg), ("lon_deg", lon_deg), ("pressure_pa", pressure_pa), ("t_s", t_s))
            )
        )
        dt_k = atm.delta_t(lat, lon, t)
        p_sl = atm.sea_level_pressure(lat, lon, t)
        h = pressure_altitude_m(p)  # the ISA height: tens to hundreds of metres off
        for _ in range(_HYPSOMETRIC_ITERATIONS):
            h = h + ISA_R_AIR * isa_temperature_k(h, dt_k) / G0 * np.log(isa_pressure_pa(h, dt_k, p_sl) / p)
        return geometric_altitude_m(h)

    def apply(self, reports: pd.DataFrame, ground_elevation_m=0.0) -> pd.DataFrame:
        """A copy of an observation table with the reference columns filled from this analysis:
        `ref_wind_speed_kt`, `ref_wind_dir_deg` ("from") and `ref_source` (the model name).

        Needs `time` (UTC epoch seconds or ISO-8601), `lat`, `lon`, `pressure_altitude_ft`;
        `ground_elevation_m` (MSL, scalar or one per row) places the boundary layer.
        """
        missing = [c for c in ("time", "lat", "lon", "pressure_altitude_ft") if c not in reports.columns]
        if missing:
            raise ValueError(f"reports: missing columns {', '.join(missing)} (observation table, docs/data-formats.md)")
        out = reports.copy()
        t = reports["time"]
        if pd.api.types.is_numeric_dtype(t):
            epoch = _column("time", t.to_numpy(dtype=float))
        else:
            try:
                stamps = pd.to_datetime(t, utc=True)
            except (ValueError, TypeError) as exc:
                raise ValueError(f"reports.time: expected UTC epoch seconds or ISO-8601, {exc}") from None
            epoch = (stamps - pd.Timestamp(0, tz="UTC")).dt.total_seconds().to_numpy()
        day0 = _dt.datetime(
            self.atmosphere.date.year, self.atmosphere.date.month, self.atmosphere.date.day, tzinfo=_dt.UTC
        ).timestamp()
        t_s = epoch - day0
        lat = _column("reports.lat", reports["lat"].to_numpy(dtype=float))
        lon = _column("reports.lon", reports["lon"].to_numpy(dtype=float))
        h_p = _column("reports.pressure_altitude_ft", reports["pressure_altitude_ft"].to_numpy(dtype=float)) * FT
        p = isa_pressure_pa(h_p)  # pressure altitude is the ISA height of the static pressure
        z = self.geometric_altitude_of_pressure_m(lat, lon, p, t_s)
        zg = np.broadcast_to(_column("ground_elevation_m", ground_elevation_m), lat.shape)
        u, v = self._evaluate(lat, lon, z, t_s, np.array(zg, dtype=float), p)
        out["ref_wind_speed_kt"] = np.hypot(u, v) / KT
        out["ref_wind_dir_deg"] = np.degrees(np.arctan2(-u, -v)) % 360.0
        out["ref_source"] = self.spec.name
        return out
