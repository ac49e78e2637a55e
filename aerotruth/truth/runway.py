"""The runway frame in three dimensions, through pyproj.

docs/conventions.md runway frame (right-handed): origin at the threshold centre at runway
elevation, x along the approach course (towards and past the threshold: an approaching
aircraft has x < 0, the runway is 0 <= x <= length), y to the left, z up. It is the
local tangent plane at the threshold (PROJ's topocentric conversion of ECEF, EPSG 9837)
rotated by the runway's true course c:

    x = e sin c + n cos c,    y = -e cos c + n sin c,    z = u.

A straight line in this frame is a straight line in space (a glide-path cone, a
localizer plane), so heights here are above the tangent plane, not above the ellipsoid:
at 20 km from the threshold the ellipsoid lies 31 m below the plane (d^2 / 2R), which is
why ILS guidance and scoring use this frame and not ellipsoidal heights.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from aerotruth import geo
from aerotruth.truth.airports import Runway


@dataclass(frozen=True)
class RunwayFrame:
    """Runway frame of one runway end: origin (geodetic, ellipsoidal height) and course."""

    lat0_deg: float
    lon0_deg: float
    h0_m: float
    course_deg: float

    @classmethod
    def of(cls, runway: Runway) -> RunwayFrame:
        return cls(
            float(runway.threshold_lat),
            float(runway.threshold_lon),
            float(runway.threshold_height_ellipsoid_m),
            float(runway.true_course_deg),
        )

    @cached_property
    def _cs(self) -> tuple[float, float]:
        c = math.radians(self.course_deg)
        return math.cos(c), math.sin(c)

    def from_geodetic(self, lat_deg, lon_deg, h_m):
        """Runway-frame x, y, z (m) of geodetic points (deg, ellipsoidal m)."""
        e, n, u = geo.enu(lat_deg, lon_deg, h_m, self.lat0_deg, self.lon0_deg, self.h0_m)
        cc, sc = self._cs
        e, n, u = np.asarray(e, float), np.asarray(n, float), np.asarray(u, float)
        return e * sc + n * cc, -e * cc + n * sc, u

    def to_geodetic(self, x, y, z):
        """Geodetic lat, lon (deg) and ellipsoidal height (m) of runway-frame points."""
        cc, sc = self._cs
        x, y, z = np.asarray(x, float), np.asarray(y, float), np.asarray(z, float)
        e, n = x * sc - y * cc, x * cc + y * sc
        return geo.geodetic_from_enu(e, n, z, self.lat0_deg, self.lon0_deg, self.h0_m)

    def rotation_from_ned(self, lat_deg, lon_deg) -> np.ndarray:
        """Matrices (..., 3, 3) taking a NED vector at (lat, lon) to runway-frame axes: the
        local NED frame there, through ECEF, to the frame's axes at the origin (exact for
        any distance, not only near the threshold)."""
        c_e_ned = geo.ecef_from_ned_matrix(lat_deg, lon_deg)  # (..., 3, 3)
        c_rwy_e = self._rwy_from_ecef
        return np.einsum("ij,...jk->...ik", c_rwy_e, c_e_ned)

    @property
    def rotation_from_ecef(self) -> np.ndarray:
        """The matrix (3, 3) taking ECEF vectors to runway-frame axes."""
        return self._rwy_from_ecef

    @cached_property
    def _rwy_from_ecef(self) -> np.ndarray:
        c_e_ned0 = geo.ecef_from_ned_matrix(self.lat0_deg, self.lon0_deg)
        cc, sc = self._cs
        # runway axes in NED at the origin: x = (cos c, sin c, 0), y = (sin c, -cos c, 0), z = (0, 0, -1)
        c_rwy_ned0 = np.array([[cc, sc, 0.0], [sc, -cc, 0.0], [0.0, 0.0, -1.0]])
        return c_rwy_ned0 @ c_e_ned0.T
