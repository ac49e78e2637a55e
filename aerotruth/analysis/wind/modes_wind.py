"""Winds from Mode-S enhanced surveillance, and a reference-free check of the heading and
airspeed the aircraft reports.

Wind (wind paper eq. 1): W = V_G - V_A, with V_G from track and ground speed (BDS 5,0 or
ADS-B) and V_A = TAS cos(gamma) (cos psi, sin psi) (north, east) from TAS (BDS 5,0, along
the air path: its horizontal part, gamma the climb angle from the vertical rate) and the
true heading psi = magnetic heading (BDS 6,0) + declination (IGRF for the date at the
aircraft: ppigrf). Below, TAS is that horizontal part.

Consistency model (no reference wind needed): the wind is smooth in time along the
flight, W(t) = sum_j c_j phi_j(t) (cubic B-splines, knots every `knot_s`, restarted after
each gap longer than SEGMENT_GAP_S: a level change or another leg), while errors
of the aircraft's heading and airspeed move the derived wind with the heading, so they
show up when the aircraft turns. The unknowns are corrections to the reported values:
true heading = reported + A + B sin psi + C cos psi + D r (A an offset, e.g. a stale
variation table; B, C a one-cycle deviation as wind paper eq. 2; D the lag of the heading
samples behind the ground track, r the heading rate: a heading sampled D seconds late
reads psi - r D), true TAS = (1 + k) reported TAS. Linearised about the reported air
vector V_A (dV_A/dpsi = TAS (-sin psi, cos psi)):

    V_G - V_A = W(t) + k V_A + TAS (-sin psi, cos psi) (A + B sin psi + C cos psi + D r).

All unknowns enter linearly: one least-squares solve.

A slaved compass (flux valve + directional gyro) does not show its deviation at once:
the gyro follows the valve through the slaving loop, de/dt = (d(psi) - e) / tau, so after
a turn the error moves from the old heading's deviation to the new one's with the time
constant tau (the gyro slaving lag). With `tau_s` the deviation's columns are the
sinusoids passed through that first-order lag (restarted on each segment, the filter
state starting at the segment's first value); tau is found by a profile search
(SLAVING_TAU_GRID_S) around the linear solve.
"""

from __future__ import annotations

import datetime as dt

import numpy as np
import pandas as pd
from scipy.interpolate import BSpline

from aerotruth.analysis.least_squares import ols
from aerotruth.truth.aircraft_types import SAAB340, AircraftType
from aerotruth.units import FPM, FT, KT

EFFECT_COLUMNS = {
    "heading_offset": ("A_deg",),
    "heading_deviation_1psi": ("B_deg", "C_deg"),
    "tas_scale": ("k",),
    "heading_time_offset": ("D_s",),
    "heading_slaving_lag": ("tau_s",),  # nonlinear: profile search (needs heading_deviation_1psi)
}


def _igrf_declination_deg(lon, lat, alt_m, when) -> np.ndarray:
    """IGRF declination (deg, east positive) from one ppigrf call: points (arrays) on a date,
    or one point on several dates (`when` a list), flattened."""
    import ppigrf

    be, bn, _ = ppigrf.igrf(lon, lat, np.asarray(alt_m, float) / 1000.0, when)
    return np.degrees(np.arctan2(np.ravel(be), np.ravel(bn)))


def declination_deg(lat, lon, alt_m, when: dt.datetime) -> np.ndarray:
    """IGRF declination (deg, east positive) at the points for the date (ppigrf)."""
    lat, lon, alt = (np.atleast_1d(np.asarray(a, float)) for a in (lat, lon, alt_m))
    # the field changes little over a flight: evaluate on a coarse set and interpolate
    idx = np.linspace(0, len(lat) - 1, min(len(lat), 50)).astype(int)
    dec = _igrf_declination_deg(lon[idx], lat[idx], alt[idx], when)
    return np.interp(np.arange(len(lat)), idx, dec) if len(idx) > 1 else np.full(len(lat), dec[0])


def declination_history_deg(lat: float, lon: float, alt_m: float, dates: list[dt.datetime]) -> np.ndarray:
    """IGRF declination (deg, east positive) at one point on each of `dates`: one ppigrf
    call for them all (ppigrf re-reads and interpolates its coefficients per call)."""
    return _igrf_declination_deg(np.array([float(lon)]), np.array([float(lat)]), np.array([float(alt_m)]), list(dates))


