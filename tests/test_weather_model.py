"""Weather-model analyses: error size per level and season, correlation lengths, smoothing,
interpolation between analysis times, biases, observation-table references, bad specs."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pandas as pd
import pytest
from pydantic import ValidationError
from scipy.optimize import curve_fit

from aerotruth.sensors.weather_model import WeatherModelAnalysis, WeatherModelSpec, preset
from aerotruth.truth.atmosphere import TruthAtmosphere, WindFieldSpec
from aerotruth.truth.isa import geometric_altitude_m, pressure_altitude_m
from aerotruth.truth.mesoscale import MesoscaleSpec
from aerotruth.units import EARTH_RADIUS_M, FT, HPA, KT

APRIL_PEAK = dt.date(2010, 4, 16)  # day 106: the presets' seasonal peak, factor 1 + 0.11
JULY_TROUGH = dt.date(2010, 7, 16)  # day 197: 91 days later, factor 1 - 0.11 cos(2 pi 0.5 d / 182.625)
A_SEASON = 0.11


@pytest.fixture(scope="module")
def atm() -> TruthAtmosphere:
    return TruthAtmosphere.for_day(APRIL_PEAK, 7, "upper_midwest")


def _latlon(atm: TruthAtmosphere, x, y):
    """Inverse of the atmosphere's tangent plane (x east, y north, m)."""
    lat = atm.lat0 + np.degrees(np.asarray(y) / EARTH_RADIUS_M)
    lon = atm.lon0 + np.degrees(np.asarray(x) / (EARTH_RADIUS_M * math.cos(math.radians(atm.lat0))))
    return lat, lon


def _z_of(p_hpa: float) -> float:
    """ISA geometric height of a pressure level (only places the points; sigma uses p)."""
    return float(geometric_altitude_m(pressure_altitude_m(p_hpa * HPA)))


# --- (a) error size per level and season -----------------------------------------------
@pytest.mark.parametrize("p_hpa, sigma_table", [(850.0, 2.0), (500.0, 2.3), (250.0, 3.2)])
def test_error_vector_rms_per_level_matches_the_stated_sigma(atm, p_hpa, sigma_table):
    spec = preset("rr")
    expected = math.sqrt(2.0) * sigma_table * (1 + A_SEASON)  # vector RMS, hand-worked from the table
    rng = np.random.default_rng(11)
    n_real, n_pts = 16, 4000
    ms = []
    for r in range(n_real):
        an = WeatherModelAnalysis.draw(spec, atm, np.random.default_rng([11, r]))
        lat, lon = _latlon(atm, rng.uniform(-1.5e6, 1.5e6, n_pts), rng.uniform(-1.5e6, 1.5e6, n_pts))
        z = _z_of(p_hpa) + rng.uniform(-300, 300, n_pts)
        t = 3600.0 * rng.integers(0, 24, n_pts)  # analysis times: no interpolation
        eu, ev = an.analysis_error(lat, lon, z, t, p_hpa * HPA)
        ms.append(np.mean(eu**2 + ev**2))
    ms = np.array(ms)
    rms = math.sqrt(ms.mean())
    se = ms.std(ddof=1) / math.sqrt(n_real) / (2 * rms)  # standard error of the RMS
    print(f"{p_hpa:.0f} hPa: vector RMS {rms:.3f} m/s, stated {expected:.3f}, se {se:.3f}")
    assert se < 0.03 * expected
    assert abs(rms - expected) < 3 * se


def _period_factor(spec: WeatherModelSpec, start: str, end: str) -> float:
    d0, d1 = dt.date.fromisoformat(start), dt.date.fromisoformat(end)
    days = [d0 + dt.timedelta(i) for i in range((d1 - d0).days + 1)]
    return float(np.mean([spec.seasonal_factor(d) ** 2 for d in days]))  # mean error variance factor


CONTROL_PERIODS = {  # wind paper Tables II-IV: (before, after) of the control groups
    "mesaba": (("2009-08-15", "2009-09-15"), ("2009-10-21", "2009-11-21")),
    "penair": (("2010-01-09", "2010-03-09"), ("2010-03-27", "2010-05-27")),
    "chautauqua": (("2010-01-10", "2010-03-10"), ("2010-03-11", "2010-05-11")),
}


