"""The wind climatology's per-region/season statistics and its comparison with a cited
climatology: hand-worked numbers, and bad reference cells named in one line."""

from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from aerotruth.sim.campaign_file import ConfigError
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.studies.wind_climatology import PERIOD_SEP, ReferenceClimatology, versus_reference, wind_by_region
from aerotruth.units import KT

CAMPAIGN = """\
name: wc
seed: 3
periods:
  - {name: a, start: 2009-08-14, end: 2009-08-15}
  - {name: b, dates: [2009-08-15]}
studies:
  wind_climatology:
    regions:
      - {name: midwest, network: mesaba}
    periods: [a, b]
    flight_levels: [100, 300]
    hours_utc: [0]
    points: 10
"""


def rows(day_periods: dict[str, str], speeds: dict[str, list[tuple[float, float]]]) -> pd.DataFrame:
    out = []
    for day, uv in speeds.items():
        for u, v in uv:
            out.append(
                {"region": "r", "date": day, "flight_level": 100, "u_mps": u, "v_mps": v, "periods": day_periods[day]}
            )
    return pd.DataFrame(out)


def test_wind_by_region_counts_a_day_in_each_of_its_periods():
    # day 1 in period a only: speeds 5 (3-4-5) and 13 (5-12-13); day 2 in a and b: speed 10
    df = rows({"d1": "a", "d2": f"a{PERIOD_SEP}b"}, {"d1": [(3.0, 4.0), (5.0, 12.0)], "d2": [(6.0, 8.0)]})
    t = wind_by_region(df).set_index("period")
    assert list(t.index) == ["a", "b"]
    assert t.loc["a", "samples"] == 3 and t.loc["b", "samples"] == 1
    assert t.loc["a", "mean_mps"] == pytest.approx((5 + 13 + 10) / 3)
    assert t.loc["a", "sd_mps"] == pytest.approx(np.std([5.0, 13.0, 10.0], ddof=1))
    assert t.loc["a", "p50_mps"] == pytest.approx(10.0)
    assert t.loc["a", "u_mean_mps"] == pytest.approx((3 + 5 + 6) / 3)
    assert t.loc["a", "v_mean_mps"] == pytest.approx((4 + 12 + 8) / 3)
    assert t.loc["b", "mean_mps"] == pytest.approx(10.0) and math.isnan(t.loc["b", "sd_mps"])
    assert (t.loc["a", "first_date"], t.loc["a", "last_date"]) == ("d1", "d2")


def by_region(u: float, v: float = 0.0, mean: float = 20.0, sd: float = 6.0) -> pd.DataFrame:
    return pd.DataFrame(
        [
            {
                "region": "r",
                "period": "a",
                "flight_level": 300,
                "samples": 100,
                "mean_mps": mean,
                "sd_mps": sd,
                "p50_mps": mean,
                "p90_mps": mean + 1.2816 * sd,
                "p95_mps": mean,
                "u_mean_mps": u,
                "v_mean_mps": v,
                "first_date": "d1",
                "last_date": "d2",
            }
        ]
    )


def judged(truth: pd.DataFrame, **cell) -> pd.DataFrame:
    ref = ReferenceClimatology(
        source="test",
        tolerance=0.3,
        min_difference_kt=5.0,
        cells=[{"region": "r", "period": "a", "flight_level": 300, **cell}],
    )
    return versus_reference(truth, ref)


def test_mean_vector_within_30_percent_passes_and_beyond_is_off():
    ok = judged(by_region(12.0), mean_u_mps=10.0, mean_v_mps=0.0).iloc[0]
    assert ok["ratio"] == pytest.approx(1.2) and not ok["off"]
    # 14 vs 10 m/s: 40 % and 4 m/s = 7.8 kt, beyond both 30 % (3 m/s) and 5 kt (2.57 m/s)
    off = judged(by_region(14.0), mean_u_mps=10.0, mean_v_mps=0.0).iloc[0]
    assert off["ratio"] == pytest.approx(1.4) and off["off"]
    # the vector's magnitude: (6, 8) against (10, 0) is the same length, pointing elsewhere
    turned = judged(by_region(6.0, 8.0), mean_u_mps=10.0, mean_v_mps=0.0).iloc[0]
    assert turned["ratio"] == pytest.approx(1.0) and (turned["truth_u_mps"], turned["truth_v_mps"]) == (6.0, 8.0)


