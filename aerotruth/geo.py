"""Geodesy helpers on WGS-84 through pyproj: distances, courses, points along a
geodesic, and local tangent-plane (ENU) coordinates.

Angles in and out are degrees at this edge (lat/lon are stored in degrees in every
table of the project); distances in metres.
"""

from __future__ import annotations

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


def enu(lat_deg, lon_deg, h_m, lat0_deg: float, lon0_deg: float, h0_m: float):
    """East, north, up (m) of points relative to the origin (lat0, lon0, h0), all ellipsoidal."""
    x, y, z = (np.asarray(c, dtype=float) for c in ecef(lat_deg, lon_deg, h_m))
    x0, y0, z0 = ecef(lat0_deg, lon0_deg, h0_m)
    la, lo = np.radians(lat0_deg), np.radians(lon0_deg)
    dx, dy, dz = x - x0, y - y0, z - z0
    e = -np.sin(lo) * dx + np.cos(lo) * dy
    n = -np.sin(la) * np.cos(lo) * dx - np.sin(la) * np.sin(lo) * dy + np.cos(la) * dz
    u = np.cos(la) * np.cos(lo) * dx + np.cos(la) * np.sin(lo) * dy + np.sin(la) * dz
    return e, n, u


def wrap180(angle_deg):
    """Wrap an angle (deg) into [-180, 180)."""
    return (np.asarray(angle_deg) + 180.0) % 360.0 - 180.0


def wrap360(angle_deg):
    """Wrap an angle (deg) into [0, 360)."""
    return np.asarray(angle_deg) % 360.0
