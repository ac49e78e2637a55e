"""`aerotruth diagnose`: where measured data disagree with the simulation's sensor model,
which effect explains it, by how much, and what the extension gains on held-out data.

This module: Mode-S data (raw message logs and 1-s Mode-S trajectories); observation
tables are aerotruth.analysis.diagnose.wind, approach logs aerotruth.analysis.diagnose.fits.
The model of a real flight is the Mode-S sensor run on the flight's own trajectory with
ideal heading and airspeed (aerotruth.sensors.modes); its prediction is that the derived
wind (aerotruth.analysis.wind.modes_wind) is smooth in time, once the air vector is taken
horizontal (TAS cos gamma) along the air track (heading less the bank geometry a sin(phi),
with the angle of attack of the aircraft's type: aerotruth.truth.aircraft_types). Residual
structure that follows the heading, the airspeed or the turn rate is an effect of the
aircraft's sensors.

Only near-level flight at steady speed is used: the smooth-wind assumption holds in time
at a level, not through the shear of a climb (measured on the CDG flight: with climbs and
descents kept, a spurious TAS "scale factor" of -18 % absorbed the wind's change with
height), and while the speed changes the held TAS and the fresh ground speed are of
different instants (SPEED_RATE_KT_S), and so are a heading held through a gap in reception
and the track that moved on meanwhile (HELD_APART_DEG).

A candidate is considered only where the data can identify it (heading octants occupied,
MIN_OCTANTS) and kept only with a physically plausible size (PLAUSIBLE): on a single leg
that flies one heading, a "deviation" of 40 deg is the wind, not the compass.

The loop (forward selection): start from the smooth-wind model; for each candidate effect
not yet in the model, fit on the whole record and score it by (a) dBIC on all data and
(b) the held-out residual RMS: K folds of contiguous time blocks, the effect's
parameters learned on K-1 folds and applied to the held-out fold (whose nuisance wind is
refitted locally). The best candidate enters when dBIC < -10 (very strong, Kass & Raftery
1995), a Wald test with the block-jackknife covariance rejects at ALPHA / 4 (family-wise
ALPHA = 2 %; BIC alone counts correlated 1-s samples as independent), its size exceeds the
model's resolution (RESOLUTION: Mode-S register timing) and its held-out RMS is lower
than without it; repeat until none does. An empty list is the answer when nothing is there.
Each size's standard error is the block jackknife's (the test's), not least squares'. A TAS
scale must also agree with the one found without the heading (HEADING_FREE_AGREE_SIGMA).
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass, field

import numpy as np
import pandas as pd
from scipy import stats

from aerotruth.analysis.wind.modes_wind import EFFECT_COLUMNS, fit, predict_rms, tas_scale_heading_free
from aerotruth.units import KT

CAUSES = {
    "heading_offset": "the reported heading is off by a constant: a stale or wrong magnetic-variation table, or an "
    "alignment/mounting error",
    "heading_deviation_1psi": "the heading error goes once round with the heading: a compass (flux-valve) deviation, "
    "as the wind paper's hard iron",
    "tas_scale": "the true airspeed is off by a constant factor: air-data calibration (static source, temperature)",
    "heading_time_offset": "heading and ground track are sampled at different instants: registers held for different "
    "times",
    "heading_slaving_lag": "the compass deviation reaches the heading through a slow slaving loop: after each turn the "
    "error moves to the new heading's deviation with the time constant tau (a slaved directional gyro)",
}
DBIC_THRESHOLD = -10.0
JACKKNIFE_GROUPS = 8
# A TAS scale is also seen without the heading (modes_wind.tas_scale_heading_free: ground
# speed against TAS where the track turns, the wind solved with it). The heading-based scale
# is a finding only where the two agree within HEADING_FREE_AGREE_SIGMA combined jackknife
# standard errors: a heading error (a turn's register timing, the air track's angle of attack)
# moves the heading-based scale, never the heading-free one, while a real airspeed error moves
# both.
HEADING_FREE_AGREE_SIGMA = 3.0
# Smaller than this agrees with the model: Mode-S registers are held between replies (BDS 6,0
# heading p50 0.69 s, ADS-B velocity 1.07 s: aerotruth.sensors.modes), so the heading and the
# track of one sample differ in age by up to ~0.5 s; null simulated days gave 0.16-0.49 s.
RESOLUTION = {"D_s": 0.5, "tau_s": 2.0}  # tau: the lag grid's first value (modes_wind.SLAVING_TAU_GRID_S)
ALPHA = 0.02  # family-wise over the candidates (Bonferroni): also a jackknife Wald test (_jackknife_p), since
# BIC counts 1-s samples of held registers as independent (it found 78 effects in 100 null days)
MIN_HELD_OUT_GAIN = (
    0.0  # any drop of the held-out RMS (the dBIC carries the evidence; 1 % refused a true 2-deg offset on a 4-leg day)
)
# identifiability: a heading effect is told from the wind only across turns; a one-cycle
# deviation needs headings spread round the compass (the wind method refuses it otherwise)
MIN_OCTANTS = {
    "heading_offset": 2,
    "heading_deviation_1psi": 6,
    "tas_scale": 2,
    "heading_time_offset": 1,
    "heading_slaving_lag": 6,
}
# a time offset between heading and track shows only while the heading changes: samples
# turning faster than TURN_RATE_DEG_S, at least MIN_TURN_SAMPLES of them (the CDG flight's
# level samples fly one heading, p99 0.14 deg/s: a "1.8-s offset" with dBIC -154 was noise)
TURN_RATE_DEG_S = 0.5
MIN_TURN_SAMPLES = 30
OCTANT_MIN_SHARE = 0.03
PLAUSIBLE = {
    "A_deg": 20.0,
    "B_deg": 10.0,
    "C_deg": 10.0,
    "k": 0.1,
    "D_s": 10.0,
    "tau_s": 299.0,
}  # beyond: a model failure, not an effect
PARABOLA_FPM = 1500.0  # vertical rates of a zero-g parabola; level and normal climbs stay far below
PARABOLA_MARGIN_S = 60.0
LEVEL_FPM = 500.0
# While the airspeed changes (level decelerations in the terminal area), the held BDS 5,0
# TAS and the fresh ADS-B ground speed are of different instants (registers are held for
# ~1-5 s): on null simulated days these samples alone made a "TAS scale" of -3 to -5 %
# (p < 1e-4). TAS rate over +-10 s of the held register.
SPEED_RATE_KT_S = 0.5
SPEED_HALF_WINDOW_S = 10.0  # the wind is smooth in time at a level; climbing through shear it changes with height
# The same for the directions: a trajectory resampled to 1 s holds a register's last value
# through a gap in reception, so in a turn the heading may stand still while the ADS-B track
# moves on (or the other way round). A sample whose heading has not changed since the track
# moved more than HELD_APART_DEG (or whose track has not changed since the heading did) pairs
# values of different instants: on the A310 flight, 364 such samples in 2.5-deg/s turns had
# residuals of 20-90 kt (1.7 kt wings level). A steady register lag shows as a heading time
# offset; these are the gaps.
HELD_APART_DEG = 1.0
# The wind paper rejects roll > 10 deg (banked, the nose is not where the aircraft goes).
# Here it is optional and off: turns are what identify a heading lag, and measured on
# simulated Mesaba days the filter left the decaying sideslip after roll-out to alias into
# a lag of -0.5 to -0.9 s and lost a hidden 2-s lag entirely; without it the SAAB's
# sideslip spikes in its fast roll-ins read as a TAS scale.


@dataclass
class Finding:
    effect: str
    cause: str
    parameters: dict
    evidence: dict
    gain: dict


@dataclass
class Diagnosis:
    measured: str
    kind: str
    samples_used: int
    samples_excluded: dict
    findings: list[Finding] = field(default_factory=list)
    baseline: dict = field(default_factory=dict)


def _folds(t: np.ndarray, block_s: float, k: int) -> np.ndarray:
    return (np.floor((t - t.min()) / block_s).astype(int)) % k


def _cv_rms(track: pd.DataFrame, effects: tuple[str, ...], knot_s: float, folds: np.ndarray, k: int) -> float:
    sq, n = 0.0, 0
    for f in range(k):
        test = folds == f
        if test.sum() < 20:
            continue
        fitted = fit(track, knot_s, effects, rows=~test)
        r = predict_rms(track, fitted, knot_s, effects, test)
        sq += r**2 * test.sum()
        n += test.sum()
    return math.sqrt(sq / n)


def _jackknife_groups(t: np.ndarray) -> np.ndarray:
    """The jackknife's groups: the record cut in time order into JACKKNIFE_GROUPS contiguous
    pieces of equal sample count. Contiguous, not interleaved: what decides a heading effect
    happens leg by leg and turn by turn (the day's wind against each heading, the weave of a
    straight segment, register timing), and the wind spline couples neighbouring samples, so
    short blocks dealt round the groups leave each leg's own error in every replicate and
    the spread understates it (on null simulated days, interleaved 900-s blocks gave a
    -0.36 deg heading offset p 0.001 that contiguous groups put at p 0.12)."""
    rank = np.empty(len(t), dtype=int)
    rank[np.argsort(t, kind="stable")] = np.arange(len(t))
    return (rank * JACKKNIFE_GROUPS) // max(len(t), 1)


def _jackknife_p(
    track: pd.DataFrame, knot_s: float, effects: tuple[str, ...], eff: str, f: dict, t: np.ndarray
) -> tuple[float, np.ndarray]:
    """p-value of `eff`'s parameters = 0 and their standard errors: a Wald test with the
    delete-one-group jackknife covariance (groups: `_jackknife_groups`), referred to
    Hotelling's T^2 distribution for J groups, (J - q) / (q (J - 1)) W ~ F(q, J - q): the
    covariance is itself estimated from J replicates, so W is not chi^2 (with J = 8 and
    q = 2 a W of 12.4 is p 0.047, not the chi^2's 0.002). The errors that matter are not
    the samples' noise but what happens turn by turn (register timing, gusts): the
    least-squares se, even inflated for AR(1), made null days' timing offsets of 0.2-0.5 s
    look like p < 1e-10 (and on simulated 4-leg days with a hidden 2-deg table error the
    estimates scatter 1.7x their least-squares se). With fewer than q + 2 groups: p 1,
    se NaN."""
    idx = [f["names"].index(nm) for nm in EFFECT_COLUMNS[eff]]
    groups = _jackknife_groups(t)
    thetas = []
    for g in np.unique(groups):
        keep = groups != g
        if keep.sum() < 50:
            continue
        thetas.append(fit(track, knot_s, effects, rows=keep)["coef"][idx])
    J, q = len(thetas), len(idx)
    if J < max(3, q + 2):
        return 1.0, np.full(q, np.nan)
    th = np.array(thetas)
    cov = (J - 1) / J * (th - th.mean(axis=0)).T @ (th - th.mean(axis=0))
    b = f["coef"][idx]
    w = float(b @ np.linalg.pinv(np.atleast_2d(cov)) @ b)
    return float(stats.f.sf(w * (J - q) / (q * (J - 1)), q, J - q)), np.sqrt(np.diag(np.atleast_2d(cov)))


def heading_free_scale(track: pd.DataFrame, knot_s: float, t: np.ndarray) -> dict:
    """The heading-free TAS scale (modes_wind.tas_scale_heading_free) with its
    delete-one-group jackknife standard error (groups as `_jackknife_p`'s). Identifiable as
    the heading-based scale is: the ground track in MIN_OCTANTS["tas_scale"] octants, at
    least 3 groups; else k and se are None and `outcome` says why."""
    out: dict = {
        "k": None,
        "se": None,
        "method": "ground speed against horizontal TAS where the track turns, the smooth wind solved with it; "
        "no heading",
    }
    chi = np.degrees(np.arctan2(track["ve_mps"].to_numpy(float), track["vn_mps"].to_numpy(float))) % 360
    octants = int(np.sum(np.bincount((chi // 45.0).astype(int), minlength=8) >= OCTANT_MIN_SHARE * len(track)))
    if octants < MIN_OCTANTS["tas_scale"]:
        out["outcome"] = (
            f"not identifiable: {octants} ground-track octant(s) occupied, needs {MIN_OCTANTS['tas_scale']}"
        )
        return out
    groups = _jackknife_groups(t)
    thetas = [
        tas_scale_heading_free(track, knot_s, rows=groups != g) for g in np.unique(groups) if (groups != g).sum() >= 50
    ]
    th = np.array([x for x in thetas if np.isfinite(x)])
    if len(th) < 3:
        out["outcome"] = f"not identifiable: {len(th)} jackknife group(s) of {JACKKNIFE_GROUPS}, needs 3"
        return out
    out["k"] = tas_scale_heading_free(track, knot_s)
    out["se"] = float(np.sqrt((len(th) - 1) / len(th) * np.sum((th - th.mean()) ** 2)))
    out["outcome"] = "estimated"
    return out


def diagnose_track(
    track: pd.DataFrame, *, knot_s: float = 600.0, block_s: float = 900.0, k: int = 4, start: tuple[str, ...] = ()
) -> tuple[list[Finding], dict]:
    """Forward selection of effects on a wind frame (see the module docstring). `start`: the
    effects the model already has, free (e.g. a compass deviation for a slaved compass);
    the slaving lag is a candidate only once the deviation is in the model."""
    t = track["time_s"].to_numpy(float)
    span = float(t.max() - t.min()) if len(t) else 0.0
    block_s = min(block_s, span / (2 * k)) if span > 0 else block_s  # >= 2 blocks per fold on short records
    folds = _folds(t, block_s, k)
    current: tuple[str, ...] = tuple(start)
    base_fit = fit(track, knot_s, current)
    base_cv = _cv_rms(track, current, knot_s, folds, k)
    baseline = {
        "rms_kt": base_fit["rms"] / KT,
        "held_out_rms_kt": base_cv / KT,
        "equations": base_fit["n"],
        "model_effects": list(current),
    }
    findings: list[Finding] = []
    cur_fit, cur_cv = base_fit, base_cv
    octant = (np.floor((np.degrees(track["heading_rad"].to_numpy()) % 360) / 45.0)).astype(int)
    occupied = int(np.sum(np.bincount(octant, minlength=8) >= OCTANT_MIN_SHARE * len(track)))
    baseline["heading_octants_occupied"] = occupied
    turning = int(np.sum(np.abs(np.degrees(track["heading_rate_rad_s"].to_numpy(float))) > TURN_RATE_DEG_S))
    baseline["turning_samples"] = turning
    free = heading_free_scale(track, knot_s, t)
    baseline["tas_scale_heading_free"] = free
    baseline["rounds"] = []
    while True:
        best = None
        tried: dict[str, dict] = {}
        for eff in EFFECT_COLUMNS:
            if eff in current or (eff == "heading_slaving_lag" and "heading_deviation_1psi" not in current):
                continue
            if occupied < MIN_OCTANTS[eff]:
                tried[eff] = {
                    "outcome": f"not identifiable: {occupied} heading octant(s) occupied, needs {MIN_OCTANTS[eff]}"
                }
                continue
            if eff == "heading_time_offset" and turning < MIN_TURN_SAMPLES:
                tried[eff] = {
                    "outcome": f"not identifiable: {turning} samples turning faster than {TURN_RATE_DEG_S} deg/s, "
                    f"needs {MIN_TURN_SAMPLES}"
                }
                continue
            trial = current + (eff,)
            f = fit(track, knot_s, trial)
            vals = {n: float(f["coef"][f["names"].index(n)]) for n in EFFECT_COLUMNS[eff]}
            if any(abs(v) > PLAUSIBLE[n] for n, v in vals.items()):
                tried[eff] = {"outcome": "implausible size (the wind, not the sensor)", "values": vals}
                continue
            if any(abs(v) < RESOLUTION.get(n, 0.0) for n, v in vals.items()):
                tried[eff] = {"outcome": "below the model's resolution", "values": vals}
                continue
            n = f["n"]
            dbic = n * math.log(f["rss"] / cur_fit["rss"]) + (f["p"] - cur_fit["p"]) * math.log(n)
            cv = _cv_rms(track, trial, knot_s, folds, k)
            p, jk_se = _jackknife_p(track, knot_s, trial, eff, f, t)
            ok = dbic < DBIC_THRESHOLD and p < ALPHA / len(EFFECT_COLUMNS) and cv < (1 - MIN_HELD_OUT_GAIN) * cur_cv
            ses = dict(zip(EFFECT_COLUMNS[eff], map(float, jk_se), strict=False))  # the block jackknife's, as the test
            outcome = "passes" if ok else "not significant"
            if eff == "tas_scale" and free["k"] is not None:
                spread = math.hypot(free["se"], ses["k"] if np.isfinite(ses["k"]) else 0.0)
                gap = abs(vals["k"] - free["k"]) / spread if spread > 0 else math.inf
                if ok and not gap <= HEADING_FREE_AGREE_SIGMA:
                    ok = False
                    outcome = (
                        f"disagrees with the heading-free scale {free['k']:+.4f} ± {free['se']:.4f} "
                        f"({gap:.1f} se apart)"
                    )
            tried[eff] = {
                "outcome": outcome,
                "values": vals,
                "se": ses,
                "delta_bic": float(dbic),
                "p_value": p,
                "held_out_before_kt": cur_cv / KT,
                "held_out_after_kt": cv / KT,
            }
            if ok and (best is None or dbic < best[1]):
                best = (eff, dbic, f, cv, p, ses)
        baseline["rounds"].append(tried)
        if best is None:
            break
        eff, dbic, f, cv, p, ses = best
        params = {
            name: {"value": float(f["coef"][f["names"].index(name)]), "se": ses[name]} for name in EFFECT_COLUMNS[eff]
        }
        findings.append(
            Finding(
                effect=eff,
                cause=CAUSES[eff],
                parameters=params,
                evidence={
                    "delta_bic": float(dbic),
                    "p_value": p,
                    "alpha": ALPHA / len(EFFECT_COLUMNS),
                    "held_out_folds": k,
                    "fold_block_s": block_s,
                    **({"heading_free": free} if eff == "tas_scale" else {}),
                },
                gain={
                    "metric": "wind-vector residual RMS per component (kt)",
                    "before": cur_fit["rms"] / KT,
                    "after": f["rms"] / KT,
                    "held_out": cv / KT,
                    "held_out_before": cur_cv / KT,
                    "held_out_after": cv / KT,
                },
            )
        )
        current, cur_fit, cur_cv = current + (eff,), f, cv
    return findings, baseline


def variation_table_epoch(
    offset_deg: float, track: pd.DataFrame, lat: float, lon: float, alt_m: float, when: dt.datetime
) -> dict:
    """For a heading-offset finding on magnetic heading: the variation the aircraft's own
    table must hold (today's IGRF declination + the offset) and the IGRF epoch in which
    the declination there had that value (a stale table is a real, common error)."""
    from aerotruth.analysis.wind.modes_wind import declination_history_deg

    now = float(np.mean(track["declination_deg"]))
    implied = now + offset_deg
    years = np.arange(1950, when.year + 1)
    decs = declination_history_deg(lat, lon, alt_m, [dt.datetime(int(y), 1, 1) for y in years])
    out = {"declination_now_deg": now, "implied_table_variation_deg": implied}
    between = np.flatnonzero(np.diff(np.sign(decs - implied)) != 0)
    if len(between):
        i = between[-1]
        out["igrf_epoch_with_that_variation"] = float(years[i] + (implied - decs[i]) / (decs[i + 1] - decs[i]))
    return out
