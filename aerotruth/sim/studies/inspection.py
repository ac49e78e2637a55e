"""Inspection study: does each flight-inspection truth system recover an ILS's errors well
enough to pass or fail the facility correctly? (FITS paper sections I-II for AFIS and
DGPS-FIS.)

One task per approach, as in the `fits` study (same section fields, same truth from the
store, same sensors and paired draws), plus the ILS facility and the baselines:

* the facility (aerotruth.truth.ils): alignment, path angle, sensitivity errors and
  course bends; `facility_errors: fixed` injects the section's values on every approach,
  `uniform_2x_tolerance` draws alignment and path-angle error per approach uniformly over
  +-2x the category's Annex 10 tolerance (the wrong-verdict experiment). The receiver
  reads it from the true positions of the localizer and glide-slope antennas at the log
  rows, with its noise. The aircraft flies the nominal beams (aerotruth.truth.approach).
* truth systems, each giving the reference point (GNSS antenna) at the log rows:
  `truth` (the true position: the estimator's own floor), `dgps` (DGPS-FIS:
  aerotruth.sensors.dgps, with its survey offset if set), `afis` (a navigation-grade
  INS by eq. 4 horizontally and the free-inertial vertical channel with its gravity
  feedback, the AFIS filter's own model), a barometer (Gauss-Markov + white, AfisSpec), RA, TVPS and the marks at
  both runway ends through the Kalman filter and RTS smoother of aerotruth.analysis.fits.afis),
  and `waas/<ins>` for every INS of the sensors (the WAAS-aided FITS, carried between WAAS
  epochs by that INS). Antenna positions follow from the reference point by the true
  lever arms (the systems' attitude errors move them by millimetres).
* the inspection (aerotruth.analysis.fits.inspection) on each system: alignment, path angle
  and bend amplitude against the injected ones; verdicts against the true verdicts; the
  0.015/0.05 deg requirement from 10 nm (aerotruth.analysis.fits.ils_metrics).
"""

from __future__ import annotations

import datetime as dt
import math
from pathlib import Path
from typing import Literal

import numpy as np
import pandas as pd
from pydantic import Field, ValidationInfo, field_validator

from aerotruth.analysis.fits.afis import AfisSpec
from aerotruth.schema import Section
from aerotruth.sim.studies import Figure, Summary
from aerotruth.sim.studies.fits import ApproachStudy, FitsStudyConfig, planned_approach
from aerotruth.sim.tasks import Task
from aerotruth.truth.ils import TOLERANCES, IlsFacilitySpec
from aerotruth.truth.mission import MissionRun

NM = 1852.0


class MissionSection(Section):
    """An inspection mission flown once (aerotruth.truth.mission) through every truth system,
    and the real calibration tracks its profile is compared with."""

    airport: str
    runway: str
    date: dt.date
    start_hour_utc: float = Field(default=14.0, ge=0, lt=24)
    mass_kg: float = Field(default=12000.0, gt=0)
    turbulence: bool = True
    runs: list[MissionRun] = Field(min_length=1)
    compare_with: list[str] = Field(
        default_factory=list,
        description="real ADS-B calibration tracks (JSON, .gz); a relative "
        "path is taken from the campaign file's folder",
    )

    @field_validator("compare_with")
    @classmethod
    def _exist(cls, v: list[str], info: ValidationInfo) -> list[str]:
        base = (info.context or {}).get("base_dir")
        out = []
        for i, p in enumerate(v):
            path = Path(p).expanduser()
            if not path.is_absolute() and base is not None:
                path = Path(base) / path
            if not path.is_file():
                raise ValueError(f"[{i}]: no such file {str(path)!r} (a real calibration track, JSON or JSON.gz)")
            out.append(str(path.resolve()))
        return out


class InspectionConfig(FitsStudyConfig):
    """The fits study's approaches and sensors, the facility and the baseline systems."""

    facility: IlsFacilitySpec = Field(default_factory=IlsFacilitySpec, description="the ILS and its injected errors")
    facility_errors: Literal["fixed", "uniform_2x_tolerance"] = Field(
        default="fixed", description="inject the facility's values, or draw alignment and angle over +-2x the tolerance"
    )
    afis: AfisSpec = Field(default_factory=AfisSpec)
    alignment_segment_m: tuple[float, float] = Field(
        default=(1050.0, 7400.0),
        description="course averaged for the alignment: metres before the threshold (Point B to Point A)",
    )
    mission: MissionSection | None = Field(
        default=None, description="an inspection mission as it is flown (runs in order)"
    )


