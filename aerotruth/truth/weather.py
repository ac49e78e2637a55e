"""The weather a leg flies through: the Atmosphere interface the truth loop needs, a
uniform known-truth atmosphere for analytic tests, the day's truth-atmosphere
realization for a network, and leg planning with runways into the day's surface wind."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from datetime import UTC, datetime
from typing import TYPE_CHECKING, Protocol

import numpy as np

from aerotruth.truth.isa import geopotential_altitude_m, isa_pressure_pa

if TYPE_CHECKING:
    from aerotruth.truth.airports import Airport

ISA_LAPSE = 0.0065  # K/m, ICAO standard atmosphere troposphere lapse rate (Doc 7488)


class Atmosphere(Protocol):
    """What the truth loop needs of an atmosphere (heights above mean sea level, t in s
    since 00:00 UTC of the departure day, winds towards east/north/up in m/s)."""

    def wind(self, lat_deg, lon_deg, alt_m, t_s, ground_elevation_m=0.0): ...

    def delta_t(self, lat_deg, lon_deg, t_s): ...

    def static_pressure(self, lat_deg, lon_deg, alt_m, t_s): ...


@dataclass(frozen=True)
class UniformAtmosphere:
    """ISA + delta_t with a constant wind: the known-truth atmosphere of analytic tests
    (drift, wind triangle) and of calm-air runs."""

    u_mps: float = 0.0
    v_mps: float = 0.0
    w_mps: float = 0.0
    delta_t_k: float = 0.0
    sea_level_pressure_pa: float = 101325.0

    def wind(self, lat_deg, lon_deg, alt_m, t_s, ground_elevation_m=0.0):
        shape = np.shape(lat_deg)
        return (np.full(shape, self.u_mps), np.full(shape, self.v_mps), np.full(shape, self.w_mps))

    def delta_t(self, lat_deg, lon_deg, t_s):
        return np.full(np.shape(lat_deg), self.delta_t_k)

    def static_pressure(self, lat_deg, lon_deg, alt_m, t_s):
        return isa_pressure_pa(
            geopotential_altitude_m(np.asarray(alt_m, dtype=float)), self.delta_t_k, self.sea_level_pressure_pa
        )


NETWORK_REGION = {"mesaba": "upper_midwest", "penair": "alaska", "chautauqua": "eastern_us"}


def region_for_airport(icao: str) -> str:
    """Truth-atmosphere region of an airport: that of the first network serving it, else
    the nearest region centre. All legs of one network and day share one realization."""
    from aerotruth.truth.airports import airport, networks
    from aerotruth.truth.atmosphere import REGIONS

    for name, net in sorted(networks().items()):
        if icao in net.airports:
            return NETWORK_REGION[name]
    apt = airport(icao)
    return min(REGIONS, key=lambda k: (REGIONS[k][0] - apt.lat) ** 2 + ((REGIONS[k][1] - apt.lon) * 0.7) ** 2)


def truth_atmosphere_for(plan, seed, region: str | None = None):
    """The day's truth atmosphere for a leg: one realization per (date, seed, region);
    the region defaults to that of the origin (give the network's for a network day)."""
    from aerotruth.truth.atmosphere import TruthAtmosphere

    return TruthAtmosphere.for_day(plan.departure_utc.date(), seed, region or region_for_airport(plan.origin.icao))


def surface_wind_from(atmosphere, day) -> Callable[[Airport, datetime], tuple[float, float]]:
    """A routes.SurfaceWind: the truth 10 m wind (towards, m/s) at an airport and UTC time,
    used to choose runways into the wind."""
    day0 = datetime(day.year, day.month, day.day, tzinfo=UTC)

    def wind(apt: Airport, when: datetime) -> tuple[float, float]:
        u, v, _ = atmosphere.wind(
            apt.lat, apt.lon, apt.elevation_m + 10.0, (when - day0).total_seconds(), ground_elevation_m=apt.elevation_m
        )
        return float(np.asarray(u)), float(np.asarray(v))

    return wind
