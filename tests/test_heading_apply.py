"""`aerotruth heading apply`: the tables `heading fit` learned on one period applied to the
reports of another (tests/obs_generator.py: an independent generator with a known
deviation), and the corrected wind against a hand-worked rotation."""

from __future__ import annotations

import math

import numpy as np
import obs_generator as gen
import pandas as pd
import pytest

from aerotruth.analysis.wind.apply import APPLY_COLUMNS, corrected_wind
from aerotruth.app.cli import main
from aerotruth.app.heading_apply import heading_apply_main
from aerotruth.app.heading_fit import heading_fit_main
from aerotruth.errors import DataError

TRUTHS = [gen.AircraftTruth("N401XJ", A=2.0, B=-3.0, C=1.5), gen.AircraftTruth("N402XJ", A=-1.0, B=1.0, C=2.5)]


@pytest.fixture(scope="module")
def periods(tmp_path_factory):
    """Two aircraft x 40 flights, split in time: tables fitted on the first half."""
    obs = gen.generate(TRUTHS, np.random.default_rng(5), flights=40)
    d = tmp_path_factory.mktemp("apply")
    late = obs["time"] >= obs["time"].quantile(0.5)
    obs[~late].to_csv(d / "fit.csv", index=False)
    obs[late].to_csv(d / "later.csv", index=False)
    assert heading_fit_main(str(d / "fit.csv"), str(d / "fitted")) == 0
    return d


def test_corrected_wind_is_the_air_vector_turned_by_the_correction():
    # heading north at 100 m/s, no wind: turned 90 deg clockwise the air vector points east,
    # so the recomputed wind is V_A - R(c) V_A = (-100, 100); a small c gives
    # (-V sin c, V (1 - cos c))
    e, n = corrected_wind(np.array([0.0]), np.array([0.0]), np.array([0.0]), np.array([100.0]), np.array([90.0]))
    assert (e[0], n[0]) == pytest.approx((-100.0, 100.0))
    e, n = corrected_wind(np.array([3.0]), np.array([-4.0]), np.array([0.0]), np.array([100.0]), np.array([2.0]))
    c = math.radians(2.0)
    assert (e[0], n[0]) == pytest.approx((3.0 - 100 * math.sin(c), -4.0 + 100 * (1 - math.cos(c))))


def test_tables_from_one_period_correct_the_next_out_of_sample(periods):
    d = periods
    assert heading_apply_main(str(d / "later.csv"), str(d / "fitted" / "deviation.csv"), str(d / "out")) == 0
    scores = pd.read_csv(d / "out" / "apply.csv").set_index("aircraft")
    assert list(scores.reset_index().columns) == list(APPLY_COLUMNS)
    for a in TRUTHS:  # 3-3.5 deg of deviation at ~280 kt: most of the transverse error goes
        s = scores.loc[a.aircraft]
        assert s["transverse_after_kt"] < 0.5 * s["transverse_before_kt"], s
        assert abs(s["longitudinal_after_kt"] - s["longitudinal_before_kt"]) < 0.1 * s["longitudinal_before_kt"]
    rows = pd.read_csv(d / "out" / "corrected.csv", dtype={"aircraft": str})
    used = rows["corrected"].to_numpy()
    assert used.any() and (rows.loc[~used, "correction_deg"] == 0).all()
    assert (rows.loc[~used, "wind_speed_kt_corrected"] == rows.loc[~used, "wind_speed_kt"]).all()
    # the correction applied is minus the hidden deviation at the report's heading (the
    # generator's, a function of the magnetic heading): table fit noise, the 8-point
    # interpolation (~4 % of the amplitude) and the ~1-deg declination shift
    truth = {a.aircraft: a for a in TRUTHS}
    for name, g in rows[used].groupby("aircraft"):
        z_mag = g["table_heading_deg"].to_numpy() - g["declination_deg"].to_numpy()  # deviation.csv: true heading
        err = g["correction_deg"].to_numpy() + truth[name].deviation(z_mag)
        assert np.sqrt(np.mean(err**2)) < 0.4, (name, np.sqrt(np.mean(err**2)))


def test_an_aircraft_without_a_table_is_left_as_reported(periods, tmp_path):
    d = periods
    dev = pd.read_csv(d / "fitted" / "deviation.csv")
    dev[dev["aircraft"] == "N401XJ"].to_csv(tmp_path / "one.csv", index=False)
    heading_apply_main(str(d / "later.csv"), str(tmp_path / "one.csv"), str(tmp_path / "out"))
    scores = pd.read_csv(tmp_path / "out" / "apply.csv").set_index("aircraft")
    assert scores.loc["N402XJ", "status"] == "no table"
    assert scores.loc["N402XJ", "rms_after_kt"] == pytest.approx(scores.loc["N402XJ", "rms_before_kt"])
    rows = pd.read_csv(tmp_path / "out" / "corrected.csv")
    assert not rows.loc[rows["aircraft"] == "N402XJ", "corrected"].any()
    # the fleet's row is over the aircraft with a table: N401XJ's reports alone
    assert scores.loc["all", "n_scored"] == scores.loc["N401XJ", "n_scored"]
    assert scores.loc["all", "rms_after_kt"] == pytest.approx(scores.loc["N401XJ", "rms_after_kt"])


