"""Multi-aircraft traffic in (aerotruth.measured.traffic) and the consensus reference
(aerotruth.analysis.wind.consensus), on traffic from an independent generator
(tests/traffic_generator.py: dead-reckoned flights in a known wind field, IGRF declination
from ppigrf directly, Mode-S register resolutions, known heading offsets)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import traffic_generator as gen

from aerotruth.analysis.wind.consensus import observation_table, remove_fleet_mode, sample_winds
from aerotruth.errors import DataError
from aerotruth.measured.traffic import canonical_traffic


def test_traffic_names_are_read_case_insensitively_with_their_units():
    df = pd.DataFrame(
        {
            "ICAO24": ["AB12CD"],
            "timestamp": ["2024-06-01T12:00:00Z"],
            "Latitude": [45.0],
            "longitude": [-93.0],
            "altitude": [30000.0],
            "groundspeed": [450.0],
            "track": [90.0],
            "heading": [88.0],
            "TAS": [430.0],
            "vertical_rate": [-500.0],
        }
    )
    tr = canonical_traffic(df, "t.csv")
    assert tr.loc[0, "aircraft"] == "ab12cd" and tr.loc[0, "time_s"] == 1717243200.0
    assert tr.loc[0, "heading_mag_deg"] == 88.0 and tr.loc[0, "vertical_rate_fpm"] == -500.0


def test_opensky_state_vectors_are_refused_naming_what_they_lack():
    df = pd.DataFrame(
        {
            "time": [1717243200],
            "icao24": ["ab12cd"],
            "lat": [45.0],
            "lon": [-93.0],
            "baroaltitude": [9144.0],
            "velocity": [231.5],
            "heading": [90.0],
            "vertrate": [0.0],
        }
    )
    with pytest.raises(DataError, match=r"OpenSky state vectors without the aircraft's magnetic heading"):
        canonical_traffic(df, "sv.csv")


def test_the_wind_triangle_returns_the_generators_wind():
    """Zero offsets: V_G - V_A (IGRF-true heading, horizontal TAS) is the generator's wind to
    its register resolutions (TAS 2 kt, heading 90/512 deg: ~1 kt rms at 450 kt)."""
    df, _ = gen.make_traffic(6, seed=3, offsets_deg=np.zeros(6))
    tr = canonical_traffic(df, "gen")
    w = sample_winds(tr)
    gu, gv = gen.wind_kt(tr["lat"].to_numpy(), tr["lon"].to_numpy(), tr["pressure_altitude_ft"].to_numpy())
    err = np.hypot(w["wind_u_kt"] - gu, w["wind_v_kt"] - gv)
    assert np.sqrt(np.mean(err**2)) < 1.0


@pytest.mark.slow
def test_consensus_recovers_offsets_up_to_what_a_consensus_cannot_see():
    """36 aircraft at one flight level in a 200-km box over an hour, offsets uniform in +-3 deg.
    A consensus cannot see a constant plus a once-round sinusoid of heading across the aircraft
    that share neighbourhoods (what a wind error common to them does): the truth with that
    mode removed, per group, against the consensus's offsets. Measured on seeds 1-5: rms 0.036,
    0.098, 0.048, 0.178, 0.038 deg (max 0.42 on seed 4); four flight levels (groups of ~9
    aircraft): rms 0.15-0.24 deg. Not yet the traffic issue's 0.2-deg maximum."""
    rms = []
    for seed in (1, 2, 3, 4, 5):
        df, off = gen.make_traffic(36, seed=seed, levels_ft=(30000.0,))
        a = observation_table(canonical_traffic(df, "gen")).attrs["consensus_aircraft"]
        seen, group = a["seen"].to_numpy(), a["group"].to_numpy()
        truth = pd.Series(off)[a.index].to_numpy()
        for g in np.unique(group[seen]):
            truth = remove_fleet_mode(truth, a["mean_heading_deg"].to_numpy(), seen & (group == g))
        e = (a["offset_deg"].to_numpy() - truth)[seen]
        rms.append(float(np.sqrt(np.mean(e**2))))
    assert np.mean(rms) < 0.12 and max(rms) < 0.2


def test_the_unseen_fleet_mode_is_a_constant_and_a_once_round_sinusoid():
    """Hand-worked: offsets made of 0.5 + 1.0 sin(psi) - 0.3 cos(psi) vanish; one aircraft's
    extra 1 deg is kept, less its projection on the mode."""
    psi = np.array([0.0, 60.0, 135.0, 200.0, 290.0])
    mode = 0.5 + np.sin(np.radians(psi)) - 0.3 * np.cos(np.radians(psi))
    seen = np.ones(5, bool)
    assert np.allclose(remove_fleet_mode(mode, psi, seen), 0.0, atol=1e-12)
    bump = np.array([1.0, 0, 0, 0, 0])
    x = np.column_stack([np.ones(5), np.sin(np.radians(psi)), np.cos(np.radians(psi))])
    expected = bump - x @ np.linalg.lstsq(x, bump, rcond=None)[0]
    assert np.allclose(remove_fleet_mode(mode + bump, psi, seen), expected, atol=1e-12)


@pytest.mark.slow
def test_the_reports_command_writes_an_observation_table_the_wind_method_reads(tmp_path, capsys):
    """`aerotruth reports` as typed: a state table in traffic's names to the observation-table
    contract (validated by the wind method's own reader), the reference from the consensus."""
    from aerotruth.app.cli import main
    from aerotruth.contracts import OBSERVATION_REQUIRED
    from aerotruth.measured.observations import read_observation_table

    df, _ = gen.make_traffic(8, seed=5, minutes=30, levels_ft=(30000.0,))
    df.to_csv(tmp_path / "hour.csv", index=False)
    assert (
        main(["reports", str(tmp_path / "hour.csv"), "--reference", "consensus", "--out", str(tmp_path / "o.parquet")])
        == 0
    )
    said = capsys.readouterr().out
    assert "reports of 8 aircraft" in said and "consensus group" in said
    obs = read_observation_table(tmp_path / "o.parquet")
    assert set(OBSERVATION_REQUIRED) - {"time"} <= set(obs.columns) and (obs["ref_source"] == "consensus").all()
    gu, gv = gen.wind_kt(obs["lat"].to_numpy(), obs["lon"].to_numpy(), obs["pressure_altitude_ft"].to_numpy())
    # the reference is the other aircraft's wind, their offsets taken out: the truth within a few kt
    ru = -obs["ref_wind_speed_kt"] * np.sin(np.radians(obs["ref_wind_dir_deg"]))
    rv = -obs["ref_wind_speed_kt"] * np.cos(np.radians(obs["ref_wind_dir_deg"]))
    assert np.sqrt(np.mean((ru - gu) ** 2 + (rv - gv) ** 2)) < 5.0


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--out", "o.txt"], "--out: .*expected a .parquet, .csv or .csv.gz file name"),
        (["--reference", "model", "--out", "o.parquet"], "--reference: expected one of consensus, got 'model'"),
    ],
)
def test_the_reports_command_refuses_in_one_line(tmp_path, capsys, args, message):
    import re

    from aerotruth.app.cli import main

    df, _ = gen.make_traffic(2, seed=1, minutes=25, levels_ft=(30000.0,))
    df.to_csv(tmp_path / "hour.csv", index=False)
    argv = ["reports", str(tmp_path / "hour.csv")] + [str(tmp_path / a) if a.startswith("o.") else a for a in args]
    assert main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(message, err)
