"""Multi-aircraft traffic in (aerotruth.measured.traffic) and the consensus reference
(aerotruth.analysis.wind.consensus), on traffic from an independent generator
(tests/traffic_generator.py: dead-reckoned flights in a known wind field, IGRF declination
from ppigrf directly, Mode-S register resolutions, known heading offsets)."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
import traffic_generator as gen

from aerotruth.analysis.wind.consensus import consensus_wind, sample_winds
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


def test_flights_split_at_pauses_and_landings_and_ground_samples_left_out():
    """One aircraft: 3 airborne samples, 2 on the ground (a touch-and-go's landing roll), 2
    airborne again 20 min later (under the 30-min pause: the landing splits them), then 2
    more after a 40-min pause; a second aircraft flying throughout."""
    t = [0, 10, 20, 30, 40, 1240, 1250, 3650, 3660]
    ground = ["False", "False", "False", "True", "True", "False", "False", "False", "False"]
    one = pd.DataFrame({"icao24": "aaaaaa", "timestamp": t, "onground": ground})
    other = pd.DataFrame({"icao24": "bbbbbb", "timestamp": [0, 1240, 3650], "onground": "False"})
    df = pd.concat([one, other], ignore_index=True).assign(
        latitude=45.0, longitude=-93.0, altitude=20000.0, groundspeed=300.0, track=90.0, heading=90.0, TAS=280.0
    )
    df["timestamp"] = df["timestamp"] + 1_717_243_200
    tr = canonical_traffic(df, "t.csv")
    assert tr.attrs["rows_on_ground"] == 2 and len(tr) == 10
    assert tr[tr["aircraft"] == "aaaaaa"]["flight"].tolist() == [1, 1, 1, 2, 2, 3, 3]
    assert tr[tr["aircraft"] == "bbbbbb"]["flight"].tolist() == [1, 1, 2]  # 1240 -> 3650 s: over 30 min


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


FOUR_LEVELS_FT = (20000.0, 24000.0, 28000.0, 30000.0)


def _consensus(df: pd.DataFrame) -> pd.DataFrame:
    """consensus_wind's per-aircraft table of a generated state table."""
    tr = canonical_traffic(df, "gen")
    return consensus_wind(tr, sample_winds(tr))[3]


def _errors(table: pd.DataFrame, offsets: dict) -> tuple[np.ndarray, np.ndarray]:
    """Per aircraft with a reference: estimate - known offset, and the same with each group's
    mean taken out of both (offsets relative to the fleet)."""
    seen, group = table["seen"].to_numpy(), table["group"].to_numpy()
    est, truth = table["offset_deg"].to_numpy(), pd.Series(offsets)[table.index].to_numpy()
    relative = np.full(len(est), np.nan)
    for g in np.unique(group[seen]):
        s = seen & (group == g)
        relative[s] = (est[s] - est[s].mean()) - (truth[s] - truth[s].mean())
    return (est - truth)[seen], relative[seen]


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_consensus_recovers_every_offset_within_0_2_deg_at_one_level(seed):
    """36 aircraft at one flight level in a 200-km box over an hour (the generator: straight
    20-min flights, heading register 90/512 deg, TAS to 2 kt), offsets uniform in +-3 deg.
    Aircraft of all headings meet, so every offset is seen, the fleet's mean included: each
    aircraft's, and each relative to the fleet, within 0.2 deg. Measured, seeds 1-5: max
    |error| 0.059, 0.079, 0.054, 0.061, 0.044 deg, rms 0.018-0.042 (seeds 6-10: up to 0.085)."""
    df, off = gen.make_traffic(36, seed=seed, levels_ft=(30000.0,))
    a = _consensus(df)
    assert a["seen"].all() and a["group"].nunique() == 1 and (a["neighbours"] >= 5).all()
    err, relative = _errors(a, off)
    assert np.abs(err).max() < 0.2 and np.abs(relative).max() < 0.2
    assert np.sqrt(np.mean(err**2)) < 0.08


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3, 4, 5])
def test_consensus_recovers_every_offset_within_0_2_deg_at_four_levels(seed):
    """48 aircraft at four flight levels (FL200, 240, 280, 300: 12 a level on average, 6 to 16
    in the seeds' groups): levels never meet, so each is its own group with its own system.
    Measured, seeds 1-5: max |error| 0.089, 0.088, 0.064, 0.105, 0.148 deg; an aircraft with
    fewer than two others near at any time has no reference (seen False)."""
    df, off = gen.make_traffic(48, seed=seed, levels_ft=FOUR_LEVELS_FT)
    a = _consensus(df)
    assert a["group"][a["seen"]].nunique() == 4 and a["seen"].sum() >= 46
    err, relative = _errors(a, off)
    assert np.abs(err).max() < 0.2 and np.abs(relative).max() < 0.2


