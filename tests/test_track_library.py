"""TruthTrack storage and the cached truth library."""

from datetime import datetime, timezone

import numpy as np
import pandas as pd
import pytest

from aerotruth.truth.flight import FlightDiverged
from aerotruth.truth.library import TruthLibrary, parse_departure, truth_key
from aerotruth.truth.routes import plan_leg
from aerotruth.truth.track import COLUMNS, TruthTrack, air_velocity_ned


def _synthetic(n=5) -> TruthTrack:
    df = pd.DataFrame({c: np.linspace(0.0, 1.0, n) for c in COLUMNS if c not in ("leg_index", "phase")})
    df["leg_index"] = np.zeros(n, dtype=np.int32)
    df["phase"] = pd.Categorical(["cruise"] * n, categories=["climb", "cruise", "descent", "approach"])
    return TruthTrack(df, {"route": "X-Y", "seed": 4})


def test_parquet_round_trip_keeps_samples_and_metadata(tmp_path):
    t = _synthetic()
    t.to_parquet(tmp_path / "t.parquet")
    back = TruthTrack.read_parquet(tmp_path / "t.parquet")
    assert back.df.equals(t.df) and back.meta == t.meta
    assert not list(tmp_path.glob("*.tmp"))


def test_a_parquet_file_without_truth_metadata_is_refused(tmp_path):
    _synthetic().df.to_parquet(tmp_path / "plain.parquet")
    with pytest.raises(ValueError, match="not a TruthTrack"):
        TruthTrack.read_parquet(tmp_path / "plain.parquet")


def test_missing_columns_are_named():
    with pytest.raises(ValueError, match="tas_mps"):
        TruthTrack(_synthetic().df.drop(columns=["tas_mps"]))


def test_air_velocity_of_level_flight_heading_east_with_zero_alpha_beta():
    df = _synthetic(1).df
    df.loc[:, ["roll_rad", "pitch_rad", "alpha_rad", "beta_rad"]] = 0.0
    df["heading_rad"] = np.pi / 2
    df["tas_mps"] = 100.0
    assert air_velocity_ned(df)[0] == pytest.approx([0.0, 100.0, 0.0], abs=1e-12)
    # climbing at 10 deg pitch with alpha 10 deg: the air path is level
    df["pitch_rad"], df["alpha_rad"] = np.radians(10.0), np.radians(10.0)
    assert air_velocity_ned(df)[0] == pytest.approx([0.0, 100.0, 0.0], abs=1e-9)


def test_truth_key_changes_with_every_input():
    dep = datetime(2009, 8, 15, 13, 0, tzinfo=timezone.utc)
    plan = plan_leg("KMSP", "KRST", dep)
    base = truth_key(plan, seed=1)
    assert truth_key(plan, seed=1) == base
    assert truth_key(plan, seed=2) != base
    assert truth_key(plan, seed=1, turbulence=True) != base
    assert truth_key(plan_leg("KMSP", "KRST", dep.replace(hour=14)), seed=1) != base


def test_library_flies_once_then_reads_the_cache(tmp_path, monkeypatch):
    dep = datetime(2009, 8, 15, 13, 0, tzinfo=timezone.utc)
    plan = plan_leg("KMSP", "KRST", dep)
    lib = TruthLibrary(tmp_path)
    first = lib.get(plan, seed=5)
    files = list(tmp_path.glob("*.parquet"))
    assert len(files) == 1

    def no_flying(*a, **k):
        raise AssertionError("flew again instead of reading the cache")

    monkeypatch.setattr("aerotruth.truth.library.fly_leg", no_flying)
    again = lib.get(plan, seed=5)
    assert again.df.equals(first.df)


def test_library_remembers_a_divergence(tmp_path, monkeypatch):
    plan = plan_leg("KMSP", "KRST", datetime(2009, 8, 15, 13, 0, tzinfo=timezone.utc))

    def diverging(*a, **k):
        raise FlightDiverged("attitude limit: roll 61.0 deg, pitch 2.0 deg", 9, 120.0)

    monkeypatch.setattr("aerotruth.truth.library.fly_leg", diverging)
    lib = TruthLibrary(tmp_path)
    for _ in range(2):
        with pytest.raises(FlightDiverged, match="roll 61.0") as err:
            lib.get(plan, seed=9)
        assert err.value.seed == 9


@pytest.mark.parametrize("text", ["2009-02-30", "15/08/2009", "yesterday"])
def test_bad_departure_dates_name_the_option(text):
    with pytest.raises(ValueError, match="--date"):
        parse_departure(text)


def test_departure_date_defaults_to_13_utc():
    assert parse_departure("2009-08-15") == datetime(2009, 8, 15, 13, 0, tzinfo=timezone.utc)


def test_flight_diverged_survives_pickling_between_processes():
    import pickle

    e = pickle.loads(pickle.dumps(FlightDiverged("NaN in the JSBSim state", {"entropy": "1", "spawn_key": [2]}, 61.5)))
    assert (e.reason, e.seed, e.time_s) == ("NaN in the JSBSim state", {"entropy": "1", "spawn_key": [2]}, 61.5)
    assert "t=61.5 s" in str(e)
