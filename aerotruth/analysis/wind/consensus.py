"""Winds from multi-aircraft traffic and a reference-free reference: the consensus of the
other aircraft.

Each sample's wind is the wind triangle (wind paper eq. 1), W = V_G - V_A, with V_G from the
ADS-B ground speed and track and V_A from the aircraft's own true airspeed and heading:
Mode-S BDS 6,0 heading is magnetic, made true with the IGRF declination at the sample
(aerotruth.sensors.magnetics), and BDS 5,0 TAS is along the air path, so its horizontal part
is TAS cos(gamma) = sqrt(TAS^2 - w^2), w the vertical rate (the table's, else the pressure
altitude's rate per aircraft): a 53-deg zero-g pull-up would otherwise read as a 40 % TAS
error.

The consensus reference of a sample is the mean wind of the *other* aircraft's samples in a
space-time neighbourhood: within `radius_km` horizontally, `layer_ft` vertically and
`window_s` in time, as one ellipsoid (each axis scaled to the radius) searched with a k-d
tree (scipy cKDTree), its own aircraft excluded, from at least `min_aircraft` other
aircraft (else NaN). A heading error of one aircraft rotates its own wind; the consensus
sees it against the fleet, so offsets are found relative to the fleet's mean (a fleet-wide
offset cancels), and each aircraft's own error leaves its reference untouched.
"""

from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from aerotruth.sensors.magnetics import GeomagneticField
from aerotruth.units import DEG, EARTH_RADIUS_M, FT, KT

CONSENSUS_RADIUS_KM = 50.0  # a mesoscale wind changes by ~1 m/s over this (Nastrom-Gage)
CONSENSUS_LAYER_FT = 1000.0  # shear of a few kt per 1,000 ft
CONSENSUS_WINDOW_S = 900.0
CONSENSUS_MIN_AIRCRAFT = 2
POOL_STEP_S = 10.0  # one sample per aircraft and 10 s carries the work: neighbours, not 1-s repeats
CONSENSUS_ITERATIONS = 8


def declination_deg(traffic: pd.DataFrame) -> np.ndarray:
    """IGRF declination (deg, east positive) at each sample, one field grid per UTC day."""
    out = np.empty(len(traffic))
    day = np.floor(traffic["time_s"].to_numpy() / 86400.0)
    for d in np.unique(day):
        sel = day == d
        when = dt.datetime(1970, 1, 1) + dt.timedelta(days=float(d), hours=12)
        lat, lon = traffic["lat"].to_numpy()[sel], traffic["lon"].to_numpy()[sel]
        h = traffic["pressure_altitude_ft"].to_numpy()[sel] * FT
        field = GeomagneticField.covering(lat, lon, when)
        out[sel] = np.degrees(field.at(lat, lon, np.clip(h, -500.0, 15000.0)).declination_rad)
    return out


def vertical_rate_fpm(traffic: pd.DataFrame) -> np.ndarray:
    """The table's vertical rate where given, else the pressure altitude's rate per aircraft
    (central differences over the aircraft's own samples; 0 where it has one sample)."""
    given = traffic["vertical_rate_fpm"].to_numpy(float) if "vertical_rate_fpm" in traffic else None
    rate = np.zeros(len(traffic))
    ac = traffic["aircraft"].to_numpy()
    t, alt = traffic["time_s"].to_numpy(float), traffic["pressure_altitude_ft"].to_numpy(float)
    starts = np.flatnonzero(np.r_[True, ac[1:] != ac[:-1]])
    for a, b in zip(starts, np.r_[starts[1:], len(ac)], strict=True):
        if b - a >= 2 and np.all(np.diff(t[a:b]) > 0):
            rate[a:b] = np.gradient(alt[a:b], t[a:b]) * 60.0
    if given is not None:
        rate = np.where(np.isfinite(given), given, rate)
    return rate


def sample_winds(traffic: pd.DataFrame) -> pd.DataFrame:
    """Per sample of the canonical traffic frame (aerotruth.measured.traffic): declination_deg,
    heading_deg (true), tas_h_kt (horizontal TAS), wind_u_kt / wind_v_kt (towards east,
    north; wind paper eq. 1). `traffic` sorted by aircraft and time."""
    dec = declination_deg(traffic)
    hdg = (traffic["heading_mag_deg"].to_numpy(float) + dec) % 360.0
    tas = traffic["tas_kt"].to_numpy(float)
    w_kt = vertical_rate_fpm(traffic) * FT / 60.0 / KT
    tas_h = np.sqrt(np.maximum(tas**2 - w_kt**2, 0.0))
    gs, trk = traffic["gs_kt"].to_numpy(float), traffic["track_deg"].to_numpy(float) * DEG
    u = gs * np.sin(trk) - tas_h * np.sin(hdg * DEG)
    v = gs * np.cos(trk) - tas_h * np.cos(hdg * DEG)
    return pd.DataFrame({"declination_deg": dec, "heading_deg": hdg, "tas_h_kt": tas_h, "wind_u_kt": u, "wind_v_kt": v})


