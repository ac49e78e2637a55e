"""The Mode-S sensor: LSBs, registers sampled at different instants and held, reply processes."""

import numpy as np
import pandas as pd
import pytest

from aerotruth.sensors.modes import LSB, ModeSSensor, ModeSSpec, ReplyProcess, held_track, unique_payload_intervals


def avionics_turn(rate_deg_s=3.0, duration=600.0, dt=0.05):
    t = np.arange(0.0, duration, dt)
    heading = (90.0 + rate_deg_s * t) % 360
    return pd.DataFrame(
        {
            "time_s": t,
            "roll_deg": 25.0 + 0 * t,
            "track_deg": heading,
            "groundspeed_kt": 250.0 + 0 * t,
            "track_rate_deg_s": rate_deg_s + 0 * t,
            "tas_kt": 240.0 + 0 * t,
            "heading_mag_deg": heading,
            "ias_kt": 200.0 + 0 * t,
            "mach": 0.4 + 0 * t,
            "vrate_baro_fpm": 0 * t,
            "vrate_inertial_fpm": 0 * t,
            "v_east_kt": 0 * t,
            "v_north_kt": 0 * t,
            "vertical_rate_fpm": 0 * t,
            "altitude_ft": 15000 + 0 * t,
            "lat": 45.0 + 0 * t,
            "lon": -93.0 + 0 * t,
        }
    )


def test_fields_are_multiples_of_their_lsb():
    av = avionics_turn()
    av["tas_kt"] = 241.3
    msgs = ModeSSensor(ModeSSpec()).apply(av, np.random.default_rng(0))
    b50 = msgs[msgs["register"] == "BDS50"]
    assert set(b50["tas_kt"]) == {242.0}  # 241.3 kt to the 2-kt LSB
    h = msgs.loc[msgs["register"] == "BDS60", "heading_mag_deg"].to_numpy()
    assert np.allclose(h / LSB["heading_mag_deg"], np.round(h / LSB["heading_mag_deg"]))


def test_held_registers_lag_by_their_age_so_heading_and_track_disagree_in_a_turn_by_rate_times_age():
    rate = 3.0
    msgs = ModeSSensor(ModeSSpec()).apply(avionics_turn(rate), np.random.default_rng(1))
    for reg, field in (("BDS50", "track_deg"), ("BDS60", "heading_mag_deg")):
        m = msgs[msgs["register"] == reg]
        age = m["time_s"] - m["sampled_at_s"]
        assert (age >= 0).all() and age.max() <= 0.5 + 0.05  # refresh 0.5 s, avionics at 20 Hz
        truth_now = (90.0 + rate * m["time_s"]) % 360
        lag = ((truth_now - m[field] + 180) % 360) - 180
        # the value is the avionics' at sampled_at_s, to the LSB: lag = rate x age (+- half an LSB)
        assert np.allclose(lag, rate * age, atol=LSB[field] / 2 + 1e-9)


def test_squitters_come_every_0_4_to_0_6_s_less_the_lost_ones():
    p = ReplyProcess(kind="squitter", reception=1.0)
    d = np.diff(p.times(0.0, 3600.0, np.random.default_rng(2)))
    assert d.min() >= 0.4 and d.max() <= 0.6 and np.mean(d) == pytest.approx(0.5, abs=0.005)
    lossy = np.diff(ReplyProcess(kind="squitter", reception=0.8).times(0.0, 3600.0, np.random.default_rng(3)))
    assert np.mean(lossy) == pytest.approx(0.5 / 0.8, rel=0.02)


def test_interrogation_bursts_have_the_stated_dead_time_and_mean():
    p = ReplyProcess(dead_time_s=0.2, mean_excess_s=0.5, reception=1.0)
    d = np.diff(p.times(0.0, 20_000.0, np.random.default_rng(4)))
    assert d.min() >= 0.2 and np.mean(d) == pytest.approx(0.7, rel=0.02)
    assert np.median(d) == pytest.approx(0.2 + 0.5 * np.log(2), rel=0.03)


def test_a_steady_register_gives_no_new_payloads_and_a_held_track_fills_the_gaps():
    av = avionics_turn(rate_deg_s=0.0)
    msgs = ModeSSensor(ModeSSpec()).apply(av, np.random.default_rng(5))
    assert len(unique_payload_intervals(msgs, "BDS50")) == 0  # nothing ever changes
    track = held_track(msgs)
    assert track["tas_kt"].iloc[5:].eq(240.0).all() and track["heading_mag_deg"].iloc[5:].eq(90.0).all()


def test_missing_avionics_column_is_named():
    with pytest.raises(ValueError, match="'tas_kt'"):
        ModeSSensor(ModeSSpec()).apply(avionics_turn().drop(columns=["tas_kt"]), np.random.default_rng(0))
