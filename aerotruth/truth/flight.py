"""Flying a leg with JSBSim: the truth loop.

Python sets targets once per simulated second (leg sequencing, phase, speed, the truth
wind sample at the aircraft's position one second ahead, the atmosphere's temperature
and pressure); JSBSim flies at 20 Hz (fdm.DT) with the aircraft-agnostic autopilot XML, which
also interpolates the wind to every step. Samples are recorded at 10 Hz into a
TruthTrack. A flight that produces NaN, leaves attitude limits, sinks below its
runways or fails to arrive ends with FlightDiverged (reason and seed), never as truth.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from datetime import UTC, datetime

import jsbsim
import numpy as np

from aerotruth import seeds
from aerotruth.truth.airframes import Airframe, airframe, new_fdm
from aerotruth.truth.fdm import (
    ATMOSPHERE_EVERY,
    DT,
    FPS,
    GUIDE_EVERY,
    RECORD_EVERY,
    FlightDiverged,
    Recorder,
    WindAhead,
    params_digest,
    property_node,
    seed_repr,
    set_atmosphere,
    set_mass,
    trim_or_settle,
)
from aerotruth.truth.guidance import GreatCircleLeg, LegGeometry, arc_ground_speeds_mps, turn_anticipation_m
from aerotruth.truth.profile import VerticalProfile, draw_profile
from aerotruth.truth.steering import NavigationError, SteeringWander
from aerotruth.truth.track import PHASES, TruthTrack
from aerotruth.truth.turbulence import ChopGusts, TurbulencePatches
from aerotruth.truth.weather import Atmosphere, UniformAtmosphere
from aerotruth.units import DEG, FT, G0, KT, NM

TEN_THOUSAND_FT = 10000 * FT
US_SPEED_LIMIT_KT = 250.0  # 14 CFR 91.117(a): 250 KIAS below 10,000 ft MSL
# the bank the FMS plans its turns at, at most: "banks are planned between 0 and 23 deg with
# 25 deg as a maximum" (Honeywell FMZ-series FMS pilot's manual, A28-1146-181 rev. 3, 2009,
# p. 7-23); the autopilot's own limit (gains_*.xml, 25 deg) stays for the approach's turn
# onto final. Below the cap, a fly-by turn is planned at half its course change (the fly-by
# transition of RTCA DO-236B, section 3.2.5.4.1: bank = min(course change / 2, 23 deg)
# below FL195), so a 30-deg turn is flown at 15 deg and only turns of 46 deg or more reach
# the cap.
# A fly-by turn is a path fixed over the ground: an arc of the radius the planned bank gives at
# the turn's largest ground speed, as a procedure's RF turn is built (ICAO Doc 8168 PANS-OPS
# vol. II, part III, section 3, ch. 1, 1.4.5: r = (V + Vw)^2 / (127094 tan phi), V the largest
# true airspeed, Vw the largest wind). Flown at a lower ground speed the arc needs less bank,
# tan(bank) = GS^2 / (g r): the achieved bank varies along the turn with the wind (PANS-OPS
# takes the average achieved bank 5 deg below the maximum), and only a calm-air turn is flown
# at its planned bank throughout.
PLANNED_BANK_DEG = 23.0
FMS_MAX_BANK_DEG = 25.0  # the FMZ's maximum, which an arc flown faster than planned may reach
# turn anticipation assumes this share of the planned bank: the roll-in takes ~7 s
ANTICIPATION_BANK_SHARE = 20.0 / 23.0
TURN_SETTLE_S = 15.0  # the turn's bank limit is held this long past the planned turn's duration


def planned_bank_deg(course_change_deg: float) -> float:
    """The bank a fly-by turn of `course_change_deg` is planned at: half the course change,
    PLANNED_BANK_DEG at most (DO-236B's fly-by transition, module constants)."""
    return min(abs(course_change_deg) / 2.0, PLANNED_BANK_DEG)


# the climb's level change (_Guide._level_change) and the descent path's vertical-speed limits
FLCH_KP_FPM_PER_KT, FLCH_KI_FPM_PER_KT_S = 70.0, 2.2
FLCH_VS_MIN_FPM, FLCH_VS_MAX_FPM = 300.0, 4000.0
FLCH_CAPTURE_FT = 300.0  # the altitude law captures the level from here
DESCENT_VS_MIN_FPM = -2500.0  # rejoining the path after a level-off: an expedited descent at most


@dataclass(frozen=True)
class Route:
    """What the loop flies: waypoints joined by great-circle legs, the start state, the
    cruise pressure altitude and the arrival geometry. Heights are WGS-84 ellipsoidal."""

    name: str
    waypoints: tuple[tuple[str, float, float], ...]
    departure_utc: datetime
    start_h_ellipsoid_m: float
    start_course_deg: float
    cruise_pressure_altitude_m: float
    arrival_h_ellipsoid_m: float
    arrival_threshold: tuple[float, float]
    arrival_course_deg: float
    arrival_far_point: tuple[float, float]
    undulation_m: float
    lowest_runway_ellipsoid_m: float
    departure_elevation_msl_m: float = 0.0
    arrival_elevation_msl_m: float = 0.0

    @property
    def legs(self) -> list[GreatCircleLeg]:
        w = self.waypoints
        return [
            GreatCircleLeg(f"{w[i][0]}-{w[i + 1][0]}", w[i][1], w[i][2], w[i + 1][1], w[i + 1][2])
            for i in range(len(w) - 1)
        ]


class _Guide:
    """Python's 1 Hz part of the guidance: leg sequencing, distance to go, phases, targets.
    Targets are written through property nodes and only when they change."""

    def __init__(self, route: Route, af: Airframe, fdm: jsbsim.FGFDMExec, profile: VerticalProfile | None = None):
        self.route = route
        self.af = af
        self.profile = profile or VerticalProfile()
        self.flch_i = min(af.schedule.climb_vs_fpm, FLCH_VS_MAX_FPM)  # the level change's integral (fpm)
        self.hold_since: dict[str, float] = {}  # level-offs: "climb"/"descent" -> start time
        self.hold_done: set[str] = set()
        legs = route.legs
        self.geom = [LegGeometry(leg, legs[i + 1] if i + 1 < len(legs) else None) for i, leg in enumerate(legs)]
        self.lengths = [g.length_m for g in self.geom]
        self.leg = 0
        self.phase = 0  # index into PHASES
        self.level_since: float | None = None
        self._phase_applied = -1
        pm = fdm.get_property_manager()
        self._nodes: dict[str, jsbsim.FGPropertyNode] = {}
        self._last: dict[str, float] = {}
        self._pm = pm
        self._set("ap/nav/mode", 1)
        self._set("ap/gain/bank-max-rad", math.radians(PLANNED_BANK_DEG))
        self.turn_until = -math.inf  # the planned turn's bank limit holds until then
        self.turn_tan_per_gs2 = 0.0  # the arc being flown: tan(bank) per (m/s)^2 of ground speed
        self._wind_n = property_node(pm, "ap/wind/north-fps").get_double_value
        self._wind_e = property_node(pm, "ap/wind/east-fps").get_double_value
        self._set_leg(0)

    def _set(self, prop: str, value: float) -> None:
        if self._last.get(prop) != value:
            node = self._nodes.get(prop)
            if node is None:
                node = self._nodes[prop] = property_node(self._pm, prop)
            node.set_double_value(float(value))
            self._last[prop] = value

    def _set_leg(self, i: int) -> None:
        self.leg = i
        nx, ny, nz = self.geom[i].n
        self._set("ap/nav/nx", nx)
        self._set("ap/nav/ny", ny)
        self._set("ap/nav/nz", nz)

    def _level_change(self, speed_excess_kt: float) -> float:
        """The level change's vertical speed (fpm) from the speed above its target: PI at the
        1-s guidance rate, its integral frozen while the output is limited. Gains for a
        speed loop through the flight path of natural frequency 0.05 rad/s, damping 0.8 at
        165 KTAS (dV/dt = -g VS / V: 70 fpm per kt, 2.2 fpm per kt-second)."""
        raw = FLCH_KP_FPM_PER_KT * speed_excess_kt + self.flch_i
        out = min(max(raw, FLCH_VS_MIN_FPM), FLCH_VS_MAX_FPM)
        if raw == out:
            self.flch_i += FLCH_KI_FPM_PER_KT_S * speed_excess_kt
        return out

    def _level_off(self, which: str, level_off, t: float, p_alt_ft: float, rising: bool) -> float | None:
        """The pressure altitude (ft) of an ATC level-off still to come or being held, else
        None: held from reaching it for its duration."""
        if level_off is None or which in self.hold_done:
            return None
        alt_ft, dur_s = level_off
        since = self.hold_since.get(which)
        if since is None and (p_alt_ft >= alt_ft - 50.0 if rising else p_alt_ft <= alt_ft + 50.0):
            self.hold_since[which] = since = t
        if since is not None and t - since >= dur_s:
            self.hold_done.add(which)
            return None
        return alt_ft

    def distance_to_go_m(self, lat: float, lon: float) -> float:
        return self.geom[self.leg].to_go_m(lat, lon) + sum(self.lengths[self.leg + 1 :])

    def update(
        self,
        t: float,
        lat: float,
        lon: float,
        vn_mps: float,
        ve_mps: float,
        h_ell_m: float,
        p_alt_m: float,
        tas_kt: float,
        cas_kt: float,
    ) -> bool:
        """Advance legs and phase; set autopilot targets. False once the route is finished.

        Cruise begins once the cruise level and the cruise TAS are both captured (or 300 s
        after level-off if the speed is not): the level-off acceleration belongs to the climb."""
        s = self.af.schedule
        g = self.geom[self.leg]
        to_leg_end = g.to_go_m(lat, lon)
        gs_mps = math.hypot(vn_mps, ve_mps)
        if self.leg + 1 < len(self.geom):
            bank = planned_bank_deg(g.turn_deg)
            if bank > 0.0:
                # the arc planned at the turn's largest ground speed in the FMS's wind (the
                # autopilot's mean wind, without the gusts)
                wn, we = self._wind_n() * FPS, self._wind_e() * FPS
                air = math.hypot(vn_mps - wn, ve_mps - we)
                gs_lo, gs_hi = arc_ground_speeds_mps(air, wn, we, g.course_end_deg, g.turn_deg)
                gs_hi = max(gs_hi, 1.0)
                if to_leg_end <= turn_anticipation_m(gs_hi, g.turn_deg, ANTICIPATION_BANK_SHARE * bank):
                    self._set_leg(self.leg + 1)
                    tan_bank = math.tan(math.radians(bank))
                    radius_m = gs_hi * gs_hi / (G0 * tan_bank)
                    self.turn_tan_per_gs2 = 1.0 / (G0 * radius_m)
                    # the arc flown at the bank its ground speed needs, then the LNAV's full limit
                    self.turn_until = t + radius_m * math.radians(abs(g.turn_deg)) / max(gs_lo, 1.0) + TURN_SETTLE_S
            elif to_leg_end <= 0.0:
                self._set_leg(self.leg + 1)
        elif to_leg_end <= 0.0:
            return False
        if t > self.turn_until:
            self._set("ap/gain/bank-max-rad", math.radians(PLANNED_BANK_DEG))
        else:
            arc_bank = math.atan(self.turn_tan_per_gs2 * gs_mps * gs_mps)
            self._set("ap/gain/bank-max-rad", min(arc_bank, math.radians(FMS_MAX_BANK_DEG)))
        to_go = self.distance_to_go_m(lat, lon)
        r = self.route
        final = self.leg == len(self.geom) - 1
        grad = self.profile.descent_gradient
        # top of descent: where the planned path from the arrival height (8 nm out) meets the aircraft
        descent_needed_m = (h_ell_m - r.arrival_h_ellipsoid_m) / grad
        if self.phase < 2 and to_go <= descent_needed_m + 8 * NM:
            self.phase = 2
        if self.phase == 2 and final:
            self.phase = 3
        if self.phase == 0 and abs(p_alt_m - r.cruise_pressure_altitude_m) < 50 * FT:
            if self.level_since is None:
                self.level_since = t
            if abs(tas_kt - s.cruise_tas_kt) < 2.0 or t - self.level_since > 300.0:
                self.phase = 1
        if self.phase != self._phase_applied:
            for prop, value in self.af.phase_properties.get(PHASES[self.phase], {}).items():
                self._set(prop, value)
            self._phase_applied = self.phase
        levelled = self.level_since is not None
        ias = {0: s.climb_ias_kt, 1: s.climb_ias_kt, 2: s.descent_ias_kt, 3: s.arrival_ias_kt}[self.phase]
        if self.phase == 0:
            # no faster than the cruise TAS: its calibrated equivalent here is cruise_tas * CAS/TAS
            ias = min(ias, s.cruise_tas_kt * cas_kt / max(tas_kt, 1.0))
        if to_go < 25 * NM:
            ias = min(ias, s.arrival_ias_kt)
        if h_ell_m - r.undulation_m < TEN_THOUSAND_FT:
            ias = min(ias, US_SPEED_LIMIT_KT)
        if self.phase <= 1:
            target_ft = r.cruise_pressure_altitude_m / FT
            held = self._level_off("climb", self.profile.climb_level_off, t, p_alt_m / FT, rising=True)
            if held is not None:
                target_ft = held
            self._set("ap/target/use-pressure-altitude", 1)
            self._set("ap/target/altitude-ft", target_ft)
            self._set("ap/target/altitude-rate-fps", 0.0)
            self._set("ap/target/vs-min-fpm", -1000.0)
            power = s.climb_throttle
            if power is not None and self.phase == 0 and target_ft - p_alt_m / FT > FLCH_CAPTURE_FT:
                self._set("ap/target/throttle-fixed", power)
                self._set("ap/target/vs-max-fpm", self._level_change(cas_kt - ias))
            else:
                self._set("ap/target/throttle-fixed", -1.0)
                self._set("ap/target/vs-max-fpm", s.climb_vs_fpm)
        else:
            self._set("ap/target/throttle-fixed", -1.0)
            self._set("ap/target/use-pressure-altitude", 0)
            along = max(0.0, to_go - 8 * NM)
            target_m = r.arrival_h_ellipsoid_m + along * grad
            rate = -gs_mps * grad if along > 0.0 else 0.0
            held = self._level_off("descent", self.profile.descent_level_off, t, p_alt_m / FT, rising=False)
            if held is not None:  # the restriction's pressure altitude as a height here
                hold_m = h_ell_m + (held * FT - p_alt_m)
                if hold_m > target_m:
                    target_m, rate = hold_m, 0.0
            self._set("ap/target/altitude-ft", target_m / FT)
            self._set("ap/target/altitude-rate-fps", rate / FT)
            self._set("ap/target/altitude-t0-sec", t)
            self._set("ap/target/vs-max-fpm", 1000.0)
            self._set("ap/target/vs-min-fpm", s.descent_vs_fpm if s.climb_throttle is None else DESCENT_VS_MIN_FPM)
        if self.phase == 1 or (self.phase == 0 and levelled):
            self._set("ap/target/speed-mode", 2)
            self._set("ap/target/tas-kt", s.cruise_tas_kt)
        else:
            self._set("ap/target/speed-mode", 0)
            self._set("ap/target/ias-kt", ias)
        return True


def _initial_conditions(
    fdm, route: Route, af: Airframe, atmosphere: Atmosphere, t0_s: float, mass_kg: float | None = None
) -> None:
    lat, lon = route.waypoints[0][1], route.waypoints[0][2]
    fdm["ic/lat-geod-deg"] = lat
    fdm["ic/long-gc-deg"] = lon
    fdm["ic/h-sl-ft"] = route.start_h_ellipsoid_m / FT
    fdm["ic/terrain-elevation-ft"] = route.lowest_runway_ellipsoid_m / FT
    if af.fuel_lbs is not None:
        for i, lbs in enumerate(af.fuel_lbs):
            fdm[f"propulsion/tank[{i}]/contents-lbs"] = lbs
    for k, v in af.extra_ic.items():
        fdm[k] = v
    if mass_kg is not None:
        set_mass(fdm, mass_kg)
    set_atmosphere(fdm, route, atmosphere, lat, lon, t0_s)
    u, v, w = (
        float(np.asarray(c).ravel()[0])
        for c in atmosphere.wind(
            lat,
            lon,
            route.start_h_ellipsoid_m - route.undulation_m,
            t0_s,
            ground_elevation_m=route.departure_elevation_msl_m,
        )
    )
    fdm["ap/wind/t0-sec"] = 0.0
    fdm["ap/wind/north-fps"], fdm["ap/wind/east-fps"], fdm["ap/wind/down-fps"] = v / FPS, u / FPS, -w / FPS
    # JSBSim 1.3.3's initial condition ignores the wind when it builds the ground velocity
    # (the ic/vw-* setters do not take), so set the state it can hold exactly: ground
    # velocity G = TAS h(psi) + W along the start course chi, body heading psi from the
    # wind triangle, entered as a sideslip of the IC velocity (heading = psi_ic - beta_ic).
    # CAS -> TAS first: an angle set after ic/vc-kts corrupts the speed.
    fdm["ic/vc-kts"] = af.schedule.initial_ias_kt
    tas = fdm["ic/vt-kts"] * KT
    # the leg starts in the climb it is flown in: the schedule's climb rate at the start
    # speed; the air-relative velocity then has a horizontal part sqrt(TAS^2 - climb^2)
    climb = min(0.25 * tas, af.schedule.climb_vs_fpm * FT / 60.0)
    tas_h = math.sqrt(tas * tas - climb * climb)
    chi = route.start_course_deg * DEG
    cross = -v * math.sin(chi) + u * math.cos(chi)  # wind to the right of the course
    psi = chi - math.asin(max(-0.5, min(0.5, cross / tas_h)))
    gn, ge = tas_h * math.cos(psi) + v, tas_h * math.sin(psi) + u
    fdm["ic/psi-true-deg"] = route.start_course_deg
    fdm["ic/gamma-deg"] = math.degrees(math.atan2(climb, math.hypot(gn, ge)))
    fdm["ic/beta-deg"] = (chi - psi) / DEG
    fdm["ic/vt-kts"] = math.hypot(math.hypot(gn, ge), climb) / KT


def fly_route(
    route: Route,
    *,
    seed,
    aircraft: str | Airframe | None = None,
    atmosphere: Atmosphere | None = None,
    turbulence: bool = False,
    max_duration_s: float | None = None,
    meta: dict | None = None,
) -> TruthTrack:
    """Fly `route` with JSBSim and return its TruthTrack (10 Hz). `turbulence`: the
    atmosphere's disturbances (MIL-F-8785C patches and light chop); without it the air is
    calm. The guidance's own errors (the autopilot's steering wander and the FMS's
    navigation error, aerotruth.truth.steering) and the vertical profile's draws
    (aerotruth.truth.profile) are part of every flight. Raises FlightDiverged."""
    af = aircraft if isinstance(aircraft, Airframe) else airframe(aircraft)
    atmosphere = atmosphere if atmosphere is not None else UniformAtmosphere()
    rng = np.random.default_rng(seed)
    day0 = route.departure_utc.replace(hour=0, minute=0, second=0, microsecond=0)
    t0_s = (route.departure_utc - day0).total_seconds()
    fdm = new_fdm(af, DT)
    # the flight's vertical profile (mass, descent path, ATC level-offs) from its own named
    # stream, the same calm or turbulent (aerotruth.truth.profile)
    profile = draw_profile(
        seeds.generator(seeds.named_child(seed, "profile")),
        route.cruise_pressure_altitude_m / FT,
        (route.arrival_h_ellipsoid_m - route.undulation_m) / FT,
        mass=af.name == "saab340",
    )
    _initial_conditions(fdm, route, af, atmosphere, t0_s, profile.mass_kg)
    # JSBSim's milspec turbulence in patches along the path with the MIL-F-8785C climatology
    # (aerotruth.truth.turbulence); its generator is seeded from the flight's stream
    patches = TurbulencePatches(fdm, rng) if turbulence else None
    # light chop below the MIL-F-8785C curves (the A320 recorder's climatology), its own stream
    chop = ChopGusts(fdm, rng.spawn(1)[0], fdm["metrics/bw-ft"] * FT) if turbulence else None
    # the autopilot's steering wander (the A320 recorder's weave in straight flight) and the
    # FMS's navigation error: in every flight, calm or not, each on its own named stream
    wander = SteeringWander(fdm, seeds.generator(seeds.named_child(seed, "steering")))
    nav_error = NavigationError(fdm, seeds.generator(seeds.named_child(seed, "navigation")), dt_s=GUIDE_EVERY * DT)
    path_m = 0.0
    # guidance and targets before the initial condition is run: JSBSim evaluates the
    # autopilot (filters, rate limiters) during initialisation and trim, and stale targets
    # there (altitude 0, the default leg normal) started every leg with a -1,200 fpm dive
    # and a 17 deg roll transient
    guide = _Guide(route, af, fdm, profile)
    s = af.schedule
    for prop, value in (
        ("ap/target/use-pressure-altitude", 1),
        ("ap/target/altitude-ft", route.cruise_pressure_altitude_m / FT),
        ("ap/target/vs-max-fpm", s.climb_vs_fpm),
        ("ap/target/vs-min-fpm", -1000.0),
        ("ap/target/speed-mode", 0),
        ("ap/target/ias-kt", s.initial_ias_kt),
    ):
        fdm[prop] = value
    for prop, value in af.phase_properties.get("climb", {}).items():
        fdm[prop] = value
    fdm.run_ic()
    fdm["propulsion/set-running"] = -1
    trim_or_settle(fdm, af)
    fdm["ap/active"] = 1

    total_m = float(sum(guide.lengths))
    limit_s = max_duration_s if max_duration_s is not None else total_m / (180 * KT) + 1800.0
    rec = Recorder(fdm)
    rows, tags = rec.rows, rec.tags
    getters = rec.getters
    run = fdm.run
    pm = fdm.get_property_manager()
    (g_lat, g_lon, g_h, g_palt, g_vn, g_ve, g_vd, g_t, g_vt, g_vc, g_phi, g_theta) = (
        property_node(pm, p).get_double_value
        for p in (
            "position/lat-geod-deg",
            "position/long-gc-deg",
            "position/geod-alt-ft",
            "atmosphere/pressure-altitude",
            "velocities/v-north-fps",
            "velocities/v-east-fps",
            "velocities/v-down-fps",
            "simulation/sim-time-sec",
            "velocities/vtrue-fps",
            "velocities/vc-fps",
            "attitude/phi-rad",
            "attitude/theta-rad",
        )
    )
    g_psi = property_node(pm, "attitude/psi-rad").get_double_value
    wind_ahead = WindAhead(fdm, atmosphere, t0_s, GUIDE_EVERY * DT)
    max_bank, max_pitch, min_pitch = af.max_bank_deg * DEG, af.max_pitch_deg * DEG, af.min_pitch_deg * DEG
    floor_ft = (route.lowest_runway_ellipsoid_m - 150.0) / FT
    seed_id = seed_repr(seed)
    ticks = 0
    g_fuel = property_node(pm, "propulsion/total-fuel-lbs").get_double_value
    fuel_floor_lbs = 0.01 * g_fuel()

    while True:
        lat, lon, h_ft = g_lat(), g_lon(), g_h()
        t = g_t()
        phi, theta = g_phi(), g_theta()
        if not all(map(math.isfinite, (lat, lon, h_ft, phi, theta))):
            raise FlightDiverged("NaN in the JSBSim state", seed_id, t)
        if abs(phi) > max_bank or theta > max_pitch or theta < min_pitch:
            raise FlightDiverged(f"attitude limit: roll {phi / DEG:.1f} deg, pitch {theta / DEG:.1f} deg", seed_id, t)
        if h_ft < floor_ft:
            raise FlightDiverged(f"altitude {h_ft * FT:.0f} m below the runways", seed_id, t)
        if t > limit_s:
            raise FlightDiverged(f"did not arrive within {limit_s:.0f} s", seed_id, t)
        if g_fuel() < fuel_floor_lbs:
            raise FlightDiverged(f"fuel exhausted ({g_fuel():.0f} lb left)", seed_id, t)
        vn, ve, vd = g_vn() * FPS, g_ve() * FPS, g_vd() * FPS
        gs = math.hypot(vn, ve)
        if not guide.update(t, lat, lon, vn, ve, h_ft * FT, g_palt() * FT, g_vt() / KT * FPS, g_vc() / KT * FPS):
            break
        dt_g = GUIDE_EVERY * DT
        ground = route.departure_elevation_msl_m if guide.phase < 2 else route.arrival_elevation_msl_m
        wind_ahead.update(t, lat, lon, h_ft * FT, route.undulation_m, vn, ve, vd, ground)
        nav_error.step()
        if patches is not None:
            assert chop is not None  # patches and chop exist iff turbulence
            if patches.due(path_m):
                patches.update_from(path_m, atmosphere, lat, lon, ground, t0_s + t)
            if chop.due(path_m):
                chop.update(path_m)
            path_m += gs * dt_g
        ticks += 1
        if ticks % ATMOSPHERE_EVERY == 0:
            set_atmosphere(fdm, route, atmosphere, lat, lon, t0_s + t)
        tag = (guide.leg, guide.phase)
        for _ in range(GUIDE_EVERY // RECORD_EVERY):
            rows.append([g() for g in getters])
            tags.append(tag)
            if chop is not None:
                chop.step(g_vt() * FPS, g_psi())
            wander.step()
            for _ in range(RECORD_EVERY):
                run()

    df = rec.frame(rows, tags)
    if not np.isfinite(df.drop(columns=["phase"]).to_numpy()).all():
        raise FlightDiverged("NaN in the recorded truth", seed_id)
    meta = dict(meta or {})
    thr, far = route.arrival_threshold, route.arrival_far_point
    meta.update(
        {
            "route": route.name,
            "aircraft": af.name,
            "seed": seed_id,
            "jsbsim_version": jsbsim.__version__,
            "departure_utc": route.departure_utc.astimezone(UTC).isoformat(),
            "cruise_tas_kt": af.schedule.cruise_tas_kt,
            "cruise_pressure_altitude_m": route.cruise_pressure_altitude_m,
            "legs": [asdict(leg) for leg in route.legs],
            "arrival_runway": {
                "threshold_lat": thr[0],
                "threshold_lon": thr[1],
                "far_lat": far[0],
                "far_lon": far[1],
                "course_deg": route.arrival_course_deg,
            },
            "turbulence": bool(turbulence),
            "turbulence_patches": patches.meta() if patches is not None else [],
            "chop_patches": [[round(a, 1), round(sw, 3)] for a, sw in chop.patches] if chop is not None else [],
            "rate_hz": 1.0 / (DT * RECORD_EVERY),
            "vertical_profile": asdict(profile),
        }
    )
    meta["config_hash"] = params_digest({k: meta[k] for k in sorted(meta) if k != "config_hash"})
    return TruthTrack(df, meta)


def route_from_plan(plan) -> Route:
    """The loop's Route for a routes.LegPlan (waypoints, ellipsoidal heights, arrival
    centreline; the undulation used for MSL heights is the mean of the two airports')."""
    from aerotruth import geo

    rw = plan.arrival_runway
    far_lat, far_lon, _ = geo.forward(rw.threshold_lat, rw.threshold_lon, (rw.true_course_deg + 180.0) % 360.0, 30 * NM)
    return Route(
        name=f"{plan.origin.icao}-{plan.destination.icao}",
        waypoints=tuple((w.name, float(w.lat), float(w.lon)) for w in plan.waypoints),
        departure_utc=plan.departure_utc,
        start_h_ellipsoid_m=float(plan.initial_height_m),
        start_course_deg=float(plan.initial_course_deg),
        cruise_pressure_altitude_m=float(plan.cruise_pressure_altitude_m),
        arrival_h_ellipsoid_m=float(plan.arrival_height_m),
        arrival_threshold=(float(rw.threshold_lat), float(rw.threshold_lon)),
        arrival_course_deg=float(rw.true_course_deg),
        arrival_far_point=(float(far_lat), float(far_lon)),
        undulation_m=0.5 * (plan.origin.undulation_m + plan.destination.undulation_m),
        lowest_runway_ellipsoid_m=min(plan.origin.elevation_ellipsoid_m, plan.destination.elevation_ellipsoid_m),
        departure_elevation_msl_m=float(plan.origin.elevation_m),
        arrival_elevation_msl_m=float(plan.destination.elevation_m),
    )


def fly_leg(
    plan,
    *,
    seed,
    aircraft: str | Airframe | None = None,
    turbulence: bool = False,
    atmosphere: Atmosphere | None = None,
    region: str | None = None,
) -> TruthTrack:
    """Fly a routes.LegPlan through the day's truth atmosphere (unless one is given).
    `seed` (int or SeedSequence) selects the atmosphere realization of the day and the
    flight's own draws (turbulence, chop, steering wander, navigation error, vertical
    profile). Raises FlightDiverged."""
    if atmosphere is None:
        from aerotruth.truth.weather import truth_atmosphere_for

        atmosphere = truth_atmosphere_for(plan, seed, region)
    atm = atmosphere
    meta = {
        "origin": plan.origin.icao,
        "destination": plan.destination.icao,
        "departure_runway": plan.departure_runway.ident,
        "arrival_runway_ident": plan.arrival_runway.ident,
        "flight_id": plan.flight_id,
        "cruise_flight_level": plan.cruise_flight_level,
        "atmosphere": getattr(atm, "region_key", type(atm).__name__),
    }
    return fly_route(
        route_from_plan(plan), seed=seed, aircraft=aircraft, atmosphere=atm, turbulence=turbulence, meta=meta
    )
