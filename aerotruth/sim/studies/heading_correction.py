"""Heading-correction study: the wind paper's method end to end on a simulated fleet —
fit each aircraft's deviation on a long period, select the poor and control aircraft by
their before-period wind RMS as the airline did, upload the 8-point tables to the poor
ones, and compare the after period with the before (wind paper section 8, Tables I-IV).

Stages (aircraft-day tasks, truth from the store; each airframe keeps its sensors in
every period because its sensor streams are named by the aircraft, not the day):

* `fit`    — reports of the fit period, uncorrected;
* `before` — reports of the before period, uncorrected;
* learned `corrections` (fitted once both are done, stored in RUN_DIR/learned): per
  aircraft the deviation fit of `aerotruth.analysis.wind.heading_correction` on the fit
  period (true heading, the paper's choice, or magnetic: `fit_heading`), its before-period
  RMS vector difference against the combined references (total and transverse), and its
  group: the `poor` aircraft with the largest before RMS, the `control` aircraft with the
  smallest (`selection.by`: the total RMS, or its transverse component)
  (selection by the noisy before RMS itself, so regression to the mean is part of the
  result), `other` for the rest;
* `after`  — reports of the after period; poor aircraft carry their uploaded table:
  8-point lookup on the measured magnetic heading (SAAB 340), or the offset alone where
  the avionics hand over true heading (ERJ-145, Table IV); refused fits upload nothing.

Control-group adjustment (wind paper Table II: after 9.0 kn - control change 0.6 kn =
8.4 kn): each after cell of the poor group minus the control group's change in the same
cell (total, longitudinal, transverse, each by subtraction). Table IV subtracts 1.2 kn
where its control moved 1.3; here always the control's own change.

Paired twin (simulation only): each after-period day of a table-carrying aircraft is also
reported without its table — the same flights and sensor noise, since every stream is
named — so `poor.after_untreated` is what the poor group would have reported, and
`poor.table_effect` = after_untreated - after is the table's own effect, free of the
regression to the mean and model changes that the paper's control subtraction has to
estimate (the `improvement` row is that estimate, as the paper computes it).

Metrics: per group and period the total, longitudinal and transverse RMS (combined
references, reports banked over `max_roll_deg` left out), the poor group's adjusted after
cells and improvement (kn and %), the trustworthy share of aircraft (before-period RMS
under `trustworthy_rms_kt`, wind paper Fig. 10) before and after, and — available only
in simulation — the poor group's residual heading error against the truth.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Literal

import numpy as np
import pandas as pd
from pydantic import Field, StrictBool, StrictInt, model_validator

from aerotruth.analysis.wind.paper_draw import COMPONENTS, aircraft_day_sums, derived_cells
from aerotruth.schema import Section
from aerotruth.sim.campaign_file import Campaign, References
from aerotruth.sim.fleet_days import (
    FlightSelection,
    aircraft_days,
    check_networks,
    day_cost,
    day_task,
)
from aerotruth.sim.studies import Figure, Study, Summary
from aerotruth.sim.studies.wind_reports import (
    DIVERGED,
    band_midpoints_ft,
    check_sensors,
    day_rows,
    observations_only,
    sensor_params,
    steady_heading_error,
    unbanked,
)
from aerotruth.sim.tasks import Task
from aerotruth.sim.wind_observations import WindSensors

STAGES = ("fit", "before", "after")


class PeriodRoles(Section):
    """Which campaign periods play the fit, before and after roles."""

    fit: str = Field(min_length=1)
    before: str = Field(min_length=1)
    after: str = Field(min_length=1)


class Selection(Section):
    """How many aircraft get tables (largest before RMS) and how many are controls (smallest),
    ranked by which before-period RMS (`by`)."""

    poor: StrictInt = Field(ge=1, le=10_000, description="aircraft with the largest before-period RMS get tables")
    control: StrictInt = Field(
        ge=1, le=10_000, description="aircraft with the smallest before-period RMS are the control group"
    )
    by: Literal["total", "transverse"] = Field(
        "total",
        description="rank by the total RMS vector difference (wind quality: 'chosen for their poorer wind "
        "quality', wind paper section 8.2) or by its transverse component, the heading's "
        "share ('poorly performing heading systems', Tables I-IV; section 6: transverse "
        "errors suggest inaccurate heading, longitudinal inaccurate TAS)",
    )


class PaperCell(Section):
    """A published table cell, shown beside the simulated one (never used to compute it)."""

    group: Literal["poor", "control"]
    period: Literal["before", "after", "after_adjusted", "improvement", "change"]
    rms_kt: float
    longitudinal_rms_kt: float | None = None
    transverse_rms_kt: float | None = None
    role: Literal["calibrated", "predicted"] = Field(
        description="calibrated: a cell the campaign's parameters were "
        "tuned on; predicted: a cell left to the simulation"
    )


class PaperTable(Section):
    """The published table the campaign predicts (for the side-by-side report table)."""

    source: str = Field(min_length=1, description="where the numbers are printed, e.g. 'wind paper Table II'")
    cells: list[PaperCell] = Field(min_length=1)


class HeadingCorrectionConfig(Section):
    """Fleets, periods, sensors, selection and method options of the study."""

    fleets: list[str] = Field(min_length=1)
    periods: PeriodRoles
    max_legs_per_day: StrictInt | None = Field(default=None, ge=1, le=72)
    turbulence: StrictBool = Field(
        default=False,
        description="fly the truth legs with the atmosphere's disturbances "
        "(MIL-F-8785C patches and light chop, aerotruth.truth.turbulence); the "
        "autopilot's steering wander and the FMS's navigation error "
        "(aerotruth.truth.steering) are in every leg",
    )
    sensors: WindSensors = Field(default_factory=WindSensors)
    selection: Selection
    fit_heading: Literal["true", "magnetic"] = Field(
        default="true",
        description="frame of the fitted table: true (the paper's shortcut) or magnetic (the frame "
        "the onboard table is indexed by)",
    )
    max_roll_deg: float = Field(default=10.0, gt=0, le=90, description="reports banked more are not scored")
    trustworthy_rms_kt: float = Field(
        default=10.0,
        gt=0,
        description="an aircraft is trustworthy when its RMS vector "
        "difference is below this (assumption: the paper's flag threshold is not given)",
    )
    paper: PaperTable | None = Field(default=None, description="published cells shown beside the simulated ones")

    @model_validator(mode="after")
    def _distinct_roles(self) -> HeadingCorrectionConfig:
        if self.periods.before == self.periods.after:
            raise ValueError("periods: before and after must be different periods")
        return self

    def gates(self):
        """The method's ground-track gates: the study's roll limit, the reports' position step."""
        from aerotruth.analysis.wind.heading_errors import GateSpec

        return GateSpec(max_roll_deg=self.max_roll_deg, position_step_deg=self.sensors.reports.lat_lon_step_deg)

    def flights(self, role: str) -> FlightSelection:
        """The aircraft-days of one role."""
        return FlightSelection(
            fleets=self.fleets,
            periods=[getattr(self.periods, role)],
            max_legs_per_day=self.max_legs_per_day,
            turbulence=self.turbulence,
        )


