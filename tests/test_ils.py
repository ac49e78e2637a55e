"""ILS deviations against hand-worked geometry and the Annex 10 sensitivities."""

import math

import numpy as np
import pytest

from aerotruth.truth.ils import TOLERANCES, IlsFacilitySpec, ddm_to_microamps, nominal

LENGTH = 3000.0


def facility(**kw):
    base = dict(
        alignment_m=0.0,
        loc_sensitivity_rel=0.0,
        gp_angle_error_deg=0.0,
        bend_amplitude_deg=0.0,
        loc_noise_ddm=0.0,
        gs_noise_ddm=0.0,
    )
    return IlsFacilitySpec(**{**base, **kw}).draw(np.random.default_rng(1), LENGTH)


def test_localizer_sensitivity_at_the_threshold_is_0_00145_ddm_per_metre():
    f = facility()
    # 50 m left at the threshold: DDM = 50 x 0.00145 (the sector is linear in angle; the
    # small difference between angle and tangent at 3.3 km is 1e-4 relative)
    assert float(f.localizer_ddm(0.0, 50.0)) == pytest.approx(50 * 0.00145, rel=1e-3)
    # 10 nm out the same angle is 18,520 m / (3,300 m + ...) times wider: DDM at the edge of
    # the sector is 0.155 where y = 106.9 m x (distance to the array) / 3,300 m
    x = -18520.0
    y_edge = 0.155 / 0.00145 * (f.loc_x_m - x) / f.loc_x_m
    assert float(f.localizer_ddm(x, y_edge)) == pytest.approx(0.155, rel=1e-3)


def test_alignment_error_moves_the_course_by_its_displacement_at_the_threshold():
    f = facility(alignment_m=3.0)
    assert float(f.localizer_ddm(0.0, 3.0)) == pytest.approx(0.0, abs=1e-12)  # the course passes 3 m left
    assert float(f.localizer_ddm(0.0, 0.0)) == pytest.approx(
        -3.0 * 0.00145, rel=1e-3
    )  # centreline reads right of course


def test_sensitivity_error_scales_the_ddm():
    assert float(facility(loc_sensitivity_rel=0.10).localizer_ddm(0.0, 40.0)) == pytest.approx(
        1.1 * 40 * 0.00145, rel=1e-3
    )


def test_on_the_nominal_path_the_glide_slope_reads_zero_and_tch_is_15_m():
    f = facility()
    th = math.radians(3.0)
    for x in (-18520.0, -3000.0, 0.0):
        r = math.hypot(x - f.gp_x_m, 0.0 - f.spec.gp_offset_m)
        assert float(f.glide_slope_ddm(x, 0.0, r * math.tan(th))) == pytest.approx(0.0, abs=1e-12)
    assert f.gp_x_m * math.tan(th) == pytest.approx(15.0)


def test_glide_path_angle_error_reads_as_its_share_of_the_half_sector():
    f = facility(gp_angle_error_deg=0.05)
    th = math.radians(3.0)
    x = -9000.0
    z = math.hypot(x - f.gp_x_m, f.spec.gp_offset_m) * math.tan(th)  # on the nominal 3.00 deg path
    expected = 0.0875 * (3.0 - 3.05) / (0.12 * 3.05)
    assert float(f.glide_slope_ddm(x, 0.0, z)) == pytest.approx(expected, rel=1e-9)


def test_bends_have_the_stated_amplitude_and_the_nominal_facility_has_none():
    f = facility(bend_amplitude_deg=0.02)
    x = np.linspace(-18000, 0, 20001)
    bend_deg = np.degrees(f.bend_rad(x))
    assert bend_deg.max() == pytest.approx(0.02, rel=1e-3) and bend_deg.min() == pytest.approx(-0.02, rel=1e-3)
    assert 1000 <= f.bend_wavelength_m <= 2000
    n = nominal(facility(alignment_m=5.0, bend_amplitude_deg=0.02, gp_angle_error_deg=0.1))
    assert float(n.localizer_ddm(-5000.0, 0.0)) == 0.0


def test_microamps_and_the_annex_10_tolerances():
    assert float(ddm_to_microamps(0.155, "loc")) == pytest.approx(150.0)
    assert float(ddm_to_microamps(0.0875, "gs")) == pytest.approx(75.0)  # one dot
    assert (TOLERANCES["I"]["alignment_m"], TOLERANCES["II"]["alignment_m"], TOLERANCES["III"]["alignment_m"]) == (
        10.5,
        7.5,
        3.0,
    )


def test_receiver_noise_has_the_stated_sigma():
    f = IlsFacilitySpec(loc_noise_ddm=0.001, gs_noise_ddm=0.002, bend_amplitude_deg=0.0).draw(
        np.random.default_rng(2), LENGTH
    )
    n = 200_000
    loc, gs = f.measure(np.full(n, -5000.0), np.zeros(n), np.full(n, 262.0), np.random.default_rng(3))
    assert np.std(loc) == pytest.approx(0.001, rel=0.01) and np.std(gs) == pytest.approx(0.002, rel=0.01)


def test_bad_spec_names_the_field():
    with pytest.raises(ValueError, match="bend_wavelength_m"):
        IlsFacilitySpec(bend_wavelength_m=(2000.0, 1000.0)).draw(np.random.default_rng(0), LENGTH)
    with pytest.raises(ValueError, match="loc_noise_ddm"):
        IlsFacilitySpec(loc_noise_ddm=-1.0)
