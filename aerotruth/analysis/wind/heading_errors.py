"""Heading errors from wind reports (wind paper section 5.1): the ground track from three
adjacent reports, the air vectors of eqs. 3 and 4, and d = psi - psi'.

Wind paper (Mulally & Anderson, "Correction of aircraft flux valve based heading ...",
AirDat), section 5.1, from reports only:

    V_G   ground velocity from three adjacent reports i-1, i, i+1 of one flight:
          (p[i+1] - p[i-1]) / (t[i+1] - t[i-1]), kept only when the two segments are
          collinear (course change <= 10 deg) and flown at constant speed (ground-speed
          change <= 10 %) - each limit widened by 3 sd of the change that the reports'
          0.01-deg rounding makes by itself (`step_noise`) - the reports <= 10 min apart
          and V_G's rounding error <= 0.5 |V_G|;
          positions on a local tangent plane with the WGS-84 radii of curvature M, N
          (error ~ (L/R)^2 ~ 1e-4 for L <= 100 km); reports with |roll| > 10 deg dropped;
    V_A   = V_G - V_W,TAM                                    wind paper eq. 3
    V_A'  = V_G - V_W,REF   (one row per reference model)    wind paper eq. 4
    d     = psi - psi' = angle(V_A) - angle(V_A')            heading error (deg)

V_G cancels in V_A - V_A' = V_W,REF - V_W,TAM, so d does not depend on the ground
track's quantisation noise to first order (an error e in V_G moves d by about
|e| |V_W,TAM - V_W,REF| / |V_A|^2: at |e| = 0.5 |V_G| and a 10-kt difference at 160 kt,
~1.8 deg, about the reference model's own noise - hence the 0.5); the track only supplies
the measured heading z' = angle(V_A) (and |V_A| = TAS) where the table has no
`heading_deg` (`tas_kt`) column. The gates were once a fixed 10-km baseline and fixed
10-deg / 10-% limits: on short spans the rounding alone fails them, and they threw away
every departure climb - on a one-axis network (PenAir) the only reports off the axis, so
the tables held the sinusoid's component along the axis alone (refitted on the frozen
PenAir runs and scored against the truth heading on other days: 1.89 deg rms left, 1.47
with the widened gates; ascents 2.45 -> 1.72; Mesaba 1.34 -> 1.32).

Flights: the `flight` column when present, else a new flight wherever an aircraft's
consecutive reports are more than `flight_gap_s` (30 min) apart. Clusters (of the fits'
standard errors and bootstrap): whole flights, or with `cluster_s` > 0 each flight cut into
equal time blocks of at most `cluster_s` (`report_clusters`).

Gates from the data (`data_gates`): the position resolution is read off the values (TAMDAR's
0.01 deg; decoded Mode-S positions are not rounded, and a 0.01-deg step assumed for them
fails three quarters of 1-s reports at the baseline gate), and reports closer than a minute
(Mode-S state tables) are clustered in 5-min blocks (DENSE_CLUSTER_S) instead of flights.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from numba import njit
from pydantic import Field

from aerotruth.analysis.least_squares import clustered_se
from aerotruth.analysis.wind.fast_trig import (
    arctan2,
    atan2_scalar,
    hypot,
    sin_cos,
    sincos_scalar,
)
from aerotruth.analysis.wind.observations import validate_observations
from aerotruth.ellipsoid import A_M, E2, radii_from_sin
from aerotruth.errors import DataError
from aerotruth.schema import Section
from aerotruth.units import DEG, KT

GATE_NAMES = ("used", "no_neighbours", "gap", "baseline", "collinearity", "speed_change", "roll", "implausible")


class GateSpec(Section):
    """Quality gates of the three-report ground track (wind paper section 5.1) and the
    plausibility limits of a report."""

    max_gap_s: float = Field(600.0, gt=0, description="largest time between adjacent reports of a triple")
    min_baseline_km: float = Field(0.0, ge=0, description="shortest distance from report i-1 to i+1 (0: none)")
    max_course_change_deg: float = Field(
        10.0, gt=0, description="collinearity: course i-1->i vs i->i+1, beyond what the position step can fake"
    )
    max_speed_change: float = Field(
        0.10, gt=0, description="constant speed: |gs2 - gs1| / mean(gs), beyond what the position step can fake"
    )
    max_track_noise: float = Field(
        0.5, gt=0, description="baseline: the rounding error of V_G from the position step (sd) over |V_G| at most this"
    )
    position_step_deg: float = Field(0.01, ge=0, description="the reports' lat/lon resolution (TAMDAR: 0.01 deg)")
    noise_sigmas: float = Field(
        3.0,
        ge=0,
        description="the collinearity and speed limits widen by this many "
        "standard deviations of the change the position step alone makes",
    )
    max_roll_deg: float = Field(10.0, gt=0, description="reports banked more are dropped (wind paper section 4)")
    flight_gap_s: float = Field(1800.0, gt=0, description="a longer pause between reports starts a new flight")
    cluster_s: float = Field(
        0.0,
        ge=0,
        description="the clusters of the standard errors and the bootstrap: each flight cut into equal blocks "
        "of at most this length (0: whole flights)",
    )
    min_tas_kt: float = Field(60.0, ge=0, description="|V_A| below this is implausible")
    max_tas_kt: float = Field(600.0, gt=0, description="|V_A| above this is implausible")
    max_heading_error_deg: float = Field(30.0, gt=0, description="|psi - psi'| above this is a gross error")


# The gates of analyses that use the ground track itself, not only d (which V_G cancels
# from to first order): |V_A| and the along-track residuals of `aerotruth diagnose` move
# one for one with V_G's error, so they keep spans >= 10 km and fixed 10-deg / 10-% limits
# (0.01-deg rounding: <= ~0.45 km of difference error, <= 2.6 deg of track).
TRACK_GATES = GateSpec(min_baseline_km=10.0, noise_sigmas=0.0, max_track_noise=math.inf)


def towards_from_report(speed_kt, dir_from_deg) -> tuple[np.ndarray, np.ndarray]:
    """(u east, v north) in m/s of a reported wind (speed kt, meteorological "from" deg)."""
    sp = np.asarray(speed_kt, dtype=float)
    d = np.asarray(dir_from_deg, dtype=float)
    sp, d = np.broadcast_arrays(sp, d)
    u, v = np.empty(sp.shape), np.empty(sp.shape)
    _towards(np.ascontiguousarray(sp).reshape(-1), np.ascontiguousarray(d).reshape(-1), u.reshape(-1), v.reshape(-1))
    return u, v


@njit(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")
def _towards(speed_kt: np.ndarray, dir_from_deg: np.ndarray, u: np.ndarray, v: np.ndarray) -> None:
    for i in range(len(speed_kt)):
        s, c = sincos_scalar(dir_from_deg[i] * DEG)  # (|x| <= 1e5 rad: any plausible direction)
        k = -speed_kt[i] * KT  # towards = -from
        u[i], v[i] = s * k, c * k


def wrap(x: np.ndarray, period: float, lo: float = 0.0) -> np.ndarray:
    """x wrapped into [lo, lo + period), as (x - lo) % period + lo (a floor instead of the
    float remainder: 20x faster)."""
    y = x - lo
    return x - period * np.floor(y / period, out=y)


def wgs84_radii(lat_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Meridional (M) and prime-vertical (N) radii of curvature (m) at a latitude
    (`aerotruth.ellipsoid`, with the method's single-precision sine)."""
    return radii_from_sin(sin_cos(lat_rad)[0])


