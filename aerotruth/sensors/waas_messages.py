"""WAAS position errors built from the message stream and the satellite geometry, beside
the FITS paper's eq. 6 (aerotruth.sensors.waas): the cyclic noise is not drawn here; what
period and amplitude it has is what the fast-correction arithmetic and the geometry make.

Constellation (a stated simplification, no almanac): a Walker 24/6/1 delta pattern of
GPS-like circular orbits, semi-major axis 26,559.7 km, inclination 55 deg, six planes
60 deg apart, four satellites per plane, adjacent planes phased by 15 deg; the Earth
turns under it at 7.2921151467e-5 rad/s. Each approach draws the orbit phase and the
sidereal angle uniformly (the hour of day), satellites above `elevation_mask_deg` at the
runway threshold are used.

Per satellite i, the pseudorange error after the WAAS corrections, at the receiver's
1-Hz epochs:

    r_i(t) = c_i(t) - [PRC_k + RRC_k (t - t_k)] + s_i(t) + m_i(t)

* c_i: the satellite clock and orbit error along the line of sight that the fast
  corrections exist to remove: an integrated random walk (rate sigma
  `clock_rate_sigma_mps` at the start, rate random walk `clock_rate_walk_mps_per_sqrt_s`).
* Fast corrections (message types 2-5; DO-229): each satellite's pseudorange correction
  PRC_k broadcast every `fast_correction_interval_s` (6 s), the four message types in
  successive seconds (satellite j of the PRN mask in type 2 + j // 13); PRC_k = -(c_i at
  the measurement `latency_s` before the broadcast) + the master station's estimation
  noise (`prc_noise_sigma_m`, white per update), rounded to `prc_resolution_m` (0.125 m,
  the 12-bit field of types 2-5). The receiver applies the latest PRC_k from its
  broadcast t_k and extrapolates with the range-rate correction it derives from the last
  two, RRC_k = (PRC_k - PRC_(k-1)) / (t_k - t_(k-1)) (DO-229's rule for the RRC from
  successive fast corrections).
* s_i: the slow corrections' residual (ionosphere grid, long-term corrections, troposphere):
  a constant per satellite (`slow_sigma_m`) that steps by `iono_step_sigma_m` at each
  ionospheric-grid update (every `iono_update_interval_s`, flagged `iono_update`).
* m_i: airborne multipath and receiver noise after code-carrier smoothing, a first-order
  Gauss-Markov process per satellite with tau `receiver_tau_s` (the smoothing window) and
  sigma 0.13 + 0.53 exp(-theta / 10 deg) m (the airborne multipath model of the WAAS MOPS,
  DO-229 Appendix J, theta the elevation) in quadrature with `receiver_noise_sigma_m`.

Position error: the weighted least-squares solution (weights 1 / sigma_i^2 of the terms
above) of the line-of-sight errors, dx = (H^T W H)^-1 H^T W r with H rows (-u_i^T, 1), u_i
the unit vector to satellite i (east, north, up), turned into the runway frame. A
satellite rising above or setting below the mask changes the solution's set: a jump,
flagged `sv_change`, and the solution's sensitivity to the slow errors changes with it.

The drawn parts are returned as WaasErrors (aerotruth.sensors.waas): `cyclic_m` the
fast-correction residual (c - PRC - RRC (t - t_k)) through the geometry, the part the FITS
removes; `gm_m` the multipath and receiver noise; `bias_m` + `jump_m` the slow residual
(its value at the first epoch, then its change); `white_m` zero.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field
from scipy.signal import lfilter

from aerotruth import geo
from aerotruth.schema import Section

EARTH_RATE_RADPS = 7.2921151467e-5
MU_EARTH = 3.986005e14  # m^3/s^2 (WGS-84 as GPS uses it)
GPS_A_M = 26_559_700.0
WALKER = (24, 6, 1)  # total, planes, phasing
INCLINATION_DEG = 55.0


class WaasMessageSpec(Section):
    """The message-stream WAAS model (module docstring); levels are stated estimates
    except where a standard is named."""

    elevation_mask_deg: float = Field(default=5.0, ge=0, lt=60, description="satellites used above this elevation")
    fast_correction_interval_s: float = Field(
        default=6.0, gt=0, description="each satellite's fast correction (types 2-5) broadcast this often"
    )
    prc_resolution_m: float = Field(
        default=0.125, gt=0, description="fast-correction quantum (types 2-5: 12 bits at 0.125 m, DO-229)"
    )
    prc_noise_sigma_m: float = Field(
        default=0.05, ge=0, description="the master station's estimation noise per fast correction, 1 sigma"
    )
    latency_s: float = Field(default=2.0, ge=0, le=10, description="from a correction's measurement to its broadcast")
    clock_rate_sigma_mps: float = Field(
        default=0.01, ge=0, description="rate of the clock and orbit error along the line of sight, 1 sigma"
    )
    clock_rate_walk_mps_per_sqrt_s: float = Field(
        default=0.0005, ge=0, description="random walk of that rate (m/s per sqrt(s))"
    )
    slow_sigma_m: float = Field(
        default=0.4, ge=0, description="slow corrections' residual per satellite (ionosphere, orbit), 1 sigma"
    )
    iono_update_interval_s: float = Field(default=300.0, gt=0, description="ionospheric grid updates")
    iono_step_sigma_m: float = Field(default=0.1, ge=0, description="step of each satellite's slow residual")
    receiver_noise_sigma_m: float = Field(
        default=0.1, ge=0, description="smoothed code noise per satellite, 1 sigma (with the DO-229 multipath)"
    )
    receiver_tau_s: float = Field(default=100.0, gt=0, description="code-carrier smoothing time constant")


def _satellites_ecef(t_s: np.ndarray, u0: float, theta0: float) -> np.ndarray:
    """(n_sat, n_t, 3) ECEF positions of the Walker constellation at times t (s)."""
    total, planes, phasing = WALKER
    per = total // planes
    inc = math.radians(INCLINATION_DEG)
    n_motion = math.sqrt(MU_EARTH / GPS_A_M**3)
    raan = 2 * np.pi * np.repeat(np.arange(planes), per) / planes
    slot = np.tile(np.arange(per), planes)
    u_init = u0 + 2 * np.pi * slot / per + 2 * np.pi * phasing * np.repeat(np.arange(planes), per) / total
    u = u_init[:, None] + n_motion * t_s[None, :]
    x_orb, y_orb = GPS_A_M * np.cos(u), GPS_A_M * np.sin(u)
    co, so = np.cos(raan)[:, None], np.sin(raan)[:, None]
    x = x_orb * co - y_orb * math.cos(inc) * so
    y = x_orb * so + y_orb * math.cos(inc) * co
    z = y_orb * math.sin(inc)
    g = theta0 + EARTH_RATE_RADPS * t_s[None, :]  # Earth rotation: ECI -> ECEF
    return np.stack([x * np.cos(g) + y * np.sin(g), -x * np.sin(g) + y * np.cos(g), np.broadcast_to(z, x.shape)], -1)


def line_of_sight(t_s, lat_deg: float, lon_deg: float, h_m: float, u0: float, theta0: float) -> np.ndarray:
    """(n_sat, n_t, 3) unit vectors (east, north, up) from the site to each satellite."""
    sat = _satellites_ecef(np.asarray(t_s, float), u0, theta0)
    site = np.array(geo.ecef(lat_deg, lon_deg, h_m), float)
    c_en = geo.ecef_from_ned_matrix(lat_deg, lon_deg)  # NED -> ECEF
    d = sat - site
    d /= np.linalg.norm(d, axis=-1, keepdims=True)
    ned = d @ c_en  # (C^T d) row-wise
    return np.stack([ned[..., 1], ned[..., 0], -ned[..., 2]], -1)


def fast_correction_residual(
    t_s: np.ndarray, c: np.ndarray, spec: WaasMessageSpec, slot_offset_s: float, rng: np.random.Generator
) -> np.ndarray:
    """c(t) - [PRC_k + RRC_k (t - t_k)] at the epochs t_s for one satellite whose error
    along the line of sight is c (on t_s) and whose fast corrections are broadcast at
    slot_offset_s + j x interval (module docstring)."""
    dt = spec.fast_correction_interval_s
    t0, t1 = float(t_s[0]), float(t_s[-1])
    tb = slot_offset_s + dt * np.arange(
        math.floor((t0 - 3 * dt - slot_offset_s) / dt), math.ceil((t1 - slot_offset_s) / dt) + 1
    )
    c_meas = np.interp(tb - spec.latency_s, t_s, c)  # held at the ends (the record starts 3 updates before)
    prc = -c_meas + spec.prc_noise_sigma_m * rng.standard_normal(len(tb))
    prc = spec.prc_resolution_m * np.round(prc / spec.prc_resolution_m)
    rrc = np.diff(prc, prepend=prc[0]) / dt
    rrc[0] = 0.0
    k = np.clip(np.searchsorted(tb, t_s, side="right") - 1, 0, len(tb) - 1)
    return c + prc[k] + rrc[k] * (t_s - tb[k])


def draw_message_stream(spec: WaasMessageSpec, rng: np.random.Generator, t_s, frame) -> dict:
    """The parts of one approach's WAAS error at the epochs t_s (1-D, uniform) for the
    runway frame `frame` (aerotruth.truth.runway.RunwayFrame): keys fast, receiver, slow
    ((n, 3), runway frame) and the receiver flags sv_change, iono_update (int8, (n,)).
    Nothing periodic is drawn."""
    t = np.asarray(t_s, float)
    n = len(t)
    u0, theta0 = rng.uniform(0, 2 * np.pi, 2)
    los = line_of_sight(t - t[0], frame.lat0_deg, frame.lon0_deg, frame.h0_m, u0, theta0)
    n_sat = los.shape[0]
    elev = np.degrees(np.arcsin(np.clip(los[..., 2], -1, 1)))
    used = elev > spec.elevation_mask_deg
    # per-satellite errors
    dt = float(t[1] - t[0]) if n > 1 else 1.0
    rate = spec.clock_rate_sigma_mps * rng.standard_normal((n_sat, 1))
    walk = np.cumsum(spec.clock_rate_walk_mps_per_sqrt_s * math.sqrt(dt) * rng.standard_normal((n_sat, n)), axis=1)
    c = np.cumsum((rate + walk) * dt, axis=1) + 5.0 * rng.standard_normal((n_sat, 1))
    slots = np.arange(n_sat) // 13  # message type 2 + j // 13, one type per second
    fast = np.stack([fast_correction_residual(t, c[i], spec, float(slots[i]), rng) for i in range(n_sat)])
    sig_mp = 0.13 + 0.53 * np.exp(-np.maximum(elev, 0.0) / 10.0)
    sig_rx = np.sqrt(sig_mp**2 + spec.receiver_noise_sigma_m**2)
    rho = math.exp(-dt / spec.receiver_tau_s)
    u = rng.standard_normal((n_sat, n))
    u[:, 1:] *= math.sqrt(1 - rho**2)
    rx = lfilter([1.0], [1.0, -rho], u, axis=1) * sig_rx
    n_iono = int((t[-1] - t[0]) // spec.iono_update_interval_s)
    iono_times = (
        t[0] + rng.uniform(0, spec.iono_update_interval_s) + spec.iono_update_interval_s * np.arange(n_iono + 1)
    )
    iono_times = iono_times[iono_times <= t[-1]]
    slow = spec.slow_sigma_m * rng.standard_normal((n_sat, 1)) * np.ones((1, n))
    iono = np.zeros(n, np.int8)
    for ti in iono_times:
        k = int(np.searchsorted(t, ti))
        if 0 < k < n:
            slow[:, k:] += spec.iono_step_sigma_m * rng.standard_normal((n_sat, 1))
            iono[k] = 1
    # the weighted least-squares position error per epoch
    weight_var = spec.prc_resolution_m**2 / 12 + spec.prc_noise_sigma_m**2 + sig_rx**2 + spec.slow_sigma_m**2
    out: dict[str, np.ndarray] = {}
    n_used = used.sum(axis=0)
    sets = used.T  # (n, n_sat)
    change = np.zeros(n, np.int8)
    change[1:] = np.any(sets[1:] != sets[:-1], axis=1)
    if n_used.min() < 4:
        k = int(np.argmin(n_used))
        raise ValueError(f"WAAS message stream: only {n_used[k]} satellites above the mask at epoch {t[k]:.0f} s")
    # every epoch at once: the satellites below the mask weigh nothing
    h = np.concatenate([-np.transpose(los, (1, 0, 2)), np.ones((n, n_sat, 1))], axis=2)  # (n, n_sat, 4)
    w = np.where(sets, 1.0 / weight_var.T, 0.0)  # (n, n_sat)
    hw = h * w[..., None]
    a = np.linalg.solve(np.einsum("kij,kil->kjl", hw, h), np.transpose(hw, (0, 2, 1)))  # (n, 4, n_sat)
    m = np.einsum("ij,kjs->kis", _rotation_enu_to_runway(frame.course_deg), a[:, :3])  # (n, 3, n_sat)
    out["fast"] = np.einsum("kis,sk->ki", m, fast)
    out["receiver"] = np.einsum("kis,sk->ki", m, rx)
    out["slow"] = np.einsum("kis,sk->ki", m, slow)
    out["sv_change"] = change
    out["iono_update"] = np.where(change > 0, 0, iono).astype(np.int8)
    return out


def _rotation_enu_to_runway(course_deg: float) -> np.ndarray:
    """Runway-frame x (along the course), y (left), z (up) from east, north, up."""
    c, s = math.cos(math.radians(course_deg)), math.sin(math.radians(course_deg))
    return np.array([[s, c, 0.0], [-c, s, 0.0], [0.0, 0.0, 1.0]])
