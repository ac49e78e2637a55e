"""Nothing silently wrong (issue 51): a value that the readers would otherwise take for
something else is one line naming the file, the row and the column, exit status 2.

* deviation tables (`heading apply`): a heading frame other than `true` or `magnetic`
  (taken for magnetic it turns every heading by the declination), dates that are none;
* observation tables: two rows of one (aircraft, time, reference) with different values
  (exact repeats are still dropped and counted), times outside the dates aerotruth models;
* `heading fit`'s figures: aircraft ids that clean to one file name, or are long, get
  unique bounded names, listed in report.md;
* approach logs (`fits`, `diagnose`): a TVPS or radar altimeter read in feet, an INS axis
  of the other sign (on short approaches too, where the frame check of 3 approaches and a
  metre of motion cannot see it), lever arms no airframe has;
* command-line numbers: `fits --ra-lever-arm`, `heading fit --seed/--bootstrap`."""

from __future__ import annotations

import datetime as dt
import re

import approach_log_generator as alg
import numpy as np
import obs_generator as gen
import pandas as pd
import pytest

from aerotruth.analysis.wind.observations import validate_observations
from aerotruth.app.cli import main
from aerotruth.app.heading_fit import MAX_FIGURE_STEM, figure_stems
from aerotruth.errors import DataError
from aerotruth.measured.approach_log import read_approach_log
from aerotruth.measured.deviation_tables import read_tables

TRUTHS = [gen.AircraftTruth("N401XJ", A=2.0, B=-3.0, C=1.5), gen.AircraftTruth("N402XJ", A=-1.0, B=1.0, C=2.5)]


def one_line(capsys, argv) -> str:
    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    return err


# ---- deviation tables


@pytest.fixture(scope="module")
def fitted(tmp_path_factory):
    """deviation.csv of two aircraft (fitted on their first half) and the later reports."""
    obs = gen.generate(TRUTHS, np.random.default_rng(5), flights=24)
    d = tmp_path_factory.mktemp("tables")
    late = obs["time"] >= obs["time"].quantile(0.5)
    obs[~late].to_csv(d / "fit.csv", index=False)
    obs[late].to_csv(d / "later.csv", index=False)
    assert main(["heading", "fit", str(d / "fit.csv"), "--out", str(d / "fitted"), "--bootstrap", "0"]) == 0
    return d


@pytest.mark.parametrize(
    "frame, shown",
    [
        ("sideways", "'sideways'"),
        ("true ", "'true '"),
        (" magnetic", "' magnetic'"),
        ("", "an empty cell"),
        ("false", "'false'"),
        ("Magnetic", "'Magnetic'"),
    ],
)
def test_a_heading_frame_other_than_true_or_magnetic_is_refused_naming_the_aircraft(
    fitted, tmp_path, capsys, frame, shown
):
    dev = pd.read_csv(fitted / "fitted" / "deviation.csv", dtype={"heading_frame": str}, keep_default_na=False)
    dev.loc[dev["aircraft"] == "N402XJ", "heading_frame"] = frame
    bad = tmp_path / "deviation.csv"
    dev.to_csv(bad, index=False)
    err = one_line(capsys, ["heading", "apply", fitted / "later.csv", "--tables", bad, "--out", tmp_path / "out"])
    assert f"{bad}: table: aircraft 'N402XJ', column 'heading_frame': {shown}; expected 'true' or 'magnetic'" in err
    assert not (tmp_path / "out").exists()


def test_the_frames_heading_fit_writes_are_read(fitted, tmp_path):
    assert {f.heading for f in read_tables(fitted / "fitted" / "deviation.csv").fits_.values()} == {"true"}
    dev = pd.read_csv(fitted / "fitted" / "deviation.csv")
    dev.assign(heading_frame="magnetic").to_csv(tmp_path / "mag.csv", index=False)
    assert {f.heading for f in read_tables(tmp_path / "mag.csv").fits_.values()} == {"magnetic"}
    dev.drop(columns=["heading_frame"]).to_csv(tmp_path / "old.csv", index=False)  # before the column existed
    assert {f.heading for f in read_tables(tmp_path / "old.csv").fits_.values()} == {"true"}


