"""Campaign schema: every error path gives one line naming the YAML path, what was
expected and the line of the file; valid files resolve with their defaults."""

from __future__ import annotations

import datetime as dt

import pytest

from aerotruth.app.cli import main
from aerotruth.sim.campaign_file import ConfigError
from aerotruth.sim.campaign_loader import load_campaign, parse_campaign
from aerotruth.sim.studies import builtin_sources

BUILTIN = ", ".join(sorted(builtin_sources()))  # the installed built-in studies, as the message lists them

VALID = """\
name: t1
seed: 5
fleets:
  - name: north
    network: mesaba
    aircraft: [N401XJ, N402XJ]
  - name: alaska
    network: penair
    aircraft: [N672PA]
periods:
  - name: aug
    dates: [2009-08-15, 2009-08-16]
  - name: sep
    start: 2009-09-01
    end: 2009-09-03
studies:
  truth:
    fleets: [north, alaska]
    periods: [aug]
    max_legs_per_day: 2
  wind_climatology:
    regions:
      - {name: midwest, lat_deg: [43, 49], lon_deg: [-97, -88]}
      - {name: alaska, network: penair}
    periods: [sep]
    flight_levels: [100, 200]
"""


def line_of(text: str, needle: str) -> int:
    """1-based line of the first line containing `needle` (the independent expectation)."""
    return next(i for i, line in enumerate(text.splitlines(), 1) if needle in line)


def error_of(text: str) -> str:
    with pytest.raises(ConfigError) as e:
        parse_campaign(text)
    msg = str(e.value)
    assert "\n" not in msg
    return msg


def test_valid_campaign_resolves_defaults_and_period_days():
    c = parse_campaign(VALID)
    assert c.executor.kind == "local" and c.outputs.report is True
    assert c.period("sep").days() == [dt.date(2009, 9, 1), dt.date(2009, 9, 2), dt.date(2009, 9, 3)]
    assert c.studies["wind_climatology"].hours_utc == [0.0, 6.0, 12.0, 18.0]
    assert list(c.studies) == ["truth", "wind_climatology"]


def test_resolved_yaml_reads_back_to_the_same_campaign_and_hash():
    c = parse_campaign(VALID)
    again = parse_campaign(c.to_yaml())
    assert again == c
    assert again.config_hash() == c.config_hash()


def test_config_hash_ignores_executor_and_outputs_but_not_seed():
    base = parse_campaign(VALID).config_hash()
    assert (
        parse_campaign(VALID + "executor: {kind: dask, workers: 3}\noutputs: {report: false}\n").config_hash() == base
    )
    assert parse_campaign(VALID.replace("seed: 5", "seed: 6")).config_hash() != base


def test_wrong_type_names_path_value_and_line():
    text = VALID.replace("flight_levels: [100, 200]", "flight_levels: [100, abc]")
    assert (
        error_of(text) == 'studies.wind_climatology.flight_levels[1]: expected an integer, got "abc" '
        f"(line {line_of(text, 'flight_levels')})"
    )


def test_wrong_type_of_a_string_field():
    text = VALID.replace("aircraft: [N672PA]", "aircraft: [N672PA, 17]")
    assert error_of(text) == f"fleets[1].aircraft[1]: expected a string, got 17 (line {line_of(text, 'N672PA, 17')})"


def test_unknown_key_names_allowed_keys_and_its_line():
    text = VALID.replace("    network: penair\n", "    network: penair\n    hard_iron_nT: 3\n")
    msg = error_of(text)
    assert msg.startswith("fleets[1].hard_iron_nT: unknown key (allowed: name, aircraft_type, network, aircraft)")
    assert msg.endswith(f"(line {line_of(text, 'hard_iron_nT')})")