def test_seasonal_law_makes_all_three_control_groups_worse_in_their_later_period_and_an_annual_law_would_not():
    spec = preset("rr")
    for fleet, (before, after) in CONTROL_PERIODS.items():
        ratio = _period_factor(spec, *after) / _period_factor(spec, *before)
        print(f"{fleet}: error variance after/before {ratio:.3f}")
        assert ratio > 1.0  # paper: +0.6, +0.9, +1.3 kn
    annual = preset("rr", seasonal_period_days=365.25, seasonal_peak_doy=20.0)
    signs = {f: _period_factor(annual, *a) > _period_factor(annual, *b) for f, (b, a) in CONTROL_PERIODS.items()}
    assert signs == {"mesaba": True, "penair": False, "chautauqua": False}
    # hand-worked factors: peak 1.11 on day 106; day 197 is half a period later minus 0.3 d
    assert spec.seasonal_factor(APRIL_PEAK) == pytest.approx(1.11, abs=1e-12)
    expected_july = 1 + A_SEASON * math.cos(2 * math.pi * 91 / 182.625)
    assert spec.seasonal_factor(JULY_TROUGH) == pytest.approx(expected_july, abs=1e-12)
    assert expected_july == pytest.approx(0.89, abs=1e-4)


def test_same_draw_on_another_date_scales_the_error_by_the_seasonal_ratio():
    spec = preset("rr")
    lat, lon = np.linspace(40, 50, 50), np.linspace(-100, -82, 50)
    errs = []
    for date in (APRIL_PEAK, JULY_TROUGH):
        a = TruthAtmosphere.for_day(date, 7, "upper_midwest")
        an = WeatherModelAnalysis.draw(spec, a, np.random.default_rng(3))
        errs.append(an.analysis_error(lat, lon, 3000.0, 7200.0, 700 * HPA)[0])
    expected = 1.11 / (1 + A_SEASON * math.cos(2 * math.pi * 91 / 182.625))
    np.testing.assert_allclose(errs[0], expected * errs[1], rtol=1e-5, atol=1e-6)


# --- (b) correlation lengths -----------------------------------------------------------
def _gauss(r, c, length):
    return c * np.exp(-0.5 * (r / length) ** 2)