def test_a_near_zero_mean_is_judged_by_the_5_kt_floor_not_its_ratio():
    # 3 vs 1 m/s: ratio 3, but 2 m/s = 3.9 kt apart, under the 5-kt floor
    small = judged(by_region(3.0), mean_u_mps=1.0, mean_v_mps=0.0).iloc[0]
    assert small["ratio"] == pytest.approx(3.0) and not small["off"]
    assert judged(by_region(1.0 + 5.2 * KT), mean_u_mps=1.0, mean_v_mps=0.0).iloc[0]["off"]


def test_mean_speed_and_spread_are_compared_in_knots_and_only_the_mean_is_judged():
    t = judged(by_region(5.0, mean=20.0, sd=6.0), mean_speed_kt=20.0 / KT * 0.75, sd_speed_kt=1.0)
    mean, sd = t.iloc[0], t.iloc[1]
    assert mean["statistic"] == "mean speed (kt)" and mean["truth"] == pytest.approx(20.0 / KT)
    assert mean["ratio"] == pytest.approx(1 / 0.75) and mean["off"]  # 33 % and 13 kt
    assert sd["statistic"] == "speed sd (kt)" and sd["truth"] == pytest.approx(6.0 / KT) and not sd["off"]


def test_a_cell_the_truth_did_not_sample_is_off():
    t = judged(by_region(10.0).assign(period="other"), mean_u_mps=10.0, mean_v_mps=0.0).iloc[0]
    assert math.isnan(t["truth"]) and t["off"]


def with_reference(cells: str) -> str:
    return CAMPAIGN + "    references:\n    - source: test\n      cells:\n" + cells


def test_bad_reference_cells_get_one_line_naming_the_field():
    with pytest.raises(
        ConfigError,
        match=r'references\[0\]\.cells\[0\]\.region: expected one of the study.s regions \(midwest\), got "nowhere"',
    ):
        parse_campaign(with_reference("        - {region: nowhere, period: a, flight_level: 100, mean_speed_kt: 20}\n"))
    with pytest.raises(ConfigError, match=r"references\[0\]\.cells\[0\]\.flight_level.*100, 300.*180"):
        parse_campaign(with_reference("        - {region: midwest, period: a, flight_level: 180, mean_speed_kt: 20}\n"))
    with pytest.raises(ConfigError, match="both mean_u_mps and mean_v_mps"):
        parse_campaign(with_reference("        - {region: midwest, period: a, flight_level: 100, mean_u_mps: 3}\n"))
    with pytest.raises(ConfigError, match="expected mean_speed_kt, p50_speed_kt, or mean_u_mps and mean_v_mps"):
        parse_campaign(with_reference("        - {region: midwest, period: b, flight_level: 100}\n"))
    with pytest.raises(ConfigError, match="p90_speed_kt needs p50_speed_kt below it"):
        parse_campaign(
            with_reference(
                "        - {region: midwest, period: b, flight_level: 100, p50_speed_kt: 30, p90_speed_kt: 20}\n"
            )
        )


