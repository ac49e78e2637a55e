"""Flight-profile statistics of a trajectory as a surveillance receiver sees it, the same
for simulated and real flights, so that the truth can be put beside real traffic.

Input: a trajectory table with `time_s` (s), `altitude_ft` (barometric), `groundspeed_kt`,
`track_deg` (true), and where the source has them `latitude`, `longitude` (deg) and
`roll_deg`. Samples need not be regular; gaps longer than GAP_S split the trajectory into
pieces that are measured apart. Manoeuvring beyond any airline profile (a 30-s vertical
rate above 6,000 fpm, as in a parabolic flight) is left out with 2 min either side.
`with_position_track` puts the positions' track in place of a track column that is not the
track the positions fly. Every statistic is a set of samples (one per second, per window, per turn or per
approach, as named), so that two sources are compared as distributions (`compare`).

What each measures (all heights barometric, as Mode-S reports them):

* `climb_fpm` / `descent_fpm_*`: the vertical rate from the altitude over a centred 30-s
  window (the 25-ft altitude steps of Mode-S then cost < 60 fpm of noise), while climbing
  (> 300 fpm) between 1,500 and 10,000 ft, and while descending (< -300 fpm) at or above
  10,000 ft and between 2,000 and 10,000 ft. `climb_fpm_altitude_ft` pairs each climb
  sample with its altitude (how the rate falls with height: `climb_slope_fpm_per_kft`).
* `roll_abs_deg_above_10000ft`: |roll| at or above 10,000 ft (every sample);
  `roll_rate_deg_s`: |roll change| between samples exactly 1 s apart above 1,500 ft.
* `wander_rms_m`, `wander_max_m`: 600-s windows (stepped 300 s) flown straight (every
  track within 2 deg of the window's mean track; an airway's dogleg of a few degrees inside
  a window would otherwise count as hundreds of metres of wander): the great circle fitted to the positions
  (the plane through the Earth's centre nearest the points' unit vectors) and the rms and
  largest distance of the positions from it. A wander of amplitude A as cos(2 pi k t / T)
  over the window (whole periods) has rms A / sqrt(2): the fit takes out offset and
  heading only.
* `turn_bank_deg`: turns below 10,000 ft (above 1,000 ft) with the track rate above
  1 deg/s for at least 15 s: the median |roll| over the turn, or where there is no roll the
  coordinated bank atan(V omega / g) with the ground speed for V (the wind's part is then
  a bias of the size of wind / V).
* approaches (`approach_*`): every descent (30-s rate below -300 fpm for 60 s or more)
  that ends at a low point (the lowest height within 90 s, not undercut later, followed by
  the end of the data or a climb of 500 ft: a landing, a pass, a go-around) and whose
  last 500-1,950 ft above that point are flown straight (every track within 5 deg of the
  mean) for at least 60 s: the height
  against the distance flown (the integrated ground speed) fitted by a straight line: its
  angle (`approach_path_deg`), the 95th percentile and the largest |residual|
  (`approach_resid_p95_m`, `approach_resid_max_m`), and |roll| on that segment
  (`approach_roll_abs_deg`). The window is 500-1,950 ft above the low point: on a 3-deg
  path ending at the threshold, 1.5-6 nm from it; a pass or a go-around a few hundred feet
  up moves it by well under a mile. A barometric path angle is the geometric one times
  T_ISA / T (a warm day flattens it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import stats

from aerotruth.units import FT, KT

GAP_S = 10.0  # a longer gap between samples splits the trajectory
MANOEUVRE_FPM, MANOEUVRE_MARGIN_S = 6000.0, 120.0  # beyond any airline profile (a parabolic flight's pull-ups)
TRACK_AGREE_DEG = 5.0  # median |reported - position track| above this: the reported track is not the track
RATE_HALF_WINDOW_S = 15.0
G0 = 9.80665
EARTH_R_M = 6371008.8  # mean radius (IUGG): great-circle fits over 600 s
WINDOW_S, WINDOW_STEP_S, STRAIGHT_DEG = 600.0, 300.0, 2.0
TURN_RATE_DEG_S, TURN_MIN_S = 1.0, 15.0
FINAL_LOW_FT, FINAL_HIGH_FT, FINAL_STRAIGHT_DEG, FINAL_MIN_S = 500.0, 1950.0, 5.0, 60.0

REQUIRED = ("time_s", "altitude_ft", "groundspeed_kt", "track_deg")
SAMPLE_KEYS = (
    "climb_fpm",
    "climb_fpm_altitude_ft",
    "descent_fpm_above_10000ft",
    "descent_fpm_2000_10000ft",
    "roll_abs_deg_above_10000ft",
    "roll_rate_deg_s",
    "wander_rms_m",
    "wander_max_m",
    "turn_bank_deg",
    "approach_path_deg",
    "approach_resid_p95_m",
    "approach_resid_max_m",
    "approach_roll_abs_deg",
)


def _pieces(t: np.ndarray) -> list[slice]:
    """Runs of samples with no gap longer than GAP_S."""
    cut = np.flatnonzero(np.diff(t) > GAP_S) + 1
    edges = np.r_[0, cut, len(t)]
    return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:], strict=True) if b > a]


def centred_rate(t: np.ndarray, x: np.ndarray, half_s: float) -> np.ndarray:
    """(x(t + h) - x(t - h)) / 2h per second, x interpolated in time; NaN where the window
    leaves the samples. One piece (no gaps) of finite values."""
    out = np.full(len(t), np.nan)
    ok = (t - half_s >= t[0]) & (t + half_s <= t[-1])
    if ok.any():
        out[ok] = (np.interp(t[ok] + half_s, t, x) - np.interp(t[ok] - half_s, t, x)) / (2.0 * half_s)
    return out


def vertical_rate_fpm(t: np.ndarray, alt_ft: np.ndarray, half_s: float = RATE_HALF_WINDOW_S) -> np.ndarray:
    """The altitude's centred rate over +-half_s in ft/min."""
    return centred_rate(t, alt_ft, half_s) * 60.0