def _fitted_scales(atm, spec, offsets, axis, n_real=24, n_pts=1500):
    """Per realization, the Gaussian correlation scale fitted to the empirical correlation of
    the error at separations `offsets` along `axis` (horizontal: random direction)."""
    rng = np.random.default_rng(5)
    p = 600 * HPA
    sigma2 = 2 * spec.sigma_ms(p, atm.date) ** 2
    fits = []
    for r in range(n_real):
        an = WeatherModelAnalysis.draw(spec, atm, np.random.default_rng([5, r]))
        x, y = rng.uniform(-1.5e6, 1.5e6, n_pts), rng.uniform(-1.5e6, 1.5e6, n_pts)
        z = 4000.0 + rng.uniform(-500, 500, n_pts)
        t = 3600.0 * rng.integers(0, 12, n_pts)
        th = rng.uniform(0, 2 * np.pi, n_pts)
        base = an.analysis_error(*_latlon(atm, x, y), z, t, p)
        rho = []
        for d in offsets:
            xb, yb, zb, tb = x, y, z, t
            if axis == "h":
                xb, yb = x + d * np.cos(th), y + d * np.sin(th)
            elif axis == "z":
                zb = z + d
            else:
                tb = t + d
            other = an.analysis_error(*_latlon(atm, xb, yb), zb, tb, p)
            rho.append(np.mean(base[0] * other[0] + base[1] * other[1]) / sigma2)
        (c, length), _ = curve_fit(
            _gauss, np.asarray(offsets, dtype=float), np.array(rho), p0=(1.0, offsets[len(offsets) // 2])
        )
        fits.append(abs(length))
    fits = np.array(fits)
    return fits.mean(), fits.std(ddof=1) / math.sqrt(n_real)


@pytest.mark.slow
@pytest.mark.parametrize(
    "axis, offsets, stated",
    [
        ("h", [0, 50e3, 100e3, 150e3, 200e3, 250e3, 300e3, 400e3], 150e3),
        ("z", [0, 500.0, 1000.0, 1500.0, 2000.0, 2500.0, 3500.0], 1500.0),
        ("t", [0, 3600.0, 7200.0, 10800.0, 14400.0, 18000.0, 25200.0], 3 * 3600.0),
    ],
)
def test_error_correlation_length_fitted_from_the_field_matches_the_stated_scale(atm, axis, offsets, stated):
    spec = preset("rr")
    mean, se = _fitted_scales(atm, spec, offsets, axis)
    print(f"{axis}: fitted Gaussian scale {mean:.4g} +- {se:.2g}, stated {stated:.4g}")
    assert se < 0.04 * stated
    assert abs(mean - stated) < 3 * se


# --- (c) smoothing ------------------------------------------------------------------------
def _one_wave_atmosphere(wavelength_m: float, rms_ms: float = 5.0) -> TruthAtmosphere:
    meso = MesoscaleSpec(
        min_wavelength_m=wavelength_m,
        max_wavelength_m=wavelength_m * (1 + 1e-9),
        shells=1,
        directions=1,
        rms_ms=rms_ms,
        w_modes=1,
        w_rms_ms=0.0,
    )
    return TruthAtmosphere.for_day(APRIL_PEAK, 3, "upper_midwest", WindFieldSpec(n_waves=0, mesoscale=meso))


NO_ERROR = {"sigma_levels": ((1000.0, 0.0),)}


@pytest.mark.parametrize(
    "wavelength_over_lambda_e, response",
    [
        (0.25, 2.0**-16),  # exp(-ln2 * 16): dropped (below 1e-3), i.e. ~1.5e-5 of the wave left
        (0.5, 2.0**-4),  # 0.0625
        (1.0, 0.5),  # half amplitude at the effective resolution
        (10.0, 2.0**-0.01),  # 0.99309: a long wave passes
    ],
)
def test_truth_wave_is_attenuated_by_the_stated_response_of_the_effective_resolution(
    wavelength_over_lambda_e, response
):
    spec = preset("rr", **NO_ERROR)
    a = _one_wave_atmosphere(wavelength_over_lambda_e * spec.effective_resolution_m)
    an = WeatherModelAnalysis.draw(spec, a, np.random.default_rng(0))
    rng = np.random.default_rng(1)
    lat, lon = _latlon(a, rng.uniform(-1e6, 1e6, 3000), rng.uniform(-1e6, 1e6, 3000))
    z, t = 6000.0, 3600.0 * rng.integers(0, 24, 3000)
    us, vs = a.synoptic_wind(lat, lon, z, t)
    ut, vt, _ = a.wind(lat, lon, z, t)
    ua, va = an.wind(lat, lon, z, t)
    truth_wave = np.hypot(ut - us, vt - vs)
    analysis_wave = np.hypot(ua - us, va - vs)
    ratio = math.sqrt(np.mean(analysis_wave**2) / np.mean(truth_wave**2))
    print(f"lambda/lambda_e {wavelength_over_lambda_e}: amplitude ratio {ratio:.5f}, stated {response:.5f}")
    assert np.sqrt(np.mean(truth_wave**2)) > 3.0
    assert ratio == pytest.approx(response, abs=2e-4)
    np.testing.assert_allclose(ua - us, response * (ut - us), atol=1e-3)


def test_synoptic_flow_passes_the_smoothing_unchanged(atm):
    a = _one_wave_atmosphere(50e3, rms_ms=0.0)  # mean flow and no mesoscale
    an = WeatherModelAnalysis.draw(preset("nam", **NO_ERROR), a, np.random.default_rng(0))
    lat, lon = np.meshgrid(np.linspace(38, 52, 15), np.linspace(-105, -78, 15))
    for t in (0.0, 6 * 3600.0):
        ut, vt, _ = a.wind(lat, lon, 5000.0, t)
        ua, va = an.wind(lat, lon, 5000.0, t)
        np.testing.assert_allclose(ua, ut, atol=1e-9)
        np.testing.assert_allclose(va, vt, atol=1e-9)


def test_analysis_minus_truth_is_the_drawn_error_plus_the_unresolved_mesoscale(atm):
    """At analysis times V_REF - V - e is the part of the truth the model does not resolve;
    its mean square is env^2 sum_j a_j^2 (1 - H_j)^2 / 2 with a_j the truth's mode amplitudes
    (each mode carries a_j^2/2 of u^2 + v^2) and H the stated response."""
    spec = preset("rr")
    m = atm.mesoscale
    a2 = np.sum(m.amplitude[:, :2] ** 2, axis=1)
    lam = 2 * np.pi / np.hypot(m.kx, m.ky)
    h = np.exp(-math.log(2) * (spec.effective_resolution_m / lam) ** 2)
    z = 5000.0
    env = 0.6 + 0.4 * z / atm.jet_altitude_m  # truth envelope (atmosphere docstring)
    unresolved = env**2 * np.sum(a2 * (1 - h) ** 2) / 2
    an = WeatherModelAnalysis.draw(spec, atm, np.random.default_rng(9))
    rng = np.random.default_rng(9)
    n, batches = 24000, 24
    lat, lon = _latlon(atm, rng.uniform(-1.5e6, 1.5e6, n), rng.uniform(-1.5e6, 1.5e6, n))
    zz = z + rng.uniform(-200, 200, n)  # the envelope moves by < 1 % over this
    t = 3600.0 * rng.integers(0, 24, n)
    p = atm.static_pressure(lat, lon, zz, t)
    ua, va = an.wind(lat, lon, zz, t)
    ut, vt, _ = atm.wind(lat, lon, zz, t)
    eu, ev = an.analysis_error(lat, lon, zz, t, p)
    sq = ((ua - ut - eu) ** 2 + (va - vt - ev) ** 2).reshape(batches, -1).mean(axis=1)
    se = sq.std(ddof=1) / math.sqrt(batches)
    total = math.sqrt(np.mean((ua - ut) ** 2 + (va - vt) ** 2))
    print(
        f"unresolved vector MS {sq.mean():.3f} +- {se:.3f} m2/s2, from the modes {unresolved:.3f}; "
        f"analysis - truth vector RMS {total:.2f} m/s"
    )
    assert se < 0.1 * unresolved
    assert abs(sq.mean() - unresolved) < 3 * se + 0.02 * unresolved  # + the envelope's spread


# --- (d) analysis times --------------------------------------------------------------------
@pytest.mark.parametrize("name, interval_h", [("rr", 1), ("nam", 6)])
def test_analysis_is_the_truth_at_analysis_times_and_linear_in_time_between_them(atm, name, interval_h):
    """With no smoothing (lambda_e = 1 m) and no error the analysis is the truth itself at
    the analysis times and the straight line between consecutive ones."""
    spec = preset(name, effective_resolution_m=1.0, **NO_ERROR)
    assert spec.analysis_interval_s == interval_h * 3600.0
    an = WeatherModelAnalysis.draw(spec, atm, np.random.default_rng(0))
    rng = np.random.default_rng(2)
    lat, lon = 45 + rng.uniform(-4, 4, 500), -91 + rng.uniform(-6, 6, 500)
    z = rng.uniform(300, 9000, 500)
    T = spec.analysis_interval_s
    tk = T * rng.integers(0, 24 // interval_h, 500)
    u0, v0, _ = atm.wind(lat, lon, z, tk)
    u1, v1, _ = atm.wind(lat, lon, z, tk + T)
    ua, va = an.wind(lat, lon, z, tk)
    np.testing.assert_allclose(ua, u0, atol=2e-3)
    np.testing.assert_allclose(va, v0, atol=2e-3)
    for alpha in (0.25, 0.5, 0.9):
        ua, va = an.wind(lat, lon, z, tk + alpha * T)
        np.testing.assert_allclose(ua, (1 - alpha) * u0 + alpha * u1, atol=2e-3)
        np.testing.assert_allclose(va, (1 - alpha) * v0 + alpha * v1, atol=2e-3)
    # the truth itself is not linear over the interval: the interpolation is a real error
    um, _, _ = atm.wind(lat, lon, z, tk + 0.5 * T)
    assert np.sqrt(np.mean((um - 0.5 * (u0 + u1)) ** 2)) > 0.05


@pytest.mark.parametrize("name", ["rr", "rtfdda", "nam"])
def test_analysis_with_error_is_linear_in_time_between_analyses(atm, name):
    spec = preset(name)
    an = WeatherModelAnalysis.draw(spec, atm, np.random.default_rng(4))
    lat, lon, z = np.full(40, 44.0), np.linspace(-97, -85, 40), np.full(40, 2500.0)
    T = spec.analysis_interval_s
    u0, v0 = an.wind(lat, lon, z, T)
    u1, v1 = an.wind(lat, lon, z, 2 * T)
    e0, _ = an.analysis_error(lat, lon, z, T, 750 * HPA)
    assert np.std(e0) > 1.0  # the error is there
    for alpha in (0.1, 0.5, 0.75):
        u, v = an.wind(lat, lon, z, (1 + alpha) * T)
        # sigma follows the pressure at the point, which moves by a few Pa over T: 1e-2 m/s
        np.testing.assert_allclose(u, (1 - alpha) * u0 + alpha * u1, atol=1e-2)
        np.testing.assert_allclose(v, (1 - alpha) * v0 + alpha * v1, atol=1e-2)


# --- biases -------------------------------------------------------------------------
def test_bias_vector_and_relative_speed_bias_shift_the_analysis_as_stated(atm):
    spec = preset("rr", bias_ms=(2.0, -1.0), speed_bias_fraction=-0.1, **NO_ERROR)
    an = WeatherModelAnalysis.draw(spec, atm, np.random.default_rng(0))
    lat, lon = np.linspace(42, 48, 30), np.linspace(-95, -87, 30)
    us, vs = an.smoothed_truth(lat, lon, 7000.0, 5000.0)
    ua, va = an.wind(lat, lon, 7000.0, 5000.0)
    np.testing.assert_allclose(ua, 0.9 * us + 2.0, atol=1e-9)
    np.testing.assert_allclose(va, 0.9 * vs - 1.0, atol=1e-9)


# --- observation table ------------------------------------------------------------------
def _reports(atm, n=400, seed=8):
    rng = np.random.default_rng(seed)
    lat, lon = 45 + rng.uniform(-3, 3, n), -91 + rng.uniform(-4, 4, n)
    z, t = rng.uniform(400, 7600, n), rng.uniform(0, 86400, n)
    p = atm.static_pressure(lat, lon, z, t)
    day0 = dt.datetime(2010, 4, 16, tzinfo=dt.UTC).timestamp()
    return (
        pd.DataFrame(
            {
                "aircraft": "N1",
                "time": day0 + t,
                "lat": lat,
                "lon": lon,
                "pressure_altitude_ft": pressure_altitude_m(p) / FT,
            }
        ),
        lat,
        lon,
        z,
        t,
        p,
    )


def test_pressure_altitude_is_converted_to_the_height_where_the_truth_has_that_pressure(atm):
    an = WeatherModelAnalysis.draw(preset("rr"), atm, np.random.default_rng(0))
    _, lat, lon, z, t, p = _reports(atm)
    zz = an.geometric_altitude_of_pressure_m(lat, lon, p, t)
    isa_error = geometric_altitude_m(pressure_altitude_m(p)) - z
    print(
        f"height from pressure: max error {np.max(np.abs(zz - z)):.2e} m; "
        f"ISA heights would be off by up to {np.max(np.abs(isa_error)):.0f} m"
    )
    np.testing.assert_allclose(zz, z, atol=1e-3)
    np.testing.assert_allclose(atm.static_pressure(lat, lon, zz, t), p, rtol=1e-9)


def test_apply_fills_the_reference_columns_with_the_analysis_at_each_report(atm):
    an = WeatherModelAnalysis.draw(preset("rr"), atm, np.random.default_rng(0))
    reports, lat, lon, z, t, _ = _reports(atm)
    out = an.apply(reports, ground_elevation_m=250.0)
    u, v = an.wind(lat, lon, z, t, ground_elevation_m=250.0)
    np.testing.assert_allclose(out["ref_wind_speed_kt"], np.hypot(u, v) / KT, atol=1e-6)
    d = (out["ref_wind_dir_deg"].to_numpy() - np.degrees(np.arctan2(-u, -v)) + 180) % 360 - 180
    assert np.max(np.abs(d)) < 1e-5
    assert (out["ref_source"] == "rr").all()
    assert list(out.columns[:5]) == list(reports.columns) and "ref_wind_speed_kt" not in reports
    iso = reports.assign(time=pd.to_datetime(reports["time"], unit="s", utc=True).dt.strftime("%Y-%m-%dT%H:%M:%S.%fZ"))
    np.testing.assert_allclose(an.apply(iso, 250.0)["ref_wind_speed_kt"], out["ref_wind_speed_kt"], atol=1e-4)


@pytest.mark.parametrize(
    "bias, speed_kt, from_deg",
    [
        ((-10.0, 0.0), 10 / KT, 90.0),  # air moving west comes from the east
        ((0.0, 10.0), 10 / KT, 180.0),  # moving north: from the south
        ((3.0, 4.0), 5 / KT, 216.8699),  # towards 036.87: from 216.87
    ],
)
def test_reference_direction_is_meteorological_from_and_speed_in_knots(atm, bias, speed_kt, from_deg):
    # the truth scaled to 1e-7 of itself leaves the bias alone (~3e-6 m/s)
    spec = preset("rr", bias_ms=bias, speed_bias_fraction=-1 + 1e-7, **NO_ERROR)
    an = WeatherModelAnalysis.draw(spec, atm, np.random.default_rng(0))
    reports = _reports(atm, n=5)[0]
    out = an.apply(reports)
    np.testing.assert_allclose(out["ref_wind_speed_kt"], speed_kt, atol=1e-4)
    np.testing.assert_allclose(out["ref_wind_dir_deg"], from_deg, atol=1e-3)


def test_apply_names_missing_report_columns(atm):
    an = WeatherModelAnalysis.draw(preset("rr"), atm, np.random.default_rng(0))
    with pytest.raises(ValueError, match="pressure_altitude_ft"):
        an.apply(pd.DataFrame({"time": [0.0], "lat": [45.0], "lon": [-91.0]}))


# --- bad specs ---------------------------------------------------------------------------
@pytest.mark.parametrize(
    "kwargs, field, words",
    [
        ({"name": "rr", "sigma_levels": ((850.0, 2.0), (500.0, -1.0))}, "sigma_levels", "sigma must be"),
        ({"name": "rr", "sigma_levels": ((500.0, 2.0), (850.0, 2.0))}, "sigma_levels", "decrease"),
        ({"name": "rr", "horizontal_correlation_m": -5.0}, "horizontal_correlation_m", "greater than 0"),
        ({"name": "ecmwf"}, "name", "not a preset"),
        ({"name": "rr", "sigma": 2.0}, "sigma", "Extra inputs"),
    ],
)
def test_bad_spec_gives_one_error_naming_the_field(kwargs, field, words):
    with pytest.raises(ValidationError) as exc:
        WeatherModelSpec(**kwargs)
    assert isinstance(exc.value, ValueError)
    assert exc.value.error_count() == 1
    assert field in str(exc.value) and words in str(exc.value)


def test_unknown_preset_name_is_a_value_error_naming_it():
    with pytest.raises(ValueError, match="name: unknown weather model 'ecmwf'"):
        preset("ecmwf")


def test_custom_model_with_every_field_is_accepted():
    fields = dict(preset("rr"))
    fields.update(name="my_model", effective_resolution_m=60e3)
    spec = WeatherModelSpec(**fields)
    assert spec.name == "my_model" and spec.response(2 * np.pi / 60e3) == pytest.approx(0.5)
