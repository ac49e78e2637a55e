"""FITS study: the WAAS-aided flight-inspection truth system of the FITS paper on JSBSim
approaches, scored against the truth and the ILS accuracy requirement (0.015 deg desired,
0.05 deg minimum; aerotruth.analysis.fits.ils_metrics).

One task per approach: runway x date x k. Its truth (a coupled ILS approach flown by the
SAAB 340 with the AFIS level pass, aerotruth.truth.approach) comes from the truth store
(flown once: changing a sensor or the filter never re-flies); the day's truth
atmosphere is the campaign's for that date (the same weather seed as every flight study),
turbulence on by default. The sensors (aerotruth.sensors.inspection_log) write the
approach log of each INS variant; every variant of an approach shares its truth, WAAS
noise, RA, TVPS, DGPS and pilot marks (paired draws: only the INS differs), so the
equivalence test of section VI compares like with like. The FITS runs on the log exactly
as `aerotruth fits` does (aerotruth.analysis.fits.approach_log.run_approach).

Rows: `kind = approach` (one per approach and INS: residual and bias summaries, verdicts;
or the divergence), `kind = epoch` (one per WAAS epoch and INS: residual, errors, angular
view), `kind = segment` (one per segment between flagged jumps and INS: the truth's bias
and the applied bias there, aerotruth.analysis.fits.scoring.segment_rows), `kind = log`
(the approach logs of the first `export_logs` approaches, exported to
RUN_DIR/data/fits.approach_log.parquet/.csv with the runway geometry beside them).
"""

from __future__ import annotations

import datetime as dt
import json
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
from pydantic import Field, model_validator

from aerotruth import seeds
from aerotruth.analysis.fits.filter import FitsSpec, noise_floor_rms
from aerotruth.schema import Section
from aerotruth.sensors.inspection_log import LOG_COLUMNS, InspectionSensors
from aerotruth.sim.campaign_file import Campaign, References
from aerotruth.sim.studies import Figure, Study, Summary
from aerotruth.sim.tasks import Task

AXES = ("x", "y", "z")
AXIS_NAMES = {"x": "along-track", "y": "cross-track", "z": "vertical"}
DIST_EDGES_NM = (0.0, 1.0, 2.0, 4.0, 6.0, 8.0, 10.0)


class RunwayRef(Section):
    airport: str = Field(description="ICAO code")
    runway: str = Field(description="runway end, e.g. 27 or 30L")


class EquivalenceTest(Section):
    """A TOST between two INS variants of the sensors (paired approaches), per channel;
    the margin derived from the requirement unless given (aerotruth.analysis.fits.scoring:
    the share of the requirement's floor the 95 % error may move by)."""

    a: str
    b: str
    margin_m: float | None = Field(
        default=None,
        gt=0,
        description="equivalence margin on the per-approach residual RMS (m), every channel; "
        "default: derived from the requirement with `requirement_share`",
    )
    requirement_share: float = Field(
        default=0.1,
        gt=0,
        le=1,
        description="the share of the requirement's floor (1 ft vertical, 2 ft horizontal) an "
        "equivalent INS may move the FITS error's 95 % bound by",
    )
    expect: Literal["equivalent", "different"] = Field(
        default="equivalent",
        description="what the pair is: a claim of equivalence, or a negative control the test must "
        "not call equivalent in at least one channel (`expect_met` of the pair in the metrics)",
    )
    alpha: float = Field(default=0.05, gt=0, lt=0.5)

    def margins(self) -> dict[str, float]:
        """The margin (m) of each channel: all, horizontal, vertical."""
        from aerotruth.analysis.fits.scoring import requirement_margins

        if self.margin_m is not None:
            return dict.fromkeys(("all", "horizontal", "vertical"), self.margin_m)
        return requirement_margins(self.requirement_share)


