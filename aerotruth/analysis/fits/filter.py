"""The WAAS-aided flight-inspection truth system (FITS paper section IV, eqs. 3 and 7-19).

Per axis, on the WAAS epochs n (uniform spacing dt, T = cyclic period / dt samples; 1 Hz
and 12 s give T = 12):

    dz[n]  = z_waas[n] - z_ins[n] = N_w + B_w - B_i - x + eta_w             # eq. 3
    h[k]   = (T - |k|) / T^2,  |k| <= T,   sum h = 1                          # eq. 7
    y      = h * dz                                                           # eq. 8 / 13
    e      = dz - y                                                           # eq. 9 / 14
    V      = h * e                                                            # eq. 10 / 15
    N_hat  = e - V = (delta - h) * (delta - h) * dz                           # eq. 11 / 16
    z_nl   = z_waas - N_hat                                                   # eq. 17
    B_hat  = [z_nl - z_RA/TVPS] at the threshold                              # eq. 18
    z_true = z_nl - B_hat                                                     # eq. 19

Closed forms (derived here; checked in tests/test_fits_filter.py). h is the triangle =
the convolution of two length-T boxcars / T^2, so its even moments are m0 = 1,
m2 = sum h k^2 = (T^2 - 1) / 6 and its odd moments vanish. For a drift x(n) with
x'''' = 0, h * x = x + (m2 / 2) x'' exactly, hence

    vertical, x = x0 + v0 n + beta n^2 / 2:        y = -x - (T^2 - 1)/12 beta
    horizontal, x = ... + eps n^3 / 6:              y = -x - (T^2 - 1)/12 (beta + eps n)

The paper's "143/T" is (T^2 - 1)/12 at T = 12 only (143/12 = 11.917; at T = 10 the
coefficient is 8.25, not 14.3). The paper's "4 eps" in eq. 13 holds for no T: the cubic
leaves only the linear term (T^2 - 1)/12 eps n (the "nearly linear function of time"
the paper mentions), no constant. The leftover in e is then linear in n, which the
symmetric h passes unchanged, so V removes it and N_hat carries no drift at all: the
high pass G = (delta - h)^2 annihilates every polynomial up to degree 3. Its frequency
response is G(f) = (1 - F(f))^2 with the Fejer kernel F(f) = sin^2(pi f T dt) /
(T^2 sin^2(pi f dt)): G(0) = 0, and G = 1 at f = m / (T dt), m = 1 .. T - 1 (every
harmonic of the 12 s cycle, so a stepped fast-correction wave passes whole).

Noise floor: white noise (sigma_w) and a first-order Gauss-Markov part (sigma_g,
rho = exp(-dt/tau)) in the WAAS leak through G into N_hat with variance
sigma_w^2 sum g_k^2 + sigma_g^2 sum_jk g_j g_k rho^|j-k| (`noise_floor_rms`).

Edge treatment: G needs 2T samples on either side. The record is extended by 2T samples
at each end with a least-squares model of dz fitted to the first (last) `edge_fit_periods`
x T samples: a cubic (the drift class above) plus a zero-mean T-periodic sequence
(harmonics 1 .. T/2 of the cycle, T - 1 coefficients). Where dz is exactly such a model
the output is exact at the edges too; within 2T of an end it otherwise carries the model
misfit (amplitude change of the cycle, noise). Approaches should therefore extend 2T
past the threshold (the data flown beyond it).

Jumps (section IV-C): at an epoch flagged by the receiver (satellite-set change or iono
update) the step of dz is estimated by least squares on the +-2T epochs around it with
the same local model (cubic + T-periodic) plus a step; dz = WAAS - INS carries the
aircraft's motion across the jump by the INS (its smooth short-term velocity), so only
the WAAS step remains. The WAAS positions from that epoch on are shifted back by the step,
so the whole approach refers to one bias, the one fixed at the threshold. An unflagged
jump is not compensated.

Threshold fix (eq. 18): positions between WAAS epochs are carried by the INS (the
WAAS - INS correction interpolated linearly, plus the INS position). The threshold time
is the event mark minus the mean pilot reaction (a log's legacy numeric mark lands on
the first row after the press: the log reader takes half a row off). Along-track:
B_x = x_nl(t_threshold) (the threshold is x = 0). Vertical: the mean of z_nl - (h_RA + RA
lever arm) over the radar-altimeter readings within `fix_window_s` of the threshold time
(runway surface flat at z = 0). Cross-track: the mean of y_nl - y_TVPS over the TVPS
readings in the same window, or none (`cross_track_fix: none`, the paper's flight test:
the WAAS's own cross-track bias stays).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view
from pydantic import Field

from aerotruth.schema import Section


class FitsSpec(Section):
    """FITS filter settings (FITS paper section IV)."""

    period_s: float = Field(default=12.0, gt=0, description="cyclic-noise period (2 x 6 s fast corrections, Fig. 6)")
    edge_fit_periods: int = Field(default=4, ge=2, description="edge model fitted over this many periods at each end")
    jump_window_periods: int = Field(default=2, ge=1, description="jump steps fitted over +- this many periods")
    fix_window_s: float = Field(
        default=3.0, gt=0, description="RA/TVPS readings within this time of the threshold fix the bias"
    )
    event_delay_s: float = Field(
        default=0.2, ge=0, description="mean delay of the pilot's event mark after the crossing"
    )
    ra_lever_arm_m: float = Field(
        default=0.0,
        ge=-10.0,
        le=10.0,
        description="height of the position reference point above the RA antenna (m): within an airframe's height",
    )
    grid_rate_hz: float = Field(default=8.0, gt=0, description="output grid (FITS paper section V: 8 Hz)")
    cross_track_fix: Literal["tvps", "none"] = Field(
        default="tvps",
        description="fix the cross-track bias from the TVPS at the threshold (eq. 18), or leave the "
        "WAAS's own (none: FITS paper section V's flight test, where the TVPS was not accurate "
        "enough, and Figs. 19/20)",
    )
    waas_latency_s: float = Field(
        default=0.0,
        ge=-2.0,
        le=2.0,
        description="WAAS positions stamped this late (s): the "
        "receiver's output latency left in its time tags; the FITS puts each epoch at its time "
        "minus this (FITS paper eq. 3 assumes the WAAS - INS delay insignificant)",
    )


DEFAULT_SPEC = FitsSpec()  # the default settings (FitsSpec is frozen: one shared instance is safe)


def triangular_lowpass(T: int) -> np.ndarray:
    """Taps h[k], k = -T .. T, of the triangular low pass (FITS paper eq. 7); sum = 1."""
    if int(T) != T or T < 1:
        raise ValueError(f"T: expected a positive integer number of samples, got {T!r}")
    k = np.arange(-T, T + 1)
    return (T - np.abs(k)) / float(T) ** 2  # FITS paper eq. 7


def highpass_taps(T: int) -> np.ndarray:
    """Taps g of the whole cyclic-noise high pass (delta - h) * (delta - h), k = -2T .. 2T."""
    h = triangular_lowpass(T)
    d = -h
    d[T] += 1.0
    return np.convolve(d, d)


def _fir(x: np.ndarray, taps: np.ndarray) -> np.ndarray:
    """Symmetric FIR along axis 0, 'valid' part (len(x) - len(taps) + 1 samples)."""
    return sliding_window_view(x, len(taps), axis=0) @ taps


def _local_basis(j: np.ndarray, T: int, scale: float) -> np.ndarray:
    """Columns: cubic in j/scale, then the zero-mean T-periodic sequences (T - 1 columns)."""
    s = j / scale
    cols = [np.ones_like(s), s, s**2, s**3]
    for m in range(1, (T - 1) // 2 + 1):
        cols += [np.cos(2 * np.pi * m * j / T), np.sin(2 * np.pi * m * j / T)]
    if T % 2 == 0:
        cols.append(np.cos(np.pi * j))
    return np.column_stack(cols)


def edge_extension(dz: np.ndarray, T: int, fit_samples: int) -> np.ndarray:
    """dz extended by 2T samples at each end with the local cubic + T-periodic model
    fitted to `fit_samples` samples at that end (see the module docstring)."""
    n = len(dz)
    w = min(fit_samples, n)
    j_fit = np.arange(w, dtype=float)
    j_out = np.arange(-2 * T, 0, dtype=float)
    a_fit, a_out = _local_basis(j_fit, T, w), _local_basis(j_out, T, w)
    head = a_out @ np.linalg.lstsq(a_fit, dz[:w], rcond=None)[0]
    # the tail: the same, counted backwards from the last sample
    tail = a_out @ np.linalg.lstsq(a_fit, dz[::-1][:w], rcond=None)[0]
    return np.concatenate([head, dz, tail[::-1]])


@dataclass(frozen=True)
class CyclicNoiseStages:
    """The intermediate signals of the high-pass block (FITS paper Fig. 10), per epoch."""

    y: np.ndarray  # eq. 8 / 13
    e: np.ndarray  # eq. 9 / 14
    v: np.ndarray  # eq. 10 / 15
    n_hat: np.ndarray  # eq. 11 / 16


def cyclic_noise(dz, T: int = 12, edge_fit_periods: int = 4) -> CyclicNoiseStages:
    """Estimate the cyclic noise in dz = WAAS - INS ((n,) or (n, 3), uniform epochs);
    the same structure serves the vertical (eqs. 8-11) and horizontal (eqs. 13-16)."""
    dz = np.asarray(dz, dtype=float)
    h = triangular_lowpass(T)
    if len(dz) < 4 * T:
        raise ValueError(f"dz: expected at least 4T = {4 * T} epochs, got {len(dz)}")
    ext = edge_extension(dz, T, edge_fit_periods * T)  # n + 4T
    y = _fir(ext, h)  # eq. 8 / 13, aligned with ext[T:-T]
    e = ext[T:-T] - y  # eq. 9 / 14
    v = _fir(e, h)  # eq. 10 / 15, aligned with dz
    n_hat = e[T:-T] - v  # eq. 11 / 16
    return CyclicNoiseStages(y[T:-T], e[T:-T], v, n_hat)


def frequency_response(T: int = 12, f_hz=None, dt_s: float = 1.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(f, H_lowpass, H_highpass) of eq. 7 and of the cascade eqs. 8-11, evaluated from the
    filter taps (zero phase, so real): FITS paper Figs. 11 and 12 (drawn by the fits study)."""
    f = np.linspace(0.0, 0.5 / dt_s, 1201) if f_hz is None else np.asarray(f_hz, dtype=float)
    h, g = triangular_lowpass(T), highpass_taps(T)
    k_h, k_g = np.arange(-T, T + 1), np.arange(-2 * T, 2 * T + 1)
    lp = np.cos(2 * np.pi * np.outer(f * dt_s, k_h)) @ h  # symmetric taps: the sine parts cancel
    hp = np.cos(2 * np.pi * np.outer(f * dt_s, k_g)) @ g
    return f, lp, hp


