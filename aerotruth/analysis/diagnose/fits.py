"""`aerotruth diagnose` on an approach log (the FITS paper's side): where a
flight's WAAS, INS and DGPS data disagree with the simulation's sensor model, why, and
what the extended model gains on approaches it was not fitted on.

The model is the campaign's `fits` (or `inspection`) section: the cyclic period of the
WAAS fast corrections, the INS grade, the DGPS survey offset (aerotruth.sensors.*). The
approaches are split in two halves (alternate approaches, in log order); each effect is
estimated on one half and its gain measured on the other, then the other way round, and
the two gains averaged ("held out"). Gains are in the metric a flight inspector cares
about: the RMS of the WAAS-aided FITS minus the DGPS truth, cross-track and vertical
(along-track is left out: it is the pilot's mark timing), and for the INS the Gaussian
log-likelihood of its drift. Without DGPS only the INS frame and the cyclic period can be
tested.

Effects (each with the size the hidden-effect tests use):
* `ins_frame` — the INS columns are not in the runway frame: an axis of the other sign (z
  down, y right), two axes swapped, or the horizontal axes turned (a north-east frame, a
  magnetic course used for the true one). Drift is smooth (a cubic in time holds its bias,
  velocity, tilt, accelerometer and gyro terms over an approach), the aircraft's motion
  is not (wander, level-offs, speed changes), so beyond a cubic per approach (and a step
  at each flagged WAAS epoch) the INS must follow the WAAS axis by axis: the loadings F of
  the INS's axes on the WAAS's (least squares over approaches, standard errors clustered
  by approach) are the identity, shrunk by the WAAS noise. Tested on the axes whose motion
  beyond the cubic is >= 1 m RMS; the frame is the orthogonal matrix nearest the loadings
  (analysis.ins_frame.orientation); finding when an entry it moves is > 4 se from the
  identity's and putting the INS back lowers WAAS - INS beyond the drift by > 0.1 m RMS.
  Needs no DGPS. Extension: the
  INS columns put back in the frame; the other effects run on them (else the motion reads
  as WAAS noise: a z down read as a second cyclic period, a DGPS offset and jumps).
* `cyclic_period` — the WAAS - INS difference, detrended by a local cubic (Savitzky-Golay,
  41 s) and averaged over approaches as a periodogram, peaks at a period other than the
  model's (or at a second one): the fast-correction interval is not what the model says
  (6 s instead of 12, or two update rates). Finding when the other peak holds more than
  3x the power at the model's period (or, for a second period, more than a third of the
  main peak and 20x the median power). Extension: the FITS filter's period_s.
* `dgps_offset` — FITS - DGPS has a constant part across approaches (y, z): the DGPS
  reference station's surveyed position is off (the FITS paper suspects it in its own
  flight test). Finding when |mean| > 4 standard errors of the across-approach scatter and
  > 0.1 m. Aliased with a common radar-altimeter/TVPS bias (the same signature); the
  report says so. Extension: the DGPS survey offset.
* `waas_jump` — an unflagged step in the WAAS bias: WAAS - N_hat - DGPS (the bias plus
  slow noise) steps by more than 0.5 m and 8 noise sigmas between the 30 s before and
  after an epoch the receiver did not flag. Extension: the epoch flagged (the FITS
  compensates it, section IV-C). A single event: its gain is measured on that approach.
  The effects tested before the scan (latency, TVPS scale, offset, INS bias, barometer)
  are tested again with the steps found flagged: before its step an approach's FITS is off
  by it (the bias is fixed at the threshold, after it), and steps that agree across
  approaches read as a DGPS offset and a latency.
* `baro_coupling` — (a barometer-coupled INS only) the INS - DGPS height error has the
  spectrum of the barometer's error through a third-order loop of another time constant
  than the model's: the mean periodogram over approaches of its first differences (Hann
  window, against leakage in 6-min records; 1/40-1/5 Hz) is fitted in
  log power by |H_tau(f)|^2 S_baro(f) + a white floor (the model's barometer:
  Gauss-Markov + white per 1-s reading; the floor, DGPS and INS noise, fitted freely)
  over tau from 3 to 300 s; finding when the fitted tau is outside 0.7-1.4x
  the model's and its log-power misfit is less than half the model's. Extension: the loop's
  time constant (bandwidth ~ 1/tau). Held out: tau fitted on one half, misfit on the other.
* `waas_latency` — the WAAS fixes are stamped tau late against the log's time base (the RA,
  TVPS and DGPS times): the FITS's position is the WAAS's, so FITS - DGPS = -tau (v - v_thr)
  cross-track and vertically (v the DGPS velocity, v_thr its value at the threshold fix,
  which the bias takes up); least squares over approaches and both axes, standard error
  clustered by approach; finding when |tau| > 4 se and >= 20 ms. Uncompensated, the
  level-off's change of vertical speed reads as an unflagged jump in every approach and the
  glide path's as a DGPS offset, so the effects after it run on re-tagged epochs.
  Extension: FitsSpec.waas_latency_s (`aerotruth fits --waas-latency`).
* `tvps_scale` — the TVPS reads k x the camera's cross-track position (k = -1: the opposite
  sign convention; a focal length or pixel size off): eq. 18 fixes the cross-track bias on
  the reading at the threshold, so FITS - DGPS is off by (1 - 1/k) y for the whole approach;
  regressed across approaches on the reading (mean within the fix window), the slope is
  1 - 1/k and a common DGPS/TVPS offset the intercept. Tested when >= 6 approaches cross
  the threshold with readings spread by >= 0.5 m (sd; on the centreline every time a scale
  is an offset); finding when |slope| > 4 se and it moves the FITS by > 0.1 m at the
  readings' RMS. Extension: `tvps_y_m` / k. The offset and later effects run on the
  rescaled readings.
* `ins_bias` — the INS drift against DGPS (quadratic per axis over the approach; the
  accelerometer bias is twice its t^2 coefficient) is larger than the grade says:
  sum of (b_hat / sigma)^2 is chi-square with one degree per approach and axis under the
  model; finding at p < 0.001 and a scale k = RMS(b_hat) / sigma above 1.5. Extension:
  the grade's biases scaled by k.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd
from scipy import signal, stats

from aerotruth.analysis.diagnose.modes import Finding
from aerotruth.analysis.fits import ins_frame
from aerotruth.analysis.fits.approach_log import (
    ApproachInputs,
    approach_inputs,
    at_times,
    check_approach,
    fits_of,
    retagged,
)
from aerotruth.analysis.fits.filter import FitsSpec
from aerotruth.analysis.least_squares import clustered_se
from aerotruth.errors import DataError
from aerotruth.sensors.inertial_errors import INS_GRADES, MICRO_G

SG_WINDOW = 41  # epochs (s at 1 Hz): the local cubic removed before the periodogram
STEP_WINDOW = 30  # epochs each side of a candidate jump


@dataclass(frozen=True)
class FitsModel:
    """What the simulation assumes about the sensors behind a log."""

    period_s: float = 12.0
    grade: str = "tactical"
    dgps_offset_m: tuple[float, float, float] = (0.0, 0.0, 0.0)
    vertical: str = "free"  # the INS's vertical channel: free, inertial or baro (aerotruth.sensors.ins)
    baro_loop_tau_s: float = 30.0
    baro_gm_sigma_m: float = 1.0
    baro_gm_tau_s: float = 60.0
    baro_white_sigma_m: float = 0.3

    @property
    def accel_bias_ug(self) -> float:
        return INS_GRADES[self.grade].accel_bias_ug

    @classmethod
    def from_campaign(cls, campaign) -> FitsModel:
        """The sensors of the campaign's fits (or inspection) section: its WAAS period, its
        first INS's grade, its DGPS survey offset; the defaults without such a section."""
        for name in ("fits", "inspection"):
            if name in campaign.studies:
                s = campaign.studies[name]
                ins = s.sensors.ins[0]
                return cls(
                    period_s=s.sensors.waas.cyclic_period_s,
                    grade=ins.grade,
                    dgps_offset_m=tuple(s.sensors.dgps.survey_offset_m),
                    vertical=ins.vertical,
                    baro_loop_tau_s=ins.baro_loop_time_constant_s,
                    baro_gm_sigma_m=ins.baro_gm_sigma_m,
                    baro_gm_tau_s=ins.baro_gm_tau_s,
                    baro_white_sigma_m=ins.baro_white_sigma_m,
                )
        return cls()


