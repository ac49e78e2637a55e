"""validation/diagnose_fits_confusion.py: the sizing rule worked by hand, and a dataset's
effects as the approach-log diagnosis names them on the independent generator's logs."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
import diagnose_fits_confusion as dfc  # noqa: E402


@pytest.mark.parametrize(
    "shares, expected",
    [
        ([0.10, 0.55, 0.90], 2.0),  # the first in 50-80 %
        ([0.10, 0.30, 0.95], (2.0, 3.0)),  # 30 % -> 95 %: try the geometric mean of 2 and 3
        ([0.00, 0.20, 0.40], 3.0),  # none: |0.40 - 0.65| = 0.25 is the closest
        ([0.90, 1.00, 1.00], 1.0),  # none: 0.25 from 65 % beats 0.35
        ([0.45, 0.85, 1.00], (1.0, 2.0)),
    ],
)
def test_the_sizing_rule_by_hand(shares, expected):
    assert dfc.pick_size([1.0, 2.0, 3.0], shares) == expected


def test_a_clear_dgps_offset_is_named_first_and_nothing_on_the_null():
    kw, mutate = dfc.EFFECTS["dgps_offset"][3](0.3)  # 0.3 m cross-track and vertical
    assert dfc.diagnosed(30_000, kw, mutate, False)[0] == "dgps_offset"
    assert dfc.diagnosed(30_000, {}, None, False) == []


def test_a_turned_ins_is_hidden_by_turning_its_columns():
    kw, mutate = dfc.EFFECTS["ins_frame"][3](16.0)
    assert kw == {} and dfc.diagnosed(30_001, kw, mutate, False) == ["ins_frame"]
