"""Turbulence climatology of the truth legs (aerotruth.truth.turbulence): a patch's severity
is the MIL-F-8785C curve its probability of exceedance exceeds."""

from __future__ import annotations

import numpy as np
import pytest

from aerotruth.truth.turbulence import (
    CHOP_SCALE_M,
    GUST_DT_S,
    PATCH_MEAN_M,
    POE_OF_SEVERITY,
    ChopGusts,
    TurbulencePatches,
    chop_sigma_w,
    severity_of,
)


@pytest.mark.parametrize(
    "u,k",
    [
        (0.9, 1),
        (0.2, 1),
        (0.15, 1),
        (0.1, 2),
        (0.05, 2),
        (0.01, 3),
        (0.002, 3),
        (1e-3, 4),
        (2e-5, 5),
        (1e-5, 6),
        (1e-6, 7),
        (1e-9, 7),
    ],
)
def test_severity_is_the_most_severe_curve_exceeded(u, k):
    assert severity_of(u) == k


class _Props(dict):
    pass


def test_patches_follow_the_probabilities_of_exceedance_and_their_mean_length():
    rng = np.random.default_rng(5)
    fdm = _Props()
    p = TurbulencePatches(fdm, rng)
    assert fdm["atmosphere/turb-type"] == 3
    n, path = 200_000, 0.0
    while len(p.patches) < n:
        p.update(path, 7.0)
        path = p.next_m
    sev = np.array([k for _, k in p.patches])
    for k in (2, 3, 4):  # P(severity >= k) = POE of curve k; binomial 4-sigma bounds
        q = POE_OF_SEVERITY[k - 1]
        assert abs(np.mean(sev >= k) - q) < 4 * np.sqrt(q * (1 - q) / n), k
    lengths = np.diff([a for a, _ in p.patches])
    assert np.mean(lengths) == pytest.approx(PATCH_MEAN_M, rel=0.02)
    assert fdm["atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps"] == pytest.approx(7.0 / 0.3048)
    assert fdm["atmosphere/turbulence/milspec/severity"] == sev[-1]


@pytest.mark.parametrize("u,sigma", [(0.0, 0.095), (0.5, 0.212), (0.3, 0.149 + 0.2 * (0.212 - 0.149)), (1.0, 0.913)])
def test_chop_intensity_is_the_a320_quantile_interpolated(u, sigma):
    # hand-interpolated between the tabulated quantiles (validation/chop_climatology.py)
    assert chop_sigma_w(u) == pytest.approx(sigma)


class _Node:
    def __init__(self):
        self.values = []

    def set_double_value(self, v):
        self.values.append(v)


class _Manager:
    def __init__(self):
        self.nodes = {}

    def get_node(self, name, create=False):
        return self.nodes.setdefault(name, _Node())


class _Fdm:
    def __init__(self):
        self.pm = _Manager()

    def get_property_manager(self):
        return self.pm


def test_chop_gusts_have_the_dryden_first_order_variances_and_time_constants():
    # analytic: an AR(1) x' = a x + sigma sqrt(1 - a^2) n is stationary with rms sigma and
    # lag-one correlation a = exp(-dt / tau); tau_u = L / V, tau_v = tau_w = L / (2 V),
    # sigma_p = 1.9 sigma_w / sqrt(L b) (Yeager 1998 eq. 8)
    fdm, v, span = _Fdm(), 140.0, 21.44
    chop = ChopGusts(fdm, np.random.default_rng(2), span)
    chop.sigma_w = 0.5
    n = 200_000
    x = np.empty((n, 4))
    for k in range(n):
        chop.step(v, 0.0)  # heading north: u is the north gust, v the east one
        x[k] = chop.x
    assert np.std(x[:, :3], axis=0) == pytest.approx([0.5, 0.5, 0.5], rel=0.05)
    assert np.std(x[:, 3]) == pytest.approx(1.9 * 0.5 / np.sqrt(CHOP_SCALE_M * span), rel=0.05)
    for j, tau in enumerate([CHOP_SCALE_M / v, CHOP_SCALE_M / (2 * v), CHOP_SCALE_M / (2 * v)]):
        r1 = np.corrcoef(x[:-1, j], x[1:, j])[0, 1]
        assert r1 == pytest.approx(np.exp(-GUST_DT_S / tau), abs=0.005)
    nodes = fdm.pm.nodes
    assert nodes["atmosphere/gust-north-fps"].values[-1] == pytest.approx(x[-1, 0] / 0.3048)
    assert nodes["atmosphere/gust-east-fps"].values[-1] == pytest.approx(x[-1, 1] / 0.3048)
    assert nodes["atmosphere/chop/p-rad_sec"].values[-1] == pytest.approx(x[-1, 3])


def test_chop_patches_draw_the_climatology():
    chop = ChopGusts(_Fdm(), np.random.default_rng(4), 21.44)
    path = 0.0
    while len(chop.patches) < 20_000:
        chop.update(path)
        path = chop.next_m
    s = np.array([sw for _, sw in chop.patches])
    assert np.median(s) == pytest.approx(0.212, abs=0.005)
    assert np.mean(s > 0.642) == pytest.approx(0.05, abs=0.006)
    assert np.mean(np.diff([a for a, _ in chop.patches])) == pytest.approx(PATCH_MEAN_M, rel=0.03)


