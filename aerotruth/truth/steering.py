"""The lateral guidance's own errors, in calm air as in turbulence: the steering wander (the
small turns an airline autopilot keeps making in straight flight, which a noiseless guidance
loop does not; route legs, ILS approaches and inspection missions) and the navigation error
(the FMS flies the path where it believes it is; route legs).

Navigation error (NavigationError). The LNAV steers the cross-track the FMS computes from
its position estimate, so the aircraft flies its path offset by the estimate's cross-track
error plus the path-steering law's own slow error (flight technical error): a first-order
Gauss-Markov offset, NAV_SIGMA_M rms with correlation time NAV_TAU_S, updated at the 1-Hz
guidance tick, added to the cross-track the XML steers (`ap/nav/position-error-ft`). The
LNAV closes a cross-track error with a ~60-s time constant at cruise speed
(gains_saab340.xml: 4e-5 rad of intercept per ft), so the truth follows the offset's
slow part. Sizes: a GNSS-updated position errs by a few metres with correlation times of
tens of minutes, autopilot path steering by tens of metres; real airliners' 600-s straight
stretches leave 3-13 m rms about their great circle in calm air (Mode-S positions; the
`aerotruth realism` study measures it: `wander_rms_m`), which a 15-m, 600-s process gives
after the window's own great-circle fit takes out its offset and heading (an estimate fitted
to those figures, not a published navigation-error statistic: none with an rms and a
correlation time of coupled LNAV path steering was found; GPS's own part is small beside
it, 95 % horizontal 7.1 m at the FAA's reference stations, Kaplan & Hegarty, Understanding
GPS, 2nd ed., 2006, sec. 7.7; "most modern aircraft remain within 100 m of a published
straight route" on RNAV 1 routes, NATS's London airspace trials, is consistent with it).

What it stands for. In straight flight above 10,000 ft the real A320 recorder extract
(../shared/real-data/fuelflow_a320.json.gz, 1 Hz) banks 0.32 deg rms (|roll| < 3 deg,
10-s windows, as recorded in 0.35-deg steps), and that bank turns the aircraft: the window's
track rate regresses on g tan(roll) / V with slope 0.71 and correlation 0.81
(`python validation/turn_stats.py`, `wings_level.*`). The autopilot is weaving by fractions
of a degree on its own commands; the load factor's light chop (aerotruth.truth.turbulence),
fed to the SAAB 340 truth, moves its wings-level bank by 0.095 deg rms only (slope 0.22,
correlation 0.34). The recorder cannot say what the wandering reference is (the FMS's
position and track estimates, a radio course's bends, the path-steering law's own
sampling); the model states only the observable.

Model. The bank the roll channel commands (aircraft/systems/aerotruth_autopilot.xml,
channel "roll outer": V / (g tau) x track error) carries an additive error e(t), a
first-order Gauss-Markov process (variance SIGMA^2, correlation time TAU), discretized
exactly at the truth's 10 Hz: e(k+1) = a e(k) + SIGMA sqrt(1 - a^2) n(k),
a = exp(-dt / TAU), n ~ N(0, 1). The bank turns the aircraft, so it is coordinated turning
as the recorder's is, and the track loop takes the track back within its 4-s time
constant. It enters at the bank, not at the track the loop steers to: an error in the track
or cross-track would bank a faster aircraft more (the loop's bank per radian of track
error is V / (g tau)), and the same numbers then hold for the jet stand-in of the
Chautauqua campaign at the A320's own speeds. At the SAAB 340's cruise TAS (~130 m/s) a
bank error SIGMA is a track error SIGMA g tau / V = 0.30 SIGMA.

Calibration (2 Mesaba aircraft-days, 13 legs, truth rounded to the recorder's steps,
`python validation/turn_stats.py --days 2`), against the A320's wings-level bank rms 0.324
deg and its share of 1-s roll changes of two or more steps above 10,000 ft, 5.5 % (the
acceptance criterion is the p95 of that change, 0.70 deg/s). First explored as a track
error (SIGMA_track below, in the track the loop steers to; bank-equivalent 3.3 x that at
cruise):

    SIGMA_track deg  TAU s   bank rms   share >= 2 steps   slope / corr
    0                -       0.095      1.2 %              0.22 / 0.34   (no wander)
    0.1              5       0.178      1.3 %              0.70 / 0.80
    0.2              2       0.273      12.5 %             0.85 / 0.91
    0.2              5       0.304      6.0 %              0.87 / 0.93
    0.2              10      0.282      2.6 %              0.86 / 0.92
    0.5              60      0.349      2.8 %              0.90 / 0.95

TAU 5 s is the one that gives the A320's share of two-step changes with its bank rms;
SIGMA = 0.65 deg of bank is the 0.2 deg of track at cruise speed (4 days:
`validation/turn_stats.py --days 4`, figures in the commit that made it the bank).

The bank's autocorrelation is where the model and the recorder part: the A320's stays
positive (0.62, 0.44, 0.30, 0.09 at 1, 2, 5, 10 s), the adopted model's turns negative
after ~4 s (the loop returns the track within its 4-s time constant); mixtures of a fast
and a slow wander (tau 2-3 s with 60 s) did not remove the negative lobe either.
"""

