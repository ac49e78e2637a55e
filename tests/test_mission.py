"""An inspection mission flown by JSBSim: the runs in order at their heights and places,
and the profile tools against hand-made tracks."""

import datetime as dt

import numpy as np
import pandas as pd
import pytest

from aerotruth.sim.studies.inspection import _real_track, level_segments
from aerotruth.truth.mission import MissionRun, MissionSpec, fly_mission
from aerotruth.units import FT, NM

RUNS = [
    {"type": "low_pass", "from_nm": 9, "height_ft": 1800},
    {"type": "crossing", "height_ft": 1300, "at_nm": 6},
    {"type": "level_run", "height_ft": 2200, "from_nm": 12, "to_nm": 3},
    {"type": "approach", "from_nm": 10, "height_ft": 2000, "decision_height_ft": 400},
]


@pytest.fixture(scope="module")
def mission():
    spec = MissionSpec("PANC", "07R", dt.datetime(2009, 8, 15, 14, tzinfo=dt.UTC), tuple(MissionRun(**r) for r in RUNS))
    return fly_mission(spec, seed=3)


@pytest.mark.slow
def test_runs_are_flown_in_order_where_and_how_high_they_should_be(mission):
    df = mission.df
    flown = [int(k) for k in dict.fromkeys(df.loc[df["run"] >= 0, "run"])]
    assert flown == [0, 1, 2, 3]
    z_ft = df["z_m"] / FT
    low = df[(df["run"] == 0) & (df["x_m"] > 300) & (df["x_m"] < mission.meta["runway_length_m"] - 300)]
    assert low["z_m"].div(FT).between(80, 140).all()  # the 100 ft pass over the runway (exponential capture)
    cross = df[df["run"] == 1]
    assert z_ft[cross.index].between(1250, 1350).all()
    i0 = np.argmin(np.abs(cross["y_m"].to_numpy()))
    assert cross["x_m"].iloc[i0] == pytest.approx(-6 * NM, abs=0.1 * NM)
    level = df[df["run"] == 2]
    assert z_ft[level.index].between(2150, 2250).all() and level["y_m"].abs().max() < 60.0
    appr = df[df["run"] == 3]
    assert 330 < z_ft[appr.index].min() < 430  # the go-around at 400 ft
    assert np.degrees(df["roll_rad"]).abs().max() < 30.0


def test_level_segments_and_the_real_track_reader(tmp_path):
    t = np.arange(0.0, 600.0, 5.0)
    vs = np.where((t >= 100) & (t < 250), 0.0, 800.0)  # one 145 s level run
    trk = np.where(t < 180, 90.0, 95.0)
    p = pd.DataFrame({"time_s": t, "vertical_rate_fpm": vs, "track_deg": trk})
    assert list(level_segments(p)) == [145.0]
    assert list(level_segments(p.assign(track_deg=np.where(t < 180, 90.0, 150.0)))) == [
        75.0,
        65.0,
    ]  # a 60-deg turn splits it
    rec = [
        {
            "timestamp": 1000 * k,
            "altitude": 0 if k == 0 else 2000,
            "groundspeed": 150,
            "vertical_rate": 0,
            "track": 90,
            "latitude": 50.0,
            "longitude": 4.0,
        }
        for k in range(5)
    ]
    path = tmp_path / "c.json"
    path.write_text(pd.Series(rec).to_json(orient="values"))
    r = _real_track(str(path))
    assert len(r) == 4 and r["altitude_ft"].eq(2000).all()  # the 0-ft ground report dropped
    with pytest.raises(ValueError, match="missing 'track'"):
        bad = tmp_path / "b.json"
        bad.write_text(pd.Series([{k: v for k, v in rec[1].items() if k != "track"}]).to_json(orient="values"))
        _real_track(str(bad))
