"""Leg plans and daily schedules on the airline networks: which runways, which lateral
path, which cruise level, when.

A leg is flown from just after take-off to a point on final approach:

* initial point over the far end of the departure runway, 400 ft above it, on the
  runway course (the flight loop starts there, airborne);
* a point ``CLIMB_OUT_NM`` ahead on the runway course (straight-out climb);
* direct (geodesic) to the intermediate fix ``IF`` on the arrival runway's extended
  centreline ``INTERMEDIATE_FIX_NM`` from the threshold; when that would need a turn
  of more than 90 deg at the IF, a ``BASE`` point ``BASE_OFFSET_NM`` abeam the IF, on
  the side the aircraft comes from, is inserted first;
* the final point ``FINAL`` on the centreline ``FINAL_POINT_NM`` from the threshold,
  where the flight ends 2,000 ft above the runway;
* with :func:`with_airway`, en-route fixes between the climb-out and the arrival
  (airway doglegs): course changes in climb, cruise and descent as airline legs have.

Heights the flight loop targets are WGS-84 ellipsoidal (through the one conversion
:func:`aerotruth.truth.airports.ellipsoidal_height_m`); the cruise level is a pressure
altitude. Winds are "towards" components (u east, v north), m/s. Everything is
deterministic given the inputs; random choices come only from the Generator passed in.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, replace
from datetime import UTC, date, datetime, time, timedelta
from typing import overload
from zoneinfo import ZoneInfo

import numpy as np

from aerotruth.geo import forward, inverse, wrap180, wrap360
from aerotruth.truth.airports import (
    Airport,
    Network,
    Runway,
    airport,
    ellipsoidal_height_m,
    network,
)
from aerotruth.units import FT, KT, NM

INITIAL_HEIGHT_AGL_FT = 400.0  # over the far end of the departure runway (<= 500 ft AGL)
CLIMB_OUT_NM = 5.0  # straight-out climb on the runway course
INTERMEDIATE_FIX_NM = 12.0  # IF on the arrival runway's extended centreline
FINAL_POINT_NM = 6.0  # end of the leg on the centreline
ARRIVAL_HEIGHT_AGL_FT = 2000.0  # height above the arrival runway at FINAL_POINT_NM
BASE_OFFSET_NM = 5.0  # abeam the IF, inserted when the turn at the IF would exceed 90 deg

# Cruise level by leg length (great-circle airport to airport): FL140 at <= 100 nm,
# FL230 at 250 nm, FL250 (the SAAB 340B ceiling) from 350 nm; a SAAB 340B needs
# ~20-25 min to reach FL250 (its published ~2,000 fpm initial climb at MTOW, falling with
# height towards the 25,000 ft service ceiling), so short legs fly low.
CRUISE_TABLE_NM = (100.0, 250.0, 350.0)
CRUISE_TABLE_FT = (14000.0, 23000.0, 25000.0)
CRUISE_FLOOR_FT = 14000.0
CRUISE_CEILING_FT = 25000.0
# Profile feasibility for short legs: mean climb gradient to cruise (FL250 in ~22 min at
# ~200 kt ground speed -> ~350 ft/nm), 3 deg descent (tan 3 deg * 6076 ft = 318 ft/nm),
# and at least MIN_CRUISE_NM level; the level is lowered until the profile fits.
CLIMB_GRADIENT_FT_PER_NM = 350.0
DESCENT_PATH_DEG = 3.0
MIN_CRUISE_NM = 10.0
# the lowest level a leg is planned at: 4,000 ft keeps the shortest network legs
# (KDTW-KFNT, 48 nm, flown at 4,000-6,000 ft by the airline) while 2,000 ft of cruise
# above the profile's floor remain
LOWEST_CRUISE_FT = 4000.0

# En-route fixes (with_airway), from the real A320 recorder extract in ../shared/real-data
# (fuelflow_a320.json.gz, 1,360 nm above 10,000 ft): 14 course changes of more than 2 deg,
# mean |change| 11.4 deg (2-38 deg), one per ~100 nm. Fix spacing is gamma distributed
# (shape 2, mean AIRWAY_FIX_SPACING_NM); each segment's course departs from the direct one
# by N(0, AIRWAY_SEGMENT_SIGMA_DEG), so the change at a fix has rms sqrt(2) x 9 = 13 deg,
# mean |change| 10 deg (11 deg over the changes > 2 deg, as the A320's are counted), after
# the path is closed onto the arrival fix (a linear ramp of the cross-track offsets);
# ~1 % extra distance.
AIRWAY_FIX_SPACING_NM = 100.0
AIRWAY_SPACING_SHAPE = 2.0
AIRWAY_SEGMENT_SIGMA_DEG = 9.0
AIRWAY_MARGIN_NM = 20.0  # no fix this close to the climb-out point or to the arrival fix

BLOCK_SPEED_KT = 250.0  # schedule: block time = distance / 250 kt + 15 min
BLOCK_OVERHEAD_MIN = 15.0

WindUV = tuple[float, float]
SAME_AS_DEPARTURE = object()  # plan_leg default: the arrival runway uses the departure wind


@dataclass(frozen=True)
class Waypoint:
    """A named point of the lateral path (deg, WGS-84)."""

    name: str
    lat: float
    lon: float


@overload
def _check_wind(wind_uv: None, name: str) -> None: ...
@overload
def _check_wind(wind_uv: WindUV, name: str) -> WindUV: ...
@overload
def _check_wind(wind_uv: object, name: str) -> WindUV | None: ...
def _check_wind(wind_uv, name: str) -> WindUV | None:
    if wind_uv is None:
        return None
    try:
        u, v = (float(c) for c in wind_uv)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected (u, v) in m/s (towards east, north), got {wind_uv!r}") from None
    if not (math.isfinite(u) and math.isfinite(v)):
        raise ValueError(f"{name}: wind components must be finite, got {wind_uv!r}")
    return u, v


def headwind_mps(runway: Runway, wind_uv: WindUV) -> float:
    """Headwind component (m/s, positive on the nose) for an aircraft on the runway's
    course, from a "towards" wind (u east, v north): -(u sin c + v cos c)."""
    u, v = _check_wind(wind_uv, "headwind_mps wind_uv")
    c = math.radians(runway.true_course_deg)
    return -(u * math.sin(c) + v * math.cos(c))


def choose_runway(apt: Airport, wind_uv: WindUV | None = None) -> Runway:
    """The runway end most into the surface wind (largest headwind component), for
    departure and arrival alike; with no wind (None) or equal headwinds, the longest
    runway (then the lowest ident, for determinism)."""
    wind = _check_wind(wind_uv, "choose_runway wind_uv")

    def key(rw: Runway):
        head = 0.0 if wind is None else round(headwind_mps(rw, wind), 6)
        return (-head, -rw.length_m, rw.ident)

    return min(apt.runways, key=key)


def runway_frame_xy_m(runway: Runway, lat, lon):
    """Horizontal runway-frame coordinates (m) of points (docs/conventions.md runway frame: origin
    at the threshold, x along the landing course, positive past the threshold, so an
    approaching aircraft has x < 0; y to the left). From the geodesic distance s and
    azimuth a from the threshold: x = s cos(a - c), y = -s sin(a - c); exact on the
    centreline geodesic, which is where it matters."""
    lat_a, lon_a = np.broadcast_arrays(np.asarray(lat, dtype=float), np.asarray(lon, dtype=float))
    az, _, s = inverse(
        np.full(lat_a.shape, runway.threshold_lat), np.full(lat_a.shape, runway.threshold_lon), lat_a, lon_a
    )
    d = np.radians(np.asarray(az) - runway.true_course_deg)
    x, y = np.asarray(s) * np.cos(d), -np.asarray(s) * np.sin(d)
    if x.ndim == 0:
        return float(x), float(y)
    return x, y


def cross_track_to_centreline_m(runway: Runway, lat, lon):
    """Signed distance (m) of points from the runway's extended centreline, positive to
    the left of the landing direction (runway-frame y); for the "within 1 nm of the
    extended centreline" arrival check."""
    return runway_frame_xy_m(runway, lat, lon)[1]


