"""Truth atmosphere for one simulated day over a region: wind, temperature, pressure.

    wind(lat, lon, z, t) = b(z_agl) * [u_syn + e(z) u_meso] + w_meso    (u east, v north, w up)
    T(lat, lon, z, t)    = T_ISA(H(z)) + dT(lat, lon, t)
    p(lat, lon, z, t)    = hydrostatic integral of T from p_sl(lat, lon, t) at H = 0

* Synoptic flow (`u_syn`): a westerly mean flow U(z) M(lat) whose speed grows with
  height to a jet maximum (default ~11 km, 23 m/s in summer to 36 m/s in winter at the
  core) and decays above it; the core lies at the season's climatological latitude over
  North America (36 N in mid-February to 51 N in mid-August, HWM14) and meanders day to
  day, so that a region's mean flow is the climatology's (see WindFieldSpec), plus a few
  baroclinic waves given by a streamfunction on the sphere, psi_j = A_j(z, t) cos(Theta_j)
  cos(l_j (lat - lat_j)), with
  u = -(1/R) d(psi)/d(lat), v = 1/(R cos lat) d(psi)/d(lon): the synoptic flow is exactly
  non-divergent on the sphere. Waves move east at c_j ~ 10 m/s, grow or decay
  exponentially through the day and tilt westward with height (as baroclinic waves do).
* Mesoscale perturbations (`u_meso`, `w_meso`): see `aerotruth.truth.mesoscale`
  (Nastrom & Gage 1985 spectrum); evaluated on a local tangent plane x = R cos(lat0)
  (lon - lon0), y = R (lat - lat0). e(z) rises from 0.6 at the surface to 1 at jet level
  (NG85 measured the spectrum at 9-14 km).
* Boundary layer: horizontal wind scaled by b = clip(z_agl / 1000 m, 0.002, 1)^(1/7)
  (power-law profile), so a 15 m/s flow aloft gives ~ 8 m/s at 10 m.
* Temperature: ISA plus a column-constant offset dT(lat, lon, t): seasonal and
  latitudinal climate offset, a meridional gradient set by thermal wind from the mean
  tropospheric shear, dT/dy = -(f T / g) dU/dz (thermal wind: Holton 2004, An
  Introduction to Dynamic Meteorology, 4th ed., sec. 3.4), saturating 1500 km from the
  region centre, and two slowly
  moving large-scale anomalies. The waves carry no temperature signal.
* Sea-level pressure: 101325 Pa + a random offset + rho0 f0 psi(z = 0), i.e. in
  geostrophic balance with the synoptic flow at z = 0 (before the boundary-layer
  reduction): p' = rho f psi (geostrophic wind with constant f, Holton sec. 2.4.1).

ISA: ICAO Doc 7488/3, in `aerotruth.truth.isa` (re-exported here): "ISA + dT" keeps
the ISA layer heights and lapse rates and shifts every temperature by dT; pressure
follows from the hypsometric equation per layer. `pressure_altitude_m(p)` is the ISA
geopotential height at which p occurs (what an altimeter set to 1013.25 hPa shows).

Geometric altitudes are above mean sea level; `ground_elevation_m` tells the wind where
the ground is. Intended use: within ~2000 km of the region centre, t within a day or
so of 00:00 UTC of the date.
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import math
from dataclasses import dataclass, field

import numpy as np
from scipy.special import erf

from aerotruth.truth.isa import (  # noqa: F401  (re-exported: the ISA API lives here too)
    H_BOTTOM_M,
    H_TOP_M,
    ISA_EARTH_RADIUS_M,
    ISA_P0_PA,
    geometric_altitude_m,
    geopotential_altitude_m,
    isa_point,
    isa_pressure_pa,
    isa_temperature_k,
    pressure_altitude_m,
)
from aerotruth.truth.mesoscale import MesoscaleField, MesoscaleSpec
from aerotruth.units import EARTH_RADIUS_M, G0

REGIONS: dict[str, tuple[float, float]] = {
    # centre (lat, lon) of the networks in saab340b-facts.md
    "upper_midwest": (45.0, -91.0),  # Mesaba: MSP/DTW hubs, 40-50 N, 80-105 W
    "alaska": (58.0, -157.0),  # PenAir: Anchorage to SW Alaska, 52-63 N, 145-170 W
    "eastern_us": (40.0, -84.0),  # Chautauqua: IND, CMH, STL, ORD
}

OMEGA_EARTH = 7.2921159e-5  # rad/s
_RHO0 = 1.225  # kg/m^3, ISA sea-level density, for the geostrophic sea-level pressure
_T_MID_TROPOSPHERE_K = 250.0  # for the thermal-wind temperature gradient
_DELTA_T_SATURATION_M = 1.5e6  # the thermal-wind gradient saturates (tanh) beyond this
_DAY_S = 86400.0
_MID_DAY_S = 43200.0
_MAX_ABS_LAT = 89.0  # v = (1/(R cos lat)) dpsi/dlon: stay off the poles
_Z_MIN_M = float(geometric_altitude_m(H_BOTTOM_M))  # geometric altitudes of the ISA table ends
_Z_MAX_M = float(geometric_altitude_m(H_TOP_M))


def _as_float_array(name: str, x) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if not np.all(np.isfinite(a)):
        raise ValueError(f"{name} must be finite numbers, got non-finite values")
    return a


# --- specification -------------------------------------------------------------------
WIND_FIELD_YAML = "wind_field.yaml"  # in the package's truth/data folder


def _wind_field_file():
    from importlib import resources

    return resources.files("aerotruth.truth").joinpath("data").joinpath(WIND_FIELD_YAML)


def _load_wind_field(fields: tuple[str, ...], mesoscale_fields: tuple[str, ...], src=None) -> dict:
    """The truth atmosphere's parameters from truth/data/wind_field.yaml (each value there
    with its source; `src` another file of that form): every WindFieldSpec field, lists as
    tuples; ValueError naming the file and the field for a field missing, unknown or not a
    number."""
    import yaml

    src = _wind_field_file() if src is None else src
    raw = yaml.safe_load(src.read_text(encoding="utf-8"))
    if not isinstance(raw, dict):
        raise ValueError(f"{src}: expected a mapping of WindFieldSpec fields")

    def check(d: dict, names: tuple[str, ...], where: str) -> dict:
        missing = [n for n in names if n not in d]
        unknown = [n for n in d if n not in names]
        if missing or unknown:
            raise ValueError(
                f"{src}: {where} "
                + "; ".join(
                    x
                    for x in (missing and f"missing {', '.join(missing)}", unknown and f"unknown {', '.join(unknown)}")
                    if x
                )
            )
        out = {}
        for k, v in d.items():
            items = v if isinstance(v, list) else [v]
            if k != "mesoscale" and not all(
                isinstance(x, (int, float)) or (x is None and k == "rms_ms") for x in items
            ):
                raise ValueError(f"{src}: {k}: expected a number or a list of numbers, got {v!r}")
            out[k] = tuple(v) if isinstance(v, list) else v
        return out

    out = check(raw, fields, "WindFieldSpec")
    if not isinstance(raw["mesoscale"], dict):
        raise ValueError(f"{src}: mesoscale: expected a mapping of MesoscaleSpec fields")
    out["mesoscale"] = check(raw["mesoscale"], mesoscale_fields, "mesoscale")
    return out


_WIND_FIELD_FIELDS = (
    "jet_speed_winter_ms",
    "jet_speed_summer_ms",
    "jet_speed_spread",
    "jet_latitude_winter_deg",
    "jet_latitude_summer_deg",
    "jet_latitude_southmost_doy",
    "jet_latitude_sd_deg",
    "jet_altitude_m",
    "jet_altitude_seasonal_m",
    "surface_geostrophic_ms",
    "jet_lower_width_m",
    "jet_lower_width_summer_m",
    "stratosphere_decay_m",
    "stratosphere_fraction",
    "jet_meridional_width_deg",
    "jet_meridional_contrast",
    "n_waves",
    "wave_wavelength_m",
    "wave_meridional_wavelength_m",
    "wave_amplitude_ms",
    "wave_surface_fraction",
    "wave_phase_speed_ms",
    "wave_growth_per_day",
    "wave_tilt_rad",
    "boundary_layer_depth_m",
    "boundary_layer_exponent",
    "mesoscale",
    "mesoscale_surface_fraction",
    "delta_t_at_40n_k",
    "delta_t_per_deg_lat_k",
    "delta_t_seasonal_k",
    "delta_t_thermal_wind",
    "delta_t_synoptic_k",
    "delta_t_offset_sd_k",
    "sea_level_pressure_sd_pa",
)
_D = _load_wind_field(_WIND_FIELD_FIELDS, tuple(MesoscaleSpec.__dataclass_fields__))


@dataclass(frozen=True)
class WindFieldSpec:
    """The truth atmosphere's parameters (SI), defaults from truth/data/wind_field.yaml,
    where each value stands with what it represents and its source; a field given here
    replaces the file's (tests and studies of the field itself; the truth store's flights
    fly the file's).

    Jet speed, latitude and the depth of its shear interpolate between summer and winter
    values with day of year (coldest/strongest on 20 January); the speed is drawn times
    1 + jet_speed_spread * U(-1, 1) and the latitude meanders day to day by
    N(0, jet_latitude_sd_deg) about its season's. The mean flow is calibrated on the HWM14
    climatology's mean vectors, the waves' amplitude on the Range Reference Atmosphere's
    wind-speed statistics at Kodiak (campaigns/wind_climatology.yaml, docs/calibration-log.md).
    """

    jet_speed_winter_ms: float = _D["jet_speed_winter_ms"]
    jet_speed_summer_ms: float = _D["jet_speed_summer_ms"]
    jet_speed_spread: float = _D["jet_speed_spread"]
    jet_latitude_winter_deg: float = _D["jet_latitude_winter_deg"]
    jet_latitude_summer_deg: float = _D["jet_latitude_summer_deg"]
    jet_latitude_southmost_doy: float = _D["jet_latitude_southmost_doy"]
    jet_latitude_sd_deg: float = _D["jet_latitude_sd_deg"]
    jet_altitude_m: float = _D["jet_altitude_m"]
    jet_altitude_seasonal_m: float = _D["jet_altitude_seasonal_m"]
    surface_geostrophic_ms: float = _D["surface_geostrophic_ms"]
    jet_lower_width_m: float = _D["jet_lower_width_m"]
    jet_lower_width_summer_m: float = _D["jet_lower_width_summer_m"]
    stratosphere_decay_m: float = _D["stratosphere_decay_m"]
    stratosphere_fraction: float = _D["stratosphere_fraction"]
    jet_meridional_width_deg: float = _D["jet_meridional_width_deg"]
    jet_meridional_contrast: float = _D["jet_meridional_contrast"]
    n_waves: int = _D["n_waves"]
    wave_wavelength_m: tuple[float, float] = _D["wave_wavelength_m"]
    wave_meridional_wavelength_m: tuple[float, float] = _D["wave_meridional_wavelength_m"]
    wave_amplitude_ms: tuple[float, float] = _D["wave_amplitude_ms"]
    wave_surface_fraction: float = _D["wave_surface_fraction"]
    wave_phase_speed_ms: tuple[float, float] = _D["wave_phase_speed_ms"]
    wave_growth_per_day: float = _D["wave_growth_per_day"]
    wave_tilt_rad: tuple[float, float] = _D["wave_tilt_rad"]
    boundary_layer_depth_m: float = _D["boundary_layer_depth_m"]
    boundary_layer_exponent: float = _D["boundary_layer_exponent"]
    mesoscale: MesoscaleSpec = field(default_factory=lambda: MesoscaleSpec(**_D["mesoscale"]))
    mesoscale_surface_fraction: float = _D["mesoscale_surface_fraction"]
    delta_t_at_40n_k: float = _D["delta_t_at_40n_k"]
    delta_t_per_deg_lat_k: float = _D["delta_t_per_deg_lat_k"]
    delta_t_seasonal_k: float = _D["delta_t_seasonal_k"]
    delta_t_thermal_wind: bool = _D["delta_t_thermal_wind"]
    delta_t_synoptic_k: float = _D["delta_t_synoptic_k"]
    delta_t_offset_sd_k: float = _D["delta_t_offset_sd_k"]
    sea_level_pressure_sd_pa: float = _D["sea_level_pressure_sd_pa"]

    def __post_init__(self) -> None:
        for name in (
            "jet_speed_winter_ms",
            "jet_speed_summer_ms",
            "jet_altitude_m",
            "jet_lower_width_m",
            "jet_lower_width_summer_m",
            "stratosphere_decay_m",
            "jet_meridional_width_deg",
            "boundary_layer_depth_m",
            "boundary_layer_exponent",
        ):
            if not (getattr(self, name) > 0):
                raise ValueError(f"WindFieldSpec.{name} must be > 0, got {getattr(self, name)!r}")
        if not (
            0
            <= self.surface_geostrophic_ms
            < min(self.jet_speed_summer_ms, self.jet_speed_winter_ms) * (1 - self.jet_speed_spread)
        ):
            raise ValueError("WindFieldSpec.surface_geostrophic_ms must be >= 0 and below the lowest jet speed")
        if not (0 <= self.jet_speed_spread < 1):
            raise ValueError("WindFieldSpec.jet_speed_spread must be in [0, 1)")
        if not (0 <= self.jet_meridional_contrast < 1):
            raise ValueError("WindFieldSpec.jet_meridional_contrast must be in [0, 1)")
        if not (self.jet_latitude_sd_deg >= 0):
            raise ValueError("WindFieldSpec.jet_latitude_sd_deg must be >= 0")
        if int(self.n_waves) < 0:
            raise ValueError("WindFieldSpec.n_waves must be >= 0")
        for name in (
            "wave_wavelength_m",
            "wave_meridional_wavelength_m",
            "wave_amplitude_ms",
            "wave_phase_speed_ms",
            "wave_tilt_rad",
        ):
            lo, hi = getattr(self, name)
            if not (lo <= hi):
                raise ValueError(f"WindFieldSpec.{name} must be (low, high) with low <= high")
        if not isinstance(self.mesoscale, MesoscaleSpec):
            raise ValueError("WindFieldSpec.mesoscale must be a MesoscaleSpec")


def _season_weight(doy: int, peak_doy: float) -> float:
    """0.5 (1 + cos(2 pi (doy - peak) / 365.25)): 1 on the peak day, 0 half a year away."""
    return 0.5 * (1 + math.cos(2 * math.pi * (doy - peak_doy) / 365.25))


def _seasonal(summer: float, winter: float, weight: float) -> float:
    """The summer value moved towards the winter value by `weight` (0 summer, 1 winter)."""
    return summer + (winter - summer) * weight


def _stable_words(text: str) -> tuple[int, int]:
    d = hashlib.sha256(text.encode("utf-8")).digest()
    return int.from_bytes(d[:4], "little"), int.from_bytes(d[4:8], "little")


def _resolve_region(region) -> tuple[str, float, float]:
    if isinstance(region, str):
        if region not in REGIONS:
            raise ValueError(f"region must be one of {sorted(REGIONS)} or (lat0, lon0), got {region!r}")
        lat0, lon0 = REGIONS[region]
        return region, lat0, lon0
    try:
        lat0, lon0 = (float(v) for v in region)
    except (TypeError, ValueError):
        raise ValueError(f"region must be a name or (lat0_deg, lon0_deg), got {region!r}") from None
    if not (15.0 <= lat0 <= 75.0) or not (-180.0 <= lon0 <= 180.0):
        raise ValueError(
            f"region (lat0, lon0) must have 15 <= lat0 <= 75 (northern mid-latitude "
            f"westerlies) and -180 <= lon0 <= 180, got {region!r}"
        )
    return f"{lat0:.6f},{lon0:.6f}", lat0, lon0


# --- the atmosphere ------------------------------------------------------------------
def _is_point(*args) -> bool:
    return all(type(a) is float or type(a) is int or np.ndim(a) == 0 for a in args)


def _point_float(name: str, x) -> float:
    v = float(x)
    if not math.isfinite(v):
        raise ValueError(f"{name} must be a finite number, got {x!r}")
    return v


class TruthAtmosphere:
    """One realization of the truth atmosphere; build it with `for_day`.

    Times are seconds since 00:00 UTC of `date`; lat/lon in degrees; altitudes in metres
    (geometric, above MSL). Scalar arguments give floats (a fast path for the flight
    loop); array arguments broadcast and give arrays. The two paths evaluate the same
    formulas and agree to rounding (~1e-12 relative), not bit for bit.
    """

    def __init__(
        self,
        date: _dt.date,
        region_key: str,
        lat0: float,
        lon0: float,
        spec: WindFieldSpec,
        rng_syn: np.random.Generator,
        rng_meso: np.random.Generator,
        rng_thermo: np.random.Generator,
    ):
        self.date, self.region_key, self.spec = date, region_key, spec
        self.lat0, self.lon0 = float(lat0), float(lon0)
        s = spec
        r = EARTH_RADIUS_M
        self.f0 = 2 * OMEGA_EARTH * math.sin(math.radians(lat0))
        self._coslat0 = math.cos(math.radians(lat0))
        doy = date.timetuple().tm_yday
        self.winterness = _season_weight(doy, 20.0)  # 1 on 20 Jan

        # mean flow
        jet = _seasonal(s.jet_speed_summer_ms, s.jet_speed_winter_ms, self.winterness)
        self.jet_speed_ms = float(jet * (1 + s.jet_speed_spread * rng_syn.uniform(-1, 1)))
        self.jet_altitude_m = float(
            s.jet_altitude_m + s.jet_altitude_seasonal_m * (0.5 - self.winterness) + rng_syn.uniform(-300.0, 300.0)
        )
        self.surface_ms = float(s.surface_geostrophic_ms)
        self.jet_lower_width_m = float(_seasonal(s.jet_lower_width_summer_m, s.jet_lower_width_m, self.winterness))
        self._g0 = math.exp(-((self.jet_altitude_m / self.jet_lower_width_m) ** 2))  # G(z=0)
        southness = _season_weight(doy, s.jet_latitude_southmost_doy)
        self.jet_lat_deg = float(
            _seasonal(s.jet_latitude_summer_deg, s.jet_latitude_winter_deg, southness)
            + rng_syn.normal(0.0, s.jet_latitude_sd_deg)
        )
        # waves: psi_j = A_j cos(Theta_j) cos(l_j (lat - lat_j))
        n = int(s.n_waves)
        lam = rng_syn.uniform(*s.wave_wavelength_m, n)
        self.wave_wavelengths_m = lam
        self._wm = 2 * np.pi * r * self._coslat0 / lam  # zonal wavenumber per radian of lon
        self._wl = 2 * np.pi * r / rng_syn.uniform(*s.wave_meridional_wavelength_m, n)
        self._wlat = np.radians(lat0 + rng_syn.uniform(-10.0, 10.0, n))
        v_amp = rng_syn.uniform(*s.wave_amplitude_ms, n) * (self.jet_speed_ms / 45.0)
        self._wa = v_amp * r * self._coslat0 / self._wm  # psi amplitude at jet level, m^2/s
        self._womega = self._wm * rng_syn.uniform(*s.wave_phase_speed_ms, n) / (r * self._coslat0)
        self._wphase = rng_syn.uniform(0.0, 2 * np.pi, n)
        self._wgrowth = rng_syn.uniform(-1.0, 1.0, n) * s.wave_growth_per_day / _DAY_S
        self._wtilt = rng_syn.uniform(*s.wave_tilt_rad, n)
        self._waves = tuple(
            zip(
                *(
                    a.tolist()
                    for a in (
                        self._wa,
                        self._wm,
                        self._wl,
                        self._wlat,
                        self._womega,
                        self._wphase,
                        self._wgrowth,
                        self._wtilt,
                    )
                ),
                strict=False,
            )
        )

        self.mesoscale = MesoscaleField.draw(s.mesoscale, rng_meso)

        # temperature offset and sea-level pressure
        # the mean flow's shear over the region's centre: u = U(z) M(lat)
        self.tropospheric_shear_per_s = (
            (self.jet_speed_ms - self.surface_ms)
            / self.jet_altitude_m
            * float(self._meridional_shape(math.radians(lat0)))
        )
        # thermal wind: dT/dy = -(f T / g) dU/dz (Holton 2004 sec. 3.4)
        self.delta_t_gradient_k_per_m = (
            -self.f0 * _T_MID_TROPOSPHERE_K / G0 * self.tropospheric_shear_per_s if s.delta_t_thermal_wind else 0.0
        )
        self.delta_t_climate_k = float(
            s.delta_t_at_40n_k
            + s.delta_t_per_deg_lat_k * (lat0 - 40.0)
            - s.delta_t_seasonal_k * (2 * self.winterness - 1)
        )
        self.delta_t_offset_k = float(rng_thermo.normal(0.0, s.delta_t_offset_sd_k))
        n_t = 2
        k_t = 2 * np.pi / rng_thermo.uniform(2.0e6, 5.0e6, n_t)
        th_t = rng_thermo.uniform(0.0, 2 * np.pi, n_t)
        self._tkx, self._tky = k_t * np.cos(th_t), k_t * np.sin(th_t)
        self._tomega = -self._tkx * 10.0  # anomalies carried east at 10 m/s
        self._tphase = rng_thermo.uniform(0.0, 2 * np.pi, n_t)
        self._tamp = np.full(n_t, s.delta_t_synoptic_k * np.sqrt(2.0 / n_t))
        self._tmodes = tuple(
            zip(*(a.tolist() for a in (self._tkx, self._tky, self._tomega, self._tphase, self._tamp)), strict=False)
        )
        self.sea_level_pressure_offset_pa = float(rng_thermo.normal(0.0, s.sea_level_pressure_sd_pa))

    # construction ------------------------------------------------------------------
    @classmethod
    def for_day(
        cls,
        date: _dt.date,
        seed: int | np.random.SeedSequence,
        region: str | tuple[float, float],
        spec: WindFieldSpec | None = None,
    ) -> TruthAtmosphere:
        """Realization for (date, seed, region): bit-identical for the same triple (and spec).

        Stream: SeedSequence(seed, spawn_key=(two words of sha256(date|region))), split
        into independent children for the synoptic, mesoscale and thermal parts (so e.g.
        changing n_waves leaves the mesoscale field unchanged). A SeedSequence seed keeps
        its entropy and spawn key and gets the same two words appended.
        """
        if not isinstance(date, _dt.date):
            raise ValueError(f"date must be a datetime.date, got {date!r}")
        if isinstance(date, _dt.datetime):
            date = date.date()
        spec = WindFieldSpec() if spec is None else spec
        if not isinstance(spec, WindFieldSpec):
            raise ValueError(f"spec must be a WindFieldSpec, got {type(spec).__name__}")
        key, lat0, lon0 = _resolve_region(region)
        words = _stable_words(f"truth-atmosphere|{date.isoformat()}|{key}")
        if isinstance(seed, np.random.SeedSequence):
            ss = np.random.SeedSequence(seed.entropy, spawn_key=tuple(seed.spawn_key) + words, pool_size=seed.pool_size)
        elif isinstance(seed, (int, np.integer)) and not isinstance(seed, bool) and seed >= 0:
            ss = np.random.SeedSequence(int(seed), spawn_key=words)
        else:
            raise ValueError(f"seed must be a non-negative int or a numpy SeedSequence, got {seed!r}")
        syn, meso, thermo = (np.random.default_rng(c) for c in ss.spawn(3))
        return cls(date, key, lat0, lon0, spec, syn, meso, thermo)

    # coordinates --------------------------------------------------------------------
    def plane_xy(self, lat_deg, lon_deg) -> tuple[np.ndarray, np.ndarray]:
        """Tangent-plane coordinates (m) of the mesoscale field and temperature anomalies:
        x = R cos(lat0) (lon - lon0) with the longitude difference wrapped to [-180, 180),
        y = R (lat - lat0)."""
        dlon = (np.asarray(lon_deg, dtype=float) - self.lon0 + 180.0) % 360.0 - 180.0
        x = EARTH_RADIUS_M * self._coslat0 * np.radians(dlon)
        y = EARTH_RADIUS_M * np.radians(np.asarray(lat_deg, dtype=float) - self.lat0)
        return x, y

    def _plane_xy_point(self, lat: float, lon: float) -> tuple[float, float]:
        dlon = (lon - self.lon0 + 180.0) % 360.0 - 180.0
        return (EARTH_RADIUS_M * self._coslat0 * math.radians(dlon), EARTH_RADIUS_M * math.radians(lat - self.lat0))

    # synoptic flow ------------------------------------------------------------------
    def mean_zonal_profile(self, alt_m) -> np.ndarray:
        """U(z) (m/s): westerly speed of the mean flow at the jet-core latitude.

        Below the jet U = U_0 + (U_j - U_0) (G(z) - G(0)) / (1 - G(0)) with the Gaussian
        G = exp(-((z - z_j)/h)^2), h = `jet_lower_width_m` in winter to `jet_lower_width_summer_m`
        in summer: nearly uniform shear through the
        mid troposphere, zero shear at the jet, U(0) = U_0. Above the jet a Gaussian decay
        (`stratosphere_decay_m`) towards `stratosphere_fraction` U_j.
        """
        z = np.asarray(alt_m, dtype=float)
        uj, zj, u0, g0 = self.jet_speed_ms, self.jet_altitude_m, self.surface_ms, self._g0
        gz = np.exp(-(((z - zj) / self.jet_lower_width_m) ** 2))
        below = u0 + (uj - u0) * (gz - g0) / (1.0 - g0)
        floor = self.spec.stratosphere_fraction * uj
        above = floor + (uj - floor) * np.exp(-(((z - zj) / self.spec.stratosphere_decay_m) ** 2))
        return np.where(z <= zj, below, above)

    def _mean_zonal_point(self, z: float) -> float:
        uj, zj, u0, g0 = self.jet_speed_ms, self.jet_altitude_m, self.surface_ms, self._g0
        if z <= zj:
            gz = math.exp(-(((z - zj) / self.jet_lower_width_m) ** 2))
            return u0 + (uj - u0) * (gz - g0) / (1.0 - g0)
        floor = self.spec.stratosphere_fraction * uj
        return floor + (uj - floor) * math.exp(-(((z - zj) / self.spec.stratosphere_decay_m) ** 2))

    def _meridional_shape(self, lat_rad):
        """M(lat): 1 at the jet core, 1 - contrast far from it (Gaussian in latitude)."""
        w = math.radians(self.spec.jet_meridional_width_deg)
        c = self.spec.jet_meridional_contrast
        return 1.0 - c * (1.0 - np.exp(-(((lat_rad - math.radians(self.jet_lat_deg)) / w) ** 2)))

    def _wave_vertical(self, uz):
        p = self.spec.wave_surface_fraction
        return p + (1 - p) * uz / self.jet_speed_ms

    def _tilt(self, z):
        return np.tanh(z / self.jet_altitude_m) / math.tanh(1.0)

    def _wave_terms(self, latr, lonr, z, t, uz):
        """Per wave (last axis): amplitude A(z, t), phase Theta, meridional angle."""
        dlon = (lonr - math.radians(self.lon0) + math.pi) % (2 * math.pi) - math.pi
        amp = self._wa * np.exp(self._wgrowth * (t[..., None] - _MID_DAY_S)) * self._wave_vertical(uz)[..., None]
        theta = (
            self._wm * dlon[..., None]
            - self._womega * t[..., None]
            + self._wphase
            + self._wtilt * self._tilt(z)[..., None]
        )
        merid = self._wl * (latr[..., None] - self._wlat)
        return amp, theta, merid

    def synoptic_wind(self, lat_deg, lon_deg, alt_m, t_s):
        """(u, v) m/s of the synoptic flow (mean flow + waves) in the free atmosphere (no
        boundary layer): u = -(1/R) dpsi/dlat, v = 1/(R cos lat) dpsi/dlon."""
        # floats on the point path, arrays below it
        lat: float | np.ndarray
        lon: float | np.ndarray
        z: float | np.ndarray
        t: float | np.ndarray
        if _is_point(lat_deg, lon_deg, alt_m, t_s):
            lat, lon, z, t = self._check_point(lat_deg, lon_deg, alt_m, t_s)
            return self._synoptic_point(lat, lon, z, t)
        lat, lon, z, t = np.broadcast_arrays(*self._check_arrays(lat_deg, lon_deg, alt_m, t_s))
        latr, lonr = np.radians(lat), np.radians(lon)
        uz = self.mean_zonal_profile(z)
        amp, theta, merid = self._wave_terms(latr, lonr, z, t, uz)
        r = EARTH_RADIUS_M
        u = uz * self._meridional_shape(latr) + np.sum(amp * (self._wl / r) * np.cos(theta) * np.sin(merid), axis=-1)
        v = -np.sum(amp * self._wm * np.sin(theta) * np.cos(merid), axis=-1) / (r * np.cos(latr))
        return u, v

    def _synoptic_point(self, lat: float, lon: float, z: float, t: float) -> tuple[float, float]:
        latr = math.radians(lat)
        dlon = (math.radians(lon) - math.radians(self.lon0) + math.pi) % (2 * math.pi) - math.pi
        uz = self._mean_zonal_point(z)
        w = math.radians(self.spec.jet_meridional_width_deg)
        c = self.spec.jet_meridional_contrast
        u = uz * (1.0 - c * (1.0 - math.exp(-(((latr - math.radians(self.jet_lat_deg)) / w) ** 2))))
        vert = self._wave_vertical(uz)
        tilt = math.tanh(z / self.jet_altitude_m) / math.tanh(1.0)
        r = EARTH_RADIUS_M
        vsum = 0.0
        for a, m, l_, lat_j, om, ph, g, tl in self._waves:
            amp = a * math.exp(g * (t - _MID_DAY_S)) * vert
            theta = m * dlon - om * t + ph + tl * tilt
            merid = l_ * (latr - lat_j)
            u += amp * (l_ / r) * math.cos(theta) * math.sin(merid)
            vsum += amp * m * math.sin(theta) * math.cos(merid)
        return u, -vsum / (r * math.cos(latr))

    def _surface_streamfunction(self, latr, lonr, t):
        """psi (m^2/s) of the synoptic flow at z = 0: -R U(0) int M dlat (from lat0) + waves."""
        w = math.radians(self.spec.jet_meridional_width_deg)
        c = self.spec.jet_meridional_contrast
        lj, l0 = math.radians(self.jet_lat_deg), math.radians(self.lat0)
        int_m = (1 - c) * (latr - l0) + c * w * math.sqrt(math.pi) / 2 * (
            erf((latr - lj) / w) - math.erf((l0 - lj) / w)
        )
        u0 = self._mean_zonal_point(0.0)
        z0 = np.zeros(np.shape(latr))
        amp, theta, merid = self._wave_terms(latr, lonr, z0, t, np.full(z0.shape, u0))
        return -EARTH_RADIUS_M * u0 * int_m + np.sum(amp * np.cos(theta) * np.cos(merid), axis=-1)

    def _surface_streamfunction_point(self, latr: float, lonr: float, t: float) -> float:
        w = math.radians(self.spec.jet_meridional_width_deg)
        c = self.spec.jet_meridional_contrast
        lj, l0 = math.radians(self.jet_lat_deg), math.radians(self.lat0)
        int_m = (1 - c) * (latr - l0) + c * w * math.sqrt(math.pi) / 2 * (
            math.erf((latr - lj) / w) - math.erf((l0 - lj) / w)
        )
        u0 = self._mean_zonal_point(0.0)
        psi = -EARTH_RADIUS_M * u0 * int_m
        dlon = (lonr - math.radians(self.lon0) + math.pi) % (2 * math.pi) - math.pi
        vert = self._wave_vertical(u0)
        for a, m, l_, lat_j, om, ph, g, _tl in self._waves:
            theta = m * dlon - om * t + ph  # tilt(0) = 0
            psi += a * math.exp(g * (t - _MID_DAY_S)) * vert * math.cos(theta) * math.cos(l_ * (latr - lat_j))
        return psi

    # full wind ------------------------------------------------------------------------
    def profiles(self, z, zg):
        """Mesoscale envelope e(z), boundary-layer factor b(z_agl), w taper (arrays or
        floats) at geometric height z over ground at zg (m): the factors `wind` applies,
        public for models derived from the truth (aerotruth.sensors.weather_model)."""
        s = self.spec
        env = s.mesoscale_surface_fraction + (1 - s.mesoscale_surface_fraction) * np.clip(
            z / self.jet_altitude_m, 0.0, 1.0
        )
        bl = np.clip((z - zg) / s.boundary_layer_depth_m, 0.002, 1.0) ** s.boundary_layer_exponent
        w_taper = np.clip((z - zg) / 500.0, 0.0, 1.0)  # w -> 0 at the ground
        return env, bl, w_taper

    def wind(self, lat_deg, lon_deg, alt_m, t_s, ground_elevation_m=0.0):
        """Truth wind (u east, v north, w up; m/s; the direction the air moves towards) at
        geometric altitude alt_m above MSL; ground_elevation_m (MSL) sets the boundary layer."""
        # floats on the point path, arrays below it
        lat: float | np.ndarray
        lon: float | np.ndarray
        z: float | np.ndarray
        t: float | np.ndarray
        zg: float | np.ndarray
        x: float | np.ndarray
        y: float | np.ndarray
        um: float | np.ndarray
        vm: float | np.ndarray
        wm: float | np.ndarray
        if _is_point(lat_deg, lon_deg, alt_m, t_s, ground_elevation_m):
            lat, lon, z, t = self._check_point(lat_deg, lon_deg, alt_m, t_s)
            zg = _point_float("ground_elevation_m", ground_elevation_m)
            us, vs = self._synoptic_point(lat, lon, z, t)
            x, y = self._plane_xy_point(lat, lon)
            um, vm, wm = self.mesoscale.wind_point(x, y, z, t)
            sp = self.spec
            fr = sp.mesoscale_surface_fraction
            env = fr + (1 - fr) * min(max(z / self.jet_altitude_m, 0.0), 1.0)
            bl = min(max((z - zg) / sp.boundary_layer_depth_m, 0.002), 1.0) ** sp.boundary_layer_exponent
            taper = min(max((z - zg) / 500.0, 0.0), 1.0)
            return bl * (us + env * um), bl * (vs + env * vm), taper * env * wm
        lat, lon, z, t, zg = np.broadcast_arrays(
            *self._check_arrays(lat_deg, lon_deg, alt_m, t_s), _as_float_array("ground_elevation_m", ground_elevation_m)
        )
        us, vs = self.synoptic_wind(lat, lon, z, t)
        x, y = self.plane_xy(lat, lon)
        um, vm, wm = self.mesoscale.wind_xy(x, y, z, t)
        env, bl, taper = self.profiles(z, zg)
        return bl * (us + env * um), bl * (vs + env * vm), taper * env * wm

    # thermodynamics -------------------------------------------------------------------
    def delta_t(self, lat_deg, lon_deg, t_s):
        """Column temperature offset from ISA (K) at (lat, lon, t): climate + offset +
        thermal-wind meridional gradient (saturating) + two moving large-scale anomalies."""
        # floats on the point path, arrays below it
        lat: float | np.ndarray
        lon: float | np.ndarray
        t: float | np.ndarray
        x: float | np.ndarray
        y: float | np.ndarray
        out: float | np.ndarray
        ys = _DELTA_T_SATURATION_M
        base = self.delta_t_climate_k + self.delta_t_offset_k
        if _is_point(lat_deg, lon_deg, t_s):
            lat, lon, t = self._check_point_2d(lat_deg, lon_deg, t_s)
            x, y = self._plane_xy_point(lat, lon)
            out = base + self.delta_t_gradient_k_per_m * ys * math.tanh(y / ys)
            for kx, ky, om, ph, a in self._tmodes:
                out += a * math.cos(x * kx + y * ky + t * om + ph)
            return out
        lat, lon, t = np.broadcast_arrays(*self._check_arrays_2d(lat_deg, lon_deg, t_s))
        x, y = self.plane_xy(lat, lon)
        out = base + self.delta_t_gradient_k_per_m * ys * np.tanh(y / ys)
        for kx, ky, om, ph, a in self._tmodes:
            out = out + a * np.cos(x * kx + y * ky + t * om + ph)
        return out

    def sea_level_pressure(self, lat_deg, lon_deg, t_s):
        """Pressure at H = 0 (Pa): 101325 + offset + rho0 f0 psi(z = 0) (geostrophic)."""
        # floats on the point path, arrays below it
        lat: float | np.ndarray
        lon: float | np.ndarray
        t: float | np.ndarray
        psi: float | np.ndarray
        if _is_point(lat_deg, lon_deg, t_s):
            lat, lon, t = self._check_point_2d(lat_deg, lon_deg, t_s)
            psi = self._surface_streamfunction_point(math.radians(lat), math.radians(lon), t)
        else:
            lat, lon, t = np.broadcast_arrays(*self._check_arrays_2d(lat_deg, lon_deg, t_s))
            psi = self._surface_streamfunction(np.radians(lat), np.radians(lon), t)
        return ISA_P0_PA + self.sea_level_pressure_offset_pa + _RHO0 * self.f0 * psi

    def temperature(self, lat_deg, lon_deg, alt_m, t_s):
        """Static air temperature (K): T_ISA(H(z)) + delta_t(lat, lon, t)."""
        return self.temperature_and_pressure(lat_deg, lon_deg, alt_m, t_s)[0]

    def static_pressure(self, lat_deg, lon_deg, alt_m, t_s):
        """Static pressure (Pa): the ISA + delta_t column integrated up from the local
        sea-level pressure (hypsometric equation)."""
        return self.temperature_and_pressure(lat_deg, lon_deg, alt_m, t_s)[1]

    def temperature_and_pressure(self, lat_deg, lon_deg, alt_m, t_s):
        """(temperature K, static pressure Pa) in one call (the flight loop wants both)."""
        # floats on the point path, arrays below it
        lat: float | np.ndarray
        lon: float | np.ndarray
        z: float | np.ndarray
        t: float | np.ndarray
        if _is_point(lat_deg, lon_deg, alt_m, t_s):
            lat, lon, z, t = self._check_point(lat_deg, lon_deg, alt_m, t_s)
            h = ISA_EARTH_RADIUS_M * z / (ISA_EARTH_RADIUS_M + z)  # geopotential height
            return isa_point(h, self.delta_t(lat, lon, t), self.sea_level_pressure(lat, lon, t))
        lat, lon, z, t = np.broadcast_arrays(*self._check_arrays(lat_deg, lon_deg, alt_m, t_s))
        h = geopotential_altitude_m(z)
        dt = self.delta_t(lat, lon, t)
        return isa_temperature_k(h, dt), isa_pressure_pa(h, dt, self.sea_level_pressure(lat, lon, t))

    # validation -------------------------------------------------------------------------
    def _check_point_2d(self, lat_deg, lon_deg, t_s) -> tuple[float, float, float]:
        lat = _point_float("lat_deg", lat_deg)
        if abs(lat) > _MAX_ABS_LAT:
            raise ValueError(f"lat_deg must be within [-{_MAX_ABS_LAT}, {_MAX_ABS_LAT}], got {lat}")
        return lat, _point_float("lon_deg", lon_deg), _point_float("t_s", t_s)

    def _check_point(self, lat_deg, lon_deg, alt_m, t_s) -> tuple[float, float, float, float]:
        lat, lon, t = self._check_point_2d(lat_deg, lon_deg, t_s)
        z = _point_float("alt_m", alt_m)
        if not (_Z_MIN_M <= z <= _Z_MAX_M):
            raise ValueError(f"alt_m must be within [{_Z_MIN_M:.0f}, {_Z_MAX_M:.0f}] m, got {z}")
        return lat, lon, z, t

    def _check_arrays_2d(self, lat_deg, lon_deg, t_s):
        lat = _as_float_array("lat_deg", lat_deg)
        if np.any(np.abs(lat) > _MAX_ABS_LAT):
            raise ValueError(f"lat_deg must be within [-{_MAX_ABS_LAT}, {_MAX_ABS_LAT}]")
        return lat, _as_float_array("lon_deg", lon_deg), _as_float_array("t_s", t_s)

    def _check_arrays(self, lat_deg, lon_deg, alt_m, t_s):
        lat, lon, t = self._check_arrays_2d(lat_deg, lon_deg, t_s)
        z = _as_float_array("alt_m", alt_m)
        if np.any(z < _Z_MIN_M) or np.any(z > _Z_MAX_M):
            raise ValueError(f"alt_m must be within [{_Z_MIN_M:.0f}, {_Z_MAX_M:.0f}] m")
        return lat, lon, z, t
