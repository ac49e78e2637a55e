"""Great-circle guidance geometry against hand-worked spherical cases."""

import math

import numpy as np
import pytest

from aerotruth.truth.guidance import GreatCircleLeg, LegGeometry, geocentric_lat_rad, turn_anticipation_m
from aerotruth.units import EARTH_RADIUS_M


def test_equator_leg_cross_track_is_arc_to_the_point_and_positive_left():
    leg = GreatCircleLeg("eq", 0.0, 0.0, 0.0, 10.0)  # eastbound along the equator
    # geodetic 1 deg N is geocentric slightly less; the arc is R * phi_c
    expect = EARTH_RADIUS_M * float(geocentric_lat_rad(1.0))
    assert leg.cross_track_m(1.0, 5.0) == pytest.approx(expect, rel=1e-12)  # north = left of eastbound
    assert leg.cross_track_m(-1.0, 5.0) == pytest.approx(-expect, rel=1e-12)


def test_meridian_leg_course_and_distance_to_go():
    leg = GreatCircleLeg("n", 10.0, 20.0, 30.0, 20.0)  # northbound along a meridian
    assert (leg.course_deg(20.0, 20.0) + 180.0) % 360.0 - 180.0 == pytest.approx(0.0, abs=1e-9)
    to_go = leg.along_track_to_go_m(20.0, 20.0)
    arc = EARTH_RADIUS_M * float(geocentric_lat_rad(30.0) - geocentric_lat_rad(20.0))
    assert to_go == pytest.approx(arc, rel=1e-12)
    assert leg.along_track_to_go_m(31.0, 20.0) < 0.0  # past the end


def test_scalar_twin_matches_vectorized_geometry():
    a = GreatCircleLeg("a", 44.88, -93.22, 46.84, -92.19)
    b = GreatCircleLeg("b", 46.84, -92.19, 46.9, -91.0)
    g = LegGeometry(a, b)
    for lat, lon in [(45.0, -93.0), (46.0, -92.9), (47.0, -92.0)]:
        assert g.to_go_m(lat, lon) == pytest.approx(float(a.along_track_to_go_m(lat, lon)), abs=1e-6)
    turn = float(b.course_deg(46.84, -92.19) - a.course_deg(46.84, -92.19))
    assert g.turn_deg == pytest.approx((turn + 180) % 360 - 180, abs=1e-9)


def test_turn_anticipation_is_radius_times_tan_half_angle():
    # V = 100 m/s, bank 20 deg: R = V^2 / (g tan 20) = 2801.6 m; 90 deg turn -> R tan 45 = R
    assert turn_anticipation_m(100.0, 90.0, 20.0) == pytest.approx(
        100.0**2 / (9.80665 * math.tan(math.radians(20))), rel=1e-12
    )
    assert turn_anticipation_m(100.0, -90.0, 20.0) == turn_anticipation_m(100.0, 90.0, 20.0)
    assert turn_anticipation_m(100.0, 0.0, 20.0) == 0.0


def test_coincident_leg_ends_are_rejected():
    with pytest.raises(ValueError, match="coincide"):
        _ = GreatCircleLeg("x", 45.0, -93.0, 45.0, -93.0).normal


def test_the_arc_ground_speeds_follow_the_wind_triangle():
    from aerotruth.truth.guidance import arc_ground_speeds_mps

    # 100 m/s of airspeed, 20 m/s of wind blowing to the east: north -> east ends downwind
    # (120), starts across the wind (sqrt(100^2 - 20^2))
    assert arc_ground_speeds_mps(100.0, 0.0, 20.0, 0.0, 90.0) == pytest.approx((96**0.5 * 10.0, 120.0))
    # north -> west by the left ends upwind (80)
    assert arc_ground_speeds_mps(100.0, 0.0, 20.0, 0.0, -90.0) == pytest.approx((80.0, 96**0.5 * 10.0))
    # a turn through both the downwind and the upwind track
    assert arc_ground_speeds_mps(100.0, 0.0, 20.0, 80.0, 200.0) == pytest.approx((80.0, 120.0))

    # 350 -> 330 on the upwind side: both ends; GS = 20 cos d + sqrt(100^2 - (20 sin d)^2)
    def gs(track):
        d = np.radians(track - 90.0)
        return 20.0 * np.cos(d) + np.sqrt(100.0**2 - (20.0 * np.sin(d)) ** 2)

    assert arc_ground_speeds_mps(100.0, 0.0, 20.0, 350.0, -20.0) == pytest.approx((gs(330.0), gs(350.0)))
    assert arc_ground_speeds_mps(100.0, 0.0, 0.0, 0.0, 90.0) == (100.0, 100.0)
