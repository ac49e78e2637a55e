"""A user's CSV read as written (aerotruth.measured.tables): labels stay text, the separator is the
header's; through `aerotruth heading fit`, `fits`' log reader and `diagnose`'s loader."""

from __future__ import annotations

import numpy as np
import obs_generator as gen
import pandas as pd
import pytest

from aerotruth.analysis.wind.observations import validate_observations
from aerotruth.app.heading_fit import heading_fit_main
from aerotruth.measured.kinds import load_measured
from aerotruth.measured.observations import read_observation_file, read_observation_table
from aerotruth.measured.tables import csv_separator, read_csv_table


def _obs() -> pd.DataFrame:
    return gen.generate(
        [gen.AircraftTruth("N470XJ", A=-3.0, B=1.5, C=0.0, cruise_tas_kt=280.0)], np.random.default_rng(12), flights=8
    )


@pytest.mark.parametrize("header, sep", [("a,b;c", ","), ("a;b;c", ";"), ("a\tb\tc", "\t"), ("a", ",")])
def test_separator_is_the_headers(header, sep):
    assert csv_separator(header) == sep


def test_labels_stay_text_and_numbers_stay_numbers(tmp_path):
    p = tmp_path / "t.csv"
    p.write_text("aircraft,heading_input,flight,lat\n0511,true,007,61.2\n0511,true,007,61.3\n")
    df = read_csv_table(p)
    assert df["aircraft"].tolist() == ["0511", "0511"]  # not 511
    assert df["heading_input"].tolist() == ["true", "true"]  # not the boolean True
    assert df["flight"].tolist() == ["007", "007"]
    assert df["lat"].tolist() == [61.2, 61.3]


def test_an_all_true_heading_fleet_in_csv_gets_offset_only_tables(tmp_path):
    # every row "true": pandas alone reads the column as booleans, which the method refused
    obs = _obs().assign(heading_input="true")
    obs.to_csv(tmp_path / "obs.csv", index=False)
    heading_fit_main(str(tmp_path / "obs.csv"), str(tmp_path / "out"))
    dev = pd.read_csv(tmp_path / "out" / "deviation.csv")
    assert dev["status"].tolist() == ["offset_only"] and "true heading" in dev["reason"].iloc[0]


def test_heading_input_is_a_word_in_any_case(tmp_path):
    obs = _obs().assign(heading_input="TRUE")
    obs.to_csv(tmp_path / "obs.csv", index=False)
    assert list(read_observation_table(tmp_path / "obs.csv")["heading_input"].unique()) == ["true"]