@dataclass
class _Approach(ApproachInputs):
    """An approach's FITS inputs (approach_log.approach_inputs: lever arms included) and its id."""

    name: object = None
    source: str = ""  # the log's file, for errors


def checked_approaches(path, df: pd.DataFrame) -> list[_Approach]:
    out = []
    for a, g in df.groupby("approach", sort=False):
        check_approach(path, a, g)
        out.append(_Approach(**vars(approach_inputs(g)), name=a, source=str(path)))
    return out


def _fits(ap: _Approach, period_s: float, extra_flags: np.ndarray | None = None):
    try:
        return fits_of(ap, FitsSpec(period_s=period_s), extra_flags)
    except DataError:
        raise
    except ValueError as e:  # what the FITS cannot take (too short an approach, ...): one line naming it
        raise DataError(f"{ap.source}: approach {ap.name!r}: {e}") from None


def _err_rms(aps: list[_Approach], period_s: float, offset=(0.0, 0.0, 0.0), flags: dict | None = None) -> float:
    """RMS of FITS - (DGPS - offset), cross-track and vertical, over the approaches."""
    sq, n = 0.0, 0
    for ap in aps:
        r = _fits(ap, period_s, (flags or {}).get(ap.name))
        e = r.xyz_m - (ap.dgps_w - np.asarray(offset))
        e = e[np.isfinite(e).all(axis=1)][:, 1:]
        sq += float(np.sum(e**2))
        n += e.size
    return math.sqrt(sq / n) if n else float("nan")


def _halves(aps: list) -> tuple[list, list]:
    return aps[0::2], aps[1::2]


def _power_at(f: np.ndarray, p: np.ndarray, period: float) -> float:
    i = int(np.argmin(np.abs(f - 1.0 / period)))
    return float(p[max(i - 1, 0) : i + 2].max())


def _detrended(ap: _Approach) -> np.ndarray | None:
    dz = ap.waas - ap.ins_w
    if len(dz) < 2 * SG_WINDOW:
        return None
    return dz - signal.savgol_filter(dz, SG_WINDOW, 3, axis=0)


