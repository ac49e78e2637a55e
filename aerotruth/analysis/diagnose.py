"""`aerotruth diagnose`: where measured data disagree with the simulation's sensor model,
which effect explains it, by how much, and what the extension gains on held-out data.

This module: Mode-S data (raw message logs and 1-s Mode-S trajectories); observation
tables are aerotruth.analysis.diagnose_wind, approach logs aerotruth.analysis.diagnose_fits.
The model of a real flight is the Mode-S sensor run on the flight's own trajectory with
ideal heading and airspeed (aerotruth.sensors.modes); its prediction is that the derived
wind (aerotruth.analysis.modes_wind) is smooth in time, once the air vector is taken
along the air track (heading less the bank geometry a sin(phi), with the model aircraft's
angle of attack: modes_wind.ALPHA_LAW_SAAB340). Residual structure that follows the
heading, the airspeed or the turn rate is an effect of the aircraft's sensors.

Only near-level flight at steady speed is used: the smooth-wind assumption holds in time
at a level, not through the shear of a climb (measured on the CDG flight: with climbs and
descents kept, a spurious TAS "scale factor" of -18 % absorbed the wind's change with
height), and while the speed changes the held TAS and the fresh ground speed are of
different instants (SPEED_RATE_KT_S).

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
Each size's standard error is the block jackknife's (the test's), not least squares'.
"""

from __future__ import annotations

import datetime as dt
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd
from scipy import stats

from aerotruth.analysis.modes_wind import (ALPHA_LAW_SAAB340, EFFECT_COLUMNS, central_rate, fit, modes_track_to_wind_frame,
                                         predict_rms)
from aerotruth.errors import DataError
from aerotruth.files import atomic_write_text
from aerotruth.measured import Measured
from aerotruth.units import KT

CAUSES = {
    "heading_offset": "the reported heading is off by a constant: a stale or wrong magnetic-variation table, or an alignment/mounting error",
    "heading_deviation_1psi": "the heading error goes once round with the heading: a compass (flux-valve) deviation, as the wind paper's hard iron",
    "tas_scale": "the true airspeed is off by a constant factor: air-data calibration (static source, temperature)",
    "heading_time_offset": "heading and ground track are sampled at different instants: registers held for different times",
    "heading_slaving_lag": "the compass deviation reaches the heading through a slow slaving loop: after each turn the error "
                           "moves to the new heading's deviation with the time constant tau (a slaved directional gyro)",
}
DBIC_THRESHOLD = -10.0
JACKKNIFE_GROUPS = 8
# Smaller than this agrees with the model: Mode-S registers are held between replies (BDS 6,0
# heading p50 0.69 s, ADS-B velocity 1.07 s: aerotruth.sensors.modes), so the heading and the
# track of one sample differ in age by up to ~0.5 s; null simulated days gave 0.16-0.49 s.
RESOLUTION = {"D_s": 0.5, "tau_s": 2.0}  # tau: the lag grid's first value (modes_wind.SLAVING_TAU_GRID_S)
ALPHA = 0.02  # family-wise over the candidates (Bonferroni): also a jackknife Wald test (_jackknife_p), since
# BIC counts 1-s samples of held registers as independent (it found 78 effects in 100 null days)
MIN_HELD_OUT_GAIN = 0.0  # any drop of the held-out RMS (the dBIC carries the evidence; 1 % refused a true 2-deg offset on a 4-leg day)
# identifiability: a heading effect is told from the wind only across turns; a one-cycle
# deviation needs headings spread round the compass (the wind-method issue's refusal)
MIN_OCTANTS = {"heading_offset": 2, "heading_deviation_1psi": 6, "tas_scale": 2, "heading_time_offset": 1,
               "heading_slaving_lag": 6}
