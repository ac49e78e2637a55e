"""TruthTrack storage and the shared truth store."""

import dataclasses
from datetime import UTC, date, datetime

import numpy as np
import pandas as pd
import pytest

from aerotruth.truth.days import AircraftDay, FixedLeg, PlannedLeg, parse_departure
from aerotruth.truth.flight import FlightDiverged
from aerotruth.truth.routes import plan_leg
from aerotruth.truth.store import TruthStore, truth_key
from aerotruth.truth.track import COLUMNS, FLOAT64_COLUMNS, TruthTrack, air_velocity_ned


def _synthetic(n=5) -> TruthTrack:
    df = pd.DataFrame({c: np.linspace(0.0, 1.0, n) for c in COLUMNS if c not in ("leg_index", "phase")})
    df["leg_index"] = np.zeros(n, dtype=np.int32)
    df["phase"] = pd.Categorical(["cruise"] * n, categories=["climb", "cruise", "descent", "approach"])
    return TruthTrack(df, {"route": "X-Y", "seed": 4})


def test_parquet_round_trip_keeps_position_and_time_exact_and_the_rest_to_float32(tmp_path):
    t = _synthetic()
    t.df["lat_deg"] = 46.8418123456789  # float32 would move this by ~1 m
    t.to_parquet(tmp_path / "t.parquet")
    back = TruthTrack.read_parquet(tmp_path / "t.parquet")
    assert back.meta == t.meta and not list(tmp_path.glob("*.tmp"))
    for c in COLUMNS:
        if c in FLOAT64_COLUMNS:
            assert back.df[c].dtype == np.float64 and back.df[c].equals(t.df[c])
        elif c not in ("leg_index", "phase"):
            assert back.df[c].dtype == np.float32
            assert np.array_equal(back.df[c].to_numpy(), t.df[c].to_numpy().astype(np.float32))
    # writing what was read gives the same bytes: stored and freshly flown truth agree
    back.to_parquet(tmp_path / "u.parquet")
    assert TruthTrack.read_parquet(tmp_path / "u.parquet").df.equals(back.df)


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


DEP = datetime(2009, 8, 15, 13, 0, tzinfo=UTC)


def _leg(**kw) -> PlannedLeg:
    base = dict(plan=plan_leg("KMSP", "KRST", DEP), region="upper_midwest", weather_seed=1, flight_seed=5)
    return PlannedLeg(**{**base, **kw})


def test_truth_key_changes_with_every_input_that_changes_a_flight():
    base = truth_key(_leg(), None, False)
    assert truth_key(_leg(), None, False) == base
    assert truth_key(_leg(flight_seed=6), None, False) != base
    assert truth_key(_leg(weather_seed=2), None, False) != base
    assert truth_key(_leg(region="eastern_us"), None, False) != base
    assert truth_key(_leg(), "737", False) != base
    assert truth_key(_leg(), None, True) != base
    assert truth_key(_leg(plan=plan_leg("KMSP", "KRST", DEP.replace(hour=14))), None, False) != base
    assert truth_key(_leg(plan=dataclasses.replace(_leg().plan, flight_id="X-1")), None, False) != base


@pytest.mark.slow
def test_store_flies_once_then_reads_what_it_returned(tmp_path, monkeypatch):
    store = TruthStore(tmp_path)
    first = store.leg(_leg())
    assert first.flown_now and first.track is not None and store.flown_count() == 1
    assert len(store.files()) == 1

    def no_flying(*a, **k):
        raise AssertionError("flew again instead of reading the store")

    monkeypatch.setattr("aerotruth.truth.store.fly_leg", no_flying)
    again = store.leg(_leg())
    assert not again.flown_now and again.track.df.equals(first.track.df) and again.track.meta == first.track.meta
    assert store.flown_count() == 1


def test_store_remembers_a_divergence(tmp_path, monkeypatch):
    def diverging(*a, **k):
        raise FlightDiverged("attitude limit: roll 61.0 deg, pitch 2.0 deg", 9, 120.0)

    monkeypatch.setattr("aerotruth.truth.store.fly_leg", diverging)
    store = TruthStore(tmp_path)
    outs = [store.leg(_leg(flight_seed=9)) for _ in range(2)]
    assert [o.flown_now for o in outs] == [True, False]
    for o in outs:
        assert o.track is None and o.diverged.seed == 9 and "roll 61.0" in o.diverged.reason


