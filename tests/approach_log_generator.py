"""Synthetic approach logs for the FITS tests, written independently of aerotruth's sensor
code (own WAAS, INS, RA, TVPS, DGPS and event models), with the truth kept beside them.

Truth: a straight-in ILS approach at 65 m/s on a 3 deg path, crossing the threshold at
15 m, then a low pass over a 2500 m runway at ~8 m and beyond; some lateral and vertical
wander far out (the filter must not care about the aircraft's motion, FITS paper eq. 3).
WAAS (at the whole seconds): bias + Poisson jumps with flags + 12-s cyclic noise
(sine, or +-A held 6 s) with a +-30 % amplitude change over 200 s + Gauss-Markov (Euler
recursion written out here) + white. INS: a polynomial drift (accel bias beta t^2/2,
gyro bias g eps t^3/6) plus white accelerometer/gyro noise integrated by cumulative sums
(one-sided PSDs; two-sided = half). RA: height of its antenna (lever_arm_m below the
reference point) over the runway; TVPS: cross-track from 600 m before the threshold to
the runway end; DGPS: 2 cm white. Event: first row after crossing + 0.2 +- 0.05 s. `waas_latency_s`: the WAAS
fix logged at t is the truth of t - latency (a receiver's output latency left in its tags).
"""

from __future__ import annotations

import math

import numpy as np
import pandas as pd

SPEED, GLIDE_DEG, TCH, RUNWAY_M = 65.0, 3.0, 15.0, 2500.0
G = 9.80665
UG = 1e-6 * G


def truth_xyz(
    t: np.ndarray,
    t_cross: float,
    rng: np.random.Generator | None,
    ph: np.ndarray | None = None,
    y_offset_m: float = 0.0,
) -> np.ndarray:
    """The trajectory at times t; its wander phases `ph` drawn from rng when not given;
    `y_offset_m` a lateral offset of the whole track (where it crosses the threshold)."""
    x = SPEED * (t - t_cross)
    far = np.clip(-x / 5000.0, 0.0, 1.0)
    ph = rng.uniform(0, 2 * math.pi, 2) if ph is None else ph
    y = 15.0 * far * np.sin(2 * math.pi * t / 90.0 + ph[0]) + y_offset_m
    z_app = TCH - x * math.tan(math.radians(GLIDE_DEG)) + 3.0 * far * np.sin(2 * math.pi * t / 70.0 + ph[1])
    z_pass = 8.0 + 7.0 * np.exp(-np.maximum(x, 0.0) / 400.0)
    return np.column_stack([x, y, np.where(x < 0, z_app, z_pass)])


def waas_errors(
    t: np.ndarray,
    rng: np.random.Generator,
    waveform: str = "sine",
    amplitude: float = 0.5,
    modulation: float = 0.3,
    bias_sigma=(0.45, 0.45, 0.8),
    jumps_per_s: float = 1 / 1800.0,
    jump_sigma: float = 1.0,
    gm_sigma: float = 0.05,
    gm_tau: float = 100.0,
    white_sigma: float = 0.03,
    period_s: float = 12.0,
    second_period_s: float | None = None,
    unflagged_jump: tuple[float, float] | None = None,
) -> dict[str, np.ndarray]:
    """Components (n, 3) at 1-Hz epochs t and the flags."""
    n = len(t)
    bias = np.asarray(bias_sigma) * rng.normal(size=3)
    cyc = np.empty((n, 3))
    for axis in range(3):
        amp = amplitude * (1 + modulation * np.sin(2 * math.pi * t / 200.0 + rng.uniform(0, 2 * math.pi)))
        if waveform == "sine":
            wave = np.sin(2 * math.pi * t / period_s + rng.uniform(0, 2 * math.pi))
        else:
            t0 = rng.uniform(0.0, period_s)
            wave = np.where(np.mod(t - t0, period_s) < period_s / 2, 1.0, -1.0)
        if second_period_s is not None:
            wave = wave + np.sin(2 * math.pi * t / second_period_s + rng.uniform(0, 2 * math.pi))
        cyc[:, axis] = amp * wave
    gm = np.empty((n, 3))
    a = math.exp(-1.0 / gm_tau)
    gm[0] = gm_sigma * rng.normal(size=3)
    for k in range(1, n):
        gm[k] = a * gm[k - 1] + gm_sigma * math.sqrt(1 - a * a) * rng.normal(size=3)
    white = white_sigma * rng.normal(size=(n, 3))
    jumps = np.zeros((n, 3))
    sv, iono = np.zeros(n, int), np.zeros(n, int)
    t_jump = t[0]
    while True:
        t_jump += rng.exponential(1.0 / jumps_per_s) if jumps_per_s > 0 else np.inf
        if t_jump > t[-1]:
            break
        k = int(np.argmax(t >= t_jump))
        jumps[k:] += jump_sigma * rng.normal(size=3)
        (sv if rng.random() < 0.5 else iono)[k] = 1
    if unflagged_jump is not None:  # a step in the bias the receiver did not flag: (time from the start, m per axis)
        jumps[t - t[0] >= unflagged_jump[0]] += unflagged_jump[1]
    return dict(
        bias=bias, cyclic=cyc, gm=gm, white=white, jumps=jumps, sv=sv, iono=iono, total=bias + cyc + gm + white + jumps
    )


