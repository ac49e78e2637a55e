"""Wind metrics (wind paper section 6) against hand-worked report tables."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from pyproj import Geod

from aerotruth.analysis.wind.heading_errors import GATE_NAMES, ground_track
from aerotruth.analysis.wind.metrics import (
    METRIC_GATES,
    air_track_heading,
    longitudinal_transverse,
    rms_vector_difference,
    wind_error_summary,
    wind_errors,
)


def _obs(aircraft, times, lats, lons, wind, ref, alt_ft=5000.0, phase="ascent", ref_source="RR") -> pd.DataFrame:
    return pd.DataFrame(
        {
            "aircraft": aircraft,
            "time": times,
            "lat": lats,
            "lon": lons,
            "pressure_altitude_ft": alt_ft,
            "wind_speed_kt": [w[0] for w in wind],
            "wind_dir_deg": [w[1] for w in wind],
            "ref_wind_speed_kt": [r[0] for r in ref],
            "ref_wind_dir_deg": [r[1] for r in ref],
            "phase": phase,
            "ref_source": ref_source,
            "fleet": "mesaba",
        }
    )


# Four reports flying due north along 93 W, one a minute. Report wind / reference ("from"):
#   r0 20 kt from 270 / 10 kt from 270: du = +10          |e| = 10 (end report: no track)
#   r1 30 kt from 360 / 20 kt from 360: dv = -10          |e| = 10, longitudinal -10, transverse 0
#   r2 10 kt from 090 / calm:           du = -10          |e| = 10, longitudinal 0, transverse -10
#   r3  5 kt from 180 /  5 kt from 180: 0                  (end report: no track)
# total = sqrt(300 / 4) = 8.660; components over r1, r2: sqrt(100 / 2) = 7.071 each, RSS 10.0
NORTH = dict(
    times=[0.0, 60.0, 120.0, 180.0],
    lats=[45.0, 45.1, 45.2, 45.3],
    lons=[-93.0] * 4,
    wind=[(20, 270), (30, 360), (10, 90), (5, 180)],
    ref=[(10, 270), (20, 360), (0, 0), (5, 180)],
)
# Five reports: north as above, then a 90 deg turn to the east at r3 (fails the collinearity
# gate). r1 and r2: 10 kt from 270 against calm (du = +10: transverse +10, to the right of
# north); r0, r3, r4 agree with the reference. total = sqrt(200 / 5) = 6.325 < transverse 10.
TURN = dict(
    times=[0.0, 60.0, 120.0, 180.0, 240.0],
    lats=[45.0, 45.1, 45.2, 45.3, 45.3],
    lons=[-93.0, -93.0, -93.0, -93.0, -92.86],
    wind=[(5, 180), (10, 270), (10, 270), (5, 180), (5, 180)],
    ref=[(5, 180), (0, 0), (0, 0), (5, 180), (5, 180)],
)


def test_hand_worked_four_reports_give_total_and_components_whose_rss_exceeds_the_total():
    errors = wind_errors(_obs("N1", **NORTH), axis="ground_track")
    np.testing.assert_allclose(errors["error_kt"], [10, 10, 10, 0], atol=1e-9)
    np.testing.assert_allclose(errors["longitudinal_kt"], [np.nan, -10, 0, np.nan], atol=1e-6)
    np.testing.assert_allclose(errors["transverse_kt"], [np.nan, 0, -10, np.nan], atol=1e-6)
    s = wind_error_summary(errors).iloc[0]
    assert (s["n"], s["n_components"]) == (4, 2)
    assert s["rms_kt"] == pytest.approx(np.sqrt(75.0))
    assert s["longitudinal_rms_kt"] == pytest.approx(np.sqrt(50.0), abs=1e-6)
    assert s["transverse_rms_kt"] == pytest.approx(np.sqrt(50.0), abs=1e-6)
    assert s["rss_components_kt"] == pytest.approx(10.0, abs=1e-6) and s["rss_components_kt"] > s["rms_kt"]
    # the total on the same reports as the components adds up exactly
    same = wind_error_summary(errors, total_over="track_subset").iloc[0]
    assert same["rms_kt"] == pytest.approx(same["rss_components_kt"], abs=1e-6) == pytest.approx(10.0, abs=1e-6)


def test_track_subset_mechanism_reproduces_a_transverse_rms_above_the_total_as_in_table_iv():
    errors = wind_errors(_obs("N2", **TURN), axis="ground_track")
    assert errors["has_axis"].tolist() == [False, True, True, False, False]
    s = wind_error_summary(errors).iloc[0]
    assert s["rms_kt"] == pytest.approx(np.sqrt(40.0))
    assert s["transverse_rms_kt"] == pytest.approx(10.0, abs=1e-6) and s["transverse_rms_kt"] > s["rms_kt"]
    assert s["longitudinal_rms_kt"] == pytest.approx(0.0, abs=1e-6)


def _track(case):
    n = len(case["times"])
    return ground_track(
        np.asarray(case["times"]), np.radians(case["lats"]), np.radians(case["lons"]), np.zeros(n, int), METRIC_GATES
    )


def test_three_report_track_matches_the_geodesic_between_the_end_reports():
    gt = _track(NORTH)
    _, _, dist = Geod(ellps="WGS84").inv(-93.0, 45.0, -93.0, 45.2)
    assert np.hypot(gt.vg_e[1], gt.vg_n[1]) == pytest.approx(dist / 120.0, rel=1e-6)
    assert np.degrees(np.arctan2(gt.vg_e[1], gt.vg_n[1])) == pytest.approx(0.0, abs=1e-9)
    assert [GATE_NAMES[g] for g in gt.gate] == ["no_neighbours", "used", "used", "no_neighbours"]
    # the 90-deg turn at r3 fails collinearity (r1, r2 pass)
    assert [GATE_NAMES[g] for g in _track(TURN).gate] == [
        "no_neighbours",
        "used",
        "used",
        "collinearity",
        "no_neighbours",
    ]


def test_air_track_axis_is_the_heading_of_ground_velocity_minus_reported_wind():
    # V_G = 100 kt north, wind towards east 20 kt: V_A = (-20, 100) -> 360 - atan(20/100) = 348.69 deg
    assert np.degrees(air_track_heading(0.0, 100.0, 20.0, 0.0)) == pytest.approx(348.690, abs=1e-3)
    # in the table: r2's wind 10 kt from 090 (towards west), V_G ~ 360 kt north (0.1 deg a minute):
    # axis atan(10/360) = 1.59 deg, transverse -10 cos(1.59 deg) = -9.996
    errors = wind_errors(_obs("N1", **NORTH), axis="air_track")
    assert errors["axis_deg"].iloc[2] == pytest.approx(np.degrees(np.arctan2(10.0, 360.0)), abs=0.01)
    assert errors["transverse_kt"].iloc[2] == pytest.approx(-9.9961, abs=2e-4)
    assert errors["longitudinal_kt"].iloc[1] == pytest.approx(-10.0, abs=1e-9)  # r1's wind is along track


def test_longitudinal_and_transverse_are_the_projection_on_the_axis_and_its_right_normal():
    # axis east (90 deg): error (3 east, 4 north) is 3 along, 4 to the left -> transverse -4
    lon, tra = longitudinal_transverse(3.0, 4.0, np.pi / 2)
    assert (float(lon), float(tra)) == pytest.approx((3.0, -4.0))
    assert rms_vector_difference([3.0, 0.0], [4.0, 0.0]) == pytest.approx(np.sqrt(12.5))


def test_combined_references_pool_every_report_model_pair():
    iso = pd.to_datetime(np.array(NORTH["times"]), unit="s", utc=True).strftime("%Y-%m-%dT%H:%M:%SZ")
    rr = _obs("N1", **{**NORTH, "times": list(iso)}, ref_source="RR")
    # the second model agrees exactly with every report
    other = _obs("N1", **{**NORTH, "times": list(iso), "ref": NORTH["wind"]}, ref_source="RTFDDA")
    errors = wind_errors(pd.concat([rr, other], ignore_index=True), axis="ground_track")
    by_ref = wind_error_summary(errors, by=["ref_source"]).set_index("ref_source")
    assert by_ref.loc["RR", "rms_kt"] == pytest.approx(np.sqrt(75.0))
    assert by_ref.loc["RTFDDA", "rms_kt"] == pytest.approx(0.0)
    pooled = wind_error_summary(errors).iloc[0]
    # 8 pairs: sqrt(300 / 8); components over 4 pairs (r1, r2 per model): sqrt(100 / 4) = 5
    assert (pooled["n"], pooled["n_components"]) == (8, 4)
    assert pooled["rms_kt"] == pytest.approx(np.sqrt(300.0 / 8.0))
    assert pooled["longitudinal_rms_kt"] == pytest.approx(5.0, abs=1e-6)
    assert pooled["transverse_rms_kt"] == pytest.approx(5.0, abs=1e-6)


def test_summary_by_aircraft_altitude_band_phase_and_fleet():
    obs = pd.concat(
        [_obs("N1", **NORTH, alt_ft=5000.0, phase="ascent"), _obs("N2", **TURN, alt_ft=15000.0, phase="level")],
        ignore_index=True,
    )
    errors = wind_errors(obs, axis="ground_track")
    expected = {"N1": (np.sqrt(75.0), np.sqrt(50.0), np.sqrt(50.0)), "N2": (np.sqrt(40.0), 0.0, 10.0)}
    for by, keys in (
        ("aircraft", ("N1", "N2")),
        ("phase", ("ascent", "level")),
        ("altitude_band", ("0-10000", "10000-20000")),
    ):
        table = wind_error_summary(errors, by=[by], altitude_bands_ft=[0, 10000, 20000]).set_index(by)
        for key, ac in zip(keys, ("N1", "N2"), strict=False):
            got = table.loc[key, ["rms_kt", "longitudinal_rms_kt", "transverse_rms_kt"]].to_numpy(dtype=float)
            np.testing.assert_allclose(got, expected[ac], atol=1e-6)
    fleet = wind_error_summary(errors, by=["fleet"]).iloc[0]
    # 9 reports: sqrt(500 / 9); 4 with tracks: longitudinal sqrt(100 / 4), transverse sqrt(300 / 4)
    np.testing.assert_allclose(
        fleet[["rms_kt", "longitudinal_rms_kt", "transverse_rms_kt"]].to_numpy(dtype=float),
        [np.sqrt(500.0 / 9.0), 5.0, np.sqrt(75.0)],
        atol=1e-6,
    )
    with pytest.raises(ValueError, match="altitude_bands_ft"):
        wind_error_summary(errors, by=["altitude_band"])
    with pytest.raises(ValueError, match="by"):
        wind_error_summary(errors, by=["tail"])
    with pytest.raises(ValueError, match="missing columns"):
        wind_errors(obs.drop(columns=["ref_wind_dir_deg"]))