def fleet_headings(codes: np.ndarray, heading_deg: np.ndarray, m: int) -> np.ndarray:
    """Each aircraft's mean heading (deg, circular mean of its samples)."""
    s = np.bincount(codes, weights=np.sin(heading_deg * DEG), minlength=m)
    c = np.bincount(codes, weights=np.cos(heading_deg * DEG), minlength=m)
    return np.degrees(np.arctan2(s, c))


def remove_fleet_mode(offsets: np.ndarray, mean_heading_deg: np.ndarray, seen: np.ndarray) -> np.ndarray:
    """Offsets without the part a consensus cannot see: a constant and a once-round
    sinusoid of heading across the fleet, a + b sin(psi) + c cos(psi), is what a wind error
    common to the neighbourhood does to every aircraft's heading error (a wind error e turns
    the air vector of an aircraft heading psi by e x psi / TAS). Least squares over the
    aircraft in `seen` (at least 4 headings, else the mean only)."""
    out = offsets.copy()
    if not seen.any():
        return out
    h = mean_heading_deg[seen] * DEG
    x = np.column_stack([np.ones(h.size), np.sin(h), np.cos(h)]) if h.size >= 4 else np.ones((h.size, 1))
    coef, *_ = np.linalg.lstsq(x, offsets[seen], rcond=None)
    out[seen] = offsets[seen] - x @ coef
    return out