def track_rate_deg_s(t: np.ndarray, track_deg: np.ndarray, half_s: float = 2.5) -> np.ndarray:
    """Centred track rate (deg/s) over +-half_s, the track unwrapped first."""
    return centred_rate(t, np.degrees(np.unwrap(np.radians(track_deg))), half_s)


def _circ_dev_deg(track_deg: np.ndarray, ref_deg: float) -> np.ndarray:
    return np.abs((track_deg - ref_deg + 180.0) % 360.0 - 180.0)


def _circ_mean_deg(track_deg: np.ndarray) -> float:
    r = np.radians(track_deg)
    return float(np.degrees(np.arctan2(np.sin(r).mean(), np.cos(r).mean())))


def great_circle_offsets_m(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    """Signed distances (m, sphere of the mean radius) of the points from the great circle
    nearest them: the normal is the right singular vector of the least singular value of
    the points' unit vectors (no centring: a great circle's plane passes through the
    Earth's centre)."""
    la, lo = np.radians(lat_deg), np.radians(lon_deg)
    p = np.column_stack([np.cos(la) * np.cos(lo), np.cos(la) * np.sin(lo), np.sin(la)])
    n = np.linalg.svd(p, full_matrices=False)[2][-1]
    return EARTH_R_M * np.arcsin(np.clip(p @ n, -1.0, 1.0))


@dataclass
class _Piece:
    t: np.ndarray
    alt: np.ndarray
    gs: np.ndarray
    trk: np.ndarray
    lat: np.ndarray | None
    lon: np.ndarray | None
    roll: np.ndarray | None


def _piece_arrays(df: pd.DataFrame, s: slice) -> _Piece:
    def col(name: str) -> np.ndarray | None:
        if name not in df:
            return None
        v = df[name].to_numpy(float)[s]
        return v if np.isfinite(v).any() else None

    return _Piece(
        df["time_s"].to_numpy(float)[s],
        df["altitude_ft"].to_numpy(float)[s],
        df["groundspeed_kt"].to_numpy(float)[s],
        df["track_deg"].to_numpy(float)[s],
        col("latitude"),
        col("longitude"),
        col("roll_deg"),
    )


def _vertical(p: _Piece, out: dict[str, list]) -> None:
    vr = vertical_rate_fpm(p.t, p.alt)
    a = p.alt
    climb = (vr > 300.0) & (a >= 1500.0) & (a <= 10000.0)
    out["climb_fpm"] += list(vr[climb])
    out["climb_fpm_altitude_ft"] += list(a[climb])
    out["descent_fpm_above_10000ft"] += list(-vr[(vr < -300.0) & (a >= 10000.0)])
    out["descent_fpm_2000_10000ft"] += list(-vr[(vr < -300.0) & (a >= 2000.0) & (a < 10000.0)])


def _roll(p: _Piece, out: dict[str, list]) -> None:
    if p.roll is None:
        return
    r, a = p.roll, p.alt
    high = (a >= 10000.0) & np.isfinite(r)
    out["roll_abs_deg_above_10000ft"] += list(np.abs(r[high]))
    one = (np.abs(np.diff(p.t) - 1.0) < 0.05) & (a[1:] >= 1500.0)
    dr = np.abs(np.diff(r))[one]
    out["roll_rate_deg_s"] += list(dr[np.isfinite(dr)])


def _wander(p: _Piece, out: dict[str, list]) -> None:
    if p.lat is None or p.lon is None:
        return
    t = p.t
    start = t[0]
    while start + WINDOW_S <= t[-1]:
        w = (t >= start) & (t < start + WINDOW_S)
        start += WINDOW_STEP_S
        lat, lon, trk = p.lat[w], p.lon[w], p.trk[w]
        ok = np.isfinite(lat) & np.isfinite(lon) & np.isfinite(trk)
        if ok.sum() < 0.8 * WINDOW_S / max(np.median(np.diff(t)), 1.0):
            continue
        if _circ_dev_deg(trk[ok], _circ_mean_deg(trk[ok])).max() > STRAIGHT_DEG:
            continue
        d = great_circle_offsets_m(lat[ok], lon[ok])
        out["wander_rms_m"].append(float(np.sqrt(np.mean(d**2))))
        out["wander_max_m"].append(float(np.abs(d).max()))


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(np.int8), 0]))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2], strict=True)]