def test_eviction_removes_least_recently_used_flights_first(tmp_path):
    import os

    store = TruthStore(tmp_path)
    for i, age in enumerate((300, 100, 200)):
        p = tmp_path / "ab" / f"k{i}.parquet"
        p.parent.mkdir(exist_ok=True)
        p.write_bytes(b"x" * 1000)
        os.utime(p, (1e9 - age, 1e9 - age))
    assert store.size_bytes() == 3000
    assert store.evict(1500) == (2, 2000)
    assert [p.name for p in store.files()] == ["k1.parquet"]  # the most recently used stays


def test_aircraft_day_seeds_are_named_by_aircraft_and_date_not_by_study():
    a = AircraftDay.for_campaign(42, "N1", date(2009, 8, 15), legs=(FixedLeg("KMSP", "KRST", "13:00"),))
    b = AircraftDay.for_campaign(42, "N1", date(2009, 8, 15), network="mesaba")
    c = AircraftDay.for_campaign(42, "N2", date(2009, 8, 15), legs=a.legs)
    assert (a.weather_seed, a.day_seed) == (b.weather_seed, b.day_seed)
    assert a.weather_seed == c.weather_seed and a.day_seed != c.day_seed
    assert a.flight_seed(0) != a.flight_seed(1) and a.flight_seed(0) == b.flight_seed(0)


@pytest.mark.parametrize("text", ["2009-02-30", "15/08/2009", "yesterday"])
def test_bad_departure_dates_name_the_option(text):
    with pytest.raises(ValueError, match="--date"):
        parse_departure(text)


def test_departure_date_defaults_to_13_utc():
    assert parse_departure("2009-08-15") == datetime(2009, 8, 15, 13, 0, tzinfo=UTC)


def test_flight_diverged_survives_pickling_between_processes():
    import pickle

    e = pickle.loads(pickle.dumps(FlightDiverged("NaN in the JSBSim state", {"entropy": "1", "spawn_key": [2]}, 61.5)))
    assert (e.reason, e.seed, e.time_s) == ("NaN in the JSBSim state", {"entropy": "1", "spawn_key": [2]}, 61.5)
    assert "t=61.5 s" in str(e)


def test_a_filesystem_that_refuses_locks_stops_the_store_in_one_line(tmp_path, monkeypatch):
    """Lustre mounted with noflock answers flock with ENOSYS, an NFS client without lockd
    with ENOLCK: the store stops naming the lock file and the way out, and flies nothing
    unlocked."""
    import errno

    from aerotruth.truth.store import StoreLockError

    def refuse(fd, op):
        raise OSError(errno.ENOLCK, "No locks available")

    def no_flying(*a, **k):
        raise AssertionError("flew without the key's lock")

    monkeypatch.setattr("aerotruth.truth.store.fcntl.flock", refuse)
    monkeypatch.setattr("aerotruth.truth.store.fly_leg", no_flying)
    with pytest.raises(StoreLockError) as e:
        TruthStore(tmp_path).leg(_leg())
    msg = str(e.value)
    assert "\n" not in msg and ".lock: No locks available (ENOLCK)" in msg and "-o flock" in msg


def _append_lines(root: str, worker: int, n: int) -> None:
    store = TruthStore(root)
    for i in range(n):
        store._log_line(f"k{worker}-{i}", "x" * 3000, 1.0, "flown")  # lines longer than a pipe's atomic write


def test_flown_log_lines_from_concurrent_workers_stay_whole(tmp_path):
    """Four processes appending 200 long lines each to one store's flown.log (under its
    lock): 800 lines, each whole JSON, each key once."""
    import json
    import multiprocessing as mp

    ctx = mp.get_context("spawn")
    procs = [ctx.Process(target=_append_lines, args=(str(tmp_path), w, 200)) for w in range(4)]
    for p in procs:
        p.start()
    for p in procs:
        p.join(60)
        assert p.exitcode == 0
    lines = (tmp_path / "flown.log").read_text().splitlines()
    keys = [json.loads(line)["key"] for line in lines]
    assert len(keys) == 800 and len(set(keys)) == 800
    assert TruthStore(tmp_path).flown_count() == 800
