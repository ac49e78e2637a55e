"""The JSBSim side shared by every truth flight (route legs, approaches and inspection
missions): the step and sampling rates, the recorder of the truth columns, the autopilot's
wind input one guidance tick ahead, the hand-over of the truth atmosphere's pressure and
temperature, the trim, and the divergence a flight ends with instead of truth.

Route legs (aerotruth.truth.flight, 10 Hz, great-circle guidance, light chop and steering
wander) and runway-frame flights (aerotruth.truth.approach.fly_loop: approaches and
missions, 50 Hz, the low-altitude gust model and the same steering wander) run their own
loops over these parts.
"""

from __future__ import annotations

import hashlib
import json
import math

import jsbsim
import numpy as np
import pandas as pd

from aerotruth.contracts import TRUTH_TRACK
from aerotruth.truth.airframes import Airframe, quiet_jsbsim
from aerotruth.truth.track import PHASES
from aerotruth.truth.weather import ISA_LAPSE, Atmosphere
from aerotruth.units import DEG, EARTH_RADIUS_M, FT

# s: the JSBSim step of route legs, 20 Hz: the 10 Hz truth samples fall on steps, the
# autopilot's outer loops (10 Hz) and LNAV (5 Hz) keep their rates, its inner loops (25 Hz
# at AUTOPILOT_STEP_S) run at every step (airframes.channel_execrate). Measured against the
# same legs at 50 and 100 Hz in docs/truth.md, "The step"
DT = 0.05


# s: the step of ILS approaches and inspection missions, 100 Hz: their 50 Hz inertial
# samples are JSBSim's trapezoidal integrals of the specific force and body rate, which a
# strapdown closes to 0.63 m over 120 s at two steps a sample and 1.39 m at one (tests/
# test_approach.py, the calm AFIS approach)
ILS_DT = 0.01


RECORD_EVERY = round(0.1 / DT)  # steps: 10 Hz truth samples


GUIDE_EVERY = round(1.0 / DT)  # steps: 1 Hz target and wind updates


ATMOSPHERE_EVERY = 10  # guidance ticks: temperature and pressure fields every 10 s (they vary over 100s of km)


FPS = FT  # m/s per ft/s


PSF = 47.880258980336  # Pa per lbf/ft^2


RANKINE = 5.0 / 9.0  # K per degree Rankine


class FlightDiverged(Exception):
    """A flight that left its envelope: never returned as truth."""

    def __init__(self, reason: str, seed, time_s: float | None = None):
        self.reason = reason
        self.seed = seed
        self.time_s = time_s
        at = f" at t={time_s:.1f} s" if time_s is not None else ""
        super().__init__(f"flight diverged{at} (seed {seed}): {reason}")

    def __reduce__(self):  # picklable across worker processes with its fields
        return (FlightDiverged, (self.reason, self.seed, self.time_s))


def params_digest(obj) -> str:
    return hashlib.sha256(json.dumps(obj, sort_keys=True, default=str).encode()).hexdigest()[:16]


def property_node(pm: jsbsim.FGPropertyManager, path: str) -> jsbsim.FGPropertyNode:
    """`pm.get_node(path)` of a property the model defines (JSBSim's own or the aircraft's
    XML), which is never None."""
    node = pm.get_node(path)
    assert node is not None, f"JSBSim property {path} does not exist"
    return node


class Recorder:
    """Reads the truth properties through property nodes (faster than fdm[...])."""

    PROPS = (
        ("simulation/sim-time-sec", 1.0),
        ("position/lat-geod-deg", 1.0),
        ("position/long-gc-deg", 1.0),
        ("position/geod-alt-ft", FT),
        ("atmosphere/pressure-altitude", FT),
        ("velocities/v-north-fps", FPS),
        ("velocities/v-east-fps", FPS),
        ("velocities/v-down-fps", FPS),
        ("attitude/phi-rad", 1.0),
        ("attitude/theta-rad", 1.0),
        ("attitude/psi-rad", 1.0),
        ("velocities/vtrue-fps", FPS),
        ("velocities/vc-fps", FPS),
        ("aero/alpha-rad", 1.0),
        ("aero/beta-rad", 1.0),
        ("velocities/p-rad_sec", 1.0),
        ("velocities/q-rad_sec", 1.0),
        ("velocities/r-rad_sec", 1.0),
        ("atmosphere/total-wind-east-fps", FPS),
        ("atmosphere/total-wind-north-fps", FPS),
        ("atmosphere/total-wind-down-fps", -FPS),
        ("atmosphere/P-psf", PSF),
        ("atmosphere/T-R", RANKINE),
    )
    COLUMNS = TRUTH_TRACK[:-2]  # the recorded columns; the leg and phase tags follow (aerotruth.contracts)

    def __init__(self, fdm: jsbsim.FGFDMExec):
        pm = fdm.get_property_manager()
        self.getters = [property_node(pm, p).get_double_value for p, _ in self.PROPS]
        self.scale = np.array([s for _, s in self.PROPS])
        self.rows: list[list[float]] = []
        self.tags: list[tuple[int, int]] = []

    def frame(self, rows: list[list[float]], tags: list[tuple[int, int]]) -> pd.DataFrame:
        data = np.asarray(rows, dtype=float) * self.scale
        df = pd.DataFrame(data, columns=list(self.COLUMNS))
        tag = np.asarray(tags, dtype=np.int64).reshape(-1, 2)
        df["leg_index"] = tag[:, 0].astype(np.int32)
        # pandas-stubs want an Index for `categories`; pandas takes any list-like
        df["phase"] = pd.Categorical.from_codes(tag[:, 1], categories=list(PHASES))  # type: ignore[call-overload]
        return df


