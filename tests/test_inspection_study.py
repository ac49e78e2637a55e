"""The inspection study: an ILS with injected errors, measured by the aircraft's receiver
on JSBSim approaches and recovered through each truth system.

Independent expectations: the injected facility errors (sensors/ils defaults: alignment
3 m, path angle +0.05 deg, bends 0.02 deg), the Annex 10 Cat I tolerances for the drawn
facilities, and the FITS paper's statement that the AFIS is worse far from the runway."""

import json

import numpy as np
import pandas as pd
import pytest

from aerotruth.config import ConfigError, parse_campaign
from aerotruth.sim.campaign import run_campaign
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
    rows = pd.concat([pd.read_parquet(p) for p in sorted((out / "tasks").glob("inspection--*.parquet"))], ignore_index=True)
    return metrics, rows


@pytest.fixture(scope="module")
def fixed(tmp_path_factory):
    return _run(campaign(), tmp_path_factory.mktemp("insp") / "run")


def test_injected_errors_are_recovered_through_the_truth_and_waas_systems(fixed):
    m, rows = fixed
    s = rows[rows["kind"] == "system"].set_index(["approach", "system"])
    assert set(s.index.get_level_values("system")) == {"truth", "dgps", "afis", "waas/tactical"}
    for sysname in ("truth", "waas/tactical", "dgps"):
        g = s.xs(sysname, level="system")
        assert np.allclose(g["alignment_true_m"], 3.0) and np.allclose(g["gp_angle_true_deg"], 0.05)
        assert (g["alignment_err_m"].abs() < 1.0).all(), sysname  # the 1 m at the threshold
        assert (g["gp_angle_err_deg"].abs() < 0.01).all(), sysname  # 0.01 deg
        assert (g["bend_rel_err"].abs() < 0.2).all(), sysname  # 20 %
        assert g["alignment_pass_est"].all() and g["gp_angle_pass_est"].all()  # 3 m and 0.05 deg pass Cat I
    assert m["inspection.waas_tactical.alignment_err_p95_m"] < 1.0


def test_afis_is_worse_far_from_the_runway(fixed):
    _, rows = fixed
    ep = rows[(rows["kind"] == "epoch") & (rows["system"] == "afis")]
    d = ep["distance_to_threshold_m"] / 1852.0
    near = np.sqrt(np.mean(ep.loc[d < 1, "cross_m"] ** 2))
    far = np.sqrt(np.mean(ep.loc[d > 8, "cross_m"] ** 2))
    assert far > 3 * near


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
