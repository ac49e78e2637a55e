"""WGS-84 radii of curvature (aerotruth.ellipsoid) against the ellipsoid's textbook values
and pyproj's geodesics."""

from __future__ import annotations

import numpy as np
import pytest
from pyproj import Geod

from aerotruth.ellipsoid import radii, radii_from_sin


def test_radii_at_the_equator_and_the_pole():
    m, n = radii(np.array([0.0, np.pi / 2]))
    # equator: N = a, M = a (1 - e^2) = b^2 / a; pole: M = N = a^2 / b (b = 6356752.314245 m)
    assert n[0] == pytest.approx(6378137.0, abs=1e-6)
    assert m[0] == pytest.approx(6356752.314245**2 / 6378137.0, abs=1e-4)
    assert m[1] == pytest.approx(6378137.0**2 / 6356752.314245, abs=1e-4) and n[1] == pytest.approx(m[1], abs=1e-6)


@pytest.mark.parametrize("lat_deg", [0.0, 30.0, 45.0, 61.2, 80.0])
def test_small_steps_match_pyprojs_geodesic(lat_deg):
    g = Geod(ellps="WGS84")
    m, n = radii(np.radians(lat_deg))
    d = 1e-3  # deg: the curvature radii give the arc to ~1e-9 relative
    north = g.inv(0.0, lat_deg - d / 2, 0.0, lat_deg + d / 2)[2]
    east = g.inv(-d / 2, lat_deg, d / 2, lat_deg)[2]
    assert m * np.radians(d) == pytest.approx(north, rel=1e-8)
    assert n * np.cos(np.radians(lat_deg)) * np.radians(d) == pytest.approx(east, rel=1e-8)
    assert radii_from_sin(np.sin(np.radians(lat_deg))) == pytest.approx((m, n), rel=1e-15)