class WindAhead:
    """The autopilot's wind input (ap/wind/*, eased in by the XML between guidance ticks):
    at each tick the truth wind one tick ahead at the dead-reckoned position, reached
    linearly from the value set at the previous tick."""

    def __init__(self, fdm, atmosphere: Atmosphere, t0_s: float, dt_g: float):
        pm = fdm.get_property_manager()
        self._nodes = [
            pm.get_node(f"ap/wind/{k}")
            for k in (
                "t0-sec",
                "north-fps",
                "east-fps",
                "down-fps",
                "north-rate-fps2",
                "east-rate-fps2",
                "down-rate-fps2",
            )
        ]
        self._prev = (fdm["ap/wind/north-fps"], fdm["ap/wind/east-fps"], fdm["ap/wind/down-fps"])
        self._atmosphere, self._t0_s, self._dt = atmosphere, t0_s, dt_g

    def update(
        self,
        t: float,
        lat: float,
        lon: float,
        h_m: float,
        undulation_m: float,
        vn: float,
        ve: float,
        vd: float,
        ground_elevation_m: float,
    ) -> None:
        """Tick at sim time t (s) from geodetic lat/lon (deg), ellipsoidal height (m), the
        geoid undulation there (m) and NED velocity (m/s)."""
        dt = self._dt
        lat1 = lat + vn * dt / EARTH_RADIUS_M / DEG
        lon1 = lon + ve * dt / (EARTH_RADIUS_M * math.cos(lat * DEG)) / DEG
        wind = self._atmosphere.wind(
            lat1, lon1, h_m - vd * dt - undulation_m, self._t0_s + t + dt, ground_elevation_m=ground_elevation_m
        )
        # floats from a point-path atmosphere (TruthAtmosphere), 0-d or 1-element arrays from others
        u, v, w = (c if type(c) is float else float(np.asarray(c).ravel()[0]) for c in wind)
        nodes, prev = self._nodes, self._prev
        nxt = (v / FPS, u / FPS, -w / FPS)
        nodes[0].set_double_value(t)
        for k in range(3):
            nodes[1 + k].set_double_value(prev[k])
            nodes[4 + k].set_double_value((nxt[k] - prev[k]) / dt)
        self._prev = nxt


def set_atmosphere(fdm, route, atmosphere: Atmosphere, lat: float, lon: float, t_s: float) -> None:
    """JSBSim's 'sea level' is the ellipsoid; the truth atmosphere is referenced to mean sea
    level. Give JSBSim the truth pressure at the ellipsoid (MSL height -N) as its sea-level
    pressure and the temperature offset shifted by the lapse over N, so JSBSim's pressure
    and temperature at an ellipsoidal height equal the truth at the same point. `route`:
    anything with the geoid undulation N in `undulation_m` (a Route, an approach's runway)."""
    n = route.undulation_m
    dt = float(np.asarray(atmosphere.delta_t(lat, lon, t_s)).ravel()[0]) + ISA_LAPSE * n
    p0 = float(np.asarray(atmosphere.static_pressure(lat, lon, -n, t_s)).ravel()[0])
    fdm["atmosphere/delta-T"] = dt / RANKINE
    fdm["atmosphere/P-sl-psf"] = p0 / PSF


def seed_repr(seed):
    """JSON-able form of an int seed or a SeedSequence (for metadata and divergence logs)."""
    if isinstance(seed, np.random.SeedSequence):
        return {"entropy": str(seed.entropy), "spawn_key": list(seed.spawn_key)}
    return int(seed)


def trim_or_settle(fdm, af: Airframe) -> None:
    """Start from JSBSim's longitudinal trim when it converges; otherwise from a mid
    throttle guess (turboprop trims are unreliable) and let the autopilot settle."""
    try:
        with quiet_jsbsim():
            fdm["simulation/do_simple_trim"] = 0
        thr, elev = fdm["fcs/throttle-cmd-norm[0]"], fdm["fcs/elevator-cmd-norm"]
    except jsbsim.TrimFailureError:
        thr, elev = 0.6, 0.0
        for i in range(af.engines):
            fdm[f"fcs/throttle-cmd-norm[{i}]"] = thr
    fdm["ap/trim/throttle"] = thr
    fdm["ap/trim/elevator"] = elev


def set_mass(fdm, mass_kg: float) -> None:
    """Gross mass by the passenger point mass, fuel at the model default (1,760 kg)."""
    kg_per_lb = 0.45359237
    fdm.run_ic()
    now = fdm["inertia/weight-lbs"] * kg_per_lb
    pax = fdm["inertia/pointmass-weight-lbs[0]"] * kg_per_lb + (mass_kg - now)
    if pax < 0.0:
        without_pax = now - fdm["inertia/pointmass-weight-lbs[0]"] * kg_per_lb
        raise ValueError(f"mass_kg: {mass_kg:g} kg is below the model's empty + fuel + baggage ({without_pax:.0f} kg)")
    fdm["inertia/pointmass-weight-lbs[0]"] = pax / kg_per_lb
