"""A flight-inspection mission as it is flown: many runs about one ILS, not one approach.

The real navaid-calibration tracks in ../shared/real-data/calibration (ADS-B; e.g.
Brussels: 2.5 h of level runs at ~1,300 and ~2,200 ft along and across the localizer,
arcs, approaches to ~400 ft with go-arounds) set the run types; a mission is their list
in order (campaign YAML), flown by the same JSBSim SAAB 340 and autopilot XML as the
approaches (aerotruth.truth.approach: its initial condition, recorded loop and glide
path). Geometry is the runway frame (x along the approach course, y left, z up, m).

Run types (`MissionRun.type`):
* `level_run` — inbound along the localizer course from `from_nm` to `to_nm` before the
  threshold at `height_ft` (course structure);
* `arc` — an arc of `radius_nm` about the localizer antenna from `from_deg` to `to_deg`
  off the course line (+ left) at `height_ft`, flown as 5-deg chords (coverage, width);
* `crossing` — straight across the course at `at_nm` before the threshold, `half_width_nm`
  either side, at `height_ft` (displacement sensitivity);
* `approach` — the coupled ILS from `from_nm` (level at `height_ft` until the glide path
  is captured), gear and flaps as on an approach, go-around at `decision_height_ft`;
* `low_pass` — the same approach continued to a level pass at `pass_height_ft` over the
  runway (the AFIS runway update: radar altimeter, TVPS, marks at both ends), then climb.

Between runs the guidance positions the aircraft as a crew would for the next run: direct
to a base point 2.5 nm to the side of a lead-in point 3 nm before the run's first point,
then to the lead-in point and onto the run (a squared-off teardrop), climbing or
descending to the run's height at up to 1,500 fpm. Turns are anticipated by the turn
radius at 25 deg of bank. Runs are flown at `ias_kt` (clean; flaps 15 in a lead-in to an
approach); approaches keep the approach schedule (Vapp below 2,000 ft).

Recording at 10 Hz: the route columns, the CG and its runway-frame position, `run`
(index into the mission's runs, -1 while positioning) and `run_type`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime
from typing import TYPE_CHECKING, Literal

import numpy as np
from pydantic import Field

from aerotruth.schema import Section
from aerotruth.truth.airframes import Airframe
from aerotruth.truth.approach import (
    DEFAULT_POINTS_M,
    ApproachSchedule,
    GlidePath,
    add_frame_columns,
    engage,
    fly_loop,
    frame_meta,
    ils_setup,
    initial_conditions,
)
from aerotruth.truth.fdm import FlightDiverged, params_digest, seed_repr
from aerotruth.truth.guidance import GreatCircleLeg
from aerotruth.truth.ils import IlsFacilitySpec
from aerotruth.truth.runway import RunwayFrame
from aerotruth.truth.track import TruthTrack
from aerotruth.truth.turbulence import TurbulencePatches
from aerotruth.truth.weather import Atmosphere
from aerotruth.units import DEG, FT, G0, NM

if TYPE_CHECKING:
    import jsbsim

RATE_HZ = 10
RUN_TYPES = ("level_run", "arc", "crossing", "approach", "low_pass")
BANK_DEG = 25.0


class MissionRun(Section):
    """One run of an inspection mission (module docstring)."""

    type: Literal["level_run", "arc", "crossing", "approach", "low_pass"]
    height_ft: float = Field(
        default=2200.0, gt=300, lt=10000, description="above the threshold (approaches: before the glide path)"
    )
    from_nm: float = Field(default=15.0, gt=0, le=30, description="level run / approach start, before the threshold")
    to_nm: float = Field(default=2.0, ge=0, description="level run end, before the threshold")
    radius_nm: float = Field(default=10.0, gt=1, le=25, description="arc radius about the localizer antenna")
    from_deg: float = Field(default=-35.0, ge=-90, le=90)
    to_deg: float = Field(default=35.0, ge=-90, le=90)
    at_nm: float = Field(default=6.0, gt=0, le=20, description="crossing distance before the threshold")
    half_width_nm: float = Field(default=2.5, gt=0, le=8)
    decision_height_ft: float = Field(default=400.0, gt=100, description="approach: go-around height")
    pass_height_ft: float = Field(default=100.0, gt=30, lt=500, description="low pass height over the runway")
    ias_kt: float = Field(default=170.0, gt=110, lt=230, description="speed of level runs, arcs and crossings")


@dataclass(frozen=True)
class MissionSpec:
    airport: str
    runway: str
    start_utc: datetime
    runs: tuple[MissionRun, ...]
    mass_kg: float = 12000.0
    turbulence: bool = False
    ils: IlsFacilitySpec = field(default_factory=IlsFacilitySpec)
    points_m: dict[str, tuple[float, float, float]] = field(default_factory=lambda: dict(DEFAULT_POINTS_M))

    def __post_init__(self) -> None:
        if not self.runs:
            raise ValueError("runs: expected at least one run")


def run_path(run: MissionRun, gp: GlidePath, length_m: float) -> list[tuple[float, float]]:
    """Runway-frame waypoints (m) of a run's lateral path."""
    if run.type == "level_run":
        if not run.from_nm > run.to_nm:
            raise ValueError(f"level_run: from_nm ({run.from_nm}) must exceed to_nm ({run.to_nm})")
        return [(-run.from_nm * NM, 0.0), (-run.to_nm * NM, 0.0)]
    if run.type == "arc":
        n = max(2, int(abs(run.to_deg - run.from_deg) / 5.0) + 1)
        a = np.radians(np.linspace(run.from_deg, run.to_deg, n))
        r = run.radius_nm * NM
        return [(gp.loc_x - r * math.cos(v), r * math.sin(v)) for v in a]
    if run.type == "crossing":
        w = run.half_width_nm * NM
        return [(-run.at_nm * NM, w), (-run.at_nm * NM, -w)]
    # approach / low pass: the centreline through the runway and 2 nm beyond
    return [(-run.from_nm * NM, 0.0), (length_m + 2.0 * NM, 0.0)]