def group_rms(obs: pd.DataFrame) -> dict[str, float]:
    """Total/longitudinal/transverse RMS and report count of an observation table."""
    from aerotruth.analysis.wind.metrics import wind_error_summary, wind_errors

    if obs.empty:
        return {"n": 0, **{c: np.nan for c, _ in COMPONENTS}}
    s = wind_error_summary(wind_errors(obs)).iloc[0]
    return {"n": int(obs.drop_duplicates(["aircraft", "time"]).shape[0]), **{c: float(s[c]) for c, _ in COMPONENTS}}


def per_aircraft_rms(obs: pd.DataFrame, errors: pd.DataFrame | None = None) -> pd.DataFrame:
    """RMS vector difference (combined references) per aircraft; `errors`: the table's
    `wind_errors` when they are at hand."""
    from aerotruth.analysis.wind.metrics import wind_error_summary, wind_errors

    if obs.empty:
        return pd.DataFrame(columns=["aircraft", "n", "rms_kt", "transverse_rms_kt"])
    errors = wind_errors(obs) if errors is None else errors
    return wind_error_summary(errors, by=["aircraft"])[["aircraft", "n", "rms_kt", "transverse_rms_kt"]]


class HeadingCorrection(Study):
    """The `heading_correction` study (see the module docstring)."""

    name = "heading_correction"
    title = "Heading-deviation correction: fit, select, upload, compare (wind paper Tables I-IV)"
    Config = HeadingCorrectionConfig
    learns = {"corrections": ("fit", "before")}

    def check(self, campaign: Campaign, refs: References) -> None:
        section: HeadingCorrectionConfig = campaign.section(self.name)
        refs.names(("fleets",), "fleets")
        for role in STAGES:
            refs.names(("periods", role), "periods")
        check_networks(campaign, refs, section.fleets, "aircraft fly their network's daily schedule")
        check_sensors(campaign, refs, section.sensors, prefix=("sensors",))
        n = sum(len(campaign.fleet(f).aircraft) for f in section.fleets)
        if section.selection.poor + section.selection.control > n:
            raise refs.error(
                ("selection",),
                f"poor + control = {section.selection.poor + section.selection.control} "
                f"exceeds the {n} aircraft of the fleets",
            )

    def expand(self, campaign: Campaign, section: HeadingCorrectionConfig) -> list[Task]:
        tasks = []
        for role in STAGES:
            needs = ("corrections",) if role == "after" else ()
            for fleet, day in aircraft_days(campaign, section.flights(role)):
                tasks.append(
                    day_task(
                        self.name,
                        fleet,
                        day,
                        stage=role,
                        needs=needs,
                        **sensor_params(campaign, section.sensors, fleet),
                    )
                )
        return tasks

    def cost(self, task: Task) -> float:
        return day_cost(task.params["day"]) + 1.0

    def run(self, task: Task, ctx) -> pd.DataFrame:
        correction = None
        if task.stage == "after":
            correction = uploaded_correction(ctx.learned["corrections"], task.params["day"].aircraft)
        rows = day_rows(task, ctx, correction, mark_corrected=True).assign(untreated=False)
        if correction is None:
            return rows
        # the same reports without the table: same flights, same sensor noise (named streams)
        twin = day_rows(task, ctx, None, mark_corrected=True)
        return pd.concat([rows, twin[twin["trigger"] != DIVERGED].assign(untreated=True)], ignore_index=True)

    def fit(self, name: str, rows: pd.DataFrame, section: HeadingCorrectionConfig, rng) -> pd.DataFrame:
        from aerotruth.analysis.wind.heading_correction import FleetHeadingFit

        fit_obs = reported(rows[rows["stage"] == "fit"])
        before = unbanked(reported(rows[rows["stage"] == "before"]), section.max_roll_deg)
        table = (
            FleetHeadingFit(heading=section.fit_heading, gates=section.gates())
            .fit(fit_obs, source="fit-period reports")
            .to_table()
        )
        rms = per_aircraft_rms(before).rename(
            columns={"n": "before_n", "rms_kt": "before_rms_kt", "transverse_rms_kt": "before_transverse_rms_kt"}
        )
        info = fit_obs.drop_duplicates("aircraft")[["aircraft", "fleet", "heading_input", "heading_class"]]
        out = info.merge(rms, on="aircraft", how="left").merge(table, on="aircraft", how="left")
        out["aircraft"] = out["aircraft"].astype(str)
        rank = {"total": "before_rms_kt", "transverse": "before_transverse_rms_kt"}[section.selection.by]
        have = (
            out.dropna(subset=[rank]).sort_values([rank, "aircraft"], ascending=[False, True])["aircraft"].tolist()
        )  # worst first; aircraft without before-period reports are never selected
        poor = set(have[: section.selection.poor])
        control = set(have[::-1][: section.selection.control]) - poor
        out["group"] = np.where(
            out["aircraft"].isin(poor), "poor", np.where(out["aircraft"].isin(control), "control", "other")
        )
        out["status"] = out["status"].fillna("refused")
        out["reason"] = out["reason"].fillna("no fit-period reports")
        gates = section.gates()  # how the tables were learned (the fit figure redraws with them)
        out["gate_max_roll_deg"], out["gate_position_step_deg"] = gates.max_roll_deg, gates.position_step_deg
        return out.sort_values("aircraft").reset_index(drop=True)

    def summarize(self, rows: pd.DataFrame, learned, section: HeadingCorrectionConfig) -> Summary:
        corr = learned.get("corrections")
        m: dict[str, Any] = {
            "aircraft_days": int(rows["task_id"].nunique()) if "task_id" in rows else 0,
            "legs_diverged": int((rows.get("trigger") == "leg_diverged").sum()) if "trigger" in rows else 0,
        }
        if corr is None or rows.empty:
            return Summary(m, {})
        from aerotruth.analysis.wind.metrics import wind_errors

        group_of = corr.set_index("aircraft")["group"]
        cells, per_ac, scored, day_sums = [], [], {}, []
        for stage in ("before", "after"):
            obs = unbanked(reported(rows[rows["stage"] == stage]), section.max_roll_deg)
            if obs.empty:
                continue
            obs = obs.assign(group=obs["aircraft"].astype(str).map(group_of).fillna("other"))
            scored[stage] = obs
            for g in ("poor", "control"):
                cells.append({"group": g, "period": stage, **group_rms(obs[obs["group"] == g])})
            errors = wind_errors(obs)
            per_ac.append(per_aircraft_rms(obs, errors).assign(period=stage))
            day_sums.append(aircraft_day_sums(errors, stage))
        twin = unbanked(untreated(rows[rows["stage"] == "after"]), section.max_roll_deg) if "stage" in rows else None
        if twin is not None and len(twin):
            day_sums.append(aircraft_day_sums(wind_errors(twin), "after_untreated"))
            cells.append(
                {
                    "group": "poor",
                    "period": "after_untreated",
                    **group_rms(twin[twin["aircraft"].astype(str).map(group_of) == "poor"]),
                }
            )
        table = pd.DataFrame(cells)
        table = derived_cells(table)
        by_altitude = rms_by_altitude(scored, table)
        for r in table.itertuples():
            for col, label in COMPONENTS:
                m[f"{r.group}.{r.period}.{label}_rms_kt"] = None if pd.isna(getattr(r, col)) else float(getattr(r, col))
        imp = table[(table.group == "poor") & (table.period == "improvement")]
        bef = table[(table.group == "poor") & (table.period == "before")]
        if len(imp) and len(bef):
            m["poor.improvement_pct"] = float(100.0 * imp["rms_kt"].iloc[0] / bef["rms_kt"].iloc[0])
        bars = pd.concat(per_ac, ignore_index=True) if per_ac else pd.DataFrame()
        if len(bars):
            bars["group"] = bars["aircraft"].astype(str).map(group_of).fillna("other")
            wide = bars.pivot_table(index=["aircraft", "group"], columns="period", values="rms_kt").reset_index()
            for p in ("before", "after"):
                if p in wide:
                    m[f"trustworthy_share.{p}"] = float((wide[p] < section.trustworthy_rms_kt).mean())
        else:
            wide = pd.DataFrame()
        residual = residual_heading_error(rows, group_of)
        for r in residual.itertuples():
            m[f"{r.group}.{r.period}.heading_error_rms_deg"] = float(r.heading_error_rms_deg)
        fits = corr[
            [
                c
                for c in (
                    "aircraft",
                    "fleet",
                    "group",
                    "heading_class",
                    "heading_input",
                    "before_rms_kt",
                    "status",
                    "A_deg",
                    "B_deg",
                    "C_deg",
                    "D_deg",
                    "E_deg",
                    "A_se_deg",
                    "B_se_deg",
                    "C_se_deg",
                    "reason",
                )
                if c in corr.columns
            ]
        ]
        m["aircraft_fitted"] = int((corr["status"] == "fitted").sum())
        m["aircraft_offset_only"] = int((corr["status"] == "offset_only").sum())
        m["aircraft_refused"] = int((corr["status"] == "refused").sum())
        tables = {"groups": table, "aircraft_days": _aircraft_days(day_sums, group_of)}
        if section.paper is not None:
            tables["versus_paper"] = versus_paper(table, section.paper)
        tables.update(
            {
                "per_aircraft": wide,
                "heading_error_vs_truth": residual,
                "fits": fits,
                "rms_by_altitude": by_altitude,
                "trustworthy_by_day": trustworthy_by_day(scored, section),
            }
        )
        return Summary(m, tables, exports={"observations": reported(rows)})

    def figures(self, rows: pd.DataFrame, summary: Summary, learned, out_dir: Path) -> list[Figure]:
        import matplotlib.pyplot as plt

        figs = []
        wide = summary.tables.get("per_aircraft")
        if wide is not None and len(wide) and "before" in wide:
            w = wide[wide["group"].isin(["poor", "control"])].sort_values(["group", "before"], ascending=[False, False])
            fig, ax = plt.subplots(figsize=(max(6, 0.35 * len(w)), 4))
            x = np.arange(len(w))
            ax.bar(x - 0.2, w["before"], 0.4, color="maroon", label="before")
            if "after" in w:
                poor = (w["group"] == "poor").to_numpy()
                for sel, color, label in (
                    (poor, "green", "after, table uploaded"),
                    (~poor, "white", "after, control (unchanged)"),
                ):
                    if sel.any():
                        ax.bar(x[sel] + 0.2, w["after"].to_numpy()[sel], 0.4, color=color, edgecolor="k", label=label)
            ax.set_xticks(x, w["aircraft"], rotation=90, fontsize=7)
            ax.set_ylabel("RMS vector difference (kt)")
            ax.legend(fontsize=8)
            ax.set_title("Per aircraft before/after, combined references (wind paper Fig. 9)")
            out_dir.save(fig, "heading_correction_per_aircraft")
            figs.append(
                Figure(
                    "heading_correction_per_aircraft",
                    "RMS vector difference per aircraft before and after (poor: table uploaded; control: unchanged)",
                )
            )
        alt = summary.tables.get("rms_by_altitude")
        if alt is not None and len(alt):
            figs += altitude_figures(alt, out_dir)
        daily = summary.tables.get("trustworthy_by_day")
        if daily is not None and len(daily):
            fig, ax = plt.subplots(figsize=(max(6, 0.3 * len(daily)), 3.5))
            x = np.arange(len(daily))
            ax.bar(x, daily["untrustworthy"], color="tab:blue", label="untrustworthy")
            ax.bar(x, daily["trustworthy"], bottom=daily["untrustworthy"], color="tab:green", label="trustworthy")
            ax.set_xticks(
                x, [f"{d} ({p})" for d, p in zip(daily["date"], daily["period"], strict=False)], rotation=90, fontsize=7
            )
            ax.set_ylabel("aircraft reporting")
            ax.legend(fontsize=8)
            ax.set_title(
                f"Trustworthy: the day's RMS vector difference < {float(daily['threshold_kt'].iloc[0]):g} kt "
                "(wind paper Fig. 10)",
                fontsize=9,
            )
            out_dir.save(fig, "heading_correction_trustworthy")
            figs.append(
                Figure(
                    "heading_correction_trustworthy",
                    "Trustworthy and untrustworthy aircraft per day, "
                    "before and after the tables (every aircraft of the fleet)",
                )
            )
        corr = learned.get("corrections")
        fit_obs = reported(rows[rows["stage"] == "fit"]) if "stage" in rows else pd.DataFrame()
        if corr is not None and len(fit_obs):
            from aerotruth.analysis.wind.heading_errors import GateSpec, heading_errors

            poor = corr[(corr["group"] == "poor") & (corr["status"] != "refused")].sort_values(
                "before_rms_kt", ascending=False
            )
            show = poor["aircraft"].tolist()[:4]
            if show:
                # the fit's own gates and heading frame (stored with the tables; defaults for older runs)
                first = corr.iloc[0]
                gates = GateSpec(
                    **{
                        k: float(first[f"gate_{k}"])
                        for k in ("max_roll_deg", "position_step_deg")
                        if f"gate_{k}" in corr.columns
                    }
                )
                frames = corr["heading_frame"].dropna() if "heading_frame" in corr.columns else pd.Series(dtype=object)
                frame = "heading_mag_deg" if len(frames) and frames.iloc[0] == "magnetic" else "heading_deg"
                errs = heading_errors(fit_obs[fit_obs["aircraft"].astype(str).isin(show)], gates)
                fig, axes = plt.subplots(1, len(show), figsize=(3.2 * len(show), 3.2), squeeze=False, sharey=True)
                z = np.linspace(0, 360, 181)
                for ax, ac in zip(axes[0], show, strict=False):
                    e = errs[(errs["aircraft"].astype(str) == ac) & (errs["gate"] == "used")]
                    ax.plot(e[frame], e["error_deg"], ".", ms=2, alpha=0.4)
                    r = corr.set_index("aircraft").loc[ac]
                    zr = np.radians(z)
                    d = (
                        r["A_deg"]
                        + r["B_deg"] * np.sin(zr)
                        + r["C_deg"] * np.cos(zr)
                        + r["D_deg"] * np.sin(2 * zr)
                        + r["E_deg"] * np.cos(2 * zr)
                    )
                    ax.plot(z, d, "r-", lw=2)
                    ax.set_title(f"{ac} ({r['status']})", fontsize=9)
                    ax.set_xlabel(f"measured {'magnetic' if frame == 'heading_mag_deg' else 'true'} heading (deg)")
                    ax.set_xlim(0, 360)
                    ax.set_ylim(-15, 15)
                    ax.grid(alpha=0.3)
                axes[0][0].set_ylabel("heading error (deg)")
                fig.suptitle("Heading error vs measured heading with the fit (wind paper Figs. 3/8)")
                out_dir.save(fig, "heading_correction_fits")
                figs.append(
                    Figure(
                        "heading_correction_fits",
                        "Fit-period heading errors of the poorest aircraft with the fitted eq. 2 curve",
                    )
                )
        return figs


