"""The wind_reports study: truth legs from the store through the heading system, air data,
TAMDAR reports and weather-model analyses, inside a campaign.

Expectations are independent of the code under test: the truth wind itself (an ideal
sensor and a reference model with no error must reproduce it), and the hand formula of a
hard-iron deviation in level flight evaluated on IGRF from ppigrf directly."""

import datetime as dt
import json

import numpy as np
import pandas as pd
import ppigrf
import pytest

from aerotruth.sensors.magnetics import FluxValveFleetSpec
from aerotruth.sim.campaign import run_campaign
from aerotruth.sim.campaign_file import ConfigError
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.executors import ExecutorChoice
from aerotruth.sim.wind_observations import aircraft_heading

LEGS = '[{from: KMSP, to: KDLH, departure_utc: "13:00"}, {from: KDLH, to: KMSP, departure_utc: "14:30"}]'
IDEAL_REFERENCE = (
    "{name: exact, grid_spacing_m: 1, effective_resolution_m: 1, analysis_interval_s: 10, "
    "sigma_levels: [[1000, 0.0]], horizontal_correlation_m: 1.0e5, vertical_correlation_m: 1000, "
    "temporal_correlation_s: 3600}"
)


def campaign(heading: str, air: str, references: str = f"[{IDEAL_REFERENCE}]", extra: str = "") -> str:
    return f"""\
name: wr
seed: 11
fleets:
  - {{name: f, aircraft: [N1]}}
periods:
  - {{name: d, dates: [2009-08-15]}}
studies:
  wind_reports:
    flights: {{fleets: [f], periods: [d], legs: {LEGS}}}
    sensors:
      fleets:
        f: {{heading: {heading}, air_data: {air}}}
      references: {references}
{extra}"""


PERFECT_VALVE = "{poor_fraction: 0, healthy_hard_iron_sigma_nT: 0, soft_iron_sigma: 0, mounting_sigma_deg: 0}"
HARD_IRON_VALVE = "{poor_fraction: 1, poor_hard_iron_sigma_nT: 500, soft_iron_sigma: 0, mounting_sigma_deg: 0}"
NO_NOISE = "{tas_noise_kt: 0, pressure_altitude_noise_ft: 0, gps_position_sigma_m: 0, gps_velocity_sigma_mps: 0}"


def _run(text, out):
    s = run_campaign(
        parse_campaign(text), ExecutorChoice("local", workers=2), out=out, progress=False, log=lambda m: None
    )
    obs = pd.read_parquet(out / "data" / "wind_reports.observations.parquet")
    return s, obs, json.loads((out / "metrics.json").read_text())["metrics"]


def _steady_level(obs, perfect_valve: bool = False):
    """Level reports, wings level at the trigger. With a perfect valve, also a window mean
    heading within 0.5 deg of the trigger's truth heading: en-route course changes fall
    inside some 10-s windows (a valve that drops every report fails the count)."""
    sel = (obs["phase"] == "level") & (obs["roll_deg"].abs() < 2.0)
    if perfect_valve:
        sel &= ((obs["heading_deg"] - obs["truth_heading_deg"] + 180.0) % 360.0 - 180.0).abs() < 0.5
    return obs[sel]


def _straight_for(obs, rows, seconds: float, turn_deg: float = 1.0) -> np.ndarray:
    """Whether each of `rows` comes `seconds` after the flight's last turn: the first level
    report, or a truth-heading change of more than `turn_deg` between consecutive reports."""
    ok = []
    for _, r in rows.iterrows():
        f = obs[(obs["flight"] == r["flight"]) & (obs["time"] <= r["time"])].sort_values("time")
        lv = f[f["phase"] == "level"]
        dpsi = ((f["truth_heading_deg"].diff() + 180.0) % 360.0 - 180.0).abs()
        turns = f["time"][dpsi > turn_deg]
        start = max(lv["time"].min(), turns.max() if len(turns) else -np.inf)
        ok.append(r["time"] - start >= seconds)
    return np.array(ok, dtype=bool)