def mean_periodogram(aps: list[_Approach]) -> tuple[np.ndarray, np.ndarray | None]:
    """(grid, mean periodogram over approaches and axes of the detrended WAAS - INS), the
    approaches' periodograms of different lengths interpolated on one frequency grid."""
    grid = np.linspace(1.0 / 40.0, 0.5, 400)
    acc = []
    for ap in aps:
        res = _detrended(ap)
        if res is not None:
            f, p = signal.periodogram(res, fs=1.0, axis=0, detrend=False)
            acc.append(np.interp(grid, f, p.mean(axis=1)))
    return grid, (np.mean(acc, axis=0) if acc else None)


def _detect_period(aps: list[_Approach], model: FitsModel):
    """(kind, period, power ratio, main peak period) of the cyclic noise, or None when the
    model's period is what the data show (module docstring)."""
    grid, pm = mean_periodogram(aps)
    if pm is None:
        return None
    band = (grid >= 1.0 / 30.0) & (grid <= 1.0 / 2.5)
    i_peak = np.flatnonzero(band)[np.argmax(pm[band])]
    peak_period = 1.0 / grid[i_peak]
    p_model = _power_at(grid, pm, model.period_s)
    med = float(np.median(pm[band]))
    # a second peak away from the first and from the harmonics of either period
    harm = np.zeros_like(grid, bool)
    for base in (peak_period, model.period_s):
        for m in (1, 2, 3):
            harm |= np.abs(grid - m / base) < 0.012
    far = band & ~harm
    i2 = np.flatnonzero(far)[np.argmax(pm[far])]
    if abs(peak_period - model.period_s) > 0.1 * model.period_s and pm[i_peak] > 3.0 * p_model:
        return "period", peak_period, pm[i_peak] / max(p_model, 1e-30), peak_period
    if pm[i2] > pm[i_peak] / 3.0 and pm[i2] > 20.0 * med:
        return "second", 1.0 / grid[i2], pm[i2] / med, peak_period
    return None


def _periodic_rms(aps: list[_Approach], periods: list[float]) -> float:
    """RMS of the detrended WAAS - INS after a least-squares fit, per approach and axis, of
    a sinusoid at each of the given periods (the WAAS model's sine waveform): how much of
    the measured noise a cyclic model with those periods accounts for."""
    sq, n = 0.0, 0
    for ap in aps:
        res = _detrended(ap)
        if res is None:
            continue
        t = ap.t_w - ap.t_w[0]
        cols = [np.ones_like(t)]
        for per in periods:
            cols += [np.sin(2 * np.pi * t / per), np.cos(2 * np.pi * t / per)]
        A = np.column_stack(cols)
        r = res - A @ np.linalg.lstsq(A, res, rcond=None)[0]
        sq += float(np.sum(r**2))
        n += r.size
    return math.sqrt(sq / n) if n else float("nan")


def _frame_effect(aps: list[_Approach]) -> Finding | None:
    fe = ins_frame.frame_error(aps)
    if fe is None:
        return None
    held = []
    for fit, test in zip(_halves(aps), _halves(aps)[::-1], strict=False):
        g = ins_frame.frame_error(fit)
        p_fit = g.q if g is not None else np.eye(3)
        held.append(
            (
                ins_frame.beyond_drift_rms(test),
                ins_frame.beyond_drift_rms([ins_frame.in_frame(ap, p_fit) for ap in test]),
            )
        )
    ax = ins_frame.AXES
    return Finding(
        "ins_frame",
        f"The INS positions are not in the runway frame (x along the course, y left, z up): {'; '.join(fe.said())}. "
        f"Beyond a drift (a cubic in time per approach), the INS follows the aircraft's motion as the WAAS sees "
        f"it with loadings {fe.loads()} (1 in the frame; the WAAS noise shrinks them a little). The FITS's filter "
        "then takes the motion for WAAS noise. Put the INS columns in the runway frame.",
        {
            f"F_{ax[i]}{ax[j]}": {"value": float(fe.f[i, j]), "se": float(fe.se[i, j])}
            for j in fe.cols
            for i in range(3)
        },
        {
            "frame": fe.q.tolist(),
            "motion_rms_m": [float(v) for v in fe.motion_m],
            "axes_tested": [ax[j] for j in fe.cols],
            "approaches": len(aps),
            "z": fe.z,
            "score": float(np.log10(max(fe.z, 1.0)) + 1.0),
        },
        {
            "before": fe.rms_m,
            "after": fe.rms_in_frame_m,
            "held_out_before": float(np.mean([h[0] for h in held])),
            "held_out_after": float(np.mean([h[1] for h in held])),
            "unit": "m (WAAS - INS beyond the drift polynomial, RMS)",
        },
    )


