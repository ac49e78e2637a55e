"""Flight-tracker exports (aerotruth.measured.trackers) and the recognition of traffic files
(aerotruth.measured.traffic.read_traffic): small hand-written files in the documented formats
(readsb's README-json.md trace format; a Flightradar24 playback track with EMS fields) with
hand-worked expected values, the refusals in one line, and every file of ../shared/real-data
read or refused naming what it lacks."""

from __future__ import annotations

import datetime as dt
import gzip
import json

import numpy as np
import pandas as pd
import ppigrf
import pytest

from aerotruth.errors import DataError
from aerotruth.measured.kinds import real_data_dir
from aerotruth.measured.traffic import read_traffic

T0 = 1663259853.016  # readsb's example trace timestamp (2022-09-15)


def trace_doc(points):
    return {"icao": "3c66b0", "r": "D-AIUP", "t": "A320", "timestamp": T0, "trace": points}


def write(tmp_path, name, doc, gz=False):
    p = tmp_path / name
    data = json.dumps(doc).encode()
    p.write_bytes(gzip.compress(data) if gz else data)
    return p


def test_trace_full_points_with_details_are_read(tmp_path):
    """Five points: (1) details with tas and mag_heading: read as they are; (2) no details;
    (3) flags 8, a geometric altitude; (4) on the ground; (5) details with true_heading only:
    made magnetic with the IGRF declination there (3.64 deg from ppigrf; readsb's own WMM pair
    at that point, 305.89 true for 302.17 magnetic, says 3.72)."""
    doc = trace_doc(
        [
            [7016.59, 49.2633, 10.614239, 25125, 446.5, 309.0, 0, -2176,
             {"type": "adsb_icao", "ias": 335, "tas": 484, "mach": 0.796, "roll": -10.72, "mag_heading": 304.28,
              "true_heading": 308.02}, "adsb_icao", 25875, -2208, 335, -10.7],
            [7024.85, 49.273589, 10.593278, 24825, 446.0, 306.6, 0, -2176, None, "adsb_icao", 25550, -2144, 337, -1.6],
            [7035.67, 49.286865, 10.56589, 25800, 446.8, 306.5, 8, -2176, {"tas": 483, "mag_heading": 302.2}],
            [7040.0, 49.29, 10.56, "ground", 12.0, 120.0, 0, 0, {"tas": 0, "mag_heading": 118.0}],
            [7057.8, 49.314042, 10.509941, 23625, 445.2, 306.7, 0, -2176, {"tas": 482, "true_heading": 305.89}],
        ]
    )  # fmt: skip
    tr = read_traffic(write(tmp_path, "trace_full_3c66b0.json", doc, gz=True))
    assert tr.attrs["rows_read"] == 5 and tr.attrs["rows_incomplete"] == 3
    assert tr.attrs["tracker"] == {"points": 5, "points with details": 4}
    a, b = tr.iloc[0], tr.iloc[1]
    assert a["aircraft"] == "3c66b0" and a["time_s"] == pytest.approx(T0 + 7016.59)
    got = a[["lat", "lon", "pressure_altitude_ft", "gs_kt", "track_deg", "heading_mag_deg", "tas_kt", "roll_deg"]]
    assert got.tolist() == [49.2633, 10.614239, 25125.0, 446.5, 309.0, 304.28, 484.0, -10.72]
    assert a["vertical_rate_fpm"] == -2176.0
    when = dt.datetime(1970, 1, 1) + dt.timedelta(seconds=T0 + 7057.8)
    be, bn, _ = ppigrf.igrf(10.509941, 49.314042, 23625 * 0.3048 / 1000, when)
    dec = float(np.degrees(np.arctan2(np.ravel(be), np.ravel(bn)))[0])
    assert dec == pytest.approx(3.64, abs=0.01)
    assert b["heading_mag_deg"] == pytest.approx(305.89 - dec, abs=0.02)
    assert b["heading_mag_deg"] == pytest.approx(302.17, abs=0.1)


