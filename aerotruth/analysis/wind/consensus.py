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
aircraft (else NaN). Each other aircraft counts once, w_sj = 1 / (n_aircraft n_samples_j),
since its samples share one heading offset and one TAS error; and each has its heading
offset taken out, all offsets estimated jointly.

The offsets. Aircraft i's BDS 6,0 heading made true is psi + o_i. On each pool sample s of
it (one per aircraft and `pool_step_s`), the reference with offsets o taken out,
W_s(o) = sum_j w_sj sum_k (V_G,k - TAS_k (sin, cos)(psi_k + o_j^true - o_j)), implies a
heading, that of V_G,s - W_s(o); d_s(o) is it less i's own heading with o_i taken out. To
first order in the errors e = o - o^true (TAS_j, psi_j a neighbour's, TAS_i, psi_i its own):

    d_s(o) = e_i - sum_j w_sj (TAS_j / TAS_i) cos(psi_j - psi_i) e_j + noise

a sparse linear system, one row per pool sample, in the m offsets. They minimise
sum_s rho_s d_s(o)^2, rho_s = 1 / (aircraft i's rows) so that each aircraft's equations count
once, by Gauss-Newton from o = 0 (the first step is the linear solve, the next take out its
second-order part), with Huber weights (HUBER_K robust sigmas) from the second step on.

What no consensus sees: errors e with every d_s = 0, TAS_i e_i = sum_j w_sj cos(psi_j -
psi_i) TAS_j e_j on every row. The weights sum to 1 and |cos| <= 1, so the largest
|TAS_i e_i| of a group (aircraft linked through shared references) is matched by every
neighbour at |cos| = 1, and so on through the group: a group has an unseen mode only if its
aircraft all fly one line (one heading or its reciprocal), e_i = c cos(psi_i - psi_0) / TAS_i,
a wind error across the line; the solve leaves next to nothing of it in the offsets (the
minimum norm of the linear step: a 1e-6 ridge). Where aircraft of different headings meet, every offset is seen,
a fleet-wide one included: a common offset turns every air vector by one angle, which moves
the winds of different headings differently. The weakest mode seen is the once-round
sinusoid e_i = (a sin psi_i + b cos psi_i) / TAS_i, what a wind error common to the
neighbourhood does to each heading: the neighbours' mean, spread round the compass, carries
half of it, so it is seen at half gain, through the reported TAS (were each aircraft's TAS
error free as well, this mode would be unseen in heading and TAS together).

Density (tests/traffic_generator.py: straight 20-min flights in a 200-km box over an hour, the
heading register's 90/512 deg and TAS to 2 kt, offsets uniform in +-3 deg): the largest
error of any aircraft against its known offset is 0.15 deg at 8 aircraft a flight level
(0.19 relative to the fleet's mean), 0.13 at 12 (0.18) and 0.08-0.10 at 16 to 36 (ten seeds
each); at four levels (5 seeds), 0.19, 0.15, 0.13 and 0.09 deg at 9, 12, 16 and 36 a level.
What is left is chiefly the neighbours' TAS resolution (+-1 kt along a neighbour's track
reads as up to 0.14 deg across another's), then the heading register and the wind's change
across a neighbourhood; with exact data the offsets come back exactly.
"""

from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd
from scipy.sparse import coo_matrix, csr_matrix, identity
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import spsolve
from scipy.spatial import cKDTree

from aerotruth.sensors.magnetics import GeomagneticField
from aerotruth.units import DEG, EARTH_RADIUS_M, FT, G0, KT

CONSENSUS_RADIUS_KM = 50.0  # a mesoscale wind changes by ~1 m/s over this (Nastrom-Gage)
CONSENSUS_LAYER_FT = 1000.0  # shear of a few kt per 1,000 ft
CONSENSUS_WINDOW_S = 900.0
CONSENSUS_MIN_AIRCRAFT = 2
# one sample per aircraft and 20 s carries the work (neighbours, not 1-s repeats): 4.5 km of track, a tenth
# of the radius; offsets and references are the same at 10, 20 and 30 s, the pairs fall as its square
POOL_STEP_S = 20.0
CONSENSUS_ITERATIONS = 3  # Gauss-Newton steps: a 3-deg offset's second-order part is gone after the second
HUBER_K = 2.5  # rows beyond 2.5 robust sigmas (1.4826 MAD) of the residuals count less: turns, bad decodes
HUBER_FLOOR_DEG = 1e-3  # the least robust sigma, far below the heading register's 0.18 deg


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


TURN_WINDOW_S = 10.0  # the track's rate of turn from the samples this far either side
MAX_BANK_DEG = 10.0  # the wind paper's roll gate (section 4): reports banked more are dropped


def implied_bank_deg(traffic: pd.DataFrame, window_s: float = TURN_WINDOW_S) -> np.ndarray:
    """|bank| (deg) of each sample of a canonical traffic frame (sorted by aircraft and time):
    the table's roll where given, else the bank of a coordinated turn at the ADS-B ground
    track's rate, tan(phi) = V_G omega / g, omega from the track at the aircraft's samples
    nearest t - window_s and t + window_s (0 where it has no other sample within the window:
    sparse reports say nothing of turns). In turns the BDS 6,0 heading and the ADS-B velocity,
    sampled at different instants, disagree by the turn rate times the time between them
    (shared/real-data README; 2 s at 3 deg/s is 6 deg), and the heading leads the air track
    by alpha sin(roll): the wind paper drops reports banked over 10 deg."""
    n = len(traffic)
    out = np.zeros(n)
    if n == 0:
        return out
    codes = pd.factorize(traffic["aircraft"])[0].astype(float)
    t = traffic["time_s"].to_numpy(float)
    span = (np.nanmax(t) - np.nanmin(t)) + 4 * window_s + 1.0
    key = codes * span + (t - np.nanmin(t))  # aircraft by aircraft, in time order within each
    lo = np.searchsorted(key, key - window_s, side="left")
    hi = np.searchsorted(key, key + window_s, side="right") - 1
    lo = np.where(codes[lo] == codes, lo, np.arange(n))
    hi = np.where(codes[np.minimum(hi, n - 1)] == codes, hi, np.arange(n))
    trk = traffic["track_deg"].to_numpy(float)
    dt_ = t[hi] - t[lo]
    turn = (trk[hi] - trk[lo] + 180.0) % 360.0 - 180.0
    with np.errstate(invalid="ignore", divide="ignore"):
        omega = np.where(dt_ > 0, np.radians(turn) / dt_, 0.0)
    v = traffic["gs_kt"].to_numpy(float) * KT
    out = np.degrees(np.arctan(np.abs(v * omega) / G0))
    if "roll_deg" in traffic:
        roll = np.abs(traffic["roll_deg"].to_numpy(float))
        out = np.where(np.isfinite(roll), roll, out)
    return np.nan_to_num(out, nan=0.0)


def straight_samples(traffic: pd.DataFrame, max_bank_deg: float = MAX_BANK_DEG) -> pd.DataFrame:
    """The samples of a canonical traffic frame not banked over `max_bank_deg` (implied_bank_deg);
    attrs as the frame's, plus `turning` (the samples left out)."""
    keep = implied_bank_deg(traffic) <= max_bank_deg
    out = traffic[keep].reset_index(drop=True)
    out.attrs = {**traffic.attrs, "turning": int((~keep).sum())}
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


def _pool(codes: np.ndarray, t: np.ndarray, step_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(pool, slot): the first sample of each (aircraft, `step_s` slot of epoch time) and each
    sample's index into `pool`; one pass when the samples are sorted by aircraft and time."""
    s = np.floor(t / step_s)
    s = (s - s.min()).astype(np.int64)
    key = codes.astype(np.int64) * (int(s.max()) + 1) + s
    if np.all(key[1:] >= key[:-1]):
        first = np.r_[True, key[1:] != key[:-1]]
        return np.flatnonzero(first), np.cumsum(first) - 1
    _, pool, slot = np.unique(key, return_index=True, return_inverse=True)
    return pool, slot.ravel()


def _sorting(key: np.ndarray) -> np.ndarray:
    """The stable sorting permutation of a non-negative int64 `key`: key and position packed
    in one int64 and sorted by value (several times faster than argsort)."""
    bits = max(int(key.size).bit_length(), 1)
    if key.size and int(key.max()) < 1 << (62 - bits):
        return np.sort((key << bits) | np.arange(key.size, dtype=np.int64)) & ((1 << bits) - 1)
    return np.argsort(key, kind="stable")


def _neighbour_segments(
    pts: np.ndarray, pc: np.ndarray, m: int, radius: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The neighbourhoods as segments, one per (pool sample, other aircraft in its
    neighbourhood): (owner sample, that aircraft, neighbour samples ordered by segment,
    each segment's start in them)."""
    pairs = cKDTree(pts).query_pairs(radius, output_type="ndarray")
    i, j = pairs[:, 0], pairs[:, 1]
    other = pc[i] != pc[j]
    owner, nbr = np.r_[i[other], j[other]], np.r_[j[other], i[other]]
    key = owner * m + pc[nbr]
    order = _sorting(key)
    key, nbr = key[order], nbr[order]
    start = np.flatnonzero(np.r_[True, key[1:] != key[:-1]]) if key.size else np.zeros(0, np.int64)
    return key[start] // m, key[start] % m, nbr, start


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
    (module docstring): u, v towards east and north (kt), NaN where fewer than
    `min_aircraft` other aircraft are near; n_aircraft, the other aircraft near. `winds`:
    sample_winds of `traffic`. The table, per aircraft: offset_deg (its heading offset,
    solved jointly with all others': `iterations` Gauss-Newton steps of the module
    docstring's equations), group (aircraft linked through shared references, directly or
    through others), mean_heading_deg, seen (has a reference), neighbours (other aircraft in
    its references). The work is done on one sample per aircraft and `pool_step_s` slot (the
    slot's first); every sample takes its slot's reference (a neighbourhood spans minutes)."""
    codes, names = pd.factorize(traffic["aircraft"])
    m = len(names)
    if m == 0:
        empty = pd.DataFrame(
            {"offset_deg": [], "group": [], "mean_heading_deg": [], "seen": [], "neighbours": []},
            index=pd.Index([], name="aircraft"),
        )
        return np.zeros(0), np.zeros(0), np.zeros(0, np.int64), empty
    t = traffic["time_s"].to_numpy(float)
    pool, slot = _pool(codes, t, pool_step_s)
    pc, npool = codes[pool], pool.size
    lat, lon = traffic["lat"].to_numpy(float)[pool], traffic["lon"].to_numpy(float)[pool]
    lat0, lon0, km = float(np.median(lat)), float(np.median(lon)), EARTH_RADIUS_M / 1000.0 * DEG
    pts = np.column_stack(
        [
            km * np.cos(lat0 * DEG) * ((lon - lon0 + 180.0) % 360.0 - 180.0),
            km * (lat - lat0),
            traffic["pressure_altitude_ft"].to_numpy(float)[pool] * (radius_km / layer_ft),
            (t[pool] - t[pool].min()) * (radius_km / window_s),
        ]
    )
    seg_owner, seg_ac, nbr, start = _neighbour_segments(pts, pc, m, radius_km)
    gs, trk = traffic["gs_kt"].to_numpy(float)[pool], traffic["track_deg"].to_numpy(float)[pool] * DEG
    ge, gn = gs * np.sin(trk), gs * np.cos(trk)
    hdg_all = winds["heading_deg"].to_numpy(float)
    hdg, tas = hdg_all[pool], winds["tas_h_kt"].to_numpy(float)[pool]
    # per segment, the sums over its samples that the reference needs at any offsets
    sums = [
        np.add.reduceat(q[nbr], start) if nbr.size else np.zeros(0)
        for q in (ge, gn, tas * np.sin(hdg * DEG), tas * np.cos(hdg * DEG))
    ]
    count = np.diff(np.r_[start, nbr.size])
    n_ac = np.bincount(seg_owner, minlength=npool)
    ok = n_ac >= max(min_aircraft, 1)
    use = ok[seg_owner]
    seg_owner, seg_ac = seg_owner[use], seg_ac[use]
    sge, sgn, s_sin, s_cos = (s[use] for s in sums)
    w = 1.0 / (count[use] * n_ac[seg_owner])  # each other aircraft counts once, whatever its samples
    rows = np.flatnonzero(ok)
    seg_row = np.cumsum(ok)[seg_owner] - 1  # each segment's row in `rows`
    seen = np.bincount(pc[rows], minlength=m) > 0
    link = coo_matrix((np.ones(seg_owner.size), (pc[seg_owner], seg_ac)), shape=(m, m)).tocsr()
    _, group = connected_components(link, directed=False)
    row_weight = 1.0 / np.bincount(pc[rows], minlength=m)[pc[rows]] if rows.size else np.zeros(0)
    offsets = np.zeros(m)
    huber = row_weight
    for it in range(max(iterations, 0) + 1):
        # the neighbours' winds with their offsets taken out: sum of G - TAS (sin, cos)(psi - o)
        co, so = np.cos(offsets[seg_ac] * DEG), np.sin(offsets[seg_ac] * DEG)
        a_sin, a_cos = co * s_sin - so * s_cos, co * s_cos + so * s_sin
        u = np.bincount(seg_owner, weights=w * (sge - a_sin), minlength=npool)
        v = np.bincount(seg_owner, weights=w * (sgn - a_cos), minlength=npool)
        if it == max(iterations, 0) or rows.size == 0:
            break
        ae, an = ge[rows] - u[rows], gn[rows] - v[rows]
        psi = np.arctan2(ae, an)  # the heading the reference implies
        d = (np.degrees(psi) - hdg[rows] + offsets[pc[rows]] + 180.0) % 360.0 - 180.0
        # d/d(o_j) of psi: the neighbour's air vectors turned, seen across the reference's air vector
        dj = -w * (a_cos * np.cos(psi[seg_row]) + a_sin * np.sin(psi[seg_row])) / np.hypot(ae, an)[seg_row]
        if it > 0:  # Huber weights on the first step's residuals on: turns and bad decodes count less
            sigma = max(1.4826 * float(np.median(np.abs(d - np.median(d)))), HUBER_FLOOR_DEG)
            huber = row_weight * np.minimum(1.0, HUBER_K * sigma / np.maximum(np.abs(d), HUBER_FLOOR_DEG))
        sq = np.sqrt(huber)
        jac = csr_matrix(
            (np.r_[sq, sq[seg_row] * dj], (np.r_[np.arange(rows.size), seg_row], np.r_[pc[rows], seg_ac])),
            shape=(rows.size, m),
        )
        normal = (jac.T @ jac).tocsc()
        ridge = 1e-6 * max(float(normal.diagonal().max()), 1.0)  # zero in what the data cannot see
        offsets = offsets + spsolve(normal + ridge * identity(m, format="csc"), -(jac.T @ (sq * d)))
    neighbours = np.bincount(np.unique(pc[seg_owner] * m + seg_ac) // m, minlength=m)
    est = pd.DataFrame(
        {
            "offset_deg": offsets,
            "group": group,
            "mean_heading_deg": fleet_headings(codes, hdg_all, m),
            "seen": seen,
            "neighbours": neighbours,
        },
        index=pd.Index(names, name="aircraft"),
    )
    return np.where(ok, u, np.nan)[slot], np.where(ok, v, np.nan)[slot], n_ac[slot], est


def _speed_dir(u: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Speed and meteorological direction (from, deg in [0, 360)) of a wind blowing towards (u, v)."""
    return np.hypot(u, v), np.degrees(np.arctan2(-u, -v)) % 360.0


def build_observation_table(
    traffic: pd.DataFrame,
    winds: pd.DataFrame,
    ref_u_kt: np.ndarray,
    ref_v_kt: np.ndarray,
    ref_source: str,
    extra: dict[str, np.ndarray] | None = None,
) -> pd.DataFrame:
    """The observation table (docs/data-formats.md) of a canonical traffic frame
    (aerotruth.measured.traffic) against any reference: one row per sample whose reference
    (ref_u_kt, ref_v_kt: towards east and north, kt; NaN where none) is finite. `winds` is
    sample_winds of `traffic`: `tas_kt` the horizontal TAS (so that V_G - V_A from `tas_kt`
    and `heading_deg` is the reported wind), `heading_mag_deg` and `declination_deg` as used;
    `ref_source` labels every row; `extra` columns (one value per sample) follow it.
    attrs: samples (read), without_reference (left out)."""
    speed, direction = _speed_dir(winds["wind_u_kt"].to_numpy(), winds["wind_v_kt"].to_numpy())
    ref_u, ref_v = np.asarray(ref_u_kt, dtype=float), np.asarray(ref_v_kt, dtype=float)
    rspeed, rdir = _speed_dir(ref_u, ref_v)
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
            "tas_kt": winds["tas_h_kt"].to_numpy(),
            "heading_deg": winds["heading_deg"].to_numpy(),
            "heading_mag_deg": traffic["heading_mag_deg"].to_numpy() % 360.0,
            "declination_deg": winds["declination_deg"].to_numpy(),
            "ref_source": ref_source,
            **(extra or {}),
        }
    )
    if "roll_deg" in traffic:
        obs["roll_deg"] = traffic["roll_deg"].to_numpy()
    if "flight" in traffic:  # the reader's flights (gaps, ground): the method's clusters within them
        obs["flight"] = traffic["flight"].astype(str).to_numpy()
    keep = np.isfinite(ref_u) & np.isfinite(ref_v)
    out = obs[keep].reset_index(drop=True)
    out.attrs["samples"] = int(len(obs))
    out.attrs["without_reference"] = int((~keep).sum())
    return out


def observation_table(traffic: pd.DataFrame, **consensus) -> pd.DataFrame:
    """The observation table (docs/data-formats.md) of traffic against the consensus
    reference (build_observation_table): `ref_source` "consensus", `ref_aircraft` the number
    of other aircraft in each reference; attrs also consensus_aircraft (consensus_wind's
    per-aircraft table)."""
    w = sample_winds(traffic)
    ru, rv, n_ac, offsets = consensus_wind(traffic, w, **consensus)
    out = build_observation_table(traffic, w, ru, rv, "consensus", extra={"ref_aircraft": n_ac})
    out.attrs["consensus_aircraft"] = offsets
    return out