def _period_effect(aps: list[_Approach], model: FitsModel) -> Finding | None:
    found = _detect_period(aps, model)
    if found is None:
        return None
    kind, period, ratio, main = found

    def periods_of(fd):
        if fd is None:
            return [model.period_s]
        return [fd[1]] if fd[0] == "period" else [model.period_s, fd[1]]

    a, b = _halves(aps)
    before = _periodic_rms(aps, [model.period_s])
    after = _periodic_rms(aps, periods_of(found))
    ho_before = np.mean([_periodic_rms(h, [model.period_s]) for h in (a, b)])
    ho_after = np.mean([_periodic_rms(test, periods_of(_detect_period(fit, model))) for fit, test in ((a, b), (b, a))])
    gain = {
        "before": before,
        "after": after,
        "held_out_before": float(ho_before),
        "held_out_after": float(ho_after),
        "unit": "m (RMS of WAAS - INS not explained by the cyclic model)",
    }
    resolution = period**2 * (1.0 / 40.0)  # one bin of a 40-s-resolution periodogram, in period
    if kind == "period":
        cause = (
            f"The WAAS cyclic noise repeats every {period:.1f} s, not the model's {model.period_s:g} s: the fast "
            f"corrections arrive every {period / 2:.1f} s."
        )
        if model.period_s % round(period) == 0:
            cause += (
                f" The FITS filter with T = {model.period_s:g} already removes it (a harmonic of its period); the "
                "simulation's WAAS sensor model is what must change."
            )
    else:
        cause = (
            f"Besides the {main:.1f} s cycle the WAAS noise has a second period of {period:.1f} s (another "
            "correction stream); a FITS filter with one period leaves it in the position."
        )
    return Finding(
        "cyclic_period" if kind == "period" else "second_cyclic_period",
        cause,
        {"period_s": {"value": float(period), "se": float(resolution)}},
        {
            "power_ratio": float(ratio),
            "model_period_s": model.period_s,
            "peak_period_s": float(main),
            "score": float(np.log10(ratio)),
        },
        gain,
    )


def _offset_effect(aps: list[_Approach], model: FitsModel) -> Finding | None:
    means = []
    for ap in aps:
        r = _fits(ap, model.period_s)
        d = (ap.dgps_w - np.asarray(model.dgps_offset_m)) - r.xyz_m
        d = d[np.isfinite(d).all(axis=1)]
        if len(d):
            means.append(d.mean(axis=0))
    if len(means) < 4:
        return None
    m = np.array(means)
    mu, se = m.mean(axis=0), m.std(axis=0, ddof=1) / math.sqrt(len(m))
    z = np.abs(mu[1:]) / np.maximum(se[1:], 1e-9)
    if not ((z > 4.0) & (np.abs(mu[1:]) > 0.1)).any():
        return None
    a, b = _halves(aps)
    off = {}
    for fit, test in ((a, b), (b, a)):
        mm = np.mean(
            [
                ((ap.dgps_w - np.asarray(model.dgps_offset_m)) - _fits(ap, model.period_s).xyz_m)[
                    np.isfinite(ap.dgps_w).all(axis=1)
                ].mean(axis=0)
                for ap in fit
            ],
            axis=0,
        )
        mm[0] = 0.0
        off[id(test)] = mm
    before = np.mean([_err_rms(h, model.period_s, model.dgps_offset_m) for h in (a, b)])
    held = np.mean([_err_rms(h, model.period_s, np.asarray(model.dgps_offset_m) + off[id(h)]) for h in (a, b)])
    mu_all = np.array([0.0, mu[1], mu[2]])
    after = _err_rms(aps, model.period_s, np.asarray(model.dgps_offset_m) + mu_all)
    return Finding(
        "dgps_offset",
        f"FITS minus DGPS holds a constant {mu[1]:+.2f} m cross-track and {mu[2]:+.2f} m vertical on every approach: "
        "the DGPS reference station's surveyed position is off by that much (a common radar-altimeter/TVPS bias "
        "would look the same; the along-track part is the pilot's mark and is not estimated).",
        {
            "offset_y_m": {"value": float(mu[1]), "se": float(se[1])},
            "offset_z_m": {"value": float(mu[2]), "se": float(se[2])},
        },
        {"z": [float(v) for v in z], "approaches": len(m), "score": float(np.log10(max(z.max(), 1.0)) + 1.0)},
        {"before": before, "after": after, "held_out_before": before, "held_out_after": held, "unit": "m"},
    )


TVPS_MIN_SPREAD_M = 0.5  # sd of the approaches' threshold readings below which a TVPS scale is an offset
TVPS_MIN_EFFECT_M = 0.1  # a scale moving the FITS less at the approaches' readings (RMS) is not worth a finding


def _tvps_fit(aps: list[_Approach], model: FitsModel, min_approaches: int = 6):
    """(slope s, its standard error, the readings y_i) of the regression
    across approaches of the mean cross-track FITS - DGPS on the TVPS reading that fixed the
    bias (the mean within the fix window, as eq. 18 takes it). A TVPS reading k x the
    camera's position leaves the FITS (k - 1) y_true = (1 - 1/k) y off cross-track for the
    whole approach (eq. 18-19), so s = 1 - 1/k: 2 for the opposite sign, 0 when k = 1.
    None with fewer approaches than `min_approaches` or readings spread less than
    TVPS_MIN_SPREAD_M (then a scale cannot be told from an offset)."""
    spec = FitsSpec(period_s=model.period_s)
    ys, es = [], []
    for ap in aps:
        near = (np.abs(ap.t_rows - (ap.t_mark - spec.event_delay_s)) <= spec.fix_window_s) & np.isfinite(ap.tvps)
        r = _fits(ap, model.period_s)
        d = r.xyz_m[:, 1] - (ap.dgps_w[:, 1] - model.dgps_offset_m[1])
        d = d[np.isfinite(d)]
        if near.any() and len(d):
            ys.append(float(np.mean(ap.tvps[near])))
            es.append(float(np.mean(d)))
    y, e = np.array(ys), np.array(es)
    if len(y) < min_approaches or np.std(y, ddof=1) < TVPS_MIN_SPREAD_M:
        return None
    fit = stats.linregress(y, e)
    return float(fit.slope), float(fit.stderr), y


