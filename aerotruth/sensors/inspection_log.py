"""The sensors of a WAAS-aided flight-inspection truth system on one approach's truth,
written as the approach log a user would bring from a real flight (docs/data-formats.md).

Each sensor samples its own point of the airframe (aerotruth.truth.approach.point_positions,
lever arms from the approach truth's metadata) and draws from its own named stream, so
that two INS variants of one approach share the truth, the WAAS noise, the radar
altimeter, TVPS, DGPS and the pilot's marks (paired runs):

* WAAS (aerotruth.sensors.waas) at the GNSS antenna on the whole seconds of the record,
  with its receiver flags;
* each INS (aerotruth.sensors.ins) at the GNSS antenna (the reference point), every row
  (the error model evaluated on the log rows; the strapdown integrates the 50 Hz IMU
  record and is read at the rows);
* radar altimeter at its antenna, TVPS at its camera (aerotruth.sensors.ranging), every
  row; with them the lever arms the system computes from its attitude: `ra_lever_arm_m`
  = z of the reference point minus z of the RA antenna, `tvps_lever_arm_m` = y of the
  reference point minus y of the camera (here from the true attitude: the INS attitude
  differs by ~0.03 deg, ~2 mm over these arms);
* DGPS (aerotruth.sensors.dgps) at the antenna on its 5 Hz epochs (NaN between them);
* the pilot's marks as rows of their own at the press time: `thr` when the reference
  point crosses the threshold (x = 0) plus the reaction delay, `end` at the stop end.

The runway frame, the airport's geoid undulation (heights are ellipsoidal; the frame's
origin is the threshold at runway elevation + undulation) and the glide-path geometry
come from the truth's metadata; `geometry(track)` is the log's sidecar content.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd
from pydantic import Field, field_validator

from aerotruth.contracts import APPROACH_LOG_WRITTEN
from aerotruth.schema import Section
from aerotruth.sensors.dgps import DgpsSpec
from aerotruth.sensors.ins import InsSpec, ins_positions
from aerotruth.sensors.ranging import EventButtonSpec, RadarAltimeterSpec, TvpsSpec
from aerotruth.sensors.waas import WaasErrors, WaasSpec

LOG_COLUMNS = APPROACH_LOG_WRITTEN
REFERENCE_POINT = "gnss"


def _default_ins() -> list[InsSpec]:
    return [InsSpec(grade="tactical"), InsSpec(grade="automotive")]


class InspectionSensors(Section):
    """The sensors of the WAAS-aided FITS and its DGPS reference (module docstring)."""

    log_rate_hz: float = Field(
        default=5.0, gt=0, description="log rows per second (a divisor of the 50 Hz truth, a multiple of the WAAS rate)"
    )
    waas: WaasSpec = Field(default_factory=WaasSpec)
    ins: list[InsSpec] = Field(
        default_factory=_default_ins, description="INS variants flown on the same truth and WAAS noise"
    )
    radar_altimeter: RadarAltimeterSpec = Field(default_factory=RadarAltimeterSpec)
    tvps: TvpsSpec = Field(default_factory=TvpsSpec)
    dgps: DgpsSpec = Field(default_factory=DgpsSpec)
    event_button: EventButtonSpec = Field(default_factory=EventButtonSpec)

    @field_validator("ins")
    @classmethod
    def _unique(cls, v: list[InsSpec]) -> list[InsSpec]:
        if not v:
            raise ValueError("expected at least one INS")
        labels = [s.label for s in v]
        dup = sorted({x for x in labels if labels.count(x) > 1})
        if dup:
            raise ValueError(f"INS names must be unique; {dup[0]!r} is used twice (give each a `name`)")
        return v


@dataclass
class ApproachLogs:
    """One approach through the sensors: a log per INS (same rows otherwise), the truth
    at the WAAS epochs, and the runway geometry of the log's sidecar."""

    logs: dict[str, pd.DataFrame]
    truth: pd.DataFrame  # time_s, x_m, y_m, z_m (antenna), cyclic_*_m, bias_*_m (bias + jumps)
    geometry: dict
    t_rows: np.ndarray | None = None  # the log's epochs (event rows aside)
    points_rows: dict[str, np.ndarray] | None = None  # true positions of every airframe point at t_rows
    marks: list[tuple[float, str]] | None = None  # (press time, code) of the pilot's marks
    ground_speed_rows: np.ndarray | None = None  # m/s at t_rows