class _MissionGuide:
    """1 Hz guidance through the runs (module docstring)."""

    def __init__(
        self, fdm, spec: MissionSpec, gp: GlidePath, frame: RunwayFrame, length_m: float, sched: ApproachSchedule
    ):
        self.fdm, self.spec, self.gp, self.frame, self.length = fdm, spec, gp, frame, length_m
        self.sched = sched
        self.vapp = sched.vref_kt(spec.mass_kg) + sched.additive_kt
        self.run_k = 0
        self.legs: list[tuple[tuple[float, float], tuple[float, float], str]] = []
        self.leg_i = 0
        self.mode = "run"
        self.events: dict[str, list[float]] = {"run_start_s": [], "run_end_s": []}
        self.done = False
        pm = fdm.get_property_manager()
        self._pm = pm
        self._nodes: dict[str, jsbsim.FGPropertyNode] = {}
        self.current_run = -1
        self.vmode = "level"

    def _set(self, prop: str, value: float) -> None:
        node = self._nodes.get(prop)
        if node is None:
            node = self._nodes[prop] = self._pm.get_node(prop)
        node.set_double_value(float(value))

    def _set_leg(self, a, b) -> None:
        la, lo_a, _ = self.frame.to_geodetic(a[0], a[1], 0.0)
        lb, lo_b, _ = self.frame.to_geodetic(b[0], b[1], 0.0)
        n = GreatCircleLeg("M", float(la), float(lo_a), float(lb), float(lo_b)).normal
        for k, c in zip("xyz", n, strict=False):
            self._set(f"ap/nav/n{k}", c)

    def plan_run(self, x: float, y: float, first: bool = False) -> None:
        """Legs from the aircraft at (x, y) through the positioning points into run `run_k`."""
        run = self.spec.runs[self.run_k]
        path = run_path(run, self.gp, self.length)
        (x0, y0), (x1, y1) = path[0], path[1]
        d = math.hypot(x1 - x0, y1 - y0)
        ux, uy = (x1 - x0) / d, (y1 - y0) / d
        lead = (x0 - 3.0 * NM * ux, y0 - 3.0 * NM * uy)
        side = 1.0 if (-(uy) * (x - lead[0]) + ux * (y - lead[1])) >= 0 else -1.0  # the aircraft's side of the run line
        base = (lead[0] - 2.5 * NM * uy * side, lead[1] + 2.5 * NM * ux * side)
        legs = []
        if not first:
            legs += [((x, y), base, "position"), (base, lead, "position")]
        legs += [(lead, path[0], "position")]
        legs += [(p, q, "run") for p, q in zip(path[:-1], path[1:], strict=False)]
        self.legs, self.leg_i = legs, 0
        self._set_leg(*legs[0][:2])
        self.vmode = "level"

    def _anticipation(self, gs: float) -> float:
        if self.leg_i + 1 >= len(self.legs):
            return 0.0
        (a, b, _), (c, d, _) = self.legs[self.leg_i], self.legs[self.leg_i + 1]
        h1 = math.atan2(b[1] - a[1], b[0] - a[0])
        h2 = math.atan2(d[1] - c[1], d[0] - c[0])
        dpsi = abs((h2 - h1 + math.pi) % (2 * math.pi) - math.pi)
        r = gs**2 / (G0 * math.tan(BANK_DEG * DEG))
        return min(r * math.tan(min(dpsi, 2.6) / 2.0), 3.0 * r)

    def update(
        self, t: float, x: float, y: float, z: float, h_ell: float, vn: float, ve: float, vd: float, cas_kt: float
    ) -> None:
        run = self.spec.runs[self.run_k]
        a, b, kind = self.legs[self.leg_i]
        d = math.hypot(b[0] - a[0], b[1] - a[1])
        to_go = ((b[0] - x) * (b[0] - a[0]) + (b[1] - y) * (b[1] - a[1])) / d
        gs = math.hypot(vn, ve)
        if to_go < self._anticipation(gs):
            if self.leg_i + 1 < len(self.legs):
                self.leg_i += 1
                self._set_leg(*self.legs[self.leg_i][:2])
            else:  # run finished
                self.events["run_end_s"].append(t)
                self.current_run = -1
                self._set("fcs/gear-cmd-norm", 0.0)
                self.run_k += 1
                if self.run_k >= len(self.spec.runs):
                    self.done = True
                    return
                self.plan_run(x, y)
                run = self.spec.runs[self.run_k]
            a, b, kind = self.legs[self.leg_i]
        if kind == "run" and self.current_run != self.run_k:
            self.current_run = self.run_k
            self.events["run_start_s"].append(t)
        approachlike = run.type in ("approach", "low_pass")
        # vertical and configuration
        rate = 0.0
        target_z = run.height_ft * FT
        flaps, ias = 0.0, run.ias_kt
        if approachlike:
            flaps, ias = 15.0, self.sched.capture_ias_kt + 10.0
            if kind == "run" and x < 0.0:
                z_gp = self.gp.height_m(x, y)
                if self.vmode == "level" and z >= z_gp - 1.0 and x > -run.from_nm * NM - NM:
                    self.vmode = "glidepath"
                if self.vmode == "glidepath":
                    self._set("fcs/gear-cmd-norm", 1.0)
                    flaps, ias = 20.0, self.sched.capture_ias_kt
                    if z < self.sched.flaps35_below_ft * FT:
                        ias = self.vapp
                        flaps = 35.0 if cas_kt <= self.sched.vfe35_kt else 20.0
                    target_z = z_gp
                    vx = vn * math.cos(self.frame.course_deg * DEG) + ve * math.sin(self.frame.course_deg * DEG)
                    rate = (
                        vx * self.gp.tan * (x - self.gp.gp_x) / max(math.hypot(x - self.gp.gp_x, y - self.gp.gp_y), 1.0)
                    )
                    if run.type == "approach" and z <= run.decision_height_ft * FT:
                        self.vmode = "climb"
                    if run.type == "low_pass" and z - run.pass_height_ft * FT <= max(vd, 0.0) * 60.0 / 4.0:
                        self.vmode = "pass"
            if self.vmode == "pass" and kind == "run":
                target_z, rate, flaps, ias = run.pass_height_ft * FT, 0.0, 20.0, self.vapp + 5.0
                self._set("fcs/gear-cmd-norm", 1.0)
                if x > self.length:
                    self.vmode = "climb"
            if self.vmode == "climb":
                target_z, rate, flaps, ias = run.height_ft * FT, 0.0, 15.0, self.vapp + 15.0
                self._set("fcs/gear-cmd-norm", 0.0)
        self._set("ap/target/altitude-ft", (h_ell + target_z - z) / FT)
        self._set("ap/target/altitude-rate-fps", rate / FT)
        self._set("ap/target/altitude-t0-sec", t)
        self._set("ap/target/vs-max-fpm", 1500.0)
        self._set("ap/target/vs-min-fpm", -1500.0)
        self._set("ap/target/path-mode", float(approachlike and kind == "run" and self.vmode in ("glidepath", "pass")))
        self._set("ap/target/speed-mode", 0)
        self._set("ap/target/ias-kt", ias)
        self._set("fcs/flap-cmd-norm", flaps / 35.0)