def _rescaled(ap: _Approach, k: float) -> _Approach:
    return dataclasses.replace(ap, tvps=ap.tvps / k)


def _tvps_effect(aps: list[_Approach], model: FitsModel) -> Finding | None:
    got = _tvps_fit(aps, model)
    if got is None:
        return None
    s, se, y = got
    if not (abs(s) > 4.0 * se and abs(s) * math.sqrt(np.mean(y**2)) > TVPS_MIN_EFFECT_M) or abs(1.0 - s) < 1e-6:
        return None
    k = 1.0 / (1.0 - s)
    held = []
    for fit, test in zip(_halves(aps), _halves(aps)[::-1], strict=False):
        g = _tvps_fit(fit, model, min_approaches=3)
        k_fit = 1.0 / (1.0 - g[0]) if g is not None and abs(1.0 - g[0]) > 1e-6 else 1.0
        held.append(
            (
                _err_rms(test, model.period_s, model.dgps_offset_m),
                _err_rms([_rescaled(ap, k_fit) for ap in test], model.period_s, model.dgps_offset_m),
            )
        )
    what = (
        "has the opposite sign to the runway frame's y (positive left of the centreline)"
        if k < 0
        else f"is {k:.3g}x the camera's cross-track position (its scale: focal length, pixel size)"
    )
    return Finding(
        "tvps_scale",
        f"The TVPS cross-track reading {what}: across the approaches, FITS minus DGPS cross-track follows the "
        f"TVPS reading at the threshold with slope {s:+.2f} (1 - 1/k), since eq. 18 fixes the cross-track bias "
        f"on that reading. Dividing `tvps_y_m` by {k:.3g} removes it. A common DGPS or TVPS offset is the "
        "intercept, not this slope.",
        {"tvps_scale": {"value": k, "se": se / (1.0 - s) ** 2}, "slope": {"value": s, "se": se}},
        {
            "z": abs(s) / se,
            "approaches": len(y),
            "threshold_y_sd_m": float(np.std(y, ddof=1)),
            "score": float(np.log10(max(abs(s) / se, 1.0)) + 1.0),
        },
        {
            "before": _err_rms(aps, model.period_s, model.dgps_offset_m),
            "after": _err_rms([_rescaled(ap, k) for ap in aps], model.period_s, model.dgps_offset_m),
            "held_out_before": float(np.mean([h[0] for h in held])),
            "held_out_after": float(np.mean([h[1] for h in held])),
            "unit": "m",
        },
    )


LATENCY_MIN_S = 0.02  # smaller latencies move the FITS by < 7 cm on a 3-deg glide path: not worth a finding


def _latency_fit(aps: list[_Approach], model: FitsModel) -> tuple[float, float, int]:
    """(tau, its standard error, approaches) of a WAAS time tag late by tau: FITS - DGPS
    = -tau (v - v_thr) cross-track and vertical (v the DGPS velocity; the threshold's part
    is a constant of each approach, removed with the approach's mean), least squares
    pooled over approaches and both axes, the standard error from the approaches'
    scores (clustered by approach)."""
    num = den = 0.0
    parts = []
    for ap in aps:
        r = _fits(ap, model.period_s)
        e = (r.xyz_m - (ap.dgps_w - np.asarray(model.dgps_offset_m)))[:, 1:]
        v = (at_times(ap.t_rows, ap.dgps_rows, ap.t_w + 0.5) - at_times(ap.t_rows, ap.dgps_rows, ap.t_w - 0.5))[
            :, 1:
        ]  # m/s
        ok = np.isfinite(e).all(axis=1) & np.isfinite(v).all(axis=1)
        if ok.sum() < 30:
            continue
        e, v = e[ok] - e[ok].mean(axis=0), v[ok] - v[ok].mean(axis=0)
        parts.append((e, v))
        num += float(np.sum(v * e))
        den += float(np.sum(v * v))
    if len(parts) < 3 or den <= 0:
        return 0.0, math.inf, len(parts)
    slope = num / den
    score = np.concatenate([np.sum(v * (e - slope * v), axis=1) for e, v in parts])
    approach = np.repeat(np.arange(len(parts)), [len(e) for e, _ in parts])
    se, g = clustered_se(score, approach, den)
    return -slope, se, g