def semicircular_altitude_ft(
    altitude_ft: float, true_course_deg: float, *, floor_ft: float, ceiling_ft: float
) -> float:
    """Nearest whole thousand of feet obeying the semicircular rule (courses 0-179 deg:
    odd thousands; 180-359: even), within [floor, ceiling]; ties go to the lower level.
    The rule is stated for magnetic course; the true course is used here (magnetic
    variation on these networks is 0-20 deg, so only legs within that of north or south
    can differ)."""
    odd = float(wrap360(true_course_deg)) < 180.0
    levels = [
        k * 1000.0
        for k in range(int(math.ceil(floor_ft / 1000.0)), int(ceiling_ft // 1000.0) + 1)
        if (k % 2 == 1) == odd
    ]
    if not levels:
        raise ValueError(
            f"semicircular_altitude_ft: no {'odd' if odd else 'even'} thousand in [{floor_ft}, {ceiling_ft}] ft"
        )
    return min(levels, key=lambda lv: (abs(lv - altitude_ft), lv))


def cruise_altitude_ft(distance_m: float, true_course_deg: float, *, rng: np.random.Generator | None = None) -> float:
    """Cruise pressure altitude (ft) by leg length, FL140-FL250, on the semicircular
    rule. With rng, the level is moved by -2000, 0 or +2000 ft (equally likely) before
    the rule is applied, as traffic and winds move real levels."""
    if not (distance_m > 0.0):
        raise ValueError(f"cruise_altitude_ft: distance_m must be > 0, got {distance_m}")
    base = float(np.interp(distance_m / NM, CRUISE_TABLE_NM, CRUISE_TABLE_FT))
    if rng is not None:
        base += 2000.0 * int(rng.integers(-1, 2))
    return semicircular_altitude_ft(base, true_course_deg, floor_ft=CRUISE_FLOOR_FT, ceiling_ft=CRUISE_CEILING_FT)


def feasible_cruise_ceiling_ft(path_m: float, start_ft: float, end_ft: float) -> float:
    """Highest cruise altitude (ft) whose climb from start_ft (at CLIMB_GRADIENT_FT_PER_NM),
    descent to end_ft (3 deg, 318 ft/nm) and MIN_CRUISE_NM of level flight fit in the
    path length: (h - s)/g_c + (h - e)/g_d + L_min = D, solved for h."""
    g_c = CLIMB_GRADIENT_FT_PER_NM
    g_d = math.tan(math.radians(DESCENT_PATH_DEG)) * NM / FT
    return (path_m / NM - MIN_CRUISE_NM + start_ft / g_c + end_ft / g_d) / (1.0 / g_c + 1.0 / g_d)


@dataclass(frozen=True)
class LegPlan:
    """One planned leg. Heights ``*_height_m`` are WGS-84 ellipsoidal; the cruise is a
    pressure altitude. ``waypoints`` run from the initial point (index 0) to the final
    point; ``segment_lengths_m[i]`` is the geodesic from waypoint i to i+1."""

    flight_id: str
    origin: Airport
    destination: Airport
    departure_runway: Runway
    arrival_runway: Runway
    departure_utc: datetime
    distance_m: float  # great circle, airport reference point to reference point
    true_course_deg: float  # initial geodesic course origin -> destination (semicircular rule)
    initial_course_deg: float  # departure runway course, flown at waypoint 0
    initial_height_m: float
    cruise_pressure_altitude_m: float
    arrival_height_m: float
    waypoints: tuple[Waypoint, ...]
    segment_lengths_m: tuple[float, ...]
    block_time_s: float

    @property
    def cruise_flight_level(self) -> int:
        """Cruise level in hundreds of feet (e.g. 170 for FL170)."""
        return int(round(self.cruise_pressure_altitude_m / FT / 100.0))

    @property
    def total_distance_m(self) -> float:
        """Length of the lateral path from the initial point to the final point (m)."""
        return float(sum(self.segment_lengths_m))

    @property
    def arrival_height_msl_m(self) -> float:
        """Arrival target above mean sea level (m): arrival runway elevation + 2,000 ft."""
        return self.arrival_runway.elevation_m + ARRIVAL_HEIGHT_AGL_FT * FT

    def _check_index(self, index: int) -> None:
        if not (0 <= index < len(self.waypoints)):
            raise ValueError(f"index: expected a waypoint index 0..{len(self.waypoints) - 1}, got {index}")

    def distance_to_go_m(self, index: int, lat, lon):
        """Path distance (m) left from (lat, lon) flying to waypoints[index]: the geodesic to
        that waypoint plus the remaining segments to the final point."""
        self._check_index(index)
        wp = self.waypoints[index]
        _, _, d = inverse(lat, lon, wp.lat, wp.lon)
        rest = sum(self.segment_lengths_m[index:])
        return d + rest

    def cross_track_m(self, index: int, lat, lon):
        """Signed distance (m, positive left) of (lat, lon) from the geodesic segment
        waypoints[index-1] -> waypoints[index] (index >= 1), from the segment's start:
        y = -s sin(a - c)."""
        self._check_index(index)
        if index == 0:
            raise ValueError("index: cross_track_m needs a segment, so index >= 1")
        a, b = self.waypoints[index - 1], self.waypoints[index]
        course, _, _ = inverse(a.lat, a.lon, b.lat, b.lon)
        az, _, s = inverse(a.lat, a.lon, lat, lon)
        return -np.asarray(s) * np.sin(np.radians(np.asarray(az) - course))

    @staticmethod
    def descent_distance_m(from_height_m: float, to_height_m: float, path_angle_deg: float = DESCENT_PATH_DEG) -> float:
        """Ground distance (m) to descend between two heights on a fixed path angle
        (3 deg: 318 ft per nm)."""
        return max(from_height_m - to_height_m, 0.0) / math.tan(math.radians(path_angle_deg))

    @property
    def top_of_descent_to_go_m(self) -> float:
        """Distance to go (m) at which a 3 deg descent from the cruise level reaches the
        arrival height at the final point (pressure altitude taken as height above mean
        sea level, the standard-atmosphere approximation of planning)."""
        return self.descent_distance_m(self.cruise_pressure_altitude_m, self.arrival_height_msl_m)


def _as_airport(apt: Airport | str, name: str) -> Airport:
    if isinstance(apt, Airport):
        return apt
    if isinstance(apt, str):
        return airport(apt)
    raise ValueError(f"{name}: expected an Airport or an ICAO code, got {apt!r}")


def _lateral_path(origin: Airport, dep: Runway, arr: Runway) -> list[Waypoint]:
    far = origin.runway(dep.reciprocal_ident)
    start = Waypoint("DEP", far.start_lat, far.start_lon)
    lat, lon, _ = forward(start.lat, start.lon, dep.true_course_deg, CLIMB_OUT_NM * NM)
    climb = Waypoint("CLIMB", float(lat), float(lon))
    inbound_az = float(wrap360(arr.true_course_deg + 180.0))  # from threshold out along the approach
    # forward's back azimuth at the IF is the centreline's landing course there (it differs
    # from the threshold's by the meridian convergence, ~0.2 deg at 12 nm and 45 N)
    lat, lon, final_course_at_fix = forward(arr.threshold_lat, arr.threshold_lon, inbound_az, INTERMEDIATE_FIX_NM * NM)
    fix = Waypoint("IF", float(lat), float(lon))
    lat, lon, _ = forward(arr.threshold_lat, arr.threshold_lon, inbound_az, FINAL_POINT_NM * NM)
    final = Waypoint("FINAL", float(lat), float(lon))
    path = [start, climb]
    _, back_az, _ = inverse(climb.lat, climb.lon, fix.lat, fix.lon)
    turn = float(wrap180(final_course_at_fix - (back_az + 180.0)))
    if abs(turn) > 90.0:
        side_left = cross_track_to_centreline_m(arr, climb.lat, climb.lon) > 0.0
        base_az = float(final_course_at_fix) + (-90.0 if side_left else 90.0)
        lat, lon, _ = forward(fix.lat, fix.lon, base_az, BASE_OFFSET_NM * NM)
        path.append(Waypoint("BASE", float(lat), float(lon)))
    path += [fix, final]
    return path


def plan_leg(
    origin: Airport | str,
    destination: Airport | str,
    departure_utc: datetime,
    *,
    rng: np.random.Generator | None = None,
    wind_uv: WindUV | None = None,
    arrival_wind_uv: WindUV | None | object = SAME_AS_DEPARTURE,
    flight_id: str = "",
    cruise_flight_level: int | None = None,
) -> LegPlan:
    """Plan one leg: runways into the surface wind (``wind_uv`` at the origin,
    ``arrival_wind_uv`` at the destination, by default the same as ``wind_uv``; None:
    longest runway), the lateral path, the cruise level (by length, semicircular rule, lowered if the
    climb and descent would not fit), initial/arrival ellipsoidal heights and the block
    time. ``rng`` only moves the cruise level (see :func:`cruise_altitude_ft`);
    ``cruise_flight_level`` sets it instead (re-flying a recorded leg)."""
    org = _as_airport(origin, "origin")
    dst = _as_airport(destination, "destination")
    if org.icao == dst.icao:
        raise ValueError(f"destination: must differ from origin, both are {org.icao}")
    if not isinstance(departure_utc, datetime) or departure_utc.utcoffset() is None:
        raise ValueError(f"departure_utc: expected a timezone-aware datetime, got {departure_utc!r}")
    departure_utc = departure_utc.astimezone(UTC)
    dep_wind = _check_wind(wind_uv, "wind_uv")
    if arrival_wind_uv is SAME_AS_DEPARTURE:
        arr_wind = dep_wind
    else:
        arr_wind = _check_wind(arrival_wind_uv, "arrival_wind_uv")
    dep = choose_runway(org, dep_wind)
    arr = choose_runway(dst, arr_wind)

    course, _, distance = inverse(org.lat, org.lon, dst.lat, dst.lon)
    course = float(wrap360(course))
    path = _lateral_path(org, dep, arr)
    segments = tuple(float(inverse(a.lat, a.lon, b.lat, b.lon)[2]) for a, b in zip(path[:-1], path[1:], strict=False))

    far = org.runway(dep.reciprocal_ident)
    initial_msl_ft = far.elevation_m / FT + INITIAL_HEIGHT_AGL_FT
    arrival_msl_ft = arr.elevation_m / FT + ARRIVAL_HEIGHT_AGL_FT
    cruise_ft = (
        cruise_altitude_ft(distance, course, rng=rng) if cruise_flight_level is None else 100.0 * cruise_flight_level
    )
    ceiling_ft = feasible_cruise_ceiling_ft(sum(segments), initial_msl_ft, arrival_msl_ft)
    if cruise_ft > ceiling_ft:
        if ceiling_ft < LOWEST_CRUISE_FT + 2000.0:
            raise ValueError(
                f"destination: leg {org.icao}->{dst.icao} ({distance / NM:.0f} nm) is too short for a climb, "
                f"{MIN_CRUISE_NM:.0f} nm cruise and 3 deg descent above {LOWEST_CRUISE_FT:.0f} ft"
            )
        # highest level of the right parity at or below the feasible ceiling
        cruise_ft = semicircular_altitude_ft(ceiling_ft, course, floor_ft=LOWEST_CRUISE_FT, ceiling_ft=ceiling_ft)
    return LegPlan(
        flight_id=flight_id,
        origin=org,
        destination=dst,
        departure_runway=dep,
        arrival_runway=arr,
        departure_utc=departure_utc,
        distance_m=float(distance),
        true_course_deg=course,
        initial_course_deg=dep.true_course_deg,
        initial_height_m=ellipsoidal_height_m(initial_msl_ft * FT, org.undulation_m),
        cruise_pressure_altitude_m=cruise_ft * FT,
        arrival_height_m=ellipsoidal_height_m(arrival_msl_ft * FT, dst.undulation_m),
        waypoints=tuple(path),
        segment_lengths_m=segments,
        block_time_s=block_time_s(float(distance)),
    )


def with_airway(plan: LegPlan, rng: np.random.Generator) -> LegPlan:
    """The plan with en-route fixes ``AWY1``, ``AWY2``, ... inserted between the climb-out
    point and the next waypoint (``BASE`` or ``IF``), not within ``AIRWAY_MARGIN_NM`` of
    either: gamma-distributed spacing, each segment's course off the direct one by
    N(0, ``AIRWAY_SEGMENT_SIGMA_DEG``), the path closed onto the arrival fix (module
    constants and their source). Legs too short for a fix are returned unchanged."""
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected a numpy.random.Generator, got {rng!r}")
    names = [w.name for w in plan.waypoints]
    if "CLIMB" not in names:
        raise ValueError("plan: expected a CLIMB waypoint (a plan from plan_leg)")
    i = names.index("CLIMB")
    a, b = plan.waypoints[i], plan.waypoints[i + 1]
    course, _, length = inverse(a.lat, a.lon, b.lat, b.lon)
    lo, hi = AIRWAY_MARGIN_NM * NM, float(length) - AIRWAY_MARGIN_NM * NM
    xs: list[float] = []
    x = 0.0
    while True:
        x += float(rng.gamma(AIRWAY_SPACING_SHAPE, AIRWAY_FIX_SPACING_NM * NM / AIRWAY_SPACING_SHAPE))
        if x >= hi:
            break
        if x > lo:
            xs.append(x)
    if not xs:
        return plan
    bounds = np.array([0.0, *xs, float(length)])
    theta = np.radians(rng.normal(0.0, AIRWAY_SEGMENT_SIGMA_DEG, len(bounds) - 1))
    y = np.concatenate([[0.0], np.cumsum(np.diff(bounds) * np.tan(theta))])
    y -= y[-1] * bounds / bounds[-1]  # closes onto the arrival fix
    fixes = []
    for k, (x, yk) in enumerate(zip(xs, y[1:-1], strict=False), start=1):
        lat, lon, back = forward(a.lat, a.lon, course, x)
        # the course there is back + 180, so its right is back - 90; y > 0: right of the path
        lat, lon, _ = forward(lat, lon, float(back) - 90.0, float(yk))
        fixes.append(Waypoint(f"AWY{k}", float(lat), float(lon)))
    path = list(plan.waypoints[: i + 1]) + fixes + list(plan.waypoints[i + 1 :])
    segments = tuple(float(inverse(p.lat, p.lon, q.lat, q.lon)[2]) for p, q in zip(path[:-1], path[1:], strict=False))
    return replace(plan, waypoints=tuple(path), segment_lengths_m=segments)


def block_time_s(distance_m: float) -> float:
    """Scheduled block time (s): distance at 250 kt plus 15 min for taxi, climb and approach."""
    return distance_m / (BLOCK_SPEED_KT * KT) + BLOCK_OVERHEAD_MIN * 60.0


def hub_timezone(net: Network, hub: str) -> ZoneInfo:
    """The time zone of a network's hub (tz database, via zoneinfo and tzdata)."""
    if hub not in net.hub_timezone:
        raise ValueError(f"hub: {hub!r} is not a hub of network {net.name}; hubs are {', '.join(net.hubs)}")
    return ZoneInfo(net.hub_timezone[hub])


def hub_utc_offset_h(net: Network, hub: str, day: date) -> int:
    """Local time minus UTC (h) at a hub at local noon of a date (daylight time included)."""
    offset = datetime.combine(day, time(12, 0), tzinfo=hub_timezone(net, hub)).utcoffset()
    assert offset is not None  # aware: a ZoneInfo always gives an offset
    return int(offset.total_seconds() // 3600)


SurfaceWind = Callable[[Airport, datetime], "WindUV | None"]


def day_schedule(
    network_name: str | Network,
    day: date,
    rng: np.random.Generator,
    *,
    aircraft_id: str,
    surface_wind: SurfaceWind | None = None,
) -> list[LegPlan]:
    """One aircraft's day on a network: a hub drawn from the network's hubs, 4-8 legs
    alternating hub -> spoke -> hub -> ... (each spoke drawn from that hub's spokes),
    first departure 06:00-08:00 hub local time (5-min steps) expressed in UTC, turn
    times 30-60 min (5-min steps), block time distance / 250 kt + 15 min.

    ``surface_wind(airport, time_utc)`` gives the (u, v) surface wind used to choose
    runways (None: longest runway). Flight ids are ``{aircraft_id}-{YYYYMMDD}-{n}``.
    Deterministic given rng."""
    net = network_name if isinstance(network_name, Network) else network(network_name)
    if not isinstance(rng, np.random.Generator):
        raise ValueError(f"rng: expected a numpy.random.Generator, got {rng!r}")
    if isinstance(day, datetime) or not isinstance(day, date):
        raise ValueError(f"day: expected a datetime.date, got {day!r}")
    if not aircraft_id:
        raise ValueError("aircraft_id: expected a non-empty string")
    hub = net.hubs[int(rng.integers(len(net.hubs)))]
    spokes = net.spokes_by_hub[hub]
    n_legs = int(rng.integers(4, 9))
    local_first = datetime.combine(day, time(6, 0)) + timedelta(minutes=5 * int(rng.integers(0, 25)))
    t = local_first.replace(tzinfo=hub_timezone(net, hub)).astimezone(UTC)
    legs: list[LegPlan] = []
    here = hub
    for k in range(n_legs):
        there = spokes[int(rng.integers(len(spokes)))] if here == hub else hub
        org, dst = airport(here), airport(there)
        dep_wind = surface_wind(org, t) if surface_wind is not None else None
        eta = t + timedelta(seconds=block_time_s(float(inverse(org.lat, org.lon, dst.lat, dst.lon)[2])))
        arr_wind = surface_wind(dst, eta) if surface_wind is not None else None
        leg = plan_leg(
            org,
            dst,
            t,
            rng=rng,
            wind_uv=dep_wind,
            arrival_wind_uv=arr_wind,
            flight_id=f"{aircraft_id}-{day:%Y%m%d}-{k + 1}",
        )
        legs.append(leg)
        t = t + timedelta(seconds=leg.block_time_s) + timedelta(minutes=5 * int(rng.integers(6, 13)))
        here = there
    return legs