def fly_mission(
    spec: MissionSpec, *, seed, aircraft: str | Airframe | None = None, atmosphere: Atmosphere | None = None
) -> TruthTrack:
    """Fly the mission's runs in order and return the 10 Hz TruthTrack (module docstring)."""
    sched = ApproachSchedule()
    ils = ils_setup(spec, seed, aircraft, atmosphere, "missions")
    af, runway, frame, gp, atmosphere, fdm = ils.af, ils.runway, ils.frame, ils.gp, ils.atmosphere, ils.fdm
    und, t0_s = ils.undulation_m, ils.t0_s
    first = spec.runs[0]
    path = run_path(first, gp, runway.length_m)
    (x0, y0), (x1, y1) = path[0], path[1]
    dd = math.hypot(x1 - x0, y1 - y0)
    ux, uy = (x1 - x0) / dd, (y1 - y0) / dd
    start = (x0 - 3.0 * NM * ux, y0 - 3.0 * NM * uy)
    track_deg = frame.course_deg - math.degrees(math.atan2(uy, ux))  # y is left: a left-going path turns the track left
    ias0 = sched.initial_ias_kt if first.type in ("approach", "low_pass") else first.ias_kt
    initial_conditions(
        fdm,
        frame,
        start[0],
        start[1],
        first.height_ft * FT,
        track_deg,
        af,
        spec.mass_kg,
        ias0,
        15.0 if first.type in ("approach", "low_pass") else 0.0,
        atmosphere,
        und,
        t0_s,
    )
    guide = _MissionGuide(fdm, spec, gp, frame, runway.length_m, sched)
    guide.plan_run(start[0], start[1], first=True)
    a, b, _ = guide.legs[0]
    la, loa, _ = frame.to_geodetic(a[0], a[1], 0.0)
    lb, lob, _ = frame.to_geodetic(b[0], b[1], 0.0)
    engage(fdm, af, GreatCircleLeg("M", float(la), float(loa), float(lb), float(lob)), ias0)
    fdm["ap/active"] = 1
    seed_id = seed_repr(seed)
    t_limit = 3600.0 * 0.5 + 900.0 * len(spec.runs)
    run_tags: list[int] = []

    def step(t, x, y, z, h, vn, ve, vd, vc_kt) -> bool:
        if t > t_limit:
            raise FlightDiverged(f"mission not finished within {t_limit:.0f} s (run {guide.run_k})", seed_id, t)
        guide.update(t, x, y, z, h, vn, ve, vd, vc_kt)
        run_tags.extend([guide.current_run] * (RATE_HZ))
        return guide.done

    turb = TurbulencePatches(fdm, ils.rng) if spec.turbulence else None
    cg_props = tuple(f"inertia/cg-{a}-in" for a in "xyz")
    rec, rows, tags = fly_loop(
        fdm,
        frame,
        atmosphere,
        und,
        t0_s,
        runway.elevation_m,
        step,
        seed_id,
        RATE_HZ,
        cg_props,
        min_height_m=3.0,
        turbulence=turb,
        steering=ils.steering,
    )
    nrec = len(rec.PROPS)
    data = np.asarray(rows, dtype=float)
    df = rec.frame(data[:, :nrec], tags)
    add_frame_columns(df, frame, data[:, nrec : nrec + 3])
    run_idx = np.asarray(run_tags[: len(df)], dtype=np.int16)
    df["run"] = run_idx
    names = np.array(["position"] + [r.type for r in spec.runs], dtype=object)
    df["run_type"] = names[run_idx + 1]
    if not np.isfinite(df.drop(columns=["phase", "run_type"]).to_numpy(float)).all():
        raise FlightDiverged("NaN in the recorded truth", seed_id)
    meta = {
        **frame_meta("mission", "mission", af, seed_id, spec, runway, frame, und, gp),
        "runs": [r.model_dump() for r in spec.runs],
        "run_events_s": guide.events,
        "mass_kg": spec.mass_kg,
        "points_structural_m": {k: list(v) for k, v in spec.points_m.items()},
        "turbulence": bool(spec.turbulence),
        "turbulence_patches": turb.meta() if turb is not None else [],
        "rate_hz": RATE_HZ,
    }
    meta["config_hash"] = params_digest({k: meta[k] for k in sorted(meta) if k != "config_hash"})
    return TruthTrack(df, meta)