def test_a_campaign_with_a_reference_reports_each_cell_beside_the_truth(tmp_path):
    from aerotruth.sim.campaign import run_campaign
    from aerotruth.sim.executors import ExecutorChoice

    text = with_reference(
        "        - {region: midwest, period: b, flight_level: 300, mean_u_mps: 500.0, mean_v_mps: 0.0}\n"
        "        - {region: midwest, period: a, flight_level: 100, mean_speed_kt: 1.0e-3}\n"
    )
    out = tmp_path / "run"
    run_campaign(parse_campaign(text), ExecutorChoice("local", workers=1), out=out, progress=False, log=lambda m: None)
    vs = pd.read_csv(out / "tables" / "wind_climatology.versus_reference.csv")
    assert list(vs["statistic"]) == ["mean wind vector (m/s)", "mean speed (kt)"]
    assert vs["off"].all()  # no truth wind is 500 m/s or 0.001 kt
    by = pd.read_csv(out / "tables" / "wind_climatology.wind_by_region.csv")
    assert set(zip(by["period"], by["flight level"], strict=False)) == {
        ("a", "FL100"),
        ("a", "FL300"),
        ("b", "FL100"),
        ("b", "FL300"),
    }
    # period a holds both days (10 points x 1 hour each), b the second only
    assert set(by.loc[by["period"] == "a", "samples"]) == {20} and set(by.loc[by["period"] == "b", "samples"]) == {10}
    from aerotruth.app.report import write_report

    m = json.loads((out / "metrics.json").read_text())["metrics"]
    assert m["wind_climatology.reference.0.cells"] == 2 and m["wind_climatology.reference.0.cells_off"] == 2
    assert m["wind_climatology.reference.0.cells_unsampled"] == 0
    report = write_report(out).read_text()
    assert "wind_versus_reference.png" in report and "| midwest | b | FL300 | mean wind vector (m/s) | 500 |" in report
    assert (out / "figures" / "wind_versus_reference.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_median_and_90th_percentile_are_judged_and_a_stand_in_reference_only_shown():
    # truth median 20 m/s = 38.9 kt; 90th percentile 20 + 1.2816 x 6 = 27.69 m/s = 53.8 kt
    t = judged(by_region(5.0, mean=20.0, sd=6.0), p50_speed_kt=40.0, p90_speed_kt=80.0)
    p50, p90 = t.iloc[0], t.iloc[1]
    assert p50["statistic"] == "median speed (kt)" and p50["truth"] == pytest.approx(20.0 / KT)
    assert not p50["off"]  # 2.8 % low
    assert p90["statistic"] == "90 % speed (kt)" and p90["truth"] == pytest.approx((20.0 + 1.2816 * 6.0) / KT)
    assert p90["ratio"] == pytest.approx(53.83 / 80.0, rel=1e-3) and p90["off"]  # 33 % and 26 kt low
    shown = ReferenceClimatology(
        source="a station outside the region",
        judged=False,
        cells=[{"region": "r", "period": "a", "flight_level": 300, "p50_speed_kt": 40.0, "p90_speed_kt": 80.0}],
    )
    vs = versus_reference(by_region(5.0, mean=20.0, sd=6.0), shown, 2)
    assert not vs["off"].any() and set(vs["source_index"]) == {2} and not vs["judged"].any()
    assert list(vs["ratio"].round(3)) == [round(p50["ratio"], 3), round(p90["ratio"], 3)]


def test_each_reference_is_judged_on_its_own_and_a_stand_in_never_flags(tmp_path):
    from aerotruth.sim.campaign import run_campaign
    from aerotruth.sim.executors import ExecutorChoice

    text = (
        CAMPAIGN
        + "    references:\n"
        + "    - source: judged\n      tolerance: 0.2\n      cells:\n"
        + "        - {region: midwest, period: a, flight_level: 300, p50_speed_kt: 1.0e-3, p90_speed_kt: 1.0}\n"
        + "    - source: shown\n      judged: false\n      cells:\n"
        + "        - {region: midwest, period: a, flight_level: 300, p50_speed_kt: 1.0e-3, p90_speed_kt: 1.0}\n"
    )
    out = tmp_path / "run"
    run_campaign(parse_campaign(text), ExecutorChoice("local", workers=1), out=out, progress=False, log=lambda m: None)
    m = json.loads((out / "metrics.json").read_text())["metrics"]
    # no truth wind has a 0.001-kt median: off where judged, shown only where not
    assert (m["wind_climatology.reference.0.cells_off"], m["wind_climatology.reference.1.cells_off"]) == (2, 0)
    assert (m["wind_climatology.reference.0.judged"], m["wind_climatology.reference.1.judged"]) == (1, 0)
    # the same cells, the same ratios: the same RMS of log ratio for both
    assert (
        m["wind_climatology.reference.0.speed_rms_log_ratio"] == m["wind_climatology.reference.1.speed_rms_log_ratio"]
    )
    assert m["wind_climatology.reference.0.speed_rms_log_ratio"] > 5.0  # log(~20 kt / 0.001 kt) ~ 10
    vs = pd.read_csv(out / "tables" / "wind_climatology.versus_reference.csv")
    assert list(vs["source_index"]) == [0, 0, 1, 1] and list(vs["judged"]) == [True, True, False, False]
