"""Reference-free consistency fit on a synthetic flight whose wind, heading and airspeed
errors are known (the generator below integrates the exact, non-linear wind triangle)."""

import numpy as np
import pandas as pd
import pytest

from aerotruth.analysis.wind.modes_wind import fit, predict_rms


def synthetic(A_deg=1.5, k=0.01, D_s=2.0, B_deg=0.0, C_deg=0.0, noise_mps=0.5, seed=0, hours=2.0, slaving_tau_s=0.0):
    rng = np.random.default_rng(seed)
    t = np.arange(0.0, hours * 3600, 1.0)
    # legs of 4-8 min between turns at 1.5 deg/s to random headings
    parts, h = [], 0.0
    while sum(len(p) for p in parts) < len(t):
        parts.append(np.full(int(rng.uniform(240, 480)), h))
        new = h + rng.uniform(60, 180) * rng.choice([-1, 1])
        parts.append(np.linspace(h, new, int(abs(new - h) / 1.5), endpoint=False))
        h = new
    psi = np.radians(np.concatenate(parts)[: len(t)])
    tas = 120.0 + 5 * np.sin(2 * np.pi * t / 1800.0)
    wn = 15.0 * np.cos(2 * np.pi * t / 7200.0)
    we = 20.0 + 5.0 * np.sin(2 * np.pi * t / 5400.0)
    vn, ve = tas * np.cos(psi) + wn, tas * np.sin(psi) + we
    # what the aircraft reports: heading late by D_s, off by -A (the correction is +A) and a one-cycle deviation
    psi_late = np.interp(t - D_s, t, np.unwrap(psi))
    dev = np.radians(A_deg + B_deg * np.sin(psi_late) + C_deg * np.cos(psi_late))
    if (
        slaving_tau_s
    ):  # a slaved gyro: the error follows the valve's deviation, de/dt = (dev - e) / tau, 10 sub-steps a second
        e = np.empty_like(dev)
        e[0] = dev[0]
        for i in range(1, len(dev)):
            x = e[i - 1]
            for _ in range(10):
                x += 0.1 * (dev[i - 1] - x) / slaving_tau_s
            e[i] = x
        dev = e
    psi_rep = psi_late - dev
    tas_rep = tas / (1 + k)
    return pd.DataFrame(
        {
            "time_s": t,
            "tas_mps": tas_rep,
            "heading_rad": psi_rep,
            "vn_mps": vn + noise_mps * rng.standard_normal(len(t)),
            "ve_mps": ve + noise_mps * rng.standard_normal(len(t)),
            "heading_rate_rad_s": np.gradient(np.unwrap(psi_rep), t),
        }
    )


def test_hidden_heading_offset_tas_scale_and_time_offset_are_recovered():
    track = synthetic()
    f = fit(track, effects=("heading_offset", "tas_scale", "heading_time_offset"))
    got = dict(zip(f["names"], f["coef"], strict=False))
    se = dict(zip(f["names"], f["se"], strict=False))
    assert got["A_deg"] == pytest.approx(1.5, abs=max(0.1, 4 * se["A_deg"]))
    assert got["k"] == pytest.approx(0.01, abs=0.002)
    assert got["D_s"] == pytest.approx(2.0, abs=0.3)


def test_one_cycle_deviation_is_recovered():
    track = synthetic(A_deg=0.0, k=0.0, D_s=0.0, B_deg=1.0, C_deg=-0.5)
    f = fit(track, effects=("heading_deviation_1psi",))
    got = dict(zip(f["names"], f["coef"], strict=False))
    assert (got["B_deg"], got["C_deg"]) == pytest.approx((1.0, -0.5), abs=0.15)


def test_held_out_gain_is_positive_only_for_a_real_effect():
    track = synthetic(A_deg=1.5, k=0.0, D_s=0.0)
    half = np.arange(len(track)) < len(track) // 2
    base = predict_rms(track, fit(track, rows=half), 600.0, (), ~half)
    with_a = predict_rms(track, fit(track, effects=("heading_offset",), rows=half), 600.0, ("heading_offset",), ~half)
    assert with_a < 0.8 * base
    null = synthetic(A_deg=0.0, k=0.0, D_s=0.0, seed=3)
    base0 = predict_rms(null, fit(null, rows=half), 600.0, (), ~half)
    with0 = predict_rms(null, fit(null, effects=("heading_offset",), rows=half), 600.0, ("heading_offset",), ~half)
    assert with0 > 0.97 * base0  # nothing to gain on held-out data when nothing is there


def test_declination_history_is_the_per_date_declination_in_one_call():
    """One ppigrf call for many dates gives each date's declination (the per-date path);
    around Minneapolis the agonic line has drifted west over the decades, so the
    declination there fell from east to about zero between 1950 and 2010 (IGRF)."""
    import datetime as dt

    from aerotruth.analysis.wind.modes_wind import declination_deg, declination_history_deg

    dates = [dt.datetime(y, 1, 1) for y in (1950, 1980, 2010)]
    got = declination_history_deg(44.88, -93.22, 3000.0, dates)
    each = [declination_deg([44.88], [-93.22], [3000.0], d)[0] for d in dates]
    assert got == pytest.approx(each, abs=1e-9)
    assert got[0] > got[1] > got[2] and got[0] > 3.0 and abs(got[2]) < 2.0