ALTITUDE_BANDS_FT = tuple(float(x) for x in range(0, 45001, 5000))
MIN_BAND_REPORTS = 20  # an altitude band with fewer (report, model) rows is not shown


def rms_by_altitude(scored: dict[str, pd.DataFrame], table: pd.DataFrame) -> pd.DataFrame:
    """Total/longitudinal/transverse RMS by group, period, flight phase ("all" and each of
    ascent/descent/level) and 5,000-ft pressure-altitude band (wind paper Figs. 5/6, 11/12,
    13/14); the poor group's after rows also adjusted by the control group's change of the
    whole table (period "after_adjusted", the paper's Fig. 14: "0.6 kn ... subtracted")."""
    from aerotruth.analysis.wind.metrics import wind_error_summary, wind_errors

    parts = []
    for stage, obs in scored.items():
        sel = obs[obs["group"].isin(["poor", "control"])]
        if sel.empty:
            continue
        for group, g in sel.groupby("group", sort=True, observed=True):
            err = wind_errors(g)
            for phase_by in ([], ["phase"]):
                t = wind_error_summary(err, by=[*phase_by, "altitude_band"], altitude_bands_ft=ALTITUDE_BANDS_FT)
                if not phase_by:
                    t["phase"] = "all"
                parts.append(t.assign(period=stage, group=group))
    if not parts:
        return pd.DataFrame()
    out = pd.concat(parts, ignore_index=True)
    out = out[out["n"] >= MIN_BAND_REPORTS].copy()
    out["altitude_band"] = out["altitude_band"].astype(str)
    change = table[(table["group"] == "control") & (table["period"] == "change")] if len(table) else table
    if len(change):
        adj = out[(out["group"] == "poor") & (out["period"] == "after")].copy()
        for col, _ in COMPONENTS:
            adj[col] = adj[col] - float(change[col].iloc[0])
        out = pd.concat([out, adj.assign(period="after_adjusted")], ignore_index=True)
    return out[["group", "period", "phase", "altitude_band", "n", *(c for c, _ in COMPONENTS)]]