def consensus_wind(
    traffic: pd.DataFrame,
    winds: pd.DataFrame,
    radius_km: float = CONSENSUS_RADIUS_KM,
    layer_ft: float = CONSENSUS_LAYER_FT,
    window_s: float = CONSENSUS_WINDOW_S,
    min_aircraft: int = CONSENSUS_MIN_AIRCRAFT,
    pool_step_s: float = POOL_STEP_S,
    iterations: int = CONSENSUS_ITERATIONS,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, pd.DataFrame]:
    """(u, v, n_aircraft, per-aircraft table) of the consensus reference at every sample
    (module docstring); the table: offset_deg, group (aircraft linked through shared
    neighbourhoods), mean_heading_deg, seen (has a reference anywhere). `winds`:
    sample_winds of `traffic`. Each aircraft's heading offset is estimated against the
    others (the median of its samples' heading errors, without the fleet mode a consensus
    cannot see: remove_fleet_mode) and its air vector turned back by it before its winds
    enter the others' reference, `iterations` times: a neighbour's 2-deg offset at 400 kt is
    a 14-kt error in the plain mean. NaN where fewer than `min_aircraft` other aircraft are
    near."""
    lat, lon = traffic["lat"].to_numpy(float), traffic["lon"].to_numpy(float)
    lat0, lon0 = float(np.median(lat)), float(np.median(lon))
    x = EARTH_RADIUS_M / 1000.0 * np.cos(lat0 * DEG) * ((lon - lon0 + 180.0) % 360.0 - 180.0) * DEG
    y = EARTH_RADIUS_M / 1000.0 * (lat - lat0) * DEG
    z = traffic["pressure_altitude_ft"].to_numpy(float) * (radius_km / layer_ft)
    t = traffic["time_s"].to_numpy(float)
    pts = np.column_stack([x, y, z, (t - t.min()) * (radius_km / window_s)])
    codes, names = pd.factorize(traffic["aircraft"])
    m = codes.max() + 1
    # the work is done on one sample per aircraft and `pool_step_s` slot (the slot's first);
    # every sample of a slot takes its slot's reference (the neighbourhood spans minutes)
    key = pd.DataFrame({"a": codes, "s": np.floor(t / pool_step_s)})
    slot = key.groupby(["a", "s"], sort=False).ngroup().to_numpy()
    pool = np.flatnonzero(~key.duplicated().to_numpy())  # pool[k]: the first sample of slot k
    pc = codes[pool]
    hits = cKDTree(pts[pool]).query_ball_point(pts[pool], r=radius_km, return_sorted=False)
    counts = np.fromiter((len(h) for h in hits), dtype=np.int64, count=len(hits))
    flat = np.concatenate([np.asarray(h, dtype=np.int64) for h in hits]) if counts.sum() else np.zeros(0, int)
    owner = np.repeat(np.arange(pool.size), counts)
    other = pc[flat] != pc[owner]
    flat, owner = flat[other], owner[other]
    n = np.bincount(owner, minlength=pool.size).astype(float)
    n_ac = np.bincount(np.unique(owner.astype(np.int64) * m + pc[flat]) // m, minlength=pool.size)
    ok = (n_ac >= min_aircraft) & (n > 0)
    gs, trk = traffic["gs_kt"].to_numpy(float)[pool], traffic["track_deg"].to_numpy(float)[pool] * DEG
    ge, gn = gs * np.sin(trk), gs * np.cos(trk)
    hdg_all = winds["heading_deg"].to_numpy(float)
    tas, hdg = winds["tas_h_kt"].to_numpy(float)[pool], hdg_all[pool]
    offsets = np.zeros(m)
    u = v = np.full(pool.size, np.nan)
    seen = np.isin(np.arange(m), pc[ok])
    mean_heading = fleet_headings(codes, hdg_all, m)
    # aircraft that share neighbourhoods, directly or through others: each group has its own
    # unseen mode (groups at flight levels farther apart than the layer never meet)
    link = coo_matrix((np.ones(owner.size), (pc[owner], pc[flat])), shape=(m, m))
    _, group = connected_components(link, directed=False)
    for _ in range(max(iterations, 1)):
        h = (hdg - offsets[pc]) * DEG  # each aircraft's heading with its own offset taken out
        wu, wv = ge - tas * np.sin(h), gn - tas * np.cos(h)
        with np.errstate(invalid="ignore", divide="ignore"):
            u = np.where(ok, np.bincount(owner, weights=wu[flat], minlength=pool.size) / n, np.nan)
            v = np.where(ok, np.bincount(owner, weights=wv[flat], minlength=pool.size) / n, np.nan)
        d = (np.degrees(np.arctan2(ge - u, gn - v)) - np.degrees(h) + 180.0) % 360.0 - 180.0  # heading error
        step = pd.Series(d[ok]).groupby(pc[ok]).median().reindex(range(m)).fillna(0.0).to_numpy()
        offsets = offsets - step
        for g in np.unique(group[seen]):
            offsets = remove_fleet_mode(offsets, mean_heading, seen & (group == g))
    u, v, n_ac = u[slot], v[slot], n_ac[slot]
    est = pd.DataFrame(
        {"offset_deg": offsets, "group": group, "mean_heading_deg": mean_heading, "seen": seen},
        index=pd.Index(names, name="aircraft"),
    )
    return u, v, n_ac, est


def _speed_dir(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speed and meteorological direction (from, deg in [0, 360)) of a wind blowing towards (u, v)."""
    return np.hypot(u, v), np.degrees(np.arctan2(-u, -v)) % 360.0


def observation_table(traffic: pd.DataFrame, **consensus) -> pd.DataFrame:
    """The observation table (docs/data-formats.md) of traffic against the consensus
    reference: one row per sample with a reference, `tas_kt` the horizontal TAS (so that
    V_G - V_A from `tas_kt` and `heading_deg` is the reported wind), `heading_mag_deg` and
    `declination_deg` as used, `ref_source` "consensus"."""
    w = sample_winds(traffic)
    ru, rv, n_ac, offsets = consensus_wind(traffic, w, **consensus)
    speed, direction = _speed_dir(w["wind_u_kt"].to_numpy(), w["wind_v_kt"].to_numpy())
    rspeed, rdir = _speed_dir(ru, rv)
    obs = pd.DataFrame(
        {
            "aircraft": traffic["aircraft"].to_numpy(),
            "time": traffic["time_s"].to_numpy(),
            "lat": traffic["lat"].to_numpy(),
            "lon": traffic["lon"].to_numpy(),
            "pressure_altitude_ft": traffic["pressure_altitude_ft"].to_numpy(),
            "wind_speed_kt": speed,
            "wind_dir_deg": direction,
            "ref_wind_speed_kt": rspeed,
            "ref_wind_dir_deg": rdir,
            "tas_kt": w["tas_h_kt"].to_numpy(),
            "heading_deg": w["heading_deg"].to_numpy(),
            "heading_mag_deg": traffic["heading_mag_deg"].to_numpy() % 360.0,
            "declination_deg": w["declination_deg"].to_numpy(),
            "ref_source": "consensus",
            "ref_aircraft": n_ac,
        }
    )
    if "roll_deg" in traffic:
        obs["roll_deg"] = traffic["roll_deg"].to_numpy()
    keep = np.isfinite(ru) & np.isfinite(rv)
    out = obs[keep].reset_index(drop=True)
    out.attrs["samples"] = int(len(obs))
    out.attrs["without_reference"] = int((~keep).sum())
    out.attrs["consensus_aircraft"] = offsets
    return out