# a time offset between heading and track shows only while the heading changes: samples
# turning faster than TURN_RATE_DEG_S, at least MIN_TURN_SAMPLES of them (the CDG flight's
# level samples fly one heading, p99 0.14 deg/s: a "1.8-s offset" with dBIC -154 was noise)
TURN_RATE_DEG_S = 0.5
MIN_TURN_SAMPLES = 30
OCTANT_MIN_SHARE = 0.03
PLAUSIBLE = {"A_deg": 20.0, "B_deg": 10.0, "C_deg": 10.0, "k": 0.1, "D_s": 10.0, "tau_s": 299.0}  # beyond: a model failure, not an effect
PARABOLA_FPM = 1500.0  # vertical rates of a zero-g parabola; level and normal climbs stay far below
PARABOLA_MARGIN_S = 60.0
LEVEL_FPM = 500.0
# While the airspeed changes (level decelerations in the terminal area), the held BDS 5,0
# TAS and the fresh ADS-B ground speed are of different instants (registers are held for
# ~1-5 s): on null simulated days these samples alone made a "TAS scale" of -3 to -5 %
# (p < 1e-4). TAS rate over +-10 s of the held register.
SPEED_RATE_KT_S = 0.5
SPEED_HALF_WINDOW_S = 10.0  # the wind is smooth in time at a level; climbing through shear it changes with height
# The wind paper rejects roll > 10 deg (banked, the nose is not where the aircraft goes).
# Here it is optional and off: turns are what identify a heading lag, and measured on
# simulated Mesaba days the filter left the decaying sideslip after roll-out to alias into
# a lag of -0.5 to -0.9 s and lost a hidden 2-s lag entirely; without it the SAAB's
# sideslip spikes in its fast roll-ins (the truth-realism issue) read as a TAS scale.


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


def _on_grid(x: np.ndarray, lsb: float) -> np.ndarray:
    r = np.mod(x / lsb, 1.0)
    return (r < 1e-3) | (r > 1 - 1e-3)


def track_from_measured(m: Measured, max_roll_deg: float | None = None) -> tuple[pd.DataFrame, dict]:
    """The Mode-S wind frame of a measured flight and what was excluded (with the reason);
    `max_roll_deg` applies the wind paper's roll filter where the data carry roll."""
    if m.kind == "modes_track":
        d = m.df.dropna(subset=["heading", "TAS", "track", "groundspeed", "latitude", "longitude", "altitude"])
        excluded = {"missing fields": int(len(m.df) - len(d))}
    elif m.kind == "modes_raw":
        d = _track_from_raw(*_raw_registers(m))
        excluded = {"BDS 6,0 replies without BDS 5,0 / ADS-B neighbours": int((m.df["bds"] == "60").sum() - len(d))}
    else:
        what = {"adsb_track": "an ADS-B track", "qar": "a flight-data-recorder extract"}.get(m.kind, f"a {m.kind.replace('_', ' ')}")
        raise DataError(f"{m.path}: diagnose of {what} is not possible: it carries no heading and "
                        "airspeed to test; Mode-S data, observation tables and approach logs are supported")
    if len(d) < 200:  # before the exclusions, which need samples to work on
        raise DataError(f"{m.path}: only {len(d)} samples carry heading, TAS, track, ground speed and position "
                        f"({excluded}); need at least 200")
    vr = d["vertical_rate"].to_numpy(float) if "vertical_rate" in d else np.zeros(len(d))
    t = d["time_s"].to_numpy(float)
    steep = np.abs(vr) > PARABOLA_FPM
    near = np.zeros(len(d), bool)
    for ts in t[steep]:
        near |= np.abs(t - ts) <= PARABOLA_MARGIN_S
    excluded[f"within {PARABOLA_MARGIN_S:.0f} s of |vertical rate| > {PARABOLA_FPM:.0f} ft/min (parabolas, steep climbs and descents)"] = int(near.sum())
    keep = ~near
    climbing = keep & (np.abs(vr) > LEVEL_FPM)
    excluded[f"climbing or descending faster than {LEVEL_FPM:.0f} ft/min (wind shear with height)"] = int(climbing.sum())
    keep &= ~climbing
    tas = d["TAS"].to_numpy(float)
    order = np.argsort(t, kind="stable")
    ts, vs = t[order], tas[order]
    rate = np.empty(len(t))
    rate[order] = central_rate(ts, vs, SPEED_HALF_WINDOW_S)
    changing = keep & (np.abs(rate) > SPEED_RATE_KT_S)
    excluded[f"airspeed changing faster than {SPEED_RATE_KT_S:g} kt/s (held TAS and fresh ground speed of different instants)"] = int(changing.sum())
    keep &= ~changing
    if max_roll_deg is not None and "roll" in d:
        banked = keep & (np.abs(d["roll"].to_numpy(float)) > max_roll_deg)
        excluded[f"roll beyond {max_roll_deg:g} deg (wind paper)"] = int(banked.sum())
        keep &= ~banked
    if m.kind == "modes_track":
        fresh = _on_grid(d["heading"].to_numpy(float), 90 / 512) & _on_grid(d["TAS"].to_numpy(float), 2.0)
        excluded["heading or TAS off its register LSB grid (interpolated by the resampler)"] = int((keep & ~fresh).sum())
        keep &= fresh
    d = d[keep]
    if len(d) < 200:
        raise DataError(f"{m.path}: only {len(d)} usable samples after exclusions ({excluded}); need at least 200")
    when = dt.datetime.fromtimestamp(float(d["time_s"].iloc[0]), tz=dt.timezone.utc).replace(tzinfo=None)
    return modes_track_to_wind_frame(d, when), excluded