def noise_floor_rms(T: int, white_sigma_m: float, gm_sigma_m: float, gm_tau_s: float, dt_s: float = 1.0) -> float:
    """RMS of white + first-order Gauss-Markov WAAS noise after the high pass: the floor
    of the cyclic-noise residual (module docstring)."""
    g = highpass_taps(T)
    k = np.arange(len(g))
    rho = np.exp(-dt_s / gm_tau_s)
    corr = rho ** np.abs(k[:, None] - k[None, :])
    return float(np.sqrt(white_sigma_m**2 * g @ g + gm_sigma_m**2 * g @ corr @ g))


def estimate_jumps(dz: np.ndarray, flag_idx, T: int, window_periods: int = 2) -> np.ndarray:
    """Steps of dz (n, 3) at the flagged epochs (FITS paper section IV-C), each fitted on
    +- window_periods x T epochs with a local cubic + T-periodic model; epochs after an
    earlier step are corrected before the next is fitted. Returns (len(flag_idx), 3)."""
    dz = np.array(dz, dtype=float)
    idx = np.asarray(flag_idx, dtype=int)
    n, half = len(dz), window_periods * T
    steps = np.zeros((len(idx), dz.shape[1]))
    for i, k in enumerate(idx):  # few jumps per approach; each depends on the last
        hi = min(n, k + half, idx[i + 1] if i + 1 < len(idx) else n)
        lo = max(0, k - half)
        j = np.arange(lo, hi, dtype=float) - k
        a = np.column_stack([_local_basis(j, T, half), (j >= 0).astype(float)])
        if hi - lo < a.shape[1] + 4:  # too short for the full model: a local line and the step
            a = np.column_stack([np.ones_like(j), j, (j >= 0).astype(float)])
        steps[i] = np.linalg.lstsq(a, dz[lo:hi], rcond=None)[0][-1]
        dz[k:] -= steps[i]
    return steps