def _latency_effect(aps: list[_Approach], model: FitsModel) -> Finding | None:
    tau, se, n = _latency_fit(aps, model)
    if not (abs(tau) > 4.0 * se and abs(tau) >= LATENCY_MIN_S):
        return None
    a, b = _halves(aps)
    held = []
    for fit, test in ((a, b), (b, a)):
        t_fit = _latency_fit(fit, model)[0]
        held.append(
            (
                _err_rms(test, model.period_s, model.dgps_offset_m),
                _err_rms([retagged(ap, t_fit) for ap in test], model.period_s, model.dgps_offset_m),
            )
        )
    before = _err_rms(aps, model.period_s, model.dgps_offset_m)
    after = _err_rms([retagged(ap, tau) for ap in aps], model.period_s, model.dgps_offset_m)
    return Finding(
        "waas_latency",
        f"The WAAS positions are stamped {1000 * tau:.0f} ms late against the log's time base (RA, TVPS, DGPS): "
        "FITS minus DGPS follows the aircraft's velocity (minus its value at the threshold fix), cross-track and "
        "vertically, which the FITS paper's eq. 3 assumes away. Re-tagging the WAAS epochs (`aerotruth fits "
        f"--waas-latency {tau:.2f}`) removes it. A DGPS stamped that early would look the same.",
        {"latency_s": {"value": tau, "se": se}},
        {"z": abs(tau) / se, "approaches": n, "score": float(np.log10(max(abs(tau) / se, 1.0)) + 1.0)},
        {
            "before": before,
            "after": after,
            "held_out_before": float(np.mean([h[0] for h in held])),
            "held_out_after": float(np.mean([h[1] for h in held])),
            "unit": "m",
        },
    )


def _jump_effects(aps: list[_Approach], model: FitsModel) -> list[Finding]:
    out = []
    for ap in aps:
        r = _fits(ap, model.period_s)
        b = ap.waas - r.noiseless.n_hat - ap.dgps_w  # the bias, slow noise and any unflagged step
        ok = np.isfinite(b).all(axis=1)
        if ok.sum() < 4 * STEP_WINDOW:
            continue
        bb = b[ok]
        n = len(bb)
        sig = (
            1.4826
            * np.median(np.abs(np.diff(bb, axis=0) - np.median(np.diff(bb, axis=0), axis=0)), axis=0)
            / math.sqrt(2)
        )
        cs = np.vstack([np.zeros(3), np.cumsum(bb, axis=0)])
        k = np.arange(STEP_WINDOW, n - STEP_WINDOW)
        after = (cs[k + STEP_WINDOW] - cs[k]) / STEP_WINDOW
        before = (cs[k] - cs[k - STEP_WINDOW]) / STEP_WINDOW
        step = after - before
        score = np.sqrt(np.sum((step / (np.maximum(sig, 1e-3) * math.sqrt(2.0 / STEP_WINDOW))) ** 2, axis=1))
        # windows that hold a flagged epoch see that (known) jump: not evidence of another
        # (on aerotruth's own logs a flagged 1.3-m jump read as an unflagged 0.8-m step 11 s
        # before it)
        cf = np.r_[0, np.cumsum(ap.flags[ok] > 0)]
        score = np.where(cf[k + STEP_WINDOW] - cf[k - STEP_WINDOW] > 0, 0.0, score)
        i = int(np.argmax(score))
        mag = float(np.linalg.norm(step[i]))
        epoch = int(np.flatnonzero(ok)[k[i]])
        if score[i] < 8.0 * math.sqrt(3) or mag < 0.5 or ap.flags[max(epoch - 2, 0) : epoch + 3].any():
            continue
        flags = np.zeros(len(ap.t_w), np.int8)
        flags[epoch] = 1
        before_rms = _err_rms([ap], model.period_s)
        after_rms = _err_rms([ap], model.period_s, flags={ap.name: flags})
        out.append(
            Finding(
                "waas_jump",
                f"Approach {ap.name}: the WAAS bias steps by {mag:.2f} m at t = {ap.t_w[epoch]:.0f} s without a "
                "satellite-set or ionosphere flag from the receiver; the FITS carries it into every position after it. "
                "Flagging the epoch lets the FITS compensate it (section IV-C).",
                {
                    "step_m": {"value": mag, "se": float(np.linalg.norm(sig) * math.sqrt(2.0 / STEP_WINDOW))},
                    "time_s": {"value": float(ap.t_w[epoch]), "se": 1.0},
                },
                {"score_sigma": float(score[i]), "approach": str(ap.name), "score": float(np.log10(score[i]))},
                {
                    "before": before_rms,
                    "after": after_rms,
                    "held_out_before": before_rms,
                    "held_out_after": after_rms,
                    "unit": "m",
                    "note": "a single event: measured on its own approach",
                },
            )
        )
    return out


def _drift_biases(t_w: np.ndarray, d: np.ndarray) -> list[float]:
    """Accelerometer biases (m/s^2) from an INS - DGPS drift (n, 3): twice the t^2
    coefficient of a quadratic (vertical) or cubic (horizontal, the gyro's t^3 too)."""
    ok = np.isfinite(d).all(axis=1)
    if ok.sum() < 60:
        return []
    t = t_w[ok] - t_w[ok][0]
    return [2.0 * np.polyfit(t, d[ok, ax], 3 if ax < 2 else 2)[-3] for ax in range(3)]


