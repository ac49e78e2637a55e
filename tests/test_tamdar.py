"""TAMDAR report generator and air-data sensor (wind paper sections 2, 3, 5.1, 8.1, 8.4).

Expectations are hand-counted schedules of a scripted pressure profile, hand-worked winds
and interpolations, and the analytic quantization error of a 3-report track.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from pyproj import Geod

from aerotruth.analysis.wind.heading_errors import GATE_NAMES, ground_track, report_flights
from aerotruth.analysis.wind.metrics import METRIC_GATES
from aerotruth.ellipsoid import radii
from aerotruth.sensors.air_data import AirDataSpec
from aerotruth.sensors.tamdar import (
    LookupTableCorrection,
    OffsetCorrection,
    ReportSpec,
    generate_reports,
    quantize,
    report_schedule,
)
from aerotruth.truth.isa import pressure_altitude_m
from aerotruth.units import DEG, KT

RATE_HZ = 10


def _truth(knots_t_s, knots_p_hpa, tas_mps=120.0, heading_deg=0.0, wind_uv=(0.0, 0.0)) -> pd.DataFrame:
    """Truth-like samples at 10 Hz: a scripted static-pressure profile (piecewise linear in
    Pa), straight flight at constant TAS and true heading in a constant wind."""
    t = np.arange(int(knots_t_s[-1] * RATE_HZ) + 1) / RATE_HZ
    p = np.interp(t, knots_t_s, np.asarray(knots_p_hpa, float) * 100.0)
    psi = heading_deg * DEG
    ve = tas_mps * np.sin(psi) + wind_uv[0]
    vn = tas_mps * np.cos(psi) + wind_uv[1]
    m, n = radii(45.0 * DEG)
    return pd.DataFrame(
        {
            "time_s": t,
            "lat_deg": 45.0 + np.degrees(vn * t / m),
            "lon_deg": -93.0 + np.degrees(ve * t / (n * np.cos(45 * DEG))),
            "h_ellipsoid_m": pressure_altitude_m(p),
            "pressure_altitude_m": pressure_altitude_m(p),
            "vn_mps": np.full(t.size, vn),
            "ve_mps": np.full(t.size, ve),
            "vd_mps": np.zeros(t.size),
            "roll_rad": np.zeros(t.size),
            "pitch_rad": np.zeros(t.size),
            "heading_rad": np.full(t.size, psi),
            "tas_mps": np.full(t.size, tas_mps),
            "wind_u_mps": np.full(t.size, wind_uv[0]),
            "wind_v_mps": np.full(t.size, wind_uv[1]),
            "static_pressure_pa": p,
            "temperature_k": np.full(t.size, 250.0),
        }
    )


# climb 1000 -> 400 hPa at 0.5 hPa/s, cruise at 400 hPa (~23,600 ft), descent to 700 hPa at
# 0.5 hPa/s, near-level drift 700 -> 725 hPa (~9,900 ft) at 0.0625 hPa/s, descent to the
# ground (1000 hPa) at 0.5 hPa/s. All crossings fall on exact samples in binary.
PROFILE_T = [0.0, 1200.0, 2700.0, 3300.0, 3700.0, 4250.0]
PROFILE_P = [1000.0, 400.0, 400.0, 700.0, 725.0, 1000.0]


def _expected_schedule(resets: bool) -> list[tuple[float, str, str]]:
    """Hand count, (time s, trigger, phase) of every report."""
    climb = [(t, "pressure", "ascent") for t in range(20, 201, 20)]  # 990 ... 900 hPa, 10 hPa steps
    climb += [(t, "pressure", "ascent") for t in range(300, 1201, 100)]  # 850 ... 400 hPa, 50 hPa steps
    cruise = [(t, "time", "level") for t in (1620, 2040, 2460)]  # 7 min above 20,000 ft
    descent = [(t, "pressure", "descent") for t in range(2800, 3301, 100)]  # 450 ... 700 hPa
    drift = [(t, "time", "level") for t in (3480, 3660)]  # 3 min below 20,000 ft; p = 711.25, 722.5 hPa
    # last descent: from 722.5 hPa (reset by the time report) -> 772.5, 822.5, 872.5; without the
    # reset from 700 hPa -> 750, 800, 850; then 900 (100 hPa above ground: 10 hPa steps), 910 ... 1000
    first = (3795, 3895, 3995) if resets else (3750, 3850, 3950)
    final = [(t, "pressure", "descent") for t in first] + [(t, "pressure", "descent") for t in range(4050, 4251, 20)]
    return climb + cruise + descent + drift + final


@pytest.mark.parametrize("resets", [True, False])
def test_report_schedule_matches_the_hand_count_of_a_scripted_climb_cruise_descent(resets):
    truth = _truth(PROFILE_T, PROFILE_P)
    spec = ReportSpec(time_report_resets_pressure=resets)
    reports = generate_reports(truth, truth["heading_rad"].to_numpy(), spec, ground_pressure_hpa=1000.0)
    expected = _expected_schedule(resets)
    assert len(reports) == len(expected) == 45
    np.testing.assert_array_equal(reports["time"].to_numpy(), [e[0] for e in expected])
    assert reports["trigger"].tolist() == [e[1] for e in expected]
    assert reports["phase"].tolist() == [e[2] for e in expected]
    gaps = np.diff(np.r_[0.0, reports["time"].to_numpy()])
    print(f"reports: {len(reports)}  gaps (s): {sorted(set(gaps.round(1).tolist()))}")


def test_time_reports_come_every_limit_even_when_sample_times_are_inexact_decimals():
    # level at 950 hPa (~1,770 ft, ground 1000 hPa) and at 400 hPa (~23,600 ft), samples at
    # 0.3 + k/10 s (no exact binary times): reports every 180 s / 420 s on the sample grid
    t = (np.arange(0, 30001) + 3) / 10.0
    low = report_schedule(t, np.full(t.size, 95000.0), np.full(t.size, 540.0), 100000.0, ReportSpec())
    np.testing.assert_allclose(t[low[0]], 0.3 + 180.0 * np.arange(1, 17), atol=1e-9)
    high = report_schedule(t, np.full(t.size, 40000.0), np.full(t.size, 7190.0), 100000.0, ReportSpec())
    np.testing.assert_allclose(t[high[0]], 0.3 + 420.0 * np.arange(1, 8), atol=1e-9)
    assert not low[1].any() and not high[1].any()


@pytest.mark.parametrize("field", ["lat_lon_step_deg", "time_step_s", "wind_speed_step_kt", "wind_dir_step_deg"])
@pytest.mark.parametrize("value", [0.0, -0.01])
def test_zero_or_negative_quantization_step_is_rejected_naming_the_field(field, value):
    with pytest.raises(ValueError, match=field):
        ReportSpec(**{field: value})


def test_ideal_sensors_report_the_constant_truth_wind_quantized():
    # wind u = 10 m/s (towards east), v = -5 m/s (towards south): speed sqrt(125) = 11.18 m/s
    # = 21.73 kt -> 22 kt; from atan2(-10, 5) = -63.43 deg -> 296.57 -> 297 deg
    truth = _truth([0.0, 600.0], [700.0, 700.0], heading_deg=30.0, wind_uv=(10.0, -5.0))
    reports = generate_reports(truth, truth["heading_rad"].to_numpy(), ReportSpec(), ground_pressure_hpa=1000.0)
    assert len(reports) == 3  # 180, 360, 540 s
    assert (reports["wind_speed_kt"] == 22.0).all()
    assert (reports["wind_dir_deg"] == 297.0).all()
    np.testing.assert_allclose(reports["heading_deg"], 30.0)
    np.testing.assert_allclose(reports["tas_kt"], 120.0 / KT)
    # lat/lon on the 0.01 deg grid
    np.testing.assert_allclose(reports["lat"] / 0.01, np.round(reports["lat"] / 0.01), atol=1e-9)


def test_lookup_table_interpolates_circularly_on_the_magnetic_heading():
    lut = LookupTableCorrection(lut_deg=[-2.0, 0, 0, 0, 0, 0, 0, 0])
    # true 2 deg, variation +10 deg (east) -> magnetic 352 deg, between 315 (0) and 360 (-2):
    # c = -2 (352 - 315) / 45 = -1.6444 deg
    got = lut.apply(np.array([2.0 * DEG]), np.array([10.0 * DEG]))
    np.testing.assert_allclose(np.degrees(got), [2.0 - 2.0 * 37.0 / 45.0])
    # the same true heading with no variation is magnetic 2 deg: c = -2 (1 - 2/45)
    np.testing.assert_allclose(np.degrees(lut.apply(np.array([2.0 * DEG]), 0.0)), [2.0 - 2.0 * 43.0 / 45.0])
    mid = LookupTableCorrection(lut_deg=[0, 1, 2, 3, 4, 3, 2, 1])
    np.testing.assert_allclose(
        np.degrees(mid.correction_rad(np.radians([22.5, 337.5, 350.0, 180.0, 200.0]))),
        [0.5, 0.5, 1 - 35 / 45, 4.0, 4 - 20 / 45],
    )
    with pytest.raises(ValueError, match="lut_deg"):
        LookupTableCorrection(lut_deg=[0.0] * 7)


@pytest.mark.parametrize("correction", [OffsetCorrection(offset_deg=-3.0), LookupTableCorrection(lut_deg=[-3.0] * 8)])
def test_onboard_correction_removes_a_heading_offset_from_the_reported_wind(correction):
    truth = _truth([0.0, 600.0], [700.0, 700.0], heading_deg=30.0, wind_uv=(10.0, -5.0))
    measured = truth["heading_rad"].to_numpy() + 3.0 * DEG
    spec = ReportSpec()
    raw = generate_reports(truth, measured, spec, ground_pressure_hpa=1000.0)
    fixed = generate_reports(
        truth,
        measured,
        spec,
        ground_pressure_hpa=1000.0,
        correction=correction,
        variation_rad=np.full(len(truth), -2.0 * DEG),
    )
    # uncorrected: the air vector is turned by 3 deg: wind error 2 TAS sin(1.5 deg) = 6.28 m/s = 12.2 kt
    u_true, v_true = 10.0 / KT, -5.0 / KT

    def err(r):
        d = np.radians(r["wind_dir_deg"].to_numpy())
        return np.hypot(-r["wind_speed_kt"] * np.sin(d) - u_true, -r["wind_speed_kt"] * np.cos(d) - v_true)

    np.testing.assert_allclose(err(raw), 2 * 120.0 * np.sin(1.5 * DEG) / KT, atol=0.6)
    assert (fixed["wind_speed_kt"] == 22.0).all() and (fixed["wind_dir_deg"] == 297.0).all()


def test_air_data_errors_follow_their_measurement_equation():
    truth = _truth([0.0, 1000.0], [700.0, 700.0], tas_mps=100.0)
    rng = np.random.default_rng(7)
    exact = (
        AirDataSpec(
            tas_bias_kt=2.0,
            tas_scale_factor=0.01,
            tas_noise_kt=0.0,
            pressure_altitude_noise_ft=0.0,
            gps_position_sigma_m=0.0,
            gps_velocity_sigma_mps=0.0,
        )
        .draw(rng)
        .apply(truth, rng)
    )
    np.testing.assert_allclose(exact["tas_mps"], 1.01 * 100.0 + 2.0 * KT)
    np.testing.assert_allclose(exact["static_pressure_pa"], truth["static_pressure_pa"], rtol=1e-9)
    noisy = (
        AirDataSpec(tas_noise_kt=1.0, gps_position_sigma_m=5.0, gps_velocity_sigma_mps=0.2).draw(rng).apply(truth, rng)
    )
    m, n = radii(np.radians(truth["lat_deg"].to_numpy()))
    h = truth["h_ellipsoid_m"].to_numpy()
    assert np.std(noisy["tas_mps"] - 100.0) / KT == pytest.approx(1.0, rel=0.03)
    assert np.std(np.radians(noisy["lat_deg"] - truth["lat_deg"]) * (m + h)) == pytest.approx(5.0, rel=0.03)
    east = np.radians(noisy["lon_deg"] - truth["lon_deg"]) * (n + h) * np.cos(np.radians(truth["lat_deg"]))
    assert np.std(east) == pytest.approx(5.0, rel=0.03)
    assert np.std(noisy["ve_mps"] - truth["ve_mps"]) == pytest.approx(0.2, rel=0.03)
    with pytest.raises(ValueError, match="tas_noise_kt"):
        AirDataSpec(tas_noise_kt=-1.0)


# ------------------------------------------------------------------- quantization of the 3-report track

GEOD = Geod(ellps="WGS84")


def _quantized_triples(rng, n: int, speed_mps: float, spacing_s: float, step_deg: float, time_step_s: float):
    """n independent geodesic straight-line triples (the test's own generator, pyproj
    geodesics), reports quantized like TAMDAR; returns the estimated track and the truth."""
    lat0, lon0 = rng.uniform(44.0, 48.0, n), rng.uniform(-95.0, -88.0, n)
    az0 = rng.uniform(0.0, 360.0, n)
    # report spacing jittered by up to one time step, so the three time roundings are independent
    spacing = spacing_s + rng.uniform(-0.5, 0.5, n) * time_step_s
    lon1, lat1, back1 = GEOD.fwd(lon0, lat0, az0, speed_mps * spacing)
    lon2, lat2, _ = GEOD.fwd(lon0, lat0, az0, 2 * speed_mps * spacing)
    t0 = rng.uniform(0.0, 1000.0, n)
    t = np.stack([t0, t0 + spacing, t0 + 2 * spacing], axis=1).ravel()
    lat = np.stack([lat0, lat1, lat2], axis=1).ravel()
    lon = np.stack([lon0, lon1, lon2], axis=1).ravel()
    ids = np.repeat(np.arange(n), 3)
    tq = quantize(t, time_step_s)
    gt = ground_track(
        tq,
        np.radians(quantize(lat, step_deg)),
        np.radians(quantize(lon, step_deg)),
        report_flights(ids, tq, METRIC_GATES.flight_gap_s),
        METRIC_GATES,
    )
    true_track = np.radians(np.mod(np.asarray(back1) + 180.0, 360.0))
    sel = slice(1, None, 3)
    track_err = np.angle(np.exp(1j * (np.arctan2(gt.vg_e[sel], gt.vg_n[sel]) - true_track)))
    return gt, sel, track_err, np.hypot(gt.vg_e[sel], gt.vg_n[sel]) - speed_mps, np.radians(lat1), true_track


def test_cruise_three_report_track_error_matches_the_quantization_analytic_estimate():
    # 250 kt, time-triggered reports 7 min apart: baseline 108 km >> 0.01 deg (~1 km)
    rng = np.random.default_rng(2010)
    v, spacing, step, tstep = 250 * KT, 420.0, 0.01, 1.0
    gt, sel, track_err, speed_err, lat_mid, eta = _quantized_triples(rng, 40000, v, spacing, step, tstep)
    m, n = radii(lat_mid)
    sig_n = m * np.radians(step) / np.sqrt(12)  # uniform quantization: step / sqrt(12) per coordinate
    sig_e = n * np.cos(lat_mid) * np.radians(step) / np.sqrt(12)
    sig_t = tstep / np.sqrt(12)
    span = 2 * spacing
    baseline = v * span
    var_track = 2 * (sig_e**2 * np.cos(eta) ** 2 + sig_n**2 * np.sin(eta) ** 2) / baseline**2
    var_speed = (
        2 * (sig_e**2 * np.sin(eta) ** 2 + sig_n**2 * np.cos(eta) ** 2) / span**2 + 2 * v**2 * sig_t**2 / span**2
    )
    rms_track, pred_track = np.sqrt(np.mean(track_err**2)), np.sqrt(np.mean(var_track))
    rms_speed, pred_speed = np.sqrt(np.mean(speed_err**2)), np.sqrt(np.mean(var_speed))
    print(f"cruise track rms deg: {np.degrees(rms_track):.4f} analytic {np.degrees(pred_track):.4f}")
    print(f"cruise speed rms kt: {rms_speed / KT:.4f} analytic {pred_speed / KT:.4f}")
    assert rms_track == pytest.approx(pred_track, rel=0.03)
    assert rms_speed == pytest.approx(pred_speed, rel=0.03)
    # unbiased (wind paper 5.1), and every cruise triple passes the gates
    assert abs(track_err.mean()) < 4 * rms_track / np.sqrt(track_err.size)
    assert abs(speed_err.mean()) < 4 * rms_speed / np.sqrt(speed_err.size)
    assert (gt.gate[sel] == 0).all()


def test_climb_three_report_tracks_are_mostly_rejected_by_the_gates_and_the_distribution_is_printed():
    # 160 kt climbing ~1500 ft/min: 10 hPa (~280 ft) reports ~11 s apart, baseline ~1.8 km,
    # comparable to the 0.01 deg step (1.1 km north, 0.75 km east at 46 deg)
    rng = np.random.default_rng(2009)
    v, spacing = 160 * KT, 11.0
    gt, sel, track_err, speed_err, lat_mid, eta = _quantized_triples(rng, 20000, v, spacing, 0.01, 1.0)
    gate = gt.gate[sel]  # the first gate each triple fails (0: none)
    usable, off_line = gate == 0, gate == GATE_NAMES.index("collinearity")
    speed_change = gate == GATE_NAMES.index("speed_change")
    q = [50, 90, 99]
    print(f"climb |track error| deg p50/p90/p99: {np.percentile(np.degrees(np.abs(track_err)), q).round(2)}")
    print(f"climb |speed error| kt p50/p90/p99: {np.percentile(np.abs(speed_err) / KT, q).round(1)}")
    print(
        f"climb triples: {usable.size}, collinearity gate rejects {np.mean(off_line):.3f}, "
        f"then the constant-speed gate {np.mean(speed_change):.3f}, usable {np.mean(usable):.3f}"
    )
    if usable.any():
        print(
            f"climb usable |track error| deg p50/p90: "
            f"{np.percentile(np.degrees(np.abs(track_err[usable])), [50, 90]).round(2)}"
        )
    # the gates reject most triples; the errors are tens of degrees and knots (the baseline is
    # comparable to the step, so the small-error propagation of the cruise test does not apply)
    assert np.mean(~usable) > 0.5
    assert np.percentile(np.degrees(np.abs(track_err)), 90) > 10.0
