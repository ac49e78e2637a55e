"""The observation table of an aircraft-day: truth legs from the truth store, through the
aircraft's heading system, air data and TAMDAR report generator, with the reference
columns filled from each weather model's analysis (`docs/data-formats.md`).

Which draw comes from which stream (docs/conventions.md, "Random streams"), so that paired runs
share what they should:

* an aircraft's sensors (flux valve hard/soft iron, mounting, its class; TAS bias and
  scale) are properties of the airframe, drawn once per aircraft from the stream named
  ("sensor", fleet, aircraft, "heading" | "air_data"): the same on every day, in every
  study and period of a campaign;
* a weather model's analysis error is a property of the day: the stream ("reference",
  model name, date, region) — every aircraft flying that day sees the same analysis;
* per-sample noise (TAS, pressure altitude, GPS) comes from the task's own stream
  ("sensor", "air_data", leg k).

Ground pressure (for the report trigger's low zone) and ground elevation (for the
analysis's boundary layer): the departure field's until the truth's phase turns to
descent, the arrival field's after (an assumption: the paper does not say which field
pressure the TAMDAR sensor takes; it reports every 10 hPa within 100 hPa of it).
"""

from __future__ import annotations

import datetime as dt
from typing import Literal

import numpy as np
import pandas as pd
from pydantic import Field

from aerotruth import seeds
from aerotruth.schema import Section
from aerotruth.sensors.air_data import AirDataErrors, AirDataSpec
from aerotruth.sensors.magnetics import (
    FluxValveFleetSpec,
    FluxValveSpec,
    GeomagneticField,
    HeadingSystem,
    poor_valves,
)
from aerotruth.sensors.tamdar import HeadingCorrection, ReportSpec, generate_reports
from aerotruth.sensors.weather_model import (
    WeatherModelAnalysis,
    WeatherModelSpec,
    preset,
)
from aerotruth.truth.days import AircraftDay, PlannedLeg
from aerotruth.units import HPA, KT

_DESCENDING = ("descent", "approach")


class FleetSensors(Section):
    """The sensors of one fleet's aircraft: how their heading systems and air data vary
    over the fleet, and which heading the avionics hand the TAMDAR sensor."""

    heading: FluxValveFleetSpec = Field(default_factory=FluxValveFleetSpec)
    air_data: AirDataSpec = Field(default_factory=AirDataSpec)
    heading_input: Literal["magnetic", "true"] = Field(
        default="magnetic",
        description="magnetic: a flux-valve system whose magnetic heading the onboard table "
        "indexes (SAAB 340); true: avionics hand over true heading, offset-only correction (ERJ-145, Table IV)",
    )
    references: list[WeatherModelSpec] | None = Field(
        default=None,
        min_length=1,
        description="reference models of this fleet's region (default: the study's), "
        "e.g. RR alone with sigma_scale 1.4 for Alaska",
    )


class WindSensors(Section):
    """Sensors of every fleet, the reporting rules and the reference models of a wind study."""

    fleets: dict[str, FleetSensors] = Field(
        default_factory=dict, description="per fleet name; fleets not named get the defaults"
    )
    reports: ReportSpec = Field(default_factory=ReportSpec)
    references: list[WeatherModelSpec] = Field(default_factory=lambda: [preset("rr"), preset("rtfdda")], min_length=1)

    def of(self, fleet: str) -> FleetSensors:
        """The sensors of `fleet` (defaults when not named)."""
        return self.fleets.get(fleet) or FleetSensors()

    def only(self, fleet: str) -> WindSensors:
        """These sensors with `fleet`'s alone (a task's parameters: another fleet's spec
        changing leaves its stored table valid)."""
        return self.model_copy(update={"fleets": {fleet: self.of(fleet)}})


def aircraft_rng(campaign_seed: int, fleet: str, aircraft: str, what: str) -> np.random.Generator:
    """The stream of an airframe property (the same every day, in every study)."""
    return seeds.generator(seeds.named_sequence(campaign_seed, "sensor", fleet, aircraft, what))