SEGMENT_GAP_S = 30.0  # a longer gap (a climb, a descent, another leg) starts a new wind segment
SLAVING_TAU_GRID_S = tuple(float(x) for x in np.geomspace(2.0, 300.0, 41))
RATE_HALF_WINDOW_S = 3.0
# A wind segment shorter than the knot spacing gets no more freedom per minute than one
# spline interval has (4 coefficients per knot_s): a polynomial of degree
# floor(4 duration / knot_s), constant up to knot_s / 4. A cubic on every 1-3-min stretch
# between two zero-g parabolas follows the air vector's rotation through a turn, and the
# TAS scale left to explain the rest was -3.8 % on the A310 flight; this rule alone takes
# it to -0.1 % (tests/test_diagnose_modes.py).
SHORT_SEGMENT_DOF_PER_KNOT = 4


def _one_spline(t: np.ndarray, knot_s: float) -> np.ndarray:
    """The wind's basis on one segment: cubic B-splines with knots every ~knot_s, or on a
    segment shorter than knot_s the polynomial of degree floor(4 duration / knot_s)
    (Bernstein basis)."""
    t0, t1 = float(t.min()), float(t.max())
    degree = min(3, int(SHORT_SEGMENT_DOF_PER_KNOT * (t1 - t0) / knot_s))
    if degree == 0:
        return np.ones((len(t), 1))
    if t1 - t0 < knot_s:
        knots = np.r_[[t0] * (degree + 1), [t1] * (degree + 1)]
        return BSpline.design_matrix(np.clip(t, t0, t1), knots, degree).toarray()
    n_int = max(1, int(np.ceil((t1 - t0) / knot_s)))
    inner = np.linspace(t0, t1, n_int + 1)
    knots = np.r_[[t0] * 3, inner, [t1] * 3]
    n = len(knots) - 4
    return BSpline.design_matrix(np.clip(t, t0, t1), knots, 3).toarray()[:, :n]


def _spline_basis(t: np.ndarray, knot_s: float) -> np.ndarray:
    """Cubic B-splines in time (a lower-degree polynomial on a segment shorter than
    knot_s: `_one_spline`), one independent set per segment: the wind is smooth along
    a stretch of flight at one level, not across a gap where the aircraft changed level or
    leg (the wind at another height is another wind). Read-only: the last few bases are
    kept (keyed by the times themselves), as the diagnose's profiles, folds and jackknife
    ask for the same one dozens of times."""
    key = (float(knot_s), np.ascontiguousarray(t, dtype=float).tobytes())
    basis = _BASES.get(key)
    if basis is None:
        order = np.argsort(t, kind="stable")
        ts = t[order]
        cuts = np.flatnonzero(np.diff(ts) > SEGMENT_GAP_S) + 1
        blocks = [_one_spline(seg, knot_s) for seg in np.split(ts, cuts)]
        basis = np.zeros((len(t), sum(b.shape[1] for b in blocks)))
        r = c = 0
        for b in blocks:
            basis[order[r : r + len(b)], c : c + b.shape[1]] = b
            r, c = r + len(b), c + b.shape[1]
        basis.flags.writeable = False
        if len(_BASES) >= 4:
            _BASES.pop(next(iter(_BASES)))
        _BASES[key] = basis
    return basis


_BASES: dict[tuple[float, bytes], np.ndarray] = {}


def slaving_lag(t: np.ndarray, x: np.ndarray, tau_s: float) -> np.ndarray:
    """x passed through de/dt = (x - e) / tau (exact for x held over each sample
    interval): e_k = a_k e_(k-1) + (1 - a_k) x_(k-1), a_k = exp(-dt_k / tau), e_0 = x_0,
    restarted after each gap longer than SEGMENT_GAP_S; t increasing."""
    from scipy.signal import lfilter

    out = np.empty(len(x))
    cuts = np.flatnonzero(np.diff(t) > SEGMENT_GAP_S) + 1
    for seg in np.split(np.arange(len(t)), cuts):
        xs = x[seg]
        a = np.exp(-np.diff(t[seg]) / tau_s)
        e = np.empty(len(xs))
        e[0] = xs[0]
        if len(a) and np.allclose(a, a[0]):  # equal spacing: one linear filter
            e[1:], _ = lfilter([1 - a[0]], [1, -a[0]], xs[:-1], zi=[a[0] * xs[0]])
        else:
            for k in range(1, len(xs)):
                e[k] = a[k - 1] * e[k - 1] + (1 - a[k - 1]) * xs[k - 1]
        out[seg] = e
    return out