def test_missing_required_field_points_at_its_parent():
    text = VALID.replace("seed: 5\n", "")
    assert error_of(text) == "seed: required field missing (line 1)"
    text = VALID.replace("  - name: alaska\n    network: penair\n", "  - network: penair\n")
    assert error_of(text) == f"fleets[1].name: required field missing (line {line_of(text, '- network: penair')})"


def test_bad_date_is_reported_by_path_not_by_the_yaml_parser():
    text = VALID.replace("2009-08-16", "2009-02-30")
    assert (
        error_of(text)
        == f'periods[0].dates[1]: expected a date YYYY-MM-DD, got "2009-02-30" (line {line_of(text, "2009-02-30")})'
    )


def test_end_before_start_is_an_error():
    text = VALID.replace("end: 2009-09-03", "end: 2009-08-03")
    assert (
        error_of(text) == f"periods[1]: end 2009-08-03 is before start 2009-09-01 (line {line_of(text, 'name: sep')})"
    )


def test_empty_fleet_is_an_error():
    text = VALID.replace("aircraft: [N672PA]", "aircraft: []")
    assert (
        error_of(text) == "fleets[1].aircraft: expected at least one aircraft, got an empty list "
        f"(line {line_of(text, 'aircraft: []')})"
    )


def test_repeated_aircraft_in_a_fleet_is_an_error():
    text = VALID.replace("aircraft: [N672PA]", "aircraft: [N672PA, N672PA]")
    assert "aircraft ids must be unique, repeated: N672PA" in error_of(text)


def test_literal_choice_lists_the_options():
    text = VALID + "executor: {kind: ray}\n"
    assert (
        error_of(text) == f"executor.kind: expected one of 'local' or 'dask', got \"ray\" (line {line_of(text, 'ray')})"
    )


def test_reference_to_undefined_period_names_the_defined_ones():
    text = VALID.replace("    periods: [sep]", "    periods: [october]")
    assert error_of(text) == (
        'studies.wind_climatology.periods[0]: expected the name of one of the periods (aug, sep), got "october" '
        f"(line {line_of(text, 'october')})"
    )


def test_unknown_network_and_airport_are_errors():
    text = VALID.replace("network: mesaba", "network: lufthansa")
    assert error_of(text).startswith(
        'fleets[0].network: expected a route network (chautauqua, mesaba, penair), got "lufthansa"'
    )
    text = VALID.replace("    max_legs_per_day: 2\n", "    legs: [{from: KMSP, to: ZZZZ}]\n")
    assert error_of(text).startswith(
        'studies.truth.legs[0].to: expected the ICAO code of an airport in the embedded table, got "ZZZZ"'
    )


def test_schedule_needs_a_network():
    text = VALID.replace("    network: penair\n", "")
    assert error_of(text).startswith("fleets[1].network: required by studies.truth")


def test_duplicate_yaml_key_is_an_error_not_last_wins():
    text = VALID.replace("seed: 5\n", "seed: 5\nseed: 7\n")
    assert error_of(text) == "seed: duplicate key (line 3)"


def test_no_study_and_yaml_syntax_errors():
    text = VALID[: VALID.index("studies:")] + "studies: {}\n"
    assert error_of(text).startswith(f"studies: expected at least one study ({BUILTIN})")
    assert error_of("name: [unclosed\n").startswith("not valid YAML:")
    assert error_of("- just\n- a list\n") == "expected a mapping of campaign fields at the top level, got a list of 2"


