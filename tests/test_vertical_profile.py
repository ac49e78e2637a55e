"""The route legs' vertical profile: climbs at climb power whose rate is the flight model's
(against the SAAB 340B's published ~2,000 fpm initial climb at MTOW, and falling with
height and weight as excess power does), descents on a planned path whose vertical speed
is the ground speed times its gradient, and ATC level-offs, all drawn per flight from the
flight's own named stream."""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pytest

import aerotruth.truth.flight as flight
from aerotruth.truth import profile as vp
from aerotruth.truth.days import plan_in_weather
from aerotruth.truth.weather import UniformAtmosphere
from aerotruth.units import FT, KT

FPM = FT / 60.0


def test_draws_are_in_their_ranges_and_shares():
    rng = np.random.default_rng(5)
    draws = [vp.draw_profile(rng, 21000.0, 1500.0) for _ in range(4000)]
    mass = np.array([d.mass_kg for d in draws])
    assert mass.min() >= vp.MASS_MIN_KG and mass.max() <= vp.MASS_MAX_KG
    assert mass.mean() == pytest.approx(vp.MODEL_MASS_KG, abs=25.0)
    path = np.array([d.descent_path_deg for d in draws])
    assert path.min() >= 2.6 and path.max() <= 3.4
    climbs = [d.climb_level_off for d in draws if d.climb_level_off is not None]
    descents = [d.descent_level_off for d in draws if d.descent_level_off is not None]
    # binomial shares: 0.35 and 0.5 of 4,000 (sd 0.0075, 0.0079)
    assert len(climbs) / 4000 == pytest.approx(0.35, abs=0.03)
    assert len(descents) / 4000 == pytest.approx(0.5, abs=0.03)
    for alt, dur in climbs:
        assert alt % 1000 == 0 and 4000 <= alt <= 19000 and 60 <= dur <= 240
    for alt, dur in descents:
        assert alt % 1000 == 0 and 3500 <= alt <= 19000 and 60 <= dur <= 300


def test_a_low_cruise_leaves_no_room_for_a_climb_level_off():
    rng = np.random.default_rng(1)
    for _ in range(200):
        d = vp.draw_profile(rng, 5000.0, 1500.0)
        assert d.climb_level_off is None  # no whole thousand between 4,000 and 3,000 ft


def test_the_same_stream_draws_the_same_profile_and_no_mass_for_other_airframes():
    a = vp.draw_profile(np.random.default_rng(9), 17000.0, 2000.0)
    b = vp.draw_profile(np.random.default_rng(9), 17000.0, 2000.0)
    c = vp.draw_profile(np.random.default_rng(9), 17000.0, 2000.0, mass=False)
    assert a == b
    assert c.mass_kg is None and c.descent_path_deg == a.descent_path_deg


def _fly(monkeypatch, mass_kg, level_off=None, path_deg=3.0):
    monkeypatch.setattr(flight, "draw_profile", lambda *a, **k: vp.VerticalProfile(mass_kg, path_deg, None, level_off))
    plan = plan_in_weather(
        "KDCA",
        "KRDU",
        dt.datetime(2009, 8, 15, 14, tzinfo=dt.UTC),
        weather_seed=7,
        rng=np.random.default_rng(3),
        cruise_flight_level=230,
    )
    df = flight.fly_leg(plan, seed=1, atmosphere=UniformAtmosphere()).df.iloc[::10]
    return (
        df["time_s"].to_numpy(),
        df["pressure_altitude_m"].to_numpy() / FT,
        -df["vd_mps"].to_numpy() / FPM,
        np.hypot(df["vn_mps"].to_numpy(), df["ve_mps"].to_numpy()),
        df["phase"].to_numpy(),
    )


def _climb_fpm(alt, vs, phase, lo, hi):
    sel = (phase == "climb") & (alt > lo) & (alt < hi) & (vs > 300.0)
    return float(np.median(vs[sel]))


@pytest.mark.slow
def test_climb_rate_is_the_published_one_at_mtow_and_falls_with_height_and_weight(monkeypatch):
    _, alt, vs, _, phase = _fly(monkeypatch, 13155.0)
    low, mid = _climb_fpm(alt, vs, phase, 1000, 3000), _climb_fpm(alt, vs, phase, 9000, 11000)
    assert low == pytest.approx(2000.0, rel=0.10)  # SAAB 340B: ~2,000 fpm initial climb, MTOW, sea level, ISA
    assert mid < low - 300.0  # the power lapse: excess power falls with height
    _, alt2, vs2, _, phase2 = _fly(monkeypatch, 11000.0)
    # lighter: more excess power per weight (ROC ~ (P - D V) / W: ~1/W at the same speed)
    assert _climb_fpm(alt2, vs2, phase2, 1000, 3000) > low * 13155.0 / 11000.0 * 0.9


@pytest.mark.slow
def test_descent_follows_its_path_and_holds_its_level_off(monkeypatch):
    t, alt, vs, gs, phase = _fly(monkeypatch, 12000.0, level_off=(9000.0, 120.0), path_deg=3.0)
    desc = phase == "descent"
    # held: within 50 ft of 9,000 ft for about the drawn 120 s (the capture takes a few s)
    held = desc & (np.abs(alt - 9000.0) < 50.0)
    assert 115.0 <= held.sum() <= 200.0
    # on the path (steady, away from the level-off and its rejoining): VS = -GS tan(3 deg)
    t_hold_end = t[held].max()
    before = desc & (alt > 11000.0) & (t < t[held].min() - 60.0)
    expect = -gs[before] * math.tan(math.radians(3.0)) / FPM
    assert np.median(np.abs(vs[before] - expect) / np.abs(expect)) < 0.05
    # after the hold it descends faster than the path to rejoin it, at most the expedite limit
    after = desc & (t > t_hold_end) & (t < t_hold_end + 60.0)
    assert vs[after].min() < np.median(expect) - 300.0
    # the expedite limit bounds the command; the pitch loop's response overshoots it briefly
    # (1-s samples), its 10-s means stay within 10 % of it
    ten_s = np.convolve(vs[after], np.ones(10) / 10.0, mode="valid")
    assert ten_s.min() >= 1.1 * flight.DESCENT_VS_MIN_FPM
    assert np.median(gs[before]) > 200 * KT  # the check is at descent speed, not in the approach