@pytest.mark.parametrize(
    ("details", "lacks"),
    [
        ([None, None], "no TAS or magnetic heading in any point (readsb's details object, in 0 of 2 points)"),
        ([{"tas": 480}, None], "no magnetic heading in any point (readsb's details object, in 1 of 2 points)"),
        ([{"mag_heading": 10.0}, {"ias": 250}], "no TAS in any point (readsb's details object, in 2 of 2 points)"),
        ([{"mag_heading": 10.0}, {"tas": 480}], "no TAS with a heading in any point"),
    ],
)
def test_trace_full_without_tas_and_heading_is_refused_in_one_line(tmp_path, details, lacks):
    points = [[float(i), 49.0, 10.0, 30000, 450.0, 90.0, 0, 0, d] for i, d in enumerate(details)]
    with pytest.raises(DataError) as e:
        read_traffic(write(tmp_path, "t.json", trace_doc(points)))
    msg = str(e.value)
    assert "\n" not in msg and msg.startswith(f"{tmp_path / 't.json'}: trace_full: ") and lacks in msg
    assert msg.endswith("the wind triangle needs both")


def test_trace_full_bad_values_name_point_and_field(tmp_path):
    with pytest.raises(DataError, match=r"trace point 2, field 'lat': expected a number, got 'n/a'"):
        points = [[0, 49.0, 10.0, 30000, 450, 90, 0, 0, None], [1, "n/a", 10.0, 30000, 450, 90, 0, 0, None]]
        read_traffic(write(tmp_path, "t.json", trace_doc(points)))
    with pytest.raises(DataError, match=r"trace point 1: expected \[seconds, lat, lon, altitude"):
        read_traffic(write(tmp_path, "t.json", trace_doc([{"lat": 49.0}])))
    with pytest.raises(DataError, match=r"trace point 1, field 'tas': expected a number, got '480'"):
        read_traffic(write(tmp_path, "t.json", trace_doc([[0, 49.0, 10.0, 30000, 450, 90, 0, 0, {"tas": "480"}]])))


def fr24_point(t, ems, lat=48.5, heading=180):
    return {
        "latitude": lat, "longitude": 2.3, "altitude": {"feet": 35000, "meters": 10668},
        "speed": {"kmh": 833.4, "kts": 450, "mph": 517.8}, "verticalSpeed": {"fpm": -64, "ms": 0},
        "heading": heading, "squawk": "1000", "timestamp": t, "ems": ems,
    }  # fmt: skip


def fr24_doc(track):
    flight = {
        "identification": {"id": "35a1b2c3", "callsign": "AFR1234"},
        "aircraft": {"model": {"code": "A320"}, "identification": {"modes": "3944EF", "registration": "F-HEPA"}},
        "track": track,
    }
    return {"result": {"request": {"format": "json"}, "response": {"timestamp": 1, "data": {"flight": flight}}}}


EMS = {
    "ts": 1720249999, "ias": 270, "tas": 460, "mach": 780, "mcp": 35008, "fms": 35000, "autopilot": None,
    "oat": -50, "trueTrack": 180.5, "rollAngle": -0.5, "qnh": 1013, "windDir": 270, "windSpd": 20,
    "precision": None, "altGps": 35600, "emergencyStatus": None, "tcasAcasDtatus": None, "heading": 178,
}  # fmt: skip


def test_fr24_track_with_ems_is_read(tmp_path):
    """Point 1: ems 1 s before it, read; point 2: ems null; point 3: ems 30 s old (more than
    5 s): not taken. The ems `heading` is the magnetic heading; the point's `heading` the
    track; speed and altitude from their {"kts"}/{"feet"} objects; Mach 780 is 0.780."""
    doc = fr24_doc(
        [
            fr24_point(1720250000, EMS),
            fr24_point(1720250010, None, lat=48.45),
            fr24_point(1720250020, {**EMS, "ts": 1720249990}, lat=48.4),
        ]
    )
    tr = read_traffic(write(tmp_path, "AFR1234.json", doc))
    assert tr.attrs["rows_read"] == 3 and tr.attrs["rows_incomplete"] == 2
    assert tr.attrs["tracker"] == {"points": 3, "points with ems": 1, "ems more than 5 s off": 1}
    r = tr.iloc[0]
    assert (r["aircraft"], r["time_s"], r["lat"], r["lon"]) == ("3944ef", 1720250000.0, 48.5, 2.3)
    got = r[
        ["pressure_altitude_ft", "gs_kt", "track_deg", "vertical_rate_fpm", "heading_mag_deg", "tas_kt", "roll_deg"]
    ]
    assert got.tolist() == [35000.0, 450.0, 180.0, -64.0, 178.0, 460.0, -0.5]