def segment_displacements(lat_rad: np.ndarray, lon_rad: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(east, north) metres from each point to the next, on the tangent plane at the
    segment's mid latitude with the WGS-84 radii of curvature M, N."""
    phi = 0.5 * (lat_rad[1:] + lat_rad[:-1])
    s, c = sin_cos(phi)
    rm, rn = radii_from_sin(s)
    dn = np.diff(lat_rad) * rm
    de = wrap(np.diff(lon_rad), 2 * np.pi, -np.pi) * rn * c
    return de, dn


# an upper bound of sqrt(2 (s_e^2 + s_n^2)) per degree of position step (step_noise: s_n =
# M s, s_e = N cos(lat) s with s = step / sqrt(12), M, N <= a / (1 - e^2)): metres
_MAX_STEP_NOISE_M = math.sqrt(2.0 * 2.0) * A_M / (1 - E2) * math.radians(1.0) / math.sqrt(12.0)


def step_noise(
    lat_rad: np.ndarray,
    span_e: np.ndarray,
    span_n: np.ndarray,
    span: np.ndarray,
    gs1: np.ndarray,
    gs2: np.ndarray,
    t1: np.ndarray,
    t2: np.ndarray,
    step_deg: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Standard deviations of the course change (deg), of the relative ground-speed change
    and of V_G relative to |V_G| that positions rounded to `step_deg` make by themselves at
    interior reports k of a track: segments k-1 and k around report k (ground speeds gs1,
    gs2 m/s over t1, t2 s: lengths L = gs t), the span (span_e, span_n) from report k-1 to
    k+1 (m), `span` its length.

    Rounding errors are uniform, sd s = step/sqrt(12) per coordinate (north M s, east
    N cos(lat) s in metres); across (along) the span's course c a point errs by
    s_x^2 = s_e^2 cos^2 c + s_n^2 sin^2 c (s_a^2 = s_e^2 sin^2 c + s_n^2 cos^2 c). The
    three points enter the course change as e3/L2 - e2 (1/L1 + 1/L2) + e1/L1, so
    var = s_x^2 (1/L1^2 + (1/L1 + 1/L2)^2 + 1/L2^2); the speed change likewise with the dt's
    and s_a, over the mean ground speed; V_G's error is its two end points' over the span,
    sqrt(2 (s_e^2 + s_n^2)) / |span|."""
    sin_lat, cos_lat = sin_cos(lat_rad)
    args = np.broadcast_arrays(
        *(np.asarray(v, dtype=float) for v in (sin_lat, cos_lat, span_e, span_n, span, gs1, gs2, t1, t2))
    )
    shape = args[0].shape
    out = np.empty((3, args[0].size))
    f_sin, f_cos, f_se, f_sn, f_span, f_gs1, f_gs2, f_t1, f_t2 = (np.ascontiguousarray(a).reshape(-1) for a in args)
    _step_noise_all(
        f_sin, f_cos, f_se, f_sn, f_span, f_gs1, f_gs2, f_t1, f_t2, math.radians(step_deg) / math.sqrt(12.0), out
    )
    return out[0].reshape(shape), out[1].reshape(shape), out[2].reshape(shape)


_radii = njit(cache=True, nogil=True, inline="always")(radii_from_sin)  # aerotruth.ellipsoid's, compiled


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _step_noise1(
    sin_lat: float,
    cos_lat: float,
    span_e: float,
    span_n: float,
    span: float,
    gs1: float,
    gs2: float,
    t1: float,
    t2: float,
    s: float,
) -> tuple[float, float, float]:
    """step_noise of one report, `s` = step (rad) / sqrt(12)."""
    rm, rn = _radii(sin_lat)
    s_n, s_e = rm * s, rn * cos_lat * s
    sc, cc = span_e / span, span_n / span
    s_x = math.sqrt((s_e * cc) ** 2 + (s_n * sc) ** 2)
    s_a = math.sqrt((s_e * sc) ** 2 + (s_n * cc) ** 2)
    l1, l2 = gs1 * t1, gs2 * t2
    sd_course = math.degrees(s_x * math.sqrt(1 / l1**2 + (1 / l1 + 1 / l2) ** 2 + 1 / l2**2))
    sd_speed = s_a * math.sqrt(1 / t1**2 + (1 / t1 + 1 / t2) ** 2 + 1 / t2**2) / (0.5 * (gs1 + gs2))
    return sd_course, sd_speed, math.sqrt(2.0 * (s_e**2 + s_n**2)) / span


@njit(cache=True, nogil=True, error_model="numpy")
def _step_noise_all(sin_lat, cos_lat, span_e, span_n, span, gs1, gs2, t1, t2, s, out):
    for i in range(len(sin_lat)):
        out[0, i], out[1, i], out[2, i] = _step_noise1(
            sin_lat[i], cos_lat[i], span_e[i], span_n[i], span[i], gs1[i], gs2[i], t1[i], t2[i], s
        )


def running_count(flags: np.ndarray) -> np.ndarray:
    """np.cumsum of a boolean array as int64 (summed in int32 below 2**31 rows: numpy's
    int64 running sum of booleans is 7x slower here)."""
    if len(flags) < 2**31 - 1:
        return np.cumsum(flags, dtype=np.int32).astype(np.int64)
    return np.cumsum(flags, dtype=np.int64)


def report_clusters(flight: np.ndarray, t: np.ndarray, cluster_s: float) -> np.ndarray:
    """Cluster index (0, 1, ...) of each report: its flight (`flight`, as report_flights gives,
    reports in time order within each flight) when `cluster_s` is 0, else the flight cut into
    n = ceil(span / cluster_s) blocks of equal time, span its first to last report (a flight
    of any length longer than `cluster_s` gives two clusters or more)."""
    if cluster_s <= 0 or len(t) == 0:
        return np.asarray(flight, dtype=np.int64)
    starts = np.flatnonzero(np.r_[True, flight[1:] != flight[:-1]])
    ends = np.r_[starts[1:], len(t)]
    t0 = np.repeat(t[starts], ends - starts)
    span = np.repeat(t[ends - 1] - t[starts], ends - starts)
    nblk = np.maximum(np.ceil(span / cluster_s), 1.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        blk = np.where(span > 0, np.floor((t - t0) / span * nblk), 0.0)
    blk = np.minimum(blk, nblk - 1).astype(np.int64)
    new = np.ones(len(t), dtype=bool)
    new[1:] = (flight[1:] != flight[:-1]) | (blk[1:] != blk[:-1])
    return running_count(new) - 1


# Reports closer than this (median interval) are "dense" (Mode-S, 1-s state tables): their
# errors are correlated over minutes (the reference's neighbourhood, mesoscale wind), so the
# clusters of the standard errors are time blocks of DENSE_CLUSTER_S within a flight, not
# whole flights (an hour of traffic is one flight per aircraft). 5 min: an airliner at 450 kt
# crosses ~70 km, more than the consensus reference's 50-km radius, so the neighbours of its
# reference largely change from one block to the next.
DENSE_REPORT_INTERVAL_S = 60.0
DENSE_CLUSTER_S = 300.0
# decimal steps a position may be rounded to (TAMDAR: 0.01 deg); finer ones count as unrounded
_POSITION_STEPS_DEG = (1.0, 0.1, 0.01, 0.001, 1e-4)


def position_step_deg(lat_deg: np.ndarray, lon_deg: np.ndarray) -> float:
    """The reports' lat/lon resolution read off the values: the coarsest decimal step of
    1, 0.1, ..., 1e-4 deg on which 99 % of the finite positions lie, else 0 (not rounded:
    decoded CPR positions, floats). 1e-4 deg is 11 m: finer rounding is below what the
    ground-track gates can see over any report interval."""
    v = np.concatenate([np.asarray(lat_deg, float), np.asarray(lon_deg, float)])
    v = v[np.isfinite(v)]
    if len(v) == 0:
        return 0.0
    v = v[:: max(1, len(v) // 20000)]  # a sample is enough to see the rounding
    for step in _POSITION_STEPS_DEG:
        q = v / step
        if np.mean(np.abs(q - np.round(q)) <= 1e-6 * np.maximum(1.0, np.abs(q))) >= 0.99:
            return step
    return 0.0


def report_interval_s(aircraft: np.ndarray, t: np.ndarray) -> float:
    """Median time between an aircraft's consecutive reports (s; NaN with fewer than two),
    `aircraft` codes and `t` in time order within each aircraft."""
    if len(t) < 2:
        return math.nan
    dt_ = np.diff(t)[(aircraft[1:] == aircraft[:-1])]
    dt_ = dt_[dt_ > 0]
    return float(np.median(dt_)) if len(dt_) else math.nan


@dataclass(frozen=True)
class DataGates:
    """The gates a table's own reports call for (`data_gates`) and what they were read from."""

    gates: GateSpec
    position_step_deg: float  # inferred (or given)
    report_interval_s: float  # median, inferred
    dense: bool  # reports closer than DENSE_REPORT_INTERVAL_S: clusters are time blocks
    given: tuple[str, ...]  # the GateSpec fields the user set

    def describe(self) -> str:
        """One sentence for a report."""
        step = f"{self.position_step_deg:g} deg" if self.position_step_deg > 0 else "not rounded"
        unit = (
            f"blocks of at most {self.gates.cluster_s:g} s within each flight"
            if self.gates.cluster_s > 0
            else f"whole flights (a pause over {self.gates.flight_gap_s:g} s starts a new one)"
        )
        said = f" (given: {', '.join(self.given)})" if self.given else ""
        return (
            f"positions {step}, median report interval {self.report_interval_s:.3g} s; "
            f"clusters of the standard errors and bootstrap: {unit}{said}"
        )


def data_gates(obs: pd.DataFrame, base: GateSpec | None = None, **given) -> DataGates:
    """The gates of `base` (default GateSpec()) with the position resolution and clustering
    unit read off the table (validated observations): `position_step_deg` from the values
    (position_step_deg), `cluster_s` DENSE_CLUSTER_S where the median report interval is
    under DENSE_REPORT_INTERVAL_S, else 0 (whole flights). Fields in `given` (not None)
    override what is inferred."""
    given = {k: v for k, v in given.items() if v is not None}
    ac = obs["aircraft"].cat.codes.to_numpy() if hasattr(obs["aircraft"], "cat") else pd.factorize(obs["aircraft"])[0]
    t = obs["time_s"].to_numpy()
    first = np.flatnonzero(np.r_[True, (ac[1:] != ac[:-1]) | (t[1:] != t[:-1])])
    step = position_step_deg(obs["lat"].to_numpy().take(first), obs["lon"].to_numpy().take(first))
    interval = report_interval_s(ac.take(first), t.take(first))
    dense = bool(interval < DENSE_REPORT_INTERVAL_S)
    fields = {"position_step_deg": step, "cluster_s": DENSE_CLUSTER_S if dense else 0.0}
    fields.update(given)
    gates = (base or GateSpec()).model_copy(update=fields)
    gates = GateSpec.model_validate(gates.model_dump())  # the given values checked against the schema
    return DataGates(gates, gates.position_step_deg, interval, dense, tuple(sorted(given)))


def report_flights(
    aircraft: np.ndarray, t: np.ndarray, flight_gap_s: float, flight: np.ndarray | None = None
) -> np.ndarray:
    """Flight index (0, 1, ...) of each report, the reports in time order within each
    aircraft (`aircraft`: codes): a new flight where the aircraft changes, its reports are
    more than `flight_gap_s` apart or (when given) the `flight` label changes."""
    m = len(t)
    new_fl = np.ones(m, dtype=bool)
    new_fl[1:] = (aircraft[1:] != aircraft[:-1]) | (np.diff(t) > flight_gap_s)
    if flight is not None:
        new_fl[1:] |= flight[1:] != flight[:-1]
    return running_count(new_fl) - 1


@dataclass(frozen=True)
class GroundTrack:
    """Per report: the ground velocity from its neighbours (m/s east, north; wind paper
    section 5.1) and the first track gate it fails (`gate`, a code of GATE_NAMES: 0 "used"
    passes every one; 1-5 no_neighbours, gap, baseline, collinearity, speed_change)."""

    vg_e: np.ndarray
    vg_n: np.ndarray
    gate: np.ndarray


def ground_track(
    t: np.ndarray, lat_rad: np.ndarray, lon_rad: np.ndarray, flight: np.ndarray, gates: GateSpec
) -> GroundTrack:
    """V_G = (p[k+1] - p[k-1]) / (t[k+1] - t[k-1]) of every report k of a flight from its
    neighbours and the gates of `gates` (module docstring) on it; reports in time order
    within each flight (`flight`, as report_flights gives), positions on the tangent plane
    of each segment (segment_displacements). The first and last report of a flight fail
    `no_neighbours` (their V_G is one segment's, or across flights)."""
    g = gates
    m = len(t)
    vg_e, vg_n, gate = np.full(m, np.nan), np.full(m, np.nan), np.ones(m, dtype=np.int8)
    if m >= 2:
        de, dn = segment_displacements(lat_rad, lon_rad)
        sin_lat, cos_lat = sin_cos(lat_rad)  # for step_noise
        # the rounding's own noise (step_noise) only where the plain limits fail: elsewhere
        # the widened gates pass whatever it is (V_G's rounding error is at most
        # _MAX_STEP_NOISE_M * step in metres per degree: the span gate passes above that)
        safe_span = _MAX_STEP_NOISE_M * g.position_step_deg / max(g.max_track_noise, 1e-300)
        _track_gates(
            np.asarray(t, dtype=float),
            de,
            dn,
            np.asarray(flight),
            sin_lat,
            cos_lat,
            g.max_gap_s,
            g.min_baseline_km * 1000.0,
            g.max_course_change_deg,
            g.max_speed_change,
            g.max_track_noise,
            g.noise_sigmas,
            math.radians(g.position_step_deg) / math.sqrt(12.0),
            safe_span,
            vg_e,
            vg_n,
            gate,
        )
    return GroundTrack(vg_e, vg_n, gate)


@njit(cache=True, nogil=True, error_model="numpy")
def _track_gates(
    t,
    de,
    dn,
    flight,
    sin_lat,
    cos_lat,
    max_gap_s,
    min_baseline_m,
    max_course,
    max_speed,
    max_noise,
    sigmas,
    s,
    safe_span,
    vg_e,
    vg_n,
    gate,
) -> None:
    """ground_track's loop over m >= 2 reports (segments de, dn from report k to k + 1):
    V_G into vg_e, vg_n; the first failed gate's code into `gate` (given as 1, no_neighbours;
    the ends keep it)."""
    m = len(t)
    vg_e[0], vg_n[0] = de[0] / (t[1] - t[0]), dn[0] / (t[1] - t[0])  # one segment's velocity at the ends
    vg_e[m - 1], vg_n[m - 1] = de[m - 2] / (t[m - 1] - t[m - 2]), dn[m - 2] / (t[m - 1] - t[m - 2])
    for k in range(1, m - 1):  # every quantity computed, then selected: no branch (SIMD lanes)
        e1, n1, e2, n2 = de[k - 1], dn[k - 1], de[k], dn[k]
        dt1, dt2 = t[k] - t[k - 1], t[k + 1] - t[k]
        span_e, span_n = e1 + e2, n1 + n2
        vg_e[k], vg_n[k] = span_e / (dt1 + dt2), span_n / (dt1 + dt2)  # V_G = (p[k+1] - p[k-1]) / (t[k+1] - t[k-1])
        gs1, gs2 = math.sqrt(e1 * e1 + n1 * n1) / dt1, math.sqrt(e2 * e2 + n2 * n2) / dt2
        # course change between the segments: the angle between them, in [0, 180]
        dcourse = math.degrees(abs(atan2_scalar(e1 * n2 - n1 * e2, e1 * e2 + n1 * n2)))
        dspeed = abs(gs2 - gs1) / (0.5 * (gs1 + gs2))
        span = math.sqrt(span_e * span_e + span_n * span_n)
        plain = dcourse <= max_course and dspeed <= max_speed and span >= safe_span
        sdc, sds, rvg = _step_noise1(sin_lat[k], cos_lat[k], span_e, span_n, span, gs1, gs2, dt1, dt2, s)
        sd_course, sd_speed, rel_vg = (0.0 if plain else sdc), (0.0 if plain else sds), (0.0 if plain else rvg)
        code = 0 if dspeed <= max_speed + sigmas * sd_speed else 5  # speed_change
        code = code if dcourse <= max_course + sigmas * sd_course else 4  # collinearity
        code = code if span >= min_baseline_m and rel_vg <= max_noise else 3  # baseline
        code = code if dt1 > 0 and dt2 > 0 and dt1 <= max_gap_s and dt2 <= max_gap_s else 2  # gap
        code = code if flight[k - 1] == flight[k] and flight[k] == flight[k + 1] else 1  # no_neighbours
        gate[k] = code


# The reported TAS over the wind triangle's |V_G - V_W| (eq. 3), median over the gated
# reports: a TAS scale error of a few per cent is an effect to find (diagnose), a column in
# m/s (0.51x) or km/h (1.85x) is a unit
TAS_RATIO_RANGE = (0.75, 1.33)
_TAS_UNITS = (("m/s", 1.0 / 1.943844), ("km/h", 1.852))  # (mph, 1.15x, is inside the range: a scale error)


def _check_tas_units(tas_col_ms: np.ndarray, tas_triangle_ms: np.ndarray, ok: np.ndarray, source: str) -> None:
    """DataError when the `tas_kt` column is not in knots, judged against the wind triangle."""
    with np.errstate(invalid="ignore", divide="ignore"):
        r = tas_col_ms[ok] / tas_triangle_ms[ok]
    r = r[np.isfinite(r)]
    if len(r) < 20:
        return
    med = float(np.median(r))
    lo, hi = TAS_RATIO_RANGE
    if lo <= med <= hi:
        return
    unit = next((u for u, f in _TAS_UNITS if abs(med / f - 1) < 0.05), None)
    raise DataError(
        f"{source}: column 'tas_kt' is {med:.3f}x the airspeed of the wind triangle (ground track minus "
        f"reported wind, wind paper eq. 3; median over {len(r)} reports): "
        f"{'in ' + unit + '? ' if unit else ''}expected knots"
    )


# Wind speed columns in other units than knots. The aircraft's airspeed |V_A| = |V_G - V_W|
# (eq. 3) does not follow the wind; a reported wind written in a unit u reads f = (kt per u)^-1
# times the wind, and then |V_G - f V_W| = |V_A + (1 - f) V_W| grows with the along-track wind
# w = f V_W . u_A at the slope b = (1 - f) / f: 0 in knots, +0.94 in m/s, -0.46 in km/h
# (mph, -0.13, is not told from what remains in knots: -0.07 to +0.05 on simulated and
# generated tables, `_check_wind_units`). The reference wind is then checked the same way
# (`_check_reference_units`: the airspeed it implies against the reported along-track wind,
# slope 1 - a for a reference written a x the wind; its scale a in REFERENCE_RATIO_RANGE
# passes). Either is refused only when outside its range by more than UNIT_SIGMAS
# flight-clustered standard errors from knots, on MIN_UNIT_FLIGHTS flights or more: on
# subsets of 2-7 simulated flights the plain ranges refused 28-46 % of tables in knots
# (heading errors of 10 deg and model errors of 8 kt make few flights' slopes noisy). Below
# the range the slope must also lie RANGE_SIGMAS of its standard errors beyond its edge,
# which is only 0.3 from knots: on 966 subsets of 10-39 flights of two PenAir runs in knots
# the slope was -0.10 +- 0.10 and +0.05 +- 0.12 (each run's own mean; down to -0.67 and -1.02,
# up to +0.54), and without the margin 2 were refused (-0.40 +- 0.07 on 15 flights, -0.30 +-
# 0.05 on 28).
WIND_SLOPE_RANGE = (-0.3, 0.6)
REFERENCE_RATIO_RANGE = (0.65, 1.55)
UNIT_SIGMAS = 5.0
RANGE_SIGMAS = 2.0
MIN_UNIT_FLIGHTS = 10
_WIND_UNITS = (("m/s", 1.0 / 1.943844), ("km/h", 1.852))  # f: the column's number per knot
_UNIT_CHECK_MAX_REPORTS = 20_000  # a stride through the gated reports beyond this


def _unit_named(f: float) -> str:
    unit = next((u for u, fu in _WIND_UNITS if abs(f / fu - 1) < 0.15), None)
    return f"in {unit}? " if unit else ""


@dataclass(frozen=True)
class _Sample:
    """The unit checks' reports (the gated ones, a stride through them beyond
    _UNIT_CHECK_MAX_REPORTS), with what every check reads of them, computed once: their
    index among the reports, V_A = V_G - V_W,TAM (eq. 3) and its length, the reported
    along-track wind (m/s), aircraft code, pressure altitude and flight."""

    idx: np.ndarray
    va_e: np.ndarray
    va_n: np.ndarray
    va: np.ndarray
    along: np.ndarray
    ac: np.ndarray
    alt_ft: np.ndarray
    flight: np.ndarray

    @classmethod
    def of(
        cls,
        ok: np.ndarray,
        va_e: np.ndarray,
        va_n: np.ndarray,
        wt_e: np.ndarray,
        wt_n: np.ndarray,
        ac: np.ndarray,
        alt_ft: np.ndarray,
        flight: np.ndarray,
    ) -> _Sample:
        idx = np.flatnonzero(ok)
        idx = idx[:: max(1, len(idx) // _UNIT_CHECK_MAX_REPORTS)]
        ve, vn = va_e.take(idx), va_n.take(idx)
        va = hypot(ve, vn)
        with np.errstate(invalid="ignore", divide="ignore"):
            along = (wt_e.take(idx) * ve + wt_n.take(idx) * vn) / va
        return cls(idx, ve, vn, va, along, ac.take(idx), alt_ft.take(idx), flight.take(idx))


def _band_slope(
    x: np.ndarray, y: np.ndarray, ac: np.ndarray, alt_ft: np.ndarray, flight: np.ndarray
) -> tuple[float, float, int] | None:
    """Slope of y on x (any consistent units) with the means of each aircraft and 2,000-ft
    band removed (TAS and wind both change with height: with the aircraft's means alone the
    reported-wind slope in knots was -0.13 to +0.17 on simulated and generated tables, with
    the bands' -0.07 to +0.05), its flight-clustered standard error and the number of
    flights; None when fewer than 50 points or x varies by less than 5 kt sd."""
    keep = np.isfinite(x) & np.isfinite(y)
    x, y, ac, alt_ft, flight = x[keep], y[keep], ac[keep], alt_ft[keep], flight[keep]
    if len(x) < 50:
        return None
    band = (alt_ft * (1 / 2000.0)).astype(np.int64)
    band -= band.min()
    g = ac.astype(np.int64) * (int(band.max()) + 1) + band
    n = np.maximum(np.bincount(g), 1)
    y = y - (np.bincount(g, y) / n)[g]
    x = x - (np.bincount(g, x) / n)[g]
    sxx = float(x @ x)
    if sxx < len(x) * (5.0 * KT) ** 2:  # x must vary (sd >= 5 kt)
        return None
    b = float(x @ y) / sxx
    se, flights = clustered_se(x * (y - b * x), flight, sxx)
    return b, se, flights


def _check_wind_units(sample: _Sample, source: str) -> None:
    """DataError when the reported wind (`wind_speed_kt`, `wind_dir_deg`) is not in knots
    and meteorological degrees: the slope of the triangle's airspeed on the along-track wind
    (comment above; `_band_slope`)."""
    if len(sample.idx) < 50:
        return
    fitted = _band_slope(sample.along, sample.va, sample.ac, sample.alt_ft, sample.flight)
    if fitted is None:
        return
    b, se, flights = fitted
    lo, hi = WIND_SLOPE_RANGE
    if lo - RANGE_SIGMAS * se <= b <= hi or abs(b) < UNIT_SIGMAS * se or flights < MIN_UNIT_FLIGHTS:
        return
    f = 1.0 / (1.0 + b)

    def what(columns: str) -> str:
        return (
            f"{source}: {columns}: the airspeed of the wind triangle (ground track minus reported wind, wind "
            f"paper eq. 3) changes by {b:+.2f} ± {se:.2g} kt per kt of along-track wind over {flights} flights, "
            f"as if the reported wind were {f:.3f}x the wind: "
        )

    if _unit_named(f):
        raise DataError(what("column 'wind_speed_kt'") + f"{_unit_named(f)}expected knots")
    # |V_G - f V_W| with f ~ -1: the wind's direction reversed (slope -2); a longitude of the
    # wrong sign mirrors V_G east-west, which under a zonal wind reads the same (-1.8 measured)
    if abs(f + 1.0) < 0.35:
        raise DataError(
            what("column 'wind_dir_deg'") + "a direction the wind blows to? expected the direction it "
            "blows from (meteorological convention); or, in a mostly east-west wind, the ground track "
            "mirrored east-west: 'lon' of the wrong sign?"
        )
    raise DataError(
        what("columns 'wind_speed_kt', 'wind_dir_deg'") + "check the speed unit (knots) and the "
        "direction convention (degrees clockwise from north, where the wind blows from)"
    )


# `heading_deg` is the measured true heading the reported wind was computed with, so it is the
# heading of the report's own air vector V_G - V_W,TAM (eq. 3) up to the track's noise (a
# degree or two on gated reports). A column whose median difference from it exceeds this is
# not that heading (radians, another column); a magnetic heading there (|D| mostly < 30 deg)
# is left to heading fit's warning (`magnetic_heading_warnings`).
HEADING_SUSPECT_DEG = 45.0


def _check_heading_column(h: np.ndarray, psi: np.ndarray, names: pd.Index, sample: _Sample, source: str) -> None:
    """DataError naming the first aircraft whose `heading_deg` (h, deg, per report) differs
    from its reports' air-vector heading psi (deg) by a median of more than
    HEADING_SUSPECT_DEG, over at least 50 of the sample's reports."""
    hh = h.take(sample.idx)
    fin = np.isfinite(hh)
    hh, a, pp = hh[fin], sample.ac[fin], psi.take(sample.idx)[fin]
    diff = np.abs(wrap(hh - pp, 360.0, -180.0))
    g = pd.Series(diff).groupby(a)
    med, n = g.median(), g.size()
    bad = med[(n >= 50) & (med > HEADING_SUSPECT_DEG)]
    if bad.empty:
        return
    c = int(bad.index[0])
    mine = hh[a == c]
    hint = " (all within ±2 pi: in radians?)" if np.all(np.abs(mine) <= 2 * math.pi) else ""
    raise DataError(
        f"{source}: column 'heading_deg': aircraft {names[c]}'s headings differ from the heading of its "
        f"reports' air vector (ground track minus reported wind, wind paper eq. 3) by a median of "
        f"{bad.iloc[0]:.1f} deg over {int(n[c])} reports{hint}: expected the measured true heading (deg) "
        "the reported wind was computed with (if it is, 'lat'/'lon' swapped or of the wrong sign turn "
        "the ground track)"
    )


def _check_reference_units(
    sample: _Sample,
    wt_e: np.ndarray,
    wt_n: np.ndarray,
    wr_e: np.ndarray,
    wr_n: np.ndarray,
    first: np.ndarray,
    rep_of_row: np.ndarray,
    ref: pd.Categorical,
    source: str,
) -> None:
    """DataError when a reference model's wind is not in the reported wind's units and
    convention, each reference model on its own, over the rows of the sample's reports (per
    report the reported wind; per row the reference wind; `first` each report's first row,
    `rep_of_row` each row's report). A heading error
    only turns V_A, so the airspeed the reference implies, |V_G - V_W,REF| (eq. 4), differs
    from |V_A| by the reference's error along V_A: for a reference written a x the wind,
    by (1 - a) x the along-track wind, which the reported wind measures free of the
    reference's own error (a heading error is across track). So a = 1 - the slope of that
    difference on the reported along-track wind (`_band_slope`): 1 in knots, 0.51 in m/s,
    1.85 in km/h, -1 for a direction where the wind blows to, near 0 (not following the
    wind) in another convention. Regressing the one wind vector on the other instead was
    biased wherever the wind is light: by the reference's error (attenuation, r = 1 +
    2 sigma^2 / W^2) and by the deviation's once-round terms, whose wind error TAS d(psi)
    correlates with the wind (on 2 aircraft x 100 flights in 8 kt winds with C = 5 deg: a
    scale of 3.5 refused a table in knots)."""
    rep = sample.idx
    if len(rep) < 50:
        return
    begin = first.take(rep)
    nxt = rep + 1
    counts = np.where(nxt < len(first), first.take(np.minimum(nxt, len(first) - 1)), len(rep_of_row)) - begin
    starts = np.cumsum(counts) - counts
    rows = np.repeat(begin - starts, counts) + np.arange(int(counts.sum()))  # the rows of the sample's reports
    k_of_row = np.repeat(np.arange(len(rep)), counts)  # each row's report, as a position in the sample
    codes = ref.codes.take(rows)
    for c in np.unique(codes[codes >= 0]):
        sel = codes == c
        i, k = rows[sel], k_of_row[sel]
        j = rep.take(k)
        dv = hypot(
            sample.va_e.take(k) + wt_e.take(j) - wr_e.take(i), sample.va_n.take(k) + wt_n.take(j) - wr_n.take(i)
        ) - sample.va.take(k)  # |V_A'| - |V_A|
        fitted = _band_slope(sample.along.take(k), dv, sample.ac.take(k), sample.alt_ft.take(k), sample.flight.take(k))
        if fitted is None:
            continue
        slope, se, flights = fitted
        a = 1.0 - slope
        lo, hi = REFERENCE_RATIO_RANGE
        if lo <= a <= hi or abs(a - 1.0) < UNIT_SIGMAS * se or flights < MIN_UNIT_FLIGHTS:
            continue
        name = f" (reference '{ref.categories[c]}')" if len(ref.categories) > 1 else ""
        what = (
            f"the airspeed it implies (ground track minus its wind, wind paper eq. 4) changes by {slope:+.2f} ± "
            f"{se:.2g} kt per kt of the reported along-track wind over {flights} flights, as if the reference wind "
            f"were {a:.3f}x the wind"
        )
        if -hi <= a <= -lo:
            raise DataError(
                f"{source}: column 'ref_wind_dir_deg'{name}: {what}: a direction the wind blows to? "
                "expected the direction it blows from, as 'wind_dir_deg' (meteorological convention)"
            )
        if a > 0.3:
            raise DataError(
                f"{source}: column 'ref_wind_speed_kt'{name}: {what}: {_unit_named(a)}expected knots, as "
                "'wind_speed_kt'"
            )
        raise DataError(
            f"{source}: columns 'ref_wind_speed_kt', 'ref_wind_dir_deg'{name}: {what}, i.e. it does not "
            "follow the wind: check its speed unit (knots) and direction convention (degrees clockwise "
            "from north, where the wind blows from)"
        )


def heading_errors(obs: pd.DataFrame, gates: GateSpec | None = None, source: str = "observation table") -> pd.DataFrame:
    """One row per (report, reference model): ground track (three adjacent reports, gated),
    V_A (eq. 3), V_A' (eq. 4), heading error d = psi - psi' (deg), measured heading (true and,
    when available, magnetic), TAS, wind error V_W,TAM - V_W,REF; `gate` names the first
    failed gate ("used" for the rows the fit takes). Whole table, vectorised."""
    g = gates or GateSpec()
    df = obs if "time_s" in obs.columns and obs.attrs.get("source") else validate_observations(obs, source)
    ac = df["aircraft"].cat.codes.to_numpy()
    t = df["time_s"].to_numpy()
    n = len(df)
    new_rep = np.ones(n, dtype=bool)
    new_rep[1:] = (ac[1:] != ac[:-1]) | (t[1:] != t[:-1])
    rep_of_row = running_count(new_rep)
    rep_of_row -= 1
    first = np.flatnonzero(new_rep)
    m = len(first)
    rt, rac = t.take(first), ac.take(first)  # gathers (take: faster than fancy indexing)
    lat = df["lat"].to_numpy().take(first) * DEG
    lon = df["lon"].to_numpy().take(first) * DEG
    flight = report_flights(
        rac, rt, g.flight_gap_s, df["flight"].cat.codes.to_numpy().take(first) if "flight" in df.columns else None
    )
    cluster = report_clusters(flight, rt, g.cluster_s)
    track = ground_track(rt, lat, lon, flight, g)
    vg_e, vg_n, gate = track.vg_e, track.vg_n, track.gate.copy()
    # the aircraft's side, once per report (validate_observations checked its rows agree)
    wt_e, wt_n = towards_from_report(
        df["wind_speed_kt"].to_numpy().take(first), df["wind_dir_deg"].to_numpy().take(first)
    )
    va_e_r, va_n_r = vg_e - wt_e, vg_n - wt_n  # wind paper eq. 3
    psi = np.degrees(arctan2(va_e_r, va_n_r))
    psi += 360.0 * (psi < 0)
    heading = psi
    if "heading_deg" in df.columns:
        h = df["heading_deg"].to_numpy().take(first)
        heading = np.where(np.isfinite(h), wrap(h, 360.0), psi)
    src = df.attrs.get("source") or source
    ok = gate == 0
    sample = _Sample.of(ok, va_e_r, va_n_r, wt_e, wt_n, rac, df["pressure_altitude_ft"].to_numpy().take(first), flight)
    _check_wind_units(sample, src)
    if "heading_deg" in df.columns:
        _check_heading_column(h, psi, df["aircraft"].cat.categories, sample, src)
    tas = hypot(va_e_r, va_n_r)
    if "tas_kt" in df.columns:
        tk = df["tas_kt"].to_numpy().take(first) * KT
        _check_tas_units(tk, tas, ok, src)
        tas = np.where(np.isfinite(tk), tk, tas)
    heading_mag = np.full(m, np.nan)
    if "declination_deg" in df.columns:
        heading_mag = wrap(heading - df["declination_deg"].to_numpy().take(first), 360.0)
    if "heading_mag_deg" in df.columns:
        hm = df["heading_mag_deg"].to_numpy().take(first)
        heading_mag = np.where(np.isfinite(hm), wrap(hm, 360.0), heading_mag)
    # per (report, model) row: V_A' = V_G - V_W,REF = V_A + dw with dw = V_W,TAM - V_W,REF
    # (eqs. 3, 4), so d = angle(V_A) - angle(V_A') from V_A and dw alone (_row_errors)
    wr_e, wr_n = towards_from_report(df["ref_wind_speed_kt"].to_numpy(), df["ref_wind_dir_deg"].to_numpy())
    _check_reference_units(sample, wt_e, wt_n, wr_e, wr_n, first, rep_of_row, df["ref_source"].array, src)
    va_e, va_n, dw_e, dw_n, d = _row_errors(rep_of_row, va_e_r, va_n_r, wt_e, wt_n, wr_e, wr_n)
    implausible = GATE_NAMES.index("implausible")
    with np.errstate(invalid="ignore"):  # TAS per report, |d| per row
        gate[ok & ~((tas >= g.min_tas_kt * KT) & (tas <= g.max_tas_kt * KT))] = implausible
        row_gate = gate.take(rep_of_row)
        row_gate[(row_gate == 0) & ~(np.abs(d) <= g.max_heading_error_deg)] = implausible
    tas = tas.take(rep_of_row)
    true_input = (
        (df["heading_input"] == "true").to_numpy() if "heading_input" in df.columns else np.zeros(n, dtype=bool)
    )
    out = pd.DataFrame(
        copy=False,
        data={  # copy=False: not consolidated into one block (a full copy)
            "aircraft": df["aircraft"].array,
            "ref_source": df["ref_source"].array,
            "flight": flight.take(rep_of_row),
            "cluster": cluster.take(rep_of_row),
            "report": rep_of_row,
            "time_s": t,
            "heading_deg": heading.take(rep_of_row),
            "heading_mag_deg": heading_mag.take(rep_of_row),
            "error_deg": d,
            "tas_ms": tas,
            "va_e": va_e,
            "va_n": va_n,
            "dw_e": dw_e,
            "dw_n": dw_n,
            # pandas-stubs want an Index for `categories`; pandas takes any list-like
            "gate": pd.Categorical.from_codes(row_gate, GATE_NAMES),  # type: ignore[call-overload]
            "true_heading_input": true_input,
        },
    )
    out.attrs.update(df.attrs)
    return out


@njit(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")
def _row_errors(
    rep: np.ndarray,
    va_e_r: np.ndarray,
    va_n_r: np.ndarray,
    wt_e: np.ndarray,
    wt_n: np.ndarray,
    wr_e: np.ndarray,
    wr_n: np.ndarray,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per (report, model) row i of report rep[i]: V_A (eq. 3, the report's), dw = V_W,TAM -
    V_W,REF and d = psi - psi' (deg, (-180, 180]): the angle from V_A' = V_A + dw (eq. 4) to
    V_A, clockwise, atan2 of cross(V_A', V_A) = va_e dw_n - va_n dw_e and
    dot(V_A', V_A) = |V_A|^2 + V_A . dw."""
    n = len(rep)
    va_e, va_n, dw_e, dw_n, d = np.empty(n), np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    for i in range(n):
        j = rep[i]
        ae, an = va_e_r[j], va_n_r[j]
        we, wn = wt_e[j] - wr_e[i], wt_n[j] - wr_n[i]
        va_e[i], va_n[i], dw_e[i], dw_n[i] = ae, an, we, wn
        d[i] = math.degrees(atan2_scalar(ae * wn - an * we, ae * ae + an * an + ae * we + an * wn))
    return va_e, va_n, dw_e, dw_n, d
