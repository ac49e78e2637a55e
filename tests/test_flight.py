"""The JSBSim truth loop: flies legs, closes the wind triangle, holds its targets,
is bit-reproducible and reports divergence."""

import dataclasses
import hashlib
import subprocess
import sys
from datetime import UTC, datetime

import numpy as np
import pandas as pd
import pytest

from aerotruth.truth.airframes import airframe
from aerotruth.truth.days import plan_in_weather
from aerotruth.truth.flight import FlightDiverged, fly_leg
from aerotruth.truth.routes import plan_leg
from aerotruth.truth.track import TruthTrack, air_velocity_ned
from aerotruth.truth.weather import UniformAtmosphere
from aerotruth.units import FT, KT

DEPARTURE = datetime(2009, 8, 15, 13, 0, tzinfo=UTC)


@pytest.fixture(scope="module")
def msp_dlh():
    plan = plan_in_weather("KMSP", "KDLH", DEPARTURE, weather_seed=1)
    return plan, fly_leg(plan, seed=1)


@pytest.fixture(scope="module")
def anc_dlg():
    plan = plan_in_weather("PANC", "PADL", DEPARTURE, weather_seed=2)
    return plan, fly_leg(plan, seed=2)


@pytest.mark.slow
def test_ground_minus_air_velocity_equals_a_known_constant_wind():
    # independent of the recorded wind columns: V_G - V_A from TAS, alpha, beta and attitude
    plan = plan_leg("KMSP", "KRST", DEPARTURE)
    track = fly_leg(plan, seed=0, atmosphere=UniformAtmosphere(u_mps=20.0, v_mps=-10.0))
    va = air_velocity_ned(track.df)
    drift_n = track.df["vn_mps"].to_numpy() - va[:, 0]
    drift_e = track.df["ve_mps"].to_numpy() - va[:, 1]
    assert np.max(np.abs(drift_e - 20.0)) / KT < 0.5
    assert np.max(np.abs(drift_n + 10.0)) / KT < 0.5


@pytest.mark.slow
@pytest.mark.parametrize("leg", ["msp_dlh", "anc_dlg"])
def test_leg_meets_foundation_acceptance(leg, request):
    plan, track = request.getfixturevalue(leg)
    s = track.summary()
    assert s["cruise_tas_error_max_kt"] <= 5.0
    assert s["cruise_xtrack_max_nm"] < 0.3
    assert s["arrival_centreline_offset_nm"] < 1.0
    assert s["wind_triangle_residual_max_kt"] < 0.5
    assert set(track.df["phase"].unique()) == {"climb", "cruise", "descent", "approach"}
    assert np.all(np.diff(track.df["time_s"]) == pytest.approx(0.1))


@pytest.mark.slow
def test_truth_wind_varies_along_the_flight(msp_dlh):
    _, track = msp_dlh
    speed = np.hypot(track.df["wind_u_mps"], track.df["wind_v_mps"])
    assert speed.max() - speed.min() > 2.0  # shear with height and mesoscale structure, not a constant


@pytest.mark.slow
def test_fly_by_turns_bank_at_half_the_course_change_up_to_23_deg(msp_dlh, anc_dlg):
    # DO-236B's fly-by transition: bank min(course change / 2, 23 deg). The course change
    # at each waypoint from pyproj's geodesic azimuths (not the truth's guidance geometry);
    # the bank the largest |roll| within 90 s of the waypoint's closest approach (the
    # steering wander adds ~0.65 deg rms)
    import pyproj

    geod = pyproj.Geod(ellps="WGS84")
    checked = []
    for plan, track in (msp_dlh, anc_dlg):
        df = track.df
        lat, lon, t = df["lat_deg"].to_numpy(), df["lon_deg"].to_numpy(), df["time_s"].to_numpy()
        roll = np.degrees(np.abs(df["roll_rad"].to_numpy()))
        wp = plan.waypoints
        for k in range(1, len(wp) - 1):
            back = geod.inv(wp[k - 1].lon, wp[k - 1].lat, wp[k].lon, wp[k].lat)[1]
            out = geod.inv(wp[k].lon, wp[k].lat, wp[k + 1].lon, wp[k + 1].lat)[0]
            change = abs((out - back - 180.0 + 180.0) % 360.0 - 180.0)
            if change < 16.0:
                continue
            d = geod.inv(np.full_like(lon, wp[k].lon), np.full_like(lat, wp[k].lat), lon, lat)[2]
            near = np.abs(t - t[int(np.argmin(d))]) < 90.0
            planned = min(change / 2.0, 23.0)
            checked.append(planned)
            assert planned - 1.0 < roll[near].max() < planned + 2.5, (plan.origin, k, change)
    assert min(checked) < 20.0 and max(checked) == 23.0  # both sides of the cap are flown