@pytest.mark.slow
def test_ideal_sensors_report_the_truth_wind_and_a_sensor_change_reflies_nothing(tmp_path):
    s1, obs, m = _run(campaign(PERFECT_VALVE, NO_NOISE), tmp_path / "a")
    assert s1.legs_flown == 2 and m["wind_reports.legs_diverged"] == 0
    level = _steady_level(obs, perfect_valve=True)
    assert len(level) >= 6  # 7 of the two short legs' 10 level reports (a dropping valve fails it)
    # report vs truth at the trigger sample: 1-kt/1-deg quantization and a 10-s mean of a slowly varying wind
    du = level["wind_speed_kt"] * np.sin(np.radians(level["wind_dir_deg"])) - level["truth_wind_speed_kt"] * np.sin(
        np.radians(level["truth_wind_dir_deg"])
    )
    dv = level["wind_speed_kt"] * np.cos(np.radians(level["wind_dir_deg"])) - level["truth_wind_speed_kt"] * np.cos(
        np.radians(level["truth_wind_dir_deg"])
    )
    assert np.sqrt(np.mean(du**2 + dv**2)) < 1.5
    # the error-free reference is the truth wind at the report's pressure level
    dref = np.hypot(
        level["ref_wind_speed_kt"] - level["truth_wind_speed_kt"],
        ((level["ref_wind_dir_deg"] - level["truth_wind_dir_deg"] + 180) % 360 - 180)
        * level["truth_wind_speed_kt"]
        * np.pi
        / 180,
    )
    assert np.median(dref) < 1.0

    # only the sensors change: the same two legs come from the store, nothing is flown
    s2, obs2, _ = _run(campaign(HARD_IRON_VALVE, NO_NOISE), tmp_path / "b")
    assert s2.legs_flown == 0
    # the same reports of the same flights, paired: the pendulum's tilt (the autopilot's
    # steering wander banks the valve by ~0.65 deg rms, tan(I) ~ 3.5 at Minnesota) is the
    # same in both runs, so the hard-iron valve's error less the perfect valve's is the
    # deviation alone (to first order: the deviation's slope, <= 0.03 deg/deg, times the
    # tilt's ~0.5 deg)
    key = ["flight", "sample_index"]
    perfect = _steady_level(obs).set_index(key)
    level = _steady_level(obs2)
    level = level[level.set_index(key).index.isin(perfect.index)]
    # after five slaving time constants of straight level flight (the slaved gyro has moved
    # to the new heading's deviation): a course change (truth heading changing by more than
    # 3 deg between consecutive reports: more than the wander's ~1 deg) restarts the clock
    level = level[_straight_for(obs2, level, 300.0, turn_deg=3.0)]
    assert len(level) >= 3
    _, valve = aircraft_heading(
        11, "f", "N1", FluxValveFleetSpec(poor_fraction=1, soft_iron_sigma=0, mounting_sigma_deg=0)
    )
    px, py, _ = valve.hard_iron_nT
    # level flight, magnetic heading psi: body field (H cos psi, -H sin psi); the valve reads
    # atan2(H sin psi - py, H cos psi + px)
    be, bn, _ = ppigrf.igrf(
        level["lon"].to_numpy(),
        level["lat"].to_numpy(),
        level["pressure_altitude_ft"].to_numpy() * 0.3048 / 1000,
        dt.datetime(2009, 8, 15),
    )
    h = np.hypot(be, bn).ravel()
    dec = np.degrees(np.arctan2(be, bn)).ravel()
    psi = np.radians(level["truth_heading_deg"].to_numpy() - dec)
    expected = np.degrees(np.arctan2(h * np.sin(psi) - py, h * np.cos(psi) + px) - psi)
    expected = (expected + 180) % 360 - 180
    tilt = perfect.loc[level.set_index(key).index]
    measured = (level["heading_deg"].to_numpy() - tilt["heading_deg"].to_numpy() + 180) % 360 - 180
    assert np.max(np.abs(expected)) > 0.5  # the hard iron is large enough to matter
    # what remains: the slaved gyro's approach to the deviation where the heading drifts
    # (the autopilot holding its track through the wind's change along it) and the 10-s
    # mean of a heading that wanders by a fraction of a degree
    residual = measured - expected
    assert np.max(np.abs(residual)) < 0.15 and abs(np.mean(residual)) < 0.1


