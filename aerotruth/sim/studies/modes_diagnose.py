"""Mode-S diagnose study: can `diagnose` find a sensor effect hidden in a fleet's Mode-S
data, how big does it say it is, and does it invent effects that are not there?

One task per aircraft-day (the same aircraft-days, hence the same truth, as the `truth`
study of the campaign): the day's legs from the truth store go through the Mode-S sensor
(aerotruth.sensors.modes) with the hidden effects of the section (a variation-table
error, a heading lag; the sensor's reply and noise draws from the task's "sensor",
"modes" stream), are decoded to a 1-s trajectory and diagnosed
(aerotruth.analysis.diagnose.modes). One row per finding (or one empty row per day).
Metrics: the share of days whose first finding is the hidden effect, the estimated size
(mean and spread), and the count of other findings (false findings when nothing is hidden);
a table of each day's account of the hidden effect (found, or how far its test got:
estimate, standard error, delta BIC, jackknife p), so that a day below diagnose's power
reads as such rather than as a silent miss.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
from pydantic import Field

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

EXPECTED = {"table_error_deg": ("heading_offset", "A_deg"), "heading_lag_s": ("heading_time_offset", "D_s")}


HIDDEN_EMPTY = {"outcome": "", "value": np.nan, "se": np.nan, "delta_bic": np.nan, "p_value": np.nan}


def hidden_effect_outcome(params: dict, findings, baseline: dict) -> dict:
    """What diagnose said of the day's hidden effect (the first of EXPECTED that is set):
    found (with its rank), or the outcome of its last test after the other findings (not
    significant, not identifiable, below the resolution...) with the size it estimated
    there, as `hidden_*` columns. Empty when nothing is hidden."""
    key = next((k for k in EXPECTED if params.get(k)), None)
    if key is None:
        return {f"hidden_{k}": v for k, v in HIDDEN_EMPTY.items()}
    effect, name = EXPECTED[key]
    out = dict(HIDDEN_EMPTY)
    for rank, f in enumerate(findings, 1):
        if f.effect == effect:
            out.update(
                outcome=f"found (rank {rank})",
                value=f.parameters[name]["value"],
                se=f.parameters[name]["se"],
                delta_bic=f.evidence["delta_bic"],
                p_value=f.evidence["p_value"],
            )
            break
    else:
        tried = (baseline.get("rounds") or [{}])[-1].get(effect, {"outcome": "not tried"})
        out.update(
            outcome=tried["outcome"],
            value=tried.get("values", {}).get(name, np.nan),
            se=tried.get("se", {}).get(name, np.nan),
            delta_bic=tried.get("delta_bic", np.nan),
            p_value=tried.get("p_value", np.nan),
        )
    return {f"hidden_{k}": v for k, v in out.items()}


class ModesDiagnoseConfig(Section):
    """Flights and the effects hidden in their Mode-S data."""

    flights: FlightSelection
    table_error_deg: float = Field(
        default=0.0, ge=-20, le=20, description="aircraft variation table minus true declination"
    )
    heading_lag_s: float = Field(default=0.0, ge=0, le=10, description="age of the heading samples")


class ModesDiagnose(Study):
    """The `modes_diagnose` study (see the module docstring)."""

    name = "modes_diagnose"
    title = "Diagnose on simulated Mode-S data"
    Config = ModesDiagnoseConfig

    def check(self, campaign: Campaign, refs: References) -> None:
        check_flights(campaign, refs, campaign.section(self.name).flights, prefix=("flights",))

    def expand(self, campaign: Campaign, section: ModesDiagnoseConfig) -> list[Task]:
        return [
            day_task(
                self.name, fleet, day, table_error_deg=section.table_error_deg, heading_lag_s=section.heading_lag_s
            )
            for fleet, day in aircraft_days(campaign, section.flights)
        ]

    def cost(self, task: Task) -> float:
        return day_cost(task.params["day"]) + 2.0

    def run(self, task: Task, ctx) -> pd.DataFrame:
        from aerotruth.analysis.diagnose.modes import diagnose_track
        from aerotruth.errors import DataError
        from aerotruth.measured.modes import track_from_measured
        from aerotruth.sim.modes_data import simulated_modes_day

        day, p = task.params["day"], task.params
        base = {
            "aircraft": day.aircraft,
            "date": day.date.isoformat(),
            "samples": 0,
            "rank": 0,
            "effect": "",
            "value": np.nan,
            "se": np.nan,
            "delta_bic": np.nan,
            "held_out_before_kt": np.nan,
            "held_out_after_kt": np.nan,
            "note": "",
            **{f"hidden_{k}": v for k, v in HIDDEN_EMPTY.items()},
        }
        try:
            measured = simulated_modes_day(
                day,
                table_error_deg=p["table_error_deg"],
                heading_lag_s=p["heading_lag_s"],
                rng=ctx.rng("sensor", "modes"),
                store=ctx.truth,
            )
            frame, _ = track_from_measured(measured)
        except (DataError, ValueError) as e:
            return pd.DataFrame([{**base, "note": str(e)[:200]}])
        findings, baseline = diagnose_track(frame)
        base.update(hidden_effect_outcome(p, findings, baseline))
        rows = []
        for i, f in enumerate(findings, 1):
            name, v = next(iter(f.parameters.items()))
            rows.append(
                {
                    **base,
                    "samples": len(frame),
                    "rank": i,
                    "effect": f.effect,
                    "value": v["value"],
                    "se": v["se"],
                    "delta_bic": f.evidence["delta_bic"],
                    "held_out_before_kt": f.gain["held_out_before"],
                    "held_out_after_kt": f.gain["held_out_after"],
                }
            )
        return pd.DataFrame(rows or [{**base, "samples": len(frame), "note": "no finding"}])

    def summarize(self, rows: pd.DataFrame, learned, section: ModesDiagnoseConfig) -> Summary:
        days = rows.groupby("task_id", sort=True)
        n = int(days.ngroups)
        hidden = [
            (k, v)
            for k, v in (("table_error_deg", section.table_error_deg), ("heading_lag_s", section.heading_lag_s))
            if v
        ]
        m: dict[str, Any] = {"days": n, "days_usable": int((days["samples"].max() > 0).sum())}
        firsts = rows[rows["rank"] == 1]
        if hidden:
            key, size = hidden[0]
            effect, _ = EXPECTED[key]
            mine = firsts[firsts["effect"] == effect]
            # the estimate is the correction to add, so a table error of +x reads +x; a lag of x reads +x
            m["hidden_effect"] = size
            m["detection_rate"] = float(len(mine) / max(m["days_usable"], 1))
            m["estimate_mean"] = float(mine["value"].mean()) if len(mine) else None
            m["estimate_sd"] = float(mine["value"].std(ddof=1)) if len(mine) > 1 else None
            m["other_findings"] = int((rows["rank"] > 0).sum() - len(mine))
        else:
            m["false_findings"] = int((rows["rank"] > 0).sum())
        table = rows[rows["rank"] > 0][
            [
                "aircraft",
                "date",
                "rank",
                "effect",
                "value",
                "se",
                "delta_bic",
                "held_out_before_kt",
                "held_out_after_kt",
            ]
        ].reset_index(drop=True)
        counts = pd.DataFrame({"days": [n], "usable": [m["days_usable"]], "findings": [int((rows["rank"] > 0).sum())]})
        tables = {"days_and_findings": counts, "findings": table}
        if hidden and "hidden_outcome" in rows.columns:
            # every day's account of the hidden effect: a day without it among the findings
            # says how far its test got (its estimate and evidence), not just "0 found"
            per_day = days.first()[
                [
                    "aircraft",
                    "date",
                    "samples",
                    "hidden_outcome",
                    "hidden_value",
                    "hidden_se",
                    "hidden_delta_bic",
                    "hidden_p_value",
                ]
            ].reset_index(drop=True)
            tables["hidden_effect_by_day"] = per_day.rename(columns=lambda c: c.removeprefix("hidden_"))
        return Summary(m, tables)

    def figures(self, rows: pd.DataFrame, summary: Summary, learned, out_dir: Path) -> list[Figure]:
        import matplotlib.pyplot as plt

        found = rows[rows["rank"] > 0]
        fig, ax = plt.subplots(figsize=(6, 3.5))
        if len(found):
            for i, (eff, g) in enumerate(found.groupby("effect", sort=True)):
                ax.errorbar(
                    g["value"],
                    np.full(len(g), i) + np.linspace(-0.2, 0.2, len(g)),
                    xerr=g["se"],
                    fmt="o",
                    ms=4,
                    label=eff,
                )
            ax.set_yticks(range(found["effect"].nunique()), sorted(found["effect"].unique()))
        hidden = summary.metrics.get("hidden_effect")
        if hidden:
            ax.axvline(hidden, color="r", ls="--", label=f"hidden {hidden:g}")
        ax.set_xlabel("estimated size (deg, s or relative)")
        ax.set_title(f"Findings on {summary.metrics['days']} simulated Mode-S days")
        ax.grid(alpha=0.3)
        out_dir.save(fig, "modes_diagnose_findings")
        return [
            Figure("modes_diagnose_findings", "Effects diagnose finds in simulated Mode-S data, with the hidden size")
        ]


STUDY = ModesDiagnose()


def extended_campaign(campaign: Campaign, findings) -> Campaign | None:
    """The model campaign extended by what diagnose found in Mode-S data: its
    `modes_diagnose` section (added on the first fleet and period when absent) carrying the
    found variation-table error (A, the correction diagnose reports, is the table error)
    and heading lag. None when the campaign has no fleet with a network to fly."""
    values = {f.effect: next(iter(f.parameters.values()))["value"] for f in findings}
    update = {}
    if "heading_offset" in values:
        update["table_error_deg"] = round(float(values["heading_offset"]), 3)
    if values.get("heading_time_offset", -1.0) >= 0.0:
        update["heading_lag_s"] = round(float(values["heading_time_offset"]), 3)
    section = campaign.studies.get(STUDY.name)
    if section is None:
        fleet = next((f for f in campaign.fleets if f.network is not None), None)
        if fleet is None or not campaign.periods:
            return None
        section = ModesDiagnoseConfig(
            flights=FlightSelection(fleets=[fleet.name], periods=[campaign.periods[0].name], max_legs_per_day=4)
        )
    studies = dict(campaign.studies)
    studies[STUDY.name] = section.model_copy(update=update)
    return campaign.model_copy(update={"studies": studies})