@pytest.mark.slow
def test_altitude_capture_does_not_overshoot_the_cruise_level(msp_dlh):
    plan, track = msp_dlh
    climb_cruise = track.df["phase"].isin(["climb", "cruise"])
    overshoot_ft = (track.df["pressure_altitude_m"][climb_cruise].max() - plan.cruise_pressure_altitude_m) / FT
    assert overshoot_ft < 100.0


@pytest.mark.slow
def test_flight_ends_near_2000_ft_above_the_arrival_runway(msp_dlh):
    plan, track = msp_dlh
    h_end = track.df["h_ellipsoid_m"].iloc[-1]
    assert abs(h_end - plan.arrival_height_m) < 300 * FT


def _fly_subprocess(tmp_path, name):
    out = tmp_path / name
    subprocess.run(
        [
            sys.executable,
            "-m",
            "aerotruth.app.cli",
            "fly",
            "--from",
            "KMSP",
            "--to",
            "KRST",
            "--date",
            "2009-08-15",
            "--seed",
            "7",
            "--out",
            str(out),
        ],
        check=True,
        capture_output=True,
    )
    return out


@pytest.mark.slow
def test_same_inputs_give_bit_identical_truth_from_two_processes(tmp_path):
    a, b = _fly_subprocess(tmp_path, "a.parquet"), _fly_subprocess(tmp_path, "b.parquet")
    assert hashlib.sha256(a.read_bytes()).hexdigest() == hashlib.sha256(b.read_bytes()).hexdigest()
    ta, tb = TruthTrack.read_parquet(a), TruthTrack.read_parquet(b)
    assert ta.df.equals(tb.df) and ta.meta == tb.meta
    assert ta.meta["seed"] == 7 and ta.meta["aircraft"] == airframe(None).name


class _NaNAfter(UniformAtmosphere):
    def wind(self, lat_deg, lon_deg, alt_m, t_s, ground_elevation_m=0.0):
        u, v, w = super().wind(lat_deg, lon_deg, alt_m, t_s)
        return (u * np.nan, v, w) if t_s - 13 * 3600 > 60.0 else (u, v, w)


@pytest.mark.slow
def test_nan_in_the_state_ends_the_flight_with_reason_and_seed():
    plan = plan_leg("KMSP", "KRST", DEPARTURE)
    with pytest.raises(FlightDiverged) as err:
        fly_leg(plan, seed=11, atmosphere=_NaNAfter())
    assert "NaN" in err.value.reason and err.value.seed == 11
    assert 60.0 < err.value.time_s < 70.0


@pytest.mark.slow
def test_attitude_limit_ends_the_flight():
    plan = plan_leg("KMSP", "KDLH", DEPARTURE)  # the climb-out turns towards Duluth
    stiff = dataclasses.replace(airframe(None), max_bank_deg=10.0)
    with pytest.raises(FlightDiverged, match="attitude limit") as err:
        fly_leg(plan, seed=3, aircraft=stiff, atmosphere=UniformAtmosphere())
    assert err.value.seed == 3


@pytest.mark.slow
def test_turbulence_is_reproducible_per_seed_and_differs_between_seeds():
    plan = plan_leg("KMSP", "KRST", DEPARTURE)
    calm = UniformAtmosphere()
    a1 = fly_leg(plan, seed=3, turbulence=True, atmosphere=calm).df
    a2 = fly_leg(plan, seed=3, turbulence=True, atmosphere=calm).df
    b = fly_leg(plan, seed=4, turbulence=True, atmosphere=calm).df
    assert a1.equals(a2)
    n = min(len(a1), len(b))
    assert not np.allclose(a1["wind_w_mps"][:n], b["wind_w_mps"][:n])
    assert a1["wind_w_mps"].std() > 0.1  # turbulence really is on (calm atmosphere otherwise)
    s = fly_leg(plan, seed=3, turbulence=True, atmosphere=calm).summary()
    assert s["wind_triangle_residual_max_kt"] < 0.5  # turbulence included in the recorded wind


