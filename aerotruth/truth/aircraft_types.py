"""Aircraft types: the aerodynamic terms the Mode-S diagnosis needs of the aircraft that
flew, by ICAO type designator (ICAO Doc 8643), with a generic jet and a generic turboprop
for the types not listed.

What the diagnosis needs is the angle of attack, the angle between the air path and the
body's x axis: banked, the air vector leaves the nose by alpha sin(roll)
(aerotruth.analysis.wind.modes_wind). It comes from the lift equation of a level turn at
load factor n = 1 / cos(roll):

    n m g = q S CL_alpha (alpha - alpha_0),   q = rho TAS^2 / 2,

so alpha = alpha_0 + n m g / (q S CL_alpha), with m a typical in-flight mass, S the
reference wing area, CL_alpha the whole aircraft's lift slope and alpha_0 the body angle
of zero lift (wing incidence and camber).

The lift slope, where a type does not give its own, is the DATCOM / Helmbold-Diederich
wing formula (USAF Stability and Control DATCOM, section 4.1.3.2; Raymer, Aircraft
Design: A Conceptual Approach, eq. 12.6) at the flight's Mach number M:

    CL_alpha = 2 pi A / (2 + sqrt(4 + (A beta / eta)^2 (1 + tan^2(Lambda_c/2) / beta^2))) * F_S,

beta^2 = 1 - M^2, A the aspect ratio, Lambda_c/2 the half-chord sweep, eta = 0.95 (the
airfoil's lift slope over 2 pi, Raymer's typical value) and F_S = 0.98 the exposed-area
and fuselage-lift factor (S_exposed / S_ref) F, which Raymer sets to 0.98 when the
product comes out near or above one, as it does for transport fuselages.

Masses are typical in-flight masses between the maximum landing and take-off masses
(a mid-flight fuel load); the diagnosis is not sensitive to them: 20 % of mass moves
alpha by about 1 deg in cruise, the air track by 0.4 deg at 25 deg of bank, and only in
banked samples.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aerotruth.errors import UserError
from aerotruth.truth.isa import ISA_R_AIR, isa_pressure_pa, isa_temperature_k
from aerotruth.units import G0

GAMMA_AIR = 1.4
AIRFOIL_ETA = 0.95  # airfoil lift slope / 2 pi (Raymer, eq. 12.6)
EXPOSED_FUSELAGE_FACTOR = 0.98  # (S_exposed / S_ref) F, Raymer's value for a product near one
ENGINES = ("jet", "turboprop")


@dataclass(frozen=True)
class AircraftType:
    """One aircraft type's lift terms (SI, degrees for angles); `source` says where each
    number comes from."""

    designator: str  # ICAO Doc 8643 type designator, or "jet" / "turboprop" for a generic class
    name: str
    engine: str  # "jet" or "turboprop"
    wing_area_m2: float
    mass_kg: float  # typical in-flight mass
    aspect_ratio: float
    half_chord_sweep_deg: float
    alpha0_deg: float  # body angle at zero lift
    source: str
    cl_alpha_per_rad: float | None = None  # the type's own lift slope; None: DATCOM at the flight's Mach

    def lift_slope_per_rad(self, mach: np.ndarray | float) -> np.ndarray:
        """Whole-aircraft lift slope (per rad) at Mach `mach` (DATCOM, module docstring),
        or the type's own constant slope."""
        m = np.clip(np.asarray(mach, float), 0.0, 0.9)  # the formula holds subsonic only
        if self.cl_alpha_per_rad is not None:
            return np.full(m.shape, self.cl_alpha_per_rad)
        a = self.aspect_ratio
        beta2 = 1.0 - m**2
        tan2 = math.tan(math.radians(self.half_chord_sweep_deg)) ** 2
        root = np.sqrt(4.0 + (a / AIRFOIL_ETA) ** 2 * (beta2 + tan2))  # (A beta / eta)^2 (1 + tan^2 / beta^2)
        return 2.0 * math.pi * a / (2.0 + root) * EXPOSED_FUSELAGE_FACTOR

    def alpha_deg(
        self,
        tas_mps: np.ndarray | float,
        pressure_altitude_m: np.ndarray | float,
        roll_rad: np.ndarray | float = 0.0,
    ) -> np.ndarray:
        """Angle of attack (deg) in a level turn at this true airspeed, pressure altitude
        (ISA density and speed of sound there) and bank: alpha_0 + n m g / (q S CL_alpha)."""
        h = np.clip(np.asarray(pressure_altitude_m, float), -500.0, 20000.0)
        temp = isa_temperature_k(h)
        rho = isa_pressure_pa(h) / (ISA_R_AIR * temp)
        tas = np.maximum(np.asarray(tas_mps, float), 30.0)
        q = 0.5 * rho * tas**2
        mach = tas / np.sqrt(GAMMA_AIR * ISA_R_AIR * temp)
        n = 1.0 / np.cos(np.clip(np.asarray(roll_rad, float), -1.2, 1.2))
        cl = n * self.mass_kg * G0 / (q * self.wing_area_m2)
        return self.alpha0_deg + np.degrees(cl / self.lift_slope_per_rad(mach))