class FitsStudyConfig(Section):
    """Approaches, their sensors, the FITS settings and the scoring."""

    runways: list[RunwayRef] = Field(min_length=1)
    periods: list[str] = Field(min_length=1, description="campaign periods whose dates are flown")
    approaches_per_day: int = Field(
        default=1, ge=1, le=72, description="per runway and date, 20 min apart (at most 72: one day)"
    )
    start_hour_utc: float = Field(default=15.0, ge=0, lt=24)
    turbulence: bool = Field(
        default=True,
        description="MIL-F-8785C turbulence on the approach: patches of the route legs' "
        "severity climatology, near the ground 0.1 x the day's wind at 20 ft "
        "(aerotruth.truth.turbulence.Mil8785Gusts)",
    )
    calm: bool = Field(default=False, description="no truth atmosphere (still air), for clean checks")
    mass_kg: tuple[float, float] = Field(
        default=(10500.0, 12900.0), description="landing mass drawn uniformly per approach"
    )
    offset_nm: float = Field(
        default=0.0, ge=0, le=3, description="start this far beside the centreline (side drawn per approach) ..."
    )
    intercept_deg: float = Field(
        default=0.0, ge=0, le=45, description="... heading this far off the course: a turn onto final"
    )
    sensors: InspectionSensors = Field(default_factory=InspectionSensors)
    fits: FitsSpec = Field(default_factory=FitsSpec)
    from_nm: float = Field(default=10.0, gt=0, description="requirement scored from this distance to the threshold")
    export_logs: int = Field(
        default=2, ge=0, le=100_000, description="approach logs of the first N approaches exported"
    )
    equivalence: list[EquivalenceTest] = Field(default_factory=list)

    @model_validator(mode="after")
    def _names(self) -> FitsStudyConfig:
        labels = [s.label for s in self.sensors.ins]
        for e in self.equivalence:
            for v in (e.a, e.b):
                if v not in labels:
                    raise ValueError(f"equivalence: {v!r} is not an INS of sensors.ins ({', '.join(labels)})")
        if not self.mass_kg[0] <= self.mass_kg[1]:
            raise ValueError(f"mass_kg: expected (low, high), got {self.mass_kg}")
        return self


def planned_approach(task: Task, section: FitsStudyConfig, campaign_seed: int):
    from aerotruth.truth.approach import PlannedApproach, approach_spec
    from aerotruth.truth.weather import region_for_airport

    p = task.params
    date = dt.date.fromisoformat(p["date"])
    k = p["k"]
    start = dt.datetime.combine(date, dt.time(0), tzinfo=dt.UTC) + dt.timedelta(
        hours=section.start_hour_utc, minutes=20 * k
    )
    mass_rng = seeds.generator(
        seeds.named_sequence(campaign_seed, "approach", p["airport"], p["runway"], p["date"], k, "mass")
    )
    mass = float(mass_rng.uniform(*section.mass_kg))
    side = 1.0 if mass_rng.random() < 0.5 else -1.0
    spec = approach_spec(
        p["airport"],
        p["runway"],
        start,
        turbulence=section.turbulence,
        mass_kg=mass,
        offset_nm=side * section.offset_nm,
        intercept_deg=section.intercept_deg,
    )
    return PlannedApproach(
        spec,
        weather_seed=seeds.int_seed(seeds.named_sequence(campaign_seed, "weather", date.isoformat())),
        flight_seed=seeds.int_seed(
            seeds.named_sequence(campaign_seed, "approach", p["airport"], p["runway"], p["date"], k)
        ),
        region=None if section.calm else region_for_airport(p["airport"]),
    )


def _channel_rms(appr: pd.DataFrame) -> dict[str, pd.Series]:
    """Per-approach RMS of N_hat - N: all three axes, horizontal (x, y) and vertical."""
    x, y, z = (appr[f"resid_rms_{a}_m"] for a in AXES)
    return {"all": appr["resid_rms_m"], "horizontal": np.sqrt((x**2 + y**2) / 2.0), "vertical": z}