# what the wind frame is built from in a raw message log: (downlink formats, BDS, fields, what it is)
RAW_REGISTERS = ((("20", "21"), "60", ("heading",), "Comm-B BDS 6,0 replies (magnetic heading)"),
                 (("20", "21"), "50", ("TAS",), "Comm-B BDS 5,0 replies (true airspeed)"),
                 (("17",), "09", ("groundspeed", "track", "vertical_rate"), "ADS-B airborne velocity messages (DF 17, BDS 0,9)"),
                 (("17",), "05", ("latitude", "longitude", "altitude"), "ADS-B airborne position messages (DF 17, BDS 0,5)"))


def _raw_registers(m: Measured) -> list[pd.DataFrame]:
    """The messages of each RAW_REGISTERS entry, in time order; a log without one of them
    decoded is one DataError naming it."""
    raw = m.df
    if "bds" not in raw.columns:
        raise DataError(f"{m.path}: messages without a 'bds' field; expected decoded Mode-S (BDS 0,5, 0,9, 5,0, 6,0)")
    out = []
    for dfs, bds, fields, what in RAW_REGISTERS:
        sel = raw[raw["df"].astype(str).isin(dfs) & (raw["bds"] == bds)].sort_values("time_s")
        missing = [f for f in fields if f not in sel.columns or sel[f].isna().all()]
        if len(sel) == 0 or missing:
            got = f"{len(sel)} of them, none with {missing[0]!r} decoded" if len(sel) else "none"
            raise DataError(f"{m.path}: no usable {what}: {got}; diagnose needs them with "
                            f"{', '.join(fields)}")
        out.append(sel)
    return out


def _track_from_raw(b60: pd.DataFrame, b50: pd.DataFrame, vel: pd.DataFrame, pos: pd.DataFrame) -> pd.DataFrame:
    """One row per BDS 6,0 reply: its heading, the latest BDS 5,0 TAS, the ADS-B velocity
    and position interpolated to the reply time (the registers of `_raw_registers`)."""
    b60 = b60.dropna(subset=["heading"])
    t = b60["time_s"].to_numpy(float)
    out = pd.DataFrame({"time_s": t, "heading": b60["heading"].to_numpy(float)})
    i = np.searchsorted(b50["time_s"].to_numpy(), t, side="right") - 1
    ok = i >= 0
    out["TAS"] = np.where(ok, b50["TAS"].to_numpy(float)[np.clip(i, 0, None)], np.nan)
    if "roll" in b50:
        out["roll"] = np.where(ok, b50["roll"].to_numpy(float)[np.clip(i, 0, None)], np.nan)
    vt = vel["time_s"].to_numpy(float)
    trk = np.unwrap(np.radians(vel["track"].to_numpy(float)))
    out["track"] = np.degrees(np.interp(t, vt, trk)) % 360
    out["groundspeed"] = np.interp(t, vt, vel["groundspeed"].to_numpy(float))
    out["vertical_rate"] = np.interp(t, vt, vel["vertical_rate"].to_numpy(float))
    pt = pos["time_s"].to_numpy(float)
    for c in ("latitude", "longitude", "altitude"):
        out[c] = np.interp(t, pt, pos[c].to_numpy(float))
    # keep replies with fresh neighbours: ADS-B velocity within 1 s, BDS 5,0 within 5 s
    near_v = np.abs(vt[np.clip(np.searchsorted(vt, t), 0, len(vt) - 1)] - t) <= 1.0
    age50 = np.where(ok, t - b50["time_s"].to_numpy(float)[np.clip(i, 0, None)], np.inf)
    return out[near_v & (age50 <= 5.0)].dropna().reset_index(drop=True)


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


