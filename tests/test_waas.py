"""WAAS error model (FITS paper section III-B, Table I) and the INS drift of eq. 4 (Table II
grades) against their stated statistics and closed forms."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aerotruth.geo import enu
from aerotruth.sensors.inertial_errors import (
    DEG_PER_H,
    EARTH_RADIUS_M,
    G0,
    INS_GRADES,
    MICRO_G,
    InertialErrors,
    InertialErrorSpec,
    ins_error_ned,
)
from aerotruth.sensors.waas import WaasErrors, WaasSpec


def test_bias_sigmas_give_95_percent_figures_inside_the_table_i_ranges():
    spec = WaasSpec(jump_rate_per_h=0.0)
    rng = np.random.default_rng(1)
    b = np.array([spec.draw(rng, 2.0).bias_m for _ in range(4000)])
    assert b.std(axis=0) == pytest.approx([0.45, 0.45, 0.8], rel=0.05)
    radial95 = np.percentile(np.hypot(b[:, 0], b[:, 1]), 95)  # 2-D: 2.45 sigma = 1.10 m
    vertical95 = np.percentile(np.abs(b[:, 2]), 95)  # 1-D: 1.96 sigma = 1.57 m
    print(f"\nhorizontal 95 %: {radial95:.2f} m, vertical 95 %: {vertical95:.2f} m")
    assert 0.788 < radial95 < 1.694 and radial95 == pytest.approx(2.45 * 0.45, rel=0.06)
    assert 1.116 < vertical95 < 2.307 and vertical95 == pytest.approx(1.96 * 0.8, rel=0.06)


def test_cyclic_noise_peaks_at_12_s_with_amplitude_0_5_m_varying_30_percent():
    w = WaasSpec().draw(np.random.default_rng(2), 4000.0)
    c = w.cyclic_m
    spectrum = np.abs(np.fft.rfft(c - c.mean(axis=0), axis=0))
    f = np.fft.rfftfreq(len(c), 1.0)
    assert np.allclose(f[spectrum.argmax(axis=0)], 1.0 / 12.0, atol=1e-3)  # Fig. 6
    # sine with amplitude A0 (1 + m sin): mean square A0^2 (1 + m^2/2) / 2
    assert np.sqrt((c**2).mean(axis=0)) == pytest.approx(0.5 * math.sqrt((1 + 0.3**2 / 2) / 2), rel=0.02)
    assert np.abs(c).max(axis=0) == pytest.approx([0.65] * 3, abs=0.01)  # A0 (1 + 0.3)


def test_stepped_cyclic_noise_holds_each_fast_correction_for_6_s():
    w = WaasSpec(cyclic_waveform="stepped", cyclic_modulation=0.0).draw(np.random.default_rng(3), 600.0)
    s = np.sign(w.cyclic_m)
    assert np.allclose(np.abs(w.cyclic_m), 0.5)
    for axis in range(3):
        edges = np.flatnonzero(np.diff(s[:, axis]) != 0)
        assert np.all(np.diff(edges) == 6)


def test_gauss_markov_and_white_noise_have_their_sigmas_and_100_s_correlation():
    spec = WaasSpec()
    w = WaasErrors.draw(spec, np.random.default_rng(4), np.arange(0.0, 200_000.0))
    g = w.gm_m
    assert g.std(axis=0) == pytest.approx([0.05] * 3, rel=0.1)
    lag = 100
    r = (g[lag:] * g[:-lag]).mean(axis=0) / (g**2).mean(axis=0)
    assert r == pytest.approx([math.exp(-1.0)] * 3, abs=0.08)
    assert w.white_m.std(axis=0) == pytest.approx([0.03] * 3, rel=0.01)


def test_jumps_come_once_per_30_min_with_1_m_per_axis_and_one_receiver_flag_each():
    w = WaasSpec().draw(np.random.default_rng(5), 3600.0 * 500)
    steps = np.diff(w.jump_m, axis=0)
    at = np.flatnonzero(np.any(steps != 0, axis=1)) + 1
    flagged = np.flatnonzero((w.sv_change + w.iono_update) > 0)
    assert np.array_equal(at, flagged)  # every jump raises a flag at its epoch, and nothing else does
    assert len(at) / 500.0 == pytest.approx(2.0, rel=0.1)
    assert steps[at - 1].std() == pytest.approx(1.0, rel=0.1)
    assert w.sv_change.sum() / max(1, len(flagged)) == pytest.approx(0.5, abs=0.1)


def test_apply_adds_the_error_in_the_runway_frame_and_as_east_north_up_in_geodetic():
    spec = WaasSpec()
    t = np.arange(0.0, 60.0)
    w = spec.draw(np.random.default_rng(6), 59.0)
    xyz = np.column_stack([t * 70.0, np.zeros_like(t), 100.0 + t])
    assert np.allclose(w.apply(xyz, t) - xyz, w.error_m)
    llh = np.column_stack([np.full_like(t, 45.0), np.full_like(t, -93.0), 300.0 + t])
    meas = w.apply(llh, t, frame="llh")
    e, n, u = enu(meas[:, 0], meas[:, 1], meas[:, 2], 45.0, -93.0, 0.0)
    e0, n0, u0 = enu(llh[:, 0], llh[:, 1], llh[:, 2], 45.0, -93.0, 0.0)
    got = np.column_stack([np.asarray(e) - e0, np.asarray(n) - n0, np.asarray(u) - u0])
    assert np.allclose(got, w.error_m, atol=1e-5)


def test_negative_sigma_and_irregular_epochs_are_refused_naming_the_field():
    with pytest.raises(ValueError, match="gm_sigma_m"):
        WaasSpec(gm_sigma_m=-0.1)
    with pytest.raises(ValueError, match="bias_sigma_vertical_m"):
        WaasSpec(bias_sigma_vertical_m=-1.0)
    with pytest.raises(ValueError, match="t_s"):
        WaasErrors.draw(WaasSpec(), np.random.default_rng(0), np.array([0.0, 1.0, 2.5, 3.0]))
    w = WaasSpec().draw(np.random.default_rng(0), 10.0)
    with pytest.raises(ValueError, match="t_s"):
        w.apply(np.zeros((11, 3)), np.arange(11.0) + 0.5)


# --- INS drift, FITS paper eq. 4 with the Table II grades ---------------------------


def test_accel_bias_drift_is_half_b_t_squared_and_gyro_bias_drift_is_g_eps_t_cubed_over_6():
    t = np.arange(0.0, 601.0)
    b, eps = 500 * MICRO_G, 1.0 * DEG_PER_H
    x = ins_error_ned(t, [b, 0.0, b], [0.0, eps, 0.0])  # north from b_N and eps_E; down from b_D
    w = math.sqrt(G0 / EARTH_RADIUS_M)
    exact = b * (1 - np.cos(w * t)) / w**2 + G0 * eps * (t - np.sin(w * t) / w) / w**2
    assert np.allclose(x[:, 0], exact, rtol=1e-9, atol=1e-9)
    small = t <= 300.0  # Schuler-free small-time forms, relative error ~ (wt)^2 / 12
    approx = 0.5 * b * t**2 + G0 * eps * t**3 / 6
    assert np.allclose(x[small, 0], approx[small], rtol=(w * 300.0) ** 2 / 10)
    assert np.allclose(x[:, 2], 0.5 * b * t**2, rtol=1e-12)
    assert np.allclose(x[:, 1], 0.0)
    # east: eps_N tilts the platform the other way (x_E'' = beta_E - g phi_N)
    xe = ins_error_ned(t, [0.0, 0.0, 0.0], [eps, 0.0, 0.0])
    assert np.allclose(xe[:, 1], -G0 * eps * (t - np.sin(w * t) / w) / w**2, rtol=1e-9)


def test_accelerometer_white_noise_gives_the_velocity_random_walk_of_its_one_sided_psd():
    """Double integral of white acceleration with two-sided density q = S/2: var x(t) = q t^3 / 3."""
    spec = InertialErrorSpec(initial_velocity_sigma_mps=0.0, initial_tilt_sigma_urad=0.0)
    t = np.arange(0.0, 301.0)
    rng = np.random.default_rng(7)
    xs = np.array([InertialErrors.draw(spec, rng, t).error_ned_m[-1, 2] - 0.0 for _ in range(3000)])
    q = INS_GRADES["tactical"].accel_white_ug2_hz / 2 * MICRO_G**2
    bias_var = (INS_GRADES["tactical"].accel_bias_ug * MICRO_G) ** 2 * 300.0**4 / 4
    assert xs.var() == pytest.approx(q * 300.0**3 / 3 + bias_var, rel=0.08)


def test_ins_apply_rotates_ned_error_into_the_runway_frame():
    t = np.arange(0.0, 10.0)
    e = InertialErrors.draw(InertialErrorSpec(grade="automotive"), np.random.default_rng(8), t)
    p = np.zeros((10, 3))
    east_course = e.apply(p, t, 90.0)  # x along east, y left = north, z up
    assert np.allclose(east_course, np.column_stack([e.error_ned_m[:, 1], e.error_ned_m[:, 0], -e.error_ned_m[:, 2]]))
    with pytest.raises(ValueError, match="grade"):
        InertialErrors.draw(InertialErrorSpec(grade="consumer"), np.random.default_rng(0), t)
