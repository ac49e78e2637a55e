"""Flux valve, slaved gyro and IGRF field (wind paper eq. 2, section 7 and Fig. 7).

Expectations are closed forms of compass-deviation theory (hard iron: sin d = -(P sin z' +
Q cos z')/H exactly; Smith's first-order coefficients), hand-worked turning and
acceleration errors, the first-order step response, and IGRF values from direct ppigrf
calls (Minneapolis, 2009-08-15, hand-checked: H 17,379 nT, Z 53,420 nT, D +0.91 deg).
"""

from __future__ import annotations

import datetime as dt
import math
import time

import numpy as np
import pandas as pd
import ppigrf
import pytest

from aerotruth.sensors.magnetics import (
    FluxValve,
    FluxValveFleetSpec,
    FluxValveSpec,
    GeomagneticField,
    HeadingSystem,
    slaved_heading,
)
from aerotruth.units import DEG, G0

DATE = dt.date(2009, 8, 15)
H_C = 17400.0  # nT, horizontal field over Minnesota (the Mesaba region's centre)
PSI = np.arange(720) * (2 * np.pi / 720)  # true magnetic headings for a compass swing


@pytest.fixture(scope="module")
def mesaba_field() -> GeomagneticField:
    return GeomagneticField(DATE, (38.0, 50.0), (-100.0, -78.0))


def _wrap(x):
    return np.mod(np.asarray(x) + np.pi, 2 * np.pi) - np.pi


def _swing(spec: FluxValveSpec, h_nt: float, z_nt: float) -> tuple[np.ndarray, np.ndarray]:
    """Level, unaccelerated compass swing in a field with no declination: (z', d)."""
    z_meas = FluxValve(spec).heading_mag(np.array([h_nt, 0.0, z_nt]), 0.0, 0.0, PSI)
    return z_meas, _wrap(z_meas - PSI)