def ins_errors(
    t: np.ndarray,
    rng: np.random.Generator,
    accel_bias_ug: float = 500.0,
    gyro_bias_deg_h: float = 1.0,
    accel_psd_ug2_hz: float = 2500.0,
    gyro_psd_deg2_s2_hz: float = 1e-6,
) -> np.ndarray:
    """Position drift (n, 3) of a tactical INS over a short straight approach."""
    tt = t - t[0]
    dt = float(t[1] - t[0])
    beta = accel_bias_ug * UG * rng.normal(size=3)
    eps = math.radians(gyro_bias_deg_h) / 3600.0 * rng.normal(size=2)
    v0 = 0.05 * rng.normal(size=3)
    drift = v0 * tt[:, None] + 0.5 * beta * tt[:, None] ** 2
    drift[:, :2] += G * eps * tt[:, None] ** 3 / 6.0
    acc = math.sqrt(accel_psd_ug2_hz / 2.0 / dt) * UG * rng.normal(size=(len(t), 3))
    gyro = math.sqrt(gyro_psd_deg2_s2_hz / 2.0 / dt) * math.radians(1.0) * rng.normal(size=(len(t), 2))
    acc[:, :2] += G * np.cumsum(gyro, axis=0) * dt
    return drift + np.cumsum(np.cumsum(acc, axis=0) * dt, axis=0) * dt


def baro_coupled_error(
    t: np.ndarray,
    rng: np.random.Generator,
    tau_s: float,
    gm_sigma: float = 1.0,
    gm_tau: float = 60.0,
    white_sigma: float = 0.3,
) -> np.ndarray:
    """Height error of a baro-inertial INS: the barometer's error (Gauss-Markov + white per
    1-s reading, held) through the third-order loop's transfer function with a triple pole
    at -1/tau, (k1 s^2 + k2 s + k3) / (s + 1/tau)^3, integrated by scipy's lsim (the
    inertial errors the loop removes are left out)."""
    from scipy import signal

    t_b = np.arange(t[0], t[-1] + 1.0, 1.0)
    a = math.exp(-1.0 / gm_tau)
    e = np.empty(len(t_b))
    e[0] = gm_sigma * rng.normal()
    for k in range(1, len(t_b)):
        e[k] = a * e[k - 1] + gm_sigma * math.sqrt(1 - a * a) * rng.normal()
    e += white_sigma * rng.normal(size=len(t_b))
    held = e[np.clip(np.searchsorted(t_b, t, side="right") - 1, 0, len(t_b) - 1)]
    p = 1.0 / tau_s
    num = [3 * p, 3 * p**2, p**3]
    den = [1.0, 3 * p, 3 * p**2, p**3]
    # start in the loop's steady state for the first reading (not from rest)
    _, y, _ = signal.lsim((num, den), held - held[0], t - t[0])
    return y + held[0]


