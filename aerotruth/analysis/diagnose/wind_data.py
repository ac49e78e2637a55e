"""The data of `aerotruth diagnose` on an observation table: the gated (report, reference)
rows of the wind paper's section 5.1 (`aerotruth.analysis.wind.heading_errors`) split into the
transverse and along-heading air-vector differences, with the covariates the effects and
the screening need (IGRF horizontal field and declination change, phase, turn rate, folds).
See aerotruth.analysis.diagnose.wind for the method."""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import sparse

from aerotruth.analysis.wind.heading_errors import (
    TRACK_GATES,
    GateSpec,
    heading_errors,
    position_step_deg,
    segment_displacements,
    towards_from_report,
    wgs84_radii,
)
from aerotruth.analysis.wind.observations import validate_observations
from aerotruth.errors import DataError
from aerotruth.units import DEG, FT, KT

Q_REF = (250.0 * KT) ** 2  # sigma TAS^2 of 250 kt at sea level (m2/s2): the unit of inv_q
DECL_SPAN_YR = 5.0  # secular variation of the declination averaged over the 5 years before the data

# ----------------------------------------------------------------------------- data


@dataclass
class WindData:
    """The gated (report, reference) rows with everything the model and the effects need."""

    aircraft: np.ndarray  # int codes
    names: list[str]
    source: np.ndarray  # int codes
    sources: list[str]
    flight: np.ndarray  # global flight id
    time_s: np.ndarray
    z: np.ndarray  # measured heading, rad (true)
    z_mag: np.ndarray  # the magnetic heading it was made from, rad: z less the IGRF declination at the row
    tas: np.ndarray  # m/s
    trans: np.ndarray  # m/s
    along: np.ndarray  # m/s
    wref_e: np.ndarray  # unit vector along the wind for a reference bias: the other references' mean (0 where calm)
    wref_n: np.ndarray
    wref_speed: np.ndarray  # m/s: that wind's speed (a reference's scale error is proportional to it)
    report: np.ndarray  # the row's report (rows of one report, one per reference, share it)
    wobs_e: np.ndarray  # the aircraft's reported wind, m/s towards east and north (its errors are the aircraft's)
    wobs_n: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    alt_ft: np.ndarray
    h_ratio: np.ndarray  # H0 / H
    tan_dip: np.ndarray  # Z / H = tan of the field's dip (IGRF): a tilted valve reads this much of Z per radian
    sv_deg_yr: np.ndarray  # declination change per year (IGRF, 5 years before the data)
    roll: np.ndarray | None
    phase: np.ndarray  # "ascent", "descent" or "level" per row
    turn_deg_s: np.ndarray  # heading change between the report's neighbours (its own heading left out)
    tas_rate: np.ndarray  # dTAS/dt (m/s^2) between the report's neighbours (its own TAS left out)
    # d/dt of the wind (m/s^2, east and north) between the report's neighbours, from the other
    # references' winds (the row's own reference error left out; one reference: the report's)
    wind_rate_e: np.ndarray
    wind_rate_n: np.ndarray
    climb_fpm: np.ndarray  # pressure-altitude rate from the previous report of the flight (0 at the first)
    fpa_deg: np.ndarray  # flight-path angle through the air, asin(climb rate / TAS), climb rate centred on the report
    inv_q: np.ndarray  # Q_REF / q, q = sigma(h) TAS^2: the angle of attack's shape at one weight
    inv_q_cruise: np.ndarray  # q_cruise / q: the angle of attack's shape at one cruise lift coefficient (1 at cruise)
    local_hour: np.ndarray  # local solar hour, UTC + lon / 15
    cluster: np.ndarray  # the unit of every test the row belongs to: its flight or its flight's weather block (`unit`)
    fold: np.ndarray  # 0 .. N_FOLDS - 1: unit k (in time order) in fold k mod N_FOLDS
    block: np.ndarray  # weather block of the row's flight (the fleet's contrasts compare aircraft within one)
    unit: str  # "flight" or "weather block": what `cluster` counts (dependence_units)
    sharing: dict  # the test of reference error shared between flights that chose it (reference_sharing)
    track_span_s: np.ndarray  # time between the two reports the row's ground velocity is taken over (its neighbours)
    position_step_deg: float  # the reports' lat/lon resolution read off the values (0: not rounded)
    report_lat: np.ndarray  # every report (not only gated), for the quantization
    report_lon: np.ndarray
    jitter: dict  # ground-track jitter of the reports (segment velocity differences)
    table: dict = field(default_factory=dict)  # what was read and what was left out, counted (rows, reports, gates)

    @property
    def n(self) -> int:
        return len(self.trans)