def _versus_paper(metrics: dict, section: FitsStudyConfig, tost_rows: list[dict]) -> pd.DataFrame:
    """Each claim the FITS paper states in words beside this run's number (docs/fits-paper.md)."""

    def f(key: str, fmt: str = "{:.1%}") -> str:
        v = metrics.get(key)
        return "n/a" if v is None else fmt.format(v)

    rows = []
    nm = "{:g} nm"
    rows.append(
        {
            "claim": "Figs. 3/4: the WAAS alone fails the minimum (0.05 deg) requirement within",
            "paper": "2 nm (its WAAS assumed 3 ft horizontal, 6 ft vertical, 95 %)",
            "aerotruth": f"vertical {f('waas_alone.fails_within_nm.vertical.minimum', nm)}, cross-track "
            f"{f('waas_alone.fails_within_nm.cross.minimum', nm)} (simulated WAAS); with the paper's assumption "
            f"{f('waas_alone_paper_assumption.fails_within_nm.vertical.minimum', nm)} / "
            f"{f('waas_alone_paper_assumption.fails_within_nm.cross.minimum', nm)}",
        }
    )
    for s in section.sensors.ins:
        v = s.label
        rows.append(
            {
                "claim": f"Fig. 14: cyclic-noise residual under 0.1 m ({v})",
                "paper": "most of the time",
                "aerotruth": ", ".join(f"{a} {f(f'{v}.resid_share_lt_0p1.{a}')}" for a in AXES) + " of interior epochs",
            }
        )
    for s in section.sensors.ins:
        v = s.label
        paper = "about 50 %" if s.vertical == "baro" else "as good as the horizontal (no barometer)"
        rows.append(
            {
                "claim": f"Fig. 16: vertical noise against DGPS improved ({v}, vertical {s.vertical})",
                "paper": paper,
                "aerotruth": f"{f(f'{v}.dgps_noise_improvement.z')} (horizontal {f(f'{v}.dgps_noise_improvement.y')})",
            }
        )
    if section.fits.cross_track_fix == "none":
        v = section.sensors.ins[0].label
        rows.append(
            {
                "claim": f"Fig. 15: cross-track biases against DGPS beyond 2 sigma of the WAAS ({v})",
                "paper": "larger than 2 sigma (a DGPS reference offset suspected)",
                "aerotruth": f"{f(f'{v}.dgps_bias_beyond_2sigma_share.y')} of approaches, mean "
                f"{f(f'{v}.dgps_bias_mean_m.y', '{:+.2f} m')}",
            }
        )
    for t in tost_rows:
        if t["expect"] == "equivalent" and t["channel"] == "all":
            rows.append(
                {
                    "claim": f"Figs. 19/20, section VI: {t['a']} against {t['b']}",
                    "paper": "hard to find any difference",
                    "aerotruth": f"residual RMS differs by {1000 * t['mean_diff_m']:+.1f} mm, "
                    f"{'equivalent' if t['equivalent'] else 'not shown equivalent'} within "
                    f"{1000 * t['margin (m)']:.1f} mm (TOST)",
                }
            )
    return pd.DataFrame(rows)


class ApproachStudy(Study):
    """A study whose tasks are ILS approaches flown by the campaign's aircraft: one task per
    (runway, day of its periods, approach of the day), the first `export_logs` of them
    exporting their approach log. The fits and inspection studies are both."""

    def check(self, campaign: Campaign, refs: References) -> None:
        from aerotruth.truth.approach import find_runway

        section = campaign.section(self.name)
        refs.names(("periods",), "periods")
        for i, r in enumerate(section.runways):
            try:
                find_runway(r.airport.strip().upper(), r.runway)
            except ValueError as e:
                raise refs.error(("runways", i), str(e)) from None

    def expand(self, campaign: Campaign, section: FitsStudyConfig) -> list[Task]:
        tasks = []
        for r in section.runways:
            for date in campaign.days(section.periods):
                for k in range(section.approaches_per_day):
                    ident = (
                        ("airport", r.airport.strip().upper()),
                        ("runway", r.runway),
                        ("date", date.isoformat()),
                        ("k", k),
                    )
                    tasks.append(
                        Task(
                            self.name, ident, params={**dict(ident), "section": section, "campaign_seed": campaign.seed}
                        )
                    )
        for i, t in enumerate(tasks):
            t.params["export"] = i < section.export_logs
        return tasks

    def cost(self, task: Task) -> float:
        return 3.0