def make_approach(
    rng: np.random.Generator,
    approach=0,
    rate_hz: int = 5,
    before_s: float = 300.0,
    after_s: float = 60.0,
    waveform: str = "sine",
    lever_arm_m: float = 0.0,
    t0_s: float = 1000.0,
    numeric_event: bool = False,
    dgps_offset=(0.0, 0.0, 0.0),
    ins_bias_scale: float = 1.0,
    baro_loop_tau_s: float | None = None,
    waas_latency_s: float = 0.0,
    threshold_y_sd_m: float = 0.0,
    tvps_scale: float = 1.0,
    **waas_kw,
):
    """One approach: (log rows, truth rows). WAAS on the whole seconds, other sensors every
    row. Pilot marks as the contract has them: rows of their own at the press time, code
    'thr' at the threshold and 'end' at the stop end (numeric_event: the old 0/1 flag on
    the first row after the press instead). `threshold_y_sd_m`: each approach flown
    laterally offset by a normal draw of that sd (0: on the centreline at the threshold, no
    draw); `tvps_scale`: the TVPS reads that multiple of the cross-track position (-1: the
    opposite sign convention)."""
    n = int(round((before_s + after_s) * rate_hz)) + 1
    t = t0_s + np.arange(n) / rate_hz
    t_cross = t0_s + before_s + rng.uniform(0.0, 1.0)
    ph = rng.uniform(0, 2 * math.pi, 2)
    y_off = float(rng.normal(0.0, threshold_y_sd_m)) if threshold_y_sd_m > 0 else 0.0
    p = truth_xyz(t, t_cross, None, ph, y_off)
    w_rows = np.arange(0, n, rate_hz)
    w = waas_errors(t[w_rows], rng, waveform=waveform, **waas_kw)
    waas = np.full((n, 3), np.nan)
    # a receiver stamping its positions waas_latency_s late: the fix logged at t is the truth of t - latency
    waas[w_rows] = truth_xyz(t[w_rows] - waas_latency_s, t_cross, None, ph, y_off) + w["total"]
    ins = p + ins_errors(t, rng, accel_bias_ug=500.0 * ins_bias_scale, gyro_bias_deg_h=1.0 * ins_bias_scale)
    if baro_loop_tau_s is not None:
        ins[:, 2] = p[:, 2] + baro_coupled_error(t, rng, baro_loop_tau_s)
    dgps = p + np.asarray(dgps_offset, float) + 0.02 * rng.normal(size=(n, 3))
    over = (p[:, 0] >= 0) & (p[:, 0] <= RUNWAY_M) & (np.abs(p[:, 1]) <= 30.0)
    ra = np.where(over, p[:, 2] - lever_arm_m + 0.30 / 1.96 * rng.normal(size=n), np.nan)
    seen = (p[:, 0] >= -600.0) & (p[:, 0] <= RUNWAY_M)
    tvps = np.where(seen, tvps_scale * p[:, 1] + 0.60 / 1.96 * rng.normal(size=n), np.nan)
    t_press = t_cross + 0.2 + 0.05 * rng.normal()
    t_end = t_cross + RUNWAY_M / SPEED + 0.2 + 0.05 * rng.normal()
    event = np.zeros(n, int)
    if numeric_event:
        event[np.searchsorted(t, t_press)] = 1
    sv, iono = np.zeros(n, int), np.zeros(n, int)
    sv[w_rows], iono[w_rows] = w["sv"], w["iono"]
    log = pd.DataFrame(
        {
            "approach": approach,
            "time_s": t,
            "waas_x_m": waas[:, 0],
            "waas_y_m": waas[:, 1],
            "waas_z_m": waas[:, 2],
            "ins_x_m": ins[:, 0],
            "ins_y_m": ins[:, 1],
            "ins_z_m": ins[:, 2],
            "dgps_x_m": dgps[:, 0],
            "dgps_y_m": dgps[:, 1],
            "dgps_z_m": dgps[:, 2],
            "ra_m": ra,
            "tvps_y_m": tvps,
            "event": event,
            "sv_change": sv,
            "iono_update": iono,
        }
    )
    if not numeric_event:
        marks = pd.DataFrame(
            {
                "approach": approach,
                "time_s": [t_press, t_end],
                "event": ["thr", "end"],
                "sv_change": 0,
                "iono_update": 0,
            }
        )
        log["event"] = ""
        log = pd.concat([log, marks[marks["time_s"] <= t[-1]]], ignore_index=True).sort_values("time_s", kind="stable")
        log = log.reset_index(drop=True)
    cyc = np.full((n, 3), np.nan)
    cyc[w_rows] = w["cyclic"]
    truth = pd.DataFrame(
        {
            "approach": approach,
            "time_s": t,
            "x_m": p[:, 0],
            "y_m": p[:, 1],
            "z_m": p[:, 2],
            "cyclic_x_m": cyc[:, 0],
            "cyclic_y_m": cyc[:, 1],
            "cyclic_z_m": cyc[:, 2],
            "t_cross_s": t_cross,
        }
    )
    return log, truth


def make_log(n_approaches: int, seed: int, **kw) -> tuple[pd.DataFrame, pd.DataFrame]:
    """Several approaches, one after another in time."""
    rng = np.random.default_rng(seed)
    logs, truths = [], []
    for i in range(n_approaches):
        lg, tr = make_approach(rng, approach=i + 1, t0_s=1000.0 + 600.0 * i, **kw)
        logs.append(lg)
        truths.append(tr)
    return pd.concat(logs, ignore_index=True), pd.concat(truths, ignore_index=True)