def _turns(p: _Piece, out: dict[str, list]) -> None:
    rate = track_rate_deg_s(p.t, p.trk)
    turning = (np.abs(rate) > TURN_RATE_DEG_S) & (p.alt < 10000.0) & (p.alt > 1000.0)
    for a, b in _runs(turning):
        if p.t[b - 1] - p.t[a] < TURN_MIN_S:
            continue
        if p.roll is not None and np.isfinite(p.roll[a:b]).all():
            bank = float(np.median(np.abs(p.roll[a:b])))
        else:
            v = p.gs[a:b] * KT
            bank = float(np.degrees(np.median(np.arctan(v * np.radians(np.abs(rate[a:b])) / G0))))
        out["turn_bank_deg"].append(bank)


def _final_descents(t: np.ndarray, alt: np.ndarray) -> list[tuple[int, int, float]]:
    """(start, end, low) of every descent (30-s rate below -300 fpm for at least 60 s) that
    ends at a low point: the lowest height within 90 s after it, not undercut by more than
    100 ft in the next 15 min, and followed by the end of the data (a landing, a pass) or a
    climb of 500 ft (a go-around, a low approach). En-route level-offs are followed by more
    descent and are not low points."""
    vr = vertical_rate_fpm(t, alt)
    desc = np.nan_to_num(vr, nan=0.0) < -300.0
    out = []
    for a, b in _runs(desc):
        if t[b - 1] - t[a] < FINAL_MIN_S:
            continue
        after = (t >= t[b - 1]) & (t <= t[b - 1] + 90.0)
        low = float(alt[after].min())
        later = (t > t[b - 1]) & (t <= t[b - 1] + 900.0)
        if later.any() and alt[later].min() < low - 100.0:
            continue
        ends = t[-1] - t[b - 1] <= 300.0
        climbs = later.any() and alt[later].max() >= low + 500.0
        if ends or climbs:
            out.append((a, b, low))
    return out