def _wilson(k: int, n: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a proportion k/n."""
    if n == 0:
        return float("nan"), float("nan")
    p = k / n
    d = 1 + z * z / n
    c = (p + z * z / (2 * n)) / d
    h = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / d
    return c - h, c + h


def _interp_rows(tq, t, values):
    return np.column_stack([np.interp(tq, t, values[:, i]) for i in range(values.shape[1])])


class InspectionStudy(ApproachStudy):
    """The `inspection` study (see the module docstring)."""

    name = "inspection"
    title = "ILS inspection through each truth system (AFIS, DGPS-FIS, WAAS-aided FITS)"
    Config = InspectionConfig

    def run(self, task: Task, ctx) -> pd.DataFrame:
        from aerotruth.analysis.fits.ils_metrics import (
            approach_errors,
            approach_verdict,
        )
        from aerotruth.analysis.fits.inspection import inspect_approach, verdict
        from aerotruth.sensors.inspection_log import REFERENCE_POINT, approach_logs

        section: InspectionConfig = task.params["section"]
        if task.params.get("mission"):
            return self._run_mission(task, ctx)
        planned = planned_approach(task, section, task.params["campaign_seed"])
        out = ctx.truth.approach(planned)
        label = f"{task.params['airport']}-{task.params['runway']}-{task.params['date']}-{task.params['k']}"
        head = {
            "approach": label,
            "airport": task.params["airport"],
            "runway": task.params["runway"],
            "date": task.params["date"],
        }
        if out.track is None:
            return pd.DataFrame(
                [{**head, "kind": "system", "system": "", "diverged": True, "diverge_reason": out.diverged.reason}]
            )
        track = out.track
        logs = approach_logs(track, section.sensors, lambda *n: ctx.rng("sensor", *n), label)
        t, pts = logs.t_rows, logs.points_rows
        ref = pts[REFERENCE_POINT]
        length = float(track.meta["runway_length_m"])
        # the facility: geometry of the installation flown (approach metadata), errors injected
        fspec = section.facility.model_copy(
            update={"glide_path_deg": track.meta["glide_path"]["theta_deg"], "tch_m": track.meta["glide_path"]["tch_m"]}
        )
        frng = ctx.rng("facility")
        if section.facility_errors == "uniform_2x_tolerance":
            tol = TOLERANCES[fspec.category]
            fspec = fspec.model_copy(
                update={
                    "alignment_m": float(frng.uniform(-2, 2) * tol["alignment_m"]),
                    "gp_angle_error_deg": float(frng.uniform(-2, 2) * tol["gp_angle_rel"] * fspec.glide_path_deg),
                }
            )
        facility = fspec.draw(frng, length)
        loc_pt, gs_pt = pts["loc_antenna"], pts["gs_antenna"]
        nrng = ctx.rng("ils_receiver")
        loc_ddm = facility.localizer_ddm(loc_pt[:, 0], loc_pt[:, 1]) + fspec.loc_noise_ddm * nrng.standard_normal(
            len(t)
        )
        gs_ddm = facility.glide_slope_ddm(
            gs_pt[:, 0], gs_pt[:, 1], gs_pt[:, 2]
        ) + fspec.gs_noise_ddm * nrng.standard_normal(len(t))
        truth_verdict = verdict(
            {"alignment_m": fspec.alignment_m, "gp_angle_error_deg": fspec.gp_angle_error_deg},
            fspec.category,
            fspec.glide_path_deg,
        )
        systems, rows = self._systems(track, logs, section, ctx)
        # the inspection through each
        parts = []
        w_rows = np.flatnonzero(np.abs(t - np.round(t)) < 1e-6)  # 1 Hz for the requirement
        for name, p_hat in systems.items():
            dp = p_hat - ref
            est = inspect_approach(
                loc_pt + dp, gs_pt + dp, loc_ddm, gs_ddm, facility, loc_sensitivity_rel=fspec.loc_sensitivity_rel
            )  # its path angle and bends
            est_a = self._alignment(loc_pt + dp, loc_ddm, facility, fspec, section.alignment_segment_m)
            v = verdict(
                {"alignment_m": est_a, "gp_angle_error_deg": est["gp_angle_error_deg"]},
                fspec.category,
                fspec.glide_path_deg,
            )
            errs = approach_errors(
                ref[w_rows, 0],
                p_hat[w_rows],
                ref[w_rows],
                loc_x_m=facility.loc_x_m,
                gp_x_m=facility.gp_x_m,
                gp_y_m=fspec.gp_offset_m,
            )
            req = approach_verdict(errs, 10.0)
            parts.append(
                pd.DataFrame(
                    [
                        {
                            **head,
                            "kind": "system",
                            "system": name,
                            "diverged": False,
                            "diverge_reason": "",
                            "alignment_true_m": fspec.alignment_m,
                            "alignment_est_m": est_a,
                            "alignment_err_m": est_a - fspec.alignment_m,
                            "gp_angle_true_deg": fspec.gp_angle_error_deg,
                            "gp_angle_est_deg": est["gp_angle_error_deg"],
                            "gp_angle_err_deg": est["gp_angle_error_deg"] - fspec.gp_angle_error_deg,
                            "bend_true_deg": fspec.bend_amplitude_deg,
                            "bend_est_deg": est["bend_amplitude_deg"],
                            "bend_rel_err": est["bend_amplitude_deg"] / fspec.bend_amplitude_deg - 1
                            if fspec.bend_amplitude_deg > 0
                            else float("nan"),
                            "alignment_pass_true": truth_verdict["alignment"],
                            "alignment_pass_est": v["alignment"],
                            "gp_angle_pass_true": truth_verdict["gp_angle"],
                            "gp_angle_pass_est": v["gp_angle"],
                            **{f"req_{k}": val for k, val in req.items()},
                        }
                    ]
                )
            )
            sub = errs[errs["distance_to_threshold_m"].between(0, 10 * NM)]
            parts.append(
                pd.DataFrame(
                    {
                        "approach": label,
                        "kind": "epoch",
                        "system": name,
                        "distance_to_threshold_m": sub["distance_to_threshold_m"].to_numpy(),
                        "cross_m": sub["cross_m"].to_numpy(),
                        "vertical_m": sub["vertical_m"].to_numpy(),
                        "range_loc_m": sub["range_loc_m"].to_numpy(),
                        "range_gp_m": sub["range_gp_m"].to_numpy(),
                    }
                )
            )
        return pd.concat(parts, ignore_index=True)

    def _systems(self, track, logs, section: InspectionConfig, ctx) -> tuple[dict[str, np.ndarray], pd.DataFrame]:
        """The reference point at the log rows by every truth system, and the log rows used."""
        from aerotruth.analysis.fits.afis import afis_trajectory
        from aerotruth.analysis.fits.approach_log import run_approach
        from aerotruth.analysis.fits.filter import carry_with_ins
        from aerotruth.sensors.air_data import baro_error_from_truth
        from aerotruth.sensors.ins import InsSpec, ins_positions
        from aerotruth.sensors.inspection_log import REFERENCE_POINT

        t, ref = logs.t_rows, logs.points_rows[REFERENCE_POINT]
        length = float(track.meta["runway_length_m"])
        first = next(iter(logs.logs.values()))
        rows = first[(first["event"] == "").to_numpy() | np.isfinite(first["ins_x_m"].to_numpy(float))]
        systems: dict[str, np.ndarray] = {"truth": ref}
        d = rows[["dgps_x_m", "dgps_y_m", "dgps_z_m"]].to_numpy(float)
        ok = np.isfinite(d[:, 0])
        systems["dgps"] = _interp_rows(t, t[ok], d[ok])
        delay = section.sensors.event_button.reaction_mean_s
        marks = [m[0] - delay for m in (logs.marks or [])]
        if len(marks) == 2:
            nav, _ = ins_positions(
                _Rows(t, track),
                InsSpec(grade="navigation", vertical="inertial"),
                ctx.rng("afis", "ins"),
                REFERENCE_POINT,
                true_point_m=ref,
            )
            a = section.afis
            brng = ctx.rng("afis", "baro")
            rho = np.exp(-np.diff(t, prepend=t[0]) / a.baro_tau_s)
            e = np.empty(len(t))
            e[0] = a.baro_sigma_m * brng.standard_normal()
            u = brng.standard_normal(len(t))
            for k in range(1, len(t)):  # exact Gauss-Markov recursion on the log rows
                e[k] = rho[k] * e[k - 1] + a.baro_sigma_m * math.sqrt(1 - rho[k] ** 2) * u[k]
            baro = ref[:, 2] + e + a.baro_white_m * brng.standard_normal(len(t))
            # the truth atmosphere's error, referred to the threshold
            tt = track.df["time_s"].to_numpy(float)
            k = np.clip(np.searchsorted(tt, t - 1e-9), 0, len(tt) - 1)
            atmosphere = baro_error_from_truth(track.df, k, ref[:, 0], a.baro_temperature)
            if atmosphere is not None:
                baro = baro + atmosphere
            ra = rows["ra_m"].to_numpy(float) + rows["ra_lever_arm_m"].to_numpy(float)
            tv = rows["tvps_y_m"].to_numpy(float) + rows["tvps_lever_arm_m"].to_numpy(float)
            est, _ = afis_trajectory(
                t, nav, baro, ra, tv, np.zeros(len(t)), logs.ground_speed_rows, length, a, event_times_s=marks
            )
            systems["afis"] = est
        for ins_label, log in logs.logs.items():
            r = run_approach(log, section.fits)
            ins_rows = log.loc[rows.index, ["ins_x_m", "ins_y_m", "ins_z_m"]].to_numpy(float)
            systems[f"waas/{ins_label}"] = carry_with_ins(t, r.noiseless.t_s, r.xyz_m, t, ins_rows)
        return systems, rows

    # ------------------------------------------------------------------ the mission

    def expand(self, campaign, section: InspectionConfig) -> list[Task]:
        tasks = super().expand(campaign, section)
        if section.mission is not None:
            m = section.mission
            ident = (("mission", f"{m.airport.strip().upper()}-{m.runway}-{m.date.isoformat()}"),)
            tasks.append(
                Task(
                    self.name,
                    ident,
                    params={"section": section, "campaign_seed": campaign.seed, "mission": True, "export": False},
                )
            )
        return tasks

    def cost(self, task: Task) -> float:
        return 60.0 if task.params.get("mission") else 3.0

    def _run_mission(self, task: Task, ctx) -> pd.DataFrame:
        from aerotruth import seeds
        from aerotruth.analysis.fits.ils_metrics import approach_errors
        from aerotruth.sensors.inspection_log import REFERENCE_POINT, approach_logs
        from aerotruth.truth.mission import MissionSpec
        from aerotruth.truth.weather import region_for_airport

        section: InspectionConfig = task.params["section"]
        m = section.mission
        cs = task.params["campaign_seed"]
        icao = m.airport.strip().upper()
        start = dt.datetime.combine(m.date, dt.time(0), tzinfo=dt.UTC) + dt.timedelta(hours=m.start_hour_utc)
        spec = MissionSpec(icao, m.runway, start, tuple(m.runs), m.mass_kg, m.turbulence)
        key, track, div = ctx.truth.mission(
            spec,
            weather_seed=seeds.int_seed(seeds.named_sequence(cs, "weather", m.date.isoformat())),
            flight_seed=seeds.int_seed(seeds.named_sequence(cs, "mission", icao, m.runway, m.date.isoformat())),
            region=None if section.calm else region_for_airport(icao),
        )
        label = f"{icao}-{m.runway}-{m.date.isoformat()}-mission"
        parts = [self._profile_rows("real:" + Path(f).name, _real_track(f)) for f in m.compare_with]
        if track is None:
            return pd.concat(
                parts
                + [
                    pd.DataFrame(
                        [
                            {
                                "kind": "mission_run",
                                "approach": label,
                                "system": "",
                                "diverged": True,
                                "diverge_reason": div.reason,
                            }
                        ]
                    )
                ],
                ignore_index=True,
            )
        sensors = section.sensors.model_copy(
            update={"ins": [s for s in section.sensors.ins if s.mechanization == "error_model"]}
        )
        logs = approach_logs(track, sensors, lambda *n: ctx.rng("sensor", *n), label)
        systems, _ = self._systems(track, logs, section.model_copy(update={"sensors": sensors}), ctx)
        t = logs.t_rows
        ref = logs.points_rows[REFERENCE_POINT]
        tt = track.df["time_s"].to_numpy(float)
        run_at = track.df["run"].to_numpy()[np.clip(np.searchsorted(tt, t - 1e-6), 0, len(tt) - 1)]
        g = track.meta["glide_path"]
        one_hz = np.abs(t - np.round(t)) < 1e-6
        for name, p_hat in systems.items():
            errs = approach_errors(
                ref[one_hz, 0], p_hat[one_hz], ref[one_hz], loc_x_m=g["loc_x_m"], gp_x_m=g["gp_x_m"], gp_y_m=g["gp_y_m"]
            )
            errs["run"] = run_at[one_hz]
            for k, e in errs[errs["run"] >= 0].groupby("run"):
                row = {
                    "kind": "mission_run",
                    "approach": label,
                    "system": name,
                    "diverged": False,
                    "diverge_reason": "",
                    "run": int(k),
                    "run_type": m.runs[int(k)].type,
                    "epochs": len(e),
                    "cross_rms_m": float(np.sqrt(np.mean(e["cross_m"] ** 2))),
                    "vertical_rms_m": float(np.sqrt(np.mean(e["vertical_m"] ** 2))),
                    "along_rms_m": float(np.sqrt(np.mean(e["along_m"] ** 2))),
                }
                for axis in ("cross", "vertical"):
                    for req in ("desired", "minimum"):
                        row[f"{axis}_share_{req}"] = float(e[f"{axis}_meets_{req}"].mean())
                parts.append(pd.DataFrame([row]))
        df = track.df
        sim = pd.DataFrame(
            {
                "time_s": df["time_s"].to_numpy(float),
                "altitude_ft": df["pressure_altitude_m"].to_numpy(float) / 0.3048,
                "groundspeed_kt": np.hypot(df["vn_mps"], df["ve_mps"]).to_numpy() / 0.514444,
                "vertical_rate_fpm": -df["vd_mps"].to_numpy(float) / 0.3048 * 60.0,
                "track_deg": np.degrees(np.arctan2(df["ve_mps"], df["vn_mps"])).to_numpy() % 360.0,
            }
        )
        parts.append(self._profile_rows("simulated:" + label, sim.iloc[::10].reset_index(drop=True)))
        return pd.concat(parts, ignore_index=True)

    @staticmethod
    def _profile_rows(source: str, tr: pd.DataFrame) -> pd.DataFrame:
        """1 Hz-ish profile series of a track (time from its start) for the comparison."""
        out = tr[["time_s", "altitude_ft", "groundspeed_kt", "vertical_rate_fpm", "track_deg"]].copy()
        out["time_s"] = out["time_s"] - out["time_s"].iloc[0]
        out.insert(0, "source", source)
        out.insert(0, "kind", "profile")
        return out

    @staticmethod
    def _alignment(loc_xyz, loc_ddm, facility, fspec, segment) -> float:
        """Alignment at the threshold (m, + left) from the mean course error in angle over
        the segment (metres before the threshold), each epoch's course error taken to the
        threshold by the localizer's range there: the displacement of a straight course."""
        from aerotruth.truth.ils import LOC_HALF_SECTOR_DDM, nominal

        ref = nominal(facility)
        s_loc = (1 + fspec.loc_sensitivity_rel) * LOC_HALF_SECTOR_DDM / ref.loc_half_sector_rad
        err = (np.asarray(loc_ddm) - ref.localizer_ddm(loc_xyz[:, 0], loc_xyz[:, 1])) / s_loc
        d = -loc_xyz[:, 0]
        sel = (d >= segment[0]) & (d <= segment[1])
        return float(-np.mean(err[sel]) * ref.loc_x_m) if sel.any() else float("nan")

    def summarize(self, rows: pd.DataFrame, learned, section: InspectionConfig) -> Summary:
        sysrows = rows[(rows["kind"] == "system") & ~rows["diverged"].astype(bool)] if len(rows) else rows
        n_div = (
            int(rows.loc[(rows["kind"] == "system") & rows["diverged"].astype(bool), "approach"].nunique())
            if len(rows)
            else 0
        )
        metrics: dict = {
            "approaches": int(rows.loc[rows["kind"] == "system", "approach"].nunique()) if len(rows) else 0,
            "approaches_diverged": n_div,
        }
        table, wrong = [], []
        for name, g in sysrows.groupby("system", sort=False):
            key = name.replace("/", "_")
            a95 = float(np.percentile(np.abs(g["alignment_err_m"]), 95))
            p95 = float(np.percentile(np.abs(g["gp_angle_err_deg"]), 95))
            b95 = (
                float(np.nanpercentile(np.abs(g["bend_rel_err"]), 95))
                if g["bend_rel_err"].notna().any()
                else float("nan")
            )
            metrics[f"{key}.alignment_err_p95_m"] = a95
            metrics[f"{key}.gp_angle_err_p95_deg"] = p95
            metrics[f"{key}.bend_rel_err_p95"] = b95
            row = {
                "truth system": name,
                "approaches": len(g),
                "95 % |alignment error| (m)": a95,
                "95 % |path-angle error| (deg)": p95,
                "95 % |bend amplitude error| (rel)": b95,
            }
            for axis in ("cross", "vertical"):
                for req in ("desired", "minimum"):
                    share = float(g[f"req_{axis}_meets_{req}"].astype(bool).mean())
                    metrics[f"{key}.share_meeting.{axis}.{req}"] = share
                    row[f"{axis} meets {req} (10 nm-thr)"] = share
            table.append(row)
            for param in ("alignment", "gp_angle"):
                k = int((g[f"{param}_pass_true"].astype(bool) != g[f"{param}_pass_est"].astype(bool)).sum())
                lo, hi = _wilson(k, len(g))
                metrics[f"{key}.wrong_verdict.{param}"] = k / len(g)
                wrong.append(
                    {
                        "truth system": name,
                        "parameter": param,
                        "approaches": len(g),
                        "wrong verdicts": k,
                        "rate": k / len(g),
                        "95 % low": lo,
                        "95 % high": hi,
                    }
                )
        tables = {"recovery": pd.DataFrame(table), "wrong_verdicts": pd.DataFrame(wrong)}
        self._mission_summary(rows, metrics, tables)
        return Summary(metrics, tables)

    @staticmethod
    def _mission_summary(rows: pd.DataFrame, metrics: dict, tables: dict) -> None:
        """Per run type and truth system (epoch-weighted), and the flown profile beside the real tracks."""
        mr = (
            rows[(rows["kind"] == "mission_run") & ~rows["diverged"].astype(bool)]
            if len(rows) and "kind" in rows
            else rows.iloc[0:0]
        )
        if len(mr):
            out = []
            for (rt, sysname), g in mr.groupby(["run_type", "system"], sort=False):
                w = g["epochs"].to_numpy(float)
                row = {
                    "run type": rt,
                    "truth system": sysname,
                    "runs": len(g),
                    "epochs": int(w.sum()),
                    "cross RMS (m)": float(np.sqrt(np.sum(w * g["cross_rms_m"] ** 2) / w.sum())),
                    "vertical RMS (m)": float(np.sqrt(np.sum(w * g["vertical_rms_m"] ** 2) / w.sum())),
                }
                for axis in ("cross", "vertical"):
                    for req in ("desired", "minimum"):
                        row[f"{axis} epochs meeting {req}"] = float(np.sum(w * g[f"{axis}_share_{req}"]) / w.sum())
                key = f"mission.{sysname.replace('/', '_')}.{rt}"
                metrics[f"{key}.cross_rms_m"] = row["cross RMS (m)"]
                metrics[f"{key}.vertical_rms_m"] = row["vertical RMS (m)"]
                out.append(row)
            tables["mission_by_run_type"] = pd.DataFrame(out)
        if len(mr) == 0 and len(rows) and (rows["kind"] == "mission_run").any():
            tables["mission_diverged"] = rows[rows["kind"] == "mission_run"][["approach", "diverge_reason"]]
        prof = rows[rows["kind"] == "profile"] if len(rows) and "kind" in rows else rows.iloc[0:0]
        if len(prof):
            out = []
            for src, p in prof.groupby("source", sort=False):
                segs = level_segments(p)
                alt, gs = p["altitude_ft"].to_numpy(float), p["groundspeed_kt"].to_numpy(float)
                row = {
                    "track": src,
                    "duration (min)": float(p["time_s"].max() / 60.0),
                    **{f"altitude p{q} (ft)": float(np.percentile(alt, q)) for q in (5, 50, 95)},
                    **{f"ground speed p{q} (kt)": float(np.percentile(gs, q)) for q in (5, 50, 95)},
                    "level runs": len(segs),
                    "level run median (s)": float(np.median(segs)) if len(segs) else float("nan"),
                    "share of time level": float(segs.sum() / max(p["time_s"].max(), 1.0)),
                }
                out.append(row)
                kind = "simulated" if src.startswith("simulated") else "real"
                if kind == "simulated":
                    metrics["mission.profile.altitude_p50_ft"] = row["altitude p50 (ft)"]
                    metrics["mission.profile.groundspeed_p50_kt"] = row["ground speed p50 (kt)"]
                    metrics["mission.profile.level_run_median_s"] = row["level run median (s)"]
            tables["mission_profile"] = pd.DataFrame(out)

    def figures(self, rows: pd.DataFrame, summary: Summary, learned, out_dir: Path) -> list[Figure]:
        import matplotlib.pyplot as plt

        from aerotruth.analysis.fits.ils_metrics import (
            FLOOR_HORIZONTAL_M,
            FLOOR_VERTICAL_M,
            REQUIREMENTS,
            required_error_m,
        )

        sysrows = rows[(rows["kind"] == "system") & ~rows["diverged"].astype(bool)] if len(rows) else rows
        if sysrows.empty:
            return []
        names = list(dict.fromkeys(sysrows["system"]))
        # each system's recovery error against the injected value, one y scale per row so the
        # systems compare (a plot of recovered vs injected collapses to a point when the
        # campaign injects one fixed value, and its autoscaled axes then magnify the scatter)
        fig, axes = plt.subplots(2, len(names), figsize=(3.2 * len(names), 6), squeeze=False, sharey="row")
        for i, (tcol, ecol, unit, label) in enumerate(
            (
                ("alignment_true_m", "alignment_err_m", "m", "alignment"),
                ("gp_angle_true_deg", "gp_angle_err_deg", "deg", "path angle error"),
            )
        ):
            for j, nm in enumerate(names):
                g = sysrows[sysrows["system"] == nm]
                ax = axes[i, j]
                ax.axhline(0.0, color="k", ls=":", lw=1)
                ax.plot(g[tcol], g[ecol], ".", ms=4)
                rms = float(np.sqrt(np.mean(np.square(g[ecol].to_numpy(float)))))
                ax.text(0.03, 0.95, f"RMS {rms:.3g} {unit} (n={len(g)})", transform=ax.transAxes, va="top", fontsize=8)
                ax.set(title=nm if i == 0 else "", xlabel=f"injected {label} ({unit})")
                ax.grid(alpha=0.3)
            axes[i, 0].set_ylabel(f"{label} recovery error ({unit})")
        fig.suptitle("Recovered minus injected facility error, per truth system", fontsize=11)
        fig.tight_layout()
        out_dir.save(fig, "inspection_recovery")
        figs = [
            Figure(
                "inspection_recovery",
                "Recovery error (recovered - injected) of the localizer alignment (top) and the glide-path angle "
                "error (bottom) against the injected value, per truth system",
            )
        ]
        ep = rows[rows["kind"] == "epoch"]
        fig, axes = plt.subplots(2, len(names), figsize=(3.2 * len(names), 6), squeeze=False, sharex=True)
        for j, nm in enumerate(names):
            e = ep[ep["system"] == nm]
            for i, (col, rcol, floor, lab) in enumerate(
                (
                    ("cross_m", "range_loc_m", FLOOR_HORIZONTAL_M, "cross-track"),
                    ("vertical_m", "range_gp_m", FLOOR_VERTICAL_M, "vertical"),
                )
            ):
                ax = axes[i, j]
                for _, g in e.groupby("approach"):
                    ax.plot(g["distance_to_threshold_m"] / NM, g[col], lw=0.4, alpha=0.5)
                g0 = e[e["approach"] == e["approach"].iloc[0]].sort_values("distance_to_threshold_m")
                for req, alpha in REQUIREMENTS.items():
                    r = required_error_m(g0[rcol].to_numpy(float), alpha, floor)
                    ls = "--" if req == "desired" else "-"
                    ax.plot(g0["distance_to_threshold_m"] / NM, r, "k", ls=ls, lw=1)
                    ax.plot(g0["distance_to_threshold_m"] / NM, -r, "k", ls=ls, lw=1)
                lim = max(1.0, 1.3 * float(np.percentile(np.abs(e[col]), 99))) if len(e) else 1.0
                ax.set(
                    ylim=(-lim, lim),
                    title=f"{nm}: {lab}",
                    xlabel="distance to threshold (nm)" if i else "",
                    ylabel=f"{lab} position error (m)" if j == 0 else "",
                )
                ax.grid(alpha=0.3)
        fig.tight_layout()
        out_dir.save(fig, "inspection_requirement")
        figs.append(
            Figure(
                "inspection_requirement",
                "Position error of each truth system against the 0.015 deg (dashed) and 0.05 deg requirement lines",
            )
        )
        prof = rows[rows["kind"] == "profile"]
        if len(prof):
            fig, axes = plt.subplots(1, 3, figsize=(15, 4), gridspec_kw={"width_ratios": [2.2, 1, 1]})
            for src, p in prof.groupby("source", sort=False):
                sim = src.startswith("simulated")
                axes[0].plot(
                    p["time_s"] / 60.0,
                    p["altitude_ft"],
                    lw=1.2 if sim else 0.7,
                    color="C3" if sim else None,
                    label=src.split(":", 1)[1],
                )
                axes[1].hist(
                    p["altitude_ft"],
                    bins=np.arange(0, 4001, 200),
                    histtype="step",
                    density=True,
                    lw=1.5 if sim else 0.8,
                    color="C3" if sim else None,
                )
                axes[2].hist(
                    p["groundspeed_kt"],
                    bins=np.arange(60, 260, 10),
                    histtype="step",
                    density=True,
                    lw=1.5 if sim else 0.8,
                    color="C3" if sim else None,
                )
            axes[0].set(
                xlabel="time (min)",
                ylabel="pressure altitude (ft)",
                title="Inspection mission: simulated (red) and real calibration tracks",
            )
            axes[0].legend(fontsize=7)
            axes[1].set(xlabel="pressure altitude (ft)", ylabel="density")
            axes[2].set(xlabel="ground speed (kt)")
            for ax in axes:
                ax.grid(alpha=0.3)
            fig.tight_layout()
            out_dir.save(fig, "inspection_mission_profile")
            figs.append(
                Figure(
                    "inspection_mission_profile",
                    "The flown mission's profile beside real navaid-calibration ADS-B tracks: altitude over time, "
                    "altitude and ground-speed distributions",
                )
            )
        mr = rows[(rows["kind"] == "mission_run") & ~rows["diverged"].astype(bool)]
        if len(mr):
            types = list(dict.fromkeys(mr["run_type"]))
            sysn = list(dict.fromkeys(mr["system"]))
            fig, axes = plt.subplots(1, 2, figsize=(12, 4))
            wdt = 0.8 / len(sysn)
            for i, sname in enumerate(sysn):
                for ax, col in zip(axes, ("cross_rms_m", "vertical_rms_m"), strict=False):
                    vals = [
                        float(np.sqrt(np.mean(mr[(mr["system"] == sname) & (mr["run_type"] == rt)][col] ** 2)))
                        for rt in types
                    ]
                    ax.bar(np.arange(len(types)) + i * wdt, vals, wdt, label=sname)
            for ax, lab in zip(axes, ("cross-track RMS error (m)", "vertical RMS error (m)"), strict=False):
                ax.set_xticks(np.arange(len(types)) + 0.4 - wdt / 2, types)
                ax.set(ylabel=lab)
                ax.set_yscale("log")
                ax.grid(alpha=0.3)
            axes[0].legend(fontsize=7)
            fig.tight_layout()
            out_dir.save(fig, "inspection_mission_errors")
            figs.append(
                Figure(
                    "inspection_mission_errors", "Each truth system's position error by run type over the flown mission"
                )
            )
        return figs


def _real_track(path: str) -> pd.DataFrame:
    """A real ADS-B calibration track (JSON list of records, .gz allowed): time (s), pressure
    altitude (ft), ground speed (kt), vertical rate (fpm), track (deg); airborne samples
    with all four present (ADS-B reports 0 ft on the ground)."""
    import gzip
    import json

    opener = gzip.open if str(path).endswith(".gz") else open
    with opener(path, "rt", encoding="utf-8") as f:
        d = pd.DataFrame(json.load(f))
    need = ("timestamp", "altitude", "groundspeed", "vertical_rate", "track")
    missing = [c for c in need if c not in d.columns]
    if missing:
        raise ValueError(f"{path}: not an ADS-B calibration track (missing {missing[0]!r})")
    d = d.dropna(subset=list(need))
    d = d[d["altitude"].astype(float) > 0]
    return pd.DataFrame(
        {
            "time_s": (d["timestamp"].astype(float) - float(d["timestamp"].iloc[0])) / 1000.0,
            "altitude_ft": d["altitude"].astype(float),
            "groundspeed_kt": d["groundspeed"].astype(float),
            "vertical_rate_fpm": d["vertical_rate"].astype(float),
            "track_deg": d["track"].astype(float) % 360.0,
        }
    )


def level_segments(
    p: pd.DataFrame, min_s: float = 60.0, max_vs_fpm: float = 300.0, max_turn_deg: float = 20.0
) -> np.ndarray:
    """Durations (s) of straight level runs in a profile: consecutive samples with
    |vertical rate| under max_vs_fpm and track within max_turn_deg of the segment's first,
    lasting at least min_s (the same detector for real and simulated tracks)."""
    t, vs, trk = (p[c].to_numpy(float) for c in ("time_s", "vertical_rate_fpm", "track_deg"))
    out, i, n = [], 0, len(t)
    while i < n:
        if abs(vs[i]) >= max_vs_fpm:
            i += 1
            continue
        j = i
        while (
            j + 1 < n
            and abs(vs[j + 1]) < max_vs_fpm
            and abs((trk[j + 1] - trk[i] + 180) % 360 - 180) < max_turn_deg
            and t[j + 1] - t[j] < 30.0
        ):
            j += 1
        if t[j] - t[i] >= min_s:
            out.append(t[j] - t[i])
        i = j + 1
    return np.asarray(out)


class _Rows:
    """The log rows of a track as `ins_positions` reads them (time and the true point given)."""

    def __init__(self, t: np.ndarray, track):
        self.df = pd.DataFrame({"time_s": t})
        self.meta = track.meta


STUDY = InspectionStudy()
