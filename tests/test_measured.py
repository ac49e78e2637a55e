"""Measured data is recognised from its content (not its name) and loaded as a table;
anything else is one clear error naming the file."""

from __future__ import annotations

import gzip
import json
import re

import pandas as pd
import pytest

from aerotruth.errors import DataError
from aerotruth.measured.kinds import load_measured, real_data_dir

REAL = real_data_dir()
needs_real = pytest.mark.skipif(
    not REAL.is_dir(), reason=f"real flight data not found at {REAL} (set AEROTRUTH_REAL_DATA)"
)


def test_observation_table_and_approach_log_are_told_apart_by_their_columns(tmp_path):
    obs = pd.DataFrame(
        {
            "aircraft": ["N1"],
            "time": [1.25e9],
            "lat": [45.0],
            "lon": [-93.0],
            "pressure_altitude_ft": [15000.0],
            "wind_speed_kt": [30.0],
            "wind_dir_deg": [270.0],
            "ref_wind_speed_kt": [28.0],
            "ref_wind_dir_deg": [265.0],
        }
    )
    obs.to_csv(tmp_path / "reports.dat", index=False)  # the name says nothing
    assert load_measured(tmp_path / "reports.dat").kind == "observation_table"
    log = pd.DataFrame(
        {
            "approach": [1, 1],
            "time_s": [0.0, 1.0],
            "waas_x_m": [0.0, 1.0],
            "waas_y_m": [0.0, 0.0],
            "waas_z_m": [9.0, 9.0],
        }
    )
    log.to_parquet(tmp_path / "log.bin")
    got = load_measured(tmp_path / "log.bin")
    assert got.kind == "approach_log" and list(got.df["waas_x_m"]) == [0.0, 1.0]


def test_gzipped_json_lines_of_mode_s_messages_are_raw_messages_in_seconds(tmp_path):
    lines = [
        {"timestamp": 1720248189.5, "df": "17", "frame": "8f39", "bds": "05"},
        {"timestamp": 1720248189.0, "df": "20", "frame": "a000"},
    ]
    (tmp_path / "m").write_bytes(gzip.compress("\n".join(json.dumps(x) for x in lines).encode()))
    got = load_measured(tmp_path / "m")
    assert got.kind == "modes_raw" and list(got.df["time_s"]) == [1720248189.0, 1720248189.5]  # sorted by time


def test_millisecond_timestamps_become_seconds_and_trajectories_are_classified(tmp_path):
    rec = {"timestamp": 1593069386000, "latitude": 44.8, "longitude": -0.7, "groundspeed": 155.0, "track": 224.0}
    (tmp_path / "a.json").write_text(json.dumps([rec]))
    assert load_measured(tmp_path / "a.json").kind == "adsb_track"
    (tmp_path / "b.json").write_text(json.dumps([{**rec, "heading": 224.5, "TAS": 165.8}]))
    got = load_measured(tmp_path / "b.json")
    assert got.kind == "modes_track" and got.df["time_s"].iloc[0] == 1593069386.0


@pytest.mark.parametrize(
    "content, expected",
    [
        (b"", "not measured data aerotruth knows"),
        (b"a,b\n1,2\n", "a table with columns a, b; expected an observation table"),
        (b'[{"x": 1}]', "JSON records with keys x; expected"),
        # JSON lines cut short (a capture interrupted), or with a damaged line: named, not dropped
        (b'{"timestamp": 1, "df": "17", "frame": "8f"}\n{"timestamp": 2, "df"', "line 2 is not valid JSON"),
        (
            b'{"timestamp": 1, "df": "17", "frame": "8f"}\n###\n{"timestamp": 2, "df": "17", "frame": "8f"}',
            "line 2 is not valid JSON",
        ),
    ],
)
def test_anything_else_is_one_line_naming_the_file(tmp_path, content, expected):
    f = tmp_path / "mystery"
    f.write_bytes(content)
    with pytest.raises(DataError) as e:
        load_measured(f)
    assert str(e.value).startswith(f"{f}: ") and expected in str(e.value) and "\n" not in str(e.value)


def test_missing_file_and_folder_are_named(tmp_path):
    with pytest.raises(DataError, match="no such file"):
        load_measured(tmp_path / "nope.csv")
    with pytest.raises(DataError, match="is a folder"):
        load_measured(tmp_path)


@needs_real
@pytest.mark.parametrize(
    "name, kind, rows",
    [
        ("zero_gravity.json.gz", "modes_track", 10367),
        ("full_flight_short.jsonl.gz", "modes_raw", 57793),
        ("fuelflow_a320.json.gz", "qar", 11808),
        ("calibration/brussels_ils.json.gz", "adsb_track", 1905),
    ],
)
def test_the_real_flights_are_recognised(name, kind, rows):
    got = load_measured(REAL / name)
    assert (got.kind, len(got.df)) == (kind, rows)
    assert got.df["time_s"].is_monotonic_increasing and 1.2e9 < got.df["time_s"].iloc[0] < 1.8e9


