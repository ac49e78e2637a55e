"""The AFIS baseline: free-inertial drift against the closed-form error model, and the
smoothed error along the approach against the smoother's own covariance (Monte Carlo on
INS errors simulated by an independent Euler integration)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from aerotruth.analysis.fits.afis import (
    DEG_PER_H,
    EARTH_RADIUS_M,
    G0,
    MICRO_G,
    AfisSpec,
    afis_trajectory,
    horizontal_model,
)
from aerotruth.analysis.kalman import kalman_rts

QUIET = AfisSpec(accel_white_ug2_hz=0.0, gyro_white_deg2_s2_hz=0.0)


def test_free_inertial_position_sigma_follows_the_closed_form_schuler_solution():
    """No measurements: each initial error and bias propagates through the Schuler loop,
    dv'' = -w^2 dv + ...  (w^2 = g / R), and the variances add (hand-derived):
    dp = dp0 + dv0 sin(wt)/w - R psi0 (1 - cos wt) + b_a (1 - cos wt)/w^2 - R b_g (t - sin(wt)/w)."""
    F, G, Qc, P0 = horizontal_model(QUIET)
    t = np.arange(0.0, 601.0, 10.0)
    _, P = kalman_rts(t, F, G, Qc, np.zeros(5), P0, {}, smooth=False)
    s = QUIET
    w = math.sqrt(G0 / EARTH_RADIUS_M)
    var = (
        s.initial_position_m**2
        + (s.initial_velocity_mps * np.sin(w * t) / w) ** 2
        + (EARTH_RADIUS_M * s.initial_tilt_urad * 1e-6 * (1 - np.cos(w * t))) ** 2
        + (s.accel_bias_ug * MICRO_G * (1 - np.cos(w * t)) / w**2) ** 2
        + (EARTH_RADIUS_M * s.gyro_bias_deg_h * DEG_PER_H * (t - np.sin(w * t) / w)) ** 2
    )
    assert np.sqrt(P[:, 0, 0]) == pytest.approx(np.sqrt(var), rel=1e-6)


RUNWAY = 2450.0


def _scenario(dt=1.0):
    """A 3-deg approach from 19.95 km at 70 m/s, then a level pass at 15 m over a 2,450 m
    runway (threshold crossed at t = 285 s, stop end at 320 s: on epochs)."""
    t = np.arange(0.0, 420.0, dt)
    x = -19_950.0 + 70.0 * t
    z = np.maximum(15.0, 15.0 - x * math.tan(math.radians(3.0)))
    return t, np.column_stack([x, np.zeros_like(x), z])


def _simulate_errors(t, spec, rng, runs, sub=5):
    """INS and baro errors of `runs` independent runs by Euler integration at dt/sub
    (independent of the filter's exact discretisation): horizontal [dp, dv, psi] x 2 axes,
    vertical dh, baro error; (runs, len(t), 3) and (runs, len(t))."""
    dt = (t[1] - t[0]) / sub
    out = np.zeros((runs, len(t), 3))
    baro = np.zeros((runs, len(t)))
    qa = spec.accel_white_ug2_hz * MICRO_G**2 / 2
    qg = spec.gyro_white_deg2_s2_hz * math.radians(1) ** 2 / 2
    for axis in (0, 1):
        p, v, psi = (
            rng.normal(0, s, runs)
            for s in (spec.initial_position_m, spec.initial_velocity_mps, spec.initial_tilt_urad * 1e-6)
        )
        ba, bg = (
            rng.normal(0, spec.accel_bias_ug * MICRO_G, runs),
            rng.normal(0, spec.gyro_bias_deg_h * DEG_PER_H, runs),
        )
        for k in range(len(t)):
            out[:, k, axis] = p
            for _ in range(sub):
                a = -G0 * psi + ba + math.sqrt(qa / dt) * rng.standard_normal(runs)
                p, v, psi = (
                    p + v * dt,
                    v + a * dt,
                    psi + (v / EARTH_RADIUS_M + bg + math.sqrt(qg / dt) * rng.standard_normal(runs)) * dt,
                )
    h, vz = rng.normal(0, spec.initial_position_m, runs), rng.normal(0, spec.initial_velocity_mps, runs)
    baz, eb = rng.normal(0, spec.accel_bias_ug * MICRO_G, runs), rng.normal(0, spec.baro_sigma_m, runs)
    qb = 2 * spec.baro_sigma_m**2 / spec.baro_tau_s
    for k in range(len(t)):
        out[:, k, 2], baro[:, k] = h, eb
        for _ in range(sub):
            h, vz = (
                h + vz * dt,
                vz + (2 * G0 / EARTH_RADIUS_M * h + baz + math.sqrt(qa / dt) * rng.standard_normal(runs)) * dt,
            )
            eb = eb - eb / spec.baro_tau_s * dt + math.sqrt(qb / dt) * rng.standard_normal(runs) * dt
    return out, baro


@pytest.mark.slow
def test_smoothed_error_along_the_approach_matches_the_smoother_covariance():
    """Cross-track and vertical (what an ILS angle sees); the event marks fall exactly on
    epochs here, so the along-track axis, whose budget is the mark's timing, is not scored."""
    spec = AfisSpec()
    t, truth = _scenario()
    rng = np.random.default_rng(7)
    runs = 300
    over = (truth[:, 0] >= 0) & (truth[:, 0] <= RUNWAY)
    ev = np.isin(truth[:, 0], (0.0, RUNWAY)).astype(int)
    errs, sigs = [], []
    for ins_err, baro_err in zip(*_simulate_errors(t, spec, rng, runs), strict=False):
        baro = truth[:, 2] + baro_err + spec.baro_white_m * rng.standard_normal(len(t))
        ra = np.where(over, truth[:, 2] + spec.ra_sigma_m * rng.standard_normal(len(t)), np.nan)
        tv = np.where(over, truth[:, 1] + spec.tvps_sigma_m * rng.standard_normal(len(t)), np.nan)
        est, sig = afis_trajectory(t, truth + ins_err, baro, ra, tv, ev, np.full(len(t), 70.0), RUNWAY, spec)
        errs.append(est - truth)
        sigs.append(sig)
    errs, sigs = np.array(errs), np.array(sigs)
    assert ev.sum() == 2
    for axis in (1, 2):
        for lo in (-20_000, -15_000, -10_000, -5_000, 0):
            sel = (truth[:, 0] >= lo) & (truth[:, 0] < lo + 5000)
            rms = np.sqrt(np.mean(errs[:, sel, axis] ** 2))
            assert rms == pytest.approx(np.sqrt(np.mean(sigs[:, sel, axis] ** 2)), rel=0.20), (axis, lo)
    # worse far out than at the threshold (FITS paper section II)
    at_thr = np.argmin(np.abs(truth[:, 0]))
    for axis in (1, 2):
        assert sigs[0, 0, axis] > 10 * sigs[0, at_thr, axis]