def _fit_eq2(z_meas: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Least-squares A, B, C, D, E of wind paper eq. 2 against the measured heading (rad)."""
    x = np.column_stack([np.ones_like(z_meas), np.sin(z_meas), np.cos(z_meas), np.sin(2 * z_meas), np.cos(2 * z_meas)])
    return np.linalg.lstsq(x, d, rcond=None)[0]


def _turning_track(n: int = 36000, rate_hz: float = 10.0, tas: float = 130.0, bank_deg: float = 25.0) -> pd.DataFrame:
    """10 Hz truth-like samples near Minneapolis: 5 min legs joined by coordinated 360-deg
    right turns at `bank_deg` (turn rate g tan(phi) / V), level at 3000 m, flat-Earth positions."""
    t = np.arange(n) / rate_hz
    omega = G0 * math.tan(bank_deg * DEG) / tas
    turn_s = 2 * np.pi / omega
    period = 300.0 + turn_s
    phase = np.mod(t, period)
    turning = phase >= 300.0
    psi = 0.3 + np.where(turning, (phase - 300.0) * omega, 0.0)
    roll = np.where(turning, bank_deg * DEG, 0.0)
    vn, ve = tas * np.cos(psi), tas * np.sin(psi)
    dt_s = 1.0 / rate_hz
    north = np.concatenate(([0.0], np.cumsum(vn[:-1]) * dt_s))
    east = np.concatenate(([0.0], np.cumsum(ve[:-1]) * dt_s))
    return pd.DataFrame(
        {
            "time_s": t,
            "lat_deg": 44.9 + north / 111_000.0,
            "lon_deg": -93.3 + east / (111_000.0 * math.cos(44.9 * DEG)),
            "h_ellipsoid_m": np.full(n, 3000.0),
            "vn_mps": vn,
            "ve_mps": ve,
            "vd_mps": np.zeros(n),
            "roll_rad": roll,
            "pitch_rad": np.zeros(n),
            "heading_rad": np.mod(psi, 2 * np.pi),
        }
    )


# ----------------------------------------------------------------------------- IGRF field


def test_igrf_field_at_minneapolis_matches_hand_checked_ppigrf_value(mesaba_field):
    c = mesaba_field.at(44.98, -93.27, 0.0)
    # ppigrf.igrf(-93.27, 44.98, 0.0, 2009-08-15): Be 277.35, Bn 17376.66, Bu -53419.72 nT
    assert c.north_nT == pytest.approx(17376.7, abs=5.0)
    assert c.east_nT == pytest.approx(277.4, abs=5.0)
    assert c.down_nT == pytest.approx(53419.7, abs=5.0)
    assert c.horizontal_nT == pytest.approx(17378.9, abs=5.0)
    assert np.degrees(c.declination_rad) == pytest.approx(0.914, abs=0.02)
    assert np.degrees(c.inclination_rad) == pytest.approx(71.979, abs=0.02)
    assert c.down_nT / c.horizontal_nT == pytest.approx(3.07, abs=0.01)  # Z/H ~ 3 over Minnesota (IGRF)


@pytest.mark.parametrize(
    "box", [((38.0, 50.0), (-100.0, -78.0)), ((54.0, 66.0), (-170.0, -140.0))], ids=["mesaba", "penair"]
)
def test_grid_field_is_within_5nT_and_0p02deg_of_direct_ppigrf_over_a_region(box):
    field = GeomagneticField(DATE, *box, h_m=(-500.0, 12000.0))
    rng = np.random.default_rng(7)
    lat, lon, h = rng.uniform(*box[0], 1500), rng.uniform(*box[1], 1500), rng.uniform(-500.0, 12000.0, 1500)
    be, bn, bu = (a[0] for a in ppigrf.igrf(lon, lat, h / 1000.0, dt.datetime(2009, 8, 15)))
    c = field.at(lat, lon, h)
    err_nt = np.max(np.abs(np.stack([c.north_nT - bn, c.east_nT - be, c.down_nT + bu])))
    err_dec = np.max(np.abs(np.degrees(c.declination_rad - np.arctan2(be, bn))))
    err_inc = np.max(np.abs(np.degrees(c.inclination_rad - np.arctan2(-bu, np.hypot(be, bn)))))
    print(f"\n{box}: max |grid - ppigrf| {err_nt:.2f} nT, declination {err_dec:.4f} deg, inclination {err_inc:.4f} deg")
    assert err_nt < 5.0 and err_dec < 0.02 and err_inc < 0.02


def test_field_along_a_track_matches_pointwise_evaluation(mesaba_field):
    df = _turning_track()
    n_, e_, d_ = (df[c].to_numpy() for c in ("lat_deg", "lon_deg", "h_ellipsoid_m"))
    a, b = mesaba_field.along(n_, e_, d_), mesaba_field.at(n_, e_, d_)
    assert np.max(np.abs(a.ned_nT() - b.ned_nT())) < 0.1  # the grid itself is good to ~1.5 nT


def test_field_box_may_cross_the_antimeridian():
    field = GeomagneticField(DATE, (50.0, 56.0), (170.0, 200.0))
    be, bn, bu = (a[0] for a in ppigrf.igrf([-175.0, 175.0], [52.0, 53.0], [1.0, 1.0], dt.datetime(2009, 8, 15)))
    c = field.at([52.0, 53.0], [-175.0, 175.0], [1000.0, 1000.0])
    assert np.max(np.abs(c.ned_nT() - np.stack([bn, be, -bu], axis=-1))) < 5.0


def test_field_covering_a_track_holds_its_points_and_builds_other_dates_once():
    df = _turning_track(n=6000)
    field = GeomagneticField.covering(df["lat_deg"], df["lon_deg"], DATE, margin_deg=0.25)
    assert field.lat_deg[0] == pytest.approx(df["lat_deg"].min() - 0.25) and field.lon_deg[1] == pytest.approx(
        df["lon_deg"].max() + 0.25
    )
    be, bn, bu = (a[0] for a in ppigrf.igrf(-93.3, 44.9, 3.0, dt.datetime(2009, 8, 15)))
    assert np.max(np.abs(field.at(44.9, -93.3, 3000.0).ned_nT() - [bn, be, -bu])) < 5.0
    assert field.for_date(dt.date(2004, 8, 15)) is field.for_date(dt.date(2004, 8, 15))
    assert field.for_date(DATE) is field
    aleutians = GeomagneticField.covering([52.0, 53.0], [178.0, -176.0], DATE)
    assert aleutians.lon_deg == pytest.approx((177.5, 184.5))


def test_points_outside_the_field_box_are_rejected_naming_the_coordinate(mesaba_field):
    with pytest.raises(ValueError, match="lon_deg: 1 point"):
        mesaba_field.at([45.0, 45.0], [-93.0, -120.0], [0.0, 0.0])
    with pytest.raises(ValueError, match="h_m"):
        mesaba_field.at(45.0, -93.0, 20_000.0)
    with pytest.raises(ValueError, match="when: IGRF covers"):
        GeomagneticField(dt.date(1850, 1, 1), (40, 41), (-90, -89))


# ----------------------------------------------------------------------------- deviation (eq. 2)


def test_hard_iron_deviation_scales_with_inverse_horizontal_field():
    # 4.0 deg peak-to-peak at the region's centre: |p| = H_c sin 2 deg (wind paper section 7)
    p_mag, p_dir = H_C * math.sin(2 * DEG), 30 * DEG
    pq = (p_mag * math.cos(p_dir), p_mag * math.sin(p_dir))
    spec = FluxValveSpec(hard_iron_nT=(pq[0], pq[1], 8000.0))
    b_times_h = []
    for ratio, paper_pp in ((1.0, 4.0), (0.8, 5.0), (1.18, 3.4)):
        h = ratio * H_C
        z_meas, d = _swing(spec, h, 3.0 * h)
        exact = np.arcsin(-(pq[0] * np.sin(z_meas) + pq[1] * np.cos(z_meas)) / h)  # module docstring, eq. 2 exact
        assert np.max(np.abs(d - exact)) < 1e-9
        pp = np.degrees(np.ptp(d))
        assert pp == pytest.approx(2 * np.degrees(math.asin(p_mag / h)), abs=1e-3)
        assert pp == pytest.approx(paper_pp, abs=0.06)  # Fig. 7: ~5 and ~3.4 deg at the extremes
        a_, b_, c_, d_, e_ = _fit_eq2(z_meas, d)
        assert max(abs(a_), abs(d_), abs(e_)) < 1e-6  # < 6e-5 deg: only odd harmonics (asin of a sinusoid)
        assert b_ == pytest.approx(-pq[0] / h, rel=2e-3) and c_ == pytest.approx(-pq[1] / h, rel=2e-3)
        b_times_h.append((b_ * h, c_ * h))
        print(
            f"\nH = {ratio:.2f} H_c: peak-to-peak {pp:.3f} deg, B {np.degrees(b_):.3f} deg, C {np.degrees(c_):.3f} deg"
        )
    assert np.allclose(b_times_h, b_times_h[0], rtol=1e-3)


def test_vertical_field_soft_iron_gives_B_C_proportional_to_Z_over_H():
    c, f = 0.004, -0.003
    spec = FluxValveSpec(soft_iron=((0.0, 0.0, c), (0.0, 0.0, f), (0.0, 0.0, 0.0)))
    coeffs = []
    for h, z in ((17400.0, 53400.0), (24000.0, 40000.0)):  # Z/H 3.07 (Minnesota) and 1.67
        z_meas, d = _swing(spec, h, z)
        assert np.max(np.abs(d - np.arcsin(-(c * z * np.sin(z_meas) + f * z * np.cos(z_meas)) / h))) < 1e-9
        a_, b_, c_, d_, e_ = _fit_eq2(z_meas, d)
        assert max(abs(a_), abs(d_), abs(e_)) < 1e-6
        assert b_ == pytest.approx(-c * z / h, rel=2e-3) and c_ == pytest.approx(-f * z / h, rel=2e-3)
        coeffs.append((b_, c_, z / h))
    (b1, c1, r1), (b2, c2, r2) = coeffs
    assert b1 / b2 == pytest.approx(r1 / r2, rel=1e-3) and c1 / c2 == pytest.approx(r1 / r2, rel=1e-3)


def test_horizontal_soft_iron_gives_A_D_E_that_do_not_change_with_the_field():
    a, b, d, e = 0.02, 0.006, -0.004, -0.01
    spec = FluxValveSpec(soft_iron=((a, b, 0.0), (d, e, 0.0), (0.0, 0.0, 0.0)))
    lam = 1 + (a + e) / 2
    big_a, big_d, big_e = (d - b) / (2 * lam), (a - e) / (2 * lam), (b + d) / (2 * lam)
    fits = []
    for h, z in ((17400.0, 53400.0), (24000.0, 40000.0)):
        z_meas, dev = _swing(spec, h, z)
        exact = np.angle(1 - 1j * big_a + (big_d - 1j * big_e) * np.exp(-2j * PSI))  # Smith, as in the docstring
        assert np.max(np.abs(dev - exact)) < 1e-12
        fits.append(_fit_eq2(z_meas, dev))
    np.testing.assert_allclose(fits[0], fits[1], atol=1e-12)
    a_, b_, c_, d_, e_ = fits[0]
    assert abs(b_) < 1e-12 and abs(c_) < 1e-12
    # first order: A = -A', D = -D', E = -E'; second-order terms ~ D'^2 ~ 2e-4 rad
    assert np.degrees(a_) == pytest.approx(np.degrees(-big_a), abs=0.02)
    assert np.degrees(d_) == pytest.approx(np.degrees(-big_d), abs=0.02)
    assert np.degrees(e_) == pytest.approx(np.degrees(-big_e), abs=0.02)


def test_mounting_error_gives_a_constant_offset_A():
    _, d = _swing(FluxValveSpec(mounting_deg=2.0), 17400.0, 53400.0)
    assert np.max(np.abs(d - 2.0 * DEG)) < 1e-12


# ----------------------------------------------------------------------------- tilt


def test_coordinated_turn_gives_the_hand_worked_turning_error():
    valve = FluxValve(FluxValveSpec())
    h, phi = 17400.0, 15 * DEG
    field = np.array([h, 0.0, 3.0 * h])  # tan I = 3, no declination
    psi = np.array([0.0, 30.0, 90.0, 180.0]) * DEG
    accel = G0 * math.tan(phi) * np.stack([-np.sin(psi), np.cos(psi), np.zeros(4)], axis=-1)  # towards the turn centre
    z_meas = np.degrees(valve.heading_mag(field, phi, 0.0, psi, accel))
    # tan z' = (cos phi sin psi - sin phi tan I) / cos psi: north -atan(3 sin 15) = -37.83 deg,
    # 30 deg: -18.72 deg, east: none (tan 15 * 3 < 1), south: 37.83 deg ahead
    np.testing.assert_allclose(z_meas, [360 - 37.828, 360 - 18.721, 90.0, 217.828], atol=2e-3)
    # hung on the true vertical (no acceleration) the banked valve would read true
    np.testing.assert_allclose(valve.heading_mag(field, phi, 0.0, psi), psi, atol=1e-12)


def test_valve_on_a_flown_turn_shows_the_northerly_turning_error(mesaba_field):
    df = _turning_track(bank_deg=15.0)
    fv = FluxValve(FluxValveSpec()).measure(df, mesaba_field)
    c = mesaba_field.at(df["lat_deg"], df["lon_deg"], df["h_ellipsoid_m"])
    psi_mag = _wrap(df["heading_rad"].to_numpy() - c.declination_rad)
    k = np.flatnonzero((df["roll_rad"].to_numpy() > 0) & (np.abs(psi_mag) < 0.5 * DEG))[5]  # mid-turn, heading north
    tan_i, phi, psi = c.down_nT[k] / c.horizontal_nT[k], 15 * DEG, psi_mag[k]
    expected = math.atan2(math.cos(phi) * math.sin(psi) - math.sin(phi) * tan_i, math.cos(psi))
    assert np.degrees(_wrap(fv[k] - expected)) == pytest.approx(0.0, abs=0.02)
    assert np.degrees(_wrap(fv[k] - psi)) < -35.0  # the valve shows a turn the other way
    straight = df["roll_rad"].to_numpy() == 0
    straight[1:] &= straight[:-1]
    straight[:-1] &= straight[1:]  # away from the roll steps, where the differenced acceleration jumps
    assert np.max(np.abs(_wrap(fv - psi_mag)[straight])) < 1e-5  # `along` vs `at`: < 0.1 nT


def test_steady_climb_attitude_does_not_disturb_the_pendulous_valve():
    valve = FluxValve(FluxValveSpec())
    z_meas = valve.heading_mag(np.array([17400.0, 0.0, 53400.0]), 0.0, 5 * DEG, PSI, np.zeros(3))
    assert np.max(np.abs(_wrap(z_meas - PSI))) < 1e-12


def test_forward_acceleration_on_east_heading_shows_a_turn_towards_north():
    valve = FluxValve(FluxValveSpec())
    z_meas = valve.heading_mag(
        np.array([17400.0, 0.0, 3 * 17400.0]), 0.0, 0.0, 90 * DEG, np.array([0.0, 0.1 * G0, 0.0])
    )
    # beta = atan(0.1), sin beta = 0.099504: z' = 90 - atan(3 * 0.099504) = 73.379 deg
    assert np.degrees(z_meas) == pytest.approx(73.379, abs=2e-3)


# ----------------------------------------------------------------------------- slaved gyro


def test_slaving_step_response_is_first_order_with_time_constant_tau():
    t = np.arange(6000) * 0.1
    psi = np.full(t.size, 1.0)
    valve = np.where(t >= 100.0, 1.0 + 10 * DEG, 1.0)
    out = slaved_heading(t, valve, psi, np.zeros(t.size), tau_s=60.0, cutout_bank_rad=10 * DEG)
    expected = 1.0 + np.where(t >= 100.0, 10 * DEG * (1 - np.exp(-(t - 100.0) / 60.0)), 0.0)
    assert np.max(np.abs(out - expected)) < 1e-9
    assert np.degrees(out[np.searchsorted(t, 160.0)] - 1.0) == pytest.approx(10 * (1 - math.exp(-1)), abs=1e-6)


def test_saturating_slaving_ramps_at_its_rate_limit_then_decays_with_tau():
    """A 10-deg valve step, torquer limited to 2 deg/min, tau 60 s: the loop is linear only
    within rate x tau = 2 deg of the valve, so the system heading ramps at 2 deg/min for
    (10 - 2) / 2 = 4 min, then closes the last 2 deg as exp(-t/tau) (hand-worked)."""
    t = np.arange(9000) * 0.1
    psi = np.full(t.size, 1.0)
    valve = np.where(t >= 100.0, 1.0 + 10 * DEG, 1.0)
    out = slaved_heading(
        t, valve, psi, np.zeros(t.size), tau_s=60.0, cutout_bank_rad=10 * DEG, rate_max_rad_s=2 * DEG / 60.0
    )
    dt_ = t - 100.0
    expected = np.where(
        dt_ < 0, 0.0, np.where(dt_ < 240.0, 2.0 * dt_ / 60.0, 10.0 - 2.0 * np.exp(-(dt_ - 240.0) / 60.0))
    )
    assert np.max(np.abs(np.degrees(out - 1.0) - expected)) < 0.01  # 0.1-s steps round the corner
    # below the limit it is the linear loop exactly
    small = np.where(t >= 100.0, 1.0 + 1.5 * DEG, 1.0)
    lin = slaved_heading(t, small, psi, np.zeros(t.size), tau_s=60.0, cutout_bank_rad=10 * DEG)
    sat = slaved_heading(
        t, small, psi, np.zeros(t.size), tau_s=60.0, cutout_bank_rad=10 * DEG, rate_max_rad_s=2 * DEG / 60.0
    )
    assert np.max(np.abs(lin - sat)) < 1e-12


def test_no_slaving_while_bank_exceeds_the_cutout():
    t = np.arange(6000) * 0.1
    psi = np.full(t.size, 1.0)
    valve = np.where(t >= 100.0, 1.0 + 10 * DEG, 1.0)
    roll = np.where((t >= 100.0) & (t < 200.0), 20 * DEG, 0.0)
    out = slaved_heading(t, valve, psi, roll, tau_s=60.0, cutout_bank_rad=10 * DEG)
    expected = 1.0 + np.where(t >= 200.0, 10 * DEG * (1 - np.exp(-(t - 200.0) / 60.0)), 0.0)
    assert np.max(np.abs(out - expected)) < 1e-9


def test_gyro_carries_a_turn_without_lag_and_ignores_the_valve_above_cutout():
    t = np.arange(3000) * 0.1
    psi = np.mod(0.2 + np.clip(t - 60.0, 0.0, 120.0) * 3 * DEG, 2 * np.pi)  # a 360 deg turn at 3 deg/s
    turning = (t >= 60.0) & (t < 180.0)
    # slaved throughout with an exact valve: no lag (a low-pass of the valve would lag 3 deg/s x 60 s)
    out = slaved_heading(t, psi, psi, np.zeros(t.size), tau_s=60.0, cutout_bank_rad=10 * DEG)
    assert np.max(np.abs(_wrap(out - psi))) < 1e-9
    # banked 25 deg: the valve's swinging turning error never reaches the system
    valve = np.mod(psi + np.where(turning, 40 * DEG * np.cos(psi), 0.0), 2 * np.pi)
    out = slaved_heading(t, valve, psi, np.where(turning, 25 * DEG, 0.0), tau_s=60.0, cutout_bank_rad=10 * DEG)
    assert np.max(np.abs(_wrap(out - psi))) < 1e-9


def test_gyro_drift_is_held_by_slaving_at_drift_times_tau():
    t = np.arange(12000) * 0.1
    psi = np.full(t.size, 2.0)
    drift = 6 * DEG / 3600.0  # 6 deg/h
    out = slaved_heading(t, psi, psi, np.zeros(t.size), tau_s=60.0, cutout_bank_rad=10 * DEG, drift_rad_s=drift)
    assert out[-1] - 2.0 == pytest.approx(drift * 60.0, rel=2e-3)  # 0.1 deg


def test_valve_spinning_a_full_turn_does_not_drag_the_gyro_round():
    # a violent transient: the valve reading sweeps a whole turn in 2 s, then settles 10 deg
    # right of the gyro; the slaving loop acts on the wrapped difference, so the system
    # converges on +10 deg with time constant tau (a chase of 370 deg would run away)
    t = np.arange(6000) * 0.1
    psi = np.full(t.size, 1.0)
    sweep = np.clip((t - 10.0) / 2.0, 0.0, 1.0) * 2 * np.pi
    valve = np.mod(1.0 + sweep + np.where(t >= 12.0, 10 * DEG, 0.0), 2 * np.pi)
    roll = np.zeros(t.size)
    out = slaved_heading(t, valve, psi, roll, tau_s=60.0, cutout_bank_rad=10 * DEG)
    after = t >= 100.0
    err = np.degrees(_wrap(out - psi))
    # bounded by a few degrees during the sweep (integrating <= 180 deg over 2 s / 60 s) and
    # then the first-order approach to +10 deg
    assert np.max(np.abs(err)) < 12.0
    expected = 10.0 * (1 - np.exp(-(t[after] - 12.0) / 60.0))
    assert np.max(np.abs(err[after] - expected)) < 3.0
    assert err[-1] == pytest.approx(10.0, abs=0.1)


def test_gyro_starts_from_the_power_up_reading_not_the_first_sample():
    # the first samples read a swinging valve (+30 deg); the gyro was slewed on the ground
    # to the static reading (+2 deg): the error starts at 2 deg and decays towards the
    # valve with tau (no 30-deg start)
    t = np.arange(600) * 0.1
    psi = np.full(t.size, 1.0)
    valve = np.where(t < 1.0, 1.0 + 30 * DEG, 1.0 + 2 * DEG)
    out = slaved_heading(
        t, valve, psi, np.zeros(t.size), tau_s=60.0, cutout_bank_rad=10 * DEG, initial_valve_rad=1.0 + 2 * DEG
    )
    assert np.degrees(out[0] - 1.0) == pytest.approx(2.0, abs=1e-9)
    # 1 s of +28 deg excess moves it by ~28 / 60 deg, then it holds at 2 deg + that decaying
    assert np.degrees(out[10] - 1.0) == pytest.approx(2.0 + 28.0 * (1 - math.exp(-1.0 / 60.0)), abs=1e-3)
    assert np.max(np.abs(np.degrees(out - 1.0))) < 2.5


def test_slaving_needs_equally_spaced_samples():
    with pytest.raises(ValueError, match="time_s"):
        slaved_heading([0.0, 0.1, 0.3], [0.0] * 3, [0.0] * 3, [0.0] * 3, tau_s=60.0, cutout_bank_rad=0.2)


# ----------------------------------------------------------------------------- the system


def test_stale_declination_table_offsets_true_heading_by_the_declination_change(mesaba_field):
    df = _turning_track(n=3000)  # straight and level for 300 s
    stale = HeadingSystem(FluxValveSpec(declination_epoch=dt.date(2004, 8, 15))).apply(df, mesaba_field)
    fresh = HeadingSystem(FluxValveSpec()).apply(df, mesaba_field)
    truth = df["heading_rad"].to_numpy()
    # an up-to-date table leaves only the slaving lag behind the declination change along
    # the track, tau dD/dt (D changes ~0.17 deg in these 39 km: ~0.03 deg)
    dec_rate = np.gradient(np.unwrap(fresh["declination_rad"].to_numpy()), df["time_s"].to_numpy())
    lag = np.abs(_wrap(fresh["heading_rad"].to_numpy() - truth))
    assert np.max(lag) <= 60.0 * np.max(np.abs(dec_rate)) * 1.01
    k = np.arange(0, 3000, 500)
    lat, lon, h = (df[c].to_numpy()[k] for c in ("lat_deg", "lon_deg", "h_ellipsoid_m"))
    dec = {}
    for year in (2004, 2009):
        be, bn, _ = (a[0] for a in ppigrf.igrf(lon, lat, h / 1000.0, dt.datetime(year, 8, 15)))
        dec[year] = np.degrees(np.arctan2(be, bn))
    error = np.degrees(_wrap(stale["heading_rad"].to_numpy()[k] - fresh["heading_rad"].to_numpy()[k]))
    print(f"\nstale 2004 table at Minneapolis: heading error {error.mean():.3f} deg")
    np.testing.assert_allclose(error, dec[2004] - dec[2009], atol=5e-3)  # ~ +0.54 deg
    assert error.mean() == pytest.approx(0.54, abs=0.02)


def test_system_heading_error_on_settled_straight_legs_is_the_hard_iron_deviation():
    # eight 10-min legs (10 tau) at headings 0, 45, ..., 315 deg near Minneapolis, level at 3000 m
    rate, leg_s, tas = 10.0, 600.0, 130.0
    n_leg = int(leg_s * rate)
    psi = np.repeat(np.arange(8) * 45 * DEG, n_leg)
    n = psi.size
    vn, ve = tas * np.cos(psi), tas * np.sin(psi)
    north, east = np.cumsum(vn) / rate, np.cumsum(ve) / rate
    df = pd.DataFrame(
        {
            "time_s": np.arange(n) / rate,
            "lat_deg": 44.9 + north / 111_000.0,
            "lon_deg": -93.3 + east / (111_000.0 * math.cos(44.9 * DEG)),
            "h_ellipsoid_m": np.full(n, 3000.0),
            "vn_mps": vn,
            "ve_mps": ve,
            "vd_mps": np.zeros(n),
            "roll_rad": np.zeros(n),
            "pitch_rad": np.zeros(n),
            "heading_rad": psi,
        }
    )
    p_nt = (400.0, -250.0, 300.0)
    field = GeomagneticField.covering(df["lat_deg"], df["lon_deg"], DATE)
    out = HeadingSystem(FluxValveSpec(hard_iron_nT=p_nt)).apply(df, field)
    k = np.arange(1, 9) * n_leg - 1  # last sample of each leg
    # settled on a ramp, a first-order lag is a delay tau: the system's magnetic heading is the
    # valve's of tau ago, its true heading adds today's table (D changes ~1.1 deg/100 km eastwards here)
    lag = k - int(60.0 * rate)
    dec, dev = {}, {}
    for name, j in (("now", k), ("lagged", lag)):
        lat, lon = df["lat_deg"].to_numpy()[j], df["lon_deg"].to_numpy()[j]
        be, bn, _ = (a[0] for a in ppigrf.igrf(lon, lat, 3.0, dt.datetime(2009, 8, 15)))
        dec[name] = np.arctan2(be, bn)
        psi_mag = psi[j] - dec[name]
        z_meas = np.angle(
            np.hypot(be, bn) * np.exp(1j * psi_mag) + (p_nt[0] - 1j * p_nt[1])
        )  # w = H e^{i psi} + P - iQ
        dev[name] = _wrap(z_meas - psi_mag)
    expected = np.degrees(dev["lagged"] + dec["now"] - dec["lagged"])
    error = np.degrees(_wrap(out["heading_rad"].to_numpy()[k] - psi[k]))
    print(
        "\nsettled heading error by leg (deg):",
        np.round(error, 3),
        "of which slaving lag:",
        np.round(np.degrees(dec["now"] - dec["lagged"] + dev["lagged"] - dev["now"]), 3),
    )
    np.testing.assert_allclose(error, expected, atol=0.005)
    assert np.ptp(error) > 2.0


def test_heading_system_on_an_hour_of_10hz_track(mesaba_field):
    df = _turning_track()
    spec = FluxValveFleetSpec(poor_fraction=1.0).draw(np.random.default_rng(3))
    system = HeadingSystem(spec)
    out = system.apply(df, mesaba_field)
    assert len(out) == len(df) and list(out.columns) == [
        "heading_mag_rad",
        "heading_rad",
        "valve_heading_mag_rad",
        "declination_rad",
        "slaving",
    ]
    assert not out["slaving"][df["roll_rad"] > 10 * DEG].any()
    runs = []
    for _ in range(5):
        t0 = time.perf_counter()
        system.apply(df, mesaba_field)
        runs.append(time.perf_counter() - t0)
    print(f"\nheading system, {len(df)} samples: {min(runs) * 1e3:.1f} ms; samples/s: {len(df) / min(runs):.0f}")


# ----------------------------------------------------------------------------- specs


def test_fleet_draw_matches_the_stated_distributions():
    fleet = FluxValveFleetSpec(
        poor_fraction=0.3,
        poor_hard_iron_sigma_nT=500.0,
        healthy_hard_iron_sigma_nT=100.0,
        soft_iron_sigma=0.004,
        mounting_sigma_deg=1.5,
        slaving_tau_s=90.0,
    )
    rng = np.random.default_rng(11)
    specs = [fleet.draw(rng) for _ in range(4000)]
    p = np.array([s.hard_iron_nT for s in specs])
    # mixture: E[p_i^2] = 0.3 * 500^2 + 0.7 * 100^2 = 82,000 nT^2 (standard error ~2,000)
    assert np.mean(p**2) == pytest.approx(82_000.0, rel=0.1)
    assert np.std([s.mounting_deg for s in specs]) == pytest.approx(1.5, rel=0.05)
    assert np.std([s.soft_iron for s in specs]) == pytest.approx(0.004, rel=0.05)
    assert all(s.slaving_tau_s == 90.0 for s in specs)
    assert fleet.draw(np.random.default_rng(5)) == fleet.draw(np.random.default_rng(5))


def test_bad_specs_are_rejected_naming_the_field():
    with pytest.raises(ValueError, match="poor_hard_iron_sigma_nT"):
        FluxValveFleetSpec(poor_hard_iron_sigma_nT=-1.0)
    with pytest.raises(ValueError, match="mounting_sigma_deg"):
        FluxValveFleetSpec(mounting_sigma_deg=-0.5)
    with pytest.raises(ValueError, match="soft_iron"):
        FluxValveSpec(soft_iron=((0.0, 0.0), (0.0, 0.0, 0.0), (0.0, 0.0, 0.0)))
    with pytest.raises(ValueError, match="declination_epoch"):
        FluxValveSpec(declination_epoch="stale")
    assert FluxValveSpec(declination_epoch="2004-08-15").declination_epoch == dt.date(2004, 8, 15)
    with pytest.raises(ValueError, match="slaving_tau_s"):
        FluxValveSpec(slaving_tau_s=0.0)


def test_poor_count_fixes_the_fleet_composition_and_keeps_each_valve_draw():
    from aerotruth.sensors.magnetics import poor_valves

    ids = [f"N{i}" for i in range(7)]
    # exactly k, every k-subset reachable, each aircraft poor 4/7 of the time (hypergeometric)
    draws = [poor_valves(ids, 4, np.random.default_rng(s)) for s in range(3000)]
    assert all(len(d) == 4 and d <= set(ids) for d in draws)
    share = np.mean([[a in d for a in ids] for d in draws], axis=0)
    assert np.allclose(share, 4 / 7, atol=0.035)  # se sqrt(4/7 * 3/7 / 3000) = 0.009
    assert len(set(draws)) == 35  # C(7, 4)
    # the listing order does not matter, the stream does
    assert poor_valves(ids[::-1], 4, np.random.default_rng(9)) == poor_valves(ids, 4, np.random.default_rng(9))
    with pytest.raises(ValueError, match=r"poor_count: expected 0\.\.7"):
        poor_valves(ids, 8, np.random.default_rng(0))
    # a class decided for the fleet consumes the aircraft's stream as the fraction does: the
    # valve is the fraction's draw of that class (unit normals scaled by the class's sigma)
    spec = FluxValveFleetSpec(
        poor_fraction=0.5, poor_count=4, poor_hard_iron_sigma_nT=800.0, healthy_hard_iron_sigma_nT=100.0
    )
    for seed in range(20):
        cls_p, v_p = spec.draw_with_class(np.random.default_rng(seed), poor=True)
        cls_h, v_h = spec.draw_with_class(np.random.default_rng(seed), poor=False)
        assert (cls_p, cls_h) == ("poor", "healthy")
        assert np.allclose(np.array(v_p.hard_iron_nT) / 800.0, np.array(v_h.hard_iron_nT) / 100.0)
        assert v_p.soft_iron == v_h.soft_iron and v_p.mounting_deg == v_h.mounting_deg
        by_fraction = FluxValveFleetSpec(poor_fraction=1.0, poor_hard_iron_sigma_nT=800.0).draw(
            np.random.default_rng(seed)
        )
        assert v_p.hard_iron_nT == by_fraction.hard_iron_nT


def _slaving_exact(x: np.ndarray, alpha: float, e0: float) -> np.ndarray:
    """The slaving recursion sample by sample (the definition the filter approximates)."""
    y, e = np.empty(x.size), e0
    for i, v in enumerate(x):
        e += alpha * ((v - e + math.pi) % (2 * math.pi) - math.pi)
        y[i] = e
    return y


def test_slaving_filter_is_exact_across_a_branch_change_and_after_a_swing():
    """The unwrapped valve-minus-gyro error can come back from a bank cutout 2 pi off the
    gyro's branch (JSBSim legs: a 40-s stretch of such inputs after a turn); the filter must
    follow the wrapped recursion there, and be exactly linear again once the input is calm
    (it used to stay in block mode for the rest of the leg)."""
    from aerotruth.sensors.magnetics import _slaving_filter

    rng = np.random.default_rng(3)
    alpha = -math.expm1(-0.1 / 60.0)
    x = 0.05 + 0.01 * rng.standard_normal(20000)
    x[5000:] += 2 * np.pi  # the branch change
    got = _slaving_filter(x, alpha, 0.0)
    assert np.max(np.abs(got - _slaving_exact(x, alpha, 0.0))) < 1e-12
    # a 3-s swing through the null (the valve spinning in a violent transient), then calm
    x = 0.05 + 0.01 * rng.standard_normal(20000)
    x[8000:8030] += np.linspace(0.0, 2 * np.pi, 30)
    x[8030:] += 2 * np.pi
    got, ref = _slaving_filter(x, alpha, 0.0), _slaving_exact(x, alpha, 0.0)
    assert np.max(np.abs(got - ref)) < 1e-3  # block wrapping only near the null
    assert (
        np.max(np.abs(got[9000:] - ref[9000:] - (got[8999] - ref[8999]) * (1 - alpha) ** np.arange(1, 11001))) < 1e-12
    )
