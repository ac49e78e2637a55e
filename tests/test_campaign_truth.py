"""The `truth` study: aircraft-days of JSBSim legs scored per leg, schedules truncated to
the first legs, diverged flights recorded with their seed and excluded by name, and the
same metrics whatever the number of worker processes."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest

from aerotruth.sim.campaign import expand, run_campaign
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.context import TaskContext
from aerotruth.sim.executors import ExecutorChoice
from aerotruth.sim.store import RunStore
from aerotruth.sim.studies.truth import STUDY as TRUTH
from aerotruth.truth.airports import airport
from aerotruth.units import NM

FIXED = """\
name: truth_tiny
seed: 7
fleets:
  - {name: f, aircraft: [N1, N2]}
periods:
  - {name: d, dates: [2009-08-15]}
studies:
  truth:
    fleets: [f]
    periods: [d]
    legs:
      - {from: KMSP, to: KRST, departure_utc: "13:00"}
"""
QUIET = {"progress": False, "log": lambda msg: None}


@pytest.fixture(scope="module")
def fixed_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("truth") / "run"
    run_campaign(parse_campaign(FIXED), ExecutorChoice("local", workers=1), out=out, **QUIET)
    return out


@pytest.mark.slow
def test_each_aircraft_day_flies_its_leg_within_the_foundation_acceptance(fixed_run):
    store = RunStore(fixed_run)
    rows = store.read_rows(expand(store.campaign()))
    assert list(rows["flight_id"]) == ["N1-20090815-1", "N2-20090815-1"]
    # independent of pyproj: haversine on the mean Earth radius, 0.5 % of the geodesic
    a, b = airport("KMSP"), airport("KRST")
    la1, lo1, la2, lo2 = map(np.radians, (a.lat, a.lon, b.lat, b.lon))
    hav = np.sin((la2 - la1) / 2) ** 2 + np.cos(la1) * np.cos(la2) * np.sin((lo2 - lo1) / 2) ** 2
    gc_nm = 2 * 6371008.8 * np.arcsin(np.sqrt(hav)) / NM
    for _, r in rows.iterrows():
        assert not r["diverged"] and r["diverge_reason"] == ""
        assert r["great_circle_nm"] == pytest.approx(gc_nm, rel=0.005)
        # flown from 400 ft over the runway end to 6 nm final: longer than the great circle, not wildly
        assert 0.9 * gc_nm < r["distance_nm"] < 1.6 * gc_nm
        assert r["cruise_tas_error_max_kt"] <= 5.0 and r["cruise_xtrack_max_nm"] < 0.3
        assert r["arrival_centreline_offset_nm"] < 1.0 and r["wind_triangle_residual_max_kt"] < 0.5
        assert r["atmosphere_region"] == "upper_midwest"
    # same day, same weather realization; each leg its own recorded seed
    assert rows["weather_seed"].nunique() == 1 and rows["seed"].nunique() == 2
    m = store.read_metrics()["metrics"]
    assert (m["truth.legs"], m["truth.legs_flown"], m["truth.legs_diverged"]) == (2, 2, 0)
    assert m["truth.cruise_xtrack_max_nm.pass_fraction"] == 1.0


@pytest.mark.slow
def test_two_workers_give_identical_truth_metrics(fixed_run, tmp_path):
    run_campaign(parse_campaign(FIXED), ExecutorChoice("local", workers=2), out=tmp_path / "r2", **QUIET)
    assert (tmp_path / "r2" / "metrics.json").read_bytes() == (fixed_run / "metrics.json").read_bytes()


@pytest.mark.slow
def test_the_run_counts_the_legs_it_flew_not_what_another_campaign_adds_to_the_store_log(monkeypatch, tmp_path):
    """A campaign running beside this one appends its own flights to the shared store's
    flown.log; the summary counts only this run's."""
    import json

    text = FIXED + f"truth_store: {{path: {tmp_path / 'truth'}}}\n"
    log = tmp_path / "truth" / "flown.log"
    prepare = RunStore.prepare

    def prepare_while_another_campaign_flies(self, *args, **kwargs):  # between the run's start and its end
        log.parent.mkdir(parents=True, exist_ok=True)
        with open(log, "a", encoding="utf-8") as f:
            for k in range(3):
                f.write(
                    json.dumps({"key": f"other{k}", "flight_id": "X", "what": "flown", "seconds": 1.0, "pid": 1}) + "\n"
                )
        return prepare(self, *args, **kwargs)

    monkeypatch.setattr(RunStore, "prepare", prepare_while_another_campaign_flies)
    first = run_campaign(parse_campaign(text), ExecutorChoice("local", workers=1), out=tmp_path / "a", **QUIET)
    again = run_campaign(parse_campaign(text), ExecutorChoice("local", workers=1), out=tmp_path / "b", **QUIET)
    assert (first.legs_flown, again.legs_flown) == (2, 0)
    assert sum(1 for _ in open(log)) == 2 + 3 + 3


