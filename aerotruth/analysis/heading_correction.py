"""The wind paper's heading-deviation correction as an estimator: learn an aircraft's
flux-valve deviation from its wind reports and reference-model winds, then correct.

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

Model (wind paper eq. 2), d as a function of the measured heading z':

    d = A + B sin z' + C cos z' + D sin 2z' + E cos 2z'

Noise: a reference-wind error e (per component sd sigma) moves psi' by e_perp/TAS, so
d_i = x_i b + n_i with var(n_i) = sigma^2 / TAS_i^2: base weights w_i = (TAS_i/median)^2.
For independent Gaussian errors the Cramer-Rao bound of b is sigma_d^2 (X^T W X)^-1
(sigma_d the sd at the median TAS), which weighted least squares attains.

Robust loss: Huber M-estimate, psi(u) = clip(u, -c, c) on u_i = sqrt(w_i) r_i / s,
c = 1.345 (95 % efficiency under Gaussian noise), scale s = 1.4826 MAD re-estimated each
iteration. Solved by Newton steps on the estimating equations sum_i x_i sqrt(w_i) psi(u_i)
= 0, b += B^-1 h with B = sum over |u_i| <= c of x_i x_i^T w_i and h = s sum_i x_i sqrt(w_i)
psi(u_i) (the Huber loss is piecewise quadratic, so a step is exact once the set of clipped
reports stops changing): 2.0 steps per fit from the least-squares start against IRLS's
4.1 on the method benchmark (12 aircraft x 1000 flights), coefficients equal to 1.6e-6 deg
(the same fixed point; IRLS takes over if a step's matrix is singular, condition number
> 1e10, or Newton has not converged in 20 steps). Where the unclipped reports
leave a term nearly unidentified (nearly all on one heading) the joint iteration of b and
s can have several fixed points and the two algorithms may stop at different ones.
Standard errors: cluster-robust sandwich with whole flights as clusters
(reference-model errors are correlated along a flight) in its jackknife form (CR3):
cov = (G-1)/G sum_g q_g q_g^T, q_g = (B - B_g)^-1 h_g, B = sum_i x_i x_i^T w_i psi'(u_i)/s,
B_g the same over flight g, h_g = sum_{i in g} x_i sqrt(w_i) psi(u_i) (the plain sandwich
B^-1 h_g undercovers by 5-10 % in se with ~40 flights of unequal size, measured).

Bootstrap (`HeadingDeviationFit.bootstrap`): whole flights resampled with replacement,
symmetric bootstrap-t intervals b -+ q se with q the quantile of |b* - b| / se* (CR3 se of
each resample); percentile intervals on request (they undercover with ~40 flights).

Identifiability of the sinusoid: the weighted covariance of (sin z', cos z') over the
used reports has two eigenvalues (headings uniform round the compass give 0.5 and 0.5).
Both >= 0.1: B, C are fitted. Only the larger one (one route flown both ways, e.g. a hub
with its spokes on one side, as PenAir's Anchorage-south-west network; 1 and ~0): the
data fix the deviation on the flown headings z_a and z_a + 180 and so the sinusoid's
component along that axis, s cos(z' - z_a), but nothing of the perpendicular
component; the fit is A + s cos(z' - z_a) (B = s sin z_a, C = s cos z_a, their standard
errors the one of s projected, status `fitted`, the axis named in `reason`): the minimum-
norm sinusoid, exact on the headings flown. (Measured on the PenAir campaign, 5 seeds,
spread ~0.04: fitting both terms anyway, from the few gated off-axis climb reports, made
the uploaded table's steady-flight heading error worse by 0.14 +- 0.06 deg, paired on the
same flights.) Both < 0.1 (one heading): only the offset A
(status `offset_only`, said in `reason`). D, E need the same of (sin 2z', cos 2z') and are kept only when the
cluster-robust Wald test of D = E = 0 rejects at level 0.001 (F(2, G-1), G flights) —
a Wald test on flight clusters, not dBIC: BIC counts correlated reports as independent.

Several reference models ("combined references"): every (report, model) pair is a row
of the fit, clustered by flight. Cross-model consistency (wind paper section 5: "if both
models predicted a similar curve then the results are believable"): each model fitted
alone with the same terms, from the pooled coefficients as the one-step M-estimator (one
Newton step of that model's own estimating equations at its own MAD scale; Bickel 1975,
JASA 70: from a root-n consistent start, asymptotically the fully iterated fit), kept when
a further step would move no coefficient by more than 0.1 standard error, else iterated to
convergence (models far apart). On the method benchmark's 12 aircraft x 1000 flights
every step is kept: p-values within 0.002 and curve differences within 1e-4 deg of the
iterated fits, the fit stage 15 % faster; for each pair a Wald test of equal coefficients
with the covariance of the difference from the flight-cluster influences (the fits share
the reports), F(k, G-1), Bonferroni-adjusted over the pairs; p < 0.01 is reported as a
disagreement (the fit is kept; `reason` says so).

Lookup table (wind paper section 8.1): corrections to *add* to the measured heading at
0, 45, ..., 315 deg, lut_k = -d(z_k); `correct` interpolates it piecewise linearly round
the circle. Aircraft whose avionics give TAMDAR true heading can only have an offset
corrected (wind paper section 8.4, Chautauqua ERJs): offset-only fit and table.

Heading frames: `heading="true"` fits on the true measured heading (the paper's choice);
`heading="magnetic"` on the magnetic heading the onboard table is indexed by: the
`heading_mag_deg` column, else true heading minus `declination_deg` (east positive).

Flights (clusters): the `flight` column when present, else a new flight wherever an
aircraft's consecutive reports are more than 30 min apart.
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from pydantic import Field
from scipy import stats

from aerotruth.analysis.fast_trig import sin_cos
from aerotruth.config import Section
from aerotruth.ellipsoid import A_M, E2, radii_from_sin
from aerotruth.errors import DataError
from aerotruth.units import DEG, KT

REQUIRED_COLUMNS = ("aircraft", "time", "lat", "lon", "pressure_altitude_ft", "wind_speed_kt", "wind_dir_deg",
                    "ref_wind_speed_kt", "ref_wind_dir_deg")
OPTIONAL_NUMERIC = ("tas_kt", "heading_deg", "heading_mag_deg", "declination_deg", "roll_deg")
TERM_NAMES = ("A", "B", "C", "D", "E")
LUT_HEADINGS_DEG = np.arange(0.0, 360.0, 45.0)
LUT_COLUMNS = tuple(f"lut_{int(h):03d}_deg" for h in LUT_HEADINGS_DEG)
TABLE_COLUMNS = ("aircraft", "status", "reason", "n_used", *(f"{t}_deg" for t in TERM_NAMES),
                 *(f"{t}_se_deg" for t in TERM_NAMES), *LUT_COLUMNS, "valid_from", "valid_to")
STATUSES = ("fitted", "offset_only", "refused")
GATE_NAMES = ("used", "no_neighbours", "gap", "baseline", "collinearity", "speed_change", "roll", "implausible")


class GateSpec(Section):
    """Quality gates of the three-report ground track (wind paper section 5.1) and the
    plausibility limits of a report."""

    max_gap_s: float = Field(600.0, gt=0, description="largest time between adjacent reports of a triple")
    min_baseline_km: float = Field(0.0, ge=0, description="shortest distance from report i-1 to i+1 (0: none)")
    max_course_change_deg: float = Field(10.0, gt=0, description="collinearity: course i-1->i vs i->i+1, beyond "
                                         "what the position step can fake")
    max_speed_change: float = Field(0.10, gt=0, description="constant speed: |gs2 - gs1| / mean(gs), beyond what "
                                    "the position step can fake")
    max_track_noise: float = Field(0.5, gt=0, description="baseline: the rounding error of V_G from the position "
                                   "step (sd) over |V_G| at most this")
    position_step_deg: float = Field(0.01, ge=0, description="the reports' lat/lon resolution (TAMDAR: 0.01 deg)")
    noise_sigmas: float = Field(3.0, ge=0, description="the collinearity and speed limits widen by this many "
                                "standard deviations of the change the position step alone makes")
    max_roll_deg: float = Field(10.0, gt=0, description="reports banked more are dropped (wind paper section 4)")
    flight_gap_s: float = Field(1800.0, gt=0, description="a longer pause between reports starts a new flight")
    min_tas_kt: float = Field(60.0, ge=0, description="|V_A| below this is implausible")
    max_tas_kt: float = Field(600.0, gt=0, description="|V_A| above this is implausible")
    max_heading_error_deg: float = Field(30.0, gt=0, description="|psi - psi'| above this is a gross error")


# The gates of analyses that use the ground track itself, not only d (which V_G cancels
# from to first order): |V_A| and the along-track residuals of `aerotruth diagnose` move
# one for one with V_G's error, so they keep spans >= 10 km and fixed 10-deg / 10-% limits
# (0.01-deg rounding: <= ~0.45 km of difference error, <= 2.6 deg of track).
TRACK_GATES = GateSpec(min_baseline_km=10.0, noise_sigmas=0.0, max_track_noise=math.inf)


# ----------------------------------------------------------------------------- input

def _numeric(df: pd.DataFrame, col: str, source: str) -> np.ndarray:
    s = df[col]
    if s.dtype.kind in "biuf":
        return s.to_numpy(dtype=float)
    if s.dtype.kind == "b":
        raise DataError(f"{source}: column '{col}' holds true/false, expected numbers")
    num = pd.to_numeric(s, errors="coerce")
    bad = num.isna() & s.notna() & (s.astype(str).str.strip() != "")
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise DataError(f"{source}: column '{col}', data row {i + 1}: {s.iloc[i]!r} is not a number")
    return num.to_numpy(dtype=float)


# epoch seconds of 1950-01-01 and 2200-01-01: a plausible report time (epoch milliseconds
# of any date since 1970-04 lie beyond the latter)
_TIME_RANGE_S = (-631152000.0, 7258118400.0)


def _times(df: pd.DataFrame, source: str) -> np.ndarray:
    """UTC epoch seconds from epoch numbers or ISO-8601 text, checked to lie in 1950-2200."""
    t = _parse_times(df, source)
    bad = (t < _TIME_RANGE_S[0]) | (t > _TIME_RANGE_S[1])  # NaN (empty cells) passes
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        v = df["time"].iloc[i]
        v = v.item() if isinstance(v, np.generic) else v
        hint = " (milliseconds?)" if t[i] > _TIME_RANGE_S[1] else ""
        raise DataError(f"{source}: column 'time', data row {i + 1}: {v!r} is not a time between 1950 and "
                        f"2200 in UTC epoch seconds{hint}")
    return t


def _parse_times(df: pd.DataFrame, source: str) -> np.ndarray:
    s = df["time"]
    if s.dtype.kind in "iuf":
        return s.to_numpy(dtype=float)
    if s.dtype.kind == "M":
        ts = pd.to_datetime(s, utc=True)
    else:
        num = pd.to_numeric(s, errors="coerce")
        if num.notna().sum() == s.notna().sum():
            return num.to_numpy(dtype=float)
        ts = pd.to_datetime(s.where(num.isna()), utc=True, errors="coerce", format="ISO8601")
        bad = ts.isna() & num.isna() & s.notna()
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            raise DataError(f"{source}: column 'time', data row {i + 1}: {s.iloc[i]!r} is neither UTC epoch seconds nor ISO-8601")
        iso = ((ts - pd.Timestamp("1970-01-01", tz="UTC")) / pd.Timedelta(1, "s")).to_numpy(dtype=float)
        return np.where(num.notna().to_numpy(), num.to_numpy(dtype=float), iso)
    return ((ts - pd.Timestamp("1970-01-01", tz="UTC")) / pd.Timedelta(1, "s")).to_numpy(dtype=float)


_RANGES = {"lat": (-90.0, 90.0), "lon": (-180.0, 360.0), "wind_speed_kt": (0.0, 500.0), "ref_wind_speed_kt": (0.0, 500.0),
           "wind_dir_deg": (0.0, 360.0), "ref_wind_dir_deg": (0.0, 360.0), "pressure_altitude_ft": (-2000.0, 70000.0),
           "tas_kt": (0.0, 1000.0), "heading_deg": (0.0, 360.0), "heading_mag_deg": (0.0, 360.0),
           "declination_deg": (-180.0, 180.0), "roll_deg": (-180.0, 180.0)}


def _labels(values: pd.Series, fill: str | None = None, lower: bool = False) -> pd.Categorical:
    """Text labels as a Categorical: stripped (and lower-cased if `lower`); empty or missing
    -> `fill` (None: missing)."""
    codes, uniques = pd.factorize(values, use_na_sentinel=True)
    names = np.array([(str(u).strip().lower() if lower else str(u).strip()) for u in uniques] + [""], dtype=object)
    names[names == ""] = fill if fill is not None else np.nan
    ucodes, cats = pd.factorize(pd.Series(names, dtype=object), use_na_sentinel=True)
    return pd.Categorical.from_codes(ucodes[codes], categories=pd.Index(cats, dtype=object))  # codes -1 -> last -> fill


def validate_observations(obs: pd.DataFrame, source: str = "observation table") -> pd.DataFrame:
    """An observation table (docs/data-formats.md) checked and normalised: `time_s` in UTC
    epoch seconds, numbers as float, `aircraft` and `ref_source` (filled "ref") as
    categoricals, sorted by aircraft, time and reference; rows with an empty required cell
    are dropped (count in attrs["dropped_empty"]), repeated (aircraft, time, ref_source)
    rows too (attrs["dropped_duplicates"]). Raises DataError (a ValueError) naming `source`
    and the column on anything else."""
    if not isinstance(obs, pd.DataFrame):
        raise DataError(f"{source}: expected a pandas DataFrame, got {type(obs).__name__}")
    missing = [c for c in REQUIRED_COLUMNS if c not in obs.columns]
    if missing:
        raise DataError(f"{source}: missing column '{missing[0]}' (an observation table needs {', '.join(REQUIRED_COLUMNS)})")
    if len(obs) == 0:
        raise DataError(f"{source}: no rows")
    out = {"aircraft": _labels(obs["aircraft"]), "time_s": _times(obs, source)}
    for c in REQUIRED_COLUMNS[2:] + tuple(c for c in OPTIONAL_NUMERIC if c in obs.columns):
        out[c] = _numeric(obs, c, source)
    for c, (lo, hi) in _RANGES.items():
        if c in out:
            v = out[c]
            if len(v) and lo <= np.fmin.reduce(v) and np.fmax.reduce(v) <= hi:  # NaN-blind extremes: no mask
                continue
            with np.errstate(invalid="ignore"):
                bad = (v < lo) | (v > hi)
            if bad.any():
                i = int(np.flatnonzero(bad)[0])
                raise DataError(f"{source}: column '{c}', data row {i + 1}: {v[i]:g} outside [{lo:g}, {hi:g}]")
    out["ref_source"] = _labels(obs["ref_source"], "ref") if "ref_source" in obs.columns else pd.Categorical(np.full(len(obs), "ref"))
    if "flight" in obs.columns:  # `phase` is not used by the method
        out["flight"] = _labels(obs["flight"], "")
    if "heading_input" in obs.columns:  # a word, in any case ("TRUE", "Magnetic")
        out["heading_input"] = _labels(obs["heading_input"], "", lower=True)
    if "heading_input" in out:
        vals = set(out["heading_input"].categories) - {"", "true", "magnetic"}
        if vals:
            raise DataError(f"{source}: column 'heading_input': {sorted(vals)[0]!r}, expected 'magnetic' or 'true'")
    ac_code = out["aircraft"].codes
    keep = ac_code >= 0
    for c in ("time_s", *REQUIRED_COLUMNS[2:]):
        keep &= np.isfinite(out[c])
    ref_code = out["ref_source"].codes
    order = np.lexsort((ref_code, out["time_s"], ac_code))
    order = order[keep[order]]
    a, t, r = ac_code[order], out["time_s"][order], ref_code[order]
    dup = np.zeros(len(order), dtype=bool)
    dup[1:] = (a[1:] == a[:-1]) & (t[1:] == t[:-1]) & (r[1:] == r[:-1])
    order = order[~dup]
    if len(order) == 0:
        raise DataError(f"{source}: every row has an empty required cell")
    if len(order) == len(obs) and np.array_equal(order, np.arange(len(order))):  # already in order: no copies
        df = pd.DataFrame(out, copy=False)
    else:
        df = pd.DataFrame({k: (v[order] if isinstance(v, np.ndarray) else v.take(order)) for k, v in out.items()},
                          copy=False)  # copy=False: no consolidation into one block (a copy of every column)
    _check_report_rows(df, source)
    df.attrs.update(source=source, dropped_empty=int((~keep).sum()), dropped_duplicates=int(dup.sum()))
    return df


REPORT_OWN_COLUMNS = ("wind_speed_kt", "wind_dir_deg", "heading_deg", "tas_kt", "heading_mag_deg", "declination_deg",
                      "lat", "lon", "roll_deg")


def _check_report_rows(df: pd.DataFrame, source: str) -> None:
    """The rows of one report (same aircraft and time, one per reference model) must agree
    on the aircraft's own values (REPORT_OWN_COLUMNS): `heading_errors` takes them once per
    report. `df` sorted by aircraft and time."""
    ac, t = df["aircraft"].cat.codes.to_numpy(), df["time_s"].to_numpy()
    same_rep = (ac[1:] == ac[:-1]) & (t[1:] == t[:-1])  # row i+1 repeats row i's report
    if not same_rep.any():
        return
    for c in REPORT_OWN_COLUMNS:
        if c not in df.columns:
            continue
        v = df[c].to_numpy()
        bad = (v[1:] != v[:-1]) & same_rep
        if bad.any():
            j = np.flatnonzero(bad)
            j = j[~(np.isnan(v[j]) & np.isnan(v[j + 1]))]  # both empty: the same
            if len(j):
                i = int(j[0]) + 1
                raise DataError(f"{source}: column '{c}': the rows of one report (aircraft {df['aircraft'].iloc[i]}, "
                                f"time {t[i]:.3f}) differ ({v[i - 1]:g} vs {v[i]:g}); a report's own values must be "
                                f"the same on each reference model's row")


# ----------------------------------------------------------------------------- section 5.1

def towards_from_report(speed_kt, dir_from_deg) -> tuple[np.ndarray, np.ndarray]:
    """(u east, v north) in m/s of a reported wind (speed kt, meteorological "from" deg)."""
    s = np.asarray(speed_kt, dtype=float)
    u, v = sin_cos(np.asarray(dir_from_deg, dtype=float) * DEG)
    for x in (u, v):  # in place: no third array (fresh memory costs more than a pass)
        x *= s
        x *= -KT
    return u, v


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


def step_noise(lat_rad: np.ndarray, span_e: np.ndarray, span_n: np.ndarray, span: np.ndarray, gs1: np.ndarray,
               gs2: np.ndarray, t1: np.ndarray, t2: np.ndarray, step_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
    rm, rn = radii_from_sin(sin_lat)
    s = math.radians(step_deg) / math.sqrt(12.0)
    s_n, s_e = rm * s, rn * cos_lat * s
    with np.errstate(divide="ignore", invalid="ignore"):
        sc, cc = span_e / span, span_n / span
        s_x = np.sqrt((s_e * cc) ** 2 + (s_n * sc) ** 2)
        s_a = np.sqrt((s_e * sc) ** 2 + (s_n * cc) ** 2)
        l1, l2 = gs1 * t1, gs2 * t2
        sd_course = np.degrees(s_x * np.sqrt(1 / l1**2 + (1 / l1 + 1 / l2) ** 2 + 1 / l2**2))
        sd_speed = s_a * np.sqrt(1 / t1**2 + (1 / t1 + 1 / t2) ** 2 + 1 / t2**2) / (0.5 * (gs1 + gs2))
        rel_vg = np.sqrt(2.0 * (s_e**2 + s_n**2)) / span
    return sd_course, sd_speed, rel_vg


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
    rep_of_row = np.cumsum(new_rep)
    rep_of_row -= 1
    first = np.flatnonzero(new_rep)
    m = len(first)
    rt, rac = t[first], ac[first]
    lat = df["lat"].to_numpy()[first] * DEG
    lon = df["lon"].to_numpy()[first] * DEG
    new_fl = np.ones(m, dtype=bool)
    new_fl[1:] = (rac[1:] != rac[:-1]) | (np.diff(rt) > g.flight_gap_s)
    if "flight" in df.columns:
        rfl = df["flight"].cat.codes.to_numpy()[first]
        new_fl[1:] |= rfl[1:] != rfl[:-1]
    flight = np.cumsum(new_fl) - 1
    de, dn = segment_displacements(lat, lon)
    dts = np.diff(rt)
    same = flight[1:] == flight[:-1]
    # for report k: segment 1 = seg[k-1], segment 2 = seg[k]; the gates on the interior
    # reports (the first and last have one segment and fail `has` first)
    has = np.zeros(m, dtype=bool)
    has[1:-1] = same[:-1] & same[1:]

    def interior(v):  # per report, 0 at the ends
        out = np.zeros(m, dtype=v.dtype)
        out[1:-1] = v
        return out

    # V_G = (p[k+1] - p[k-1]) / (t[k+1] - t[k-1]); one segment's velocity at the ends
    vg_e, vg_n = np.empty(m), np.empty(m)
    with np.errstate(divide="ignore", invalid="ignore"):
        if m >= 2:
            span_dt = dts[:-1] + dts[1:]
            span_e, span_n = de[:-1] + de[1:], dn[:-1] + dn[1:]
            np.divide(span_e, span_dt, out=vg_e[1:-1])
            np.divide(span_n, span_dt, out=vg_n[1:-1])
            vg_e[0], vg_n[0], vg_e[-1], vg_n[-1] = de[0] / dts[0], dn[0] / dts[0], de[-1] / dts[-1], dn[-1] / dts[-1]
            seg_gs = np.hypot(de, dn) / dts
            # course change between the segments: the angle between them (atan2 of their cross
            # and dot products), in [0, 180]
            e1, n1, e2, n2 = de[:-1], dn[:-1], de[1:], dn[1:]
            dcourse = np.degrees(np.abs(np.arctan2(e1 * n2 - n1 * e2, e1 * e2 + n1 * n2)))
            dspeed = np.abs(np.diff(seg_gs)) / (0.5 * (seg_gs[:-1] + seg_gs[1:]))
            dt1, dt2 = dts[:-1], dts[1:]
            span = np.hypot(span_e, span_n)
            # the rounding's own noise (step_noise) only where the plain limits fail: elsewhere
            # the widened gates pass whatever it is (V_G's rounding error is at most
            # _MAX_STEP_NOISE_M * step in metres per degree: the span gate passes above that)
            sd_course, sd_speed, rel_vg = np.zeros(m - 2), np.zeros(m - 2), np.zeros(m - 2)
            safe_span = _MAX_STEP_NOISE_M * g.position_step_deg / max(g.max_track_noise, 1e-300)
            with np.errstate(invalid="ignore"):
                plain = (dcourse <= g.max_course_change_deg) & (dspeed <= g.max_speed_change) & (span >= safe_span)
            i = np.flatnonzero(~plain)
            sd_course[i], sd_speed[i], rel_vg[i] = step_noise(lat[1:-1][i], span_e[i], span_n[i], span[i], seg_gs[i],
                                                              seg_gs[i + 1], dt1[i], dt2[i], g.position_step_deg)
            checks = [
                ~has,
                ~interior((dt1 > 0) & (dt2 > 0) & (dt1 <= g.max_gap_s) & (dt2 <= g.max_gap_s)),
                ~interior((span >= g.min_baseline_km * 1000.0) & (rel_vg <= g.max_track_noise)),
                ~interior(dcourse <= g.max_course_change_deg + g.noise_sigmas * sd_course),
                ~interior(dspeed <= g.max_speed_change + g.noise_sigmas * sd_speed),
            ]
        else:  # one report
            vg_e[:], vg_n[:] = np.nan, np.nan
            checks = [~has] + [np.zeros(m, dtype=bool)] * 4
    gate = np.zeros(m, dtype=np.int8)
    for code in range(len(checks), 0, -1):  # first failing gate wins
        gate[checks[code - 1]] = code
    # the aircraft's side, once per report (validate_observations checked its rows agree)
    wt_e, wt_n = towards_from_report(df["wind_speed_kt"].to_numpy()[first], df["wind_dir_deg"].to_numpy()[first])
    va_e_r, va_n_r = vg_e - wt_e, vg_n - wt_n  # wind paper eq. 3
    psi = np.degrees(np.arctan2(va_e_r, va_n_r))
    psi += 360.0 * (psi < 0)
    heading = psi
    if "heading_deg" in df.columns:
        h = df["heading_deg"].to_numpy()[first]
        heading = np.where(np.isfinite(h), wrap(h, 360.0), psi)
    tas = np.hypot(va_e_r, va_n_r)
    if "tas_kt" in df.columns:
        tk = df["tas_kt"].to_numpy()[first] * KT
        tas = np.where(np.isfinite(tk), tk, tas)
    heading_mag = np.full(m, np.nan)
    if "declination_deg" in df.columns:
        heading_mag = wrap(heading - df["declination_deg"].to_numpy()[first], 360.0)
    if "heading_mag_deg" in df.columns:
        hm = df["heading_mag_deg"].to_numpy()[first]
        heading_mag = np.where(np.isfinite(hm), wrap(hm, 360.0), heading_mag)
    # per (report, model) row: V_A' = V_G - V_W,REF = V_A + dw with dw = V_W,TAM - V_W,REF
    # (eqs. 3, 4), so d = angle(V_A) - angle(V_A') from V_A and dw alone
    wr_e, wr_n = towards_from_report(df["ref_wind_speed_kt"].to_numpy(), df["ref_wind_dir_deg"].to_numpy())
    dw_e, dw_n = wt_e[rep_of_row], wt_n[rep_of_row]
    dw_e -= wr_e
    dw_n -= wr_n
    va_e, va_n = va_e_r[rep_of_row], va_n_r[rep_of_row]
    # d = psi - psi' wrapped to (-180, 180]: the angle from V_A' to V_A, clockwise;
    # cross(V_A', V_A) = va_e dw_n - va_n dw_e, dot = |V_A|^2 + V_A . dw
    cross = va_e * dw_n
    cross -= np.multiply(va_n, dw_e, out=wr_e)
    dot = (va_e_r * va_e_r + va_n_r * va_n_r)[rep_of_row]
    dot += np.multiply(va_e, dw_e, out=wr_e)
    dot += np.multiply(va_n, dw_n, out=wr_e)
    d = np.degrees(np.arctan2(cross, dot, out=cross), out=cross)
    implausible = GATE_NAMES.index("implausible")
    with np.errstate(invalid="ignore"):  # TAS per report, |d| per row
        gate[(gate == 0) & ~((tas >= g.min_tas_kt * KT) & (tas <= g.max_tas_kt * KT))] = implausible
        row_gate = gate[rep_of_row]
        row_gate[(row_gate == 0) & ~(np.abs(d) <= g.max_heading_error_deg)] = implausible
    tas = tas[rep_of_row]
    true_input = (df["heading_input"] == "true").to_numpy() if "heading_input" in df.columns else np.zeros(n, dtype=bool)
    out = pd.DataFrame(copy=False, data={  # copy=False: not consolidated into one block (a full copy)
        "aircraft": df["aircraft"].array, "ref_source": df["ref_source"].array, "flight": flight[rep_of_row], "report": rep_of_row,
        "time_s": t, "heading_deg": heading[rep_of_row], "heading_mag_deg": heading_mag[rep_of_row], "error_deg": d,
        "tas_ms": tas, "va_e": va_e, "va_n": va_n, "dw_e": dw_e, "dw_n": dw_n,
        "gate": pd.Categorical.from_codes(row_gate, GATE_NAMES), "true_heading_input": true_input,
    })
    out.attrs.update(df.attrs)
    return out


# ----------------------------------------------------------------------------- fit core

def design(heading_deg: np.ndarray, k: int) -> np.ndarray:
    """Columns of wind paper eq. 2: 1, sin z, cos z, sin 2z, cos 2z (first k of them), (n, k)."""
    return design_t(heading_deg, k).T


def design_t(heading_deg: np.ndarray, k: int) -> np.ndarray:
    """The design of eq. 2 transposed, (k, n) with contiguous rows: the fits' per-report
    products and reductions run along rows."""
    z = np.asarray(heading_deg, dtype=float) * DEG
    XT = np.empty((k, len(z)))
    XT[0] = 1.0
    if k > 1:
        XT[1], XT[2] = sin_cos(z)
        if k > 3:  # double-angle identities: two fewer trig evaluations
            sz, cz = XT[1], XT[2]
            XT[3], XT[4] = 2 * sz * cz, (cz - sz) * (cz + sz)
    return XT


@dataclass
class _Fit:
    beta: np.ndarray
    cov: np.ndarray
    scale: float
    influence: np.ndarray  # (G, k): B^-1 h_g per flight cluster
    groups: np.ndarray  # cluster label of each influence row


def _starts(groups: np.ndarray) -> np.ndarray:
    return np.flatnonzero(np.r_[True, groups[1:] != groups[:-1]])


def robust_fit(X: np.ndarray, y: np.ndarray, w: np.ndarray, groups: np.ndarray, robust: bool = True,
               c: float = 1.345, max_iter: int = 50, beta0: np.ndarray | None = None) -> _Fit:
    """Huber M-estimate (or weighted least squares) with flight-cluster sandwich covariance
    on the (n, k) design X. Rows must be contiguous by `groups`."""
    return robust_fit_t(np.ascontiguousarray(X.T), y, w, groups, robust, c, max_iter, beta0)


def robust_fit_t(XT: np.ndarray, y: np.ndarray, w: np.ndarray, groups: np.ndarray, robust: bool = True,
                 c: float = 1.345, max_iter: int = 50, beta0: np.ndarray | None = None,
                 scale_guess: float = math.nan) -> _Fit:
    """robust_fit on the transposed (k, n) design, rows contiguous (as design_t gives);
    `scale_guess` (a nearby scale, e.g. with beta0 that of a related fit) only speeds up
    the first median."""
    beta, scale, r = _huber_t(XT, y, w, robust, c, max_iter, beta0, scale_guess)
    starts = _starts(groups)
    bread_g, scores = _cluster_parts(XT, r, w, starts, scale, c if robust else np.inf)
    infl, cov = _cr3(bread_g, scores)
    return _Fit(beta, cov, scale, infl, groups[starts])


def fit_from_t(XT: np.ndarray, y: np.ndarray, w: np.ndarray, groups: np.ndarray, beta: np.ndarray,
               scale_guess: float = math.nan, robust: bool = True, c: float = 1.345, tol_se: float = 0.1) -> _Fit:
    """The Huber fit of (XT, y, w) (as robust_fit_t) from a nearby start `beta`, as the
    one-step M-estimator (module docstring, cross-model consistency): one Newton step of the
    estimating equations at the rows' own MAD scale, kept when the next step would move no
    coefficient by more than `tol_se` of its standard error, else iterated to convergence.
    The CR3 covariance of a kept step carries each flight's scores linearly to the new
    coefficients. `scale_guess` (a nearby scale) only speeds up the medians."""
    sw = np.sqrt(w)
    r = _weighted_residuals(beta, XT, y, sw, np.empty(len(y)))
    ar, scratch = np.abs(r), np.empty(len(r))
    scale = max(1.4826 * _median(ar, scratch, scale_guess / 1.4826), 1e-9)
    starts = _starts(groups)
    bread_g, scores = _cluster_parts(XT, r, w, starts, scale, c if robust else np.inf)
    bread = bread_g.sum(axis=0)
    try:
        step = np.linalg.solve(bread, scores.sum(axis=0))
    except np.linalg.LinAlgError:
        return robust_fit_t(XT, y, w, groups, robust, c, beta0=beta, scale_guess=scale)
    new = beta + step
    scores -= bread_g @ step  # h_g(b + step) = h_g(b) - B_g step: the scores sum to 0 again
    infl, cov = _cr3(bread_g, scores)
    if robust:  # the next step, at the new coefficients and scale: B over the same reports
        _weighted_residuals(new, XT, y, sw, r)
        np.abs(r, out=ar)
        s2 = max(1.4826 * _median(ar, scratch, scale / 1.4826), 1e-9)
        np.clip(r, -c * s2, c * s2, out=r)
        r *= sw
        nxt = np.linalg.solve(bread * scale, XT @ r)  # as _huber_t's Newton step (its B is not divided by s)
        if np.any(np.abs(nxt) > tol_se * np.sqrt(np.diag(cov))):
            return robust_fit_t(XT, y, w, groups, robust, c, beta0=new, scale_guess=s2)
    return _Fit(new, cov, scale, infl, groups[starts])


def _weighted_residuals(beta: np.ndarray, XT: np.ndarray, y: np.ndarray, sw: np.ndarray, out: np.ndarray) -> np.ndarray:
    """r = sqrt(w) (y - X b) into `out` (no fresh array), `sw` = sqrt(w)."""
    np.matmul(beta, XT, out=out)
    np.subtract(y, out, out=out)
    np.multiply(out, sw, out=out)
    return out


def _cluster_parts(XT: np.ndarray, r: np.ndarray, w: np.ndarray, starts: np.ndarray, scale: float,
                   cc: float) -> tuple[np.ndarray, np.ndarray]:
    """Per flight cluster g: B_g = sum x x^T w psi'(u) / s and h_g = sum x sqrt(w) psi(u),
    u = r / s, r = sqrt(w) (y - X b) (psi the Huber function clipped at cc)."""
    k, n = XT.shape
    u = r / scale
    psi = np.clip(u, -cc, cc)
    wb = w * (np.abs(u) <= cc) / scale  # B's weights: psi'(u) w / s
    swpsi = np.sqrt(w)
    swpsi *= psi
    G = len(starts)
    # B_g (upper triangle) and h_g, one product at a time in reused buffers (no fresh
    # (k(k+1)/2, n) arrays: 5x faster here)
    bread_g = np.empty((G, k, k))
    scores = np.empty((G, k))
    buf, xw = np.empty(n), np.empty(n)
    for i in range(k):
        np.multiply(XT[i], wb, out=xw)
        for j in range(i, k):
            bread_g[:, i, j] = bread_g[:, j, i] = np.add.reduceat(np.multiply(xw, XT[j], out=buf), starts)
        scores[:, i] = np.add.reduceat(np.multiply(XT[i], swpsi, out=buf), starts)
    return bread_g, scores


def _cr3(bread_g: np.ndarray, scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Leave-one-flight-out influences q_g = (B - B_g)^-1 h_g (CR3, the linearised cluster
    jackknife: the plain sandwich undercovers with ~40 flights of unequal size) and the
    covariance (G-1)/G sum q_g q_g^T."""
    G = len(bread_g)
    bread = bread_g.sum(axis=0)
    loo = bread[None, :, :] - bread_g
    try:
        infl = np.linalg.solve(loo, scores[:, :, None])[:, :, 0] if G > 1 else scores @ np.linalg.pinv(bread).T
    except np.linalg.LinAlgError:  # a flight the rest cannot do without: its plain sandwich term
        infl = np.einsum("gij,gj->gi", np.linalg.pinv(loo), scores)
    cov = infl.T @ infl * ((G - 1) / G if G > 1 else 1.0)
    return infl, cov


