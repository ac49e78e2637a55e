"""The truth a fleet study stands on: which aircraft fly which days, as AircraftDays from
the campaign's fleets and periods, the task that carries one, and its legs from the truth
store. Any study that works
on flights (truth metrics, sensors, the methods) expands through here, so every study of a
campaign asks the truth store for the same aircraft-days and none re-flies another's.
"""

from __future__ import annotations

import datetime as _dt

from pydantic import Field, StrictBool, StrictInt, field_validator

from aerotruth.schema import Section
from aerotruth.sim.campaign_file import Campaign, References
from aerotruth.sim.tasks import MAIN_STAGE, Task
from aerotruth.truth.days import AircraftDay, FixedLeg
from aerotruth.truth.store import LegOutcome


class LegSpec(Section):
    """One fixed leg: departure and arrival airports (ICAO) and the departure time (UTC,
    "HH:MM"; quote it or not)."""

    origin: str = Field(alias="from", min_length=3)
    destination: str = Field(alias="to", min_length=3)
    departure_utc: _dt.time = Field(default=_dt.time(12, 0), description="HH:MM UTC")

    @field_validator("origin", "destination")
    @classmethod
    def _upper(cls, v: str) -> str:
        return v.strip().upper()

    @field_validator("departure_utc", mode="before")
    @classmethod
    def _clock(cls, v):
        if isinstance(v, (int, float)) and not isinstance(v, bool):
            raise ValueError(f"expected a time HH:MM, got the number {v!r}")
        return v


class FlightSelection(Section):
    """Every aircraft of the named fleets flies each day of the named periods, either its
    generated daily schedule or the fixed `legs:` list."""

    fleets: list[str] = Field(min_length=1)
    periods: list[str] = Field(min_length=1)
    legs: list[LegSpec] | None = Field(
        default=None, description="fly these legs every aircraft-day instead of a schedule"
    )
    max_legs_per_day: StrictInt | None = Field(
        default=None,
        ge=1,
        le=72,
        description="keep only the first N legs of each day (at most 72: a day of 20-min legs)",
    )
    turbulence: StrictBool = False


def check_flights(campaign: Campaign, refs: References, section: FlightSelection, prefix: tuple = ()) -> None:
    """Fleets and periods defined, airports of fixed legs known, networks where schedules are needed."""
    refs.names(prefix + ("fleets",), "fleets")
    refs.names(prefix + ("periods",), "periods")
    if section.legs is not None:
        from aerotruth.truth.airports import airports

        known = airports()
        for i, leg in enumerate(section.legs):
            for key, code in (("from", leg.origin), ("to", leg.destination)):
                if code not in known:
                    raise refs.error(
                        prefix + ("legs", i, key),
                        f"expected the ICAO code of an airport in the embedded table, got {refs.value(code)}",
                    )
            if leg.origin == leg.destination:
                raise refs.error(prefix + ("legs", i), f"from and to are the same airport {leg.origin}")
    else:
        check_networks(campaign, refs, section.fleets, "no fixed legs given")


def check_networks(campaign: Campaign, refs: References, fleets: list[str], why: str) -> None:
    """Every named fleet has a route network (its aircraft fly the daily schedule)."""
    for name in fleets:
        j = next(k for k, f in enumerate(campaign.fleets) if f.name == name)
        if campaign.fleets[j].network is None:
            raise refs.error(
                ("fleets", j, "network"),
                f"required by {refs.where} ({why}), expected a route network name",
                absolute=True,
            )


def aircraft_days(
    campaign: Campaign, section: FlightSelection, periods: list[str] | None = None
) -> list[tuple[str, AircraftDay]]:
    """(fleet name, AircraftDay) of every aircraft and day (of `periods`, default the section's)."""
    legs = (
        None
        if section.legs is None
        else tuple(
            FixedLeg(leg.origin, leg.destination, leg.departure_utc.isoformat(timespec="minutes"))
            for leg in section.legs
        )
    )
    out = []
    for name in section.fleets:
        fleet = campaign.fleet(name)
        for aircraft in fleet.aircraft:
            for day in campaign.days(periods or section.periods):
                out.append(
                    (
                        fleet.name,
                        AircraftDay.for_campaign(
                            campaign.seed,
                            aircraft,
                            day,
                            aircraft_type=fleet.aircraft_type,
                            network=fleet.network,
                            legs=legs,
                            max_legs=section.max_legs_per_day,
                            turbulence=section.turbulence,
                        ),
                    )
                )
    return out


def day_task(
    study: str, fleet: str, day: AircraftDay, *, stage: str = MAIN_STAGE, needs: tuple[str, ...] = (), **params
) -> Task:
    """The task of one aircraft-day (identity: fleet, aircraft, date)."""
    return Task(
        study,
        (("fleet", fleet), ("aircraft", day.aircraft), ("date", day.date.isoformat())),
        params={"day": day, **params},
        stage=stage,
        needs=needs,
    )


def flown_legs(ctx, day: AircraftDay) -> list[LegOutcome]:
    """The day's legs from the truth store of the task's context (flown if missing). The
    results of a study that calls this depend on the truth code through this module."""
    return ctx.truth.day(day)


def day_cost(day: AircraftDay) -> float:
    """Run-time estimate (s) of flying an aircraft-day cold: ~1.6 s per 100 nm plus 0.5 s
    per leg (measured here), over the fixed legs or the expected schedule (6 legs of the
    network's mean hub-spoke distance). Cached truth costs far less; still the best order."""
    import numpy as np

    from aerotruth import geo
    from aerotruth.truth.airports import airport, network
    from aerotruth.units import NM

    if day.legs is not None:
        pairs = [(leg.origin, leg.destination) for leg in day.legs]
    else:
        net = network(day.network)
        pairs = [(h, s) for h, spokes in net.spokes_by_hub.items() for s in spokes]
    dist_nm = [geo.inverse(airport(a).lat, airport(a).lon, airport(b).lat, airport(b).lon)[2] / NM for a, b in pairs]
    n_legs = len(pairs) if day.legs is not None else 6
    if day.max_legs is not None:
        n_legs = min(n_legs, day.max_legs)
    return n_legs * (0.5 + 1.6 * float(np.mean(dist_nm)) / 100.0)
