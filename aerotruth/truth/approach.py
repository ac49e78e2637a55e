"""An ILS approach flown by JSBSim to make truth for flight inspection (the FITS paper).

The aircraft starts on the extended centreline `start_nm` out, level below the glide
path, flaps 15, and flies a coupled localizer and glide-slope approach: the LNAV
channel of the autopilot XML tracks the centreline great circle with localizer gains,
and the vertical channel tracks the glide-path cone, whose height Python gives once a
second as a moving target that the XML extrapolates at its rate every step. The
configuration follows a crew's schedule: gear down and flaps 20 at glide-path capture,
flaps 35 below 2,000 ft above the threshold, Vref + 5 kt by 1,000 ft (stabilised).
Then either the AFIS profile (a level pass over the runway at `pass_height_ft`, as the
FAA's AFIS flies to update its INS with the radar altimeter and TVPS; FITS paper
section II) or a go-around at the decision altitude. Recording continues for
`past_threshold_s` after the threshold (filters need data on both sides).

Geometry is the runway frame (aerotruth.truth.runway) and the glide path of an ILS
installation (aerotruth.truth.ils: glide-path mast at x_G = TCH / tan(theta) abeam
the touchdown zone, offset to the side): the aircraft flies the facility's nominal
beams; the facility's errors are what an inspection measures.

Recording is at 50 Hz: the 10 Hz route columns, plus the runway-frame position of the
CG, the CG location, and the inertial truth of aircraft/systems/aerotruth_imu.xml as
increments per 20 ms (dv at the IMU point in body axes, dtheta of the inertial body
rate), differenced from integrals JSBSim accumulates every step; the strapdown
self-consistency test (tests/test_approach.py) closes on them.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from datetime import UTC, datetime
from datetime import date as Date
from typing import TYPE_CHECKING, Any, Protocol

import jsbsim
import numpy as np

from aerotruth import seeds
from aerotruth.truth.airframes import Airframe, airframe, new_fdm
from aerotruth.truth.airports import Runway, airport
from aerotruth.truth.fdm import (
    FPS,
    ILS_DT,
    FlightDiverged,
    Recorder,
    WindAhead,
    params_digest,
    seed_repr,
    set_atmosphere,
    set_mass,
    trim_or_settle,
)
from aerotruth.truth.guidance import GreatCircleLeg
from aerotruth.truth.ils import IlsFacilitySpec
from aerotruth.truth.runway import RunwayFrame
from aerotruth.truth.steering import STEER_DT_S, SteeringWander
from aerotruth.truth.track import TruthTrack
from aerotruth.truth.turbulence import Mil8785Gusts, TurbulencePatches
from aerotruth.truth.weather import Atmosphere, UniformAtmosphere
from aerotruth.units import DEG, FT, KT, NM

if TYPE_CHECKING:
    import pandas as pd

RATE_HZ = 50
GUST_UPDATE_S = 0.02  # s: the approach's gusts are updated at 50 Hz
STEPS_PER_SAMPLE = int(round(1.0 / (RATE_HZ * ILS_DT)))  # 2 at the 100 Hz step
GUIDE_EVERY = round(1.0 / ILS_DT)  # steps: 1 Hz targets and wind
IN = 0.0254  # m per inch
ALT_TO_VS_FPM_PER_FT = 4.0  # ap/gain/alt-to-vs of gains_saab340.xml
PROFILES = ("afis", "go-around")


@dataclass(frozen=True)
class ApproachSchedule:
    """What a SAAB 340 crew flies on an ILS (speeds KIAS). Vref = 1.3 Vs(flaps 35) scales
    as sqrt(mass): 120.4 KCAS at the maximum landing weight from the model's own 1-g
    stall (tests/test_saab340.py). Flap placards are estimates for the class (the
    published 340B limits are not at hand): VFE 35 140 KIAS, VFE 20 165, VLO 180."""

    vref_mlw_kt: float = 120.4
    mlw_kg: float = 12930.0
    initial_ias_kt: float = 160.0
    capture_ias_kt: float = 150.0
    vfe35_kt: float = 140.0
    flaps35_below_ft: float = 2000.0  # above the threshold
    additive_kt: float = 5.0  # Vapp = Vref + 5

    def vref_kt(self, mass_kg: float) -> float:
        return self.vref_mlw_kt * math.sqrt(mass_kg / self.mlw_kg)


# Sensor points on the airframe, JSBSim structural frame (m: x aft of the nose, y right,
# z up from the fuselage datum). Estimates for a SAAB 340 installation: GNSS antenna on
# the crown over the wing box, IMU in the avionics bay under the cabin floor near the CG,
# radar altimeter and TVPS camera on the belly, localizer and glide-slope antennas in
# the nose. Documented in docs/data-formats.md.
DEFAULT_POINTS_M: dict[str, tuple[float, float, float]] = {
    "gnss": (8.50, 0.0, 1.25),
    "imu": (8.00, 0.0, -0.60),
    "radar_altimeter": (9.50, 0.0, -1.15),
    "tvps": (3.00, 0.0, -1.10),
    "loc_antenna": (0.50, 0.0, 0.20),
    "gs_antenna": (0.80, 0.0, -0.10),
}


MTOW_KG = 13155.0  # SAAB 340B maximum take-off mass: no landing is heavier


@dataclass(frozen=True)
class ApproachSpec:
    """One approach: where, when, how (heights above the threshold in ft, edges only)."""

    airport: str
    runway: str
    start_utc: datetime
    profile: str = "afis"
    start_nm: float = 14.0
    intercept_nm: float = 12.5  # glide path captured from below about here
    pass_height_ft: float = 100.0  # AFIS level pass over the runway
    decision_height_ft: float = 200.0  # go-around
    go_around_height_ft: float = 2000.0
    past_threshold_s: float = 110.0
    offset_nm: float = 0.0  # start this far left (+) or right (-) of the centreline ...
    intercept_deg: float = 0.0  # ... on a heading this far off the course, towards it: a turn onto final
    mass_kg: float = 12000.0
    turbulence: bool = False
    ils: IlsFacilitySpec = field(default_factory=IlsFacilitySpec)
    points_m: dict[str, tuple[float, float, float]] = field(default_factory=lambda: dict(DEFAULT_POINTS_M))

    def __post_init__(self) -> None:
        if self.profile not in PROFILES:
            raise ValueError(f"profile: expected one of {PROFILES}, got {self.profile!r}")
        if not self.start_nm > self.intercept_nm >= 11.0:
            raise ValueError(
                f"start_nm/intercept_nm: expected start > intercept >= 11 nm, got {self.start_nm}/{self.intercept_nm}"
            )
        if "imu" not in self.points_m:
            raise ValueError("points_m: the IMU point is required")
        if not 0.0 <= self.intercept_deg <= 45.0:
            raise ValueError(f"intercept_deg: expected 0..45 deg, got {self.intercept_deg}")
        if not abs(self.offset_nm) <= 3.0:  # NaN too
            raise ValueError(f"offset_nm: expected at most 3 nm either side, got {self.offset_nm}")
        if not 0.0 < self.mass_kg <= MTOW_KG:  # the lower bound is the model's (fdm.set_mass)
            raise ValueError(
                f"mass_kg: expected a landing mass above 0 and at most the SAAB 340B's maximum take-off mass, "
                f"{MTOW_KG:,.0f} kg, got {self.mass_kg:g}"
            )


def find_runway(icao: str, ident: str) -> Runway:
    apt = airport(icao)  # raises ValueError naming the airport
    key = ident.strip().upper().lstrip("0") or "0"
    for rw in apt.runways:
        if rw.ident.upper().lstrip("0") == key:
            return rw
    raise ValueError(f"runway: {icao} has no runway {ident!r}; expected one of {sorted(r.ident for r in apt.runways)}")


class GlidePath:
    """Nominal ILS geometry in the runway frame."""

    def __init__(self, spec: IlsFacilitySpec, runway: Runway):
        self.theta = spec.glide_path_deg * DEG
        self.tan = math.tan(self.theta)
        self.gp_x = spec.tch_m / self.tan
        self.gp_y = spec.gp_offset_m
        self.loc_x = runway.length_m + spec.loc_setback_m
        self.loc_half_sector = math.atan(0.155 / 0.00145 / self.loc_x)  # sensors/ils.py

    def height_m(self, x: float, y: float) -> float:
        """Height of the glide-path cone above the runway plane at (x, y)."""
        return math.hypot(x - self.gp_x, y - self.gp_y) * self.tan

    def gs_dots(self, x: float, y: float, z: float) -> float:
        """Glide-slope deviation in dots (+ above; 1 dot = 75 uA = 0.0875 DDM = 0.12 theta)."""
        eps = math.atan2(z, math.hypot(x - self.gp_x, y - self.gp_y))
        return (eps - self.theta) / (0.12 * self.theta)

    def loc_dots(self, x: float, y: float) -> float:
        """Localizer deviation in dots (+ left; 1 dot = 75 uA = half the half course sector)."""
        return math.atan2(y, self.loc_x - x) / (0.5 * self.loc_half_sector)


INERTIAL_PROPS = (
    tuple(f"imu/v-{a}-fps" for a in "xyz")
    + tuple(f"imu/theta-{a}-rad" for a in "xyz")
    + tuple(f"inertia/cg-{a}-in" for a in "xyz")
)


def _ic(
    fdm,
    frame: RunwayFrame,
    gp: GlidePath,
    spec: ApproachSpec,
    af: Airframe,
    sched: ApproachSchedule,
    atmosphere: Atmosphere,
    undulation: float,
    t0_s: float,
) -> None:
    # y is left of the course: from the left (y > 0) the intercept heads right of the course
    initial_conditions(
        fdm,
        frame,
        -spec.start_nm * NM,
        spec.offset_nm * NM,
        gp.height_m(-spec.intercept_nm * NM, 0.0),
        frame.course_deg + math.copysign(spec.intercept_deg, spec.offset_nm),
        af,
        spec.mass_kg,
        sched.initial_ias_kt,
        15.0,
        atmosphere,
        undulation,
        t0_s,
    )


def initial_conditions(
    fdm,
    frame: RunwayFrame,
    x0: float,
    y0: float,
    z0: float,
    track_deg: float,
    af: Airframe,
    mass_kg: float,
    ias_kt: float,
    flaps_deg: float,
    atmosphere: Atmosphere,
    undulation: float,
    t0_s: float,
) -> None:
    """JSBSim's initial condition at runway-frame (x0, y0, z0), level, on the ground track
    `track_deg` in the truth wind (heading crabbed into it), at `ias_kt`, with the flaps set."""
    lat, lon, h = (float(v) for v in frame.to_geodetic(x0, y0, z0))
    fdm["ic/lat-geod-deg"] = lat
    fdm["ic/long-gc-deg"] = lon
    fdm["ic/h-sl-ft"] = h / FT
    fdm["ic/terrain-elevation-ft"] = (frame.h0_m - 50.0) / FT
    for k, v in af.extra_ic.items():
        fdm[k] = v
    set_mass(fdm, mass_kg)
    fdm["fcs/flap-cmd-norm"] = flaps_deg / 35.0
    fdm["fcs/flap-pos-deg"] = flaps_deg
    set_atmosphere(fdm, _Und(undulation), atmosphere, lat, lon, t0_s)
    u, v, w = (float(np.asarray(c).ravel()[0]) for c in atmosphere.wind(lat, lon, h - undulation, t0_s))
    fdm["ap/wind/t0-sec"] = 0.0
    fdm["ap/wind/north-fps"], fdm["ap/wind/east-fps"], fdm["ap/wind/down-fps"] = v / FPS, u / FPS, -w / FPS
    # same construction as the route loop's initial condition (see flight._initial_conditions)
    fdm["ic/vc-kts"] = ias_kt
    tas = fdm["ic/vt-kts"] * KT
    chi = track_deg * DEG
    cross = -v * math.sin(chi) + u * math.cos(chi)
    psi = chi - math.asin(max(-0.5, min(0.5, cross / tas)))
    gn, ge = tas * math.cos(psi) + v, tas * math.sin(psi) + u
    fdm["ic/psi-true-deg"] = track_deg
    fdm["ic/gamma-deg"] = 0.0
    fdm["ic/beta-deg"] = (chi - psi) / DEG
    fdm["ic/vt-kts"] = math.hypot(gn, ge) / KT


@dataclass(frozen=True)
class _Und:
    undulation_m: float


class _Guide:
    """1 Hz guidance: vertical mode, configuration and speed schedule."""

    def __init__(self, fdm, spec: ApproachSpec, sched: ApproachSchedule, gp: GlidePath, frame: RunwayFrame):
        self.fdm, self.spec, self.sched, self.gp, self.frame = fdm, spec, sched, gp, frame
        self.mode = "level"  # level -> glidepath -> pass | go-around
        self.vapp = sched.vref_kt(spec.mass_kg) + sched.additive_kt
        self.events: dict[str, float] = {}
        self.z_level = gp.height_m(-spec.intercept_nm * NM, 0.0)
        pm = fdm.get_property_manager()
        self._pm = pm
        self._nodes: dict[str, jsbsim.FGPropertyNode] = {}

    def _set(self, prop: str, value: float) -> None:
        node = self._nodes.get(prop)
        if node is None:
            node = self._nodes[prop] = self._pm.get_node(prop)
        node.set_double_value(float(value))

    def update(self, t: float, x: float, y: float, z: float, h_ell: float, vx: float, vd: float, cas_kt: float) -> None:
        s, gp = self.spec, self.gp
        z_gp = gp.height_m(x, y)
        rate = 0.0
        if self.mode == "level" and z >= z_gp - 1.0:
            self.mode = "glidepath"
            self.events["gs_capture_s"] = t
            self._set("fcs/gear-cmd-norm", 1.0)
            self._set("fcs/flap-cmd-norm", 20.0 / 35.0)
        if self.mode == "glidepath":
            # level-off where the altitude law's command (4 fpm per ft of error) equals the
            # sink rate, so the capture is an exponential that never undershoots the pass height
            if s.profile == "afis" and z - s.pass_height_ft * FT <= max(vd, 0.0) * 60.0 / ALT_TO_VS_FPM_PER_FT:
                self.mode = "pass"
                self.events["level_pass_s"] = t
            elif s.profile == "go-around" and z <= s.decision_height_ft * FT:
                self.mode = "go-around"
                self.events["go_around_s"] = t
                self._set("fcs/flap-cmd-norm", 15.0 / 35.0)
        if self.mode == "go-around" and "gear_up_s" not in self.events and t - self.events["go_around_s"] > 5.0:
            self.events["gear_up_s"] = t
            self._set("fcs/gear-cmd-norm", 0.0)
        if "threshold_s" not in self.events and x >= 0.0:
            self.events["threshold_s"] = t
        # vertical target (ellipsoidal height, moving at the path's rate)
        if self.mode == "level":
            target_z = self.z_level
        elif self.mode == "glidepath":
            target_z = z_gp
            rate = vx * gp.tan * (x - gp.gp_x) / max(math.hypot(x - gp.gp_x, y - gp.gp_y), 1.0)
        elif self.mode == "pass":
            target_z = s.pass_height_ft * FT
        else:
            target_z = s.go_around_height_ft * FT
        self._set("ap/target/altitude-ft", (h_ell + target_z - z) / FT)
        self._set("ap/target/altitude-rate-fps", rate / FT)
        self._set("ap/target/altitude-t0-sec", t)
        self._set("ap/target/vs-max-fpm", 1500.0 if self.mode == "go-around" else 1000.0)
        self._set("ap/target/vs-min-fpm", -1500.0)
        self._set("ap/target/path-mode", float(self.mode in ("glidepath", "pass")))
        # speed and flaps
        if self.mode == "level":
            ias = self.sched.initial_ias_kt
        elif self.mode == "go-around":
            ias = self.vapp + 10.0
        else:
            ias = self.sched.capture_ias_kt
            if z < self.sched.flaps35_below_ft * FT:
                ias = self.vapp
                if cas_kt <= self.sched.vfe35_kt and "flaps35_s" not in self.events:
                    self.events["flaps35_s"] = t
                    self._set("fcs/flap-cmd-norm", 1.0)
        self._set("ap/target/speed-mode", 0)
        self._set("ap/target/ias-kt", ias)


def frame_meta(
    kind: str,
    route_suffix: str,
    af: Airframe,
    seed_id,
    spec,
    runway: Runway,
    frame: RunwayFrame,
    undulation_m: float,
    gp: GlidePath,
) -> dict:
    """The metadata every runway-frame track carries (approaches, missions): what was flown
    where, the runway frame and the nominal ILS geometry."""
    return {
        "kind": kind,
        "route": f"{spec.airport}-{runway.ident}-{route_suffix}",
        "aircraft": af.name,
        "seed": seed_id,
        "jsbsim_version": jsbsim.__version__,
        "departure_utc": spec.start_utc.astimezone(UTC).isoformat(),
        "airport": spec.airport,
        "runway": runway.ident,
        "runway_frame": asdict(frame),
        "runway_length_m": runway.length_m,
        "undulation_m": undulation_m,
        "glide_path": {
            "theta_deg": spec.ils.glide_path_deg,
            "tch_m": spec.ils.tch_m,
            "gp_x_m": gp.gp_x,
            "gp_y_m": gp.gp_y,
            "loc_x_m": gp.loc_x,
        },
    }


def add_frame_columns(df, frame: RunwayFrame, cg_in: np.ndarray) -> None:
    """The CG location (JSBSim structural frame, inches -> m) and the runway-frame CG
    position as columns of a recorded track: cg_*_m and x_m, y_m, z_m."""
    for i, a in enumerate("xyz"):
        df[f"cg_{a}_m"] = cg_in[:, i] * IN
    xr, yr, zr = frame.from_geodetic(df["lat_deg"].to_numpy(), df["lon_deg"].to_numpy(), df["h_ellipsoid_m"].to_numpy())
    df["x_m"], df["y_m"], df["z_m"] = xr, yr, zr


def fly_loop(
    fdm,
    frame: RunwayFrame,
    atmosphere: Atmosphere,
    und: float,
    t0_s: float,
    ground_elevation_m: float,
    step,
    seed_id,
    rate_hz: int,
    extra_props=(),
    min_height_m: float = 3.0,
    max_bank_deg: float = 45.0,
    turbulence: TurbulencePatches | None = None,
    steering: SteeringWander | None = None,
):
    """The recorded flight loop shared by approaches and inspection missions: every
    second the guidance `step(t, x, y, z, h_ell, vn, ve, vd, vc_kt)` (runway frame, m,
    m/s, KCAS) sets its targets and returns True to stop; the truth wind is fed to the
    autopilot as a value and a rate for the coming second (as in flight.py); the
    atmosphere is refreshed every 10 s; samples at `rate_hz` (route columns plus
    `extra_props`). Returns (recorder, rows, tags). Raises FlightDiverged on NaN, an
    attitude beyond the limits or a height below `min_height_m` over the runway plane.
    `turbulence`: MIL-F-8785C turbulence in patches along the path, their severity as on
    the route legs (aerotruth.truth.turbulence), each patch's wind at 20 ft the truth
    atmosphere's over the runway at the patch's start, the gusts evaluated at the height
    above the runway (Mil8785Gusts: below 1,000 ft sigma_w = 0.1 x that wind, so the
    approach's gusts follow the day's surface wind) and updated at 50 Hz. No light chop
    here: the chop climatology was measured in cruise, and near the ground the
    low-altitude model's gusts are of its size already. `steering`: the autopilot's
    steering wander (aerotruth.truth.steering), stepped every STEER_DT_S of flight time,
    calm or turbulent: a coupled approach weaves on its bank commands as the cruise does."""
    rec = Recorder(fdm)
    pm = fdm.get_property_manager()
    getters = rec.getters + [pm.get_node(p).get_double_value for p in extra_props]
    g = {
        k: pm.get_node(p).get_double_value
        for k, p in (
            ("lat", "position/lat-geod-deg"),
            ("lon", "position/long-gc-deg"),
            ("h", "position/geod-alt-ft"),
            ("t", "simulation/sim-time-sec"),
            ("vn", "velocities/v-north-fps"),
            ("ve", "velocities/v-east-fps"),
            ("vd", "velocities/v-down-fps"),
            ("vc", "velocities/vc-fps"),
            ("phi", "attitude/phi-rad"),
            ("theta", "attitude/theta-rad"),
        )
    }
    wind_ahead = WindAhead(fdm, atmosphere, t0_s, GUIDE_EVERY * ILS_DT)
    steps_per_sample = int(round(1.0 / (rate_hz * ILS_DT)))
    if steps_per_sample < 1 or abs(steps_per_sample * rate_hz * ILS_DT - 1.0) > 1e-9 or GUIDE_EVERY % steps_per_sample:
        raise ValueError(f"rate_hz: expected a divisor of {round(1 / ILS_DT)} Hz that divides 1 Hz, got {rate_hz}")
    rows: list[list[float]] = []
    tags: list[tuple[int, int]] = []
    run = fdm.run
    path_m = 0.0
    gusts = None
    if turbulence is not None:
        gusts = Mil8785Gusts(fdm, turbulence.rng.spawn(1)[0], fdm["metrics/bw-ft"] * FT, turbulence)
        g_vt, g_psi = (pm.get_node(p).get_double_value for p in ("velocities/vtrue-fps", "attitude/psi-rad"))
    steps_per_gust = int(round(GUST_UPDATE_S / ILS_DT))  # the gusts' 50 Hz update, in steps
    # the wander's update, in steps (a second holds a whole number of them, so the count
    # within the second tells)
    steps_per_steer = int(round(STEER_DT_S / ILS_DT))
    steer = steering.step if steering is not None else None
    rows_append, tags_append = rows.append, tags.append
    while True:
        t = g["t"]()
        lat, lon, h = g["lat"](), g["lon"](), g["h"]() * FT
        phi, theta = g["phi"](), g["theta"]()
        if not all(map(math.isfinite, (lat, lon, h, phi, theta))):
            raise FlightDiverged("NaN in the JSBSim state", seed_id, t)
        if abs(phi) > max_bank_deg * DEG or not -15 * DEG < theta < 25 * DEG:
            raise FlightDiverged(f"attitude limit: roll {phi / DEG:.1f} deg, pitch {theta / DEG:.1f} deg", seed_id, t)
        x, y, z = (float(v) for v in frame.from_geodetic(lat, lon, h))
        if z < min_height_m:
            raise FlightDiverged(f"height {z:.1f} m over the runway plane at x = {x:.0f} m", seed_id, t)
        vn, ve, vd = g["vn"]() * FPS, g["ve"]() * FPS, g["vd"]() * FPS
        if step(t, x, y, z, h, vn, ve, vd, g["vc"]() * FPS / KT):
            break
        wind_ahead.update(t, lat, lon, h, und, vn, ve, vd, ground_elevation_m)
        if turbulence is not None:
            if turbulence.due(path_m):
                turbulence.update_from(path_m, atmosphere, frame.lat0_deg, frame.lon0_deg, ground_elevation_m, t0_s + t)
            path_m += math.hypot(vn, ve) * GUIDE_EVERY * ILS_DT
        if int(round(t)) % 10 == 0:
            set_atmosphere(fdm, _Und(und), atmosphere, lat, lon, t0_s + t)
        tag = (0, 3)
        for k in range(GUIDE_EVERY):
            if k % steps_per_sample == 0:
                rows_append([gg() for gg in getters])
                tags_append(tag)
            if steer is not None and k % steps_per_steer == 0:
                steer()
            if gusts is not None and k % steps_per_gust == 0:
                gusts.step(steps_per_gust * ILS_DT, g["h"]() * FT - frame.h0_m, g_vt() * FPS, g_psi())
            run()
    return rec, rows, tags


@dataclass
class IlsSetup:
    """What an ILS flight (an approach, a flight-inspection mission) starts from: the
    airframe, the runway with its 3-D frame and glide path, the atmosphere, the flight's
    random stream, the start time (s after 0 UTC), the geoid undulation, a fresh FDM and the
    autopilot's steering wander on it (the flight's "steering" stream)."""

    af: Airframe
    runway: Runway
    frame: RunwayFrame
    gp: GlidePath
    atmosphere: Atmosphere
    rng: np.random.Generator
    t0_s: float
    undulation_m: float
    fdm: jsbsim.FGFDMExec
    steering: SteeringWander  # the autopilot's steering wander, on the flight's "steering" stream


def ils_setup(
    spec, seed, aircraft: str | Airframe | None, atmosphere: Atmosphere | None, what: str, why: str = ""
) -> IlsSetup:
    """The IlsSetup of `spec` (an ApproachSpec or MissionSpec: airport, runway, ils,
    start_utc); only the SAAB 340 flies `what` (its flaps and Vref)."""
    af = aircraft if isinstance(aircraft, Airframe) else airframe(aircraft)
    if af.name != "saab340":
        raise ValueError(f"aircraft: {what} are flown by the saab340 only{why}, got {af.name!r}")
    runway = find_runway(spec.airport, spec.runway)
    fdm = new_fdm(af, ILS_DT, imu=True)
    day0 = spec.start_utc.replace(hour=0, minute=0, second=0, microsecond=0)
    return IlsSetup(
        af,
        runway,
        RunwayFrame.of(runway),
        GlidePath(spec.ils, runway),
        atmosphere if atmosphere is not None else UniformAtmosphere(),
        np.random.default_rng(seed),
        (spec.start_utc - day0).total_seconds(),
        runway.undulation_m,
        fdm,
        SteeringWander(fdm, seeds.generator(seeds.named_child(seed, "steering"))),
    )


def engage(fdm, af: Airframe, leg: GreatCircleLeg, ias_kt: float) -> None:
    """Lateral guidance on `leg`, altitude and speed held, then the initial condition run,
    engines running, trimmed, in the approach configuration. The guidance targets come
    before the initial condition is run: JSBSim evaluates the autopilot (filters, rate
    limiters) during initialisation and trim, and stale geometry there would start the
    flight with a full-bank command."""
    for k, c in zip("xyz", leg.normal, strict=False):
        fdm[f"ap/nav/n{k}"] = float(c)
    fdm["ap/nav/mode"] = 1
    fdm["ap/gain/xtk-to-track"] = 0.00025  # localizer tracking: ~25 s time constant at 130 kt
    fdm["ap/target/use-pressure-altitude"] = 0
    fdm["ap/target/altitude-ft"] = fdm["ic/h-sl-ft"]
    fdm["ap/target/ias-kt"] = ias_kt
    fdm.run_ic()
    fdm["propulsion/set-running"] = -1
    trim_or_settle(fdm, af)
    for prop, value in af.phase_properties.get("approach", {}).items():
        fdm[prop] = value


def fly_approach(
    spec: ApproachSpec,
    *,
    seed,
    aircraft: str | Airframe | None = None,
    atmosphere: Atmosphere | None = None,
    schedule: ApproachSchedule | None = None,
) -> TruthTrack:
    """Fly one ILS approach and return its 50 Hz TruthTrack. Raises FlightDiverged."""
    sched = schedule or ApproachSchedule()
    ils = ils_setup(spec, seed, aircraft, atmosphere, "approaches", " (its flaps and Vref)")
    af, runway, frame, gp, atmosphere, fdm = ils.af, ils.runway, ils.frame, ils.gp, ils.atmosphere, ils.fdm
    und, t0_s = ils.undulation_m, ils.t0_s
    _ic(fdm, frame, gp, spec, af, sched, atmosphere, und, t0_s)
    imu = spec.points_m["imu"]
    for axis, value in zip("xyz", imu, strict=False):
        fdm[f"imu/location-{axis}-in"] = value / IN
    far = frame.to_geodetic(-40 * NM, 0.0, 0.0)
    end = frame.to_geodetic(runway.length_m + 5 * NM, 0.0, 0.0)
    engage(
        fdm, af, GreatCircleLeg("LOC", float(far[0]), float(far[1]), float(end[0]), float(end[1])), sched.initial_ias_kt
    )
    guide = _Guide(fdm, spec, sched, gp, frame)
    fdm["ap/active"] = 1

    seed_id = seed_repr(seed)
    cc, sc = math.cos(frame.course_deg * DEG), math.sin(frame.course_deg * DEG)
    state: dict[str, float | None] = {"end_t": None}
    t_limit = spec.start_nm * NM / (100 * KT) + spec.past_threshold_s + 300.0

    def step(t, x, y, z, h, vn, ve, vd, vc_kt) -> bool:
        if t > t_limit:
            raise FlightDiverged(f"did not pass the threshold within {t_limit:.0f} s", seed_id, t)
        guide.update(t, x, y, z, h, vn * cc + ve * sc, vd, vc_kt)
        if state["end_t"] is None and "threshold_s" in guide.events:
            state["end_t"] = guide.events["threshold_s"] + spec.past_threshold_s
        return state["end_t"] is not None and t >= state["end_t"]

    turb = TurbulencePatches(fdm, ils.rng) if spec.turbulence else None
    rec, rows, tags = fly_loop(
        fdm,
        frame,
        atmosphere,
        und,
        t0_s,
        runway.elevation_m,
        step,
        seed_id,
        RATE_HZ,
        INERTIAL_PROPS,
        min_height_m=3.0,
        turbulence=turb,
        steering=ils.steering,
    )
    nrec = len(rec.PROPS)
    data = np.asarray(rows, dtype=float)
    extra = data[:, nrec:]
    df = rec.frame(data[:, :nrec], tags)
    dv, dth = np.diff(extra[:, 0:3] * FT, axis=0), np.diff(extra[:, 3:6], axis=0)
    # increments over the 20 ms that END at each sample; the first sample has none (NaN)
    for i, a in enumerate("xyz"):
        df[f"dv_{a}_mps"] = np.concatenate([[np.nan], dv[:, i]])
        df[f"dtheta_{a}_rad"] = np.concatenate([[np.nan], dth[:, i]])
    add_frame_columns(df, frame, extra[:, 6:9])
    if not np.isfinite(df.drop(columns=["phase"]).to_numpy()[1:]).all():
        raise FlightDiverged("NaN in the recorded truth", seed_id)
    meta = {
        **frame_meta("approach", "ILS", af, seed_id, spec, runway, frame, und, gp),
        "profile": spec.profile,
        "pass_height_ft": spec.pass_height_ft,
        "decision_height_ft": spec.decision_height_ft,
        "mass_kg": spec.mass_kg,
        "vref_kt": sched.vref_kt(spec.mass_kg),
        "vapp_kt": guide.vapp,
        "events_s": guide.events,
        "points_structural_m": {k: list(v) for k, v in spec.points_m.items()},
        "imu": "dv_*, dtheta_*: increments over the 20 ms ending at the sample, body axes, at the IMU point",
        "turbulence": bool(spec.turbulence),
        "turbulence_patches": turb.meta() if turb is not None else [],
        "rate_hz": RATE_HZ,
    }
    meta["config_hash"] = params_digest({k: meta[k] for k in sorted(meta) if k != "config_hash"})
    return TruthTrack(df, meta)


def dcm_body_to_ned(psi, theta, phi) -> np.ndarray:
    """C_ned<-body (n, 3, 3) of the aerospace 3-2-1 Euler angles (heading, pitch, roll):
    Rz(psi) Ry(theta) Rx(phi) written out (what scipy's Rotation.from_euler("ZYX") gives,
    tests/test_approach.py; 5x faster for the sensors' per-sample use)."""
    cps, sps, cth, sth, cph, sph = np.cos(psi), np.sin(psi), np.cos(theta), np.sin(theta), np.cos(phi), np.sin(phi)
    return np.stack(
        [
            np.stack([cth * cps, sph * sth * cps - cph * sps, cph * sth * cps + sph * sps], axis=-1),
            np.stack([cth * sps, sph * sth * sps + cph * cps, cph * sth * sps - sph * cps], axis=-1),
            np.stack([-sth, sph * cth, cph * cth], axis=-1),
        ],
        axis=-2,
    )


class TrackSamples(Protocol):
    """What `point_positions` reads of a track: its samples and its meta (a TruthTrack, or
    a subset of its rows with the same meta)."""

    @property
    def df(self) -> pd.DataFrame: ...

    @property
    def meta(self) -> dict[str, Any]: ...


def point_positions(track: TrackSamples, points_m: dict[str, tuple[float, float, float]] | None = None):
    """Runway-frame positions (m) of named points of the airframe at every sample:
    p = p_cg + C_rwy<-ned C_ned<-body r_b, with r_b the point's offset from the CG in body
    axes (structural x aft, z up -> body x forward, z down). Returns {name: (n, 3)}."""
    df, meta = track.df, track.meta
    points = points_m or {k: tuple(v) for k, v in meta["points_structural_m"].items()}
    frame = RunwayFrame(**meta["runway_frame"])
    c_nb = dcm_body_to_ned(
        df["heading_rad"].to_numpy(float), df["pitch_rad"].to_numpy(float), df["roll_rad"].to_numpy(float)
    )
    c_rn = frame.rotation_from_ned(df["lat_deg"].to_numpy(), df["lon_deg"].to_numpy())
    c_rb = np.matmul(c_rn, c_nb)
    cg = np.column_stack([df[c].to_numpy(float) for c in ("cg_x_m", "cg_y_m", "cg_z_m")])
    p_cg = np.column_stack([df[c].to_numpy(float) for c in ("x_m", "y_m", "z_m")])
    out = {}
    for name, (xs, ys, zs) in points.items():
        r_b = np.column_stack([-(xs - cg[:, 0]), ys - cg[:, 1], -(zs - cg[:, 2])])
        out[name] = p_cg + np.matmul(c_rb, r_b[:, :, None])[:, :, 0]
    return out


def approach_spec(airport_icao: str, runway: str, day: Date | datetime, **kw) -> ApproachSpec:
    """An ApproachSpec starting at 15:00 UTC of `day` unless a datetime is given."""
    when = day if isinstance(day, datetime) else datetime(day.year, day.month, day.day, 15, 0, tzinfo=UTC)
    if when.tzinfo is None:
        when = when.replace(tzinfo=UTC)
    return ApproachSpec(airport=airport_icao.strip().upper(), runway=runway, start_utc=when, **kw)


def approach_metrics(track: TruthTrack) -> dict[str, float]:
    """The acceptance figures of one approach: localizer and glide-slope
    deviations (dots), speed against Vref and sink rate (5 s means) at 1,000 ft above the threshold;
    deviation RMS inside 1 nm; height, speed, pitch and roll at the threshold."""
    df, meta = track.df, track.meta
    g = meta["glide_path"]
    gp = GlidePath.__new__(GlidePath)
    gp.theta, gp.tan = g["theta_deg"] * DEG, math.tan(g["theta_deg"] * DEG)
    gp.gp_x, gp.gp_y, gp.loc_x = g["gp_x_m"], g["gp_y_m"], g["loc_x_m"]
    gp.loc_half_sector = math.atan(0.155 / 0.00145 / gp.loc_x)
    x, y, z = (df[c].to_numpy(float) for c in ("x_m", "y_m", "z_m"))
    t = df["time_s"].to_numpy(float)
    out: dict[str, float] = {}
    before = np.flatnonzero((x < 0.0) & (z <= 1000.0 * FT))
    if len(before) == 0:
        raise ValueError("approach_metrics: the track never descends through 1,000 ft before the threshold")
    i = int(before[0])
    out["loc_dots_1000ft"] = gp.loc_dots(x[i], y[i])
    out["gs_dots_1000ft"] = gp.gs_dots(x[i], y[i], z[i])
    # speed and sink at the gate as a crew reads them: the mean over +-2.5 s around it (at
    # 50 Hz a single sample in turbulence carries every gust)
    gate = (t >= t[i] - 2.5) & (t <= t[i] + 2.5)
    out["cas_minus_vref_kt_1000ft"] = float(df["cas_mps"].to_numpy(float)[gate].mean() / KT - meta["vref_kt"])
    out["sink_fpm_1000ft"] = float(df["vd_mps"].to_numpy(float)[gate].mean() / FT * 60.0)
    inside = (x >= -NM) & (x < 0.0) & (z > 0.0)
    h_gp = np.hypot(x - gp.gp_x, y - gp.gp_y) * gp.tan
    out["lateral_rms_m_1nm"] = float(np.sqrt(np.mean(y[inside] ** 2)))
    out["vertical_rms_m_1nm"] = float(np.sqrt(np.mean((z[inside] - h_gp[inside]) ** 2)))
    k = int(np.flatnonzero(x >= 0.0)[0]) if (x >= 0.0).any() else -1
    out["height_over_threshold_ft"] = float(z[k] / FT)
    out["cas_threshold_kt"] = float(df["cas_mps"].iloc[k] / KT)
    out["pitch_threshold_deg"] = float(df["pitch_rad"].iloc[k] / DEG)
    out["roll_threshold_deg"] = float(df["roll_rad"].iloc[k] / DEG)
    out["recorded_past_threshold_s"] = float(t[-1] - t[k]) if k >= 0 else 0.0
    out["stabilised"] = float(
        abs(out["loc_dots_1000ft"]) <= 1.0
        and abs(out["gs_dots_1000ft"]) <= 1.0
        and -5.0 <= out["cas_minus_vref_kt_1000ft"] <= 10.0
        and out["sink_fpm_1000ft"] <= 1000.0
    )
    return out


@dataclass(frozen=True)
class PlannedApproach:
    """An approach with everything its truth depends on (the approach analogue of
    aerotruth.truth.days.PlannedLeg): the spec, the day's weather seed and region (None:
    calm air), and the flight seed (turbulence, initial offsets)."""

    spec: ApproachSpec
    weather_seed: int
    flight_seed: int
    region: str | None = None

    def atmosphere(self) -> Atmosphere | None:
        """The day's truth atmosphere of the region (shared with every leg of that date)."""
        if self.region is None:
            return None
        from aerotruth.truth.days import day_atmosphere

        return day_atmosphere(self.spec.start_utc.date(), self.weather_seed, self.region)

    def identity(self) -> dict:
        """The parts that determine the flight, as plain JSON values (the store's key)."""
        d = asdict(self.spec)
        d["start_utc"] = self.spec.start_utc.astimezone(UTC).isoformat()
        d["ils"] = self.spec.ils.model_dump()
        d["points_m"] = {k: [round(float(v), 6) for v in xyz] for k, xyz in sorted(self.spec.points_m.items())}
        return {
            "spec": d,
            "weather_seed": int(self.weather_seed),
            "flight_seed": int(self.flight_seed),
            "region": self.region,
        }