WEATHER_BLOCK_S = 6 * 3600.0  # twice the weather models' error correlation time (3 h: RR, RTFDDA presets)
# held-out folds: weather block k goes to fold k mod N_FOLDS, so each fit that predicts a fold
# learns on the other (N_FOLDS - 1) / N_FOLDS of the data, spread over the whole period. With
# two folds an effect found per aircraft by a scan (a recalibration's step, a drifting offset)
# was re-found on half the flights only, and a step of p 2e-5 on all the data predicted the
# held-out half worse than no step (validation/diagnose_confusion_plan.md)
N_FOLDS = 5


def flight_mid_times(flight: np.ndarray, time_s: np.ndarray) -> pd.Series:
    """Each flight's mid-time (s), halfway between its first and last row, indexed by flight id
    (sorted): what places a flight in its weather block and in time among the others."""
    fl = pd.Series(time_s).groupby(flight)
    return (fl.min() + fl.max()) / 2.0


def weather_blocks(flight: np.ndarray, time_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(cluster, fold) per row. A reference model's analysis error is one field over the
    region, correlated for hours and hundreds of km (aerotruth.sensors.weather_model), so
    the flights of every aircraft in the same hours share it: flights are not independent,
    blocks of WEATHER_BLOCK_S are (nearly). Each flight goes whole to the block of its
    mid-time; the tests cluster on blocks and the held-out folds take every N_FOLDS-th block."""
    mid = flight_mid_times(flight, time_s)
    block_of_flight = np.floor(mid / WEATHER_BLOCK_S).astype(np.int64)
    blocks = block_of_flight.reindex(flight).to_numpy()
    order = np.unique(blocks)
    cluster = np.searchsorted(order, blocks)
    return cluster, (cluster % N_FOLDS).astype(np.int8)


# the reference models' differences must show no error shared between flights at this level
# before flights are the tests' units: a test that keeps weather blocks on doubt (at 0.1 it
# chooses flights in nine of ten datasets without sharing) and needs evidence of absence
# only where it has the data to see sharing (at least MIN_SHARING_BLOCKS weather blocks)
SHARING_LEVEL = 0.1
MIN_SHARING_BLOCKS = 20  # the tests' own floor of independent clusters (wind.MIN_BLOCKS)
SHARING_WINDOW_S = WEATHER_BLOCK_S / 2  # flights whose mid-times are closer are compared
SHARING_DRAWS = 1999
SHARING_SEED = 20261130
SHARING_COMPONENTS = ("east", "north", "along the wind", "across the wind")


def reference_sharing(
    rep: np.ndarray,
    src: np.ndarray,
    flight: np.ndarray,
    time_s: np.ndarray,
    ref_e: np.ndarray,
    ref_n: np.ndarray,
) -> dict:
    """Whether the reference models' errors are shared between flights, from the differences
    of two reference models' winds at the same report (per row: report id, reference code,
    flight, time, the reference's wind east and north in m/s).

    A difference W_a - W_b carries no aircraft error and no heading effect: only the two
    analyses' errors e_a - e_b. Each pair's systematic part is fitted out first (a constant
    vector, an offset along the mean wind, a scale of it: a reference bias hidden in the data
    would otherwise look like sharing). Each flight's mean remaining difference in each
    component c (east, north, along the pair's mean wind, across it: a field error shows in
    the first two, an error of the wind's speed along every flight's own wind in the third),
    v_f,c (every pair of references side by side), enters

        S_c = sum over flights f != g with |mid_f - mid_g| < T of (1 - |mid_f - mid_g| / T) v_f,c . v_g,c,
        T = SHARING_WINDOW_S (3 h, the weather models' error correlation time),

    and the test's statistic is the largest of the S_c over their standard deviations under
    the null. The null (no error shared between flights: the v_f independent and symmetric)
    is that statistic with every flight's sign flipped at random, the same flips for every
    component (exact for any distribution of the v_f; the p-value from SHARING_DRAWS flips of
    a fixed stream; one-sided: sharing makes S_c positive). Also given: the component, z
    (its S_c over the sign-flip standard deviation) and rho (the weighted mean correlation of
    the compared flights' v_c: S_c over the same weighted sum of |v_f,c| |v_g,c|).

    What it cannot see: an error both references make alike (their common part cancels in
    the difference; two analyses that assimilate the same observations share some), and an
    error of the aircraft's own that persists from one flight to the next (a change in time
    of its heading offset is an effect the diagnosis tests, not noise)."""
    srcs = np.unique(src)
    if len(srcs) < 2:
        return {"tested": False, "why": "one reference model: nothing to compare its errors with"}
    reps, ri = np.unique(rep, return_inverse=True)
    n_src = int(src.max()) + 1
    W = np.full((len(reps), n_src, 2), np.nan)
    W[ri, src, 0], W[ri, src, 1] = ref_e, ref_n
    fl = np.empty(len(reps), dtype=flight.dtype)
    fl[ri] = flight
    flights, fi = np.unique(fl, return_inverse=True)
    F = len(flights)
    mid = flight_mid_times(flight, time_s).reindex(flights).to_numpy()
    parts = []
    for a in range(n_src):
        for b in range(a + 1, n_src):
            ok = np.isfinite(W[:, a, 0]) & np.isfinite(W[:, b, 0])
            m = int(ok.sum())
            if m < 20:
                continue
            diff, mean = W[ok, a] - W[ok, b], 0.5 * (W[ok, a] + W[ok, b])
            sp = np.hypot(mean[:, 0], mean[:, 1])
            unit = np.divide(mean, sp[:, None], out=np.zeros_like(mean), where=sp[:, None] > 0)
            X = np.zeros((2 * m, 4))
            X[:m, 0], X[m:, 1] = 1.0, 1.0
            X[:, 2], X[:, 3] = np.r_[unit[:, 0], unit[:, 1]], np.r_[mean[:, 0], mean[:, 1]]
            y = np.r_[diff[:, 0], diff[:, 1]]
            res = y - X @ np.linalg.lstsq(X, y, rcond=None)[0]
            re_, rn_ = res[:m], res[m:]
            cnt = np.bincount(fi[ok], minlength=F)
            # east, north, along the wind, across it: a field error shows in the first two, an
            # error of the wind's speed (the same along every flight's own wind) in the third
            for c in (re_, rn_, re_ * unit[:, 0] + rn_ * unit[:, 1], rn_ * unit[:, 0] - re_ * unit[:, 1]):
                parts.append(np.divide(np.bincount(fi[ok], c, minlength=F), cnt, out=np.zeros(F), where=cnt > 0))
    if not parts:
        return {"tested": False, "why": "fewer than 20 reports carry two reference models"}
    V = np.column_stack(parts)
    order = np.argsort(mid, kind="stable")
    lo = np.searchsorted(mid[order], mid[order] - SHARING_WINDOW_S, side="right")
    hi = np.searchsorted(mid[order], mid[order] + SHARING_WINDOW_S, side="left")
    i = np.repeat(np.arange(F), hi - lo)
    j = np.concatenate([np.arange(a_, b_) for a_, b_ in zip(lo, hi, strict=True)]) if F else np.zeros(0, int)
    keep = i != j
    fi_, fj = order[i[keep]], order[j[keep]]
    if len(fi_) == 0:
        return {"tested": False, "why": "no two flights within the window"}
    # Bartlett weights: the closer in time, the more a pair counts (an error correlated for
    # hours is shared most by flights in the same hour)
    w = 1.0 - np.abs(mid[fi_] - mid[fj]) / SHARING_WINDOW_S
    rng = np.random.default_rng(SHARING_SEED)
    E = rng.choice(np.array([-1.0, 1.0]), size=(SHARING_DRAWS, F))
    z_obs, z_null, rho = [], [], []
    for k, name in enumerate(SHARING_COMPONENTS):  # each component's statistic over its sign-flip sd
        Vk = V[:, k::4]
        a_ij = np.einsum("ij,ij->i", Vk[fi_], Vk[fj]) * w
        sd = float(np.sqrt(2.0 * np.sum(a_ij**2)))  # the sign-flip null's exact standard deviation
        if sd <= 0:
            continue
        A = sparse.csr_matrix((a_ij, (fi_, fj)), shape=(F, F))
        z_obs.append(float(a_ij.sum()) / sd)
        z_null.append(np.einsum("df,df->d", (A @ E.T).T, E) / sd)
        norms = np.linalg.norm(Vk, axis=1)
        scale = float(np.sum(norms[fi_] * norms[fj] * w))
        rho.append((name, float(a_ij.sum()) / scale if scale > 0 else 0.0))
    if not z_obs:
        return {"tested": False, "why": "the references' differences are all explained by their offsets and scales"}
    observed = max(z_obs)
    null = np.max(np.array(z_null), axis=0)  # the largest component's, under the same flips
    p = (1 + int(np.sum(null >= observed - 1e-12 * max(abs(observed), 1.0)))) / (1 + SHARING_DRAWS)
    k = int(np.argmax(z_obs))
    return {
        "tested": True,
        "p": float(p),
        "z": observed,
        "component": rho[k][0],
        "rho": rho[k][1],
        "flights": int(F),
        "pairs": int(len(fi_) // 2),
        "reference_pairs": len(parts) // 4,
    }


def dependence_units(flight: np.ndarray, time_s: np.ndarray, block: np.ndarray, sharing: dict) -> tuple:
    """(cluster, fold, unit) per row: the tests' independent units. Flights where the data
    span at least MIN_SHARING_BLOCKS weather blocks and the reference models' differences show
    no error shared between flights (reference_sharing, p >= SHARING_LEVEL): then each
    flight's errors are its own, and the tests gain the units (and the degrees of freedom)
    that 6-h blocks pool. Else the weather blocks: an analysis error is one field over the
    region, and flights in the same hours share it (or no test could say they do not)."""
    n_blocks = len(np.unique(block))
    if n_blocks >= MIN_SHARING_BLOCKS and sharing.get("tested") and sharing["p"] >= SHARING_LEVEL:
        mid = flight_mid_times(flight, time_s)
        rank = pd.Series(np.argsort(np.argsort(mid.to_numpy(), kind="stable")), index=mid.index)
        cluster = rank.reindex(flight).to_numpy()
        return cluster, (cluster % N_FOLDS).astype(np.int8), "flight"
    return block, (block % N_FOLDS).astype(np.int8), "weather block"


def unit_words(d: WindData) -> str:
    """The tests' units in words (plural)."""
    return "flights" if d.unit == "flight" else "6-h weather blocks"


def units_reason(d: WindData) -> str:
    """Why the tests' units are what they are, in one clause."""
    sh = d.sharing
    if d.unit == "flight":
        return (
            f"the reference models' differences show no error shared between flights (p {sh['p']:.2g}, "
            f"{sh['pairs']} pairs of flights within {SHARING_WINDOW_S / 3600:g} h)"
        )
    if not sh.get("tested"):
        return f"reference error shared between flights could not be tested: {sh['why']}"
    if len(np.unique(d.block)) < MIN_SHARING_BLOCKS:
        return f"too few weather blocks to test for reference error shared between flights (< {MIN_SHARING_BLOCKS})"
    return (
        f"the reference models' differences show error shared between flights (p {sh['p']:.2g}, "
        f"correlation {sh['rho']:.2f} between flights within {SHARING_WINDOW_S / 3600:g} h)"
    )


def _field_covariates(lat, lon, alt_ft, when: dt.datetime) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(H0 / H, the declination's change in deg per year, the declination in deg, Z / H) per
    row: IGRF at the data's median date."""
    from aerotruth.sensors.magnetics import GeomagneticField

    f = GeomagneticField.covering(lat, lon, when, margin_deg=1.0, step_deg=0.5, h_m=(-1000.0, 16000.0))
    h_m = np.clip(np.asarray(alt_ft) * FT, -900.0, 15900.0)
    now = f.at(lat, lon, h_m)
    before = f.for_date(when - dt.timedelta(days=365.25 * DECL_SPAN_YR)).at(lat, lon, h_m)
    H = now.horizontal_nT
    sv = np.degrees(((now.declination_rad - before.declination_rad + np.pi) % (2 * np.pi)) - np.pi) / DECL_SPAN_YR
    return np.median(H) / H, sv, np.degrees(now.declination_rad), now.down_nT / H


def _report_rows(df: pd.DataFrame) -> np.ndarray:
    """Index of each report's first row (a report has one row per reference model)."""
    ac, t = df["aircraft"].cat.codes.to_numpy(), df["time_s"].to_numpy()
    return np.flatnonzero(np.r_[True, (ac[1:] != ac[:-1]) | (np.diff(t) != 0)])


def heading_components(e: np.ndarray, n: np.ndarray, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A vector's (east, north) components on the (transverse, along) frame of heading z
    (radians from true north): transverse on (cos z, -sin z), along on (sin z, cos z), the
    frame of the residual's two channels (wind.py's module docstring)."""
    c, s = np.cos(z), np.sin(z)
    return e * c - n * s, e * s + n * c


def metres_per_degree(lat_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(north, east) metres per degree of latitude and of longitude at each latitude on
    WGS-84 (M and N cos(lat) times pi/180): a position grid's steps in metres, for the
    rounding of the reports' positions (the quantization check's jitter and the weighted
    fit's rounding variance, wind_weights)."""
    lat = np.asarray(lat_deg, dtype=float)
    rm, rn = wgs84_radii(lat * DEG)
    return rm * DEG, rn * np.cos(lat * DEG) * DEG


def _jitter(df: pd.DataFrame, first: np.ndarray) -> dict:
    """Differences of adjacent segment velocities (m/s, per component) at every interior
    report of level flight (`first`: the reports' rows), with c = 1/dt2^2 + (1/dt1 + 1/dt2)^2
    + 1/dt1^2 (the factor of a position-noise variance) and the report's radii per degree
    (for the grid's metres)."""
    ac = df["aircraft"].cat.codes.to_numpy()[first]
    t = df["time_s"].to_numpy()[first]
    lat, lon = df["lat"].to_numpy()[first], df["lon"].to_numpy()[first]
    alt = df["pressure_altitude_ft"].to_numpy()[first]
    m_lat, m_lon = metres_per_degree(lat)  # of the reports' grid
    # segment velocities as the wind paper's ground track has them (one displacement per segment,
    # at its mid latitude: metres from per-point scales, lon x m_lon(lat), carried lon x dm_lon)
    de, dn = segment_displacements(lat * DEG, lon * DEG)
    ok = (
        (ac[2:] == ac[:-2])
        & (np.diff(t)[:-1] > 0)
        & (np.diff(t)[1:] > 0)
        & (np.diff(t)[:-1] <= 600)
        & (np.diff(t)[1:] <= 600)
    )
    ok &= np.abs(alt[2:] - alt[:-2]) < 100.0  # level: the true velocity changes little
    dt1, dt2 = np.diff(t)[:-1], np.diff(t)[1:]
    with np.errstate(divide="ignore", invalid="ignore"):
        v1 = np.column_stack([de[:-1] / dt1, dn[:-1] / dt1])
        v2 = np.column_stack([de[1:] / dt2, dn[1:] / dt2])
        c = 1 / dt2**2 + (1 / dt1 + 1 / dt2) ** 2 + 1 / dt1**2
    dv = (v2 - v1)[ok]
    speed = np.hypot(*v1[ok].T)
    ok2 = np.all(np.isfinite(dv), axis=1) & (speed > 30.0) & (np.hypot(*dv.T) < 0.3 * speed)  # turns are not jitter
    return {
        "dv": dv[ok2],
        "c": c[ok][ok2],
        "m_lat": m_lat[1:-1][ok][ok2],
        "m_lon": m_lon[1:-1][ok][ok2],
        "aircraft": ac[1:-1][ok][ok2],
    }


def isa_density_ratio(alt_ft: np.ndarray) -> np.ndarray:
    """ISA density ratio sigma at pressure altitude (ft): troposphere (1 - 6.87559e-6 h)^4.25588,
    above 36,089 ft 0.29707 exp(-(h - 36,089) / 20,806) (ICAO standard atmosphere)."""
    h = np.asarray(alt_ft, dtype=float)
    tropo = np.clip(1.0 - 6.87559e-6 * np.minimum(h, 36089.0), 1e-6, None) ** 4.25588
    return np.where(h <= 36089.0, tropo, 0.29707 * np.exp(-(h - 36089.0) / 20806.0))


def report_rates(flight: np.ndarray, t: np.ndarray, z: np.ndarray, alt_ft: np.ndarray):
    """Per report (in time order within flights): (turn rate deg/s, climb rate ft/min from the
    previous report, climb rate ft/min centred on the report).

    The turn rate is the heading change between the report's two neighbours,
    (z[k+1] - z[k-1]) / (t[k+1] - t[k-1]), 0 where a neighbour is missing. The report's own
    heading is left out on purpose: its error is in the transverse residual (TAS sin d), so
    a rate built from it (z[k] - z[k-1]) carries +sigma_z^2 / dt of covariance with the
    residual whatever the aircraft does (errors in variables: 0.3 deg of white heading noise
    and reports 3-7 min apart made a straight-flying fleet "turn-dependent" at p 3e-9). The
    neighbours' errors are independent of it (white between reports; for errors correlated
    in time, cov(e[k+1] - e[k-1], e[k]) = rho(dt+) - rho(dt-), zero on average over the
    intervals). Altitudes do not enter the residual, so the climb rates may use report k."""
    n = len(t)
    prev_ok = np.r_[False, (flight[1:] == flight[:-1]) & (np.diff(t) > 0)]
    next_ok = np.r_[prev_ok[1:], False]
    zp, zn = np.r_[z[:1], z[:-1]], np.r_[z[1:], z[-1:]]
    tp, tn = np.r_[t[:1], t[:-1]], np.r_[t[1:], t[-1:]]
    ap = np.r_[alt_ft[:1], alt_ft[:-1]]
    both = prev_ok & next_ok
    with np.errstate(invalid="ignore", divide="ignore"):
        dz = np.degrees((zn - zp + np.pi) % (2 * np.pi) - np.pi)
        turn = np.where(both, dz / (tn - tp), 0.0)
        rate = np.where(prev_ok, (alt_ft - ap) / (t - tp) * 60.0, 0.0)
    rate_c = neighbour_rate(flight, t, alt_ft) * 60.0
    assert len(turn) == n
    return turn, rate, rate_c


def neighbour_rate(flight: np.ndarray, t: np.ndarray, x: np.ndarray) -> np.ndarray:
    """Per report (in time order within flights): (x[k+1] - x[k-1]) / (t[k+1] - t[k-1]), the
    rate of x between the report's neighbours; at a flight's first or last report the
    one-sided rate with the report itself, 0 for a flight of one report. For the TAS rate
    of the acceleration error: the report's own TAS error is in the along residual, and it
    enters the transverse residual only as TAS sin d (d the heading error, a few
    hundredths of a radian), so the transverse test may use it where a neighbour is
    missing. For the wind's rate: the other references' winds, whose errors are not the
    row's (at a flight's ends the one-sided rate carries them at the report itself, still
    not the row's own reference error)."""
    prev_ok = np.r_[False, (flight[1:] == flight[:-1]) & (np.diff(t) > 0)]
    next_ok = np.r_[prev_ok[1:], False]
    xp, xn = np.r_[x[:1], x[:-1]], np.r_[x[1:], x[-1:]]
    tp, tn = np.r_[t[:1], t[:-1]], np.r_[t[1:], t[-1:]]
    lo, hi = np.where(prev_ok, tp, t), np.where(next_ok, tn, t)
    x_lo, x_hi = np.where(prev_ok, xp, x), np.where(next_ok, xn, x)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(hi > lo, (x_hi - x_lo) / (hi - lo), 0.0)


def _track_spans(rows: pd.DataFrame) -> np.ndarray:
    """Per report (heading_errors' `report` index, time order within each flight): the time
    between its neighbours, t[k+1] - t[k-1], the span its ground velocity is taken over
    (ground_track); NaN at a flight's ends (gated out there)."""
    per = rows.groupby("report", sort=True)[["time_s", "flight"]].first()
    t, fl = per["time_s"].to_numpy(), per["flight"].to_numpy()
    out = np.full(len(t), np.nan)
    if len(t) >= 3:
        inner = (fl[2:] == fl[1:-1]) & (fl[:-2] == fl[1:-1])
        out[1:-1] = np.where(inner, t[2:] - t[:-2], np.nan)
    full = np.full(int(per.index.max()) + 1 if len(per) else 0, np.nan)
    full[per.index.to_numpy()] = out
    return full


def track_gates(df: pd.DataFrame) -> GateSpec:
    """TRACK_GATES with the shortest span scaled to the reports' position resolution (read off
    the values, heading_errors.position_step_deg): 10 km for TAMDAR's 0.01 deg, in proportion
    for finer steps (V_G's rounding error over the span stays the same fraction), from 0.1 km
    for positions rounded to 1e-4 deg or not at all (decoded Mode-S: CPR's ~5 m)."""
    step = max(position_step_deg(df["lat"].to_numpy(), df["lon"].to_numpy()), 1e-4)
    return TRACK_GATES.model_copy(update={"min_baseline_km": TRACK_GATES.min_baseline_km * min(step / 0.01, 1.0)})


def prepare(obs: pd.DataFrame, source: str = "observation table", gates: GateSpec | None = None) -> WindData:
    """Observation table -> WindData (gated rows of the wind paper's section 5.1)."""
    df = validate_observations(obs, source)
    for col in ("wind_dir_deg", "ref_wind_dir_deg", "heading_deg"):  # units guessed from the range
        if col in df.columns and len(df) >= 20:
            v = df[col].to_numpy()
            v = v[np.isfinite(v)]
            if len(v) >= 20 and v.max() <= 2 * np.pi + 1e-6:
                raise DataError(
                    f"{source}: column '{col}' lies within [0, {v.max():.2f}]: radians? expected degrees 0-360"
                )
    alt = df["pressure_altitude_ft"].to_numpy()
    alt = alt[np.isfinite(alt)]
    if len(alt) >= 20 and 100.0 <= alt.min() and alt.max() <= 1100.0 and alt.max() - alt.min() >= 300.0:
        # reports from near the ground to cruise span thousands of feet; 100-1100 is a pressure
        raise DataError(
            f"{source}: column 'pressure_altitude_ft' lies within [{alt.min():.0f}, {alt.max():.0f}]: "
            f"pressure in hPa? expected feet"
        )
    rows = heading_errors(df, track_gates(df) if gates is None else gates, source)
    used = (rows["gate"] == "used").to_numpy()
    if used.sum() < 20:
        counts = rows["gate"].value_counts().to_dict()
        raise DataError(
            f"{source}: only {int(used.sum())} report rows pass the ground-track gates (need 20); gates: {counts}"
        )
    r = rows[used]
    span = _track_spans(rows)[r["report"].to_numpy()]
    table = {
        "rows_read": int(len(obs)),
        "rows_dropped_empty": int(df.attrs.get("dropped_empty", 0)),
        "rows_dropped_duplicate": int(df.attrs.get("dropped_duplicates", 0)),
        "reports": int(rows["report"].nunique()),
        "row_gates": {str(k): int(v) for k, v in rows["gate"].value_counts().items() if v},
    }
    z = r["heading_deg"].to_numpy() * DEG
    dv_e, dv_n = -r["dw_e"].to_numpy(), -r["dw_n"].to_numpy()
    trans, _ = heading_components(dv_e, dv_n, z)
    # along: |V_A| - |V_A'|, not the projection on the heading, which carries TAS (1 - cos d)
    # of the heading error d itself (~1.5 kt at 6 deg: measured as a bias of the reference test)
    va_e, va_n = r["va_e"].to_numpy(), r["va_n"].to_numpy()
    along = np.hypot(va_e, va_n) - np.hypot(va_e - dv_e, va_n - dv_n)
    # the direction "along the wind" for a reference's row: the mean of the *other* references
    # at the same report (their errors are independent of this one's; its own direction would
    # tilt towards its own error, a bias of ~sigma^2/|W|), else the aircraft's reported wind
    # (tilted by the aircraft's heading deviation: TAS x 3 deg is ~15 kt, which attenuates)
    re_, rn_ = towards_from_report(df["ref_wind_speed_kt"].to_numpy()[used], df["ref_wind_dir_deg"].to_numpy()[used])
    rep = r["report"].to_numpy()
    g = pd.DataFrame({"rep": rep, "e": re_, "n": rn_})
    tot = g.groupby("rep")[["e", "n"]].transform("sum").to_numpy()
    cnt = g.groupby("rep")["e"].transform("size").to_numpy()
    wobs_e, wobs_n = towards_from_report(df["wind_speed_kt"].to_numpy()[used], df["wind_dir_deg"].to_numpy()[used])
    we, wn = wobs_e, wobs_n
    with np.errstate(invalid="ignore", divide="ignore"):
        others = cnt > 1
        we = np.where(others, (tot[:, 0] - re_) / (cnt - 1), we)
        wn = np.where(others, (tot[:, 1] - rn_) / (cnt - 1), wn)
    sp = np.hypot(we, wn)
    with np.errstate(invalid="ignore", divide="ignore"):
        ue, un = np.where(sp > 0, we / sp, 0.0), np.where(sp > 0, wn / sp, 0.0)
    # the wind's rate of change along each flight, per reference series: between the report's
    # neighbours, of the same wind the reference-bias direction uses (wind_model: wind_rate)
    flight, t = r["flight"].to_numpy(), r["time_s"].to_numpy()
    src_cat = (
        r["ref_source"].astype("category").cat.remove_unused_categories()
    )  # not the empty cells' fill "ref" when none is
    src_codes = src_cat.cat.codes.to_numpy()
    wind_rate_e, wind_rate_n = np.zeros(len(we)), np.zeros(len(we))
    for code in np.unique(src_codes):
        rows_m = np.flatnonzero(src_codes == code)
        rows_m = rows_m[np.lexsort((t[rows_m], flight[rows_m]))]
        wind_rate_e[rows_m] = neighbour_rate(flight[rows_m], t[rows_m], we[rows_m])
        wind_rate_n[rows_m] = neighbour_rate(flight[rows_m], t[rows_m], wn[rows_m])
    lat, lon = df["lat"].to_numpy()[used], df["lon"].to_numpy()[used]
    alt = df["pressure_altitude_ft"].to_numpy()[used]
    when = dt.datetime(1970, 1, 1) + dt.timedelta(seconds=float(np.median(t)))
    h_ratio, sv, decl, tan_dip = _field_covariates(lat, lon, alt, when)
    ac_cat = r["aircraft"].astype("category")
    names = [str(c) for c in ac_cat.cat.categories]
    ac = ac_cat.cat.codes.to_numpy()
    block, _ = weather_blocks(flight, t)
    sharing = reference_sharing(rep, src_codes, flight, t, re_, rn_)
    cluster, fold, unit = dependence_units(flight, t, block, sharing)
    # turn rate, flight phase and flight-path angle from a flight's adjacent (used) reports,
    # per report, then back on its rows
    per = pd.DataFrame({"z": z, "t": t, "f": flight, "alt": alt, "tas": r["tas_ms"].to_numpy()}).groupby(rep).first()
    turn_rep, rate, rate_c = report_rates(
        per["f"].to_numpy(), per["t"].to_numpy(), per["z"].to_numpy(), per["alt"].to_numpy()
    )
    tas_rate_rep = neighbour_rate(per["f"].to_numpy(), per["t"].to_numpy(), per["tas"].to_numpy())
    ph_rep = np.where(rate > 300.0, "ascent", np.where(rate < -300.0, "descent", "level"))
    back = per.index.get_indexer(pd.Index(rep))  # (what get_indexer makes of an array itself)
    turn, phase, climb, tas_rate = turn_rep[back], ph_rep[back], rate[back], tas_rate_rep[back]
    tas = r["tas_ms"].to_numpy()
    fpa = np.degrees(np.arcsin(np.clip(rate_c[back] * FT / 60.0 / np.maximum(tas, 1.0), -1.0, 1.0)))
    q = isa_density_ratio(alt) * tas**2
    # the angle of attack is alpha0 + (W/S) / (CL_alpha q): at one weight it scales as 1/q
    # (q_ref / q, q_ref the dynamic pressure of 250 kt at sea level). A flight's weight is
    # unknown: a jet cruising at the level chosen for its weight flies near one lift
    # coefficient, so its cruise angle is about the same from flight to flight (q_cruise / q,
    # q_cruise the flight's median q in level flight, its median q where it has none); a
    # turboprop on short sectors at the level the route allows flies at about one weight
    # (q_ref / q). The two span W/S = a + b q_cruise, both cases and those between.
    qs = pd.Series(q)
    q_level = qs.where(phase == "level").groupby(flight).transform("median")
    q_cruise = q_level.fillna(qs.groupby(flight).transform("median")).to_numpy()
    inv_q = Q_REF / np.maximum(q, 1e-6)
    inv_q_cruise = q_cruise / np.maximum(q, 1e-6)
    local_hour = (t % 86400.0 / 3600.0 + lon / 15.0) % 24.0
    roll = df["roll_deg"].to_numpy()[used] if "roll_deg" in df.columns else None
    first = _report_rows(df)
    return WindData(
        aircraft=ac,
        names=names,
        source=src_codes,
        sources=[str(c) for c in src_cat.cat.categories],
        flight=flight,
        time_s=t,
        z=z,
        z_mag=z - np.radians(decl),
        tas=r["tas_ms"].to_numpy(),
        trans=trans,
        along=along,
        wref_e=ue,
        wref_n=un,
        wref_speed=np.nan_to_num(sp),
        report=rep,
        wobs_e=wobs_e,
        wobs_n=wobs_n,
        lat=lat,
        lon=lon,
        alt_ft=alt,
        h_ratio=h_ratio,
        tan_dip=tan_dip,
        sv_deg_yr=sv,
        roll=roll,
        phase=phase,
        turn_deg_s=turn,
        tas_rate=tas_rate,
        wind_rate_e=wind_rate_e,
        wind_rate_n=wind_rate_n,
        climb_fpm=climb,
        fpa_deg=fpa,
        inv_q=inv_q,
        inv_q_cruise=inv_q_cruise,
        local_hour=local_hour,
        cluster=cluster,
        fold=fold,
        block=block,
        unit=unit,
        sharing=sharing,
        track_span_s=span,
        position_step_deg=position_step_deg(df["lat"].to_numpy()[first], df["lon"].to_numpy()[first]),
        report_lat=df["lat"].to_numpy()[first],
        report_lon=df["lon"].to_numpy()[first],
        jitter=_jitter(df, first),
        table=table,
    )
