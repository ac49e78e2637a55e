"""A third study added by one module (tests/studies/toy_offset.py) and this test, with no
edit anywhere else: it reads truth tracks from the shared truth store, learns a per-
aircraft heading offset on a "before" period and applies it to an "after" period."""

from __future__ import annotations

import json
from pathlib import Path

import pandas as pd
import pytest

from aerotruth.sim.campaign import run_campaign
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.executors import ExecutorChoice
from aerotruth.sim.studies import load_study, source_for

pytestmark = pytest.mark.slow  # every test here flies JSBSim or takes over 5 s

STUDY_FILE = Path(__file__).parent / "studies" / "toy_offset.py"
LEGS = '[{from: KMSP, to: KRST, departure_utc: "13:00"}]'
TOY = f"""\
name: toy
seed: 3
study_modules: [{STUDY_FILE}]
fleets:
  - {{name: f, aircraft: [N1, N2]}}
periods:
  - {{name: before, dates: [2009-08-14, 2009-08-15]}}
  - {{name: after, dates: [2009-08-16]}}
studies:
  truth:
    fleets: [f]
    periods: [before, after]
    legs: {LEGS}
  toy_offset:
    flights: {{fleets: [f], periods: [before, after], legs: {LEGS}}}
    before: before
    after: after
    bias_sigma_deg: 2.0
    noise_deg: 0.5
"""
N_TOY, N_TRUTH = 6, 6  # 2 aircraft x 3 days each
LOCAL1 = ExecutorChoice("local", workers=1)
LOCAL2 = ExecutorChoice("local", workers=2)
QUIET = {"progress": False, "log": lambda msg: None}


def rows_of(run_dir: Path, study: str) -> pd.DataFrame:
    files = sorted((run_dir / "tasks").glob(f"{study}--*.parquet"))
    return pd.concat([pd.read_parquet(f).assign(task=f.stem) for f in files], ignore_index=True)


def truth_bytes(run_dir: Path) -> dict[str, bytes]:
    return {f.name: f.read_bytes() for f in sorted((run_dir / "tasks").glob("truth--*.parquet"))}


@pytest.fixture(scope="module")
def toy_run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("toy") / "run"
    run_campaign(parse_campaign(TOY), LOCAL2, out=out, **QUIET)  # the legs flown on both cores
    return out


def test_offset_learned_before_removes_the_bias_after(toy_run):
    m = json.loads((toy_run / "metrics.json").read_text())["metrics"]
    # after the correction only the noise is left: sigma 0.5 deg, plus the offset's own
    # estimation error (~0.5/sqrt(~2 x 300 samples)), far below the 2-deg bias spread
    assert m["toy_offset.after.rms_error_deg"] == pytest.approx(0.5, abs=0.05)
    assert m["toy_offset.before.rms_error_deg"] > 2 * m["toy_offset.after.rms_error_deg"]
    learned = pd.read_parquet(toy_run / "learned" / "toy_offset.offset.parquet")
    before = rows_of(toy_run, "toy_offset").query("task.str.contains('--before--')", engine="python")
    for _, r in learned.iterrows():
        mine = before[before["aircraft"] == r["aircraft"]]
        assert r["offset_deg"] == pytest.approx((mine["n"] * mine["mean_error_deg"]).sum() / mine["n"].sum(), abs=1e-12)


def test_a_rerun_reuses_tasks_and_the_stored_fit(toy_run, monkeypatch):
    study = load_study(source_for(str(STUDY_FILE), None))

    def no_refit(*a, **k):
        raise AssertionError("the learned state was fitted again")

    monkeypatch.setattr(study, "fit", no_refit)
    s = run_campaign(parse_campaign(TOY), LOCAL1, out=toy_run, **QUIET)
    assert (s.ran, s.legs_flown) == (0, 0)


def test_changing_a_sensor_parameter_flies_no_leg_and_keeps_the_truth_rows(toy_run, tmp_path):
    out = tmp_path / "resensed"
    run_campaign(parse_campaign(TOY), LOCAL1, out=out, **QUIET)
    truth_before = truth_bytes(out)
    s = run_campaign(parse_campaign(TOY.replace("noise_deg: 0.5", "noise_deg: 0.8")), LOCAL1, out=out, **QUIET)
    assert s.legs_flown == 0
    assert s.ran == N_TOY  # every toy task reruns (and the fit with it), no truth task does
    assert truth_bytes(out) == truth_before and len(truth_before) == N_TRUTH


def test_paired_runs_with_and_without_the_correction_share_truth_and_noise(toy_run, tmp_path):
    off = tmp_path / "uncorrected"
    run_campaign(
        parse_campaign(TOY.replace("    noise_deg: 0.5\n", "    noise_deg: 0.5\n    correct: false\n")),
        LOCAL1,
        out=off,
        **QUIET,
    )
    a, b = rows_of(toy_run, "toy_offset"), rows_of(off, "toy_offset")
    assert list(a["task"]) == list(b["task"])
    assert list(a["truth_digest"]) == list(b["truth_digest"]) and list(a["noise_digest"]) == list(b["noise_digest"])
    after = a["task"].str.contains("--after--")
    assert (a.loc[after, "correction_deg"] != 0).all() and (b["correction_deg"] == 0).all()
    assert not a.loc[after, "rms_error_deg"].equals(b.loc[after, "rms_error_deg"])


def test_one_worker_two_workers_and_a_dask_cluster_give_the_same_bytes(toy_run, tmp_path):
    reference = (toy_run / "metrics.json").read_bytes()  # two local workers
    for name, choice in (("one", LOCAL1), ("dask", ExecutorChoice("dask", workers=2))):
        out = tmp_path / name
        run_campaign(parse_campaign(TOY), choice, out=out, **QUIET)
        assert (out / "metrics.json").read_bytes() == reference, name