def trustworthy_by_day(scored: dict[str, pd.DataFrame], section: HeadingCorrectionConfig) -> pd.DataFrame:
    """Per day of the before and after periods: how many aircraft reported and how many of
    them had a day's RMS vector difference under `trustworthy_rms_kt` (wind paper Fig. 10;
    AirDat's flag is set by its quality system, whose rule is not published)."""
    from aerotruth.analysis.wind.metrics import wind_error_summary, wind_errors

    rows = []
    for stage, obs in scored.items():
        for date, day in obs.groupby(obs["date"].astype(str), sort=True):
            per = wind_error_summary(wind_errors(day), by=["aircraft"])
            ok = int((per["rms_kt"] < section.trustworthy_rms_kt).sum())
            rows.append(
                {
                    "date": date,
                    "period": stage,
                    "trustworthy": ok,
                    "untrustworthy": int(len(per)) - ok,
                    "threshold_kt": section.trustworthy_rms_kt,
                }
            )
    return pd.DataFrame(rows)


def altitude_figures(alt: pd.DataFrame, out_dir: Path) -> list[Figure]:
    """RMS and its components vs altitude: control vs poor before (Figs. 5/6), poor before
    vs after (Figs. 11/12), and the poor group by flight phase before and after adjusted
    (Figs. 13/14)."""

    def cell(g, p, phase="all"):
        return alt[(alt["group"] == g) & (alt["period"] == p) & (alt["phase"] == phase)]

    figs = []
    components = (
        ("rms_kt", "total", "tab:blue"),
        ("longitudinal_rms_kt", "longitudinal", "tab:pink"),
        ("transverse_rms_kt", "transverse", "tab:brown"),
    )
    panels = [
        (f"{g}, {p.replace('_', ' ')}", [(cell(g, p), col, label, color) for col, label, color in components])
        for g, p in (("control", "before"), ("poor", "before"), ("poor", "after_adjusted"))
        if len(cell(g, p))
    ]
    if panels:
        figs.append(
            _altitude_panels(
                panels,
                out_dir,
                "heading_correction_rms_altitude",
                "RMS (kt)",
                3.6,
                "RMS wind difference vs altitude (wind paper Figs. 5/6 and 11/12)",
                "Total, longitudinal and transverse RMS vs altitude: control and poor groups "
                "before, poor group after (adjusted by the control's change)",
            )
        )
    poor = alt[(alt["group"] == "poor") & (alt["phase"] != "all")]
    panels = [
        (
            f"poor group, {p.replace('_', ' ')}",
            [(t, "rms_kt", phase, None) for phase, t in poor[poor["period"] == p].groupby("phase", sort=True)],
        )
        for p in ("before", "after_adjusted")
        if (poor["period"] == p).any()
    ]
    if panels:
        figs.append(
            _altitude_panels(
                panels,
                out_dir,
                "heading_correction_phase",
                "RMS vector difference (kt)",
                4.0,
                "By flight phase (wind paper Figs. 13/14)",
                "Poor group's RMS vs altitude by flight phase, before and after (after adjusted "
                "by the control group's change)",
            )
        )
    return figs