@pytest.mark.slow
def test_flight_starts_at_the_scheduled_airspeed_without_sideslip_in_a_crosswind():
    plan = plan_leg("KMSP", "KRST", DEPARTURE)
    track = fly_leg(plan, seed=0, atmosphere=UniformAtmosphere(u_mps=-15.0, v_mps=12.0))
    first = track.df.iloc[0]
    assert first["cas_mps"] / KT == pytest.approx(airframe(None).schedule.initial_ias_kt, abs=1.0)
    assert abs(np.degrees(first["beta_rad"])) < 0.5
    course = np.degrees(np.arctan2(first["ve_mps"], first["vn_mps"])) % 360.0
    assert (course - plan.initial_course_deg + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=0.5)


@pytest.mark.parametrize(
    "argv, expect",
    [
        (["--from", "KMSP", "--to", "ZZZZ"], "ZZZZ"),
        (["--from", "KMSP", "--to", "KDLH", "--date", "2009-13-01"], "--date"),
        (["--from", "KMSP", "--to", "KDLH", "--aircraft", "a380"], "unknown aircraft 'a380'"),
        (["--from", "KMSP", "--to", "KDLH", "--out", "/no/such/folder/f.parquet"], "--out"),
        # above the type's ceiling: refused before planning (a 600-nm leg would otherwise try FL900)
        (
            ["--from", "KMSP", "--to", "KMEM", "--cruise-fl", "300"],
            "--cruise-fl: FL300 is above the saab340's ceiling, FL250",
        ),
        (
            ["--from", "KMSP", "--to", "KMEM", "--cruise-fl", "450", "--aircraft", "737"],
            "above the 737's ceiling, FL410",
        ),
    ],
)
def test_fly_command_reports_bad_input_in_one_line(argv, expect, capsys, tmp_path):
    from aerotruth.app.cli import main

    args = ["fly", "--date", "2009-08-15", "--out", str(tmp_path / "f.parquet")] + argv
    assert main(args) == 2
    err = capsys.readouterr().err.strip()
    assert expect in err and "\n" not in err and "Traceback" not in err


@pytest.mark.slow
def test_running_out_of_fuel_ends_the_flight_with_that_reason():
    plan = plan_leg("KMSP", "KRST", DEPARTURE)
    dry = dataclasses.replace(airframe("737"), fuel_lbs=(60.0, 60.0, 0.0))
    with pytest.raises(FlightDiverged, match="fuel exhausted") as err:
        fly_leg(plan, seed=5, aircraft=dry, atmosphere=UniformAtmosphere())
    assert err.value.seed == 5 and err.value.time_s < 300.0


