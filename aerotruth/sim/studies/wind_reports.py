"""Wind reports study: what the wind paper's aircraft would report on the campaign's truth
flights, and how far their winds are from the weather models' (wind paper section 6).

One task per aircraft-day (the same aircraft-days, hence the same truth legs, as every
other flight study of the campaign; nothing is re-flown when only sensors change): the
day's legs from the truth store go through the aircraft's heading system (flux valve with
its hard/soft iron and mounting, slaved gyro, the receiver's declination), air data and
GPS, and the TAMDAR report generator; every report gets one row per reference model
(aerotruth.sim.wind_observations). A task's rows are its observation table; the run's
whole table is exported to RUN_DIR/data/wind_reports.observations.parquet (and .csv), in
the form `aerotruth heading fit` and `aerotruth diagnose` read.

Reports banked more than `max_roll_deg` (10 deg, the paper's quality check) are left out of
the metrics (they stay in the exported table). Metrics per fleet (and per heading class,
"poor" or "healthy", as drawn): the RMS vector difference report - reference against each
model and against the combined references (every (report, model) pair pooled), with its
longitudinal and transverse split (axis from the 3-report air track; components over the
reports whose track passes the gates, total over all: aerotruth.analysis.wind.metrics).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from pydantic import Field, field_validator

from aerotruth.schema import Section
from aerotruth.sim.campaign_file import Campaign, References
from aerotruth.sim.fleet_days import (
    FlightSelection,
    aircraft_days,
    check_flights,
    day_cost,
    day_task,
)
from aerotruth.sim.studies import Figure, Study, Summary
from aerotruth.sim.tasks import Task
from aerotruth.sim.wind_observations import WindSensors

DIVERGED = "leg_diverged"  # `trigger` of the placeholder row of a leg that has no truth
COMBINED = "combined"


class WindReportsConfig(Section):
    """Flights, their sensors and how the wind differences are summarised."""

    flights: FlightSelection
    sensors: WindSensors = Field(default_factory=WindSensors)
    altitude_bands_ft: list[float] = Field(
        default=[0.0, 5000.0, 10000.0, 15000.0, 20000.0, 25000.0, 45000.0],
        description="ascending band edges of the by-altitude table (ft)",
    )
    max_roll_deg: float = Field(
        default=10.0,
        gt=0,
        le=90,
        description="reports banked more are not used (wind paper "
        "section 3: 'wind observations when the roll angle exceeds 10 degrees are not used')",
    )
    total_over: Literal["all", "track_subset"] = Field(
        default="all", description="reports the total RMS is taken over (wind_metrics: why components need not add up)"
    )

    @field_validator("altitude_bands_ft")
    @classmethod
    def _ascending(cls, v: list[float]) -> list[float]:
        if len(v) < 2 or any(b <= a for a, b in zip(v, v[1:], strict=False)):
            raise ValueError(f"expected at least two strictly ascending edges (ft), got {v}")
        return v


def check_sensors(campaign: Campaign, refs: References, sensors: WindSensors, prefix: tuple = ()) -> None:
    """Sensor specs name fleets of the campaign; reference model names are unique."""
    names = {f.name for f in campaign.fleets}
    for fleet in sensors.fleets:
        if fleet not in names:
            raise refs.error(
                prefix + ("fleets", fleet),
                f"expected the name of a fleet of the campaign ({', '.join(sorted(names))}), got {refs.value(fleet)}",
            )
    lists = [(prefix + ("references",), sensors.references)]
    lists += [(prefix + ("fleets", f, "references"), s.references) for f, s in sensors.fleets.items() if s.references]
    for loc, specs in lists:
        seen: set[str] = set()
        for i, spec in enumerate(specs):
            if spec.name in seen:
                raise refs.error(loc + (i, "name"), f"reference model {spec.name!r} is listed twice")
            seen.add(spec.name)
    for fleet, spec in sensors.fleets.items():
        k, n = spec.heading.poor_count, len(campaign.fleet(fleet).aircraft)
        if k is not None and k > n:
            raise refs.error(
                prefix + ("fleets", fleet, "heading", "poor_count"),
                f"expected at most the fleet's {n} aircraft, got {k}",
            )


def sensor_params(campaign: Campaign, sensors: WindSensors, fleet: str) -> dict[str, Any]:
    """A day task's sensor parameters: the fleet's sensors, the campaign seed, and the
    fleet's aircraft when its valves' classes are drawn for the whole fleet (`poor_count`;
    absent otherwise, so that other tasks keep their identity)."""
    params: dict[str, Any] = {"sensors": sensors.only(fleet), "campaign_seed": campaign.seed}
    if sensors.of(fleet).heading.poor_count is not None:
        params["fleet_aircraft"] = tuple(sorted(campaign.fleet(fleet).aircraft))
    return params


def diverged_rows(fleet: str, aircraft: str, date: str, outcomes) -> pd.DataFrame:
    """One placeholder row per leg without truth (kept so that no leg is silently dropped)."""
    rows = [
        {
            "aircraft": aircraft,
            "fleet": fleet,
            "trigger": DIVERGED,
            "flight": o.leg.plan.flight_id,
            "date": date,
            "phase": "",
            "ref_source": "",
        }
        for o in outcomes
        if o.track is None
    ]
    return pd.DataFrame(rows)


def band_midpoints_ft(bands) -> list[float]:
    """Middle of each "lo-hi" altitude-band label (ft), for plotting."""
    return [float(np.mean([float(x) for x in str(b).split("-")])) for b in bands]


def observations_only(rows: pd.DataFrame) -> pd.DataFrame:
    """The observation rows of stored task tables (placeholder rows and the task id off;
    `stage` kept: fit, before, after or main)."""
    if rows.empty or "trigger" not in rows.columns:
        return rows.iloc[0:0]
    obs = rows[rows["trigger"] != DIVERGED]
    return obs.drop(columns=[c for c in ("task_id",) if c in obs.columns]).reset_index(drop=True)


def unbanked(obs: pd.DataFrame, max_roll_deg: float) -> pd.DataFrame:
    """The reports the metrics score: banked no more than max_roll_deg."""
    return obs[obs["roll_deg"].abs() <= max_roll_deg].reset_index(drop=True)


def steady_heading_error(obs: pd.DataFrame) -> pd.DataFrame:
    """Steady level reports (|roll| < 5 deg), one reference's rows, with `d_deg` = reported
    minus true heading (simulation only: the truth is known)."""
    if obs.empty:
        return obs.assign(d_deg=pd.Series(dtype=float))
    one = obs[
        (obs["ref_source"] == obs["ref_source"].iloc[0]) & (obs["phase"] == "level") & (obs["roll_deg"].abs() < 5.0)
    ]
    return one.assign(d_deg=(one["heading_deg"] - one["truth_heading_deg"] + 180.0) % 360.0 - 180.0)


def day_rows(task: Task, ctx, correction=None, mark_corrected: bool = False) -> pd.DataFrame:
    """A flight study's task table: the aircraft-day's observation table (`correction`
    uploaded, if any; with a `corrected` column when `mark_corrected`) and one placeholder
    row per leg without truth."""
    from aerotruth.sim.wind_observations import day_observations

    day, fleet = task.params["day"], dict(task.identity)["fleet"]
    outcomes = ctx.truth.day(day)
    obs = day_observations(
        task.params["campaign_seed"],
        fleet,
        day,
        task.params["sensors"],
        ctx,
        correction=correction,
        legs=outcomes,
        fleet_aircraft=task.params.get("fleet_aircraft"),
    )
    if mark_corrected and len(obs):
        obs = obs.assign(corrected=correction is not None)
    return pd.concat([obs, diverged_rows(fleet, day.aircraft, day.date.isoformat(), outcomes)], ignore_index=True)


def summary_rows(errors: pd.DataFrame, keys: dict[str, Any], total_over: str) -> dict[str, Any]:
    """One summary row (n, rms, components) of a set of wind_errors rows."""
    from aerotruth.analysis.wind.metrics import wind_error_summary

    if errors.empty:
        return {
            **keys,
            "n": 0,
            "n_components": 0,
            "rms_kt": np.nan,
            "longitudinal_rms_kt": np.nan,
            "transverse_rms_kt": np.nan,
            "rss_components_kt": np.nan,
        }
    return {**keys, **wind_error_summary(errors, total_over=total_over).iloc[0].to_dict()}


def rms_table(errors: pd.DataFrame, obs: pd.DataFrame, total_over: str) -> pd.DataFrame:
    """RMS vector difference by fleet x heading class (incl. "all") x reference (incl. combined)."""
    rows = []
    cls = obs["heading_class"].to_numpy()
    for fleet in sorted(obs["fleet"].unique()):
        in_fleet = obs["fleet"].to_numpy() == fleet
        for klass in ("all", "poor", "healthy"):
            sel = in_fleet & ((cls == klass) if klass != "all" else True)
            if not sel.any():
                continue
            e = errors[sel]
            refs = sorted(e["ref_source"].unique())
            for ref in refs + [COMBINED]:
                part = e if ref == COMBINED else e[e["ref_source"] == ref]
                rows.append(
                    summary_rows(
                        part,
                        {
                            "fleet": fleet,
                            "heading_class": klass,
                            "reference": ref,
                            "aircraft": int(obs.loc[sel, "aircraft"].nunique()),
                        },
                        total_over,
                    )
                )
    return pd.DataFrame(rows)


def heading_error_table(obs: pd.DataFrame) -> pd.DataFrame:
    """Per aircraft: the heading its system reported minus the truth, in steady level flight
    (|roll| < 5 deg): mean and spread (deg), with its class and the reports used."""
    g = steady_heading_error(obs).groupby(["fleet", "aircraft", "heading_class"], sort=True)["d_deg"]
    return g.agg(n="count", mean_deg="mean", sd_deg="std", min_deg="min", max_deg="max").reset_index()


class WindReports(Study):
    """The `wind_reports` study (see the module docstring)."""

    name = "wind_reports"
    title = "Wind reports against weather-model analyses"
    Config = WindReportsConfig

    def check(self, campaign: Campaign, refs: References) -> None:
        section = campaign.section(self.name)
        check_flights(campaign, refs, section.flights, prefix=("flights",))
        check_sensors(campaign, refs, section.sensors, prefix=("sensors",))

    def expand(self, campaign: Campaign, section: WindReportsConfig) -> list[Task]:
        return [
            day_task(self.name, fleet, day, **sensor_params(campaign, section.sensors, fleet))
            for fleet, day in aircraft_days(campaign, section.flights)
        ]

    def cost(self, task: Task) -> float:
        return day_cost(task.params["day"]) + 1.0

    def run(self, task: Task, ctx) -> pd.DataFrame:
        return day_rows(task, ctx)

    def summarize(self, rows: pd.DataFrame, learned, section: WindReportsConfig) -> Summary:
        from aerotruth.analysis.wind.metrics import wind_error_summary, wind_errors

        obs = observations_only(rows)
        diverged = int((rows["trigger"] == DIVERGED).sum()) if "trigger" in rows.columns else 0
        m: dict[str, Any] = {
            "aircraft_days": int(rows["task_id"].nunique()) if "task_id" in rows else 0,
            "legs_diverged": diverged,
            "reports": 0,
        }
        if obs.empty:
            return Summary(m, {})
        m["reports"] = int(obs.drop_duplicates(["aircraft", "time"]).shape[0])
        everything, obs = obs, unbanked(obs, section.max_roll_deg)
        m["reports_banked"] = m["reports"] - int(obs.drop_duplicates(["aircraft", "time"]).shape[0])
        if obs.empty:
            return Summary(m, {}, exports={"observations": everything})
        errors = wind_errors(obs)
        rms = rms_table(errors, obs, section.total_over)
        for r in rms.itertuples():
            key = f"{r.fleet}.{r.heading_class}.{r.reference}"
            m[f"{key}.rms_kt"] = float(r.rms_kt)
            if r.reference == COMBINED:
                m[f"{key}.longitudinal_rms_kt"] = float(r.longitudinal_rms_kt)
                m[f"{key}.transverse_rms_kt"] = float(r.transverse_rms_kt)
                m[f"{key}.n"] = int(r.n)
        bands = wind_error_summary(
            errors,
            by=["fleet", "altitude_band"],
            altitude_bands_ft=section.altitude_bands_ft,
            total_over=section.total_over,
        )
        by_class = []
        for klass in ("poor", "healthy"):
            sel = obs["heading_class"].to_numpy() == klass
            if sel.any():
                t = wind_error_summary(
                    errors[sel],
                    by=["fleet", "altitude_band"],
                    altitude_bands_ft=section.altitude_bands_ft,
                    total_over=section.total_over,
                )
                by_class.append(t.assign(heading_class=klass))
        by_alt = pd.concat(by_class + [bands.assign(heading_class="all")], ignore_index=True)
        phases = wind_error_summary(errors, by=["fleet", "phase"], total_over=section.total_over)
        one = errors[obs["ref_source"].to_numpy() == obs["ref_source"].iloc[0]]
        gates = (
            one.assign(fleet=obs.loc[one.index, "fleet"].to_numpy())
            .groupby(["fleet", "phase"], sort=True)["has_axis"]
            .agg(reports="count", with_track="sum")
            .reset_index()
        )
        gates["share_rejected"] = 1.0 - gates["with_track"] / gates["reports"]
        tables = {
            "rms": rms,
            "rms_by_altitude": by_alt,
            "rms_by_phase": phases,
            "track_gates": gates,
            "heading_error": heading_error_table(obs),
        }
        return Summary(m, tables, exports={"observations": everything})

    def figures(self, rows: pd.DataFrame, summary: Summary, learned, out_dir: Path) -> list[Figure]:
        import matplotlib.pyplot as plt

        figs = []
        by_alt = summary.tables.get("rms_by_altitude")
        if by_alt is not None and len(by_alt):
            fig, axes = plt.subplots(1, 3, figsize=(10, 4), sharey=True)
            for ax, col, label in zip(
                axes,
                ("rms_kt", "longitudinal_rms_kt", "transverse_rms_kt"),
                ("total", "longitudinal", "transverse"),
                strict=False,
            ):
                for (fleet, klass), g in by_alt.groupby(["fleet", "heading_class"], sort=True):
                    mid = band_midpoints_ft(g["altitude_band"])
                    ax.plot(g[col], mid, "o-", label=f"{fleet} {klass}")
                ax.set_xlabel(f"{label} RMS (kt)")
                ax.grid(alpha=0.3)
            axes[0].set_ylabel("pressure altitude (ft)")
            axes[0].legend(fontsize=7)
            fig.suptitle("Report minus reference, combined references (wind paper Figs. 5/6)")
            out_dir.save(fig, "wind_reports_rms_altitude")
            figs.append(
                Figure(
                    "wind_reports_rms_altitude",
                    "RMS vector difference and its components by altitude, "
                    "poor and healthy heading systems (combined references)",
                )
            )
        obs = observations_only(rows)
        if len(obs):
            fig, ax = plt.subplots(figsize=(6, 4))
            for (ac, klass), g in list(steady_heading_error(obs).groupby(["aircraft", "heading_class"], sort=True))[:8]:
                ax.plot(g["heading_mag_deg"], g["d_deg"], ".", ms=3, label=f"{ac} ({klass})")
            ax.set_xlabel("measured magnetic heading (deg)")
            ax.set_ylabel("measured - true heading (deg)")
            ax.set_xlim(0, 360)
            ax.grid(alpha=0.3)
            ax.legend(fontsize=7)
            ax.set_title("Heading error of the simulated systems (level reports)")
            out_dir.save(fig, "wind_reports_heading_error")
            figs.append(
                Figure(
                    "wind_reports_heading_error",
                    "Heading error vs measured heading, level reports, against the truth (what the method has to find)",
                )
            )
        return figs


STUDY = WindReports()