def _runway_frame(track):
    from aerotruth.truth.runway import RunwayFrame

    return RunwayFrame(**track.meta["runway_frame"])


def geometry(track) -> dict:
    """The runway geometry of the log's sidecar (`<log>.runway.json`, docs/data-formats.md)."""
    meta = track.meta
    g = meta["glide_path"]
    return {
        "airport": meta["airport"],
        "runway": meta["runway"],
        "length_m": float(meta["runway_length_m"]),
        "loc_x_m": float(g["loc_x_m"]),
        "gp_x_m": float(g["gp_x_m"]),
        "gp_y_m": float(g["gp_y_m"]),
        "glide_path_deg": float(g["theta_deg"]),
        "tch_m": float(g["tch_m"]),
        "undulation_m": float(meta["undulation_m"]),
        "runway_frame": meta["runway_frame"],
    }


@dataclass
class _Rows:
    """The columns of a track the sensors read, at the log rows (df and meta, like a TruthTrack)."""

    df: pd.DataFrame
    meta: dict


def _crossing_time(t: np.ndarray, x: np.ndarray, x_cross: float) -> float | None:
    i = np.flatnonzero((x[:-1] < x_cross) & (x[1:] >= x_cross))
    if len(i) == 0:
        return None
    k = int(i[0])
    return float(t[k] + (x_cross - x[k]) / (x[k + 1] - x[k]) * (t[k + 1] - t[k]))