def test_a_mode_s_track_without_headings_is_one_line_in_diagnose(tmp_path):
    from aerotruth.measured.modes import track_from_measured

    rec = [
        {
            "timestamp": 1593069386000 + 1000 * i,
            "latitude": 44.8,
            "longitude": -0.7,
            "altitude": 20000.0,
            "groundspeed": 300.0,
            "track": 90.0,
            "heading": None,
            "TAS": 280.0,
        }
        for i in range(300)
    ]
    (tmp_path / "t.json").write_text(json.dumps(rec))
    with pytest.raises(DataError, match=r"t\.json: only 0 samples carry heading"):
        track_from_measured(load_measured(tmp_path / "t.json"))


def _track(n: int = 300, **over) -> list[dict]:
    return [
        {
            "timestamp": 1593069386000 + 1000 * i,
            "icao24": "38cf9b",
            "latitude": 44.8,
            "longitude": -0.7,
            "altitude": 20000.0,
            "groundspeed": 300.0,
            "track": 90.0,
            "heading": 91.0,
            "TAS": 280.0,
            **over,
        }
        for i in range(n)
    ]


@pytest.mark.parametrize(
    "records, expected",
    [
        # text in a numeric field: the record and field named, not a traceback or a NaN
        (_track()[:10] + [{**_track()[0], "TAS": "fast"}], r"record 11, field 'TAS': 'fast' is not a number"),
        (_track()[:3] + [{**_track()[0], "timestamp": None}], r"record 4: no timestamp"),
        # two aircraft in one file: their samples would interleave into one nonsense flight
        (
            _track() + [{**r, "icao24": "4CA123"} for r in _track(5)],
            r"data of 2 aircraft \(icao24 38cf9b, 4ca123\); diagnose takes one",
        ),
    ],
)
def test_bad_mode_s_records_are_one_line_naming_record_and_field(tmp_path, records, expected):
    (tmp_path / "t.json").write_text(json.dumps(records))
    with pytest.raises(DataError, match=expected) as e:
        load_measured(tmp_path / "t.json")
    assert "\n" not in str(e.value)


def test_a_raw_log_without_a_register_diagnose_needs_names_it(tmp_path):
    from aerotruth.measured.modes import track_from_measured

    t0 = 1720248189.0
    msgs = [
        {
            "timestamp": t0 + i,
            "df": "17",
            "frame": "8f",
            "icao24": "393322",
            "bds": "05",
            "latitude": 49.0,
            "longitude": 2.5,
            "altitude": 30000,
        }
        for i in range(50)
    ]
    msgs += [
        {
            "timestamp": t0 + i + 0.5,
            "df": "17",
            "frame": "8f",
            "icao24": "393322",
            "bds": "09",
            "groundspeed": 400,
            "track": 90,
            "vertical_rate": 0,
        }
        for i in range(50)
    ]
    msgs += [
        {"timestamp": t0 + i + 0.2, "df": "20", "frame": "a0", "icao24": "393322", "bds": "50", "TAS": 420, "roll": 0}
        for i in range(50)
    ]
    (tmp_path / "m.jsonl").write_text("\n".join(json.dumps(m) for m in msgs))
    with pytest.raises(DataError, match=r"m\.jsonl: no usable Comm-B BDS 6,0 replies \(magnetic heading\): none"):
        track_from_measured(load_measured(tmp_path / "m.jsonl"))
    msgs += [
        {"timestamp": t0 + i + 0.7, "df": "21", "frame": "a8", "icao24": "393322", "bds": "60", "heading": None}
        for i in range(50)
    ]
    (tmp_path / "m.jsonl").write_text("\n".join(json.dumps(m) for m in msgs))
    with pytest.raises(
        DataError, match=r"BDS 6,0 replies \(magnetic heading\): 50 of them, none with 'heading' decoded"
    ):
        track_from_measured(load_measured(tmp_path / "m.jsonl"))


def test_the_real_data_folder_is_the_one_beside_the_checkout(monkeypatch):
    """Without $AEROTRUTH_REAL_DATA the folder is ../shared/real-data beside the repository
    (where CI lays shared/): a wrong default would silently skip every real-data test."""
    from pathlib import Path

    monkeypatch.delenv("AEROTRUTH_REAL_DATA", raising=False)
    repo = Path(__file__).resolve().parents[1]
    assert real_data_dir() == repo.parent / "shared" / "real-data"
    monkeypatch.setenv("AEROTRUTH_REAL_DATA", "/somewhere/else")
    assert real_data_dir() == Path("/somewhere/else")


@needs_real
@pytest.mark.parametrize(
    "name, lacks",
    [
        ("fuelflow_a320.json.gz", "it lacks position (latitude, longitude), true airspeed (TAS; it has CAS"),
        ("calibration/brussels_ils.json.gz", "it lacks true airspeed (TAS), heading (or track and drift)"),
    ],
)
def test_a_real_file_diagnose_cannot_test_is_refused_naming_what_it_lacks(name, lacks):
    """The A320 recorder extract has CAS and heading (track - drift): what it lacks for the
    Mode-S wind test is position and TAS; an ADS-B calibration track lacks TAS and heading."""
    from aerotruth.measured.modes import track_from_measured

    with pytest.raises(DataError, match=re.escape(lacks)):
        track_from_measured(load_measured(REAL / name))