def test_fly_refuses_a_folder_as_out_before_flying(tmp_path, capsys):
    from aerotruth.app.cli import main

    assert main(["fly", "--from", "KMSP", "--to", "KRST", "--date", "2009-08-15", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"aerotruth fly: --out: {tmp_path} is a folder, expected a file name")
    assert not list(tmp_path.parent.glob("*.tmp")) and not list(tmp_path.glob("*"))


def test_fly_refuses_another_formats_file_name_before_flying(tmp_path, capsys):
    from aerotruth.app.cli import main

    assert (
        main(["fly", "--from", "KMSP", "--to", "KRST", "--date", "2009-08-15", "--out", str(tmp_path / "f.csv")]) == 2
    )
    assert "expected a .parquet file name, got 'f.csv'" in capsys.readouterr().err
    assert not list(tmp_path.glob("*"))


def test_negative_seed_is_refused_by_the_argument_parser(capsys):
    from aerotruth.app.cli import main

    with pytest.raises(SystemExit) as e:
        main(["fly", "--from", "KMSP", "--to", "KRST", "--date", "2009-08-15", "--seed", "-1", "--out", "x.parquet"])
    assert e.value.code == 2
    assert "argument --seed: expected a seed from 0 to 9223372036854775807 (63 bits), got -1" in capsys.readouterr().err


@pytest.mark.slow
def test_fly_re_flies_a_campaign_leg_bit_for_bit_from_its_recorded_seeds(tmp_path):
    """A mesaba schedule leg (drawn hub, spoke, time and cruise level) re-flown alone by
    `aerotruth fly` with the fly_command of its truth row, in another process."""
    import shlex

    from aerotruth.sim.campaign import run_campaign
    from aerotruth.sim.campaign_loader import parse_campaign
    from aerotruth.sim.executors import ExecutorChoice
    from aerotruth.truth.store import TruthStore

    text = (
        "name: refly\nseed: 17\nfleets:\n  - {name: m, network: mesaba, aircraft: [N9]}\n"
        "periods:\n  - {name: d, dates: [2009-08-15]}\n"
        "studies:\n  truth: {fleets: [m], periods: [d], max_legs_per_day: 1}\n"
    )
    run_campaign(
        parse_campaign(text),
        ExecutorChoice("local", workers=1),
        out=tmp_path / "run",
        progress=False,
        log=lambda m: None,
    )
    (row,) = pd.read_parquet(next((tmp_path / "run" / "tasks").glob("truth--*.parquet"))).to_dict("records")
    args = shlex.split(row["fly_command"])[1:] + ["--out", str(tmp_path / "again.parquet")]
    subprocess.run([sys.executable, "-m", "aerotruth.app.cli", *args], check=True, capture_output=True)
    again = TruthTrack.read_parquet(tmp_path / "again.parquet")
    stored = next(p for p in TruthStore().files() if p.stem == row["truth_key"])
    original = TruthTrack.read_parquet(stored)
    assert again.meta == original.meta and again.meta["flight_id"] == row["flight_id"]
    assert list(again.df.columns) == list(original.df.columns)
    for c in original.df.columns:
        assert again.df[c].equals(original.df[c]), c
    assert (
        again.df.drop(columns=["phase"]).to_numpy().tobytes()
        == original.df.drop(columns=["phase"]).to_numpy().tobytes()
    )


def _channel_rates_hz(path, dt: float) -> dict[str, float]:
    import xml.etree.ElementTree as ET

    root = ET.parse(path).getroot()
    return {c.get("name"): 1.0 / (dt * int(c.get("execrate", "1"))) for c in root.iter("channel")}


def test_the_autopilot_runs_at_its_rates_in_hz_at_the_route_and_the_ils_step():
    """The autopilot XML counts its channel rates in steps (execrate), written for 50 Hz:
    at the ILS flights' 100 Hz every channel runs at the rate its header states; at the
    route legs' 20 Hz the outer loops (10 Hz) and LNAV (5 Hz) too, and the inner loops,
    25 Hz at 50 Hz, at every step (20 Hz); the truth wind at every step."""
    from aerotruth.truth.airframes import AUTOPILOT_STEP_S, SYSTEMS_DIR, channel_execrate, systems_root
    from aerotruth.truth.fdm import DT, ILS_DT

    assert (DT, ILS_DT) == (0.05, 0.01)
    stated = {"lnav": 5.0, "roll outer": 10.0, "vertical": 10.0, "speed": 10.0}
    stated |= {"roll inner": 25.0, "yaw": 25.0, "pitch inner": 25.0}
    for dt in (AUTOPILOT_STEP_S, ILS_DT, DT):
        rates = _channel_rates_hz(systems_root(dt) / "aerotruth_autopilot.xml", dt)
        assert rates.pop("truth wind") == pytest.approx(1.0 / dt)
        assert rates == pytest.approx({k: min(v, 1.0 / dt) for k, v in stated.items()})
    assert systems_root(AUTOPILOT_STEP_S) == SYSTEMS_DIR
    assert [channel_execrate(e, 0.05) for e in (1, 2, 5, 10)] == [1, 1, 2, 4]
    assert [channel_execrate(e, 0.01) for e in (1, 2, 5, 10)] == [2, 4, 10, 20]


def test_new_fdm_refuses_the_autopilot_at_a_step_it_cannot_keep_its_rates_at():
    from aerotruth.truth.airframes import new_fdm

    # the 25-Hz inner loops would be 4.8 steps of 1/120 s
    with pytest.raises(ValueError, match="dt: a 0.04-s autopilot channel is not a whole number of 0.00833333-s steps"):
        new_fdm(airframe("saab340"), 1.0 / 120.0)
    new_fdm(airframe("saab340"), 1.0 / 120.0, autopilot=False)  # the bare aircraft at any step


@pytest.mark.slow
def test_a_calm_leg_at_the_20_hz_step_is_the_leg_at_100_hz(msp_dlh, monkeypatch):
    """The route step is converged: the calm KMSP-KDLH leg flown again at 100 Hz (the
    autopilot's rates in Hz, its inner loops at 25 Hz instead of the 20 Hz step's every step;
    the same guidance, wind and recording in time) stays within a few metres of the 20 Hz
    leg in position, a decimetre in height and hundredths of a degree in attitude (measured
    against 50 Hz on three legs: largest position difference 0.8-1.7 m, height 0.07-0.08 m
    rms, roll 0.007-0.015 deg rms)."""
    import aerotruth.truth.flight as flight_mod

    plan, leg50 = msp_dlh
    monkeypatch.setattr(flight_mod, "DT", 0.01)
    monkeypatch.setattr(flight_mod, "RECORD_EVERY", 10)
    monkeypatch.setattr(flight_mod, "GUIDE_EVERY", 100)
    leg100 = fly_leg(plan, seed=1)
    a, b = leg50.df, leg100.df
    assert len(a) == len(b)
    north_m = (a["lat_deg"] - b["lat_deg"]).abs().max() * 111_000.0
    east_m = ((a["lon_deg"] - b["lon_deg"]).abs() * np.cos(np.radians(a["lat_deg"]))).max() * 111_000.0
    assert max(north_m, east_m) < 3.0
    assert np.sqrt(np.mean((a["h_ellipsoid_m"] - b["h_ellipsoid_m"]) ** 2)) < 0.5
    for c in ("roll_rad", "pitch_rad"):
        assert np.degrees(np.sqrt(np.mean((a[c] - b[c]) ** 2))) < 0.05


def test_the_truth_aircraft_flies_without_ground_contacts_to_the_bit():
    """airborne_only drops every <contact> of the ground reactions and nothing else; an
    approach (the truth's lowest flying: over the threshold, JSBSim's ground 50 m below the
    runway) flown with the SAAB 340's seven contacts is the same to the bit."""
    import re

    import aerotruth.truth.airframes as airframes_mod
    from aerotruth.truth.airframes import PACKAGE_AIRCRAFT_DIR, airborne_only
    from aerotruth.truth.approach import approach_spec, fly_approach

    xml = (PACKAGE_AIRCRAFT_DIR / "saab340" / "saab340.xml").read_text()
    stripped = airborne_only(xml)
    assert xml.count("<contact") == 7 and stripped.count("<contact") == 0
    assert re.sub(r"<contact\b.*?</contact>", "", xml, flags=re.S) == stripped
    spec = approach_spec("KDLH", "27", DEPARTURE, turbulence=False)
    without = fly_approach(spec, seed=3).df
    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(airframes_mod, "airborne_only", lambda text: text)
        with_contacts = fly_approach(spec, seed=3).df
    pd.testing.assert_frame_equal(without, with_contacts, check_exact=True)


@pytest.mark.slow
def test_a_fly_by_turn_in_wind_is_an_arc_over_the_ground_planned_at_its_largest_ground_speed():
    # PANS-OPS's turn over the ground: r = GS_max^2 / (g tan(planned bank)), flown with
    # tan(bank) = GS^2 / (g r). KMSP-KRST's first turn (44 -> 156 deg, planned at the 23-deg
    # cap) crosses the wind's direction (20 m/s east, 10 m/s south: to 116.6 deg), where
    # the ground speed is largest and the bank the planned one
    plan = plan_leg("KMSP", "KRST", DEPARTURE)
    df = fly_leg(plan, seed=0, atmosphere=UniformAtmosphere(u_mps=20.0, v_mps=-10.0)).df
    t = df["time_s"].to_numpy()
    vn, ve = df["vn_mps"].to_numpy(), df["ve_mps"].to_numpy()
    gs = np.hypot(vn, ve)
    roll = np.degrees(np.abs(df["roll_rad"].to_numpy()))
    first = t < 300.0
    steady = first & (roll > 15.0) & (np.abs(np.gradient(roll, t)) < 0.5)
    assert steady.sum() > 200  # 20 s and more of the arc
    k = np.tan(np.radians(roll[steady])) / gs[steady] ** 2  # 1 / (g r)
    assert k.max() / k.min() < 1.06  # one radius (the airspeed grows ~3 % in the climbing turn)
    # the planned bank where the ground speed is largest (downwind, 116.6 deg)
    fastest = int(np.argmax(gs[steady]))
    track = np.degrees(np.arctan2(ve[steady][fastest], vn[steady][fastest])) % 360.0
    assert track == pytest.approx(116.6, abs=8.0)
    assert roll[steady][fastest] == pytest.approx(23.0, abs=0.7)
    assert roll[steady].max() - roll[steady].min() > 3.0  # the bank follows the ground speed