def heading_axes(heading_deg: np.ndarray, w: np.ndarray, harmonic: int = 1,
                 sin_cos: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and unit eigenvectors (columns, in (sin nz, cos nz)) of the
    weighted covariance of (sin nz, cos nz) of the headings (`sin_cos`: those two as rows,
    (2, n), when already at hand)."""
    if sin_cos is None:
        z = harmonic * np.asarray(heading_deg) * DEG
        sin_cos = np.vstack([np.sin(z), np.cos(z)])
    ww = w / w.sum()
    mu = sin_cos @ ww
    cov = (sin_cos * ww) @ sin_cos.T - np.outer(mu, mu)
    return np.linalg.eigh(cov)


def heading_spread(heading_deg: np.ndarray, w: np.ndarray, harmonic: int = 1,
                   sin_cos: np.ndarray | None = None) -> float:
    """Smaller eigenvalue of the weighted covariance of (sin nz, cos nz): 0.5 for headings
    uniform round the compass, 0 for one heading (or, n = 1, one route both ways)."""
    return float(heading_axes(heading_deg, w, harmonic, sin_cos)[0][0])


def octants_occupied(heading_deg: np.ndarray, min_share: float = 0.03) -> int:
    """45-deg heading sectors holding at least `min_share` of the reports."""
    o = np.floor(np.asarray(heading_deg, dtype=float) / 45.0).astype(np.intp) & 7  # mod 8 (not float % and //: 5x slower)
    return int(np.sum(np.bincount(o, minlength=8) >= min_share * max(len(o), 1)))


def lut_correction(lut: np.ndarray, heading_deg: np.ndarray, table: np.ndarray | None = None) -> np.ndarray:
    """Correction (deg) at the measured heading from an 8-point table at 0, 45, ..., 315 deg,
    linear between points and round the circle (wind paper 8.1). `lut` (8,), or several
    tables (T, 8) with `table` the row (0..T-1) to use at each heading."""
    x = np.asarray(heading_deg, dtype=float) / 45.0  # in table steps (float % and // cost 5x a division)
    q = np.floor(x)
    frac = x - q
    i = q.astype(np.int64)
    i &= 7  # i mod 8, negative i too (two's complement)
    lut = np.asarray(lut, dtype=float)
    if lut.shape == (8,):
        lut = lut[None, :]
    elif table is not None and lut.ndim == 2 and lut.shape[1] == 8:
        i += np.asarray(table, dtype=np.int64) * 8  # flat index: no (n, 8) table per heading
    else:
        raise ValueError(f"lut: expected (8,), or (T, 8) with `table`, got shape {lut.shape}")
    # value at the point below plus the step to the next one (round the circle) times frac
    step = np.roll(lut, -1, axis=1) - lut
    out = step.ravel().take(i)
    out *= frac
    out += lut.ravel().take(i)
    return out


def _iso_date(t: float) -> str:
    return dt.datetime.fromtimestamp(t, tz=dt.timezone.utc).date().isoformat()


# ----------------------------------------------------------------------------- estimator

def _used_arrays(rows: pd.DataFrame, heading: str) -> dict:
    """The columns a fit needs, as arrays, and the mask of rows it may use."""
    col = "heading_deg" if heading == "true" else "heading_mag_deg"
    z = rows[col].to_numpy()
    used = (rows["gate"].cat.codes.to_numpy() == 0) & np.isfinite(z)
    if heading == "magnetic" and not np.isfinite(z).any():
        raise ValueError("heading='magnetic' needs a heading_mag_deg or declination_deg column in the observation table")
    src = pd.Categorical(rows["ref_source"])
    return {"used": used, "z": z, "y": rows["error_deg"].to_numpy(), "tas": rows["tas_ms"].to_numpy(),
            "g": rows["flight"].to_numpy(), "t": rows["time_s"].to_numpy(), "src": src.codes.astype(np.int64),
            "src_names": list(src.categories)}


class HeadingDeviationFit:
    """One aircraft's heading deviation (wind paper eq. 2) learned from its reports.

    Parameters: `terms` "auto" (offset + sinusoid, D, E when the Wald test keeps them),
    "offset", "sinusoid" (A, B, C), "full" (A..E); `robust` Huber M-estimate (else weighted
    least squares); `heading` "true" or "magnetic" (the frame of z'); `offset_only` for
    aircraft whose avionics hand TAMDAR true heading (wind paper 8.4); thresholds as in
    the module docstring. Learned: coef_, se_ (deg, dicts A..E; 0 and NaN for terms not
    fitted), status_, reason_, lut_ (8 corrections to add, deg), n_used_, n_flights_,
    valid_from_, valid_to_, terms_, scale_deg_, coverage_, octants_, consistency_.
    """

    def __init__(self, terms: str = "auto", robust: bool = True, heading: str = "true", offset_only: bool = False,
                 huber_c: float = 1.345, min_coverage: float = 0.1, de_level: float = 0.001,
                 consistency_level: float = 0.01, min_reports: int = 30, min_flights: int = 5,
                 gates: GateSpec | None = None):
        self.terms = terms
        self.robust = robust
        self.heading = heading
        self.offset_only = offset_only
        self.huber_c = huber_c
        self.min_coverage = min_coverage
        self.de_level = de_level
        self.consistency_level = consistency_level
        self.min_reports = min_reports
        self.min_flights = min_flights
        self.gates = gates

    def _check_params(self) -> None:
        if self.terms not in ("auto", "offset", "sinusoid", "full"):
            raise ValueError(f"terms: expected 'auto', 'offset', 'sinusoid' or 'full', got {self.terms!r}")
        if self.heading not in ("true", "magnetic"):
            raise ValueError(f"heading: expected 'true' or 'magnetic', got {self.heading!r}")
        if not self.huber_c > 0:
            raise ValueError(f"huber_c: expected a positive number, got {self.huber_c!r}")
        if not 0 <= self.min_coverage <= 0.5:
            raise ValueError(f"min_coverage: expected 0..0.5 (0.5 = uniform headings), got {self.min_coverage!r}")
        if self.min_flights < 2:
            raise ValueError(f"min_flights: expected >= 2 (standard errors come from flight clusters), got {self.min_flights!r}")

    # -- fitting
    def fit(self, obs: pd.DataFrame) -> HeadingDeviationFit:
        """Learn from one aircraft's observation table (or its `heading_errors` rows)."""
        self._check_params()
        rows = obs if "error_deg" in obs.columns else heading_errors(obs, self.gates)
        acs = pd.unique(rows["aircraft"])
        if len(acs) != 1:
            raise ValueError(f"obs: HeadingDeviationFit takes one aircraft, got {len(acs)} (use FleetHeadingFit)")
        order = np.lexsort((rows["time_s"].to_numpy(), rows["flight"].to_numpy()))
        return self._fit_arrays(str(acs[0]), _used_arrays(rows, self.heading), order)

    def _fit_arrays(self, aircraft: str, a: dict, sel: np.ndarray) -> HeadingDeviationFit:
        """The fit on rows `sel` of the arrays of `_used_arrays` (rows contiguous by flight)."""
        self.aircraft_ = aircraft
        # integer gathers throughout: numpy's boolean-mask indexing is 5-15x slower here
        sel = sel.take(np.flatnonzero(a["used"].take(sel)))
        self._z, self._y, self._g, self._src = (a[c].take(sel) for c in ("z", "y", "g", "src"))
        tas = a["tas"].take(sel)
        times = a["t"].take(sel)
        self._w = (tas / np.median(tas)) ** 2 if len(tas) else tas
        self.n_used_ = int(len(sel))
        self.n_flights_ = int(len(_starts(self._g))) if len(sel) else 0
        self._src_names = [str(x) for x in a["src_names"]]
        self.ref_sources_ = [self._src_names[i] for i in np.flatnonzero(np.bincount(self._src))]
        self.valid_from_ = _iso_date(times.min()) if len(times) else ""
        self.valid_to_ = _iso_date(times.max()) if len(times) else ""
        self.heading_frame_ = self.heading
        self.consistency_ = {}
        self._XT = design_t(self._z, 5)
        self.coverage_ = heading_spread(self._z, self._w, 1, self._XT[1:3]) if self.n_used_ >= 3 else 0.0
        self.octants_ = octants_occupied(self._z)
        self.de_p_ = math.nan
        if self.n_used_ < self.min_reports or self.n_flights_ < self.min_flights:
            flights = "flight" if self.n_flights_ == 1 else "flights"
            return self._refuse(f"too little data: {self.n_used_} usable reports in {self.n_flights_} {flights} "
                                f"(need {self.min_reports} in {self.min_flights})")
        reason = []
        full = None
        T = None  # fitted parameters -> A..E (None: the first k terms themselves)
        if self.offset_only or self.terms == "offset":
            k = 1
            reason.append("aircraft gives true heading: only an offset can be corrected" if self.offset_only
                          else "offset only, as asked")
        elif self.coverage_ < self.min_coverage:
            k = 1
            lam, vec = heading_axes(self._z, self._w, 1, self._XT[1:3])
            if lam[1] >= self.min_coverage:  # one axis flown both ways: its component of the sinusoid
                k = 3
                u = vec[:, 1]
                T = np.zeros((5, 2))
                T[0, 0], T[1, 1], T[2, 1] = 1.0, u[0], u[1]
                za = math.degrees(math.atan2(u[0], u[1])) % 180.0
                reason.append(f"headings on one axis ({za:.0f}/{za + 180:.0f} deg; spread {self.coverage_:.2f} < "
                              f"{self.min_coverage}): sinusoid fitted along that axis only, its perpendicular part "
                              f"(not identifiable) set to 0")
            else:
                reason.append(f"heading coverage cannot identify the sinusoid (spread {self.coverage_:.2f} < "
                              f"{self.min_coverage}, {self.octants_} of 8 octants occupied): offset only fitted")
        else:
            k = 5 if self.terms == "full" else 3
            if self.terms in ("auto", "full"):
                spread2 = heading_spread(self._z, self._w, 2, self._XT[3:5])
                if spread2 < self.min_coverage:
                    k = 3
                    reason.append(f"D, E not identifiable (2z spread {spread2:.2f})")
                elif self.terms == "auto":
                    full = robust_fit_t(self._XT, self._y, self._w, self._g, self.robust, self.huber_c)
                    de, V = full.beta[3:], full.cov[3:, 3:]
                    wald = float(de @ np.linalg.pinv(V) @ de)
                    G = self.n_flights_
                    self.de_p_ = float(stats.f.sf(wald / 2, 2, max(G - 1, 1)))
                    if self.de_p_ < self.de_level:
                        k = 5
                        reason.append(f"D, E kept (Wald p = {self.de_p_:.1e})")
        self._k = k
        self._T = np.eye(5)[:, :k] if T is None else T
        if k == 5 and full is not None:
            f = full
        elif full is not None:  # D, E dropped: the 5-term fit's A, B, C are a near start
            f = robust_fit_t(self._fit_design(), self._y, self._w, self._g, self.robust, self.huber_c,
                             beta0=full.beta[:k], scale_guess=full.scale)
        else:
            f = robust_fit_t(self._fit_design(), self._y, self._w, self._g, self.robust, self.huber_c)
        self._fit = f
        self.terms_ = TERM_NAMES[:k]
        beta = self._T @ f.beta
        cov = self._T @ f.cov @ self._T.T
        self.coef_ = {t: (float(beta[i]) if i < k else 0.0) for i, t in enumerate(TERM_NAMES)}
        se = np.sqrt(np.diag(cov))
        self.se_ = {t: (float(se[i]) if i < k else math.nan) for i, t in enumerate(TERM_NAMES)}
        self.cov_ = cov[:k, :k]
        self.scale_deg_ = float(f.scale)
        self.status_ = "offset_only" if k == 1 else "fitted"
        self._consistency(k, reason)
        self.reason_ = "; ".join(reason) if reason else "offset and sinusoid fitted"
        self.lut_ = -self.deviation(LUT_HEADINGS_DEG)
        return self

    def _fit_design(self, rows: np.ndarray | None = None) -> np.ndarray:
        """The (p, n) design of the fitted parameters, T^T X^T (X^T's first k rows when the
        parameters are the first k terms), of all used rows or of `rows` (indices)."""
        T = self._T
        if np.array_equal(T, np.eye(5)[:, :T.shape[1]]):
            XT = self._XT[:T.shape[1]]
            return XT if rows is None else XT.take(rows, axis=1)
        return T.T @ (self._XT if rows is None else self._XT.take(rows, axis=1))

    def _refuse(self, why: str) -> HeadingDeviationFit:
        self.status_, self.reason_ = "refused", why
        self.terms_ = ()
        self.coef_ = {t: math.nan for t in TERM_NAMES}
        self.se_ = {t: math.nan for t in TERM_NAMES}
        self.scale_deg_ = math.nan
        self.lut_ = np.full(8, math.nan)
        self._k = 0
        return self

    def _consistency(self, k: int, reason: list[str]) -> None:
        """Each reference model alone, pairwise Wald test of equal coefficients."""
        counts = np.bincount(self._src)
        srcs = [self._src_names[c] for c in np.flatnonzero(counts >= max(self.min_reports, 1))]
        if len(srcs) < 2:
            return
        flights = self._g[_starts(self._g)]  # rows are sorted by flight
        fits = {}
        for s in srcs:
            m = np.flatnonzero(self._src == self._src_names.index(s))  # indices: faster gathers than a mask
            f = fit_from_t(self._fit_design(m), self._y.take(m), self._w.take(m), self._g.take(m), self._fit.beta, self._fit.scale,
                           self.robust, self.huber_c)
            infl = np.zeros((len(flights), self._T.shape[1]))
            infl[np.searchsorted(flights, f.groups)] = f.influence
            fits[s] = (f.beta, infl)
        G = len(flights)
        n_pairs = len(srcs) * (len(srcs) - 1) // 2
        zz = design(np.arange(360.0), 5) @ self._T
        worst = None
        for i, a in enumerate(srcs):
            for b in srcs[i + 1:]:
                delta = fits[a][0] - fits[b][0]
                dh = fits[a][1] - fits[b][1]
                V = dh.T @ dh * G / max(G - 1, 1)
                W = float(delta @ np.linalg.pinv(V) @ delta)
                q = len(delta)
                p = min(1.0, float(stats.f.sf(W / q, q, max(G - 1, 1))) * n_pairs)  # Bonferroni over pairs
                diff = float(np.max(np.abs(zz @ delta)))
                self.consistency_[f"{a}-{b}"] = {"p": p, "max_diff_deg": diff}
                if worst is None or p < worst[1]:
                    worst = (f"{a} vs {b}", p, diff)
        self.consistency_p_ = worst[1]
        self.consistency_max_diff_deg_ = worst[2]
        if worst[1] < self.consistency_level:
            reason.append(f"reference models disagree ({worst[0]}: p = {worst[1]:.1e}, curves differ by up to "
                          f"{worst[2]:.2f} deg): check the models for bias")
        else:
            reason.append(f"reference models agree ({worst[0]}: p = {worst[1]:.2f})")

    # -- applying
    def deviation(self, heading_deg) -> np.ndarray:
        """d(z') of wind paper eq. 2 from the fitted coefficients (deg)."""
        c = np.array([self.coef_[t] for t in TERM_NAMES])
        return design(np.atleast_1d(np.asarray(heading_deg, dtype=float)), 5) @ c

    def correction(self, heading_deg) -> np.ndarray:
        """Correction to add (deg): the lookup table interpolated piecewise linearly round the
        circle (as the TAMDAR firmware does, wind paper 8.1); 0 for a refused aircraft."""
        h = np.asarray(heading_deg, dtype=float)
        return lut_correction(np.nan_to_num(np.asarray(self.lut_, dtype=float)), h)

    def correct(self, heading_deg) -> np.ndarray:
        """Corrected heading (deg, [0, 360)) = measured + lookup-table correction."""
        h = np.asarray(heading_deg, dtype=float)
        return (h + self.correction(h)) % 360.0

    # -- uncertainty
    def bootstrap(self, n_boot: int = 1000, rng: np.random.Generator | None = None, level: float = 0.95,
                  method: str = "studentized") -> pd.DataFrame:
        """Intervals for the fitted coefficients from resampling whole flights with replacement
        (terms fixed to the fitted ones). `method` "studentized" (symmetric bootstrap-t: q the
        `level` quantile of |b* - b| / se* with the flight-clustered se of each resample,
        interval b -+ q se) or
        "percentile" (quantiles of b*; measured to undercover with ~40 flights: 0.92-0.94 for
        a 95 % interval). Rows: terms; columns estimate, lo, hi, boot_se."""
        if self.status_ == "refused":
            raise ValueError(f"bootstrap: aircraft {self.aircraft_} was refused ({self.reason_})")
        if not 0 < level < 1:
            raise ValueError(f"level: expected a number in (0, 1), got {level!r}")
        if method not in ("studentized", "percentile"):
            raise ValueError(f"method: expected 'studentized' or 'percentile', got {method!r}")
        rng = rng or np.random.default_rng()
        k = self._k
        T = self._T  # fitted parameters -> A..E (an axis fit has 2 parameters for A, B, C)
        XT = self._fit_design()
        starts = _starts(self._g)
        ends = np.r_[starts[1:], len(self._g)]
        G = len(starts)
        p = T.shape[1]
        est = np.empty((n_boot, p))
        tstat = np.empty((n_boot, p))
        beta = self._fit.beta
        se = np.sqrt(np.diag(self._fit.cov))
        for b in range(n_boot):
            pick = rng.integers(0, G, G)
            lens = ends[pick] - starts[pick]
            idx = np.repeat(starts[pick] - np.r_[0, np.cumsum(lens)[:-1]], lens) + np.arange(lens.sum())
            if method == "percentile":
                est[b] = _huber_t(XT[:, idx], self._y[idx], self._w[idx], self.robust, self.huber_c)[0]
                continue
            f = robust_fit_t(XT[:, idx], self._y[idx], self._w[idx], np.repeat(np.arange(G), lens), self.robust,
                             self.huber_c, beta0=beta)
            est[b] = f.beta
            tstat[b] = (f.beta - beta) / np.sqrt(np.diag(f.cov))
        a = (1 - level) / 2
        names = list(self.terms_)
        Tk = T[:k]  # each term is one fitted parameter times a constant
        full = est @ Tk.T
        if method == "percentile":
            lo, hi = np.quantile(full, a, axis=0), np.quantile(full, 1 - a, axis=0)
        else:
            q = np.quantile(np.abs(tstat), level, axis=0)  # symmetric bootstrap-t, per fitted parameter
            half = np.abs(Tk) @ (q * se)
            lo, hi = Tk @ beta - half, Tk @ beta + half
        return pd.DataFrame({"estimate": Tk @ beta, "lo": lo, "hi": hi, "boot_se": full.std(axis=0, ddof=1)}, index=names)

    # -- learned state
    def to_table(self) -> pd.DataFrame:
        """One row with the deviation.csv columns, then extras (heading frame, terms, scale,
        coverage, octants, flights, D/E Wald p, reference sources, consistency)."""
        row = {"aircraft": self.aircraft_, "status": self.status_, "reason": self.reason_, "n_used": self.n_used_}
        row.update({f"{t}_deg": self.coef_[t] for t in TERM_NAMES})
        row.update({f"{t}_se_deg": self.se_[t] for t in TERM_NAMES})
        row.update(dict(zip(LUT_COLUMNS, map(float, self.lut_))))
        row.update(valid_from=self.valid_from_, valid_to=self.valid_to_, heading_frame=self.heading_frame_,
                   terms="".join(self.terms_), n_flights=self.n_flights_, residual_scale_deg=self.scale_deg_,
                   heading_spread=self.coverage_, octants_occupied=self.octants_, de_wald_p=self.de_p_,
                   ref_sources=" ".join(self.ref_sources_), consistency_p=getattr(self, "consistency_p_", math.nan),
                   consistency_max_diff_deg=getattr(self, "consistency_max_diff_deg_", math.nan))
        return pd.DataFrame([row])

    @classmethod
    def from_table(cls, table: pd.DataFrame | pd.Series) -> HeadingDeviationFit:
        """Rebuild a fitted estimator (coefficients, se, status, table, dates) from a row of to_table()."""
        row = table.iloc[0] if isinstance(table, pd.DataFrame) else table
        missing = [c for c in TABLE_COLUMNS if c not in row.index]
        if missing:
            raise ValueError(f"table: missing column '{missing[0]}' (expected the deviation.csv columns)")
        if row["status"] not in STATUSES:
            raise ValueError(f"table: column 'status' is {row['status']!r}, expected one of {', '.join(STATUSES)}")
        self = cls(heading=str(row.get("heading_frame", "true")) if isinstance(row.get("heading_frame", "true"), str) else "true")
        self.aircraft_ = str(row["aircraft"])
        self.status_, self.reason_ = str(row["status"]), ("" if pd.isna(row["reason"]) else str(row["reason"]))
        self.n_used_ = int(row["n_used"])
        self.coef_ = {t: float(row[f"{t}_deg"]) for t in TERM_NAMES}
        self.se_ = {t: float(row[f"{t}_se_deg"]) for t in TERM_NAMES}
        self.lut_ = np.array([float(row[c]) for c in LUT_COLUMNS])
        self.valid_from_, self.valid_to_ = str(row["valid_from"]), str(row["valid_to"])
        self.heading_frame_ = self.heading
        self.terms_ = tuple(t for t in TERM_NAMES if np.isfinite(self.se_[t]))
        self._k = len(self.terms_)
        return self


def _median(x: np.ndarray, scratch: np.ndarray, guess: float = math.nan, width: float = 0.05) -> float:
    """np.median of a finite 1-D array without its generic machinery (a third of an iteration's
    time): the middle element, or the mean of the two middle ones. `scratch` (same length)
    is partitioned in place, x left as it is. With a `guess` (the previous iteration's
    median) only the values within `width` of it are partitioned, after counting those
    below: the same order statistics, 10x cheaper; a guess that misses falls back."""
    n = len(x)
    h = n // 2
    mid = h if n % 2 else (h - 1, h)
    if guess > 0:
        lo, hi = guess * (1 - width), guess * (1 + width)
        inside = np.greater_equal(x, lo, out=scratch.view(np.uint8)[:n].view(bool))
        inside &= x <= hi
        n_lo = np.count_nonzero(x < lo)
        sub = x[inside]
        if n_lo <= h - (n % 2 == 0) and h - n_lo < len(sub):
            if n % 2:
                sub.partition(h - n_lo)
                return float(sub[h - n_lo])
            sub.partition((h - 1 - n_lo, h - n_lo))
            return float(0.5 * (sub[h - 1 - n_lo] + sub[h - n_lo]))
    np.copyto(scratch, x)
    scratch.partition(mid)
    return float(scratch[h]) if n % 2 else float(0.5 * (scratch[h - 1] + scratch[h]))


_NEWTON_STEPS = 20  # then IRLS (module docstring)
_NEWTON_MAX_COND = 1e10  # a Newton matrix worse conditioned than this: the unclipped reports do not span the terms


def _huber_t(XT: np.ndarray, y: np.ndarray, w: np.ndarray, robust: bool, c: float, max_iter: int = 50,
             beta0: np.ndarray | None = None, scale_guess: float = math.nan) -> tuple[np.ndarray, float, np.ndarray]:
    """Huber M-estimate on the transposed (k, n) design (module docstring: Newton steps,
    IRLS as the fallback): coefficients, the final MAD scale and the weighted residuals
    sqrt(w) (y - X b) at the solution. Normal equations (k <= 5 bounded columns: well conditioned
    whenever the coverage gate passes). The per-report work runs in buffers allocated once per fit (fresh
    arrays each step cost more in page faults than the arithmetic)."""
    k, n = XT.shape
    XW = np.empty((k, n))
    r, ar, wt, tmp = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    gram_w = None  # X^T W X over every report

    def solve(weights):  # weighted least squares: b and X^T W X
        np.multiply(XT, weights, out=XW)
        A = XW @ XT.T
        return np.linalg.solve(A, XW @ y), A

    def residuals(b):  # r = sqrt(w) (y - X b), ar = |r|
        _weighted_residuals(b, XT, y, sw, r)
        np.abs(r, out=ar)

    if beta0 is None:
        beta, gram_w = solve(w)
    else:
        beta = beta0
    sw = np.sqrt(w)
    newton = robust
    mad = scale_guess / 1.4826  # the previous median: NaN (none) at first unless a scale is guessed
    for i in range(max_iter if robust else 0):
        residuals(beta)
        mad = _median(ar, tmp, mad)
        cs = c * max(1.4826 * mad, 1e-9)  # c s
        new = None
        if newton and i < _NEWTON_STEPS:
            # B^-1 h: B over the unclipped reports (all of them less the clipped fifth: a
            # third of the work of summing the unclipped), h = s sum x sqrt(w) psi(u)
            if gram_w is None:
                np.multiply(XT, w, out=XW)
                gram_w = XW @ XT.T
            out = np.flatnonzero(ar > cs)
            Xc = XT[:, out]
            B = gram_w - (Xc * w[out]) @ Xc.T
            if np.linalg.cond(B) < _NEWTON_MAX_COND:  # by difference: singular shows as a huge condition
                np.clip(r, -cs, cs, out=tmp)
                np.multiply(tmp, sw, out=tmp)
                new = beta + np.linalg.solve(B, XT @ tmp)
            else:
                newton = False
        if new is None:  # IRLS step
            np.maximum(ar, 1e-300, out=wt)
            np.divide(cs, wt, out=wt)
            np.minimum(wt, 1.0, out=wt)
            np.multiply(wt, w, out=wt)
            new = solve(wt)[0]
        done = np.max(np.abs(new - beta)) < 1e-5  # deg: far below any standard error
        beta = new
        if done:
            break
    residuals(beta)
    scale = max(1.4826 * _median(ar, tmp, mad), 1e-9)
    return beta, scale, r


class FleetHeadingFit:
    """One HeadingDeviationFit per aircraft; exports/imports the deviation.csv table.
    Aircraft with any report whose `heading_input` is "true" get the offset-only fit."""

    def __init__(self, **params):
        self.params = params
        HeadingDeviationFit(**params)._check_params()

    def fit(self, obs: pd.DataFrame, source: str = "observation table") -> FleetHeadingFit:
        """Validate, compute heading errors for the whole table at once, fit each aircraft."""
        rows = obs if "error_deg" in obs.columns else heading_errors(obs, self.params.get("gates"), source)
        self.errors_ = rows
        self.fits_ = {}
        arrays = _used_arrays(rows, self.params.get("heading", "true"))
        ac = pd.Categorical(rows["aircraft"])
        codes = ac.codes
        t, g = rows["time_s"].to_numpy(), arrays["g"]
        dc, dg, dt_ = np.diff(codes), np.diff(g), np.diff(t)
        if np.all((dc > 0) | ((dc == 0) & ((dg > 0) | ((dg == 0) & (dt_ >= 0))))):  # heading_errors output: in order already
            order = np.arange(len(codes))
        else:
            order = np.lexsort((t, g, codes))
        starts = _starts(codes[order])
        ends = np.r_[starts[1:], len(order)]
        true_input = rows["true_heading_input"].to_numpy()
        for s, e in zip(starts, ends):
            sel = order[s:e]
            p = dict(self.params)
            p["offset_only"] = bool(p.get("offset_only", False) or true_input[sel].any())
            name = str(ac.categories[codes[sel[0]]])
            self.fits_[name] = HeadingDeviationFit(**p)._fit_arrays(name, arrays, sel)
        return self

    def to_table(self) -> pd.DataFrame:
        """The deviation.csv table: one row per aircraft."""
        return pd.concat([f.to_table() for f in self.fits_.values()], ignore_index=True)

    @classmethod
    def from_table(cls, table: pd.DataFrame) -> FleetHeadingFit:
        """Reload learned state stored with to_table()."""
        self = cls()
        self.fits_ = {str(r["aircraft"]): HeadingDeviationFit.from_table(r) for _, r in table.iterrows()}
        return self

    def correct(self, aircraft, heading_deg) -> np.ndarray:
        """Corrected headings (deg, [0, 360)); `aircraft` one name or an array aligned with
        heading_deg. Aircraft without a fit (or refused) are left uncorrected."""
        h = np.asarray(heading_deg, dtype=float)
        return (h + self.correction(aircraft, h)) % 360.0

    def correction(self, aircraft, heading_deg) -> np.ndarray:
        """The lookup-table corrections to add (deg) at each measured heading; 0 for aircraft
        without a fit (or refused)."""
        h = np.asarray(heading_deg, dtype=float)
        names = list(self.fits_)
        luts = np.vstack([np.nan_to_num(np.asarray(f.lut_, dtype=float)) for f in self.fits_.values()] + [np.zeros(8)])
        if np.ndim(aircraft) == 0:
            idx = np.full(h.size, names.index(aircraft) if aircraft in names else -1)
        else:
            cat = pd.Categorical(aircraft)  # cheap when it already is one
            idx = pd.Index(names).get_indexer(cat.categories.astype(str))[cat.codes]
            idx[cat.codes < 0] = -1
        idx = np.where(idx < 0, len(names), idx).reshape(h.shape)  # no fit -> the zero row
        return lut_correction(luts, h, table=idx)


# ----------------------------------------------------------------------------- metrics

def wind_error_components(dw_e, dw_n, heading_deg) -> dict[str, float]:
    """RMS of the wind error vector (reported - reference), and of its longitudinal (along
    the aircraft's heading) and transverse components (wind paper section 6), knots."""
    z = np.asarray(heading_deg) * DEG
    return _components(np.asarray(dw_e, dtype=float), np.asarray(dw_n, dtype=float), *sin_cos(z))


def _components(dw_e: np.ndarray, dw_n: np.ndarray, sz: np.ndarray, cz: np.ndarray) -> dict[str, float]:
    """wind_error_components from the heading's sine and cosine."""
    n = len(dw_e)
    if n == 0:
        return {"rms_kt": math.nan, "longitudinal_kt": math.nan, "transverse_kt": math.nan}
    lon_ = dw_e * sz
    lon_ += dw_n * cz
    total, along = float(dw_e @ dw_e + dw_n @ dw_n), float(lon_ @ lon_)
    across = max(total - along, 0.0)  # a rotation keeps the sum of squares: the transverse part is the rest
    rms = lambda ss: math.sqrt(ss / n) / KT  # noqa: E731
    return {"rms_kt": rms(total), "longitudinal_kt": rms(along), "transverse_kt": rms(across)}


def corrected_wind_error(rows: pd.DataFrame, correction_deg: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Wind error after correcting the heading by c: the wind recomputed with V_A rotated by
    c (wind paper eq. 1), V_W' = V_W,TAM + V_A - R(c) V_A."""
    c = np.asarray(correction_deg) * DEG
    return _rotated_error(rows, *sin_cos(c))


def _rotated_error(rows: pd.DataFrame, sc: np.ndarray, cc: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    va_e, va_n = rows["va_e"].to_numpy(), rows["va_n"].to_numpy()
    # rotating a heading clockwise by c: (E, N) -> (E cos c + N sin c, N cos c - E sin c);
    # V_A - R(c) V_A = (E (1 - cos c) - N sin c, N (1 - cos c) + E sin c)
    one_c = 1.0 - cc
    e = rows["dw_e"].to_numpy() + va_e * one_c
    e -= va_n * sc
    n = rows["dw_n"].to_numpy() + va_n * one_c
    n += va_e * sc
    return e, n


def wind_errors_before_after(rows: pd.DataFrame, correction_deg: np.ndarray) -> tuple[dict, dict]:
    """wind_error_components of the `heading_errors` rows as reported and after correcting
    their heading (`heading_deg`) by c (corrected_wind_error), the corrected heading's sine
    and cosine by the angle-sum identities (no second evaluation)."""
    z = rows["heading_deg"].to_numpy()
    c = np.asarray(correction_deg, dtype=float)
    # the rows of one report (one per reference model) are adjacent and share heading and
    # correction: the sines and cosines once per run of equal values (the same numbers)
    head = np.ones(len(z), dtype=bool)
    head[1:] = (z[1:] != z[:-1]) | (c[1:] != c[:-1])
    first = np.flatnonzero(head)
    if len(first) > 0.8 * len(z):
        zr, cr = z * DEG, c * DEG
        (sz, cz), (sc, cc) = sin_cos(zr), sin_cos(cr)
    else:
        run = np.cumsum(head)
        run -= 1  # each row's run
        zr, cr = z.take(first) * DEG, c.take(first) * DEG
        sz, cz, sc, cc = (v.take(run) for v in (*sin_cos(zr), *sin_cos(cr)))  # a gather: 3x faster than np.repeat
    before = _components(rows["dw_e"].to_numpy(), rows["dw_n"].to_numpy(), sz, cz)
    ae, an = _rotated_error(rows, sc, cc)
    s2 = sz * cc
    s2 += cz * sc
    c2 = cz * cc
    c2 -= sz * sc
    return before, _components(ae, an, s2, c2)
