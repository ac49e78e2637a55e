"""Truth flights: every aircraft of the chosen fleets flies each day of the chosen periods
with JSBSim, and each leg is scored against the foundation's acceptance figures.

One task per aircraft-day. The day's legs are the aircraft's generated schedule on its
fleet's network (`aerotruth.truth.routes.day_schedule`, runways into the day's surface
wind) or the campaign's fixed `legs:` list; `max_legs_per_day` keeps the first N. All
legs of one date fly through the same truth-atmosphere realization per region (seeded by
the campaign seed and the date, shared with the wind climatology). Legs come from the
truth store (aerotruth.truth.store), flown only when missing; every seed is recorded
with the leg, and `fly_command` re-flies it alone with `aerotruth fly`.

One output row per leg: identity, planned and flown distance, duration, cruise TAS error
(max, mean, RMS against the target), maximum cruise cross-track, arrival offset from the
extended centreline, maximum |V_G - V_A - V_W|, and — for a flight that diverged — the
flag, reason and time (such a leg is excluded from the statistics by name, never
silently).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from aerotruth.sim.campaign_file import Campaign, References
from aerotruth.sim.fleet_days import (
    FlightSelection,
    aircraft_days,
    check_flights,
    day_cost,
    day_task,
    flown_legs,
)
from aerotruth.sim.studies import Figure, Study, Summary
from aerotruth.sim.tasks import Task
from aerotruth.units import KT, NM

# Acceptance of a flown leg: leg metric -> upper limit
ACCEPTANCE = {
    "cruise_tas_error_max_kt": 5.0,
    "cruise_xtrack_max_nm": 0.3,
    "arrival_centreline_offset_nm": 1.0,
    "wind_triangle_residual_max_kt": 0.5,
}
LEG_METRICS = tuple(ACCEPTANCE) + ("cruise_tas_error_rms_kt", "distance_nm", "duration_s")


def leg_row(track) -> dict[str, float]:
    """The leg metrics of a flown TruthTrack: its summary() plus the cruise TAS error mean
    and RMS against the target and the mean cruise wind speed."""
    s = dict(track.summary())
    df = track.df
    cruise = (df["phase"] == "cruise").to_numpy()
    target = track.meta.get("cruise_tas_kt")
    if cruise.any() and target is not None:
        err = df["tas_mps"].to_numpy()[cruise] / KT - float(target)
        s["cruise_tas_error_mean_kt"] = float(np.mean(err))
        s["cruise_tas_error_rms_kt"] = float(np.sqrt(np.mean(err**2)))
        s["cruise_wind_mean_kt"] = float(
            np.mean(np.hypot(df["wind_u_mps"].to_numpy()[cruise], df["wind_v_mps"].to_numpy()[cruise])) / KT
        )
    else:
        s["cruise_tas_error_mean_kt"] = s["cruise_tas_error_rms_kt"] = s["cruise_wind_mean_kt"] = float("nan")
    return s


_NUMERIC = (
    "distance_nm",
    "duration_s",
    "cruise_tas_error_max_kt",
    "cruise_tas_error_mean_kt",
    "cruise_tas_error_rms_kt",
    "cruise_xtrack_max_nm",
    "arrival_centreline_offset_nm",
    "wind_triangle_residual_max_kt",
    "cruise_wind_mean_kt",
)


class TruthFlights(Study):
    """The `truth` study (see the module docstring)."""

    name = "truth"
    title = "Truth flights (JSBSim)"
    Config = FlightSelection

    def check(self, campaign: Campaign, refs: References) -> None:
        check_flights(campaign, refs, campaign.section(self.name))

    def expand(self, campaign: Campaign, section: FlightSelection) -> list[Task]:
        return [day_task(self.name, fleet, day) for fleet, day in aircraft_days(campaign, section)]

    def cost(self, task: Task) -> float:
        return day_cost(task.params["day"])

    def run(self, task: Task, ctx) -> pd.DataFrame:
        day = task.params["day"]
        ident = dict(task.identity)
        rows = []
        for k, out in enumerate(flown_legs(ctx, day)):
            leg, plan = out.leg, out.leg.plan
            row: dict[str, Any] = {
                "fleet": ident["fleet"],
                "aircraft": ident["aircraft"],
                "date": ident["date"],
                "leg": k + 1,
                "flight_id": plan.flight_id,
                "origin": plan.origin.icao,
                "destination": plan.destination.icao,
                "departure_utc": plan.departure_utc.isoformat(timespec="seconds"),
                "departure_runway": plan.departure_runway.ident,
                "arrival_runway": plan.arrival_runway.ident,
                "cruise_fl": plan.cruise_flight_level,
                "great_circle_nm": plan.distance_m / NM,
                "seed": leg.flight_seed,
                "weather_seed": leg.weather_seed,
                "day_seed": day.day_seed,
                "atmosphere_region": leg.region,
                "truth_key": out.key,
                "fly_command": "aerotruth fly " + " ".join(leg.replay_args(day.aircraft_type, day.turbulence)),
            }
            if out.diverged is not None:
                e = out.diverged
                row.update({c: float("nan") for c in _NUMERIC})
                row.update(
                    {
                        "diverged": True,
                        "diverge_reason": e.reason,
                        "diverge_time_s": float("nan") if e.time_s is None else float(e.time_s),
                    }
                )
            else:
                s = leg_row(out.track)
                row.update({c: float(s.get(c, float("nan"))) for c in _NUMERIC})
                row.update({"diverged": False, "diverge_reason": "", "diverge_time_s": float("nan")})
            rows.append(row)
        return pd.DataFrame(rows)

    def summarize(self, rows: pd.DataFrame, learned, section) -> Summary:
        metrics = self._metrics(rows)
        return Summary(metrics, self._tables(rows, metrics))

    def _metrics(self, rows: pd.DataFrame) -> dict[str, Any]:
        flown = rows[~rows["diverged"].astype(bool)] if len(rows) else rows
        out: dict[str, Any] = {
            "aircraft_days": int(rows["task_id"].nunique()) if len(rows) else 0,
            "legs": int(len(rows)),
            "legs_flown": int(len(flown)),
            "legs_diverged": int(len(rows) - len(flown)),
            "flown_hours": float(flown["duration_s"].sum() / 3600.0) if len(flown) else 0.0,
            "flown_distance_nm": float(flown["distance_nm"].sum()) if len(flown) else 0.0,
        }
        for metric, limit in ACCEPTANCE.items():
            x = flown[metric].to_numpy(dtype=float) if len(flown) else np.array([])
            x = x[np.isfinite(x)]
            if len(x):
                out[f"{metric}.mean"] = float(np.mean(x))
                out[f"{metric}.p95"] = float(np.percentile(x, 95))
                out[f"{metric}.max"] = float(np.max(x))
                out[f"{metric}.pass_fraction"] = float(np.mean(x <= limit))
            else:
                out.update({f"{metric}.{s}": None for s in ("mean", "p95", "max", "pass_fraction")})
        rms = flown["cruise_tas_error_rms_kt"].to_numpy(dtype=float) if len(flown) else np.array([])
        rms = rms[np.isfinite(rms)]
        out["cruise_tas_error_rms_kt.rms"] = float(np.sqrt(np.mean(rms**2))) if len(rms) else None
        return out

    def _tables(self, rows: pd.DataFrame, metrics: dict[str, Any]) -> dict[str, pd.DataFrame]:
        summary = pd.DataFrame(
            {
                "leg metric": list(ACCEPTANCE),
                "mean": [metrics.get(f"{m}.mean") for m in ACCEPTANCE],
                "95 %": [metrics.get(f"{m}.p95") for m in ACCEPTANCE],
                "max": [metrics.get(f"{m}.max") for m in ACCEPTANCE],
                "limit": list(ACCEPTANCE.values()),
                "fraction of legs within": [metrics.get(f"{m}.pass_fraction") for m in ACCEPTANCE],
            }
        )
        counts = pd.DataFrame(
            {
                "aircraft-days": [metrics["aircraft_days"]],
                "legs": [metrics["legs"]],
                "flown": [metrics["legs_flown"]],
                "diverged": [metrics["legs_diverged"]],
                "flight hours": [metrics["flown_hours"]],
                "distance (nm)": [metrics["flown_distance_nm"]],
            }
        )
        cols = [
            "flight_id",
            "origin",
            "destination",
            "departure_utc",
            "cruise_fl",
            "distance_nm",
            "duration_s",
            "cruise_tas_error_max_kt",
            "cruise_xtrack_max_nm",
            "arrival_centreline_offset_nm",
            "wind_triangle_residual_max_kt",
            "cruise_wind_mean_kt",
            "seed",
            "diverged",
        ]
        out = {
            "legs_flown": counts,
            "leg_metrics": summary,
            "legs": rows[cols].reset_index(drop=True) if len(rows) else pd.DataFrame(columns=cols),
        }
        div = rows[rows["diverged"].astype(bool)] if len(rows) else rows
        if len(div):
            out["diverged_legs"] = div[
                ["flight_id", "origin", "destination", "seed", "weather_seed", "diverge_time_s", "diverge_reason"]
            ].reset_index(drop=True)
        return out

    def figures(self, rows: pd.DataFrame, summary: Summary, learned, out_dir: Path) -> list[Figure]:
        import matplotlib.pyplot as plt

        from aerotruth.truth.airports import airport

        figs = []
        flown = rows[~rows["diverged"].astype(bool)] if len(rows) else rows
        labels = {
            "cruise_tas_error_max_kt": "max |TAS error| in cruise (kt)",
            "cruise_xtrack_max_nm": "max cruise cross-track (nm)",
            "arrival_centreline_offset_nm": "arrival offset from centreline (nm)",
            "wind_triangle_residual_max_kt": "max |V_G - V_A - V_W| (kt)",
        }
        fig, axes = plt.subplots(2, 2, figsize=(8, 6))
        for ax, (metric, limit) in zip(axes.ravel(), ACCEPTANCE.items(), strict=False):
            x = flown[metric].to_numpy(dtype=float) if len(flown) else np.array([])
            x = np.sort(x[np.isfinite(x)])
            if len(x):  # empirical CDF: one step per leg
                ax.step(np.concatenate([[0.0], x]), np.arange(len(x) + 1) / len(x), where="post", color="C0")
            if metric != "wind_triangle_residual_max_kt" or (len(x) and x[-1] > 0.1 * limit):
                ax.axvline(limit, color="r", ls="--", label=f"limit {limit:g}")
                ax.legend(fontsize="small", loc="lower right")
            ax.set_xlabel(labels[metric])
            ax.set_ylabel("fraction of legs")
            ax.set_ylim(0, 1.02)
            ax.grid(alpha=0.3)
        fig.suptitle(f"Leg metrics of {len(flown)} flown legs ({summary.metrics['legs_diverged']} diverged)")
        fig.tight_layout()
        out_dir.save(fig, "truth_leg_metrics")
        figs.append(
            Figure(
                "truth_leg_metrics",
                "Cumulative distribution of the per-leg truth metrics, with the foundation acceptance limits",
            )
        )

        fig, ax = plt.subplots(figsize=(7, 5))
        for _, r in rows.iterrows():
            a, b = airport(r["origin"]), airport(r["destination"])
            ax.plot([a.lon, b.lon], [a.lat, b.lat], color="r" if r["diverged"] else "C0", alpha=0.6, lw=1.2)
        codes = sorted(set(rows["origin"]) | set(rows["destination"])) if len(rows) else []
        for code in codes:
            a = airport(code)
            ax.plot(a.lon, a.lat, "k.", ms=4)
            ax.annotate(code, (a.lon, a.lat), fontsize=7, xytext=(2, 2), textcoords="offset points")
        ax.set_xlabel("longitude (deg)")
        ax.set_ylabel("latitude (deg)")
        ax.set_title("Legs flown (red: diverged)")
        ax.grid(alpha=0.3)
        out_dir.save(fig, "truth_legs_map")
        figs.append(Figure("truth_legs_map", "Legs flown by the campaign, airport to airport"))
        return figs


STUDY = TruthFlights()
