"""An aircraft's day of truth flights: which legs it flies, through which weather, with
which seeds — everything a truth flight depends on, in one picklable value that any
study (truth, sensors, the methods) asks the truth store for, so that every study of a
campaign sees the same flights.

Seeds (all recorded with each leg, so `aerotruth fly` can re-fly it alone):
* `weather_seed`: the day's truth atmosphere, shared by every aircraft and study of the
  date (one realization per region);
* `day_seed`: the aircraft-day; its child stream "plan" draws the schedule (hub, spokes,
  times, cruise levels) and its child "flight", k gives leg k's flight seed (turbulence).
Because sensors and methods draw from their own streams, never from these, changing a
sensor never changes the truth flown.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
from dataclasses import dataclass
from typing import Any

from aerotruth import seeds


@dataclass(frozen=True)
class FixedLeg:
    """A leg flown every day at a fixed UTC departure time ("HH:MM")."""

    origin: str
    destination: str
    departure_utc: str


@dataclass(frozen=True)
class AircraftDay:
    """One aircraft's day: its schedule on `network`, or the fixed `legs`."""

    aircraft: str
    date: dt.date
    weather_seed: int
    day_seed: int
    aircraft_type: str | None = None
    network: str | None = None
    legs: tuple[FixedLeg, ...] | None = None
    max_legs: int | None = None
    turbulence: bool = False

    @classmethod
    def for_campaign(cls, campaign_seed: int, aircraft: str, date: dt.date, **kw: Any) -> AircraftDay:
        """The aircraft-day of a campaign: seeds named by ("weather", date) and
        ("truth", aircraft, date), whatever study asks."""
        return cls(
            aircraft=aircraft,
            date=date,
            weather_seed=seeds.int_seed(seeds.named_sequence(campaign_seed, "weather", date.isoformat())),
            day_seed=seeds.int_seed(seeds.named_sequence(campaign_seed, "truth", aircraft, date.isoformat())),
            **kw,
        )

    def flight_seed(self, k: int) -> int:
        """Seed of leg k (0-based): the child ("flight", k) of the day's stream."""
        return seeds.int_seed(seeds.child(seeds.seed_sequence(self.day_seed, ()), "flight", k))

    def plans(self) -> list[PlannedLeg]:
        """The day's legs in flying order, each with its atmosphere and seeds."""
        from aerotruth.truth.routes import day_schedule
        from aerotruth.truth.weather import (
            NETWORK_REGION,
            region_for_airport,
            surface_wind_from,
        )

        rng = seeds.generator(seeds.child(seeds.seed_sequence(self.day_seed, ()), "plan"))
        out: list[PlannedLeg] = []
        if self.legs is None:
            assert self.network is not None  # a day without fixed legs is flown on its network (the campaign check)
            region = NETWORK_REGION[self.network]
            atm = day_atmosphere(self.date, self.weather_seed, region)
            plans = day_schedule(
                self.network, self.date, rng, aircraft_id=self.aircraft, surface_wind=surface_wind_from(atm, self.date)
            )
            out = [
                PlannedLeg(on_airway(p, self.flight_seed(k)), region, self.weather_seed, self.flight_seed(k))
                for k, p in enumerate(plans)
            ]
        else:
            for k, leg in enumerate(self.legs):
                dep = dt.datetime.combine(self.date, dt.time.fromisoformat(leg.departure_utc), tzinfo=dt.UTC)
                region = region_for_airport(leg.origin)
                plan = plan_in_weather(
                    leg.origin,
                    leg.destination,
                    dep,
                    weather_seed=self.weather_seed,
                    region=region,
                    rng=rng,
                    flight_id=f"{self.aircraft}-{self.date:%Y%m%d}-{k + 1}",
                )
                out.append(
                    PlannedLeg(on_airway(plan, self.flight_seed(k)), region, self.weather_seed, self.flight_seed(k))
                )
        return out[: self.max_legs] if self.max_legs is not None else out


