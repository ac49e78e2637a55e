"""validation/fit_noise.py's re-scoring on hand-built reports: the uploaded table undone
(the heading before it recovered from the corrected one) and another applied equals
reporting with that other table from the start."""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from aerotruth.analysis.wind.heading_correction import LUT_COLUMNS

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
import fit_noise  # noqa: E402


def test_undoing_one_table_and_applying_another_equals_reporting_with_the_other():
    rng = np.random.default_rng(11)
    n = 500
    psi_u = rng.uniform(0, 360, n)  # the measured true heading before any table
    var = rng.uniform(10, 20, n)  # declination: the table is indexed by psi - var
    true_input = rng.random(n) < 0.2  # some reports from true-heading avionics: the offset only
    z = np.arange(0, 360, 45.0)
    old = np.tile(-(1.0 + 4.0 * np.sin(np.radians(z)) - 3.0 * np.cos(np.radians(z))), (n, 1))
    new = np.tile(-(0.5 + 3.5 * np.sin(np.radians(z))), (n, 1))

    # by hand: linear interpolation round the circle at the magnetic heading, or the mean
    def applied(lut, psi):
        m = (psi - var) % 360.0
        at = np.array([np.interp(x, np.r_[z, 360.0], np.r_[row, row[0]]) for x, row in zip(m, lut, strict=False)])
        return np.where(true_input, lut.mean(axis=1), at)

    psi_c = psi_u + applied(old, psi_u)

    def tables(lut):  # the study's learned corrections: one magnetic-heading aircraft, one true-heading one
        return pd.DataFrame(
            [
                {
                    "aircraft": ac,
                    "group": "poor",
                    "status": "fitted",
                    "heading_input": hi,
                    **dict(zip(LUT_COLUMNS, lut[0], strict=False)),
                }
                for ac, hi in (("M", "magnetic"), ("T", "true"))
            ]
        )

    aircraft = np.where(true_input, "T", "M")
    assert fit_noise.uncorrected_heading(psi_c, tables(old), aircraft, var) == pytest.approx(psi_u, abs=1e-9)
    assert fit_noise.onboard_correction(tables(new), aircraft, psi_u, var) == pytest.approx(
        applied(new, psi_u), abs=1e-9
    )
    psi_n = psi_u + applied(new, psi_u)
    # the wind reported with heading psi: V_G - V_A(psi), V_G from a truth wind and the true heading
    tas, ve, vn = rng.uniform(180, 260, n), rng.normal(0, 20, n), rng.normal(0, 20, n)
    head = np.radians(rng.uniform(0, 360, n))
    ge, gn = ve + tas * np.sin(head), vn + tas * np.cos(head)

    def report(psi):
        we, wn = ge - tas * np.sin(np.radians(psi)), gn - tas * np.cos(np.radians(psi))
        return np.hypot(we, wn), np.degrees(np.arctan2(-we, -wn)) % 360.0

    s_c, d_c = report(psi_c)
    s_n, d_n = report(psi_n)
    s, d = fit_noise.rescored_wind(s_c, d_c, tas, psi_c, psi_n)
    assert s == pytest.approx(s_n, abs=1e-9)
    assert np.abs((d - d_n + 180.0) % 360.0 - 180.0).max() < 1e-7


def test_half_splits_keep_each_unit_whole_and_halve_each_aircraft():
    ac = np.array(["A"] * 9 + ["B"] * 6)
    day = np.array(["d1", "d1", "d2", "d3", "d3", "d3", "d4", "d5", "d5", "e1", "e2", "e2", "e3", "e4", "e4"])
    for first in fit_noise.half_splits(ac, day, np.random.default_rng(3), 5):
        for a, n_units in (("A", 5), ("B", 4)):
            k = ac == a
            in_first = {d for d, f in zip(day[k], first[k], strict=False) if f}
            assert all(first[k][day[k] == d].all() or not first[k][day[k] == d].any() for d in set(day[k]))
            assert len(in_first) == n_units // 2