def interp_rows(tq, t, values: np.ndarray) -> np.ndarray:
    """Linear interpolation of the rows of `values` (n, m) at times tq (held at the ends)."""
    tq = np.asarray(tq, dtype=float)
    i = np.clip(np.searchsorted(t, tq, side="right") - 1, 0, len(t) - 2)
    a = np.clip((tq - t[i]) / (t[i + 1] - t[i]), 0.0, 1.0)[:, None]
    return (1.0 - a) * values[i] + a * values[i + 1]


def carry_with_ins(tq, t_w, p_w, t_ins, ins_xyz) -> np.ndarray:
    """Positions at times tq from positions p_w at the WAAS epochs t_w: the INS position
    plus the WAAS - INS correction interpolated between epochs."""
    corr = p_w - interp_rows(t_w, t_ins, ins_xyz)
    return interp_rows(tq, t_ins, ins_xyz) + interp_rows(tq, t_w, corr)


def _cumulative_steps(n: int, idx: np.ndarray, steps: np.ndarray) -> np.ndarray:
    """(n, 3): the steps at epochs `idx` summed up to each epoch."""
    shift = np.zeros((n, 3))
    np.add.at(shift, idx, steps)
    return np.cumsum(shift, axis=0)


@dataclass(frozen=True)
class Noiseless:
    """Eqs. 3, 8-17 with jump compensation, on the WAAS epochs."""

    t_s: np.ndarray
    jump_idx: np.ndarray  # flagged epochs
    jump_m: np.ndarray  # (k, 3) estimated steps
    n_hat: np.ndarray  # (n, 3) estimated cyclic noise
    noiseless: np.ndarray  # (n, 3) eq. 17, referred to the bias before the first jump

    def jump_shift(self) -> np.ndarray:
        """(n, 3) the estimated steps of the flagged jumps summed up to each epoch: what was
        taken off the WAAS positions to refer them to the bias before the first jump."""
        return _cumulative_steps(len(self.t_s), self.jump_idx, self.jump_m)

    def segment_index(self) -> np.ndarray:
        """(n,) the segment of each epoch: 0 before the first flagged jump, k after the k-th."""
        return np.searchsorted(self.jump_idx, np.arange(len(self.t_s)), side="right")