def design(
    track: pd.DataFrame, knot_s: float, effects: tuple[str, ...], tau_s: float = 0.0
) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """(X, y, names) of the stacked north/east equations for the chosen effects (with
    `tau_s` > 0 the deviation reaches the heading through the gyro's slaving lag).
    track: time_s, tas_mps (horizontal), heading_rad (true), vn_mps, ve_mps, heading_rate_rad_s."""
    t = track["time_s"].to_numpy(float)
    tas = track["tas_mps"].to_numpy(float)
    # the air vector's direction: the heading, less the bank geometry when the frame has it
    psi = (track["air_track_rad"] if "air_track_rad" in track else track["heading_rad"]).to_numpy(float)
    van, vae = tas * np.cos(psi), tas * np.sin(psi)
    y = np.r_[track["vn_mps"].to_numpy(float) - van, track["ve_mps"].to_numpy(float) - vae]
    basis = _spline_basis(t, knot_s)
    n, nb = basis.shape
    names = [f"wind_n_{j}" for j in range(nb)] + [f"wind_e_{j}" for j in range(nb)]
    dn, de = -tas * np.sin(psi), tas * np.cos(psi)  # dV_A/dpsi per radian
    rad = np.pi / 180.0
    extra = []  # the effects' columns, each (2n, q)
    for eff in effects:
        if eff == "heading_offset":
            extra.append(np.r_[dn, de][:, None] * rad)
        elif eff == "heading_deviation_1psi":
            sp, cp = np.sin(psi), np.cos(psi)
            if tau_s > 0:
                sp, cp = slaving_lag(t, sp, tau_s), slaving_lag(t, cp, tau_s)
            extra.append(np.column_stack([np.r_[dn * sp, de * sp], np.r_[dn * cp, de * cp]]) * rad)
        elif eff == "heading_slaving_lag":
            continue  # tau_s: the deviation's columns above
        elif eff == "tas_scale":
            extra.append(np.r_[van, vae][:, None])
        elif eff == "heading_time_offset":
            r = track["heading_rate_rad_s"].to_numpy(float)
            extra.append(np.r_[dn * r, de * r][:, None])  # correction + r D
        else:
            raise ValueError(f"effects: unknown effect {eff!r}; expected one of {', '.join(EFFECT_COLUMNS)}")
        names += list(EFFECT_COLUMNS[eff])
    # [[basis, 0], [0, basis]] for the north and east wind, then the effects: filled in place
    X = np.zeros((2 * n, 2 * nb + sum(e.shape[1] for e in extra)))
    X[:n, :nb] = basis
    X[n:, nb : 2 * nb] = basis
    c = 2 * nb
    for e in extra:
        X[:, c : c + e.shape[1]] = e
        c += e.shape[1]
    return X, y, names


def fit(
    track: pd.DataFrame, knot_s: float = 600.0, effects: tuple[str, ...] = (), rows: np.ndarray | None = None
) -> dict:
    """Least-squares fit of the smooth wind and the chosen effects (on `rows` if given):
    coefficients with standard errors, residual RMS (m/s, per component) and the number
    of equations. The standard errors are the least-squares ones scaled by the residual
    variance and inflated for serial correlation: successive samples of held, quantized
    registers are not independent; with the residuals' lag-1 autocorrelation rho the
    variance of a mean grows by (1 + rho) / (1 - rho) (AR(1)). With the slaving lag among
    the effects, tau_s (from the RSS profile over SLAVING_TAU_GRID_S) is appended to names
    and coef (its se from the profile's curvature: Delta RSS = s^2, AR(1)-inflated)."""
    if "heading_slaving_lag" in effects:
        grid = SLAVING_TAU_GRID_S
        fits = [_fit_linear(track, knot_s, effects, rows, tau) for tau in grid]
        j = int(np.argmin([f["rss"] for f in fits]))
        best, tau, se_tau = fits[j], grid[j], np.nan
        if 0 < j < len(grid) - 1:
            # the RSS profile's parabola in ln tau through the grid minimum and its neighbours:
            # its vertex is the estimate (continuous, so jackknife replicates differ), its
            # curvature the standard error (Delta RSS = s^2, AR(1)-inflated)
            x, yv = np.log(np.array(grid[j - 1 : j + 2])), np.array([f["rss"] for f in fits[j - 1 : j + 2]])
            c2, c1, _ = np.polyfit(x, yv, 2)
            if c2 > 0:
                tau = float(np.exp(np.clip(-c1 / (2 * c2), x[0], x[2])))
                best = _fit_linear(track, knot_s, effects, rows, tau)
                s2 = best["rss"] / max(best["n"] - best["p"], 1)
                se_tau = tau * float(np.sqrt(s2 * best["inflate"] / c2))
        best["names"] = best["names"] + ["tau_s"]
        best["coef"] = np.r_[best["coef"], tau]
        best["se"] = np.r_[best["se"], se_tau]
        best["p"] += 1
        best["tau_s"] = float(tau)
        return best
    return _fit_linear(track, knot_s, effects, rows, 0.0)


