"""Airborne WAAS position errors as the FITS paper describes them (section III-B, eq. 2).

Measurement equation, per axis i (two horizontal axes h1, h2 and up), at the receiver's
epochs t_k (1 Hz, docs/conventions.md):

    z_waas(t_k) = P_T(t_k) + B_w(t_k) + N_w(t_k) + eta_w(t_k)              # FITS paper eq. 2
    B_w(t)      = b + sum_j J_j 1[t >= tau_j]                 bias, with jumps
    N_w(t)      = A(t) s(2 pi t / T_c + phi),  A(t) = A0 (1 + m sin(2 pi t / P_m + psi))
    eta_w(t_k)  = g_k + w_k,  g_k = rho g_(k-1) + sigma_g sqrt(1 - rho^2) u_k,  rho = exp(-dt / tau)

* b: a per-approach bias, sigma 0.45 m per horizontal axis and 0.8 m vertical. Table I
  gives 95 % figures of 0.79-1.69 m horizontal (radial: 2.45 sigma, docs/conventions.md) and
  1.12-2.31 m vertical (1.96 sigma): 0.45 m -> 1.10 m and 0.8 m -> 1.57 m, mid-range.
* Jumps J_j (sigma 1 m per axis) at Poisson times tau_j (one per 30 min): "the bias could
  jump if a satellite constellation changes and a new WAAS ionosphere correction message
  comes" (section III-B, IV-C). Each jump raises the receiver's flag `sv_change` or
  `iono_update` at the first epoch that carries it (the share of satellite-set changes is
  `jump_sv_share`).
* N_w: the cyclic noise of the fast corrections (message types 2-5 every 6 s, DO-229C)
  with period T_c = 2 x 6 s = 12 s (Fig. 6), mean amplitude A0 = 0.5 m ("usually over
  0.5 meters"), varying +-30 % over ~200 s (m = 0.3, P_m = 200 s: the slow change of
  Fig. 5/13, an assumption of this model), random phases phi, psi per axis. s is sin for
  `cyclic_waveform: sine`, or the stepped waveform (+1 for 6 s, -1 for 6 s: each fast
  correction held until the next) for `stepped`; A0 is the amplitude of either (RMS A0/sqrt 2
  for the sine, A0 for the stepped wave).
* eta_w: a first-order Gauss-Markov part (sigma 0.05 m, tau 100 s) and white noise
  (sigma 0.03 m) per epoch (multipath, thermal noise, correction residuals, section III-B).

The horizontal axes are statistically alike, so one draw serves any horizontal frame:
with `frame="xyz"` (runway frame, docs/conventions.md) h1 = x, h2 = y; with `frame="llh"` (WGS-84
lat/lon in degrees, ellipsoidal height in m) h1 = east, h2 = north, converted to angles
with the meridian and prime-vertical radii of curvature. SI units throughout.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal

import numpy as np
from pydantic import Field
from scipy.signal import lfilter

from aerotruth.ellipsoid import radii
from aerotruth.schema import Section
from aerotruth.sensors.waas_messages import WaasMessageSpec, draw_message_stream


class WaasSpec(Section):
    """WAAS error model parameters (defaults from the FITS paper, see the module docstring)."""

    rate_hz: float = Field(default=1.0, gt=0, description="output rate (FITS paper section V: WAAS at 1 Hz)")
    bias_sigma_horizontal_m: float = Field(
        default=0.45,
        ge=0,
        description="per-approach bias per horizontal axis, 1 sigma (Table I: 2.45 sigma = 1.10 m radial 95 %)",
    )
    bias_sigma_vertical_m: float = Field(
        default=0.8, ge=0, description="per-approach vertical bias, 1 sigma (Table I: 1.96 sigma = 1.57 m 95 %)"
    )
    jump_rate_per_h: float = Field(
        default=2.0, ge=0, description="Poisson rate of satellite-set changes and iono updates (one per 30 min)"
    )
    jump_sigma_m: float = Field(default=1.0, ge=0, description="jump per axis, 1 sigma (section III-B, IV-C)")
    jump_sv_share: float = Field(
        default=0.5, ge=0, le=1, description="share of jumps flagged sv_change (the rest iono_update)"
    )
    fast_correction_interval_s: float = Field(
        default=6.0,
        gt=0,
        description="fast-correction update interval (types 2-5, DO-229C); cyclic period is twice this (Fig. 6: 12 s)",
    )
    cyclic_amplitude_horizontal_m: float = Field(
        default=0.5,
        ge=0,
        description="mean amplitude of the cyclic noise per horizontal axis (section III-B: usually over 0.5 m)",
    )
    cyclic_amplitude_vertical_m: float = Field(
        default=0.5, ge=0, description="mean amplitude of the vertical cyclic noise"
    )
    cyclic_modulation: float = Field(default=0.3, ge=0, le=1, description="relative amplitude variation (+-30 %)")
    cyclic_modulation_period_s: float = Field(
        default=200.0, gt=0, description="period of the amplitude variation (~200 s)"
    )
    cyclic_waveform: Literal["sine", "stepped"] = Field(
        default="sine", description="sine, or stepped (each fast correction held 6 s)"
    )
    model: Literal["eq6", "message_stream"] = Field(
        default="eq6",
        description="eq6: the paper's model (this module); message_stream: the errors built from the fast "
        "corrections, the satellite geometry and the receiver (aerotruth.sensors.waas_messages; needs the "
        "runway frame), where the cyclic noise is not drawn",
    )
    messages: WaasMessageSpec = Field(
        default_factory=WaasMessageSpec, description="the message-stream model's settings (model: message_stream)"
    )
    gm_sigma_m: float = Field(default=0.05, ge=0, description="Gauss-Markov noise per axis, 1 sigma")
    gm_tau_s: float = Field(default=100.0, gt=0, description="Gauss-Markov correlation time")
    white_sigma_m: float = Field(default=0.03, ge=0, description="white noise per axis per epoch, 1 sigma")

    @property
    def cyclic_period_s(self) -> float:
        """Period of the cyclic noise: two fast-correction intervals."""
        return 2.0 * self.fast_correction_interval_s

    def epochs(self, duration_s: float, t0_s: float = 0.0) -> np.ndarray:
        """Receiver epochs t0, t0 + 1/rate, ... up to t0 + duration (inclusive)."""
        if not (duration_s >= 0):
            raise ValueError(f"duration_s must be >= 0, got {duration_s!r}")
        n = int(np.floor(duration_s * self.rate_hz + 1e-9)) + 1
        return t0_s + np.arange(n) / self.rate_hz

    def draw(self, rng: np.random.Generator, duration_s: float, t0_s: float = 0.0, frame=None) -> WaasErrors:
        """One approach's errors at the receiver epochs over `duration_s` (`frame`: the
        runway frame, for the message-stream model)."""
        return WaasErrors.draw(self, rng, self.epochs(duration_s, t0_s), frame)


def _uniform_epochs(t_s) -> np.ndarray:
    t = np.asarray(t_s, dtype=float)
    if t.ndim != 1 or len(t) < 2 or not np.all(np.isfinite(t)):
        raise ValueError(f"t_s: expected a 1-D array of at least 2 finite epochs, got shape {t.shape}")
    dt = np.diff(t)
    if not (np.all(dt > 0) and np.ptp(dt) <= 1e-6 * max(1.0, dt[0])):
        raise ValueError("t_s: expected increasing, uniformly spaced receiver epochs")
    return t


@dataclass(frozen=True)
class WaasErrors:
    """One drawn realization: components (n, 3) on the epochs `t_s` (axes h1, h2, up) and
    the receiver flags (int8 0/1 per epoch)."""

    t_s: np.ndarray
    bias_m: np.ndarray  # (3,) per-approach bias b
    jump_m: np.ndarray  # (n, 3) cumulative jumps
    cyclic_m: np.ndarray  # (n, 3) N_w
    gm_m: np.ndarray  # (n, 3)
    white_m: np.ndarray  # (n, 3)
    sv_change: np.ndarray
    iono_update: np.ndarray

    @classmethod
    def draw(cls, spec: WaasSpec, rng: np.random.Generator, t_s, frame=None) -> WaasErrors:
        """Draw every component at the epochs t_s (increasing, uniform spacing); the
        message-stream model needs the runway frame (aerotruth.truth.runway.RunwayFrame)."""
        t = _uniform_epochs(t_s)
        if spec.model == "message_stream":
            if frame is None:
                raise ValueError("waas.model message_stream: expected the runway frame (the satellite geometry's site)")
            p = draw_message_stream(spec.messages, rng, t, frame)
            zero = np.zeros((len(t), 3))
            slow = p["slow"]
            return cls(
                t, slow[0].copy(), slow - slow[0], p["fast"], p["receiver"], zero, p["sv_change"], p["iono_update"]
            )
        n, dt = len(t), float(t[1] - t[0])
        sig_b = np.array([spec.bias_sigma_horizontal_m, spec.bias_sigma_horizontal_m, spec.bias_sigma_vertical_m])
        bias = sig_b * rng.standard_normal(3)
        # jumps: Poisson count over (t0, t_end], uniform times, first epoch at or after each
        n_jump = rng.poisson(spec.jump_rate_per_h / 3600.0 * (t[-1] - t[0]))
        tau = rng.uniform(t[0], t[-1], n_jump)
        idx = np.clip(np.searchsorted(t, tau, side="left"), 1, n - 1)
        steps = spec.jump_sigma_m * rng.standard_normal((n_jump, 3))
        is_sv = rng.random(n_jump) < spec.jump_sv_share
        jump = np.zeros((n, 3))
        np.add.at(jump, idx, steps)
        jump = np.cumsum(jump, axis=0)
        sv = np.zeros(n, np.int8)
        iono = np.zeros(n, np.int8)
        sv[idx[is_sv]] = 1
        iono[idx[~is_sv]] = 1
        # cyclic noise of the fast corrections
        amp0 = np.array(
            [spec.cyclic_amplitude_horizontal_m, spec.cyclic_amplitude_horizontal_m, spec.cyclic_amplitude_vertical_m]
        )
        phi, psi = rng.uniform(0.0, 2 * np.pi, (2, 3))
        amp = amp0 * (
            1.0 + spec.cyclic_modulation * np.sin(2 * np.pi * t[:, None] / spec.cyclic_modulation_period_s + psi)
        )
        carrier = np.sin(2 * np.pi * t[:, None] / spec.cyclic_period_s + phi)
        if spec.cyclic_waveform == "stepped":
            carrier = np.where(carrier >= 0.0, 1.0, -1.0)
        cyclic = amp * carrier
        # first-order Gauss-Markov, exact discretization, stationary start
        rho = np.exp(-dt / spec.gm_tau_s)
        u = spec.gm_sigma_m * rng.standard_normal((n, 3))
        u[1:] *= np.sqrt(1.0 - rho**2)
        gm = lfilter([1.0], [1.0, -rho], u, axis=0)
        white = spec.white_sigma_m * rng.standard_normal((n, 3))
        return cls(t, bias, jump, cyclic, gm, white, sv, iono)

    @property
    def error_m(self) -> np.ndarray:
        """Total error (n, 3): B_w + N_w + eta_w (FITS paper eq. 2)."""
        return self.bias_m + self.jump_m + self.cyclic_m + self.gm_m + self.white_m

    def apply(self, truth, t_s, frame: Literal["xyz", "llh"] = "xyz") -> np.ndarray:
        """Measured positions at the epochs `t_s` (which must be the drawn epochs) for the
        true positions `truth` (n, 3): runway-frame x, y, z in m, or lat_deg, lon_deg, h_m."""
        t = np.asarray(t_s, dtype=float)
        if t.shape != self.t_s.shape or not np.allclose(t, self.t_s, rtol=0, atol=1e-6):
            raise ValueError("t_s: expected the receiver epochs these errors were drawn at")
        p = np.asarray(truth, dtype=float)
        if p.shape != (len(t), 3):
            raise ValueError(f"truth: expected shape ({len(t)}, 3), got {p.shape}")
        err = self.error_m
        if frame == "xyz":
            return p + err
        if frame == "llh":
            lat = np.radians(p[:, 0])
            r_m, r_n = radii(lat)  # meridian, prime vertical
            dlat = np.degrees(err[:, 1] / (r_m + p[:, 2]))
            dlon = np.degrees(err[:, 0] / ((r_n + p[:, 2]) * np.cos(lat)))
            return p + np.column_stack([dlat, dlon, err[:, 2]])
        raise ValueError(f"frame: expected 'xyz' or 'llh', got {frame!r}")
