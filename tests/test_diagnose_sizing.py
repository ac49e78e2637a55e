"""validation/diagnose_sizing.py: the plan's sizing rule worked by hand on made-up counts."""

import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "validation"))
import diagnose_sizing as ds  # noqa: E402


def test_start_first_then_doubling_while_below_five():
    assert ds.step("tas_scale", 0.0025, {}) == ("try", 0.0025)
    assert ds.step("tas_scale", 0.0025, {"0.0025": 2}) == ("try", 0.005)
    assert ds.step("tas_scale", 0.0025, {"0.0025": 2, "0.005": 4}) == ("try", 0.01)


def test_first_size_with_five_to_eight_is_chosen():
    assert ds.step("airspeed", 0.0025, {"0.0025": 6}) == ("chosen", 0.0025)
    assert ds.step("airspeed", 0.0025, {"0.0025": 1, "0.005": 8}) == ("chosen", 0.005)


def test_found_too_often_at_the_start_keeps_the_start():
    # no halving in the rule: 10 of 10 at the start is the closest to 6.5 of what was tried
    assert ds.step("reference_bias", 0.7, {"0.7": 10}) == ("chosen", 0.7)


def test_a_jump_over_the_band_tries_the_geometric_mean():
    # 0.7 -> 1.4 goes from 3 to 10: sqrt(0.7 * 1.4) = 0.98995 -> 0.99 (three digits)
    assert ds.step("reference_bias", 0.7, {"0.7": 3, "1.4": 10}) == ("try", 0.99)
    assert ds.step("reference_bias", 0.7, {"0.7": 3, "1.4": 10, "0.99": 7}) == ("chosen", 0.99)
    # the mean also outside 5-8: the closest to 6.5 of the three (|9 - 6.5| < |3 - 6.5|)
    assert ds.step("reference_bias", 0.7, {"0.7": 3, "1.4": 10, "0.99": 9}) == ("chosen", 0.99)


def test_a_step_from_below_five_to_nine_but_not_from_five():
    # 4 -> 9 is below 5 to above 8: mean sqrt(6 * 12) = 8.485 -> 8.49
    assert ds.step("stale_declination", 6.0, {"6": 4, "12": 9}) == ("try", 8.49)
    # 4 -> 8 lands in the band: chosen without a mean
    assert ds.step("stale_declination", 6.0, {"6": 4, "12": 8}) == ("chosen", 12.0)


def test_never_found_stops_at_sixteen_times_and_takes_the_closest():
    counts = {"1": 0, "2": 0, "4": 1, "8": 3, "16": 4}
    assert ds.step("field_scaling", 1.0, counts) == ("chosen", 16.0)
    # ties on the distance to 6.5 go to the smaller size
    counts = {"1": 0, "2": 2, "4": 2, "8": 2, "16": 2}
    assert ds.step("field_scaling", 1.0, counts) == ("chosen", 2.0)


def test_quantization_walks_its_own_grid_without_a_mean():
    assert ds.step("quantization", 0.02, {"0.02": 2}) == ("try", 0.03)
    assert ds.step("quantization", 0.02, {"0.02": 2, "0.03": 10}) == ("chosen", 0.03)
    assert ds.step("quantization", 0.02, {"0.02": 0, "0.03": 1, "0.05": 3}) == ("chosen", 0.05)


def test_counts_only_complete_sizes_of_the_first_ten_seeds(tmp_path):
    header = "generator,effect,size,seed,status,named_first\n"
    lines = [f"simulated,tas_scale,0.0025,{70000 + i},ok,{int(i < 3)}\n" for i in range(10)]
    lines += [f"simulated,tas_scale,0.005,{70000 + i},ok,1\n" for i in range(9)]  # one missing
    lines += ["simulated,tas_scale,0.0025,70010,ok,1\n"]  # beyond the first ten
    lines += [f"independent,tas_scale,0.0025,{70000 + i},ok,1\n" for i in range(10)]
    (tmp_path / "rows.csv").write_text(header + "".join(lines))
    assert ds.counts_of(tmp_path / "rows.csv", "simulated") == {"tas_scale": {"0.0025": 3}}
