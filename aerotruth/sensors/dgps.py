"""DGPS reference positions for flight inspection (the DGPS-FIS, and the truth against
which the FITS paper scored its flight tests): p_DGPS = p + o + n at 5 Hz (docs/conventions.md),
with n white (carrier-smoothed code DGPS over a short baseline: a few cm, stated) and o
a constant offset from an error in the reference station's surveyed position (optional:
the FITS paper suspects one in its own flight test, section V)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pydantic import Field

from aerotruth.schema import Section


class DgpsSpec(Section):
    rate_hz: float = Field(default=5.0, gt=0, description="output rate (docs/conventions.md: 5 Hz)")
    sigma_horizontal_m: float = Field(default=0.05, ge=0, description="white noise per horizontal axis")
    sigma_vertical_m: float = Field(default=0.10, ge=0, description="white noise, vertical")
    survey_offset_m: tuple[float, float, float] = Field(
        default=(0.0, 0.0, 0.0), description="reference-station survey error, runway frame"
    )

    def draw(self, rng: np.random.Generator) -> Dgps:
        return Dgps(self)


@dataclass(frozen=True)
class Dgps:
    spec: DgpsSpec

    def sample_times(self, t0: float, t1: float) -> np.ndarray:
        """Output epochs between t0 and t1 (s)."""
        return np.arange(np.ceil(t0 * self.spec.rate_hz), np.floor(t1 * self.spec.rate_hz) + 1) / self.spec.rate_hz

    def apply(self, xyz: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """Measured runway-frame positions of the antenna at the given true positions."""
        xyz = np.asarray(xyz, float)
        s = self.spec
        sigma = np.array([s.sigma_horizontal_m, s.sigma_horizontal_m, s.sigma_vertical_m])
        return xyz + np.asarray(s.survey_offset_m) + sigma * rng.standard_normal(xyz.shape)