@pytest.mark.slow
def test_a_fleet_wide_offset_and_a_once_round_sinusoid_of_heading_are_seen():
    """Every aircraft 1.5 deg off, plus 1 deg sin(psi) - 0.5 deg cos(psi) of its true heading
    psi: what a consensus seeing offsets only relative to the fleet, or a wind error common to
    the neighbourhood, would hide. A common offset turns the air vectors of different headings
    into different winds, and the neighbours' mean carries half a once-round mode: both are
    found, each aircraft within 0.2 deg (measured 0.044)."""
    n, seed = 24, 6
    zero, _ = gen.make_traffic(n, seed=seed, levels_ft=(30000.0,), offsets_deg=np.zeros(n))
    gu, gv = gen.wind_kt(zero["latitude"], zero["longitude"], zero["altitude"])
    trk = np.radians(zero["track"])
    air = pd.DataFrame(
        {"e": zero["groundspeed"] * np.sin(trk) - gu, "n": zero["groundspeed"] * np.cos(trk) - gv}
    ).groupby(zero["icao24"].to_numpy())
    psi = np.arctan2(air["e"].mean(), air["n"].mean()).to_numpy()  # straight flights: one heading each
    df, off = gen.make_traffic(
        n, seed=seed, levels_ft=(30000.0,), offsets_deg=1.5 + np.sin(psi) - 0.5 * np.cos(psi)
    )  # the same flights: the generator's draws do not depend on the offsets given
    err, _ = _errors(_consensus(df), off)
    assert np.abs(err).max() < 0.2


def _line_traffic(headings_deg, tas_kt, offsets_deg, north_km) -> pd.DataFrame:
    """Canonical traffic of aircraft flying straight at FL300 through points `north_km` north
    of 45N 93W at the middle of 16 minutes of 1-s samples, in a uniform wind of 30 kt east and
    5 kt north; the magnetic heading the true one less the IGRF declination (ppigrf) plus the
    offset, unrounded, and the TAS exact."""
    import datetime as dt

    import ppigrf

    r_km, t = 6371.0088, np.arange(-480.0, 480.0)
    frames = []
    for i, (psi, tas, off, dy) in enumerate(zip(headings_deg, tas_kt, offsets_deg, north_km, strict=True)):
        ge, gn = tas * np.sin(np.radians(psi)) + 30.0, tas * np.cos(np.radians(psi)) + 5.0
        x, y = t * ge * 1.852 / 3600.0, dy + t * gn * 1.852 / 3600.0
        lat, lon = 45.0 + np.degrees(y / r_km), -93.0 + np.degrees(x / (r_km * np.cos(np.radians(45.0))))
        be, bn, _ = ppigrf.igrf(lon, lat, 9.144, dt.datetime(2024, 6, 1, 12))
        dec = np.degrees(np.arctan2(np.ravel(be), np.ravel(bn)))
        frames.append(
            pd.DataFrame(
                {
                    "aircraft": f"l{i}",
                    "time_s": 1717243200.0 + t,
                    "lat": lat,
                    "lon": lon,
                    "pressure_altitude_ft": 30000.0,
                    "gs_kt": np.hypot(ge, gn),
                    "track_deg": np.degrees(np.arctan2(ge, gn)) % 360.0,
                    "heading_mag_deg": (psi - dec + off) % 360.0,
                    "tas_kt": tas,
                }
            )
        )
    return pd.concat(frames, ignore_index=True)


def test_aircraft_on_one_line_leave_one_mode_unseen_until_another_heading_meets_them():
    """Four aircraft on one east-west line, two each way (exact data): a wind error across the
    line turns all their air vectors alike, so their offsets are seen up to one mode,
    e_i = c cos(psi_i - 90 deg) / TAS_i, and the consensus returns them with next to nothing of
    it (the first step's minimum norm; the offsets' own mode, 0.5 deg, is left out). A fifth
    aircraft flying north across them meets them at another heading: then every offset is
    seen."""
    psi, tas, off, dy = [90.0, 90.0, 270.0, 270.0], [420.0, 450.0, 430.0, 440.0], [1.0, -0.5, 2.0, 0.3], [0, 8, 4, 12]
    tr = _line_traffic(psi, tas, off, dy)
    a = consensus_wind(tr, sample_winds(tr))[3]
    assert a["seen"].all() and a["group"].nunique() == 1
    est = a["offset_deg"].to_numpy()
    z = np.cos(np.radians(np.array(psi) - 90.0)) / np.array(tas)
    c = (est - np.array(off)) @ z / (z @ z)
    assert np.abs(est - off - c * z).max() < 0.01  # seen up to the mode...
    assert abs(est @ z) < 0.05 * np.linalg.norm(est) * np.linalg.norm(z)  # ...and returned nearly without it
    assert np.abs(c * z).min() > 0.4  # these offsets' own part of the mode, left out
    tr = _line_traffic([*psi, 0.0], [*tas, 410.0], [*off, -1.2], [*dy, 0])
    a = consensus_wind(tr, sample_winds(tr))[3]
    assert np.abs(a["offset_deg"].to_numpy() - [*off, -1.2]).max() < 0.01


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