def _ins_bias_effect(aps: list[_Approach], model: FitsModel, rng_seed: int = 0) -> Finding | None:
    """The INS drift against the grade: the estimator's spread under the model (grade
    biases and noise through the same fit) comes from simulating the grade's eq. 4 errors
    on each approach's epochs (aerotruth.sensors.inertial_errors)."""
    from aerotruth.sensors.inertial_errors import InertialErrors, InertialErrorSpec

    sigma = model.accel_bias_ug * MICRO_G
    rng = np.random.default_rng(rng_seed)
    est, null = [], []
    for ap in aps:
        b_ap = _drift_biases(ap.t_w, ap.ins_w - ap.dgps_w)
        if not b_ap:
            continue
        est.append(b_ap)
        for _ in range(10):  # the model's own estimator spread on these epochs
            null.append(
                _drift_biases(
                    ap.t_w, InertialErrors.draw(InertialErrorSpec(grade=model.grade), rng, ap.t_w).error_ned_m
                )
            )
    if len(est) < 3:
        return None
    b = np.asarray(est).ravel()
    v0 = float(np.mean(np.asarray(null).ravel() ** 2))  # E[b_hat^2] under the model
    chi2 = float(np.sum(b**2) / v0)
    p = float(stats.chi2.sf(chi2, len(b)))
    noise2 = max(v0 - sigma**2, 0.0)
    k = float(np.sqrt(max(np.mean(b**2) - noise2, 0.0)) / sigma)
    if p > 1e-3 or k < 1.5:
        return None
    half = len(b) // 2
    fit, test = b[:half], b[half:]
    k_fit = float(np.sqrt(max(np.mean(fit**2) - noise2, 0.0)) / sigma)

    def nll(x, s2):
        return float(np.mean(0.5 * x**2 / s2 + 0.5 * np.log(s2)))

    return Finding(
        "ins_bias",
        f"The INS drifts {k:.1f} times faster than its grade allows: accelerometer biases of "
        f"{k * model.accel_bias_ug:.0f} ug RMS against the model's {model.accel_bias_ug:g} ug (from the INS minus "
        "DGPS drift over each approach, net of what the grade's own noise puts into that estimate).",
        {"bias_scale": {"value": k, "se": k / math.sqrt(2 * len(b))}},
        {"chi2": chi2, "dof": len(b), "p": p, "score": float(min(-math.log10(max(p, 1e-300)), 300.0) / 10.0)},
        {
            "before": nll(b, v0),
            "after": nll(b, k**2 * sigma**2 + noise2),
            "held_out_before": nll(test, v0),
            "held_out_after": nll(test, k_fit**2 * sigma**2 + noise2),
            "unit": "negative log-likelihood per bias (nats)",
        },
    )


def _baro_psd_model(f: np.ndarray, model: FitsModel, tau: float) -> np.ndarray:
    """One-sided PSD (m^2/Hz) of the barometer error through the loop with time constant tau."""
    s = 2j * np.pi * f
    p = 1.0 / tau
    h = (3 * p * s**2 + 3 * p**2 * s + p**3) / (s + p) ** 3
    gm = 4.0 * model.baro_gm_sigma_m**2 * model.baro_gm_tau_s / (1.0 + (2 * np.pi * f * model.baro_gm_tau_s) ** 2)
    white = 2.0 * model.baro_white_sigma_m**2 * 1.0  # a new reading each 1-s epoch: white at the 1 Hz epochs
    return np.abs(h) ** 2 * (gm + white)


_BARO_GRID = np.linspace(1.0 / 40.0, 1.0 / 5.0, 120)  # periods well inside a 6-min record
_TAUS = np.geomspace(3.0, 300.0, 121)


def _baro_periodogram(aps: list[_Approach]) -> np.ndarray | None:
    acc = []
    for ap in aps:
        d = ap.ins_w[:, 2] - ap.dgps_w[:, 2]
        ok = np.isfinite(d)
        if ok.sum() < 128:
            continue
        # first differences and a Hann window: the height error's spectrum falls by four
        # decades over the band, and a short record's leakage would otherwise fill the top
        f, p = signal.periodogram(np.diff(d[ok]), fs=1.0, window="hann", detrend="constant")
        acc.append(np.interp(_BARO_GRID, f, p))
    return np.mean(acc, axis=0) if acc else None


_FLOORS = np.r_[0.0, np.geomspace(1e-6, 1e-1, 41)]  # m^2/Hz: the DGPS and INS white noise, a nuisance


def _baro_misfit(pm: np.ndarray, model: FitsModel, tau: float) -> float:
    """Mean squared log-PSD misfit at loop time constant tau, the white floor (DGPS noise)
    chosen freely."""
    diff = (2.0 * np.sin(np.pi * _BARO_GRID)) ** 2  # the first difference's gain at 1 Hz
    base = _baro_psd_model(_BARO_GRID, model, tau)
    return float(min(np.mean((np.log(pm) - np.log((base + fl) * diff)) ** 2) for fl in _FLOORS))


def _baro_fit(pm: np.ndarray, model: FitsModel) -> float:
    return float(_TAUS[int(np.argmin([_baro_misfit(pm, model, tau) for tau in _TAUS]))])