def period_samples(t_s: np.ndarray, period_s: float) -> int:
    """T: the cyclic period in WAAS epochs; refuses spacings that do not divide it."""
    dt = float(np.median(np.diff(t_s)))
    T = period_s / dt
    if abs(T - round(T)) > 1e-6 * T or round(T) < 2:
        raise ValueError(
            f"WAAS epochs every {dt:g} s: the cyclic period {period_s:g} s must be a whole number (>= 2) of epochs"
        )
    return int(round(T))


def waas_noiseless(t_s, waas_xyz, ins_xyz, jump_flags, spec: FitsSpec = DEFAULT_SPEC) -> Noiseless:
    """Noiseless WAAS (eq. 17) at the WAAS epochs, from WAAS and INS positions (n, 3) on
    the same epochs and the receiver's jump flags (n,) (sv_change or iono_update)."""
    t = np.asarray(t_s, dtype=float)
    waas, ins = np.asarray(waas_xyz, dtype=float), np.asarray(ins_xyz, dtype=float)
    dt = np.diff(t)
    if t.ndim != 1 or len(t) < 2 or not (np.all(dt > 0) and np.ptp(dt) <= 1e-6 * dt[0]):
        raise ValueError("WAAS epochs: expected increasing, uniformly spaced times")
    if waas.shape != (len(t), 3) or ins.shape != (len(t), 3):
        raise ValueError(f"waas_xyz, ins_xyz: expected shape ({len(t)}, 3), got {waas.shape} and {ins.shape}")
    T = period_samples(t, spec.period_s)
    if len(t) < 4 * T:
        raise ValueError(f"WAAS epochs: expected at least 4T = {4 * T} (the filter's 2T on each side), got {len(t)}")
    dz = waas - ins  # eq. 3
    flags = np.flatnonzero(np.asarray(jump_flags) > 0)
    flags = flags[flags > 0]  # a flag on the first epoch has nothing before it to refer to
    steps = estimate_jumps(dz, flags, T, spec.jump_window_periods)
    shift = _cumulative_steps(len(t), flags, steps)
    waas_c = waas - shift
    n_hat = cyclic_noise(dz - shift, T, spec.edge_fit_periods).n_hat
    return Noiseless(t, flags, steps, n_hat, waas_c - n_hat)  # eq. 17