class FitsStudy(ApproachStudy):
    """The `fits` study (see the module docstring)."""

    name = "fits"
    title = "WAAS-aided flight-inspection truth system (FITS paper)"
    Config = FitsStudyConfig

    def run(self, task: Task, ctx) -> pd.DataFrame:
        from aerotruth.analysis.fits.approach_log import run_approach
        from aerotruth.analysis.fits.filter import period_samples
        from aerotruth.analysis.fits.scoring import (
            approach_summary,
            dgps_noise,
            epoch_rows,
            segment_rows,
            waas_at_epochs,
        )
        from aerotruth.sensors.inspection_log import approach_logs
        from aerotruth.truth.approach import approach_metrics

        section: FitsStudyConfig = task.params["section"]
        planned = planned_approach(task, section, task.params["campaign_seed"])
        out = ctx.truth.approach(planned)
        label = f"{task.params['airport']}-{task.params['runway']}-{task.params['date']}-{task.params['k']}"
        head = {
            "approach": label,
            "airport": task.params["airport"],
            "runway": task.params["runway"],
            "date": task.params["date"],
            "k": task.params["k"],
            "mass_kg": planned.spec.mass_kg,
            "truth_key": out.key,
        }
        if out.track is None:
            return pd.DataFrame(
                [{**head, "kind": "approach", "ins": "", "diverged": True, "diverge_reason": out.diverged.reason}]
            )
        flight = approach_metrics(out.track)
        logs = approach_logs(out.track, section.sensors, lambda *n: ctx.rng("sensor", *n), label)
        parts = []
        for ins_label, log in logs.logs.items():
            result = run_approach(log, section.fits)
            T = period_samples(result.noiseless.t_s, section.fits.period_s)
            waas = waas_at_epochs(log)
            ep = epoch_rows(result, logs.truth, logs.geometry, waas, T)
            seg = segment_rows(result, logs.truth)
            summ = approach_summary(ep, result.bias_m, seg, section.from_nm)
            summ.update(dgps_noise(result, log, ep, section.from_nm, waas))
            parts.append(
                pd.DataFrame(
                    [
                        {
                            **head,
                            "kind": "approach",
                            "ins": ins_label,
                            "diverged": False,
                            "diverge_reason": "",
                            "jumps_flagged": int(len(result.noiseless.jump_idx)),
                            **summ,
                            **{f"flight_{k}": v for k, v in flight.items()},
                        }
                    ]
                )
            )
            parts.append(ep.assign(kind="epoch", ins=ins_label, approach=label))
            parts.append(seg.assign(kind="segment", ins=ins_label, approach=label))
            if task.params["export"]:
                parts.append(
                    log.assign(
                        kind="log",
                        ins=ins_label,
                        approach=f"{label}/{ins_label}",
                        geometry=json.dumps(logs.geometry, sort_keys=True),
                    )
                )
        return pd.concat(parts, ignore_index=True)

    # ------------------------------------------------------------------ summary

    def summarize(self, rows: pd.DataFrame, learned, section: FitsStudyConfig) -> Summary:
        from aerotruth.analysis.fits.ils_metrics import REQUIREMENTS
        from aerotruth.analysis.fits.scoring import tost_paired

        appr = rows[rows["kind"] == "approach"] if len(rows) else rows
        ok = appr[~appr["diverged"].astype(bool)] if len(appr) else appr
        ep = rows[rows["kind"] == "epoch"] if len(rows) else rows
        sg = rows[rows["kind"] == "segment"] if len(rows) else rows
        if len(sg):
            sg = sg[sg["approach"].isin(ok["approach"])]
        w = section.sensors.waas
        T = int(round(w.cyclic_period_s * w.rate_hz))
        floor = noise_floor_rms(T, w.white_sigma_m, w.gm_sigma_m, w.gm_tau_s, 1.0 / w.rate_hz)
        n_appr = int(appr["approach"].nunique()) if len(appr) else 0
        n_div = int(appr.loc[appr["diverged"].astype(bool), "approach"].nunique()) if len(appr) else 0
        metrics: dict = {"approaches": n_appr, "approaches_diverged": n_div, "noise_floor_rms_m": floor}
        per_ins, per_dist = [], []
        for s in section.sensors.ins:
            v = s.label
            a = ok[ok["ins"] == v]
            e = ep[
                (ep["ins"] == v)
                & (ep["distance_to_threshold_m"] >= 0)
                & (ep["distance_to_threshold_m"] <= section.from_nm * 1852.0)
            ]
            inner = ep[(ep["ins"] == v) & ~ep["edge"].astype(bool)]
            edge = ep[(ep["ins"] == v) & ep["edge"].astype(bool)]
            row = {
                "INS": v,
                "grade": s.grade,
                "mechanization": s.mechanization,
                "time tag error (s)": s.time_tag_error_s,
                "approaches": len(a),
            }
            for ax in AXES:
                r_in = inner[f"resid_{ax}_m"].to_numpy(float)
                r_ed = edge[f"resid_{ax}_m"].to_numpy(float)
                share = float(np.mean(np.abs(r_in) < 0.1)) if len(r_in) else None
                metrics[f"{v}.resid_share_lt_0p1.{ax}"] = share
                metrics[f"{v}.edge_resid_share_lt_0p1.{ax}"] = float(np.mean(np.abs(r_ed) < 0.1)) if len(r_ed) else None
                rms = float(np.sqrt(np.mean(r_in**2))) if len(r_in) else None
                metrics[f"{v}.resid_rms_m.{ax}"] = rms
                metrics[f"{v}.resid_rms_over_floor.{ax}"] = rms / floor if rms is not None and floor > 0 else None
                metrics[f"{v}.removed_share.{ax}"] = float(a[f"removed_share_{ax}"].mean()) if len(a) else None
                # over every segment between flagged jumps of every approach (scoring.segment_rows)
                b = sg.loc[sg["ins"] == v, f"bias_err_{ax}_m"].to_numpy(float) if len(sg) else np.array([])
                metrics[f"{v}.bias_err_rms_m.{ax}"] = float(np.sqrt(np.mean(b**2))) if len(b) else None
                metrics[f"{v}.bias_err_threshold_rms_m.{ax}"] = (
                    float(np.sqrt(np.mean(a[f"bias_err_{ax}_m"] ** 2))) if len(a) else None
                )
                row[f"|r| < 0.1 m {ax} (inner)"] = share
                row[f"|r| < 0.1 m {ax} (edges)"] = metrics[f"{v}.edge_resid_share_lt_0p1.{ax}"]
                row[f"RMS r {ax} (m)"] = rms
            for ax in AXES:
                # the flight test's measure (section V): noise of X - DGPS, the FITS against the raw WAAS
                if len(a) and f"dgps_noise_fits_{ax}_m" in a:
                    w_rms = float(np.sqrt(np.nanmean(a[f"dgps_noise_waas_{ax}_m"].to_numpy(float) ** 2)))
                    f_rms = float(np.sqrt(np.nanmean(a[f"dgps_noise_fits_{ax}_m"].to_numpy(float) ** 2)))
                    metrics[f"{v}.dgps_noise_waas_m.{ax}"] = w_rms
                    metrics[f"{v}.dgps_noise_fits_m.{ax}"] = f_rms
                    metrics[f"{v}.dgps_noise_improvement.{ax}"] = 1.0 - f_rms / w_rms if w_rms > 0 else None
                    row[f"noise improvement vs DGPS {ax}"] = metrics[f"{v}.dgps_noise_improvement.{ax}"]
                    # Figs. 15/16: the bias against DGPS per approach, against 2 sigma of the WAAS's bias
                    b = a[f"dgps_bias_{ax}_m"].to_numpy(float)
                    b = b[np.isfinite(b)]
                    two_sigma = 2 * (w.bias_sigma_vertical_m if ax == "z" else w.bias_sigma_horizontal_m)
                    if len(b):
                        metrics[f"{v}.dgps_bias_mean_m.{ax}"] = float(b.mean())
                        metrics[f"{v}.dgps_bias_rms_m.{ax}"] = float(np.sqrt(np.mean(b**2)))
                        metrics[f"{v}.dgps_bias_beyond_2sigma_share.{ax}"] = float(np.mean(np.abs(b) > two_sigma))
            for col, name in (("along_m", "along"), ("cross_m", "cross"), ("vertical_m", "vertical")):
                x = np.abs(e[col].to_numpy(float))
                metrics[f"{v}.error_p95_m.{name}"] = float(np.percentile(x, 95)) if len(x) else None
            for axis in ("cross", "vertical"):
                for req in REQUIREMENTS:
                    col = f"verdict_{axis}_meets_{req}"
                    share = float(a[col].astype(bool).mean()) if len(a) else None
                    metrics[f"{v}.share_meeting.{axis}.{req}"] = share
                    row[f"{axis} meets {req}"] = share
            per_ins.append(row)
            if len(e):
                d_nm = e["distance_to_threshold_m"].to_numpy(float) / 1852.0
                for lo, hi in zip(DIST_EDGES_NM[:-1], DIST_EDGES_NM[1:], strict=False):
                    sel = (d_nm >= lo) & (d_nm < hi)
                    if sel.any():
                        per_dist.append(
                            {
                                "INS": v,
                                "from (nm)": lo,
                                "to (nm)": hi,
                                "epochs": int(sel.sum()),
                                "95 % |cross| (m)": float(np.percentile(np.abs(e["cross_m"].to_numpy(float)[sel]), 95)),
                                "95 % |vertical| (m)": float(
                                    np.percentile(np.abs(e["vertical_m"].to_numpy(float)[sel]), 95)
                                ),
                                "95 % |cross| (deg)": float(
                                    np.percentile(np.abs(e["cross_deg"].to_numpy(float)[sel]), 95)
                                ),
                                "95 % |vertical| (deg)": float(
                                    np.percentile(np.abs(e["vertical_deg"].to_numpy(float)[sel]), 95)
                                ),
                            }
                        )
        tost_rows = []
        for t in section.equivalence:
            margins = t.margins()
            pair = []
            for channel, rms in _channel_rms(ok).items():
                pa = rms[ok["ins"] == t.a].set_axis(ok.loc[ok["ins"] == t.a, "approach"])
                pb = rms[ok["ins"] == t.b].set_axis(ok.loc[ok["ins"] == t.b, "approach"])
                common = pa.index.intersection(pb.index)
                res = tost_paired(pa.loc[common].to_numpy(), pb.loc[common].to_numpy(), margins[channel], t.alpha)
                key = f"tost.{t.a}_vs_{t.b}.{channel}"
                metrics.update({f"{key}.{k}": float(v) for k, v in res.items()})  # equivalent: 1.0 / 0.0
                metrics[f"{key}.margin_m"] = margins[channel]
                pair.append(
                    {"a": t.a, "b": t.b, "expect": t.expect, "channel": channel, "margin (m)": margins[channel], **res}
                )
            # the pair's verdict: a claim holds when every channel is equivalent, a negative
            # control is refused when one channel is not (the requirement cares about each)
            equivalent = all(r["equivalent"] for r in pair)
            met = equivalent if t.expect == "equivalent" else not equivalent
            metrics[f"tost.{t.a}_vs_{t.b}.expect_met"] = float(met)
            tost_rows += [{**r, "pair as expected": met} for r in pair]
        tables = {"by_ins": pd.DataFrame(per_ins)}
        # FITS paper Figs. 3/4: the WAAS alone against the requirement (one INS's epochs: the WAAS is shared)
        if len(ep):
            from aerotruth.analysis.fits.ils_metrics import (
                PAPER_WAAS_95_M,
                fails_within_nm,
                waas_alone_by_distance,
            )

            first = section.sensors.ins[0].label
            e0 = ep[(ep["ins"] == first) & ep["approach"].isin(ok["approach"])]
            alone = waas_alone_by_distance(e0, section.from_nm)
            if len(alone):
                tables["waas_alone_by_distance"] = alone
                for axis in ("cross", "vertical"):
                    for req in REQUIREMENTS:
                        metrics[f"waas_alone.fails_within_nm.{axis}.{req}"] = fails_within_nm(alone, axis, req)
                        metrics[f"waas_alone_paper_assumption.fails_within_nm.{axis}.{req}"] = fails_within_nm(
                            alone, axis, req, PAPER_WAAS_95_M[axis]
                        )
        if per_dist:
            tables["error_by_distance"] = pd.DataFrame(per_dist)
        if tost_rows:
            tables["equivalence"] = pd.DataFrame(tost_rows)
        if len(ok):
            tables["versus_paper"] = _versus_paper(metrics, section, tost_rows)
        fl = ok.drop_duplicates("approach") if len(ok) else ok
        if len(fl):
            tables["approaches"] = fl[
                [
                    "approach",
                    "mass_kg",
                    "flight_stabilised",
                    "flight_loc_dots_1000ft",
                    "flight_gs_dots_1000ft",
                    "flight_height_over_threshold_ft",
                    "flight_cas_threshold_kt",
                    "jumps_flagged",
                ]
            ].reset_index(drop=True)
            metrics["stabilised_share"] = float(fl["flight_stabilised"].mean())
        if n_div:
            tables["diverged"] = appr[appr["diverged"].astype(bool)][["approach", "diverge_reason"]].reset_index(
                drop=True
            )
        exports = {}
        logs = rows[rows["kind"] == "log"] if len(rows) else rows
        if len(logs):
            extra = [
                c for c in logs.columns if c not in LOG_COLUMNS and c in ("ra_lever_arm_m", "tvps_lever_arm_m", "ins")
            ]
            log = logs[list(LOG_COLUMNS) + extra].reset_index(drop=True)
            geo = {a: json.loads(g) for a, g in logs.groupby("approach", sort=False)["geometry"].first().items()}
            text = json.dumps({"approaches": geo}, indent=1, sort_keys=True)
            log.attrs["sidecars"] = {"runway.json": text + "\n"}
            log.attrs["parquet_metadata"] = {"runway": text}
            exports["approach_log"] = log
        return Summary(metrics, tables, exports)

    # ------------------------------------------------------------------ figures

    def figures(self, rows: pd.DataFrame, summary: Summary, learned, out_dir: Path) -> list[Figure]:
        from aerotruth.sim.studies import fits_figures

        return fits_figures.draw(rows, summary, out_dir)


STUDY = FitsStudy()