def _fit_linear(
    track: pd.DataFrame, knot_s: float, effects: tuple[str, ...], rows: np.ndarray | None, tau_s: float
) -> dict:
    X, y, names = design(track, knot_s, effects, tau_s)
    if rows is not None:
        sel = np.r_[rows, rows]
        X, y = X[sel], y[sel]
    coef, xtx = ols(X, y)
    res = y - X @ coef
    dof = max(len(y) - X.shape[1], 1)
    s2 = float(res @ res / dof)
    cov = s2 * np.linalg.pinv(xtx)
    half = len(res) // 2
    r_n, r_e = res[:half], res[half:]
    rho = float(
        np.mean([np.corrcoef(r[:-1], r[1:])[0, 1] for r in (r_n, r_e) if len(r) > 3 and np.std(r) > 0] or [0.0])
    )
    rho = min(max(rho, 0.0), 0.95)
    inflate = (1 + rho) / (1 - rho)
    se = np.sqrt(np.maximum(np.diag(cov), 0.0) * inflate)
    return {
        "names": names,
        "coef": coef,
        "se": se,
        "rms": float(np.sqrt(np.mean(res**2))),
        "n": len(y),
        "p": X.shape[1],
        "rss": float(res @ res),
        "inflate": inflate,
        "tau_s": float(tau_s),
    }


def predict_rms(track: pd.DataFrame, fitted: dict, knot_s: float, effects: tuple[str, ...], rows: np.ndarray) -> float:
    """Held-out check: the effect parameters learned elsewhere are applied to `rows`; the
    wind spline there is refitted (it is nuisance, local in time): RMS of the residual."""
    X, y, names = design(track, knot_s, effects, fitted.get("tau_s", 0.0))
    sel = np.r_[rows, rows]
    X, y = X[sel], y[sel]
    eff = [i for i, n in enumerate(names) if not n.startswith("wind_")]
    y_adj = y - (X[:, eff] @ fitted["coef"][: X.shape[1]][eff] if eff else 0.0)
    wind = [i for i, n in enumerate(names) if n.startswith("wind_")]
    coef, _ = ols(X[:, wind], y_adj)
    res = y_adj - X[:, wind] @ coef
    return float(np.sqrt(np.mean(res**2)))


def tas_scale_heading_free(
    track: pd.DataFrame, knot_s: float = 600.0, rows: np.ndarray | None = None, iterations: int = 8
) -> float:
    """The TAS scale k from the speeds alone, no heading: |V_G - W(t)| = (1 + k) TAS_h,
    the ground velocity (ADS-B) less the smooth wind (the same basis as `design`) against
    the horizontal TAS (BDS 5,0); Gauss-Newton from W = 0 (the wind is small against the
    airspeed). Neither the heading (BDS 6,0), its deviation, its timing nor the angle of
    attack enters: a second path to the scale, independent of the heading's errors. The
    scale is seen where the ground track turns within a wind segment; NaN on fewer than
    20 samples."""
    sel = slice(None) if rows is None else rows
    t = track["time_s"].to_numpy(float)
    basis = _spline_basis(t, knot_s)[sel]
    vn, ve = track["vn_mps"].to_numpy(float)[sel], track["ve_mps"].to_numpy(float)[sel]
    tas = track["tas_mps"].to_numpy(float)[sel]
    if len(tas) < 20:
        return float("nan")
    wn, we = np.zeros(len(tas)), np.zeros(len(tas))
    k = 0.0
    for _ in range(iterations):
        dn, de = vn - wn, ve - we
        speed = np.hypot(dn, de)
        un, ue = dn / speed, de / speed
        # |V_G - W| ~ |V_G - W0| - u.(W - W0): u.W + k TAS = |V_G - W0| + u.W0 - TAS
        X = np.column_stack([un[:, None] * basis, ue[:, None] * basis, tas])
        y = speed + un * wn + ue * we - tas
        coef, _ = ols(X, y)
        nb = basis.shape[1]
        wn, we, k_new = basis @ coef[:nb], basis @ coef[nb : 2 * nb], float(coef[-1])
        if abs(k_new - k) < 1e-7:
            return k_new
        k = k_new
    return k