def test_cli_validate_prints_one_line_and_exits_2(tmp_path, capsys):
    bad = tmp_path / "bad.yaml"
    bad.write_text(VALID.replace("aircraft: [N672PA]", "aircraft: []"))
    assert main(["validate", str(bad)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err
    assert err.startswith(f"aerotruth validate: {bad}: fleets[1].aircraft: expected at least one aircraft")


def test_missing_file_is_one_line():
    with pytest.raises(ConfigError, match="no such campaign file"):
        load_campaign("/nonexistent/campaign.yaml")


def test_bounds_and_strict_integers():
    assert error_of(VALID.replace("seed: 5", "seed: -3")) == "seed: expected a number >= 0, got -3 (line 2)"
    assert error_of(VALID.replace("seed: 5", "seed: yes")) == "seed: expected an integer, got true (line 2)"
    assert error_of(VALID.replace("max_legs_per_day: 2", "max_legs_per_day: 2.5")).startswith(
        "studies.truth.max_legs_per_day: expected an integer, got 2.5"
    )
    assert error_of(VALID.replace("name: t1", "name: my run")).startswith("name: expected a name of letters, digits")


# ---- composing studies: cases that each failed before the code handled them


FIXED_LEG = VALID.replace(
    "    max_legs_per_day: 2\n", "    legs:\n      - {from: kmsp, to: KRST, departure_utc: 13:00}\n"
)


def test_unquoted_departure_time_is_13_00_not_the_sexagesimal_number_780():
    (leg,) = parse_campaign(FIXED_LEG).studies["truth"].legs
    assert leg.departure_utc == dt.time(13, 0)


def test_a_number_where_a_time_belongs_is_refused_with_its_line():
    text = FIXED_LEG.replace("departure_utc: 13:00", "departure_utc: 780")
    assert (
        error_of(text) == "studies.truth.legs[0].departure_utc: expected a time HH:MM, got the number 780 "
        f"(line {line_of(text, '780')})"
    )


def test_lowercase_icao_codes_are_taken_as_upper_case_like_fly_does():
    (leg,) = parse_campaign(FIXED_LEG).studies["truth"].legs
    assert (leg.origin, leg.destination) == ("KMSP", "KRST")


def test_validate_of_a_path_below_a_file_is_one_line(tmp_path, capsys):
    f = tmp_path / "quick.yaml"
    f.write_text(VALID)
    assert main(["validate", str(f / "x")]) == 2
    err = capsys.readouterr().err
    assert err == f"aerotruth validate: {f / 'x'}: no such campaign file ({f} is not a folder)\n"


def test_an_unknown_study_names_the_available_ones_and_its_line():
    text = VALID + "  sensors_of_the_future: {}\n"
    assert error_of(text) == (
        f"studies.sensors_of_the_future: unknown study (available: {BUILTIN}) "
        f"(line {line_of(text, 'sensors_of_the_future')})"
    )


def test_a_study_module_file_that_does_not_exist_is_named():
    text = "study_modules: [no_such_study.py]\n" + VALID
    assert error_of(text).startswith("study_modules[0]: expected a study module file")


SIZED = (
    VALID
    + """sizes:
  reduced:
    fleets:
      - {name: north, network: mesaba, aircraft: [N401XJ]}
      - {name: alaska, network: penair, aircraft: [N672PA]}
    periods:
      - {name: aug, dates: [2009-08-15]}
      - {name: sep, start: 2009-09-01, end: 2009-09-03, every_days: 2}
"""
)


def test_a_named_size_overrides_fields_and_renames_the_campaign():
    full = parse_campaign(SIZED)
    small = parse_campaign(SIZED, size="reduced")
    assert full.name == "t1" and small.name == "t1-reduced" and small.size == "reduced"
    assert [f.aircraft for f in small.fleets] == [["N401XJ"], ["N672PA"]]
    assert [d.isoformat() for d in small.period("sep").days()] == ["2009-09-01", "2009-09-03"]
    assert small.studies.keys() == full.studies.keys() and small.seed == full.seed
    # the resolved YAML of a sized campaign reads back as the same campaign
    assert parse_campaign(small.to_yaml()).config_hash() == small.config_hash()
    with pytest.raises(ConfigError, match=r"^--size huge: the campaign defines no such size \(sizes: reduced\)$"):
        parse_campaign(SIZED, size="huge")
    with pytest.raises(ConfigError, match=r"^sizes\.reduced: cannot override seed"):
        parse_campaign(SIZED + "    seed: 3\n", size="reduced")
