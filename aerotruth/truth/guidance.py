"""Great-circle guidance geometry shared by Python (leg sequencing, distance to go) and
the JSBSim autopilot XML (cross-track and course at every step).

The autopilot works on a sphere with geocentric latitude: a leg A->B is described by the
unit normal n = A x B / |A x B| of its great circle, a point P is left of the leg when
P . n > 0, and the leg's course at P is the direction of t = n x P. Both sides use the
same formulas (aircraft/systems/aerotruth_autopilot.xml, channel "lnav"), so the
cross-track Python reports is the one the autopilot flies.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aerotruth.geo import WGS84
from aerotruth.units import EARTH_RADIUS_M, G0

WGS84_E2 = WGS84.es  # first eccentricity squared, 6.694380e-3 (pyproj's WGS-84; NIMA TR8350.2)


def geocentric_lat_rad(lat_geodetic_deg):
    """Geocentric latitude (rad) of a point on the ellipsoid: tan(phi_c) = (1 - e^2) tan(phi)."""
    phi = np.radians(lat_geodetic_deg)
    return np.arctan((1.0 - WGS84_E2) * np.tan(phi))


def unit_vector(lat_deg, lon_deg) -> np.ndarray:
    """Geocentric unit vector(s) of geodetic lat/lon (deg); shape (..., 3)."""
    pc = geocentric_lat_rad(lat_deg)
    lo = np.radians(lon_deg)
    return np.stack([np.cos(pc) * np.cos(lo), np.cos(pc) * np.sin(lo), np.sin(pc)], axis=-1)


@dataclass(frozen=True)
class GreatCircleLeg:
    """A leg from A to B (geodetic deg) flown along the great circle of their geocentric vectors."""

    name: str
    lat_a: float
    lon_a: float
    lat_b: float
    lon_b: float

    @property
    def a(self) -> np.ndarray:
        return unit_vector(self.lat_a, self.lon_a)

    @property
    def b(self) -> np.ndarray:
        return unit_vector(self.lat_b, self.lon_b)

    @property
    def normal(self) -> np.ndarray:
        n = np.cross(self.a, self.b)
        norm = np.linalg.norm(n)
        if norm < 1e-12:
            raise ValueError(f"leg {self.name}: start and end coincide or are antipodal")
        return n / norm

    @property
    def length_m(self) -> float:
        return float(EARTH_RADIUS_M * np.arctan2(np.linalg.norm(np.cross(self.a, self.b)), np.dot(self.a, self.b)))

    def cross_track_m(self, lat_deg, lon_deg):
        """Signed distance from the great circle, positive left of A->B (m)."""
        p = unit_vector(lat_deg, lon_deg)
        return EARTH_RADIUS_M * np.arcsin(np.clip(p @ self.normal, -1.0, 1.0))

    def along_track_to_go_m(self, lat_deg, lon_deg):
        """Distance along the great circle from the foot of P to B (m); negative once past B."""
        p = unit_vector(lat_deg, lon_deg)
        n = self.normal
        foot = p - np.multiply.outer(p @ n, n) if np.ndim(p) > 1 else p - (p @ n) * n
        foot = foot / np.linalg.norm(foot, axis=-1, keepdims=True)
        b = self.b
        ang = np.arctan2(np.cross(foot, b) @ n, foot @ b)
        return EARTH_RADIUS_M * ang

    def course_deg(self, lat_deg, lon_deg):
        """True course of the great circle at P (deg, 0..360)."""
        p = unit_vector(lat_deg, lon_deg)
        t = np.cross(self.normal, p)
        lo = np.radians(lon_deg)
        pc = geocentric_lat_rad(lat_deg)
        east = -np.sin(lo) * t[..., 0] + np.cos(lo) * t[..., 1]
        north = -np.sin(pc) * np.cos(lo) * t[..., 0] - np.sin(pc) * np.sin(lo) * t[..., 1] + np.cos(pc) * t[..., 2]
        return np.degrees(np.arctan2(east, north)) % 360.0


def turn_anticipation_m(ground_speed_mps: float, course_change_deg: float, bank_deg: float) -> float:
    """Distance before a waypoint at which a coordinated turn of constant bank must start to
    roll out on the next leg: R tan(dpsi/2), R = V^2 / (g tan(bank))."""
    radius = ground_speed_mps**2 / (G0 * math.tan(math.radians(bank_deg)))
    half = math.radians(min(abs(course_change_deg), 150.0)) / 2.0
    return float(radius * math.tan(half))


def arc_ground_speeds_mps(
    airspeed_mps: float, wind_n_mps: float, wind_e_mps: float, course_deg: float, course_change_deg: float
) -> tuple[float, float]:
    """The smallest and largest ground speed (m/s) over a turn's tracks, from `course_deg`
    through `course_change_deg` (signed, right positive), at a horizontal airspeed in a
    uniform wind (north, east; the direction it blows to). On track chi the wind triangle
    gives GS = W cos d + sqrt(V^2 - W^2 sin^2 d), d = chi - the wind's direction: largest
    downwind (d = 0), smallest upwind, monotone in |d| between, so the extremes lie at the
    arc's ends or where the arc crosses those two tracks. A wind at or above the airspeed
    has no ground track across it; the speeds are then those of the tracks that can be flown."""
    w = math.hypot(wind_n_mps, wind_e_mps)
    to_deg = math.degrees(math.atan2(wind_e_mps, wind_n_mps))

    def gs(d_deg: float) -> float:
        d = math.radians(d_deg)
        cross = w * math.sin(d)
        return w * math.cos(d) + math.sqrt(max(airspeed_mps * airspeed_mps - cross * cross, 0.0))

    def crosses(target_deg: float) -> bool:
        off = (target_deg - course_deg) % 360.0  # from the start, clockwise
        return off <= course_change_deg if course_change_deg >= 0.0 else off >= 360.0 + course_change_deg or off == 0.0

    d0 = course_deg - to_deg
    ends = (gs(d0), gs(d0 + course_change_deg))
    hi = airspeed_mps + w if crosses(to_deg) else max(ends)
    lo = max(airspeed_mps - w, 0.0) if crosses(to_deg + 180.0) else min(ends)
    return lo, hi


def _unit_scalar(lat_deg: float, lon_deg: float) -> tuple[float, float, float]:
    pc = math.atan((1.0 - WGS84_E2) * math.tan(math.radians(lat_deg)))
    lo = math.radians(lon_deg)
    cp = math.cos(pc)
    return (cp * math.cos(lo), cp * math.sin(lo), math.sin(pc))


class LegGeometry:
    """Scalar (math-module) twin of GreatCircleLeg for the 1 Hz guidance update, where
    numpy's per-call overhead would dominate. Same formulas, precomputed vectors."""

    __slots__ = ("n", "b", "length_m", "turn_deg", "course_end_deg")

    def __init__(self, leg: GreatCircleLeg, next_leg: GreatCircleLeg | None):
        self.n = tuple(float(c) for c in leg.normal)
        self.b = tuple(float(c) for c in leg.b)
        self.length_m = leg.length_m
        self.course_end_deg = float(leg.course_deg(leg.lat_b, leg.lon_b))
        if next_leg is None:
            self.turn_deg = 0.0
        else:
            nxt = float(next_leg.course_deg(leg.lat_b, leg.lon_b))
            self.turn_deg = (nxt - self.course_end_deg + 180.0) % 360.0 - 180.0

    def to_go_m(self, lat_deg: float, lon_deg: float) -> float:
        """Along-track distance from the foot of P to the leg end (m), negative once past it."""
        px, py, pz = _unit_scalar(lat_deg, lon_deg)
        nx, ny, nz = self.n
        bx, by, bz = self.b
        d = px * nx + py * ny + pz * nz
        fx, fy, fz = px - d * nx, py - d * ny, pz - d * nz
        cx, cy, cz = fy * bz - fz * by, fz * bx - fx * bz, fx * by - fy * bx
        return EARTH_RADIUS_M * math.atan2(cx * nx + cy * ny + cz * nz, fx * bx + fy * by + fz * bz)