def test_steering_wander_is_gauss_markov_with_its_variance_and_correlation_time():
    # first-order Gauss-Markov: variance sigma^2 at every step (started stationary) and
    # autocorrelation exp(-lag / tau); 200 independent runs x 600 steps
    from aerotruth.truth.steering import STEER_DT_S, STEER_PROPERTY, SteeringWander

    sigma, tau, n_runs, n = 0.01, 5.0, 200, 600
    lag = int(round(tau / STEER_DT_S))
    x = np.empty((n_runs, n))
    for r in range(n_runs):
        fdm = _Fdm()
        w = SteeringWander(fdm, np.random.default_rng([7, r]), sigma_rad=sigma, tau_s=tau)
        for _k in range(n):
            w.step()
        x[r] = fdm.pm.nodes[STEER_PROPERTY].values
    assert np.std(x[:, 0]) == pytest.approx(sigma, rel=0.15)  # stationary from the first step
    assert np.std(x) == pytest.approx(sigma, rel=0.05)
    rho = np.mean(x[:, :-lag] * x[:, lag:]) / np.mean(x * x)
    assert rho == pytest.approx(np.exp(-1.0), abs=0.04)


def test_navigation_error_is_gauss_markov_in_feet_with_its_variance_and_correlation_time():
    # the same first-order Gauss-Markov checks for the FMS's cross-track error, which is set
    # into JSBSim in feet (the metres it is drawn in / 0.3048), stepped at the 1-s guidance tick
    from aerotruth.truth.steering import NAV_PROPERTY, NavigationError

    sigma, tau, n_runs, n = 15.0, 60.0, 200, 600
    x = np.empty((n_runs, n))
    for r in range(n_runs):
        fdm = _Fdm()
        e = NavigationError(fdm, np.random.default_rng([11, r]), sigma_m=sigma, tau_s=tau, dt_s=1.0)
        for _k in range(n):
            e.step()
        x[r] = np.asarray(fdm.pm.nodes[NAV_PROPERTY].values[1:]) * 0.3048
    assert np.std(x[:, 0]) == pytest.approx(sigma, rel=0.15)
    assert np.std(x) == pytest.approx(sigma, rel=0.05)
    lag = int(tau)
    rho = np.mean(x[:, :-lag] * x[:, lag:]) / np.mean(x * x)
    assert rho == pytest.approx(np.exp(-1.0), abs=0.05)


def test_mil8785_intensity_matches_hand_worked_values():
    from aerotruth.truth.turbulence import mil8785_intensity

    # low altitude (MIL-F-8785C 3.7.3): h = 100 ft, W20 = 30 ft/s
    f = 0.177 + 0.000823 * 100.0
    su, sw, lu, lw = mil8785_intensity(100.0, 30.0, 4)
    assert (su, sw, lu, lw) == pytest.approx((3.0 / f**0.4, 3.0, 100.0 / f**1.2, 100.0))
    # at and below 10 ft the height is clipped to 10 ft
    assert mil8785_intensity(2.0, 30.0, 1) == pytest.approx(mil8785_intensity(10.0, 30.0, 1))
    # medium altitude: Figure 7's 1e-2 curve between 1,750 ft (6.9) and 3,750 ft (7.4)
    assert mil8785_intensity(3000.0, 30.0, 3) == pytest.approx((7.2125, 7.2125, 1750.0, 1750.0))
    # transition at 1,500 ft, W20 = 20 ft/s, curve 2e-1: halfway between the low-altitude
    # values at 1,000 ft (sigma 2.0, f = 1 so sigma_u = sigma_w, L = 1,000) and the curve at
    # 1,500 ft (3.2 - 1000/1250 x 1.0 = 2.4; L 1,750)
    assert mil8785_intensity(1500.0, 20.0, 1) == pytest.approx((2.2, 2.2, 1375.0, 1375.0))


@pytest.mark.slow
@pytest.mark.parametrize("w20_kt", [0.0, 30.0])
def test_approach_gusts_near_the_ground_follow_the_wind_at_20ft(w20_kt):
    """Below 1,000 ft above the runway (KDLH: 1,428 ft above sea level, where JSBSim's own
    milspec model would use its POE curves) the vertical gust's rms is 0.1 x W20."""
    import math
    from datetime import date

    from aerotruth.truth.approach import approach_spec, fly_approach
    from aerotruth.truth.weather import UniformAtmosphere
    from aerotruth.units import FT, KT

    frm = math.radians(312.0)
    atm = UniformAtmosphere(u_mps=-w20_kt * KT * math.sin(frm), v_mps=-w20_kt * KT * math.cos(frm))
    sd = []
    for seed in (3, 4, 5):
        df = fly_approach(approach_spec("KDLH", "27", date(2009, 8, 15), turbulence=True), seed=seed, atmosphere=atm).df
        low = (df["z_m"] > 50 * FT) & (df["z_m"] < 900 * FT)
        sd.append(df.loc[low, "wind_w_mps"].std())
    expect = 0.1 * w20_kt * KT
    # ~100 s of 50 Hz samples per flight with L_w = h: each rms within ~15 % of the model's
    assert np.mean(sd) == pytest.approx(expect, rel=0.15, abs=1e-3)  # abs: what decays from above 1,000 ft