# The SAAB 340B is the project's own aircraft (aerotruth/truth/aircraft/saab340): its law is
# the one fitted on its JSBSim truth (40 legs, samples with |roll| < 3 deg in climb,
# cruise and descent; residual sd 0.10 deg), alpha = -3.40 deg + 30352 Pa deg / q, written
# here as the lift equation at the model's default mass of 12,000 kg on its 41.81 m2 wing:
# CL_alpha = m g / (S 30352 Pa deg) = 5.313 per rad (trimmed; the model's clean lift
# slope is 5.4 per rad with CL 0.30 at zero body angle: zero lift at -3.2 deg).
_SAAB_FIT_PA_DEG = 30352.0
SAAB340 = AircraftType(
    designator="SF34",
    name="SAAB 340B",
    engine="turboprop",
    wing_area_m2=41.81,
    mass_kg=12000.0,
    aspect_ratio=11.0,
    half_chord_sweep_deg=0.0,
    alpha0_deg=-3.40,
    cl_alpha_per_rad=12000.0 * G0 / (41.81 * _SAAB_FIT_PA_DEG) * 180.0 / math.pi,
    source="the project's JSBSim SAAB 340B (wing 41.81 m2, span 21.44 m: Jane's All the World's Aircraft); "
    "alpha law fitted on its truth flights",
)

# Jets: wing area, span and sweep from the manufacturers' airport-planning documents (Airbus
# "Aircraft Characteristics - Airport and Maintenance Planning" for the A310 and A320,
# Boeing "737 Airplane Characteristics for Airport Planning" D6-58325-6); masses from the
# same documents' weight tables. Half-chord sweep from the quarter-chord sweep and a taper
# ratio of 0.25-0.3: tan L_c/2 = tan L_c/4 - (1 - taper) / (A (1 + taper)).
# alpha_0 = -2.0 deg for the jets: the body angle at zero lift that puts a jet at CL 0.5 and
# M 0.78 at the 2-4 deg nose-up cruise pitch attitude transport jets fly level
# (CL 0.5 / 6.0 per rad = 4.8 deg above alpha_0: alpha 2.8 deg).
A310 = AircraftType(
    designator="A310",
    name="Airbus A310-300",
    engine="jet",
    wing_area_m2=219.0,
    mass_kg=140000.0,  # MTOW 150-164 t by variant, MLW 123-124 t
    aspect_ratio=8.8,  # span 43.89 m
    half_chord_sweep_deg=25.0,  # quarter-chord 28 deg
    alpha0_deg=-2.0,
    source="Airbus, A310 Aircraft Characteristics - Airport and Maintenance Planning",
)
A320 = AircraftType(
    designator="A320",
    name="Airbus A320-200",
    engine="jet",
    wing_area_m2=122.6,
    mass_kg=70000.0,  # MTOW 73.5-78 t by variant, MLW 64.5-66 t
    aspect_ratio=9.5,  # span 34.10 m without sharklets
    half_chord_sweep_deg=22.0,  # quarter-chord 25 deg
    alpha0_deg=-2.0,
    source="Airbus, A320 Aircraft Characteristics - Airport and Maintenance Planning",
)
B738 = AircraftType(
    designator="B738",
    name="Boeing 737-800",
    engine="jet",
    wing_area_m2=124.6,
    mass_kg=72000.0,  # MTOW 79.0 t, MLW 66.4 t
    aspect_ratio=9.45,  # span 34.32 m without winglets
    half_chord_sweep_deg=22.0,  # quarter-chord 25 deg
    alpha0_deg=-2.0,
    source="Boeing, 737 Airplane Characteristics for Airport Planning (D6-58325-6)",
)
AT76 = AircraftType(
    designator="AT76",
    name="ATR 72-600",
    engine="turboprop",
    wing_area_m2=61.0,
    mass_kg=21000.0,  # MTOW 23.0 t, MLW 22.35 t
    aspect_ratio=12.0,  # span 27.05 m
    half_chord_sweep_deg=0.0,  # straight tapered wing
    alpha0_deg=-3.4,  # as the SAAB 340's: a high straight wing set at about 2 deg incidence
    source="ATR, ATR 72 Airport Planning Manual",
)
# The generic classes: a twin-jet of the A320 / 737-800 class (their means), and a
# regional turboprop of the ATR 72 / SAAB 340 / Dash 8 class (wing loading 290-430 kg/m2
# at their typical masses: 333 kg/m2 taken; aspect ratio 11-12.8: 11.5).
GENERIC_JET = AircraftType(
    designator="jet",
    name="generic twin jet (A320 / 737-800 class)",
    engine="jet",
    wing_area_m2=123.6,
    mass_kg=71000.0,
    aspect_ratio=9.5,
    half_chord_sweep_deg=22.0,
    alpha0_deg=-2.0,
    source="the mean of the A320-200 and 737-800 (their airport-planning documents)",
)
GENERIC_TURBOPROP = AircraftType(
    designator="turboprop",
    name="generic regional turboprop (ATR 72 / SAAB 340 / Dash 8 class)",
    engine="turboprop",
    wing_area_m2=60.0,
    mass_kg=20000.0,
    aspect_ratio=11.5,
    half_chord_sweep_deg=0.0,
    alpha0_deg=-3.4,
    source="the class's published wing loadings and aspect ratios; alpha_0 as the SAAB 340 model's",
)

