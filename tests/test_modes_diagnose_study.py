"""The modes_diagnose study: the truth study's aircraft-days through the Mode-S sensor with
a hidden heading lag, diagnosed inside a campaign (truth shared, streams named). (A 2-deg
variation-table error rests on the day's one or two level turns: the jackknife test finds
it on few single days; the lag shows in every turn.)"""

import json

import pandas as pd
import pytest

from aerotruth.config import parse_campaign
from aerotruth.sim.campaign import run_campaign
from aerotruth.sim.executors import ExecutorChoice

LEGS = ('[{from: KMSP, to: KDLH, departure_utc: "13:00"}, {from: KDLH, to: KMSP, departure_utc: "14:30"}, '
        '{from: KMSP, to: KRST, departure_utc: "16:00"}, {from: KRST, to: KMSP, departure_utc: "17:15"}]')
CAMPAIGN = f"""\
name: modes_diag
seed: 7
fleets:
  - {{name: f, aircraft: [N1]}}
periods:
  - {{name: d, dates: [2009-08-15]}}
studies:
  truth: {{fleets: [f], periods: [d], legs: {LEGS}}}
  modes_diagnose:
    flights: {{fleets: [f], periods: [d], legs: {LEGS}}}
    heading_lag_s: 2.0
"""


def test_hidden_heading_lag_is_found_in_the_campaign_and_truth_is_flown_once(tmp_path):
    s = run_campaign(parse_campaign(CAMPAIGN), ExecutorChoice("local", workers=2), out=tmp_path / "run",
                     progress=False, log=lambda m: None)
    m = json.loads((tmp_path / "run" / "metrics.json").read_text())["metrics"]
    assert m["modes_diagnose.detection_rate"] == 1.0
    (row,) = pd.read_parquet(next((tmp_path / "run" / "tasks").glob("modes_diagnose--*.parquet"))).query("rank == 1").to_dict("records")
    # one day's estimate: within 3 of its standard errors of 2 s plus the decoder's own
    # heading-vs-track sample age (the 1-s trajectory holds each register's last value: on
    # this day without a hidden lag diagnose measures 0.14-0.22 s, below its resolution)
    assert abs(row["value"] - 2.0) < 3 * row["se"] + 0.25 and m["modes_diagnose.estimate_mean"] == pytest.approx(row["value"])
    assert s.legs_flown <= 4  # the two studies share the aircraft-day's four legs