@pytest.mark.parametrize(
    "column, value, message",
    [
        ("valid_from", "2009-13-45", r"column 'valid_from': '2009-13-45' is not a date; expected YYYY-MM-DD"),
        ("valid_from", "yesterday", r"column 'valid_from': 'yesterday' is not a date"),
        ("valid_to", "", r"column 'valid_to': empty; a \w+ table needs its dates"),
        ("valid_from", "1850-01-01", r"column 'valid_from': expected a date from 1900-01-01 to 2029-12-31"),
        ("valid_from", "2029-12-31", r"columns 'valid_from'/'valid_to': 2029-12-31 is after"),
        ("data_from", "soon", r"column 'data_from': 'soon' is not a time; expected ISO 8601"),
        ("data_to", "2000-01-01T00:00:00Z", r"columns 'data_from'/'data_to': .* is after"),
    ],
)
def test_a_table_date_that_is_none_is_one_line(fitted, tmp_path, capsys, column, value, message):
    dev = pd.read_csv(fitted / "fitted" / "deviation.csv", dtype=str, keep_default_na=False)
    dev.loc[dev["aircraft"] == "N401XJ", column] = value
    bad = tmp_path / "deviation.csv"
    dev.to_csv(bad, index=False)
    err = one_line(capsys, ["heading", "apply", fitted / "later.csv", "--tables", bad, "--out", tmp_path / "out"])
    assert re.search(rf"{re.escape(str(bad))}: aircraft 'N401XJ', {message}", err), err


# ---- observation tables


def _obs(flights: int = 6) -> pd.DataFrame:
    return gen.generate(TRUTHS[:1], np.random.default_rng(7), flights=flights)


def test_conflicting_repeats_of_a_report_are_refused_naming_the_first(fitted, tmp_path, capsys):
    obs = _obs()
    twin = obs.iloc[[10]].assign(wind_speed_kt=obs["wind_speed_kt"].iloc[10] + 7.0)
    bad = pd.concat([obs, twin], ignore_index=True)
    with pytest.raises(DataError) as e:
        validate_observations(bad, "obs.csv")
    when = dt.datetime.fromtimestamp(obs["time"].iloc[10], tz=dt.UTC).isoformat().replace("+00:00", "Z")
    text = str(e.value)
    assert f"obs.csv: data rows 11 and {len(bad)} are one report (aircraft N401XJ, time {when}" in text
    assert f"ref_source {obs['ref_source'].iloc[10]}) with different 'wind_speed_kt'" in text
    bad.to_csv(tmp_path / "obs.csv", index=False)
    err = one_line(capsys, ["diagnose", tmp_path / "obs.csv", "--out", tmp_path / "out"])
    assert "different 'wind_speed_kt'" in err and not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", ["fit", "apply"])
def test_heading_fit_and_apply_say_the_observation_tables_own_refusal(fitted, tmp_path, capsys, command):
    obs = _obs()
    pd.concat([obs, obs.iloc[[10]].assign(wind_speed_kt=1.0)]).to_csv(tmp_path / "obs.csv", index=False)
    tables = ["--tables", fitted / "fitted" / "deviation.csv"] if command == "apply" else []
    err = one_line(capsys, ["heading", command, tmp_path / "obs.csv", *tables, "--out", tmp_path / "out"])
    assert "different 'wind_speed_kt'" in err


@pytest.mark.parametrize("column", ["ref_wind_dir_deg", "lat", "declination_deg", "heading_input"])
def test_a_repeat_differing_in_any_column_is_a_conflict(column):
    obs = _obs().assign(heading_input="magnetic")
    twin = obs.iloc[[3]].copy()
    twin[column] = "true" if column == "heading_input" else twin[column] + 0.25
    with pytest.raises(DataError, match=f"with different '{column}'"):
        validate_observations(pd.concat([obs, twin], ignore_index=True), "obs")


def test_exact_repeats_are_dropped_and_counted():
    obs = _obs()
    doubled = pd.concat([obs, obs.iloc[:25]], ignore_index=True)
    got = validate_observations(doubled, "obs")
    assert got.attrs["dropped_duplicates"] == 25
    pd.testing.assert_frame_equal(got, validate_observations(obs, "obs"), check_like=False)


@pytest.mark.parametrize("when", ["1899-12-31T12:00:00Z", "2030-01-01T00:00:00Z", -2208988801.0, 1.9e9])
def test_a_report_time_outside_the_modelled_dates_is_refused(when):
    obs = _obs()
    obs["time"] = obs["time"].astype(object)
    obs.loc[4, "time"] = when
    with pytest.raises(DataError, match=r"obs: column 'time', data row 5: .* not a time from 1900-01-01 to 2029-12-31"):
        validate_observations(obs, "obs")