def aircraft_heading(
    campaign_seed: int,
    fleet: str,
    aircraft: str,
    spec: FluxValveFleetSpec,
    fleet_aircraft: tuple[str, ...] | None = None,
) -> tuple[str, FluxValveSpec]:
    """(class "poor" | "healthy", flux valve) of one airframe. With `spec.poor_count` the
    class comes from the whole fleet's draw (`fleet_aircraft`: every aircraft of the fleet)."""
    poor = None
    if spec.poor_count is not None:
        if not fleet_aircraft or aircraft not in fleet_aircraft:
            raise ValueError(
                f"heading.poor_count: the aircraft of fleet {fleet!r} are needed to draw which "
                f"{spec.poor_count} are poor, and {aircraft!r} is not among {list(fleet_aircraft or [])}"
            )
        poor = aircraft in poor_valves(
            fleet_aircraft,
            spec.poor_count,
            seeds.generator(seeds.named_sequence(campaign_seed, "sensor", fleet, "poor_valves")),
        )
    return spec.draw_with_class(aircraft_rng(campaign_seed, fleet, aircraft, "heading"), poor=poor)


def aircraft_air_data(campaign_seed: int, fleet: str, aircraft: str, spec: AirDataSpec) -> AirDataErrors:
    """The TAS bias and scale of one airframe."""
    return spec.draw(aircraft_rng(campaign_seed, fleet, aircraft, "air_data"))


_ANALYSES: dict[tuple, WeatherModelAnalysis] = {}


def analysis_of_day(campaign_seed: int, spec: WeatherModelSpec, leg: PlannedLeg) -> WeatherModelAnalysis:
    """The weather model's analysis of the leg's day and region (one error draw per
    (model, date, region), kept per process)."""
    date = leg.plan.departure_utc.astimezone(dt.UTC).date()
    key = (campaign_seed, spec.model_dump_json(), date, leg.weather_seed, leg.region)
    if key not in _ANALYSES:
        if len(_ANALYSES) > 32:
            _ANALYSES.clear()
        rng = seeds.generator(seeds.named_sequence(campaign_seed, "reference", spec.name, date.isoformat(), leg.region))
        _ANALYSES[key] = WeatherModelAnalysis.draw(spec, leg.atmosphere(), rng)
    return _ANALYSES[key]


def _field_pressure_hpa(leg: PlannedLeg, arrival: bool, t_s: float) -> float:
    """Static pressure (hPa) at the departure or arrival field elevation at day time t_s."""
    ap = leg.plan.destination if arrival else leg.plan.origin
    p = leg.atmosphere().static_pressure(ap.lat, ap.lon, ap.elevation_m, t_s)
    return float(np.asarray(p).ravel()[0]) / HPA


def leg_reports(
    leg: PlannedLeg,
    track: pd.DataFrame,
    *,
    aircraft: str,
    heading: HeadingSystem,
    field: GeomagneticField,
    air: AirDataErrors,
    report_spec: ReportSpec,
    rng: np.random.Generator,
    correction: HeadingCorrection | None = None,
) -> pd.DataFrame:
    """The TAMDAR reports of one flown leg (REPORT_COLUMNS plus the heading the system
    measured, its declination and the truth at each report; no reference columns yet)."""
    departure = leg.plan.departure_utc.astimezone(dt.UTC)
    midnight = departure.replace(hour=0, minute=0, second=0, microsecond=0)
    t0_day = (departure - midnight).total_seconds()
    h = heading.apply(track, field)
    measured = air.apply(track, rng)
    descending = track["phase"].isin(_DESCENDING).to_numpy()
    ground = np.where(
        descending,
        _field_pressure_hpa(leg, True, t0_day + float(track["time_s"].iloc[-1])),
        _field_pressure_hpa(leg, False, t0_day),
    )
    reports = generate_reports(
        track,
        h["heading_rad"].to_numpy(),
        report_spec,
        ground_pressure_hpa=ground,
        air=measured,
        correction=correction,
        variation_rad=h["declination_rad"].to_numpy(),
        aircraft=aircraft,
        start_epoch_s=departure.timestamp(),
    )
    i = reports["sample_index"].to_numpy()
    dec = np.degrees(h["declination_rad"].to_numpy()[i])
    u, v = track["wind_u_mps"].to_numpy(float)[i], track["wind_v_mps"].to_numpy(float)[i]
    reports["heading_mag_deg"] = np.mod(reports["heading_deg"] - dec, 360.0)
    reports["declination_deg"] = dec
    reports["flight"] = leg.plan.flight_id
    reports["ground_elevation_m"] = np.where(
        descending[i], leg.plan.destination.elevation_m, leg.plan.origin.elevation_m
    )
    reports["truth_heading_deg"] = np.mod(np.degrees(track["heading_rad"].to_numpy(float)[i]), 360.0)
    reports["truth_wind_speed_kt"] = np.hypot(u, v) / KT
    reports["truth_wind_dir_deg"] = np.mod(np.degrees(np.arctan2(-u, -v)), 360.0)
    return reports


