"""The inspection recovers the facility errors that sensors/ils.py injects, and a truth
system's position error moves the estimates by the angle it subtends."""

import math

import numpy as np
import pytest

from aerotruth.analysis.fits.inspection import inspect_approach, verdict
from aerotruth.truth.ils import IlsFacilitySpec
from aerotruth.units import NM

LENGTH = 2800.0


def approach(f, n=4000):
    """A centreline approach on the nominal 3-deg path from 10 nm to the threshold."""
    x = -np.linspace(10 * NM, 0.0, n)
    r = np.hypot(x - f.gp_x_m, -f.spec.gp_offset_m)
    return np.column_stack([x, np.zeros(n), r * math.tan(math.radians(3.0))])


def test_injected_alignment_angle_and_bends_are_recovered_with_a_perfect_truth_system():
    f = IlsFacilitySpec(loc_noise_ddm=0.0, gs_noise_ddm=0.0).draw(np.random.default_rng(4), LENGTH)
    p = approach(f)
    loc, gs = f.measure(p[:, 0], p[:, 1], p[:, 2], np.random.default_rng(0))
    est = inspect_approach(
        p, p, loc, gs, f, loc_sensitivity_rel=f.spec.loc_sensitivity_rel
    )  # measured on crossing runs
    # alignment: 3 m, seen through 0.02-deg bends over the last 1,050 m (the window averages
    # part of a bend cycle: within the bend's displacement there, 0.02 deg x 3.85 km = 1.3 m)
    assert est["alignment_m"] == pytest.approx(3.0, abs=1.4)
    assert est["gp_angle_error_deg"] == pytest.approx(0.05, abs=1e-6)
    assert est["bend_amplitude_deg"] == pytest.approx(0.02, rel=0.15)


def test_without_bends_the_alignment_is_exact():
    f = IlsFacilitySpec(
        alignment_m=-4.0, loc_sensitivity_rel=0.0, bend_amplitude_deg=0.0, loc_noise_ddm=0.0, gs_noise_ddm=0.0
    ).draw(np.random.default_rng(4), LENGTH)
    p = approach(f)
    loc, gs = f.measure(p[:, 0], p[:, 1], p[:, 2], np.random.default_rng(0))
    assert inspect_approach(p, p, loc, gs, f)["alignment_m"] == pytest.approx(-4.0, abs=1e-4)


def test_a_truth_system_error_shows_up_as_the_angle_it_subtends():
    f = IlsFacilitySpec(
        alignment_m=0.0, gp_angle_error_deg=0.0, bend_amplitude_deg=0.0, loc_noise_ddm=0.0, gs_noise_ddm=0.0
    ).draw(np.random.default_rng(4), LENGTH)
    p = approach(f)
    loc, gs = f.measure(p[:, 0], p[:, 1], p[:, 2], np.random.default_rng(0))
    biased = p + [0.0, 1.0, 0.5]  # the truth system reports 1 m left and 0.5 m high
    est = inspect_approach(biased, biased, loc, gs, f)
    # reported 1 m left of where it flies (on the course): the course seems to pass 1 m left, an apparent
    # angle atan(1 / (x_L + d)) at distance d, projected to the threshold: x_L / (x_L + d), averaged
    d = -p[:, 0]
    win = d <= 1050.0
    assert est["alignment_m"] == pytest.approx(np.mean(f.loc_x_m / (f.loc_x_m + d[win])), rel=1e-3)
    # 0.5 m high: the path looks higher by atan(0.5 / r), averaged over the segment
    x = p[:, 0]
    r = np.hypot(x - f.gp_x_m, -f.spec.gp_offset_m)
    seg = (-x >= 1050.0) & (-x <= 7400.0)
    assert est["gp_angle_error_deg"] == pytest.approx(np.mean(np.degrees(np.arctan2(0.5, r[seg]))), rel=0.02)


def test_verdict_uses_the_category_tolerance():
    assert verdict({"alignment_m": 9.0, "gp_angle_error_deg": 0.2}, "I") == {"alignment": True, "gp_angle": True}
    assert verdict({"alignment_m": 9.0, "gp_angle_error_deg": 0.2}, "II") == {"alignment": False, "gp_angle": False}
