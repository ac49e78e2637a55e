"""The vertical profile of a route leg as crews and ATC make it, drawn per flight.

A real climb is flown at a fixed power with the speed on pitch (a level change): the rate
is what the excess power gives, so it falls with altitude (the engines' power lapse), with
weight and on warm days; here the power is set and the rate emerges from the flight model
(truth/flight.py). A real descent follows a path the FMS or the crew plans from the top of
descent (the "three-to-one" rule of thumb, 1,000 ft per 3 nm, ~3.1 deg), whose vertical
speed is the ground speed times its gradient: slower low down, where the air is denser
and the speed limits apply, slower into a headwind. ATC interrupts both with level-offs.

What is drawn per flight, from the flight's own named stream ("profile"), and why:

* the take-off mass: the model's 12,000 kg (empty, crew, 1,760 kg of fuel and a ~75 %
  cabin) plus the load's spread, N(0, 450 kg) clipped to 10,800-13,155 kg (MTOW): a
  34-seat cabin is 0-3,200 kg of passengers and bags; regional load factors of 2009-2010
  ran ~70-80 % on average (an estimate: no per-flight loads are at hand);
* the descent path angle: uniform 2.6-3.4 deg about the three-to-one rule's 3.1 deg;
* a climb level-off (an ATC departure restriction) with probability 0.35: at a whole
  thousand feet from 4,000 ft to 2,000 ft below the cruise level, for 60-240 s;
* a descent level-off (a crossing restriction, a step descent) with probability 0.5: at a
  whole thousand feet between 2,000 ft above the arrival and 2,000 ft below the cruise
  level, for 60-300 s.

The probabilities and durations are estimates for the class of operation (no published
statistics at hand), to be replaced by measured ones (`aerotruth realism` on a user's
traffic prints the climb and descent rate distributions they shape).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MODEL_MASS_KG = 12000.0
MASS_SD_KG, MASS_MIN_KG, MASS_MAX_KG = 450.0, 10800.0, 13155.0
PATH_DEG = (2.6, 3.4)
CLIMB_LEVEL_OFF_P, CLIMB_LEVEL_OFF_S = 0.35, (60.0, 240.0)
DESCENT_LEVEL_OFF_P, DESCENT_LEVEL_OFF_S = 0.5, (60.0, 300.0)


@dataclass(frozen=True)
class VerticalProfile:
    """One flight's draws: take-off mass, descent path angle, and the level-offs
    (pressure altitude ft, duration s) or None."""

    mass_kg: float | None = None  # None: the model's own load
    descent_path_deg: float = 3.1
    climb_level_off: tuple[float, float] | None = None
    descent_level_off: tuple[float, float] | None = None

    @property
    def descent_gradient(self) -> float:
        return math.tan(math.radians(self.descent_path_deg))


def _level(rng: np.random.Generator, lo_ft: float, hi_ft: float) -> float | None:
    levels = np.arange(math.ceil(lo_ft / 1000.0) * 1000.0, hi_ft + 1.0, 1000.0)
    return float(rng.choice(levels)) if len(levels) else None


def draw_profile(
    rng: np.random.Generator,
    cruise_ft: float,
    arrival_ft: float,
    *,
    mass: bool = True,
    min_climb_level_ft: float = 4000.0,
) -> VerticalProfile:
    """A flight's vertical profile (module docstring) for a cruise at `cruise_ft` and an
    arrival at `arrival_ft` (pressure altitudes); `mass` False keeps the model's load (an
    airframe other than the SAAB 340). The draws are made in a fixed order, each whether
    used or not, so that one draw does not shift the others."""
    m = float(np.clip(MODEL_MASS_KG + MASS_SD_KG * rng.standard_normal(), MASS_MIN_KG, MASS_MAX_KG))
    path = float(rng.uniform(*PATH_DEG))
    u_climb, u_desc = rng.random(), rng.random()
    climb_s, desc_s = float(rng.uniform(*CLIMB_LEVEL_OFF_S)), float(rng.uniform(*DESCENT_LEVEL_OFF_S))
    climb_level = _level(rng, min_climb_level_ft, cruise_ft - 2000.0)
    desc_level = _level(rng, arrival_ft + 2000.0, cruise_ft - 2000.0)
    climb = (climb_level, climb_s) if u_climb < CLIMB_LEVEL_OFF_P and climb_level is not None else None
    desc = (desc_level, desc_s) if u_desc < DESCENT_LEVEL_OFF_P and desc_level is not None else None
    return VerticalProfile(m if mass else None, path, climb, desc)