def approach_fit(t: np.ndarray, alt_ft: np.ndarray, gs_kt: np.ndarray) -> tuple[float, np.ndarray]:
    """Path angle (deg, positive descending) and residuals (m) of a straight line fitted
    to height against the distance flown (trapezoid-integrated ground speed)."""
    s = np.r_[0.0, np.cumsum(0.5 * (gs_kt[1:] + gs_kt[:-1]) * KT * np.diff(t))]
    z = alt_ft * FT
    A = np.column_stack([s - s.mean(), np.ones_like(s)])
    coef, *_ = np.linalg.lstsq(A, z, rcond=None)
    return float(np.degrees(np.arctan(-coef[0]))), z - A @ coef


def _approaches(p: _Piece, out: dict[str, list]) -> None:
    for a, b, low in _final_descents(p.t, p.alt):
        above = p.alt[a:b] - low
        inside = (above >= FINAL_LOW_FT) & (above <= FINAL_HIGH_FT)
        runs = _runs(inside)
        if not runs:
            continue
        i, j = runs[-1]  # the last stretch of the window before the low point
        seg = np.arange(a + i, a + j)
        if p.t[seg[-1]] - p.t[seg[0]] < FINAL_MIN_S:
            continue
        if not (np.isfinite(p.gs[seg]).all() and np.isfinite(p.trk[seg]).all()):
            continue
        trk = p.trk[seg]
        if _circ_dev_deg(trk, _circ_mean_deg(trk)).max() > FINAL_STRAIGHT_DEG:
            continue
        angle, resid = approach_fit(p.t[seg], p.alt[seg], p.gs[seg])
        if not 1.0 < angle < 6.0:  # not a descent along a path
            continue
        out["approach_path_deg"].append(angle)
        out["approach_resid_p95_m"].append(float(np.percentile(np.abs(resid), 95)))
        out["approach_resid_max_m"].append(float(np.abs(resid).max()))
        if p.roll is not None:
            out["approach_roll_abs_deg"] += list(np.abs(p.roll[seg][np.isfinite(p.roll[seg])]))


def manoeuvring(t: np.ndarray, alt_ft: np.ndarray) -> np.ndarray:
    """Samples within MANOEUVRE_MARGIN_S of a 30-s vertical rate beyond MANOEUVRE_FPM
    (time-sorted samples with finite altitudes)."""
    bad = np.zeros(len(t), bool)
    for s in _pieces(t):
        vr = vertical_rate_fpm(t[s], alt_ft[s])
        bad[s] = np.abs(np.nan_to_num(vr)) > MANOEUVRE_FPM
    if not bad.any():
        return bad
    tb = t[bad]
    i = np.searchsorted(tb, t)
    near_next = np.abs(tb[np.clip(i, 0, len(tb) - 1)] - t) <= MANOEUVRE_MARGIN_S
    near_prev = np.abs(tb[np.clip(i - 1, 0, len(tb) - 1)] - t) <= MANOEUVRE_MARGIN_S
    return near_next | near_prev


def position_track_deg(t: np.ndarray, lat_deg: np.ndarray, lon_deg: np.ndarray, half_s: float = 5.0) -> np.ndarray:
    """The track the positions fly (deg true): the bearing between the positions interpolated
    half_s before and after each sample (flat Earth over a few hundred metres)."""
    la, lo = np.radians(lat_deg), np.unwrap(np.radians(lon_deg))
    tp, tm = np.clip(t + half_s, t[0], t[-1]), np.clip(t - half_s, t[0], t[-1])
    dn = np.interp(tp, t, la) - np.interp(tm, t, la)
    de = (np.interp(tp, t, lo) - np.interp(tm, t, lo)) * np.cos(la)
    out = np.degrees(np.arctan2(de, dn)) % 360.0
    out[(dn == 0) & (de == 0)] = np.nan
    return out


def position_track_check(traj: pd.DataFrame) -> float:
    """Median |reported track - position track| (deg) above 60 kt; NaN without positions."""
    if "latitude" not in traj or "longitude" not in traj:
        return math.nan
    d = traj.dropna(subset=["latitude", "longitude", "track_deg", "time_s"]).sort_values("time_s")
    d = d.drop_duplicates("time_s")
    if len(d) < 10:
        return math.nan
    pt = position_track_deg(d["time_s"].to_numpy(float), d["latitude"].to_numpy(float), d["longitude"].to_numpy(float))
    fast = (d["groundspeed_kt"].to_numpy(float) > 60.0) & np.isfinite(pt)
    if fast.sum() < 10:
        return math.nan
    reported = d["track_deg"].to_numpy(float)[fast]
    return float(np.median(np.abs((reported - pt[fast] + 180.0) % 360.0 - 180.0)))