def test_magnetic_tables_need_a_magnetic_heading_and_bad_tables_are_one_line(periods, tmp_path, capsys):
    d = periods
    later = pd.read_csv(d / "later.csv").drop(columns=["declination_deg"])
    later.to_csv(tmp_path / "no_dec.csv", index=False)
    with pytest.raises(DataError, match="magnetic heading"):
        heading_apply_main(str(tmp_path / "no_dec.csv"), str(d / "fitted" / "deviation_mag.csv"), str(tmp_path / "o1"))
    pd.read_csv(d / "fitted" / "deviation.csv").drop(columns=["lut_090_deg"]).to_csv(tmp_path / "cut.csv", index=False)
    assert (
        main(
            [
                "heading",
                "apply",
                str(d / "later.csv"),
                "--tables",
                str(tmp_path / "cut.csv"),
                "--out",
                str(tmp_path / "o2"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert "cut.csv" in err and "lut_090_deg" in err and len(err.splitlines()) == 1
    dev = pd.read_csv(d / "fitted" / "deviation.csv").astype({"lut_135_deg": object})
    dev.loc[1, "lut_135_deg"] = "unknown"
    dev.to_csv(tmp_path / "text.csv", index=False)
    assert (
        main(
            [
                "heading",
                "apply",
                str(d / "later.csv"),
                "--tables",
                str(tmp_path / "text.csv"),
                "--out",
                str(tmp_path / "o3"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert err.endswith("text.csv: table: aircraft 'N402XJ', column 'lut_135_deg': expected a number, got 'unknown'"), (
        err
    )
    dev.loc[1, "lut_135_deg"] = "n/a"  # read as empty: a fitted table without one of its corrections
    dev.to_csv(tmp_path / "empty.csv", index=False)
    assert (
        main(
            [
                "heading",
                "apply",
                str(d / "later.csv"),
                "--tables",
                str(tmp_path / "empty.csv"),
                "--out",
                str(tmp_path / "o4"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert err.endswith(
        "empty.csv: table: aircraft 'N402XJ' (fitted), column 'lut_135_deg': empty; a table that "
        "is not refused needs all eight corrections"
    ), err


def test_fit_and_apply_say_what_they_wrote_in_one_line(periods, tmp_path, capsys):
    d = periods
    assert main(["heading", "fit", str(d / "fit.csv"), "--out", str(tmp_path / "f"), "--bootstrap", "0"]) == 0
    assert (
        capsys.readouterr().out.strip()
        == f"{d / 'fit.csv'}: 2 aircraft: 2 fitted, 0 offset_only, 0 refused -> {tmp_path / 'f' / 'deviation.csv'}"
    )
    assert (
        main(
            [
                "heading",
                "apply",
                str(d / "later.csv"),
                "--tables",
                str(tmp_path / "f" / "deviation.csv"),
                "--out",
                str(tmp_path / "a"),
            ]
        )
        == 0
    )
    every = pd.read_csv(tmp_path / "a" / "apply.csv").set_index("aircraft").loc["all"]
    assert capsys.readouterr().out.strip() == (
        f"{d / 'later.csv'}: 2 aircraft, {int(every['n_scored'])} scored (report, reference) rows of aircraft with a "
        f"table; wind RMS {every['rms_before_kt']:.2f} -> {every['rms_after_kt']:.2f} kt "
        f"with the tables of {tmp_path / 'f' / 'deviation.csv'} "
        f"-> {tmp_path / 'a' / 'apply.csv'}"
    )
    assert every["rms_after_kt"] < every["rms_before_kt"]


def test_a_bootstrap_of_one_resample_is_refused_in_one_line(tmp_path, capsys):
    assert main(["heading", "fit", str(tmp_path / "obs.csv"), "--out", str(tmp_path / "o"), "--bootstrap", "1"]) == 2
    err = capsys.readouterr().err.strip()
    assert "--bootstrap" in err and len(err.splitlines()) == 1


def test_magnetic_tables_are_read_at_the_magnetic_heading(periods, tmp_path):
    # deviation_mag.csv is indexed by the magnetic heading, the generator's own frame: the
    # applied correction is minus the hidden deviation at the heading the table was read at
    d = periods
    heading_apply_main(str(d / "later.csv"), str(d / "fitted" / "deviation_mag.csv"), str(tmp_path / "out"))
    rows = pd.read_csv(tmp_path / "out" / "corrected.csv", dtype={"aircraft": str})
    truth = {a.aircraft: a for a in TRUTHS}
    for name, g in rows[rows["corrected"]].groupby("aircraft"):
        err = g["correction_deg"].to_numpy() + truth[name].deviation(g["table_heading_deg"].to_numpy())
        assert np.sqrt(np.mean(err**2)) < 0.4, (name, np.sqrt(np.mean(err**2)))
    # and the magnetic heading is the true one less the declination (east positive), row by row
    heading_apply_main(str(d / "later.csv"), str(d / "fitted" / "deviation.csv"), str(tmp_path / "true"))
    true_rows = pd.read_csv(tmp_path / "true" / "corrected.csv", dtype={"aircraft": str})
    both = rows["corrected"] & true_rows["corrected"]
    diff = (
        true_rows.loc[both, "table_heading_deg"]
        - rows.loc[both, "table_heading_deg"]
        - rows.loc[both, "declination_deg"]
        + 180
    ) % 360 - 180
    assert both.sum() > 1000 and np.abs(diff).max() < 1e-6


def test_reports_that_pass_no_gate_are_one_line(periods, tmp_path, capsys):
    # every report its own aircraft: no three-report track anywhere
    later = pd.read_csv(periods / "later.csv")
    later.assign(aircraft=[f"X{i}" for i in range(len(later))]).to_csv(tmp_path / "scattered.csv", index=False)
    assert (
        main(
            [
                "heading",
                "apply",
                str(tmp_path / "scattered.csv"),
                "--tables",
                str(periods / "fitted" / "deviation.csv"),
                "--out",
                str(tmp_path / "o"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert "no report passes the ground-track gates" in err and len(err.splitlines()) == 1


def test_an_aircraft_named_all_keeps_its_own_row_before_the_fleets(periods, tmp_path):
    # the fleet's row is "all", always last: an aircraft of that name gets its own row and
    # the same scores and status as under another name
    d = periods
    for f in ("fit.csv", "later.csv"):
        t = pd.read_csv(d / f)
        t.loc[t["aircraft"] == "N401XJ", "aircraft"] = "all"
        t.to_csv(tmp_path / f, index=False)
    assert heading_fit_main(str(tmp_path / "fit.csv"), str(tmp_path / "fitted")) == 0
    assert (
        heading_apply_main(
            str(tmp_path / "later.csv"), str(tmp_path / "fitted" / "deviation.csv"), str(tmp_path / "out")
        )
        == 0
    )
    assert heading_apply_main(str(d / "later.csv"), str(d / "fitted" / "deviation.csv"), str(tmp_path / "ref")) == 0
    renamed, ref = pd.read_csv(tmp_path / "out" / "apply.csv"), pd.read_csv(tmp_path / "ref" / "apply.csv")
    assert list(renamed["aircraft"]) == ["all", "N402XJ", "all"] and list(ref["aircraft"]) == [
        "N401XJ",
        "N402XJ",
        "all",
    ]
    cols = ["status", "n_scored", "rms_before_kt", "rms_after_kt", "valid_from", "valid_to"]
    pd.testing.assert_frame_equal(renamed[cols], ref[cols])
    assert renamed["n_scored"].iloc[-1] == renamed["n_scored"].iloc[:-1].sum()


def test_a_table_correction_beyond_any_accepted_heading_error_is_refused(periods, tmp_path, capsys):
    d = periods
    dev = pd.read_csv(d / "fitted" / "deviation.csv")
    dev.loc[0, "lut_045_deg"] = 45.0  # the method drops |psi - psi'| > 30 deg as a gross error
    dev.to_csv(tmp_path / "big.csv", index=False)
    assert (
        main(
            [
                "heading",
                "apply",
                str(d / "later.csv"),
                "--tables",
                str(tmp_path / "big.csv"),
                "--out",
                str(tmp_path / "o"),
            ]
        )
        == 2
    )
    err = capsys.readouterr().err.strip()
    assert "big.csv" in err and "'N401XJ'" in err and "lut_045_deg" in err and "45 deg" in err, err
    assert len(err.splitlines()) == 1
    # large but possible: applied (a table of its coefficients: an offset of 29.5 deg, every entry -29.5)
    dev.loc[0, ["A_deg", "B_deg", "C_deg", "D_deg", "E_deg"]] = [29.5, 0.0, 0.0, 0.0, 0.0]
    dev.loc[0, [f"lut_{k:03d}_deg" for k in range(0, 360, 45)]] = -29.5
    dev.to_csv(tmp_path / "large.csv", index=False)
    assert (
        main(
            [
                "heading",
                "apply",
                str(d / "later.csv"),
                "--tables",
                str(tmp_path / "large.csv"),
                "--out",
                str(tmp_path / "o2"),
            ]
        )
        == 0
    )
