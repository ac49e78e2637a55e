"""Open-loop test manoeuvres for the SAAB 340B JSBSim model (its acceptance against published performance).

Power is always a fixed lever setting; the only closed loops are small holds on the
elevator (altitude, airspeed or flight-path angle) and on the ailerons (wings level)
where a criterion is about a steady state at fixed power. They hold attitude; they
never touch the throttle, so the airframe and engine numbers make the result.

Results are SI (m, s, m/s, rad); callers convert to knots/feet at the edges.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from pathlib import Path

import jsbsim
import numpy as np

import aerotruth.truth
from aerotruth.truth.airframes import quiet_jsbsim
from aerotruth.units import DEG, FPM, FT, KG_PER_LB, KT

AIRCRAFT_DIR = Path(aerotruth.truth.__file__).parent / "aircraft"
DT = 0.01  # s, JSBSim step (docs/conventions.md, Rates: a multiple of 50 Hz)
MTOW_KG = 13155.0  # Jane's
EMPTY_KG = 8140.0  # operating empty (facts sheet), as in saab340.xml
HP_W = 745.69987  # W per shaft horsepower
FUEL_CAPACITY_KG = 2580.0  # two wing tanks

# Lever settings (open loop). Cruise rpm 1,230 (advance 0), climb/approach 1,384 (advance 1).
CRUISE_THROTTLE = 0.85
MCP_THROTTLE = 1.0  # full lever = flat-rated 1,750 shp (maximum continuous)
APPROACH_THROTTLE = 0.28  # ~550 shp per engine: ~125 kt on a 3 deg path, flaps 35, gear down
STALL_THROTTLE = 0.03  # just above flight idle: ~1 kt/s deceleration in level flight near MTOW


def load_saab340(dt: float = DT) -> jsbsim.FGFDMExec:
    """A quiet FGFDMExec with the bare SAAB 340B model (no autopilot) at time step dt (s)."""
    with quiet_jsbsim():
        fdm = jsbsim.FGFDMExec(None)
        fdm.set_debug_level(0)
        fdm.set_aircraft_path(str(AIRCRAFT_DIR))
        fdm.set_engine_path(str(AIRCRAFT_DIR / "engine"))
        fdm.set_systems_path(str(AIRCRAFT_DIR / "systems"))
        # before load_model: FCS components (kinematics, filters, integrators) take
        # their time step when built; set afterwards they keep JSBSim's 1/120 s
        fdm.set_dt(dt)
        ok = fdm.load_model("saab340")
    if not ok:
        raise RuntimeError("JSBSim could not load the saab340 model")
    return fdm


def set_mass(fdm: jsbsim.FGFDMExec, total_kg: float, fuel_kg: float) -> None:
    """Set fuel (split evenly over both wing tanks) and passengers so the gross mass is
    total_kg; baggage keeps its default. Call before run_ic."""
    if not 0.0 <= fuel_kg <= FUEL_CAPACITY_KG:
        raise ValueError(f"fuel_kg: expected 0..{FUEL_CAPACITY_KG} kg, got {fuel_kg}")
    empty_kg = fdm["inertia/empty-weight-lbs"] * KG_PER_LB
    baggage_kg = fdm["inertia/pointmass-weight-lbs[1]"] * KG_PER_LB
    pax_kg = total_kg - empty_kg - fuel_kg - baggage_kg
    if pax_kg < 0.0:
        raise ValueError(f"total_kg: {total_kg} kg is below empty + fuel + baggage")
    for tank in (0, 1):
        fdm[f"propulsion/tank[{tank}]/contents-lbs"] = 0.5 * fuel_kg / KG_PER_LB
    fdm["inertia/pointmass-weight-lbs[0]"] = pax_kg / KG_PER_LB


def start_airborne(
    fdm: jsbsim.FGFDMExec,
    altitude_m: float,
    *,
    cas_ms: float | None = None,
    tas_ms: float | None = None,
    mass_kg: float = 12000.0,
    fuel_kg: float = 1760.0,
    flaps_deg: float = 0.0,
    gear_down: bool = False,
    throttle: float = 0.5,
    advance: float = 0.0,
    gamma_rad: float = 0.0,
    alpha_rad: float = 3.0 * DEG,
) -> None:
    """Initialise level (or on gamma) flight, engines running, fixed lever settings."""
    if (cas_ms is None) == (tas_ms is None):
        raise ValueError("start_airborne: give exactly one of cas_ms, tas_ms")
    set_mass(fdm, mass_kg, fuel_kg)
    fdm["ic/lat-geod-deg"] = 45.0
    fdm["ic/long-gc-deg"] = -93.0
    fdm["ic/psi-true-deg"] = 0.0
    fdm["ic/h-sl-ft"] = altitude_m / FT
    if cas_ms is not None:
        # JSBSim 1.3.3 re-derives the speed wrongly when angles are set after a
        # calibrated airspeed; convert to true airspeed first and set that last
        fdm["ic/vc-kts"] = cas_ms / KT
        tas_ms = fdm["ic/vt-kts"] * KT
    fdm["ic/gamma-deg"] = gamma_rad / DEG
    fdm["ic/alpha-deg"] = alpha_rad / DEG
    fdm["ic/vt-kts"] = tas_ms / KT
    fdm["fcs/flap-cmd-norm"] = flaps_deg / 35.0
    fdm["fcs/flap-pos-deg"] = flaps_deg
    fdm["fcs/gear-cmd-norm"] = 1.0 if gear_down else 0.0
    fdm["gear/gear-pos-norm"] = 1.0 if gear_down else 0.0
    fdm.run_ic()
    fdm["propulsion/set-running"] = -1
    set_levers(fdm, throttle, advance)


def set_levers(fdm: jsbsim.FGFDMExec, throttle: float, advance: float) -> None:
    """Both power levers to `throttle` and both propeller levers to `advance` (0..1)."""
    for name, value in (("throttle", throttle), ("advance", advance)):
        if not 0.0 <= value <= 1.0:
            raise ValueError(f"{name}: expected a lever position in 0..1, got {value}")
    for i in (0, 1):
        fdm[f"fcs/throttle-cmd-norm[{i}]"] = throttle
        fdm[f"fcs/advance-cmd-norm[{i}]"] = advance


class _Nodes:
    """Property nodes read every step (faster than fdm[...])."""

    def __init__(self, fdm: jsbsim.FGFDMExec):
        pm = fdm.get_property_manager()
        g = lambda name: pm.get_node(name, False)  # noqa: E731
        self.h = g("position/h-sl-ft")
        self.hdot = g("velocities/h-dot-fps")
        self.vc = g("velocities/vc-fps")
        self.vt = g("velocities/vt-fps")
        self.q = g("velocities/q-rad_sec")
        self.p = g("velocities/p-rad_sec")
        self.r = g("velocities/r-rad_sec")
        self.phi = g("attitude/phi-rad")
        self.theta = g("attitude/theta-rad")
        self.alpha = g("aero/alpha-rad")
        self.beta = g("aero/beta-rad")
        self.elev = g("fcs/elevator-cmd-norm")
        self.ail = g("fcs/aileron-cmd-norm")
        self.rud = g("fcs/rudder-cmd-norm")
        self.cl2 = g("aero/cl-squared")


class Holds:
    """Elevator and aileron holds for steady-state checks.

    Elevator (+1 nose down): an inner pitch-attitude loop (PI plus pitch-rate damping)
    under an outer loop chosen by `mode`: 'altitude' (vertical speed from the altitude
    error), 'gamma' (vertical speed V sin(gamma)), 'speed' (calibrated airspeed on
    pitch, as a crew climbs at fixed power) or 'none' (elevator left alone).
    Ailerons (+1 roll right): PI on bank angle to `bank_rad` with roll-rate damping,
    unless `lateral` is False.
    """

    def __init__(self, fdm: jsbsim.FGFDMExec, mode: str, target: float, bank_rad: float = 0.0):
        if mode not in ("altitude", "speed", "gamma", "none"):
            raise ValueError(f"mode: expected altitude, speed, gamma or none, got {mode!r}")
        self.target_rate = 0.0  # 'speed' mode: the target changes at this rate (m/s per s)
        self.n, self.mode, self.target, self.bank = _Nodes(fdm), mode, target, bank_rad
        self.theta_i = self.n.theta.get_double_value()  # outer-loop integrator (rad)
        self.elev_i = self.n.elev.get_double_value()  # inner-loop integrator (norm)
        self.ail_i = self.n.ail.get_double_value()
        self.lateral = True

    def _theta_cmd(self) -> float:
        n = self.n
        if self.mode == "speed":
            self.target += self.target_rate * DT
            err = n.vc.get_double_value() * FT - self.target  # + too fast: pitch up
            self.theta_i += 0.002 * err * DT
            return self.theta_i + 0.01 * err
        if self.mode == "altitude":
            hdot_cmd = max(-5.0, min(5.0, -0.1 * (n.h.get_double_value() * FT - self.target)))
        else:  # gamma
            hdot_cmd = n.vt.get_double_value() * FT * math.sin(self.target)
        err = hdot_cmd - n.hdot.get_double_value() * FT
        self.theta_i += 0.004 * err * DT
        return self.theta_i + 0.01 * err

    def step(self) -> None:
        """Update the surface commands; call once before each fdm.run()."""
        n = self.n
        if self.mode != "none":
            e = n.theta.get_double_value() - self._theta_cmd()
            self.elev_i += 0.5 * e * DT
            cmd = self.elev_i + 3.0 * e + 1.5 * n.q.get_double_value()
            n.elev.set_double_value(max(-1.0, min(1.0, cmd)))
        if self.lateral:
            e_phi = n.phi.get_double_value() - self.bank
            self.ail_i -= 0.3 * e_phi * DT
            cmd = self.ail_i - 1.5 * e_phi - 0.8 * n.p.get_double_value()
            n.ail.set_double_value(max(-1.0, min(1.0, cmd)))


@dataclass(frozen=True)
class SteadyFlight:
    """Averages over the measurement window of a fixed-power steady-state run."""

    tas_ms: float
    cas_ms: float
    altitude_m: float
    vertical_speed_ms: float
    gamma_rad: float
    tas_drift_ms2: float  # least-squares slope of TAS over the window
    shaft_power_w: float  # per engine
    alpha_rad: float
    pitch_rad: float


def _fly(fdm: jsbsim.FGFDMExec, holds: Holds, seconds: float) -> None:
    run = fdm.run
    for _ in range(int(round(seconds / DT))):
        holds.step()
        run()


def _measure(fdm: jsbsim.FGFDMExec, holds: Holds, seconds: float) -> SteadyFlight:
    n = holds.n
    pm = fdm.get_property_manager()
    power = pm.get_node("propulsion/engine/power-hp", False)
    samples = []
    run = fdm.run
    for k in range(int(round(seconds / DT))):
        holds.step()
        run()
        if k % 10 == 0:
            samples.append(
                (
                    fdm.get_sim_time(),
                    n.vt.get_double_value(),
                    n.vc.get_double_value(),
                    n.h.get_double_value(),
                    n.hdot.get_double_value(),
                    power.get_double_value(),
                    n.alpha.get_double_value(),
                    n.theta.get_double_value(),
                )
            )
    a = np.array(samples)
    t, vt = a[:, 0], a[:, 1] * FT
    vs = float(np.mean(a[:, 4])) * FT
    tas = float(np.mean(vt))
    return SteadyFlight(
        tas_ms=tas,
        cas_ms=float(np.mean(a[:, 2])) * FT,
        altitude_m=float(np.mean(a[:, 3])) * FT,
        vertical_speed_ms=vs,
        gamma_rad=math.asin(vs / tas),
        tas_drift_ms2=float(np.polyfit(t - t[0], vt, 1)[0]),
        shaft_power_w=float(np.mean(a[:, 5])) * HP_W,
        alpha_rad=float(np.mean(a[:, 6])),
        pitch_rad=float(np.mean(a[:, 7])),
    )


def level_cruise(
    altitude_m: float,
    *,
    mass_kg: float = 12000.0,
    throttle: float = CRUISE_THROTTLE,
    start_tas_ms: float = 260.0 * KT,
    settle_s: float = 420.0,
    window_s: float = 60.0,
) -> SteadyFlight:
    """Steady level speed at a fixed power lever (1,230 rpm), altitude held on the elevator."""
    fdm = load_saab340()
    fuel = min(FUEL_CAPACITY_KG, 0.5 * (mass_kg - EMPTY_KG))
    start_airborne(
        fdm,
        altitude_m,
        tas_ms=start_tas_ms,
        mass_kg=mass_kg,
        fuel_kg=fuel,
        throttle=throttle,
        advance=0.0,
        alpha_rad=2.0 * DEG,
    )
    holds = Holds(fdm, "altitude", altitude_m)
    _fly(fdm, holds, settle_s)
    return _measure(fdm, holds, window_s)


def steady_climb(
    altitude_m: float,
    cas_ms: float,
    *,
    mass_kg: float = MTOW_KG,
    throttle: float = MCP_THROTTLE,
    settle_s: float = 60.0,
    window_s: float = 30.0,
) -> SteadyFlight:
    """Climb at fixed power (1,384 rpm) and constant calibrated airspeed held on the elevator,
    started level at altitude_m; the result is averaged after the settling time."""
    fdm = load_saab340()
    start_airborne(
        fdm,
        altitude_m,
        cas_ms=cas_ms,
        mass_kg=mass_kg,
        fuel_kg=FUEL_CAPACITY_KG,
        throttle=throttle,
        advance=1.0,
        alpha_rad=5.0 * DEG,
    )
    holds = Holds(fdm, "speed", cas_ms)
    _fly(fdm, holds, settle_s)
    return _measure(fdm, holds, window_s)


def service_ceiling(low_m: float, high_m: float, cas_ms: float, **kw: float) -> tuple[float, float, float]:
    """Rate of climb at two altitudes (MTOW, maximum continuous power, `cas_ms`) and the
    altitude where it falls to 100 ft/min by linear interpolation between them (m).

    Returns (roc_low_ms, roc_high_ms, ceiling_m); the interpolation holds when the two
    altitudes bracket the ceiling (roc_low > 100 ft/min > roc_high).
    """
    roc_low = steady_climb(low_m, cas_ms, **kw).vertical_speed_ms
    roc_high = steady_climb(high_m, cas_ms, **kw).vertical_speed_ms
    target = 100.0 * FPM
    ceiling = low_m + (roc_low - target) * (high_m - low_m) / (roc_low - roc_high)
    return roc_low, roc_high, ceiling


@dataclass(frozen=True)
class ApproachResult:
    steady: SteadyFlight  # last `window_s` of the run
    gamma_error_max_rad: float  # largest |gamma + 3 deg| in the window
    cas_span_ms: float  # max - min calibrated airspeed in the window


def approach(
    throttle: float,
    *,
    mass_kg: float = 12000.0,
    start_cas_ms: float = 125.0 * KT,
    start_altitude_m: float = 3000.0 * FT,
    seconds: float = 150.0,
    window_s: float = 40.0,
) -> ApproachResult:
    """Flaps 35, gear down, 1,384 rpm, a fixed power lever; the elevator holds a 3 deg
    glide path (flight-path angle) and the speed settles where the power balances drag."""
    fdm = load_saab340()
    gamma = -3.0 * DEG
    start_airborne(
        fdm,
        start_altitude_m,
        cas_ms=start_cas_ms,
        mass_kg=mass_kg,
        fuel_kg=800.0,
        flaps_deg=35.0,
        gear_down=True,
        throttle=throttle,
        advance=1.0,
        gamma_rad=gamma,
        alpha_rad=1.0 * DEG,
    )
    holds = Holds(fdm, "gamma", gamma)
    _fly(fdm, holds, seconds - window_s)
    n = holds.n
    cas, gam = [], []
    for _ in range(int(round(window_s / DT)) // 10):
        for _ in range(10):
            holds.step()
            fdm.run()
        vt = n.vt.get_double_value()
        cas.append(n.vc.get_double_value() * FT)
        gam.append(math.asin(n.hdot.get_double_value() / vt))
    steady = SteadyFlight(
        tas_ms=n.vt.get_double_value() * FT,
        cas_ms=float(np.mean(cas)),
        altitude_m=n.h.get_double_value() * FT,
        vertical_speed_ms=n.hdot.get_double_value() * FT,
        gamma_rad=float(np.mean(gam)),
        tas_drift_ms2=float(np.polyfit(np.arange(len(cas)) * 10 * DT, cas, 1)[0]),
        shaft_power_w=fdm["propulsion/engine/power-hp"] * HP_W,
        alpha_rad=n.alpha.get_double_value(),
        pitch_rad=n.theta.get_double_value(),
    )
    return ApproachResult(steady, float(np.max(np.abs(np.array(gam) - gamma))), float(np.ptp(cas)))


@dataclass(frozen=True)
class StallResult:
    stall_cas_ms: float  # calibrated airspeed when the lift coefficient peaked
    cl_max: float
    decel_ms2: float  # mean deceleration from 130 kt CAS to the stall
    altitude_loss_before_m: float  # altitude lost while the hold still flew (to the stall)
    alpha_after_5s_rad: float  # angle of attack 5 s after the recovery input
    cas_gain_ms: float  # calibrated airspeed 20 s after recovery minus at the stall
    max_bank_rad: float  # largest |bank| from stall to end
    max_yaw_rate_rad_s: float  # largest |r| from stall to end
    altitude_loss_m: float  # altitude from the stall to the lowest point in 30 s


def clean_stall(
    *,
    mass_kg: float = 13000.0,
    altitude_m: float = 5000.0 * FT,
    throttle: float = STALL_THROTTLE,
    stall_alpha_deg: float = 17.0,
) -> StallResult:
    """Clean, gear up, power lever near flight idle at 1,384 rpm (about 1 kt/s of
    deceleration); altitude held on the elevator until the wing stalls (angle of attack
    past `stall_alpha_deg`, beyond CLmax at 15 deg). Then the recovery: elevator back to
    its 140 kt trim, maximum continuous power."""
    fdm = load_saab340()
    start_airborne(
        fdm,
        altitude_m,
        cas_ms=140.0 * KT,
        mass_kg=mass_kg,
        fuel_kg=2000.0,
        throttle=0.35,
        advance=1.0,
        alpha_rad=6.0 * DEG,
    )
    holds = Holds(fdm, "altitude", altitude_m)
    _fly(fdm, holds, 20.0)
    trim_elevator = holds.n.elev.get_double_value()
    set_levers(fdm, throttle, 1.0)
    n = holds.n
    cl_max, v_at_clmax, t130, t_stall = 0.0, 0.0, None, None
    while fdm.get_sim_time() < 200.0:
        holds.step()
        fdm.run()
        cas = n.vc.get_double_value() * FT
        if t130 is None and cas <= 130.0 * KT:
            t130 = fdm.get_sim_time()
        cl = math.sqrt(n.cl2.get_double_value())
        if cl > cl_max:
            cl_max, v_at_clmax, t_clmax = cl, cas, fdm.get_sim_time()
        if n.alpha.get_double_value() > stall_alpha_deg * DEG:
            t_stall = fdm.get_sim_time()
            break
    if t_stall is None or t130 is None:
        raise RuntimeError("clean_stall: the aircraft did not stall within 200 s")
    h_stall = n.h.get_double_value() * FT
    v_stall = n.vc.get_double_value() * FT
    # recovery
    holds.mode = "none"
    n.elev.set_double_value(trim_elevator)
    set_levers(fdm, MCP_THROTTLE, 1.0)
    max_bank = max_r = 0.0
    h_min = h_stall
    alpha5 = cas20 = float("nan")
    for k in range(int(30.0 / DT)):
        holds.step()
        fdm.run()
        max_bank = max(max_bank, abs(n.phi.get_double_value()))
        max_r = max(max_r, abs(n.r.get_double_value()))
        h_min = min(h_min, n.h.get_double_value() * FT)
        if k == int(5.0 / DT):
            alpha5 = n.alpha.get_double_value()
        if k == int(20.0 / DT):
            cas20 = n.vc.get_double_value() * FT
    return StallResult(
        stall_cas_ms=v_at_clmax,
        cl_max=cl_max,
        decel_ms2=(130.0 * KT - v_at_clmax) / (t_clmax - t130),
        altitude_loss_before_m=altitude_m - h_stall,
        alpha_after_5s_rad=alpha5,
        cas_gain_ms=cas20 - v_stall,
        max_bank_rad=max_bank,
        max_yaw_rate_rad_s=max_r,
        altitude_loss_m=h_stall - h_min,
    )


def _trimmed_cruise(altitude_m: float = 15000.0 * FT, tas_ms: float = 268.0 * KT) -> tuple[jsbsim.FGFDMExec, Holds]:
    """Cruise at CRUISE_THROTTLE settled for 60 s under the altitude and wings-level holds."""
    fdm = load_saab340()
    start_airborne(
        fdm,
        altitude_m,
        tas_ms=tas_ms,
        mass_kg=12000.0,
        fuel_kg=1760.0,
        throttle=CRUISE_THROTTLE,
        advance=0.0,
        alpha_rad=1.0 * DEG,
    )
    holds = Holds(fdm, "altitude", altitude_m)
    _fly(fdm, holds, 60.0)
    return fdm, holds


def doublet(surface: str, amplitude: float = 0.1, seconds: float = 30.0) -> tuple[np.ndarray, np.ndarray]:
    """Controls-fixed response to a 1 s + 1 s doublet of the elevator ('elevator': pitch
    rate) or rudder ('rudder': sideslip) from trimmed cruise at FL150.

    Returns (time s, response rad or rad/s) sampled every step from the doublet start.
    """
    if surface not in ("elevator", "rudder"):
        raise ValueError(f"surface: expected elevator or rudder, got {surface!r}")
    fdm, holds = _trimmed_cruise()
    n = holds.n
    holds.mode, holds.lateral = "none", False
    node = n.elev if surface == "elevator" else n.rud
    out = n.q if surface == "elevator" else n.beta
    trim = node.get_double_value()
    steps = int(round(seconds / DT))
    t = np.arange(steps) * DT
    y = np.empty(steps)
    for k in range(steps):
        node.set_double_value(trim + (amplitude if t[k] < 1.0 else -amplitude if t[k] < 2.0 else 0.0))
        fdm.run()
        y[k] = out.get_double_value()
    return t, y


def spiral_doubling_time(bank_rad: float = 5.0 * DEG, seconds: float = 90.0) -> tuple[float, np.ndarray, np.ndarray]:
    """Spiral mode from trimmed cruise at FL150: bank to +-bank_rad, then ailerons back to
    their wings-level trim, rudder and elevator fixed. The antisymmetric part of the two
    bank histories (half their difference) cancels any residual trim asymmetry (propeller
    torque) and leaves the spiral mode; its exponential rate from 10 s on gives the
    doubling time (inf when it converges). Returns (doubling time s, t, bank rad)."""
    runs = []
    for sign in (1.0, -1.0):
        fdm, holds = _trimmed_cruise()
        n = holds.n
        aileron_trim = n.ail.get_double_value()
        holds.bank = sign * bank_rad
        _fly(fdm, holds, 15.0)
        holds.mode, holds.lateral = "none", False
        n.ail.set_double_value(aileron_trim)
        steps = int(round(seconds / DT))
        phi = np.empty(steps)
        for k in range(steps):
            fdm.run()
            phi[k] = n.phi.get_double_value()
        runs.append(phi)
    t = np.arange(len(runs[0])) * DT
    anti = 0.5 * (runs[0] - runs[1])
    sel = t >= 10.0
    rate = float(np.polyfit(t[sel], np.log(np.abs(anti[sel])), 1)[0])
    doubling = math.log(2.0) / rate if rate > 0.0 else math.inf
    return doubling, t, anti


def step_cost_us(fdm: jsbsim.FGFDMExec, steps: int = 5000) -> float:
    """Wall time of one bare fdm.run() in microseconds (mean over `steps`)."""
    run = fdm.run
    t0 = time.perf_counter()
    for _ in range(steps):
        run()
    return (time.perf_counter() - t0) / steps * 1e6


# Landing configuration checks. Maximum landing weight 12,930 kg (SAAB 340B
# type certificate data); forward CG taken as 16 % MAC (est.: the forward limit of the
# 340B loading envelope lies near 15-17 % MAC at landing weights).
MLW_KG = 12930.0
LEMAC_M = 8.097  # x of the MAC leading edge in the model's structural frame (CG 8.40 m = 15 % MAC)
MAC_M = 2.02
IDLE_THROTTLE = 0.0


def set_cg(fdm: jsbsim.FGFDMExec, cg_mac: float) -> None:
    """Move the passenger point mass along x so the whole aircraft's CG sits at `cg_mac`
    (fraction of the MAC). Call after set_mass and before run_ic."""
    in_per_m = 1.0 / 0.0254
    target_in = (LEMAC_M + cg_mac * MAC_M) * in_per_m
    pax = fdm["inertia/pointmass-weight-lbs[0]"]
    if pax <= 0.0:
        raise ValueError("cg_mac: no passenger mass to move")
    fdm.run_ic()  # JSBSim computes the mass properties on initialisation
    total = fdm["inertia/weight-lbs"]
    x_now = fdm["inertia/cg-x-in"]
    fdm["inertia/pointmass-location-X-inches[0]"] += (target_in - x_now) * total / pax


@dataclass(frozen=True)
class StallSpeed:
    stall_cas_ms: float  # calibrated airspeed at the peak lift coefficient
    cl_max: float
    decel_ms2: float  # mean deceleration over the 10 s before the peak
    cg_mac: float


def stall_speed(
    *,
    flaps_deg: float = 35.0,
    gear_down: bool = True,
    mass_kg: float = MLW_KG,
    cg_mac: float = 0.16,
    altitude_m: float = 3000.0 * FT,
    entry_rate_ms2: float = 1.0 * KT,
    start_cas_ms: float = 125.0 * KT,
) -> StallSpeed:
    """1-g stall speed: trimmed, power lever at flight idle (1,384 rpm), wings level, the
    elevator slowing the aircraft at `entry_rate_ms2` (1 kt/s: the certification entry
    rate, 14 CFR 25.103(c)) until the lift coefficient peaks. Vs is the calibrated
    airspeed at that peak (IAS = CAS: no position error modelled). The speed hold lags its
    ramp, so the ramp is rescaled once to make the measured entry rate the stated one."""
    ramp = entry_rate_ms2
    for _ in range(2):
        r = _stall_once(flaps_deg, gear_down, mass_kg, cg_mac, altitude_m, ramp, start_cas_ms)
        ramp *= entry_rate_ms2 / max(r.decel_ms2, 0.1 * entry_rate_ms2)
    return r


def _stall_once(flaps_deg, gear_down, mass_kg, cg_mac, altitude_m, entry_rate_ms2, start_cas_ms) -> StallSpeed:
    fdm = load_saab340()
    set_mass(fdm, mass_kg, 800.0)
    set_cg(fdm, cg_mac)
    start_airborne(
        fdm,
        altitude_m,
        cas_ms=start_cas_ms,
        mass_kg=mass_kg,
        fuel_kg=800.0,
        flaps_deg=flaps_deg,
        gear_down=gear_down,
        throttle=0.3,
        advance=1.0,
        alpha_rad=4.0 * DEG,
    )
    cg = (fdm["inertia/cg-x-in"] * 0.0254 - LEMAC_M) / MAC_M
    holds = Holds(fdm, "altitude", altitude_m)
    _fly(fdm, holds, 15.0)
    set_levers(fdm, IDLE_THROTTLE, 1.0)
    holds.mode, holds.target, holds.target_rate = "speed", holds.n.vc.get_double_value() * FT, -entry_rate_ms2
    holds.theta_i = holds.n.theta.get_double_value()
    n = holds.n
    cl_max, hist = 0.0, []
    while fdm.get_sim_time() < 200.0:
        holds.step()
        fdm.run()
        cas = n.vc.get_double_value() * FT
        hist.append((fdm.get_sim_time(), cas))
        cl = math.sqrt(n.cl2.get_double_value())
        if cl > cl_max:
            cl_max, v_at, t_at = cl, cas, fdm.get_sim_time()
        elif cl < cl_max - 0.05 or n.alpha.get_double_value() > 20.0 * DEG:
            break
    else:
        raise RuntimeError("stall_speed: no lift peak within 200 s")
    h = np.array(hist)
    sel = (h[:, 0] > t_at - 10.0) & (h[:, 0] <= t_at)
    decel = -float(np.polyfit(h[sel, 0], h[sel, 1], 1)[0])
    return StallSpeed(v_at, cl_max, decel, cg)


def approach_attitude(
    cas_ms: float,
    *,
    mass_kg: float = MLW_KG,
    flaps_deg: float = 35.0,
    cg_mac: float = 0.16,
    gamma_rad: float = -3.0 * DEG,
    altitude_m: float = 3000.0 * FT,
    seconds: float = 120.0,
    window_s: float = 20.0,
) -> SteadyFlight:
    """Steady approach at `cas_ms` on `gamma_rad`, flaps and gear down, 1,384 rpm: the
    elevator holds the flight path and a slow power-lever loop (an autothrottle) holds
    the speed, so pitch and alpha are what the airframe needs there."""
    fdm = load_saab340()
    set_mass(fdm, mass_kg, 800.0)
    set_cg(fdm, cg_mac)
    start_airborne(
        fdm,
        altitude_m,
        cas_ms=cas_ms,
        mass_kg=mass_kg,
        fuel_kg=800.0,
        flaps_deg=flaps_deg,
        gear_down=True,
        throttle=APPROACH_THROTTLE,
        advance=1.0,
        gamma_rad=gamma_rad,
        alpha_rad=3.0 * DEG,
    )
    holds = Holds(fdm, "gamma", gamma_rad)
    thr_node = [fdm.get_property_manager().get_node(f"fcs/throttle-cmd-norm[{i}]", False) for i in (0, 1)]
    thr_i = APPROACH_THROTTLE
    samples = []
    steps = int(round(seconds / DT))
    for k in range(steps):
        err = cas_ms - holds.n.vc.get_double_value() * FT
        thr_i = min(1.0, max(0.0, thr_i + 0.002 * err * DT))
        thr = min(1.0, max(0.0, thr_i + 0.03 * err))
        for node in thr_node:
            node.set_double_value(thr)
        holds.step()
        fdm.run()
        if k >= steps - int(round(window_s / DT)):
            samples.append(
                (
                    fdm.get_sim_time(),
                    holds.n.vt.get_double_value() * FT,
                    holds.n.vc.get_double_value() * FT,
                    holds.n.h.get_double_value() * FT,
                    holds.n.hdot.get_double_value() * FT,
                    fdm["propulsion/engine/power-hp"] * HP_W,
                    holds.n.alpha.get_double_value(),
                    holds.n.theta.get_double_value(),
                )
            )
    a = np.array(samples)
    vs, tas = float(np.mean(a[:, 4])), float(np.mean(a[:, 1]))
    return SteadyFlight(
        tas_ms=tas,
        cas_ms=float(np.mean(a[:, 2])),
        altitude_m=float(np.mean(a[:, 3])),
        vertical_speed_ms=vs,
        gamma_rad=math.asin(vs / tas),
        tas_drift_ms2=float(np.polyfit(a[:, 0], a[:, 1], 1)[0]),
        shaft_power_w=float(np.mean(a[:, 5])),
        alpha_rad=float(np.mean(a[:, 6])),
        pitch_rad=float(np.mean(a[:, 7])),
    )