def _jackknife_p(track: pd.DataFrame, knot_s: float, effects: tuple[str, ...], eff: str, f: dict, t: np.ndarray,
                 block_s: float) -> tuple[float, np.ndarray]:
    """p-value of `eff`'s parameters = 0 and their standard errors: a Wald test with the
    delete-one-group jackknife covariance, groups JACKKNIFE_GROUPS interleaved blocks of
    `block_s`, F(q, J - 1). The errors that matter are not the samples' noise but what
    happens turn by turn (register timing, gusts): the least-squares se, even inflated for
    AR(1), made null days' timing offsets of 0.2-0.5 s look like p < 1e-10 (and on
    simulated 4-leg days with a hidden 2-deg table error the estimates scatter 1.7x their
    least-squares se). With fewer than 3 groups: p 1, se NaN."""
    idx = [f["names"].index(nm) for nm in EFFECT_COLUMNS[eff]]
    groups = (np.floor((t - t.min()) / block_s).astype(int)) % JACKKNIFE_GROUPS
    thetas = []
    for g in np.unique(groups):
        keep = groups != g
        if keep.sum() < 50:
            continue
        thetas.append(fit(track, knot_s, effects, rows=keep)["coef"][idx])
    J = len(thetas)
    if J < 3:
        return 1.0, np.full(len(idx), np.nan)
    th = np.array(thetas)
    cov = (J - 1) / J * (th - th.mean(axis=0)).T @ (th - th.mean(axis=0))
    b = f["coef"][idx]
    w = float(b @ np.linalg.pinv(np.atleast_2d(cov)) @ b)
    q = len(idx)
    return float(stats.f.sf(w / q, q, J - 1)), np.sqrt(np.diag(np.atleast_2d(cov)))


def diagnose_track(track: pd.DataFrame, *, knot_s: float = 600.0, block_s: float = 900.0, k: int = 4,
                   start: tuple[str, ...] = ()) -> tuple[list[Finding], dict]:
    """Forward selection of effects on a wind frame (see the module docstring). `start`: the
    effects the model already has, free (e.g. a compass deviation for a slaved compass);
    the slaving lag is a candidate only once the deviation is in the model."""
    t = track["time_s"].to_numpy(float)
    span = float(t.max() - t.min()) if len(t) else 0.0
    block_s = min(block_s, span / (2 * k)) if span > 0 else block_s  # >= 2 blocks per fold on short records
    jk_block_s = min(block_s, span / JACKKNIFE_GROUPS) if span > 0 else block_s
    folds = _folds(t, block_s, k)
    current: tuple[str, ...] = tuple(start)
    base_fit = fit(track, knot_s, current)
    base_cv = _cv_rms(track, current, knot_s, folds, k)
    baseline = {"rms_kt": base_fit["rms"] / KT, "held_out_rms_kt": base_cv / KT, "equations": base_fit["n"],
                "model_effects": list(current)}
    findings: list[Finding] = []
    cur_fit, cur_cv = base_fit, base_cv
    octant = (np.floor((np.degrees(track["heading_rad"].to_numpy()) % 360) / 45.0)).astype(int)
    occupied = int(np.sum(np.bincount(octant, minlength=8) >= OCTANT_MIN_SHARE * len(track)))
    baseline["heading_octants_occupied"] = occupied
    turning = int(np.sum(np.abs(np.degrees(track["heading_rate_rad_s"].to_numpy(float))) > TURN_RATE_DEG_S))
    baseline["turning_samples"] = turning
    baseline["rounds"] = []
    while True:
        best = None
        tried: dict[str, dict] = {}
        for eff in EFFECT_COLUMNS:
            if eff in current or (eff == "heading_slaving_lag" and "heading_deviation_1psi" not in current):
                continue
            if occupied < MIN_OCTANTS[eff]:
                tried[eff] = {"outcome": f"not identifiable: {occupied} heading octant(s) occupied, needs {MIN_OCTANTS[eff]}"}
                continue
            if eff == "heading_time_offset" and turning < MIN_TURN_SAMPLES:
                tried[eff] = {"outcome": f"not identifiable: {turning} samples turning faster than {TURN_RATE_DEG_S} deg/s, "
                              f"needs {MIN_TURN_SAMPLES}"}
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
            p, jk_se = _jackknife_p(track, knot_s, trial, eff, f, t, jk_block_s)
            ok = dbic < DBIC_THRESHOLD and p < ALPHA / len(EFFECT_COLUMNS) and cv < (1 - MIN_HELD_OUT_GAIN) * cur_cv
            ses = dict(zip(EFFECT_COLUMNS[eff], map(float, jk_se)))  # the block jackknife's, as the test
            tried[eff] = {"outcome": "passes" if ok else "not significant", "values": vals, "se": ses,
                          "delta_bic": float(dbic), "p_value": p, "held_out_before_kt": cur_cv / KT,
                          "held_out_after_kt": cv / KT}
            if ok and (best is None or dbic < best[1]):
                best = (eff, dbic, f, cv, p, ses)
        baseline["rounds"].append(tried)
        if best is None:
            break
        eff, dbic, f, cv, p, ses = best
        params = {name: {"value": float(f["coef"][f["names"].index(name)]), "se": ses[name]} for name in EFFECT_COLUMNS[eff]}
        findings.append(Finding(
            effect=eff, cause=CAUSES[eff], parameters=params,
            evidence={"delta_bic": float(dbic), "p_value": p, "alpha": ALPHA / len(EFFECT_COLUMNS), "held_out_folds": k,
                      "fold_block_s": block_s},
            gain={"metric": "wind-vector residual RMS per component (kt)", "before": cur_fit["rms"] / KT, "after": f["rms"] / KT,
                  "held_out": cv / KT, "held_out_before": cur_cv / KT, "held_out_after": cv / KT}))
        current, cur_fit, cur_cv = current + (eff,), f, cv
    return findings, baseline