from __future__ import annotations

import math

import numpy as np

from aerotruth.units import DEG, FT

STEER_SIGMA_RAD = 0.65 * DEG  # rms error of the bank the roll channel commands (module docstring)
STEER_TAU_S = 5.0  # its correlation time
STEER_DT_S = 0.1  # updated at the truth's 10 Hz
STEER_PROPERTY = "ap/roll/wander-rad"
NAV_SIGMA_M = 15.0  # rms of the navigation (position + path-steering) cross-track error
NAV_TAU_S = 600.0  # its correlation time
NAV_PROPERTY = "ap/nav/position-error-ft"
NORMALS_BLOCK = 256  # normals drawn at a time by a GaussMarkovProperty


class GaussMarkovProperty:
    """A first-order Gauss-Markov process of rms `sigma` and correlation time `tau_s`,
    advanced by `dt_s` at every `step()` (exact discretization) and set into the JSBSim
    property `prop` as value / `per_unit`; drawn stationary from the start."""

    def __init__(
        self, fdm, rng: np.random.Generator, prop: str, sigma: float, tau_s: float, dt_s: float, per_unit: float = 1.0
    ):
        self.rng, self.per_unit = rng, per_unit
        self.node = fdm.get_property_manager().get_node(prop, True)
        self.a = math.exp(-dt_s / tau_s)
        self.b = sigma * math.sqrt(1.0 - self.a * self.a)
        self.e = sigma * float(rng.standard_normal())
        # the stream's normals drawn NORMALS_BLOCK at a time: numpy's Generator gives the
        # same sequence in blocks as one by one, at a fraction of the per-call cost
        self._normals: list[float] = []
        self._next = 0

    def step(self) -> None:
        """Advances the process by its dt_s and sets it."""
        i = self._next
        if i == len(self._normals):
            self._normals, i = self.rng.standard_normal(NORMALS_BLOCK).tolist(), 0
        self._next = i + 1
        self.e = self.a * self.e + self.b * self._normals[i]
        self.node.set_double_value(self.e / self.per_unit)


class SteeringWander(GaussMarkovProperty):
    """Gauss-Markov wander of the autopilot's bank command (rad), set into JSBSim every
    STEER_DT_S (module docstring); first set at the first step."""

    def __init__(self, fdm, rng: np.random.Generator, sigma_rad: float = STEER_SIGMA_RAD, tau_s: float = STEER_TAU_S):
        super().__init__(fdm, rng, STEER_PROPERTY, sigma_rad, tau_s, STEER_DT_S)


class NavigationError(GaussMarkovProperty):
    """Gauss-Markov cross-track error of the FMS's path (m, set in ft; module docstring),
    stepped every `dt_s` (the guidance tick), set from the start."""

    def __init__(
        self,
        fdm,
        rng: np.random.Generator,
        sigma_m: float = NAV_SIGMA_M,
        tau_s: float = NAV_TAU_S,
        dt_s: float = 1.0,
    ):
        super().__init__(fdm, rng, NAV_PROPERTY, sigma_m, tau_s, dt_s, per_unit=FT)
        self.node.set_double_value(self.e / self.per_unit)


__all__ = [
    "GaussMarkovProperty",
    "NAV_PROPERTY",
    "NAV_SIGMA_M",
    "NAV_TAU_S",
    "STEER_DT_S",
    "STEER_PROPERTY",
    "STEER_SIGMA_RAD",
    "STEER_TAU_S",
    "NavigationError",
    "SteeringWander",
]