def _altitude_panels(panels, out_dir: Path, stem: str, xlabel: str, width: float, title: str, caption: str) -> Figure:
    """One row of panels (title, [(rows, column, label, color)]) of RMS vs altitude-band middle."""
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(panels), figsize=(width * len(panels), 4), sharex=True, sharey=True, squeeze=False)
    for ax, (name, lines) in zip(axes[0], panels, strict=False):
        for t, col, label, color in lines:
            ax.plot(t[col], band_midpoints_ft(t["altitude_band"]), "o-", color=color, label=label)
        ax.set_title(name, fontsize=9)
        ax.set_xlabel(xlabel)
        ax.grid(alpha=0.3)
    axes[0][0].set_ylabel("pressure altitude (ft)")
    axes[0][0].legend(fontsize=7)
    fig.suptitle(title, fontsize=10)
    out_dir.save(fig, stem)
    return Figure(stem, caption)


def reported(rows: pd.DataFrame) -> pd.DataFrame:
    """The observation rows the fleet reported (the untreated twins of corrected reports off)."""
    return _twins(rows, False)


def untreated(rows: pd.DataFrame) -> pd.DataFrame:
    """The after-period reports of table-carrying aircraft as they would have been without
    the table (simulation only: same flights and sensor noise)."""
    return _twins(rows, True)