def variation_table_epoch(offset_deg: float, track: pd.DataFrame, lat: float, lon: float, alt_m: float, when: dt.datetime) -> dict:
    """For a heading-offset finding on magnetic heading: the variation the aircraft's own
    table must hold (today's IGRF declination + the offset) and the IGRF epoch in which
    the declination there had that value (a stale table is a real, common error)."""
    from aerotruth.analysis.modes_wind import declination_history_deg

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


def write_diagnosis(diag: Diagnosis, track: pd.DataFrame, out_dir: Path, knot_s: float = 600.0) -> None:
    """DIR/diagnosis.json, DIR/report.md and DIR/figures/wind_along_flight.png."""
    out_dir.mkdir(parents=True, exist_ok=True)
    doc = asdict(diag)
    a0, a1 = ALPHA_LAW_SAAB340
    model = (f"Model: the simulation's Mode-S sensor on this flight's own trajectory, ideal heading and airspeed; the air "
             f"track is heading - alpha sin(roll) with the simulation's aircraft's angle of attack, the SAAB 340B's "
             f"alpha = {a0:.2f} deg + {a1:.0f} Pa deg / (q cos roll) (modes_wind.ALPHA_LAW_SAAB340), used for this aircraft "
             "too: its own alpha law is not known here (a different alpha moves the air track by (delta alpha) sin(roll), "
             "< 0.1 deg per deg of alpha at 5 deg of bank).")
    doc["model"] = model
    atomic_write_text(out_dir / "diagnosis.json", json.dumps(doc, indent=2, sort_keys=False) + "\n")
    lines = [f"# Diagnosis of `{diag.measured}`", "", f"Kind: {diag.kind}; samples used: {diag.samples_used}.", "",
             "Excluded: " + "; ".join(f"{k}: {v}" for k, v in diag.samples_excluded.items()), "",
             model, "",
             f"Baseline (ideal sensor, smooth wind): residual {diag.baseline['rms_kt']:.2f} kt per component, "
             f"held out {diag.baseline['held_out_rms_kt']:.2f} kt.", ""]
    if not diag.findings:
        lines += ["**No finding**: no candidate effect improves the held-out fit with strong evidence.", ""]
    for i, f in enumerate(diag.findings, 1):
        ps = ", ".join(f"{k} = {v['value']:.4g} ± {v['se']:.2g}" for k, v in f.parameters.items())
        vt = f.evidence.get("variation_table")
        if vt is not None:
            ps += (f"; the aircraft's variation table must hold {vt['implied_table_variation_deg']:.1f} deg where IGRF gives "
                   f"{vt['declination_now_deg']:.1f} deg today" + (f", the declination there in {vt['igrf_epoch_with_that_variation']:.0f}"
                                                                   if "igrf_epoch_with_that_variation" in vt else ""))
        lines += [f"## {i}. {f.effect}", "", f.cause, "", f"* parameters: {ps}", f"* ΔBIC {f.evidence['delta_bic']:.1f}, jackknife p = {f.evidence['p_value']:.2g} (level {f.evidence['alpha']:.2g})",
                  f"* residual {f.gain['before']:.2f} → {f.gain['after']:.2f} kt; held out {f.gain['held_out_before']:.2f} → "
                  f"{f.gain['held_out_after']:.2f} kt", ""]
    last = (diag.baseline.get("rounds") or [{}])[-1]
    if last:
        lines += ["Candidates after the last finding (what the data say of each):", "",
                  "| effect | outcome | size | ΔBIC | jackknife p | held out (kt) |", "|---|---|---|---|---|---|"]
        for eff, c in last.items():
            ses = c.get("se", {})
            size = ", ".join(f"{k} {v:.3g}" + (f" ± {ses[k]:.2g}" if k in ses else "") for k, v in c.get("values", {}).items())
            ho = (f"{c['held_out_before_kt']:.3f} → {c['held_out_after_kt']:.3f}" if "held_out_after_kt" in c else "")
            lines.append(f"| {eff} | {c['outcome']} | {size} | {c['delta_bic']:.1f} | {c['p_value']:.2g} | {ho} |"
                         if "delta_bic" in c else f"| {eff} | {c['outcome']} | {size} | | | |")
        lines.append("")
    _figure(diag, track, out_dir, knot_s)
    lines += ["![The derived wind along the flight, coloured by heading, before and after](figures/wind_along_flight.png)", ""]
    atomic_write_text(out_dir / "report.md", "\n".join(lines))