def with_position_track(traj: pd.DataFrame) -> tuple[pd.DataFrame, float]:
    """The trajectory with its track column checked against its positions: where the median
    disagreement exceeds TRACK_AGREE_DEG the track becomes the positions' (samples sorted,
    one per time). Returns (trajectory, median disagreement in deg, NaN without positions)."""
    off = position_track_check(traj)
    if not (math.isfinite(off) and off > TRACK_AGREE_DEG):
        return traj, off
    out = traj.sort_values("time_s").drop_duplicates("time_s").reset_index(drop=True)
    out["track_deg"] = position_track_deg(
        out["time_s"].to_numpy(float), out["latitude"].to_numpy(float), out["longitude"].to_numpy(float)
    )
    return out, off


def profile_samples(traj: pd.DataFrame, where: str = "trajectory") -> dict[str, np.ndarray]:
    """Every statistic of the module docstring as an array of samples (empty where the
    trajectory has none). ValueError naming `where` and the column for a missing column."""
    for c in REQUIRED:
        if c not in traj:
            raise ValueError(f"{where}: expected a column {c!r} (columns: {', '.join(map(str, traj.columns))})")
    df = traj.sort_values("time_s", kind="stable")
    df = df[np.isfinite(df["time_s"].to_numpy(float)) & np.isfinite(df["altitude_ft"].to_numpy(float))]
    df = df.drop_duplicates("time_s", keep="first").reset_index(drop=True)
    df = df[~manoeuvring(df["time_s"].to_numpy(float), df["altitude_ft"].to_numpy(float))].reset_index(drop=True)
    out: dict[str, list] = {k: [] for k in SAMPLE_KEYS}
    for s in _pieces(df["time_s"].to_numpy(float)):
        p = _piece_arrays(df, s)
        if len(p.t) < 3:
            continue
        _vertical(p, out)
        _roll(p, out)
        _wander(p, out)
        _turns(p, out)
        _approaches(p, out)
    return {k: np.asarray(v, float) for k, v in out.items()}


def pooled(samples: list[dict[str, np.ndarray]]) -> dict[str, np.ndarray]:
    """Samples of several trajectories pooled per statistic."""
    return {k: np.concatenate([s[k] for s in samples]) if samples else np.empty(0) for k in SAMPLE_KEYS}


def climb_slope_fpm_per_kft(rate_fpm: np.ndarray, alt_ft: np.ndarray) -> float:
    """Least-squares slope of the climb rate on altitude (fpm per 1,000 ft); NaN under 10 samples."""
    if len(rate_fpm) < 10:
        return math.nan
    return float(np.polyfit(alt_ft / 1000.0, rate_fpm, 1)[0])


@dataclass(frozen=True)
class Comparison:
    """One statistic, simulated beside real: sample counts, p5/p50/p95 of each, the
    Wasserstein-1 distance (in the statistic's units) and the two-sample KS statistic."""

    name: str
    n_sim: int
    n_real: int
    sim: tuple[float, float, float]
    real: tuple[float, float, float]
    wasserstein: float
    ks: float


def _pcts(x: np.ndarray) -> tuple[float, float, float]:
    if len(x) == 0:
        return (math.nan, math.nan, math.nan)
    p5, p50, p95 = np.percentile(x, [5, 50, 95])
    return (float(p5), float(p50), float(p95))


def compare(name: str, sim: np.ndarray, real: np.ndarray) -> Comparison:
    """Distances between two sample sets (NaN where either is empty)."""
    sim, real = np.asarray(sim, float), np.asarray(real, float)
    sim, real = sim[np.isfinite(sim)], real[np.isfinite(real)]
    if len(sim) and len(real):
        w = float(stats.wasserstein_distance(sim, real))
        ks = float(stats.ks_2samp(sim, real).statistic)
    else:
        w = ks = math.nan
    return Comparison(name, len(sim), len(real), _pcts(sim), _pcts(real), w, ks)