def test_fr24_bare_point_list_and_mag_hdg_spelling(tmp_path):
    ems = {"ts": 1720250000000, "tas": 452, "mag_hdg": 91.0, "mach": 0.77}
    tr = read_traffic(write(tmp_path, "flight.json", [fr24_point(1720250000000, ems)]))
    assert tr["heading_mag_deg"].tolist() == [91.0] and tr["time_s"].tolist() == [1720250000.0]
    assert tr["aircraft"].tolist() == ["flight"]  # no Mode-S address in the file: its name


def test_fr24_ems_without_heading_is_refused_naming_what_it_has(tmp_path):
    ems = {"ias": 270, "tas": 460, "mach": 780, "agps": 35600, "wind_dir": 270, "wind_speed": 20}
    with pytest.raises(DataError) as e:
        read_traffic(write(tmp_path, "f.json", fr24_doc([fr24_point(1720250000, ems)])))
    assert str(e.value) == (
        f"{tmp_path / 'f.json'}: Flightradar24 track: no magnetic heading in any point's ems (ems in 1 of 1 points, "
        "fields agps, ias, mach, tas, wind_dir, wind_speed): the wind triangle needs both"
    )


def test_files_that_are_no_traffic_name_the_formats_accepted(tmp_path):
    (tmp_path / "a.csv").write_text("a,b\n1,2\n")
    (tmp_path / "b.json").write_text(json.dumps({"foo": [1, 2]}))
    (tmp_path / "c.txt").write_bytes(b"\x00\x01binary")
    for name in ("a.csv", "b.json", "c.txt"):
        with pytest.raises(DataError) as e:
            read_traffic(tmp_path / name)
        msg = str(e.value)
        assert "\n" not in msg and "not traffic aerotruth reads; expected a decoded Mode-S/ADS-B state table" in msg
        assert "raw Mode-S frames" in msg and "trace_full" in msg and "Flightradar24" in msg
    with pytest.raises(DataError, match="no such file"):
        read_traffic(tmp_path / "missing.csv")


def test_a_state_table_in_json_records_with_ms_times(tmp_path):
    """The `traffic` names as JSON records, times in ms (as the real-data files have them)."""
    rec = {"timestamp": 1593072000000, "icao24": "39b415", "latitude": 44.8, "longitude": -0.7, "altitude": 30000,
           "groundspeed": 400.0, "track": 90.0, "heading": 88.0, "TAS": 390.0}  # fmt: skip
    tr = read_traffic(write(tmp_path, "z.json", [rec], gz=True))
    assert tr["time_s"].tolist() == [1593072000.0] and tr["heading_mag_deg"].tolist() == [88.0]


REAL = real_data_dir()


@pytest.mark.skipif(not REAL.is_dir(), reason=f"real data not found: {REAL}")
@pytest.mark.slow
def test_every_real_data_file_is_read_or_refused_naming_what_it_lacks():
    """zero_gravity (traffic's names, BDS 5,0/6,0 fields) is read; the A320 recorder extract
    lacks position and TAS (it has CAS; track and drift stand for a heading: not named); the
    calibration ADS-B tracks lack the magnetic heading and the TAS; the raw frames are read
    with pyModeS, refused naming the extra without it (tests/test_frames.py decodes them)."""
    files = sorted(p for p in REAL.rglob("*.gz"))
    assert files
    for p in files:
        try:
            tr = read_traffic(p)
        except DataError as e:
            msg = str(e)
            assert "\n" not in msg and msg.startswith(str(p)), msg
            if p.name == "fuelflow_a320.json.gz":
                assert "without position (latitude, longitude) and the true airspeed" in msg and "it has CAS" in msg
                assert "heading" not in msg.split(";")[0]
            elif p.parent.name == "calibration":
                assert "without the aircraft's magnetic heading" in msg and "and the true airspeed" in msg
                assert "position" not in msg.split(";")[0]
            elif p.name == "full_flight_short.jsonl.gz":
                assert msg.endswith("install aerotruth[modes] (pyModeS, GPL-3) to decode raw frames")
            else:
                raise AssertionError(f"{p.name} refused: {msg}") from None
            continue
        assert p.name in ("zero_gravity.json.gz", "full_flight_short.jsonl.gz"), p
        assert len(tr) > 1000 and tr["aircraft"].nunique() == 1
        if p.name == "zero_gravity.json.gz":
            assert len(tr) == tr.attrs["rows_read"] - tr.attrs["rows_incomplete"]
            assert pd.Timestamp(tr["time_s"].iloc[0], unit="s").year == 2020