def _twins(rows: pd.DataFrame, twin: bool) -> pd.DataFrame:
    obs = observations_only(rows)
    if "untreated" not in obs.columns:
        return obs.iloc[0:0] if twin else obs
    keep = obs["untreated"].fillna(False).astype(bool) == twin
    return obs[keep].drop(columns="untreated").reset_index(drop=True)


def uploaded_correction(corrections: pd.DataFrame, aircraft: str):
    """The correction uploaded to `aircraft`: its 8-point table (magnetic-heading systems)
    or its offset (true-heading avionics) when it is in the poor group and was fitted;
    None otherwise."""
    from aerotruth.analysis.wind.heading_correction import LUT_COLUMNS
    from aerotruth.sensors.tamdar import LookupTableCorrection, OffsetCorrection

    rows = corrections[corrections["aircraft"].astype(str) == aircraft]
    if rows.empty:
        return None
    r = rows.iloc[0]
    if r["group"] != "poor" or r["status"] not in ("fitted", "offset_only"):
        return None
    lut = [float(r[c]) for c in LUT_COLUMNS]
    if r["heading_input"] == "true":
        return OffsetCorrection(offset_deg=float(np.mean(lut)))
    return LookupTableCorrection(lut_deg=lut)


def _aircraft_days(parts: list[pd.DataFrame], group_of: pd.Series) -> pd.DataFrame:
    """The scored reports' sums per aircraft, UTC day and period (before, after and the
    after period's untreated twin: `parts`), every aircraft with its group (poor, control,
    other): every cell is a ratio of these sums (aerotruth.analysis.wind.paper_draw), and
    they let a cell be redrawn at the paper's fleet size and period length
    (validation/paper_tables.py)."""
    if not parts:
        return pd.DataFrame(columns=["aircraft", "group", "period", "day"])
    days = pd.concat(parts, ignore_index=True)
    days.insert(1, "group", days["aircraft"].map(group_of).fillna("other").astype(str))
    return days