@dataclass(frozen=True)
class PlannedLeg:
    """A leg plan with the atmosphere it flies through and its flight seed."""

    plan: Any  # routes.LegPlan
    region: str
    weather_seed: int
    flight_seed: int

    def atmosphere(self):
        """The day's truth atmosphere of this leg's region."""
        return day_atmosphere(self.plan.departure_utc.date(), self.weather_seed, self.region)

    def replay_args(self, aircraft_type: str | None, turbulence: bool) -> list[str]:
        """`aerotruth fly` arguments that re-fly exactly this leg."""
        p = self.plan
        args = [
            "--from",
            p.origin.icao,
            "--to",
            p.destination.icao,
            "--date",
            p.departure_utc.astimezone(dt.UTC).strftime("%Y-%m-%dT%H:%M:%SZ"),
            "--weather-seed",
            str(self.weather_seed),
            "--region",
            self.region,
            "--cruise-fl",
            str(p.cruise_flight_level),
            "--flight-id",
            p.flight_id,
            "--seed",
            str(self.flight_seed),
        ]
        if aircraft_type is not None:
            args += ["--aircraft", aircraft_type]
        if turbulence:
            args.append("--turbulence")
        return args


_ATMOSPHERES: dict[tuple, Any] = {}


def day_atmosphere(date: dt.date, weather_seed: int, region: str):
    """The truth atmosphere of (date, weather seed, region), built once per process."""
    from aerotruth.truth.atmosphere import TruthAtmosphere

    key = (date, weather_seed, region)
    if key not in _ATMOSPHERES:
        if len(_ATMOSPHERES) > 16:
            _ATMOSPHERES.clear()
        _ATMOSPHERES[key] = TruthAtmosphere.for_day(date, weather_seed, region)
    return _ATMOSPHERES[key]


def on_airway(plan, flight_seed: int):
    """The plan with its en-route fixes (routes.with_airway) drawn from the named stream
    ("airway") of the leg's flight seed, so that `aerotruth fly --seed` re-flies them."""
    from aerotruth.truth.routes import with_airway

    return with_airway(plan, seeds.generator(seeds.child(seeds.seed_sequence(int(flight_seed), ()), "airway")))


def plan_in_weather(
    origin: str,
    destination: str,
    departure_utc: dt.datetime,
    *,
    weather_seed: int,
    region: str | None = None,
    rng=None,
    cruise_flight_level: int | None = None,
    flight_id: str = "",
):
    """A LegPlan whose runways face the truth surface wind of the day (the realization of
    `weather_seed` in `region`, by default the origin's); the cruise level is drawn with
    `rng` unless given."""
    from aerotruth import geo
    from aerotruth.truth.airports import airport
    from aerotruth.truth.routes import block_time_s, plan_leg
    from aerotruth.truth.weather import region_for_airport, surface_wind_from

    region = region or region_for_airport(origin)
    day = departure_utc.astimezone(dt.UTC).date()
    wind = surface_wind_from(day_atmosphere(day, weather_seed, region), day)
    org, dst = airport(origin), airport(destination)
    eta = departure_utc + dt.timedelta(seconds=block_time_s(float(geo.inverse(org.lat, org.lon, dst.lat, dst.lon)[2])))
    plan = plan_leg(
        org,
        dst,
        departure_utc,
        rng=rng,
        wind_uv=wind(org, departure_utc),
        arrival_wind_uv=wind(dst, eta),
        cruise_flight_level=cruise_flight_level,
    )
    return dataclasses.replace(plan, flight_id=flight_id) if flight_id else plan


def parse_departure(text: str, default_hour: int = 13) -> dt.datetime:
    """`YYYY-MM-DD` (at `default_hour` UTC: 13:00 is a morning departure in the US Central
    zone) or an ISO-8601 date-time (UTC unless it carries an offset; a trailing Z is UTC)."""
    try:
        if len(text) == 10:
            d = dt.datetime.strptime(text, "%Y-%m-%d")
            return d.replace(hour=default_hour, tzinfo=dt.UTC)
        d = dt.datetime.fromisoformat(text.replace("Z", "+00:00"))
    except ValueError:
        raise ValueError(f"--date: expected YYYY-MM-DD or an ISO-8601 date-time, got {text!r}") from None
    return d if d.tzinfo is not None else d.replace(tzinfo=dt.UTC)