def _baro_effect(aps: list[_Approach], model: FitsModel) -> Finding | None:
    if model.vertical != "baro":
        return None
    pm = _baro_periodogram(aps)
    if pm is None:
        return None
    tau = _baro_fit(pm, model)
    m0, m1 = _baro_misfit(pm, model, model.baro_loop_tau_s), _baro_misfit(pm, model, tau)
    ratio = tau / model.baro_loop_tau_s
    if 0.7 <= ratio <= 1.4 or m1 > 0.5 * m0:
        return None
    a, b = _halves(aps)
    held = []
    for fit, test in ((a, b), (b, a)):
        pf, pt = _baro_periodogram(fit), _baro_periodogram(test)
        if pf is None or pt is None:
            continue
        held.append((_baro_misfit(pt, model, model.baro_loop_tau_s), _baro_misfit(pt, model, _baro_fit(pf, model))))
    hb, ha = (float(np.mean([h[0] for h in held])), float(np.mean([h[1] for h in held]))) if held else (m0, m1)
    i = int(np.argmin(np.abs(_TAUS - tau)))
    step = float(_TAUS[min(i + 1, len(_TAUS) - 1)] - _TAUS[max(i - 1, 0)]) / 2.0
    return Finding(
        "baro_coupling",
        f"The INS height follows its barometer through a loop of time constant {tau:.0f} s, not the model's "
        f"{model.baro_loop_tau_s:g} s: its bandwidth is {1.0 / ratio:.1f}x the model's, so more barometer noise "
        "reaches the vertical channel (and the FITS's vertical cyclic-noise estimate).",
        {"loop_tau_s": {"value": tau, "se": step}},
        {"misfit_model": m0, "misfit_fitted": m1, "score": float(np.log10(m0 / max(m1, 1e-9)) + 1.0)},
        {
            "before": m0,
            "after": m1,
            "held_out_before": hb,
            "held_out_after": ha,
            "unit": "mean squared log-PSD misfit of INS - DGPS height",
        },
    )


def diagnose_log(path, df: pd.DataFrame, model: FitsModel) -> tuple[list[Finding], dict]:
    """Ranked findings (strongest first) and the baseline of an approach log."""
    aps = checked_approaches(path, df)
    dgps = all(a.dgps_w is not None and np.isfinite(a.dgps_w).any() for a in aps)
    findings: list[Finding] = []
    fr = _frame_effect(aps)
    if fr is not None:  # the rest on the INS in the runway frame (else the motion reads as WAAS noise)
        findings.append(fr)
        aps = [ins_frame.in_frame(ap, np.asarray(fr.evidence["frame"])) for ap in aps]
    f = _period_effect(aps, model)
    period = model.period_s
    if f is not None:
        findings.append(f)
        if f.effect == "cyclic_period":
            period = float(round(f.parameters["period_s"]["value"]))
    baseline: dict[str, int | bool | float] = {"approaches": len(aps), "dgps": dgps}
    if dgps:
        baseline["fits_minus_dgps_rms_m"] = _err_rms(aps, model.period_s, model.dgps_offset_m)
        m2 = dataclasses.replace(model, period_s=period)
        found = _dgps_effects(aps, m2)
        jumps = [g for g in found if g.effect == "waas_jump"]
        if jumps:
            # the other effects again with the steps flagged: before an unflagged step each
            # approach's FITS is off by it (the bias is fixed at the threshold, after it), which
            # the tests before the scan read as a station offset and, the steps coming in the
            # descent, as a latency, when the steps agree across approaches
            # (validation/diagnose_fits_confusion_plan.md); the scan then looks for more steps
            found = _dgps_effects(_steps_flagged(aps, jumps), m2) + jumps
        findings += found
    findings.sort(key=lambda x: -x.evidence.get("score", 0.0))
    return findings, baseline


def _dgps_effects(aps: list[_Approach], model: FitsModel) -> list[Finding]:
    """The effects a DGPS reference shows, each tested on the inputs the ones before it
    corrected: latency, TVPS scale, then the station offset, the INS bias, the barometer
    coupling and the unflagged steps."""
    out = []
    lat = _latency_effect(aps, model)
    if lat is not None:  # the other effects on the re-tagged epochs (else the latency reads as jumps and an offset)
        out.append(lat)
        aps = [retagged(ap, lat.parameters["latency_s"]["value"]) for ap in aps]
    tv = _tvps_effect(aps, model)
    if tv is not None:  # the offset and the rest on rescaled readings (else the scale reads as an offset)
        out.append(tv)
        aps = [_rescaled(ap, tv.parameters["tvps_scale"]["value"]) for ap in aps]
    out += [g for g in (_offset_effect(aps, model), _ins_bias_effect(aps, model), _baro_effect(aps, model)) if g]
    return out + _jump_effects(aps, model)


def _steps_flagged(aps: list[_Approach], jumps: list[Finding]) -> list[_Approach]:
    """The approaches with the WAAS epoch of each step found flagged, as a receiver flags a
    satellite-set change (the FITS then carries no step across it; section IV-C)."""
    at: dict[str, list[float]] = {}
    for j in jumps:
        at.setdefault(j.evidence["approach"], []).append(j.parameters["time_s"]["value"])
    out = []
    for ap in aps:
        times = at.get(str(ap.name), [])
        if times:
            flags = ap.flags.copy()
            for t in times:  # the nearest epoch: a step found on re-tagged epochs is within the latency of its own
                flags[int(np.argmin(np.abs(ap.t_w - t)))] = 1
            ap = dataclasses.replace(ap, flags=flags)
        out.append(ap)
    return out