def _figure(diag: Diagnosis, track: pd.DataFrame, out_dir: Path, knot_s: float) -> None:
    """The derived wind along the flight, coloured by heading, with the ideal sensor and
    with the findings applied: a heading or airspeed error makes the wind jump when the
    aircraft turns; corrected, it runs on smoothly."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from aerotruth.analysis.modes_wind import design

    effects = tuple(f.effect for f in diag.findings)
    t_min = (track["time_s"].to_numpy() - track["time_s"].iloc[0]) / 60.0
    psi = np.degrees(track["heading_rad"].to_numpy()) % 360
    n = len(track)
    fig, axes = plt.subplots(2, 2, figsize=(11, 6), sharex=True, sharey="row")
    for col, (effs, title) in enumerate((((), "ideal sensor"), (effects, "with the findings" if effects else "no finding"))):
        X, y, names = design(track, knot_s, effs)
        coef, *_ = np.linalg.lstsq(X, y, rcond=None)
        eff_cols = [i for i, nm in enumerate(names) if not nm.startswith("wind_")]
        wind = (y - (X[:, eff_cols] @ coef[eff_cols] if eff_cols else 0.0)) / KT  # V_G - corrected V_A
        for row, (part, label) in enumerate(((slice(0, n), "north"), (slice(n, 2 * n), "east"))):
            ax = axes[row, col]
            sc = ax.scatter(t_min, wind[part], c=psi, cmap="twilight", s=3, vmin=0, vmax=360)
            ax.set_ylabel(f"wind {label} (kt)") if col == 0 else None
            ax.grid(alpha=0.3)
        axes[0, col].set_title(title)
        axes[1, col].set_xlabel("minutes from the first sample used")
    fig.colorbar(sc, ax=axes, label="true heading (deg)")
    (out_dir / "figures").mkdir(exist_ok=True)
    fig.savefig(out_dir / "figures" / "wind_along_flight.png", dpi=130, bbox_inches="tight")
    plt.close(fig)