def central_rate(t: np.ndarray, x: np.ndarray, half_window_s: float = RATE_HALF_WINDOW_S) -> np.ndarray:
    """Rate of a held (staircase) signal over +-half_window_s, t increasing."""
    return (np.interp(t + half_window_s, t, x) - np.interp(t - half_window_s, t, x)) / (2 * half_window_s)


ALTITUDE_RATE_HALF_WINDOW_S = 10.0  # a held altitude in 25-ft steps: +-3 s would read 250 ft/min of steps


def flight_path_angle_rad(df: pd.DataFrame) -> np.ndarray:
    """The air path's climb angle gamma, sin(gamma) = vertical rate / TAS, from the
    vertical rate (ft/min; BDS 0,9 or 6,0) where the samples carry it, else from the
    barometric altitude's rate (ft) over +-ALTITUDE_RATE_HALF_WINDOW_S; zero without
    either. df: time_s (increasing), TAS (kt), and vertical_rate or altitude."""
    tas = np.maximum(df["TAS"].to_numpy(float) * KT, 1.0)
    t = df["time_s"].to_numpy(float)
    vz = np.full(len(df), np.nan)
    if "vertical_rate" in df:
        vz = df["vertical_rate"].to_numpy(float) * FPM
    if np.isnan(vz).any() and "altitude" in df and len(df) > 1:
        alt = df["altitude"].to_numpy(float) * FT
        ok = np.isfinite(alt)
        if ok.sum() > 1:
            filled = np.interp(t, t[ok], alt[ok])
            vz = np.where(np.isnan(vz), central_rate(t, filled, ALTITUDE_RATE_HALF_WINDOW_S), vz)
    return np.arcsin(np.clip(np.nan_to_num(vz) / tas, -1.0, 1.0))


def modes_track_to_wind_frame(
    df: pd.DataFrame, when: dt.datetime, aircraft: AircraftType | None = SAAB340
) -> pd.DataFrame:
    """A Mode-S trajectory (decoded fields in knots/degrees, heading magnetic) as the
    table `design` needs, in SI, with true heading and heading rate (rows sorted by time,
    repeated times dropped).

    * The air vector of the wind triangle is horizontal: BDS 5,0 TAS is along the air
      path, so its horizontal part is TAS cos(gamma) (`tas_mps`; gamma from
      `flight_path_angle_rad`, in `gamma_rad`; the TAS as reported in `tas_path_mps`).
    * With roll (BDS 5,0) and an aircraft type, the air track psi - a sin(phi)
      (`air_track_rad`): the body-axis air velocity (V cos a, 0, V sin a), rolled by phi,
      puts V sin(a) sin(phi) sideways (a right bank swings it left of the nose).
      Unmodelled, it reads as a heading time offset of about -a V / g (-0.5 s for the
      SAAB 340: in a coordinated turn r = g tan(phi) / V). Mode-S gives roll, not a: the
      type's lift equation gives it (aerotruth.truth.aircraft_types)."""
    df = df.sort_values("time_s", kind="stable").drop_duplicates("time_s")
    dec = declination_deg(df["latitude"], df["longitude"], df["altitude"].to_numpy(float) * FT, when)
    psi = np.radians(df["heading"].to_numpy(float) + dec)
    trk = np.radians(df["track"].to_numpy(float))
    gs = df["groundspeed"].to_numpy(float) * KT
    t = df["time_s"].to_numpy(float)
    psi_u = np.unwrap(psi)
    # heading rate over +-RATE_HALF_WINDOW_S: a held, quantized heading differenced
    # sample to sample is a staircase, and a noisy regressor biases D towards zero
    rate = central_rate(t, psi_u)
    tas_path = df["TAS"].to_numpy(float) * KT
    gamma = flight_path_angle_rad(df)
    out = pd.DataFrame(
        {
            "time_s": t,
            "tas_mps": tas_path * np.cos(gamma),
            "heading_rad": psi,
            "vn_mps": gs * np.cos(trk),
            "ve_mps": gs * np.sin(trk),
            "heading_rate_rad_s": rate,
            "declination_deg": dec,
            "tas_path_mps": tas_path,
            "gamma_rad": gamma,
        }
    )
    if aircraft is not None and "roll" in df and df["roll"].notna().all():
        roll = np.radians(df["roll"].to_numpy(float))
        a = np.radians(aircraft.alpha_deg(tas_path, df["altitude"].to_numpy(float) * FT, roll))
        out["air_track_rad"] = psi - a * np.sin(roll)
    return out