def test_epoch_milliseconds_are_said():
    obs = _obs().assign(time=lambda d: (d["time"] * 1000).astype("int64"))
    with pytest.raises(DataError, match=r"data row 1: .* epoch seconds \(milliseconds\?\)"):
        validate_observations(obs, "obs")


# ---- heading fit's figures


def test_figure_names_are_unique_bounded_and_keep_plain_ids():
    ids = ["N401/XJ", "N401_XJ", "N401 XJ", "n401_xj", "x" * 300, "", "aircraft", ".hidden", "N402XJ", "../etc"]
    stems = figure_stems(ids)
    assert len({s.casefold() for s in stems.values()}) == len(ids)
    assert all(re.fullmatch(r"[A-Za-z0-9_.-]+", s) and not s.startswith(".") for s in stems.values())
    assert max(map(len, stems.values())) <= MAX_FIGURE_STEM
    assert stems["N402XJ"] == "N402XJ" and stems["aircraft"] == "aircraft" and stems["../etc"] == "_._etc"
    assert stems["N401/XJ"].startswith("N401_XJ-") and stems["x" * 300].startswith("x" * 60)
    assert figure_stems(list(reversed(ids))) == stems  # not a matter of order


def test_aircraft_ids_that_clean_to_one_name_or_are_long_each_get_their_figure(tmp_path):
    long_id = "N" + "7" * 299
    names = ["N401/XJ", "N401_XJ", long_id]
    obs = gen.generate(
        [gen.AircraftTruth(n, A=1.0, B=-2.0, C=1.0) for n in names], np.random.default_rng(9), flights=12
    )
    obs.to_csv(tmp_path / "obs.csv", index=False)
    assert main(["heading", "fit", str(tmp_path / "obs.csv"), "--out", str(tmp_path / "out"), "--bootstrap", "0"]) == 0
    figures = sorted(p.name for p in (tmp_path / "out" / "figures").iterdir())
    assert len(figures) == 3 and all(len(f) <= MAX_FIGURE_STEM + 4 for f in figures)
    report = (tmp_path / "out" / "report.md").read_text()
    for name in names:
        assert f"* `{name}`: [figures/{figure_stems(names)[name]}.png]" in report
    assert len(pd.read_csv(tmp_path / "out" / "deviation.csv")) == 3


@pytest.mark.parametrize(
    "option, value, message",
    [("--seed", "-1", "--seed: expected"), ("--bootstrap", "1000000000", "--bootstrap: expected at most")],
)
def test_heading_fit_refuses_a_negative_seed_and_a_huge_bootstrap(tmp_path, capsys, option, value, message):
    _obs().to_csv(tmp_path / "obs.csv", index=False)
    err = one_line(capsys, ["heading", "fit", tmp_path / "obs.csv", "--out", tmp_path / "out", option, value])
    assert message in err and not (tmp_path / "out").exists()


# ---- approach logs


def _log(tmp_path, log: pd.DataFrame, name: str = "log.csv"):
    path = tmp_path / name
    log.to_csv(path, index=False)
    return path


@pytest.mark.parametrize("value", ["1e9", "nan", "inf", "-inf", "-11"])
def test_fits_refuses_a_lever_arm_no_airframe_has(tmp_path, capsys, value):
    """Refused by the option's parser with the bounds FitsSpec declares (argparse's usage
    line before it: the parser's one-line errors are app/cli.py's)."""
    with pytest.raises(SystemExit) as e:
        main(["fits", str(tmp_path / "log.csv"), "--out", str(tmp_path / "out"), f"--ra-lever-arm={value}"])
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert (
        f"argument --ra-lever-arm: expected -10 to 10 m (height of the position reference point above the RA "
        f"antenna), got {value!r}"
        in err
        and "Traceback" not in err
    )


