"""Runway-relative sensors of a flight-inspection truth system: radar altimeter, TVPS and
the pilot's event button (FITS paper section II and eq. 18).

Positions are the runway-frame coordinates (docs/conventions.md, Runway frame: origin at the threshold centre at
runway elevation, x along the approach course, y left, z up; m) of each sensor's own
point on the airframe (its antenna or camera), sampled at the times `t_s`.

* Radar altimeter: h_RA = z - z_surface(x, y) + b + n, with the surveyed surface the flat
  runway (0 <= x <= length, |y| <= half width + shoulder); NaN elsewhere (the terrain
  before the threshold is not surveyed, so its returns cannot be used). Accuracy 0.30 m
  95 % (FITS paper section II) -> sigma = 0.30 / 1.96 per reading (1-D).
* TVPS: the camera's cross-track position y from the imaged runway edges and centreline,
  y_TVPS = y + b + n, where the runway is in view and resolved (from `view_from_m` before
  the threshold to the stop end); 0.60 m 95 % -> sigma = 0.60 / 1.96.
* Event button: the pilot marks the threshold crossing; the mark lands at the first
  sample after t_cross + d, d ~ N(reaction_mean_s, reaction_sd_s) (a human reaction on a
  visual cue: about 0.2 +- 0.05 s, stated, not sourced to a measurement).
Biases b are drawn per approach (zero by default), noise n per reading.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from aerotruth.schema import Section

RA_95_M, TVPS_95_M = 0.30, 0.60  # FITS paper section II


class RadarAltimeterSpec(Section):
    sigma_m: float = Field(default=RA_95_M / 1.96, ge=0, description="noise per reading (0.30 m 95 %, FITS paper)")
    bias_sigma_m: float = Field(default=0.0, ge=0, description="per-approach bias, 1 sigma")
    runway_half_width_m: float = Field(
        default=30.0, gt=0, description="surveyed surface: half the runway width plus shoulder"
    )

    def draw(self, rng: np.random.Generator) -> RadarAltimeter:
        return RadarAltimeter(self, float(self.bias_sigma_m * rng.standard_normal()))


@dataclass(frozen=True)
class RadarAltimeter:
    spec: RadarAltimeterSpec
    bias_m: float

    def apply(self, xyz: np.ndarray, runway_length_m: float, rng: np.random.Generator) -> np.ndarray:
        """Height of the antenna above the runway surface where it is over the runway, NaN elsewhere."""
        x, y, z = np.asarray(xyz, float).T
        over = (x >= 0.0) & (x <= runway_length_m) & (np.abs(y) <= self.spec.runway_half_width_m)
        h = z + self.bias_m + self.spec.sigma_m * rng.standard_normal(len(x))
        return np.where(over, h, np.nan)


class TvpsSpec(Section):
    sigma_m: float = Field(default=TVPS_95_M / 1.96, ge=0, description="noise per reading (0.60 m 95 %, FITS paper)")
    bias_sigma_m: float = Field(default=0.0, ge=0, description="per-approach bias, 1 sigma")
    view_from_m: float = Field(
        default=600.0, ge=0, description="distance before the threshold from which the runway is resolved"
    )

    def draw(self, rng: np.random.Generator) -> Tvps:
        return Tvps(self, float(self.bias_sigma_m * rng.standard_normal()))


@dataclass(frozen=True)
class Tvps:
    spec: TvpsSpec
    bias_m: float

    def apply(self, xyz: np.ndarray, runway_length_m: float, rng: np.random.Generator) -> np.ndarray:
        """Cross-track position of the camera where the runway is in view, NaN elsewhere."""
        x, y, _ = np.asarray(xyz, float).T
        seen = (x >= -self.spec.view_from_m) & (x <= runway_length_m)
        return np.where(seen, y + self.bias_m + self.spec.sigma_m * rng.standard_normal(len(x)), np.nan)


class EventButtonSpec(Section):
    reaction_mean_s: float = Field(default=0.2, ge=0, description="delay of the press after the threshold crossing")
    reaction_sd_s: float = Field(default=0.05, ge=0)


def event_flags(t_s: np.ndarray, x_m: np.ndarray, spec: EventButtonSpec, rng: np.random.Generator) -> np.ndarray:
    """0/1 per sample: 1 at the first sample after the (delayed) threshold crossing."""
    t, x = np.asarray(t_s, float), np.asarray(x_m, float)
    flags = np.zeros(len(t), dtype=np.int8)
    cross = np.flatnonzero((x[:-1] < 0.0) & (x[1:] >= 0.0))
    if len(cross) == 0:
        return flags
    i = cross[0]
    t_cross = t[i] + (0.0 - x[i]) / (x[i + 1] - x[i]) * (t[i + 1] - t[i])  # linear between samples
    t_press = t_cross + max(0.0, spec.reaction_mean_s + spec.reaction_sd_s * rng.standard_normal())
    j = int(np.searchsorted(t, t_press, side="left"))
    if j < len(t):
        flags[j] = 1
    return flags