TYPES: dict[str, AircraftType] = {t.designator: t for t in (SAAB340, A310, A320, B738, AT76)}
GENERIC: dict[str, AircraftType] = {"jet": GENERIC_JET, "turboprop": GENERIC_TURBOPROP}
# engine words and ICAO Doc 8643 engine letters (the third character of a description such
# as L2J) for the generic class; a piston aircraft flies a straight propeller wing
_ENGINE_WORDS = {
    "jet": "jet",
    "turbofan": "jet",
    "turbojet": "jet",
    "j": "jet",
    "turboprop": "turboprop",
    "propeller": "turboprop",
    "piston": "turboprop",
    "t": "turboprop",
    "p": "turboprop",
}


def engine_class(engine: str) -> str | None:
    """The generic class, jet or turboprop, of an engine word (jet, turbofan, turboprop, piston, ...) or an
    ICAO Doc 8643 aircraft description (L2J, L2T, ...); None when it names neither."""
    word = engine.strip().lower()
    if len(word) == 3 and word[1].isdigit():  # a Doc 8643 description: L2J, L4T, H1T
        word = word[2]
    return _ENGINE_WORDS.get(word)


def known_types() -> str:
    """The designators and generic classes known, for messages."""
    return ", ".join(TYPES) + " (or a generic class: " + ", ".join(GENERIC) + ")"


def aircraft_type(designator: str, engine: str | None = None, what: str = "aircraft type") -> tuple[AircraftType, str]:
    """The type of an ICAO designator (or generic class name) and a note on how it was
    chosen. An unknown designator takes the generic class of `engine` when given; without
    it, one UserError naming the known types (`what` names where the designator came from)."""
    key = designator.strip().upper()
    if key in TYPES:
        return TYPES[key], f"{key}, {TYPES[key].name}"
    if key.lower() in GENERIC:
        t = GENERIC[key.lower()]
        return t, t.name
    cls = engine_class(engine) if engine else None
    if cls is not None:
        return GENERIC[cls], f"{key} is not listed: the {GENERIC[cls].name}, by its engines ({engine})"
    if engine:
        raise UserError(f"{what} {designator!r}: engine type {engine!r} is neither jet nor turboprop")
    raise UserError(
        f"{what} {designator!r} is not known; known types: {known_types()}; "
        "for another type give its engine type (jet or turboprop)"
    )
