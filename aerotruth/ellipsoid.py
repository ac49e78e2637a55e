"""The WGS-84 ellipsoid (NIMA TR8350.2): its defining constants and the radii of
curvature, for the sensor models and the analysis, which work on latitudes and
longitudes in radians and want these in closed form. Geodesics and frame changes go
through pyproj (`aerotruth.geo`).

    N = a / sqrt(1 - e^2 sin^2 lat)                       prime vertical
    M = a (1 - e^2) / (1 - e^2 sin^2 lat)^(3/2)            meridian

so a small step (d lat, d lon) is (north, east) = (M d lat, N cos(lat) d lon) metres.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike

A_M = 6378137.0  # semi-major axis, m
F = 1.0 / 298.257223563  # flattening
E2 = F * (2.0 - F)  # first eccentricity squared, 6.69437999014e-3


def radii_from_sin(sin_lat: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Meridional (M) and prime-vertical (N) radii of curvature (m) from the sine of the
    geodetic latitude (for callers that have it already)."""
    q = 1.0 - E2 * np.square(sin_lat)
    sq = np.sqrt(q)
    return A_M * (1.0 - E2) / (q * sq), A_M / sq  # q^1.5 without the slow power


def radii(lat_rad: ArrayLike) -> tuple[np.ndarray, np.ndarray]:
    """Meridional (M) and prime-vertical (N) radii of curvature (m) at geodetic latitude
    lat (rad)."""
    return radii_from_sin(np.sin(np.asarray(lat_rad, dtype=float)))