@pytest.mark.parametrize(
    "column, value, message",
    [
        ("ra_lever_arm_m", 1e9, r"column 'ra_lever_arm_m' data row 1: 1e\+09 m; expected -10 to 10 m"),
        ("ra_lever_arm_m", np.inf, r"column 'ra_lever_arm_m' data row 1: inf m; expected -10 to 10 m"),
        ("tvps_lever_arm_m", -500.0, r"column 'tvps_lever_arm_m' data row 1: -500 m; expected -40 to 40 m"),
    ],
)
def test_a_lever_arm_column_no_airframe_has_is_named_not_blamed_on_the_ra(tmp_path, capsys, column, value, message):
    log, _ = alg.make_log(2, seed=23)
    path = _log(tmp_path, log.assign(**{column: value}))
    err = one_line(capsys, ["fits", path, "--out", tmp_path / "out"])
    assert re.search(message, err) and "feet" not in err, err
    assert not (tmp_path / "out").exists()


def test_a_tvps_in_feet_is_refused_naming_the_column(tmp_path, capsys):
    """Approaches crossing the threshold 3 m (sd) off the centreline: the TVPS reads 3.28
    times the DGPS's cross-track."""
    log, _ = alg.make_log(4, seed=31, threshold_y_sd_m=3.0)
    path = _log(tmp_path, log.assign(tvps_y_m=log["tvps_y_m"] / 0.3048))
    for command in (["fits", path, "--out", tmp_path / "out"], ["diagnose", path, "--out", tmp_path / "dia"]):
        err = one_line(capsys, command)
        assert re.search(r"log\.csv: column 'tvps_y_m': it reads 3\.\d+ \+- 0\.\d+ times the cross-track", err), err
        assert "dgps_y_m" in err and "in feet (3.281 times the metres)? expected metres" in err
    assert not (tmp_path / "out").exists() and not (tmp_path / "dia").exists()


def test_a_radar_altimeter_in_feet_on_a_low_pass_is_refused(tmp_path, capsys):
    """Heights of 1-3 m over the runway (a touch-and-go): in feet the median gap to the
    WAAS height stays under the 10 m the contract's check allows; the scale does not."""
    log, _ = alg.make_log(4, seed=32)
    low = log["ra_m"].to_numpy() * 0.2  # the pass flown at a fifth of the height
    shift = log["ra_m"].to_numpy() - low
    log = log.assign(
        ra_m=low / 0.3048,
        **{c: log[c] - np.nan_to_num(shift) for c in ("waas_z_m", "ins_z_m", "dgps_z_m")},
    )
    err = one_line(capsys, ["fits", _log(tmp_path, log), "--out", tmp_path / "out"])
    assert "column 'ra_m': it reads 3." in err and "height over the runway of dgps_z_m" in err and "in feet" in err


@pytest.mark.parametrize("n", [1, 4])
def test_an_ins_y_of_the_other_sign_on_short_approaches_is_refused(tmp_path, capsys, n):
    """Approaches of 58 WAAS epochs (under the 60 the 3-approach frame check needs): the
    flipped axis costs the FITS 0.4 m of cross-track against 0.07 m, and the reader names it."""
    log, _ = alg.make_log(n, seed=33, before_s=50.0, after_s=8.0)
    path = _log(tmp_path, log.assign(ins_y_m=-log["ins_y_m"]))
    for command in (["fits", path, "--out", tmp_path / "out"], ["diagnose", path, "--out", tmp_path / "dia"]):
        err = one_line(capsys, command)
        assert "columns ins_x_m/ins_y_m/ins_z_m: ins_y_m has the opposite sign" in err, err
        assert f"over {n} approach" in err and "expected the runway frame" in err


@pytest.mark.parametrize("seed", range(40, 46))
@pytest.mark.parametrize(
    "kw",
    [
        {},
        {"before_s": 50.0, "after_s": 8.0},
        {"threshold_y_sd_m": 3.0, "rate_hz": 1},
        {"unflagged_jump": (20.0, np.full(3, 1.5)), "before_s": 50.0, "after_s": 8.0},
        {"ins_bias_scale": 3.0, "jumps_per_s": 1 / 60.0},
    ],
    ids=["standard", "short", "offset 1 Hz", "unflagged jump", "poor INS"],
)
def test_sound_logs_pass_the_physics_checks(tmp_path, seed, kw):
    log, _ = alg.make_log(1 + seed % 4, seed=seed, **kw)
    read_approach_log(_log(tmp_path, log))
    read_approach_log(_log(tmp_path, log.drop(columns=["dgps_x_m", "dgps_y_m", "dgps_z_m"]), "nodgps.csv"))
