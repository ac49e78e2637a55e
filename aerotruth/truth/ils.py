"""The ILS signal in space (the ground installation the aircraft flies: part of the world):
localizer and glide-path deviations seen by the aircraft's receiver, from the true position
of its antennas in the runway frame, with the facility's own errors.

Runway frame (docs/conventions.md): origin at the threshold centre at runway elevation, x along the
approach course (an approaching aircraft has x < 0, the runway is 0 <= x <= length),
y to the left, z up; metres.

Localizer (ICAO Annex 10 Vol. I, 3.1.3). The antenna array stands on the extended
centreline beyond the stop end, at x_L = runway length + setback. Its course line is
rotated by the alignment error: a course displaced by e_a metres at the threshold is
rotated by delta = atan(e_a / x_L) about the antenna. The angular deviation of the
aircraft from that course, positive to the left of the course as seen on the approach,
is

    phi = atan2(y, x_L - x) - delta - b(x),

with b(x) the course bends (angular, sinusoidal along x). DDM is linear in angle within
the course sector (the standard's linear region), saturating at the clearance value:

    DDM_LOC = 0.155 (1 + s_L) phi / phi_hs,   phi_hs = atan(w_thr / x_L),

where w_thr = 0.155 / 0.00145 = 106.9 m is the half course-sector width at the
threshold that gives the nominal displacement sensitivity of 0.00145 DDM/m there
(Annex 10 3.1.3.7.1) and s_L the relative sensitivity error. Sign: positive DDM means
the aircraft is left of the course (the needle points right: fly right).

Glide path (Annex 10 3.1.5). The path is a cone about the vertical through the glide-path
antenna mast at (x_G, y_G), abeam the touchdown zone; x_G = TCH / tan(theta) puts the
nominal path at the threshold crossing height over the threshold (15 m, Annex 10
3.1.5.1.4). The elevation angle of the antenna seen from the mast base is
eps = atan2(z, r), r the horizontal distance to the mast. With the path angle theta
(+ error dtheta):

    DDM_GS = 0.0875 (1 + s_G) (eps - theta') / (0.12 theta'),   theta' = theta + dtheta,

the nominal sensitivity of 0.0875 DDM at 0.12 theta' from the path (Annex 10 3.1.5.6.2:
0.07-0.14 theta for Cat I, 0.12 theta nominal). Positive: above the path (fly down).

Microamps: full-scale 150 uA is 0.155 DDM for the localizer and 0.175 DDM for the glide
path (ICAO Doc 8071 Vol. I); one dot is 75 uA. Angular errors are reported in degrees.

Tolerances (Annex 10 Vol. I 3.1.3.6.1 localizer alignment at the threshold: Cat I
10.5 m, Cat II 7.5 m, Cat III 3 m; 3.1.3.7.1 displacement sensitivity: Cat I and II
within 17 %, Cat III within 10 %; 3.1.5.1.2.2 glide-path angle: Cat I 0.075 theta,
Cat II and III 0.04 theta; 3.1.5.6.2 glide-path sensitivity: Cat I 25 %, Cat II 20 %,
Cat III 15 %): `TOLERANCES`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import Field

from aerotruth.schema import Section

LOC_DDM_PER_M_AT_THRESHOLD = 0.00145  # Annex 10 Vol. I 3.1.3.7.1
LOC_HALF_SECTOR_DDM = 0.155
GS_HALF_SECTOR_DDM = 0.0875
GS_HALF_SECTOR_FRACTION = 0.12  # of theta
LOC_FULL_SCALE_DDM, GS_FULL_SCALE_DDM, FULL_SCALE_UA = 0.155, 0.175, 150.0
LOC_CLEARANCE_DDM = 0.18  # the DDM is held at least this far out beyond the sector (3.1.3.7.4)

# facility category -> tolerance (Annex 10 Vol. I, sections in the module docstring)
TOLERANCES = {
    "I": {"alignment_m": 10.5, "loc_sensitivity_rel": 0.17, "gp_angle_rel": 0.075, "gp_sensitivity_rel": 0.25},
    "II": {"alignment_m": 7.5, "loc_sensitivity_rel": 0.17, "gp_angle_rel": 0.04, "gp_sensitivity_rel": 0.20},
    "III": {"alignment_m": 3.0, "loc_sensitivity_rel": 0.10, "gp_angle_rel": 0.04, "gp_sensitivity_rel": 0.15},
}


class IlsFacilitySpec(Section):
    """An ILS installation and its errors (defaults: a 3 m alignment and a 0.05 deg path-angle error, inside the Cat I
    tolerances: errors an inspection must measure)."""

    category: Literal["I", "II", "III"] = "I"
    glide_path_deg: float = Field(default=3.0, gt=1.0, lt=6.0, description="nominal glide-path angle theta")
    tch_m: float = Field(default=15.0, gt=0, description="threshold crossing height (Annex 10 3.1.5.1.4: 15 m)")
    loc_setback_m: float = Field(default=300.0, ge=0, description="localizer array beyond the stop end")
    gp_offset_m: float = Field(default=120.0, description="glide-path mast to the side of the centreline (+ left)")
    alignment_m: float = Field(default=3.0, description="localizer course displacement at the threshold (+ left)")
    loc_sensitivity_rel: float = Field(
        default=0.10, gt=-0.9, description="localizer displacement-sensitivity error (relative)"
    )
    gp_angle_error_deg: float = Field(default=0.05, description="glide-path angle error")
    gp_sensitivity_rel: float = Field(default=0.0, gt=-0.9, description="glide-path sensitivity error (relative)")
    bend_amplitude_deg: float = Field(default=0.02, ge=0, description="localizer course-bend amplitude")
    bend_wavelength_m: tuple[float, float] = Field(
        default=(1000.0, 2000.0), description="bend wavelength range along x (drawn)"
    )
    loc_noise_ddm: float = Field(default=0.0005, ge=0, description="receiver noise, 1 sigma (about 0.5 uA)")
    gs_noise_ddm: float = Field(default=0.0005, ge=0, description="receiver noise, 1 sigma")

    def draw(self, rng: np.random.Generator, runway_length_m: float) -> IlsFacility:
        """A facility: bend wavelength and phase drawn from `rng`."""
        lo, hi = self.bend_wavelength_m
        if not 0 < lo <= hi:
            raise ValueError(f"bend_wavelength_m: expected 0 < low <= high, got {self.bend_wavelength_m}")
        return IlsFacility(self, runway_length_m, float(rng.uniform(lo, hi)), float(rng.uniform(0, 2 * math.pi)))


@dataclass(frozen=True)
class IlsFacility:
    """One realization of a facility (spec, geometry and drawn bends)."""

    spec: IlsFacilitySpec
    runway_length_m: float
    bend_wavelength_m: float
    bend_phase_rad: float

    @property
    def loc_x_m(self) -> float:
        return self.runway_length_m + self.spec.loc_setback_m

    @property
    def gp_x_m(self) -> float:
        return self.spec.tch_m / math.tan(math.radians(self.spec.glide_path_deg))

    @property
    def loc_half_sector_rad(self) -> float:
        return math.atan(LOC_HALF_SECTOR_DDM / LOC_DDM_PER_M_AT_THRESHOLD / self.loc_x_m)

    @property
    def path_angle_rad(self) -> float:
        return math.radians(self.spec.glide_path_deg + self.spec.gp_angle_error_deg)

    def bend_rad(self, x) -> np.ndarray:
        """Course bends along the approach (angular, radians)."""
        return math.radians(self.spec.bend_amplitude_deg) * np.sin(
            2 * np.pi * np.asarray(x, float) / self.bend_wavelength_m + self.bend_phase_rad
        )

    def localizer_angle_rad(self, x, y) -> np.ndarray:
        """Angular deviation from the radiated course, + left (before bends are added)."""
        x, y = np.asarray(x, float), np.asarray(y, float)
        delta = math.atan(self.spec.alignment_m / self.loc_x_m)
        return np.arctan2(y, self.loc_x_m - x) - delta - self.bend_rad(x)

    def localizer_ddm(self, x, y) -> np.ndarray:
        """Noise-free localizer DDM at antenna positions (+ left of course)."""
        ddm = (
            LOC_HALF_SECTOR_DDM
            * (1 + self.spec.loc_sensitivity_rel)
            * self.localizer_angle_rad(x, y)
            / self.loc_half_sector_rad
        )
        return np.clip(ddm, -LOC_CLEARANCE_DDM * 2, LOC_CLEARANCE_DDM * 2)

    def elevation_rad(self, x, y, z) -> np.ndarray:
        """Elevation angle of the antenna seen from the glide-path mast base."""
        x, y, z = (np.asarray(a, float) for a in (x, y, z))
        return np.arctan2(z, np.hypot(x - self.gp_x_m, y - self.spec.gp_offset_m))

    def glide_slope_ddm(self, x, y, z) -> np.ndarray:
        """Noise-free glide-path DDM (+ above the path)."""
        th = self.path_angle_rad
        return (
            GS_HALF_SECTOR_DDM
            * (1 + self.spec.gp_sensitivity_rel)
            * (self.elevation_rad(x, y, z) - th)
            / (GS_HALF_SECTOR_FRACTION * th)
        )

    def measure(self, x, y, z, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
        """(localizer DDM, glide-path DDM) as the receiver reads them, with its noise; x, y, z
        are the localizer and glide-slope antennas' runway-frame positions."""
        loc = self.localizer_ddm(x, y) + self.spec.loc_noise_ddm * rng.standard_normal(np.shape(x))
        gs = self.glide_slope_ddm(x, y, z) + self.spec.gs_noise_ddm * rng.standard_normal(np.shape(x))
        return loc, gs


def nominal(facility: IlsFacility) -> IlsFacility:
    """The same installation with no facility errors: what a truth system's position is
    compared against (measured deviation minus nominal deviation = ILS error)."""
    spec = facility.spec.model_copy(
        update={
            "alignment_m": 0.0,
            "loc_sensitivity_rel": 0.0,
            "gp_angle_error_deg": 0.0,
            "gp_sensitivity_rel": 0.0,
            "bend_amplitude_deg": 0.0,
        }
    )
    return IlsFacility(spec, facility.runway_length_m, facility.bend_wavelength_m, facility.bend_phase_rad)


def ddm_to_microamps(ddm, kind: Literal["loc", "gs"]) -> np.ndarray:
    """Deviation indicator current: 150 uA at full scale (0.155 DDM localizer, 0.175 DDM glide path)."""
    full = LOC_FULL_SCALE_DDM if kind == "loc" else GS_FULL_SCALE_DDM
    return np.asarray(ddm, float) * FULL_SCALE_UA / full
