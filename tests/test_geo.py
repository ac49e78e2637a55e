"""Local tangent-plane coordinates against hand-worked geometry on the WGS-84 ellipsoid."""

import math

import numpy as np
import pytest

from aerotruth.geo import enu

A, F = 6378137.0, 1 / 298.257223563
E2 = F * (2 - F)


def test_a_point_straight_above_the_origin_is_pure_up():
    e, n, u = enu(45.0, -93.0, 1250.0, 45.0, -93.0, 250.0)
    assert (float(e), float(n), float(u)) == pytest.approx((0.0, 0.0, 1000.0), abs=1e-6)


def test_a_small_step_north_is_the_meridional_radius_times_the_latitude_change():
    lat0 = 45.0
    m = A * (1 - E2) / (1 - E2 * math.sin(math.radians(lat0)) ** 2) ** 1.5  # meridional radius of curvature
    dlat = 0.01
    e, n, u = enu(lat0 + dlat, 10.0, 0.0, lat0, 10.0, 0.0)
    s = m * math.radians(dlat)
    assert float(e) == pytest.approx(0.0, abs=1e-6)
    assert float(n) == pytest.approx(s, rel=1e-5)
    assert float(u) == pytest.approx(-(s**2) / (2 * m), rel=1e-2)  # the ellipsoid falls away below the plane


def test_arrays_broadcast():
    e, n, u = enu(np.array([45.0, 45.0]), np.array([-93.0, -92.99]), np.array([0.0, 0.0]), 45.0, -93.0, 0.0)
    assert e.shape == (2,) and e[1] > 780.0 and e[1] < 790.0  # 0.01 deg of longitude at 45 deg: ~787 m