@pytest.mark.parametrize("suffix", [".csv", ".parquet"])
def test_labels_read_as_categories_validate_to_the_table_of_labels_read_as_text(tmp_path, suffix):
    """A Parquet file's labels are read once each (categoricals from its dictionary pages),
    a CSV file's as text ("0511" and " 0511" stay text: pandas' "category" dtype would make
    both the number 511); validation then gives the table that labels read as plain text
    give (pandas' own reader, dtype str)."""
    obs = _obs()
    obs["aircraft"] = np.where(np.arange(len(obs)) % 3 == 0, " 0511", "0511")
    # an empty reference label on some of one model's rows (emptying both models' rows of one
    # report would make two conflicting rows of one label, which the reader refuses)
    obs["ref_source"] = np.where((np.arange(len(obs)) % 5 == 0) & (obs["ref_source"] == "rr"), None, obs["ref_source"])
    obs["flight"] = (np.arange(len(obs)) // 40).astype(str)
    path = tmp_path / f"obs{suffix}"
    if suffix == ".csv":
        obs.to_csv(path, index=False)
        text = pd.read_csv(path, dtype={c: str for c in ("aircraft", "ref_source", "flight", "phase")})
    else:
        obs.to_parquet(path)
        text = pd.read_parquet(path)
    raw = read_observation_file(path)
    assert isinstance(raw["aircraft"].dtype, pd.CategoricalDtype) == (suffix == ".parquet")
    assert sorted(raw["aircraft"].unique()) == [" 0511", "0511"]
    got = read_observation_table(path)
    pd.testing.assert_frame_equal(got, validate_observations(text, str(path)))
    assert got["aircraft"].unique().tolist() == ["0511"] and got["flight"].nunique() == obs["flight"].nunique()


@pytest.mark.parametrize("sep", [";", "\t"])
def test_semicolon_and_tab_separated_tables_read_like_the_comma_one(tmp_path, sep):
    obs = _obs()
    obs.to_csv(tmp_path / "comma.csv", index=False)
    obs.to_csv(tmp_path / "other.csv", index=False, sep=sep)
    a, b = read_observation_table(tmp_path / "comma.csv"), read_observation_table(tmp_path / "other.csv")
    pd.testing.assert_frame_equal(a, b)
    assert load_measured(tmp_path / "other.csv").kind == "observation_table"


@pytest.mark.parametrize("sep", [";", "\t"])
def test_decimal_commas_in_a_semicolon_or_tab_table_read_as_numbers(tmp_path, sep):
    # a spreadsheet in a decimal-comma locale: `;` between fields, `61,2` in them
    obs = _obs()
    obs.to_csv(tmp_path / "comma.csv", index=False)
    obs.to_csv(tmp_path / "locale.csv", index=False, sep=sep, decimal=",")
    assert "," in (tmp_path / "locale.csv").read_text().splitlines()[1]
    a, b = read_observation_table(tmp_path / "comma.csv"), read_observation_table(tmp_path / "locale.csv")
    pd.testing.assert_frame_equal(a, b)


def test_decimal_commas_by_hand():
    df = read_csv_table(b"aircraft;lat;lon;n;e\n0511;61,2;-149,9;1;1,5e-3\n0511;;-150;2;,5\n")
    assert df["aircraft"].tolist() == ["0511", "0511"]
    assert df["lat"].iloc[0] == 61.2 and np.isnan(df["lat"].iloc[1])
    assert df["lon"].tolist() == [-149.9, -150.0]
    assert df["e"].tolist() == [0.0015, 0.5]


@pytest.mark.parametrize("cell", ["1.234,5", "61.25"])
def test_a_column_not_all_decimal_commas_is_not_guessed(tmp_path, cell):
    # grouped thousands, or a point beside commas in one column: named by the number check
    obs = _obs()
    obs.to_csv(tmp_path / "locale.csv", index=False, sep=";", decimal=",")
    lines = (tmp_path / "locale.csv").read_text().splitlines()
    header = lines[0].split(";")
    row = lines[1].split(";")
    row[header.index("lat")] = cell
    lines[1] = ";".join(row)
    (tmp_path / "locale.csv").write_text("\n".join(lines) + "\n")
    assert read_csv_table(tmp_path / "locale.csv")["lat"].dtype != float
    with pytest.raises(ValueError, match="lat"):
        read_observation_table(tmp_path / "locale.csv")


def test_signed_directions_read_as_the_same_directions(tmp_path):
    """Headings and wind angles written signed, (-180, 180] (ARINC 429's binary labels 314,
    320, 322), validate to the table written in [0, 360); below -180 is still an error."""
    obs = _obs()
    obs["heading_deg"] = (obs["time"] * 0.37) % 360  # the generator writes none: any per-report values
    obs["heading_mag_deg"] = (obs["heading_deg"] - 12.0) % 360
    signed = obs.copy()
    for c in ("heading_deg", "heading_mag_deg", "wind_dir_deg", "ref_wind_dir_deg"):
        signed[c] = (obs[c] + 180.0) % 360 - 180.0
        assert (signed[c] < 0).any()
    obs.to_csv(tmp_path / "plain.csv", index=False)
    signed.to_csv(tmp_path / "signed.csv", index=False)
    a, b = read_observation_table(tmp_path / "plain.csv"), read_observation_table(tmp_path / "signed.csv")
    pd.testing.assert_frame_equal(a, b, check_exact=False, atol=1e-9, rtol=0)
    signed.loc[3, "heading_deg"] = -190.0
    signed.to_csv(tmp_path / "bad.csv", index=False)
    with pytest.raises(ValueError, match=r"bad\.csv: column 'heading_deg', data row 4: -190 outside"):
        read_observation_table(tmp_path / "bad.csv")


def test_a_gzip_compressed_csv_reads_as_the_plain_one(tmp_path):
    """`.csv.gz` (and gzip content under any name: recognised by its magic bytes) reads as
    the plain file; a cut stream is one error naming the file."""
    import gzip

    obs = _obs()
    obs.to_csv(tmp_path / "plain.csv", index=False)
    data = gzip.compress((tmp_path / "plain.csv").read_bytes())
    (tmp_path / "obs.csv.gz").write_bytes(data)
    (tmp_path / "zipped.csv").write_bytes(data)
    want = read_observation_table(tmp_path / "plain.csv")
    for name in ("obs.csv.gz", "zipped.csv"):
        pd.testing.assert_frame_equal(read_observation_table(tmp_path / name), want)
    assert read_csv_table(data).equals(read_csv_table(tmp_path / "plain.csv"))
    (tmp_path / "cut.csv.gz").write_bytes(data[: len(data) // 2])
    with pytest.raises(ValueError, match=r"cut\.csv\.gz: not a readable CSV table") as e:
        read_observation_table(tmp_path / "cut.csv.gz")
    assert "\n" not in str(e.value)


def test_a_gzip_compressed_approach_log_reads_as_the_plain_one(tmp_path):
    import approach_log_generator as alg

    from aerotruth.measured.approach_log import read_approach_log

    log, _ = alg.make_log(1, 5)
    log.to_csv(tmp_path / "log.csv", index=False)
    log.to_csv(tmp_path / "log.csv.gz", index=False)  # pandas compresses by the name
    pd.testing.assert_frame_equal(read_approach_log(tmp_path / "log.csv.gz"), read_approach_log(tmp_path / "log.csv"))