def test_schedule_day_keeps_the_first_legs_chained_in_time():
    text = FIXED.replace("  - {name: f, aircraft: [N1, N2]}", "  - {name: f, network: mesaba, aircraft: [N1]}")
    text = text[: text.index("    legs:")] + "    max_legs_per_day: 3\n"
    (task,) = expand(parse_campaign(text))
    legs = task.params["day"].plans()
    assert len(legs) == 3
    plans = [leg.plan for leg in legs]
    for a, b in zip(plans, plans[1:], strict=False):
        assert a.destination.icao == b.origin.icao
        assert b.departure_utc >= a.departure_utc + dt.timedelta(seconds=a.block_time_s)
    assert all(p.departure_utc.date() == dt.date(2009, 8, 15) for p in plans)
    # one atmosphere realization for the network's day; each leg its own flight seed
    assert len({id(leg.atmosphere()) for leg in legs}) == 1
    assert len({leg.flight_seed for leg in legs}) == 3


@pytest.mark.slow
def test_diverged_leg_is_kept_by_name_with_its_seed_and_left_out_of_statistics(monkeypatch, tmp_path):
    import aerotruth.truth.flight as flight
    import aerotruth.truth.store as truth_store

    calls = []

    def fake_fly_leg(plan, *, seed, **kw):
        calls.append(seed)
        if len(calls) == 2:
            raise flight.FlightDiverged("attitude limit: roll 75.0 deg, pitch 3.0 deg", seed, 812.5)
        return real_fly_leg(plan, seed=seed, **kw)

    real_fly_leg = flight.fly_leg
    monkeypatch.setattr(truth_store, "fly_leg", fake_fly_leg)
    text = FIXED.replace(
        '  - {from: KMSP, to: KRST, departure_utc: "13:00"}',
        '  - {from: KMSP, to: KRST, departure_utc: "13:00"}\n      - {from: KRST, to: KMSP, departure_utc: "15:00"}',
    )
    campaign = parse_campaign(text)
    task = expand(campaign)[0]
    rows = TRUTH.run(task, TaskContext(task, 7, str(tmp_path / "store")))
    assert list(rows["diverged"]) == [False, True]
    bad = rows.iloc[1]
    assert (
        bad["seed"] == calls[1]
        and bad["diverge_reason"].startswith("attitude limit")
        and bad["diverge_time_s"] == 812.5
    )
    assert np.isnan(bad["distance_nm"])
    rows.insert(0, "task_id", task.id)
    summary = TRUTH.summarize(rows, {}, campaign.section("truth"))
    m = summary.metrics
    assert (m["legs"], m["legs_flown"], m["legs_diverged"]) == (2, 1, 1)
    assert m["cruise_tas_error_max_kt.max"] == pytest.approx(rows.iloc[0]["cruise_tas_error_max_kt"])
    div = summary.tables["diverged_legs"]
    assert list(div["flight_id"]) == ["N1-20090815-2"] and list(div["seed"]) == [calls[1]]
    # the store remembers the divergence: asked again, it reports it without flying
    again = TRUTH.run(task, TaskContext(task, 7, str(tmp_path / "store")))
    assert len(calls) == 2 and list(again["diverged"]) == [False, True]


def test_unknown_aircraft_type_is_one_line_from_validate(tmp_path, capsys):
    from aerotruth.app.cli import main

    path = tmp_path / "c.yaml"
    path.write_text(
        FIXED.replace("{name: f, aircraft: [N1, N2]}", "{name: f, aircraft_type: concorde, aircraft: [N1]}")
    )
    assert main(["validate", str(path)]) == 2
    err = capsys.readouterr().err.strip()
    assert (
        err == f"aerotruth validate: {path}: fleets[0].aircraft_type: "
        'expected an aircraft type (737, saab340), got "concorde" (line 4)'
    )
    assert "\n" not in err
