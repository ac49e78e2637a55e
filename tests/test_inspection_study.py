"""The inspection study: an ILS with injected errors, measured by the aircraft's receiver
on JSBSim approaches and recovered through each truth system.

Independent expectations: the injected facility errors (sensors/ils defaults: alignment
3 m, path angle +0.05 deg, bends 0.02 deg), the Annex 10 Cat I tolerances for the drawn
facilities, and the FITS paper's statement that the AFIS is worse far from the runway."""

import json

import numpy as np
import pandas as pd
import pytest

from aerotruth.sim.campaign import run_campaign
from aerotruth.sim.campaign_file import ConfigError
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.executors import ExecutorChoice


def campaign(extra: str = "") -> str:
    return f"""\
name: it
seed: 6
periods:
  - {{name: d, dates: [2009-08-15]}}
studies:
  inspection:
    runways: [{{airport: KDLH, runway: "27"}}, {{airport: KRST, runway: "31"}}]
    periods: [d]
    turbulence: false
    sensors:
      ins: [{{grade: tactical}}]
{extra}"""


def _run(text, out):
    run_campaign(parse_campaign(text), ExecutorChoice("local", workers=2), out=out, progress=False, log=lambda m: None)
    metrics = json.loads((out / "metrics.json").read_text())["metrics"]
    rows = pd.concat(
        [pd.read_parquet(p) for p in sorted((out / "tasks").glob("inspection--*.parquet"))], ignore_index=True
    )
    return metrics, rows


@pytest.fixture(scope="module")
def fixed(tmp_path_factory):
    return _run(campaign(), tmp_path_factory.mktemp("insp") / "run")


@pytest.mark.slow
def test_injected_errors_are_recovered_through_the_truth_and_waas_systems(fixed):
    m, rows = fixed
    s = rows[rows["kind"] == "system"].set_index(["approach", "system"])
    assert set(s.index.get_level_values("system")) == {"truth", "dgps", "afis", "waas/tactical"}
    for sysname in ("truth", "waas/tactical", "dgps"):
        g = s.xs(sysname, level="system")
        assert np.allclose(g["alignment_true_m"], 3.0) and np.allclose(g["gp_angle_true_deg"], 0.05)
        assert (g["alignment_err_m"].abs() < 1.0).all(), (
            sysname
        )  # 1 m at the threshold: an inspection's alignment resolution
        assert (g["gp_angle_err_deg"].abs() < 0.01).all(), sysname  # 0.01 deg
        assert (g["bend_rel_err"].abs() < 0.2).all(), sysname  # 20 %
        assert g["alignment_pass_est"].all() and g["gp_angle_pass_est"].all()  # 3 m and 0.05 deg pass Cat I
    assert m["inspection.waas_tactical.alignment_err_p95_m"] < 1.0


@pytest.mark.slow
def test_afis_is_worse_far_from_the_runway(fixed):
    _, rows = fixed
    ep = rows[(rows["kind"] == "epoch") & (rows["system"] == "afis")]
    d = ep["distance_to_threshold_m"] / 1852.0
    near = np.sqrt(np.mean(ep.loc[d < 1, "cross_m"] ** 2))
    far = np.sqrt(np.mean(ep.loc[d > 8, "cross_m"] ** 2))
    assert far > 3 * near


@pytest.mark.slow
def test_drawn_facilities_span_twice_the_cat_i_tolerance_and_verdicts_are_counted(tmp_path):
    m, rows = _run(campaign("    facility_errors: uniform_2x_tolerance\n    approaches_per_day: 3"), tmp_path / "v")
    s = rows[(rows["kind"] == "system") & (rows["system"] == "truth")]
    assert (s["alignment_true_m"].abs() <= 21.0).all() and (s["gp_angle_true_deg"].abs() <= 0.45 + 1e-9).all()
    assert s["alignment_true_m"].nunique() == len(s)  # drawn per approach
    assert np.array_equal(s["alignment_pass_true"].to_numpy(bool), (s["alignment_true_m"].abs() <= 10.5).to_numpy())
    for k in ("truth", "afis", "waas_tactical", "dgps"):
        assert 0.0 <= m[f"inspection.{k}.wrong_verdict.alignment"] <= 1.0


def test_a_bad_category_is_refused_naming_the_field():
    with pytest.raises(ConfigError, match="facility.category"):
        parse_campaign(campaign("    facility: {category: IV}"))


@pytest.mark.slow
def test_a_mission_is_scored_by_run_type_beside_a_real_track_found_from_the_campaign_folder(tmp_path):
    import gzip
    import shutil

    from aerotruth.sim.campaign_loader import load_campaign

    real = [
        {
            "timestamp": 1000 * k,
            "altitude": 2200 if k % 400 < 200 else 1300,
            "groundspeed": 160,
            "vertical_rate": 0,
            "track": 90 if k % 400 < 200 else 270,
            "latitude": 50.0,
            "longitude": 4.0,
        }
        for k in range(1, 1200)
    ]
    (tmp_path / "data").mkdir()
    with gzip.open(tmp_path / "data" / "cal.json.gz", "wt") as f:
        json.dump(real, f)
    text = campaign("""    mission:
      airport: PANC
      runway: 07R
      date: 2009-08-15
      turbulence: false
      compare_with: [data/cal.json.gz]
      runs:
        - {type: low_pass, from_nm: 9, height_ft: 1800}
        - {type: crossing, height_ft: 1300, at_nm: 5}""").replace(
        "periods: [d]", "periods: [d]\n    approaches_per_day: 1"
    )
    (tmp_path / "c.yaml").write_text(text)
    c = load_campaign(tmp_path / "c.yaml")
    assert c.studies["inspection"].mission.compare_with[0] == str((tmp_path / "data" / "cal.json.gz").resolve())
    out = tmp_path / "run"
    run_campaign(c, ExecutorChoice("local", workers=2), out=out, progress=False, log=lambda m: None)
    tables = {p.stem: pd.read_parquet(p) for p in (out / "tables").glob("inspection.*.parquet")}
    by_type = tables["inspection.mission_by_run_type"]
    assert set(by_type["run type"]) == {"low_pass", "crossing"}
    assert by_type.loc[by_type["truth system"] == "truth", "cross RMS (m)"].eq(0).all()
    w = by_type[by_type["truth system"] == "waas/tactical"]
    assert (w["cross RMS (m)"] < 0.5).all() and (w["vertical RMS (m)"] < 0.5).all()
    prof = tables["inspection.mission_profile"].set_index("track")
    assert prof.loc["real:cal.json.gz", "altitude p50 (ft)"] in (1300.0, 2200.0)
    assert prof.loc["real:cal.json.gz", "level runs"] == 6  # 200-s legs, each turn of 180 deg splits them
    shutil.rmtree(tmp_path / "data")
    with pytest.raises(ConfigError, match=r"mission.compare_with.*no such file"):
        load_campaign(tmp_path / "c.yaml")
