"""The message-stream WAAS (aerotruth.sensors.waas_messages) against hand-worked
expectations: the Walker constellation's orbit, the fast-correction arithmetic on
signals whose correction error is known exactly, and the spectral null the range-rate
extrapolation puts at the update rate."""

import math

import numpy as np
import pytest

from aerotruth.sensors.waas import WaasErrors, WaasSpec
from aerotruth.sensors.waas_messages import (
    GPS_A_M,
    MU_EARTH,
    WaasMessageSpec,
    _satellites_ecef,
    fast_correction_residual,
    line_of_sight,
)
from aerotruth.truth.runway import RunwayFrame


def test_walker_satellites_stay_on_their_orbit_and_come_back_after_a_period_in_inertial_space():
    period = 2 * math.pi * math.sqrt(GPS_A_M**3 / MU_EARTH)  # 43,082 s: half a sidereal day
    assert period == pytest.approx(43_082, abs=5)
    t = np.array([0.0, 1234.0, period])
    r = _satellites_ecef(t, 0.3, 0.0)
    assert r.shape == (24, 3, 3)
    assert np.allclose(np.linalg.norm(r, axis=-1), GPS_A_M, rtol=1e-12)
    # after one orbit the Earth has turned by w T: turn the ECEF positions back to compare
    g = 7.2921151467e-5 * period
    back = np.stack(
        [r[:, 2, 0] * math.cos(g) - r[:, 2, 1] * math.sin(g), r[:, 2, 0] * math.sin(g) + r[:, 2, 1] * math.cos(g)], -1
    )
    assert np.allclose(back, r[:, 0, :2], atol=1e-3 * GPS_A_M)
    assert np.allclose(r[:, 2, 2], r[:, 0, 2], atol=1e-6 * GPS_A_M)
    # the orbit planes are inclined 55 deg: |z| never exceeds a sin 55
    assert np.abs(r[..., 2]).max() <= GPS_A_M * math.sin(math.radians(55.0)) + 1.0


def test_a_mid_latitude_site_sees_six_to_twelve_of_24_satellites_above_5_deg():
    los = line_of_sight(np.arange(0.0, 86_400.0, 600.0), 46.84, -92.19, 400.0, 0.7, 1.1)
    assert np.allclose(np.linalg.norm(los, axis=-1), 1.0)
    seen = (np.degrees(np.arcsin(los[..., 2])) > 5.0).sum(axis=0)
    assert seen.min() >= 4 and 6 <= np.median(seen) <= 12


def test_the_range_rate_correction_extrapolates_a_ramp_exactly_and_the_latency_leaves_rate_times_latency():
    """A clock error c = c0 + v t with no estimation noise and a negligible quantum: the RRC
    from successive corrections is -v, so c - PRC - RRC (t - t_k) = v L (L the latency),
    by hand; with no latency exactly zero."""
    t = np.arange(0.0, 300.0)
    c = 3.0 + 0.02 * t
    rng = np.random.default_rng(0)
    spec = WaasMessageSpec(prc_noise_sigma_m=0.0, prc_resolution_m=1e-9, latency_s=0.0)
    r = fast_correction_residual(t, c, spec, 1.0, rng)
    assert np.abs(r[20:]).max() < 1e-8
    spec = WaasMessageSpec(prc_noise_sigma_m=0.0, prc_resolution_m=1e-9, latency_s=2.0)
    r = fast_correction_residual(t, c, spec, 1.0, rng)
    assert np.allclose(r[20:], 0.02 * 2.0, atol=1e-8)


def test_a_constant_error_leaves_only_the_quantum():
    t = np.arange(0.0, 120.0)
    spec = WaasMessageSpec(prc_noise_sigma_m=0.0, latency_s=0.0)
    r = fast_correction_residual(t, np.full(len(t), 1.234), spec, 0.0, np.random.default_rng(0))
    assert np.allclose(r[20:], 1.234 - 0.125 * round(1.234 / 0.125))  # 1.234 - 1.25 = -0.016


def test_the_extrapolation_of_white_correction_noise_has_a_null_at_the_update_rate():
    """Each correction's error e_k enters as -(1 + s) e_k over its own interval and + s e_k
    over the next (s = (t - t_k) / dt): the kernel's Fourier transform at f = 1/dt is
    -i dt/2pi + i dt/2pi = 0, by hand. So the residual of white correction noise has next
    to no power at 1/6 Hz against 1/12 Hz."""
    from scipy.signal import periodogram

    t = np.arange(0.0, 6000.0)
    spec = WaasMessageSpec(prc_noise_sigma_m=0.2, prc_resolution_m=1e-6, latency_s=0.0)
    rng = np.random.default_rng(3)
    p = 0
    for _ in range(20):
        f, pp = periodogram(fast_correction_residual(t, np.zeros(len(t)), spec, 0.0, rng), fs=1.0)
        p = p + pp

    def at(freq):
        return p[np.abs(f - freq) < 0.004].mean()

    assert at(1 / 6) < 0.05 * at(1 / 12)
    assert at(1 / 3) < 0.05 * at(1 / 12)


def test_the_message_stream_draw_fills_the_waas_parts_and_needs_the_runway_frame():
    spec = WaasSpec(model="message_stream")
    t = np.arange(0.0, 600.0)
    with pytest.raises(ValueError, match="runway frame"):
        WaasErrors.draw(spec, np.random.default_rng(1), t)
    w = WaasErrors.draw(spec, np.random.default_rng(1), t, RunwayFrame(46.84, -92.19, 400.0, 270.0))
    assert w.cyclic_m.shape == w.gm_m.shape == w.jump_m.shape == (600, 3)
    assert np.allclose(w.jump_m[0], 0.0) and not w.white_m.any()
    assert np.allclose(w.error_m, w.bias_m + w.jump_m + w.cyclic_m + w.gm_m)
    # the same draw twice from the same stream: the same errors (a named stream's contract)
    again = WaasErrors.draw(spec, np.random.default_rng(1), t, RunwayFrame(46.84, -92.19, 400.0, 270.0))
    assert np.array_equal(again.error_m, w.error_m)