def threshold_bias(
    nl: Noiseless,
    t_rows,
    ins_rows,
    ra_m,
    tvps_y_m,
    t_mark_s: float,
    spec: FitsSpec = DEFAULT_SPEC,
    ra_lever_m=None,
    tvps_lever_m=None,
) -> np.ndarray:
    """B_hat (3,) of eq. 18 from the event mark (along-track), the radar altimeter
    (vertical) and the TVPS (cross-track) near the threshold; the log's rows (times,
    INS positions, RA heights, TVPS cross-track) at any rate >= the WAAS rate. The mark
    at `t_mark_s` follows the crossing by the pilot's mean delay. `ra_lever_m` (per row,
    or the spec's constant when None): height of the reference point above the RA
    antenna; `tvps_lever_m` (per row, or 0): y of the reference point minus the camera's,
    both as the system computes them from its attitude."""
    t_rows = np.asarray(t_rows, dtype=float)
    ins_rows, ra, tv = np.asarray(ins_rows, float), np.asarray(ra_m, float), np.asarray(tvps_y_m, float)
    lev_ra = np.full(len(t_rows), spec.ra_lever_arm_m) if ra_lever_m is None else np.asarray(ra_lever_m, float)
    lev_tv = np.zeros(len(t_rows)) if tvps_lever_m is None else np.asarray(tvps_lever_m, float)
    t_thr = t_mark_s - spec.event_delay_s
    near = np.abs(t_rows - t_thr) <= spec.fix_window_s
    use_ra, use_tv = near & np.isfinite(ra) & np.isfinite(lev_ra), near & np.isfinite(tv) & np.isfinite(lev_tv)
    if not use_ra.any():
        raise ValueError(
            f"ra_m: no radar-altimeter reading within {spec.fix_window_s:g} s of the threshold (t = {t_thr:.2f} s)"
        )
    if spec.cross_track_fix == "none":
        use_tv = np.zeros(len(t_rows), bool)  # the WAAS's own cross-track bias stays
    elif not use_tv.any():
        raise ValueError(
            f"tvps_y_m: no TVPS reading within {spec.fix_window_s:g} s of the threshold (t = {t_thr:.2f} s); "
            "without a TVPS fix, leave the WAAS's cross-track bias (aerotruth fits --no-tvps-fix)"
        )
    tq = np.concatenate([[t_thr], t_rows[use_ra], t_rows[use_tv]])
    p = carry_with_ins(tq, nl.t_s, nl.noiseless, t_rows, ins_rows)
    n_ra = int(use_ra.sum())
    b_x = p[0, 0]  # eq. 18, along-track: threshold at x = 0
    b_z = np.mean(p[1 : 1 + n_ra, 2] - (ra[use_ra] + lev_ra[use_ra]))  # eq. 18, vertical
    b_y = np.mean(p[1 + n_ra :, 1] - (tv[use_tv] + lev_tv[use_tv])) if use_tv.any() else 0.0  # eq. 18, cross-track
    return np.array([b_x, b_y, b_z])


@dataclass(frozen=True)
class FitsResult:
    """One approach through the FITS: `xyz_m` is z_true (eq. 19) at the WAAS epochs."""

    noiseless: Noiseless
    bias_m: np.ndarray
    xyz_m: np.ndarray

    def applied_bias_m(self) -> np.ndarray:
        """(n, 3) the bias the FITS takes off at each WAAS epoch (besides the cyclic noise):
        B_hat of eq. 18, which refers to the segment before the first jump, plus the
        estimated steps of the flagged jumps before the epoch. On the threshold's segment
        it is what the RA, TVPS and event mark fixed; on the others it also carries the
        error of each step between that segment and the threshold's."""
        return self.bias_m + self.noiseless.jump_shift()

    def on_grid(self, t_ins, ins_xyz, rate_hz: float = 8.0) -> tuple[np.ndarray, np.ndarray]:
        """(t, xyz) on the runway-frame grid at `rate_hz` (the paper's 8 Hz), between WAAS
        epochs carried by the INS."""
        t_w = self.noiseless.t_s
        t = np.arange(np.ceil(t_w[0] * rate_hz - 1e-9), np.floor(t_w[-1] * rate_hz + 1e-9) + 1) / rate_hz
        return t, carry_with_ins(t, t_w, self.xyz_m, np.asarray(t_ins, float), np.asarray(ins_xyz, float))


def fits_approach(
    t_s,
    waas_xyz,
    ins_xyz,
    jump_flags,
    t_rows,
    ins_rows,
    ra_m,
    tvps_y_m,
    t_mark_s: float,
    spec: FitsSpec = DEFAULT_SPEC,
    ra_lever_m=None,
    tvps_lever_m=None,
) -> FitsResult:
    """The whole FITS on one approach: eqs. 3, 8-17 on the WAAS epochs, eq. 18 at the
    threshold from the log rows, eq. 19."""
    nl = waas_noiseless(t_s, waas_xyz, ins_xyz, jump_flags, spec)
    b = threshold_bias(nl, t_rows, ins_rows, ra_m, tvps_y_m, t_mark_s, spec, ra_lever_m, tvps_lever_m)
    return FitsResult(nl, b, nl.noiseless - b)  # eq. 19