@pytest.mark.parametrize(
    "edit, field",
    [
        ("heading: {soft_iron_sigma: -0.1}", "soft_iron_sigma"),
        ("air_data: {tas_noise_kt: -1}", "tas_noise_kt"),
    ],
)
def test_bad_fleet_sensor_spec_names_the_field(edit, field):
    text = campaign(PERFECT_VALVE, NO_NOISE).replace(
        f"f: {{heading: {PERFECT_VALVE}, air_data: {NO_NOISE}}}", f"f: {{{edit}}}"
    )
    with pytest.raises(ConfigError) as e:
        parse_campaign(text)
    msg = str(e.value)
    assert "\n" not in msg and "studies.wind_reports.sensors.fleets.f." in msg and field in msg


def test_unknown_reference_model_and_zero_quantization_and_unknown_fleet_are_one_line_errors():
    with pytest.raises(ConfigError, match=r"sensors\.references.*not a preset"):
        parse_campaign(campaign(PERFECT_VALVE, NO_NOISE, references="[{name: gfs}]"))
    zero_step = campaign(PERFECT_VALVE, NO_NOISE).replace(
        "      references:", "      reports: {lat_lon_step_deg: 0}\n      references:"
    )
    with pytest.raises(ConfigError, match=r"sensors\.reports\.lat_lon_step_deg.*quantization step"):
        parse_campaign(zero_step)
    with pytest.raises(ConfigError, match=r"sensors\.fleets\.g.*fleet of the campaign"):
        parse_campaign(campaign(PERFECT_VALVE, NO_NOISE).replace("        f: {heading", "        g: {heading"))


def test_poor_count_gives_the_fleet_exactly_that_many_poor_valves_and_is_checked_against_the_fleet():
    from aerotruth.sim.wind_observations import WindSensors

    fleet = tuple(f"N{i}" for i in range(7))
    spec = FluxValveFleetSpec(poor_count=4)
    for seed in (1, 2, 3):
        classes = [aircraft_heading(seed, "f", a, spec, fleet)[0] for a in fleet]
        assert classes.count("poor") == 4
    # the draw differs between campaign seeds (35 possible sets; three equal sets would be chance 1/35^2)
    sets = {frozenset(a for a in fleet if aircraft_heading(s, "f", a, spec, fleet)[0] == "poor") for s in (1, 2, 3)}
    assert len(sets) > 1
    with pytest.raises(ValueError, match=r"poor_count.*aircraft of fleet 'f'"):
        aircraft_heading(1, "f", "N1", spec)
    text = campaign("{poor_count: 2}", NO_NOISE)
    with pytest.raises(
        ConfigError, match=r"sensors\.fleets\.f\.heading\.poor_count.*at most the fleet's 1 aircraft, got 2"
    ):
        parse_campaign(text)
    # a task of a fleet with poor_count carries the fleet's aircraft; other tasks keep their identity
    from aerotruth.sim.studies.wind_reports import sensor_params

    c = parse_campaign(campaign("{poor_count: 1}", NO_NOISE))
    sensors = c.section("wind_reports").sensors
    assert sensor_params(c, sensors, "f")["fleet_aircraft"] == ("N1",)
    assert "fleet_aircraft" not in sensor_params(c, WindSensors(), "f")