def with_references(reports: pd.DataFrame, analyses: list[WeatherModelAnalysis]) -> pd.DataFrame:
    """One row per (report, reference model): the reference columns filled by each analysis."""
    frames = [a.apply(reports, ground_elevation_m=reports["ground_elevation_m"].to_numpy()) for a in analyses]
    return pd.concat(frames, ignore_index=True) if frames else reports


def day_observations(
    campaign_seed: int,
    fleet: str,
    day: AircraftDay,
    sensors: WindSensors,
    ctx,
    *,
    correction: HeadingCorrection | None = None,
    legs=None,
    fleet_aircraft: tuple[str, ...] | None = None,
) -> pd.DataFrame:
    """The observation table of an aircraft-day (empty when no leg has truth). `legs`: the
    day's LegOutcomes (from `ctx.truth` when None); `fleet_aircraft`: the fleet's aircraft
    (needed when the fleet's heading spec sets `poor_count`)."""
    fs = sensors.of(fleet)
    heading_class, valve = aircraft_heading(campaign_seed, fleet, day.aircraft, fs.heading, fleet_aircraft)
    system = HeadingSystem(valve)
    air = aircraft_air_data(campaign_seed, fleet, day.aircraft, fs.air_data)
    outcomes = ctx.truth.day(day) if legs is None else legs
    flown = [o for o in outcomes if o.track is not None]
    if not flown:
        return pd.DataFrame()
    lat = np.concatenate([o.track.df["lat_deg"].to_numpy()[::100] for o in flown])
    lon = np.concatenate([o.track.df["lon_deg"].to_numpy()[::100] for o in flown])
    field = GeomagneticField.covering(lat, lon, day.date)
    frames = []
    for k, o in enumerate(outcomes):
        if o.track is None:
            continue
        reports = leg_reports(
            o.leg,
            o.track.df,
            aircraft=day.aircraft,
            heading=system,
            field=field,
            air=air,
            report_spec=sensors.reports,
            rng=ctx.rng("sensor", "air_data", k),
            correction=correction,
        )
        if len(reports):
            analyses = [analysis_of_day(campaign_seed, spec, o.leg) for spec in (fs.references or sensors.references)]
            frames.append(with_references(reports, analyses))
    if not frames:
        return pd.DataFrame()
    obs = pd.concat(frames, ignore_index=True)
    obs.insert(1, "fleet", fleet)
    obs["heading_input"] = fs.heading_input
    obs["heading_class"] = heading_class
    obs["date"] = day.date.isoformat()
    return obs


def simulated_observations(
    days: list, sensors: WindSensors, sensor_seed: int, *, fleet: str = "fleet", store=None
) -> pd.DataFrame:
    """The observation table aerotruth's sensors make of `days` (AircraftDay, truth from the
    store, flown if missing) with every sensor draw from `sensor_seed`: airframe properties,
    reference-model errors and per-sample noise; the same truth under another seed is another
    fleet flying the same legs. Reports banked more than 10 deg stay in (diagnose gates them)."""
    from aerotruth.sim.context import TaskContext
    from aerotruth.sim.fleet_days import day_task
    from aerotruth.truth.store import TruthStore

    store = store or TruthStore()
    frames = []
    fleet_aircraft = tuple(sorted({day.aircraft for day in days}))
    for day in days:
        ctx = TaskContext(day_task("simulated_observations", fleet, day), campaign_seed=sensor_seed, _truth=store)
        frames.append(day_observations(sensor_seed, fleet, day, sensors, ctx, fleet_aircraft=fleet_aircraft))
    frames = [f for f in frames if len(f)]
    if not frames:
        raise ValueError("simulated_observations: no leg of the days was flown")
    return pd.concat(frames, ignore_index=True)


__all__ = [
    "FleetSensors",
    "WindSensors",
    "day_observations",
    "simulated_observations",
    "leg_reports",
    "with_references",
    "analysis_of_day",
    "aircraft_heading",
    "aircraft_air_data",
]
