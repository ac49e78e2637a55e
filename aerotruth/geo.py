"""Geodesy helpers on WGS-84 through pyproj: distances, courses, points along a
geodesic, and local tangent-plane (ENU) coordinates.

Angles in and out are degrees at this edge (lat/lon are stored in degrees in every
table of the project); distances in metres.
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np
from pyproj import Geod, Transformer

WGS84 = Geod(ellps="WGS84")

_ECEF_FROM_GEODETIC = Transformer.from_crs("EPSG:4979", "EPSG:4978", always_xy=True)


def inverse(lat1, lon1, lat2, lon2):
    """Forward azimuth at 1 (deg true), back azimuth at 2 (deg), distance (m) of the geodesic 1->2."""
    az12, az21, dist = WGS84.inv(lon1, lat1, lon2, lat2)
    return az12, az21, dist


def forward(lat, lon, azimuth_deg, distance_m):
    """Point reached from (lat, lon) along azimuth after distance; returns (lat, lon, back azimuth)."""
    lon2, lat2, back = WGS84.fwd(lon, lat, azimuth_deg, distance_m)
    return lat2, lon2, back


def geodesic_points(lat1, lon1, lat2, lon2, n: int) -> np.ndarray:
    """n points equally spaced along the geodesic 1->2 including both ends, shape (n, 2) lat, lon."""
    if n < 2:
        raise ValueError(f"geodesic_points: n must be >= 2, got {n}")
    inner = WGS84.npts(lon1, lat1, lon2, lat2, n - 2) if n > 2 else []
    pts = [(lat1, lon1)] + [(la, lo) for lo, la in inner] + [(lat2, lon2)]
    return np.asarray(pts, dtype=float)


def ecef(lat_deg, lon_deg, h_ellipsoid_m):
    """WGS-84 geodetic (ellipsoidal height) -> ECEF x, y, z (m)."""
    return _ECEF_FROM_GEODETIC.transform(lon_deg, lat_deg, h_ellipsoid_m)


def geodetic_from_ecef(x_m, y_m, z_m):
    """ECEF x, y, z (m) -> WGS-84 geodetic lat, lon (deg) and ellipsoidal height (m)."""
    lon, lat, h = _ECEF_FROM_GEODETIC.transform(x_m, y_m, z_m, direction="INVERSE")
    return lat, lon, h


def enu(lat_deg, lon_deg, h_m, lat0_deg: float, lon0_deg: float, h0_m: float):
    """East, north, up (m) of points relative to the origin (lat0, lon0, h0), all
    ellipsoidal: PROJ's topocentric conversion of the ECEF coordinates (EPSG 9837)."""
    t = _topocentric(float(lat0_deg), float(lon0_deg), float(h0_m))
    e, n, u = t.transform(
        np.asarray(lon_deg, dtype=float), np.asarray(lat_deg, dtype=float), np.asarray(h_m, dtype=float)
    )
    return e, n, u


def geodetic_from_enu(e_m, n_m, u_m, lat0_deg: float, lon0_deg: float, h0_m: float):
    """Inverse of :func:`enu`: geodetic lat, lon (deg) and ellipsoidal height (m)."""
    t = _topocentric(float(lat0_deg), float(lon0_deg), float(h0_m))
    lon, lat, h = t.transform(
        np.asarray(e_m, dtype=float), np.asarray(n_m, dtype=float), np.asarray(u_m, dtype=float), direction="INVERSE"
    )
    return lat, lon, h


def ecef_from_ned_matrix(lat_deg, lon_deg) -> np.ndarray:
    """Rotation matrices (..., 3, 3) from the local geodetic NED frame at (lat, lon) to ECEF
    axes: columns are north, east and down expressed in ECEF."""
    phi, lam = np.radians(np.asarray(lat_deg, float)), np.radians(np.asarray(lon_deg, float))
    sp, cp, sl, cl = np.sin(phi), np.cos(phi), np.sin(lam), np.cos(lam)
    north = np.stack([-sp * cl, -sp * sl, cp], axis=-1)
    east = np.stack([-sl, cl, np.zeros_like(sl)], axis=-1)
    down = np.stack([-cp * cl, -cp * sl, -sp], axis=-1)
    return np.stack([north, east, down], axis=-1)


@lru_cache(maxsize=64)
def _topocentric(lat0_deg: float, lon0_deg: float, h0_m: float) -> Transformer:
    return Transformer.from_pipeline(
        "+proj=pipeline +step +proj=unitconvert +xy_in=deg +xy_out=rad +step +proj=cart +ellps=WGS84 "
        f"+step +proj=topocentric +ellps=WGS84 +lat_0={lat0_deg!r} +lon_0={lon0_deg!r} +h_0={h0_m!r}"
    )


def wrap180(angle_deg):
    """Wrap an angle (deg) into [-180, 180)."""
    return (np.asarray(angle_deg) + 180.0) % 360.0 - 180.0


def wrap360(angle_deg):
    """Wrap an angle (deg) into [0, 360)."""
    return np.asarray(angle_deg) % 360.0