def versus_paper(table: pd.DataFrame, paper: PaperTable) -> pd.DataFrame:
    """Each published cell beside the simulated one, marked calibrated or predicted."""
    sim = table.set_index(["group", "period"]) if len(table) else None
    rows = []
    for c in paper.cells:
        for col, label in COMPONENTS:
            published = getattr(c, col)
            if published is None:
                continue
            value = (
                float(sim.loc[(c.group, c.period), col])
                if sim is not None and (c.group, c.period) in sim.index
                else np.nan
            )
            rows.append(
                {
                    "group": c.group,
                    "period": c.period,
                    "component": label,
                    "paper_kt": published,
                    "simulated_kt": value,
                    "difference_kt": value - published,
                    "role": c.role,
                }
            )
    return pd.DataFrame(rows).assign(source=paper.source)


def residual_heading_error(rows: pd.DataFrame, group_of: pd.Series) -> pd.DataFrame:
    """RMS of reported minus true heading in steady level flight per group and period
    (simulation only: the truth is known)."""
    out = []
    for stage in ("before", "after"):
        obs = reported(rows[rows["stage"] == stage]) if "stage" in rows else pd.DataFrame()
        if obs.empty:
            continue
        steady = steady_heading_error(obs)
        d = steady["d_deg"]
        g = steady["aircraft"].astype(str).map(group_of).fillna("other")
        for name in ("poor", "control"):
            x = d[g == name]
            if len(x):
                out.append(
                    {
                        "group": name,
                        "period": stage,
                        "n": int(len(x)),
                        "heading_error_rms_deg": float(np.sqrt(np.mean(x**2))),
                        "heading_error_mean_deg": float(np.mean(x)),
                    }
                )
    return pd.DataFrame(out)


STUDY = HeadingCorrection()
