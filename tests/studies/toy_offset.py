"""A toy study that exercises the campaign engine the way the sensor and method studies
will: it reads the truth tracks of aircraft-days from the truth store, measures heading
with a per-aircraft bias and white noise (a sensor), learns each aircraft's mean offset
on a "before" period (a fit) and removes it from the measurements of an "after" period
(an apply), and reports the heading error.

    measured = true heading + b_aircraft + n,   b ~ N(0, bias_sigma_deg), n ~ N(0, noise_deg)

The bias of an aircraft is the same on every day (its stream is named by the aircraft);
the noise of each task comes from the task's own "sensor" stream.
"""

from __future__ import annotations

import hashlib

import numpy as np
import pandas as pd
from pydantic import Field, StrictBool

from aerotruth import seeds
from aerotruth.config import Section  # the public path a user's study imports (a re-export)
from aerotruth.sim.fleet_days import FlightSelection, aircraft_days, check_flights, day_task
from aerotruth.sim.studies import Study, Summary

SAMPLE_EVERY = 100  # every 10 s of the 10 Hz truth


class ToyConfig(Section):
    flights: FlightSelection
    before: str
    after: str
    bias_sigma_deg: float = Field(default=2.0, ge=0)
    noise_deg: float = Field(default=0.5, ge=0)
    correct: StrictBool = True


class ToyOffset(Study):
    name = "toy_offset"
    title = "Toy heading offset (engine test)"
    Config = ToyConfig
    learns = {"offset": ("before",)}

    def check(self, campaign, refs):
        cfg = campaign.section(self.name)
        check_flights(campaign, refs, cfg.flights, prefix=("flights",))
        refs.names("before", "periods")
        refs.names("after", "periods")

    def expand(self, campaign, cfg):
        tasks = []
        for stage in ("before", "after"):
            needs = ("offset",) if stage == "after" and cfg.correct else ()
            for fleet, day in aircraft_days(campaign, cfg.flights, [getattr(cfg, stage)]):
                tasks.append(
                    day_task(
                        self.name,
                        fleet,
                        day,
                        stage=stage,
                        needs=needs,
                        bias_sigma_deg=cfg.bias_sigma_deg,
                        noise_deg=cfg.noise_deg,
                    )
                )
        return tasks

    def run(self, task, ctx):
        day, p = task.params["day"], task.params
        bias = (
            p["bias_sigma_deg"]
            * seeds.generator(seeds.named_sequence(ctx.campaign_seed, "toy_bias", day.aircraft)).standard_normal()
        )
        noise_rng = ctx.rng("sensor", "heading")
        offset = ctx.learned.get("offset")
        correction = 0.0
        if offset is not None:
            row = offset[offset["aircraft"] == day.aircraft]
            correction = float(row["offset_deg"].iloc[0]) if len(row) else 0.0
        rows = []
        for out in ctx.truth.day(day):
            true = np.degrees(out.track.df["heading_rad"].to_numpy()[::SAMPLE_EVERY].astype(np.float64))
            noise = p["noise_deg"] * noise_rng.standard_normal(len(true))
            measured = true + bias + noise - correction
            err = measured - true
            rows.append(
                {
                    "aircraft": day.aircraft,
                    "flight_id": out.leg.plan.flight_id,
                    "n": len(err),
                    "mean_error_deg": float(np.mean(err)),
                    "rms_error_deg": float(np.sqrt(np.mean(err**2))),
                    "correction_deg": correction,
                    "truth_digest": hashlib.sha256(out.track.df["heading_rad"].to_numpy().tobytes()).hexdigest(),
                    "noise_digest": hashlib.sha256(noise.tobytes()).hexdigest(),
                }
            )
        return pd.DataFrame(rows)

    def fit(self, name, rows, section, rng):
        g = rows.assign(w=rows["n"] * rows["mean_error_deg"]).groupby("aircraft", sort=True)
        return pd.DataFrame({"aircraft": list(g.groups), "offset_deg": (g["w"].sum() / g["n"].sum()).to_numpy()})

    def summarize(self, rows, learned, section):
        m = {}
        for stage, g in rows.groupby("stage", sort=True):
            m[f"{stage}.rms_error_deg"] = float(np.sqrt(np.sum(g["n"] * g["rms_error_deg"] ** 2) / np.sum(g["n"])))
        table = pd.DataFrame({"stage": list(m), "RMS heading error (deg)": list(m.values())})
        return Summary(m, {"heading_error": table})


STUDY = ToyOffset()