def approach_logs(
    track, sensors: InspectionSensors, rng: Callable[..., np.random.Generator], approach: str
) -> ApproachLogs:
    """The approach log of every INS variant (module docstring). `rng(*name)` gives the
    named stream of each consumer ("waas", ("ins", label), "radar_altimeter", ...)."""
    from aerotruth.truth.approach import point_positions

    df = track.df
    t50 = df["time_s"].to_numpy(float)
    dt = float(np.median(np.diff(t50)))
    step = int(round(1.0 / (sensors.log_rate_hz * dt)))
    per_waas = sensors.log_rate_hz / sensors.waas.rate_hz
    if abs(step * sensors.log_rate_hz * dt - 1.0) > 1e-6 or abs(per_waas - round(per_waas)) > 1e-6:
        raise ValueError(
            f"log_rate_hz: expected a divisor of the {1 / dt:g} Hz truth and a multiple of the WAAS rate "
            f"({sensors.waas.rate_hz:g} Hz), got {sensors.log_rate_hz:g}"
        )
    rows = np.arange(0, len(t50), step)
    t = np.round(t50[rows], 9)
    w_rows = np.flatnonzero(np.abs(t * sensors.waas.rate_hz - np.round(t * sensors.waas.rate_hz)) < 1e-6)
    # sensors sample the truth at the log rows (the 50 Hz IMU record only feeds the strapdown)
    need = [
        "time_s",
        "lat_deg",
        "lon_deg",
        "heading_rad",
        "pitch_rad",
        "roll_rad",
        "cg_x_m",
        "cg_y_m",
        "cg_z_m",
        "x_m",
        "y_m",
        "z_m",
        "vn_mps",
        "ve_mps",
        "vd_mps",
        "h_ellipsoid_m",
        "static_pressure_pa",  # the barometer of a baro-coupled INS
        "temperature_k",
    ]
    sub = _Rows(pd.DataFrame({c: df[c].to_numpy()[rows] for c in need if c in df.columns}), track.meta)
    pts = point_positions(sub)
    ref = pts[REFERENCE_POINT]
    n = len(rows)
    # WAAS on its epochs
    werr = WaasErrors.draw(sensors.waas, rng("waas"), t[w_rows], _runway_frame(track))
    waas = np.full((n, 3), np.nan)
    waas[w_rows] = werr.apply(ref[w_rows], t[w_rows])
    sv, iono = np.zeros(n, np.int8), np.zeros(n, np.int8)
    sv[w_rows], iono[w_rows] = werr.sv_change, werr.iono_update
    # ranging sensors at their own points, with the lever arms the system computes
    length = float(track.meta["runway_length_m"])
    ra_pt, tv_pt = pts["radar_altimeter"], pts["tvps"]
    ra = sensors.radar_altimeter.draw(rng("radar_altimeter", "bias")).apply(
        ra_pt, length, rng("radar_altimeter", "noise")
    )
    tvps = sensors.tvps.draw(rng("tvps", "bias")).apply(tv_pt, length, rng("tvps", "noise"))
    ra_lever = ref[:, 2] - ra_pt[:, 2]
    tv_lever = ref[:, 1] - tv_pt[:, 1]
    # DGPS on its epochs
    dg = sensors.dgps.draw(rng("dgps"))
    on_dgps = np.abs(t * sensors.dgps.rate_hz - np.round(t * sensors.dgps.rate_hz)) < 1e-6
    dgps = np.full((n, 3), np.nan)
    dgps[on_dgps] = dg.apply(ref[on_dgps], rng("dgps", "noise"))
    # the pilot's marks: rows of their own at the press times
    ev = rng("event_button")
    marks: list[tuple[float, str]] = []
    for code, x_cross in (("thr", 0.0), ("end", length)):
        tc = _crossing_time(t, ref[:, 0], x_cross)
        if tc is None:
            continue
        delay = max(
            0.0, sensors.event_button.reaction_mean_s + sensors.event_button.reaction_sd_s * ev.standard_normal()
        )
        if tc + delay <= t[-1]:
            marks.append((tc + delay, code))
    # rows in time order: the epochs, and each mark inserted after the epochs before it
    t_m = np.array([m[0] for m in marks])
    at = np.searchsorted(t, t_m, side="right")
    order = np.argsort(np.concatenate([np.arange(n, dtype=float), at - 0.5]), kind="stable")

    def col(values, fill=np.nan):
        v = np.asarray(values)
        return np.concatenate([v, np.full(len(marks), fill, dtype=v.dtype) if len(marks) else v[:0]])[order]

    event = np.array([""] * n + [m[1] for m in marks], dtype=object)[order]
    common = {"approach": np.full(n + len(marks), approach, dtype=object), "time_s": np.concatenate([t, t_m])[order]}
    for i, a in enumerate("xyz"):
        common[f"waas_{a}_m"] = col(waas[:, i])
    later = {
        "dgps_x_m": col(dgps[:, 0]),
        "dgps_y_m": col(dgps[:, 1]),
        "dgps_z_m": col(dgps[:, 2]),
        "ra_m": col(ra),
        "tvps_y_m": col(tvps),
        "event": event,
        "sv_change": col(sv, 0),
        "iono_update": col(iono, 0),
        "ra_lever_arm_m": col(ra_lever),
        "tvps_lever_arm_m": col(tv_lever),
    }
    logs = {}
    for spec in sensors.ins:
        if spec.mechanization == "strapdown":  # the 50 Hz increments, integrated
            p = ins_positions(track, spec, rng("ins", spec.label), REFERENCE_POINT)[0][rows]
        else:  # eq. 4 on the log rows (its white-noise sums are exact for any step)
            p = ins_positions(sub, spec, rng("ins", spec.label), REFERENCE_POINT, true_point_m=ref)[0]
        ins = {f"ins_{a}_m": col(p[:, i]) for i, a in enumerate("xyz")}
        logs[spec.label] = pd.DataFrame({**common, **ins, **later})  # LOG_COLUMNS order, then the lever arms
    truth = pd.DataFrame(
        {
            "time_s": t[w_rows],
            **{f"{a}_m": ref[w_rows, i] for i, a in enumerate("xyz")},
            **{f"cyclic_{a}_m": werr.cyclic_m[:, i] for i, a in enumerate("xyz")},
            **{f"bias_{a}_m": werr.bias_m[i] + werr.jump_m[:, i] for i, a in enumerate("xyz")},
        }
    )
    gs_rows = np.hypot(sub.df["vn_mps"].to_numpy(float), sub.df["ve_mps"].to_numpy(float))
    return ApproachLogs(logs, truth, geometry(track), t, pts, marks, gs_rows)
