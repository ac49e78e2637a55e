"""Turbulence with a climatology for the truth legs: patches along the flight path, each with
an intensity drawn from the probability-of-exceedance curves of MIL-F-8785C (1980), section
3.7.2 and Figure 7 (the same curves in MIL-HDBK-1797), which JSBSim carries as its
"milspec" severity table: severity k (1..7) is the curve exceeded with probability
POE_OF_SEVERITY[k - 1] (2e-1, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6), and JSBSim looks the
rms gust intensity up at the aircraft's altitude (e.g. the 1e-2 curve: 7.4 fps at
3,750 ft, 4.6 at 15,000, 0.4 at 35,000; the 2e-1 curve is zero above 7,500 ft).

A patch draws u ~ U(0, 1), its probability of exceedance, and takes the most severe curve
it exceeds: P(severity >= k) = POE_k, so light turbulence (1e-2 and worse) is met on 1 %
of the path, moderate (1e-3) on 0.1 %. Below the least curve (u > 0.2) the patch takes
that curve (severity 1): zero intensity above 7,500 ft, and it keeps JSBSim's low-altitude
model (below 1,000 ft AGL sigma_w = 0.1 x the wind at 20 ft, MIL-F-8785C 3.7.3) that
severity 0 would switch off. The wind at 20 ft is the truth atmosphere's at the patch's
start. Patch lengths are exponential with mean PATCH_MEAN_M (an assumption: clear-air
turbulence comes in patches of tens of km; no source with a distribution was at hand).
The severity of a leg's patches is what the leg's seed draws; JSBSim's own generator
(seeded from the same stream) makes the gusts.

Light chop (:class:`ChopGusts`), below what the curves above resolve: the MIL-F-8785C
curves put no turbulence at all on 90 % of the path above 7,500 ft, while the real A320
recorder extract (../shared/real-data) shows continuous low-level vertical-load and roll
activity in cruise. Chop patches (same patch lengths) carry an rms gust sigma_w drawn from
the distribution measured on that recorder (CHOP_SIGMA_W_QUANTILES, derived in
validation/chop_climatology.py: the A320's vertical load factor per 120-s window above
10,000 ft divided by its gust load factor and the share of a Dryden gust's rms the
recorder keeps), applied at every height. The gusts are the first-order forms of the
Dryden model that JSBSim's milspec type uses (MIL-HDBK-1797 as in Yeager 1998, eqs. 30-33:
u with time constant L/V, v and w with L/(2V), the rolling gust p with
sigma_p = 1.9 sigma_w / sqrt(L b) and L_p = sqrt(L b) / 2.6; L = 1,750 ft), discretized
exactly at 10 Hz and fed to JSBSim's gust inputs (atmosphere/gust-*-fps) and, for p, to
the aircraft's roll-damping term (``atmosphere/chop/p-rad_sec``; an aircraft file without that term
feels u, v, w only).

Near the ground (:class:`Mil8785Gusts`, approaches and inspection missions): JSBSim's
milspec model evaluates MIL-F-8785C at the altitude above *sea level* (FGWinds::Run passes
AltitudeASL), so its low-altitude model (h < 1,000 ft) never acts at an airport above
1,000 ft (KDLH, 1,428 ft) and the POE curves' low end acts over the runway instead. The
ILS flights therefore evaluate the same standard themselves at the height above the runway
and feed the gusts to JSBSim's gust inputs: below 1,000 ft sigma_w = 0.1 W20,
sigma_u = sigma_v = sigma_w / (0.177 + 0.000823 h)^0.4, L_w = h,
L_u = L_v = h / (0.177 + 0.000823 h)^1.2 (MIL-F-8785C 3.7.3, Figs. 10-11, h in ft); above
2,000 ft L = 1,750 ft and sigma from the severity's curve of Figure 7 (POE_CURVES_FPS);
between, both interpolated linearly in h (3.7.2.3). Dryden forms and the rolling gust as
for the chop; updated at 50 Hz (at 100 ft and 130 kt the vertical gust's time constant
L_w / 2V is 0.23 s).
"""

from __future__ import annotations

import bisect
import math

import numpy as np

from aerotruth.units import FT

POE_OF_SEVERITY = (2e-1, 1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6)  # JSBSim milspec rows 1..7 (MIL-F-8785C Fig. 7)
PATCH_MEAN_M = 20_000.0
TURB_TYPE_MILSPEC = 3  # FGWinds ttMilspec: Dryden forms of MIL-STD-1797A as in Yeager (1998)
W20_HEIGHT_M = 6.1  # 20 ft


def severity_of(u: float) -> int:
    """The most severe curve exceeded by a patch whose probability of exceedance is u (>= 1)."""
    k = 1
    for j, p in enumerate(POE_OF_SEVERITY, start=1):
        if u <= p:
            k = j
    return k


# MIL-F-8785C Figure 7: rms gust intensity (ft/s) of the probability-of-exceedance curves
# (rows: severity 1..7 = POE 2e-1 .. 1e-6) at these altitudes (ft)
POE_ALTITUDES_FT = (
    500.0,
    1750.0,
    3750.0,
    7500.0,
    15000.0,
    25000.0,
    35000.0,
    45000.0,
    55000.0,
    65000.0,
    75000.0,
    80000.0,
)
POE_CURVES_FPS = (
    (3.2, 2.2, 1.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    (4.2, 3.6, 3.3, 1.6, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0),
    (6.6, 6.9, 7.4, 6.7, 4.6, 2.7, 0.4, 0.0, 0.0, 0.0, 0.0, 0.0),
    (8.6, 9.6, 10.6, 10.1, 8.0, 6.6, 5.0, 4.2, 2.7, 0.0, 0.0, 0.0),
    (11.8, 13.0, 16.0, 15.1, 11.6, 9.7, 8.1, 8.2, 7.9, 4.9, 3.2, 2.1),
    (15.6, 17.6, 23.0, 23.6, 22.1, 20.0, 16.0, 15.1, 12.1, 7.9, 6.2, 5.1),
    (18.7, 21.5, 28.4, 30.2, 30.7, 31.0, 25.2, 23.1, 17.5, 10.7, 8.4, 7.2),
)


def _interp(x: float, xs, ys) -> float:
    """np.interp for one scalar (clamped at the ends), without NumPy's call overhead."""
    if x <= xs[0]:
        return ys[0]
    j = bisect.bisect_right(xs, x)
    if j >= len(xs):
        return ys[-1]
    return ys[j - 1] + (x - xs[j - 1]) / (xs[j] - xs[j - 1]) * (ys[j] - ys[j - 1])


def mil8785_intensity(h_ft: float, w20_fps: float, severity: int) -> tuple[float, float, float, float]:
    """(sigma_u, sigma_w in ft/s; L_u, L_w in ft) of MIL-F-8785C at `h_ft` above the ground
    (clipped at 10 ft) for the wind `w20_fps` at 20 ft and the Figure-7 curve `severity`
    (module docstring). sigma_v = sigma_u, L_v = L_u."""
    h = max(h_ft, 10.0)
    if h <= 1000.0:
        f = 0.177 + 0.000823 * h
        sw = 0.1 * w20_fps
        return sw / f**0.4, sw, h / f**1.2, h
    high = _interp(h, POE_ALTITUDES_FT, POE_CURVES_FPS[severity - 1])
    if h >= 2000.0:
        return high, high, 1750.0, 1750.0
    lo = mil8785_intensity(1000.0, w20_fps, severity)
    r = (h - 1000.0) / 1000.0
    return (
        lo[0] + r * (high - lo[0]),
        lo[1] + r * (high - lo[1]),
        lo[2] + r * (1750.0 - lo[2]),
        lo[3] + r * (1750.0 - lo[3]),
    )


class TurbulencePatches:
    """Sets JSBSim's milspec turbulence patch by patch along a leg (module docstring)."""

    def __init__(self, fdm, rng: np.random.Generator):
        self.fdm, self.rng = fdm, rng
        self.next_m = 0.0
        self.patches: list[tuple[float, int]] = []  # (start along the path, m; severity)
        self.severity, self.w20_mps = 1, 0.0
        fdm["atmosphere/turb-type"] = TURB_TYPE_MILSPEC
        fdm["simulation/randomseed"] = int(rng.integers(0, 2**31 - 1))

    def due(self, path_m: float) -> bool:
        """Whether the current patch has been flown at `path_m` (m along the path)."""
        return path_m >= self.next_m

    def update_from(
        self, path_m: float, atmosphere, lat_deg: float, lon_deg: float, ground_m: float, t_s: float
    ) -> None:
        """`update` with the wind at 20 ft over `ground_m` (m above MSL) at (lat, lon) and
        time `t_s` (s after 0 UTC) taken from the truth `atmosphere`."""
        u20, v20, _ = (
            float(np.asarray(c).ravel()[0])
            for c in atmosphere.wind(lat_deg, lon_deg, ground_m + W20_HEIGHT_M, t_s, ground_elevation_m=ground_m)
        )
        self.update(path_m, math.hypot(u20, v20))

    def meta(self) -> list[list]:
        """The patches for a track's metadata: [start along the path (m, 0.1 m), severity]."""
        return [[round(a, 1), k] for a, k in self.patches]

    def update(self, path_m: float, w20_mps: float) -> None:
        """Starts the next patch at `path_m` (when `due`), with the truth wind at 20 ft (m/s)."""
        k = severity_of(float(self.rng.random()))
        self.severity, self.w20_mps = k, w20_mps
        self.fdm["atmosphere/turbulence/milspec/severity"] = k
        self.fdm["atmosphere/turbulence/milspec/windspeed_at_20ft_AGL-fps"] = w20_mps / FT  # ft/s
        self.patches.append((path_m, k))
        self.next_m = path_m + float(self.rng.exponential(PATCH_MEAN_M))


# sigma_w (m/s) at these probabilities of the A320's windows (validation/chop_climatology.py)
CHOP_QUANTILE_PROBS = (0.0, 0.05, 0.1, 0.25, 0.5, 0.75, 0.9, 0.95, 1.0)
# (90 windows of one A320 flight, FL160-FL360; an upper bound: the load factor also holds
# the autopilot's own pitch activity). Quantization of the recorder removed.
CHOP_SIGMA_W_QUANTILES = (0.095, 0.115, 0.124, 0.149, 0.212, 0.300, 0.478, 0.642, 0.913)
CHOP_SCALE_M = 1750.0 * FT  # MIL-F-8785C scale length above 2,000 ft
GUST_DT_S = 0.1  # the gust inputs are updated at the truth's 10 Hz


def chop_sigma_w(u: float) -> float:
    """The rms vertical gust (m/s) of a chop patch whose quantile is u (0..1)."""
    return float(np.interp(u, CHOP_QUANTILE_PROBS, CHOP_SIGMA_W_QUANTILES))


class ChopGusts:
    """Light chop in patches along a leg, fed to JSBSim as gusts (module docstring)."""

    def __init__(self, fdm, rng: np.random.Generator, span_m: float):
        self.rng = rng
        self.lb = math.sqrt(CHOP_SCALE_M * span_m)  # sqrt(L b): the rolling gust's scale
        pm = fdm.get_property_manager()
        self.nodes = [
            pm.get_node(p)
            for p in ("atmosphere/gust-north-fps", "atmosphere/gust-east-fps", "atmosphere/gust-down-fps")
        ]
        self.p_node = pm.get_node("atmosphere/chop/p-rad_sec", True)
        self.x = [0.0, 0.0, 0.0, 0.0]  # u, v, w (m/s), p (rad/s)
        self.sigma_w = 0.0
        self.next_m = 0.0
        self.patches: list[tuple[float, float]] = []  # (start along the path, m; sigma_w, m/s)

    @property
    def sigma_w(self) -> float:
        """The current patch's rms gust (m/s)."""
        return self._sigma_w

    @sigma_w.setter
    def sigma_w(self, value: float) -> None:
        self._sigma_w = value
        self._sig = (value, value, value, value * 1.9 / self.lb)  # rms of u, v, w (m/s), p (rad/s)

    def due(self, path_m: float) -> bool:
        return path_m >= self.next_m

    def update(self, path_m: float) -> None:
        """Starts the next chop patch at `path_m` (when `due`)."""
        self.sigma_w = chop_sigma_w(float(self.rng.random()))
        self.patches.append((path_m, self.sigma_w))
        self.next_m = path_m + float(self.rng.exponential(PATCH_MEAN_M))

    def step(self, tas_mps: float, psi_rad: float) -> None:
        """Advances the gusts by GUST_DT_S at true airspeed `tas_mps` and heading `psi_rad`
        and sets them: u along the heading, v to its right, w down (NED in ft/s). Scalar
        arithmetic (~5x cheaper than small arrays at 10 Hz); four normals a call, so the
        stream's draws for the patches (`update`) come where they always came."""
        v = max(tas_mps, 30.0)
        n, x, sig = self.rng.standard_normal(4).tolist(), self.x, self._sig
        for k, tau in enumerate((CHOP_SCALE_M / v, CHOP_SCALE_M / (2 * v), CHOP_SCALE_M / (2 * v), self.lb / 2.6 / v)):
            a = math.exp(-GUST_DT_S / tau)
            x[k] = a * x[k] + sig[k] * math.sqrt(1.0 - a * a) * n[k]
        u, vv, w, p = x
        c, s = math.cos(psi_rad), math.sin(psi_rad)
        for node, val in zip(self.nodes, (u * c - vv * s, u * s + vv * c, w), strict=False):
            node.set_double_value(val / FT)
        self.p_node.set_double_value(p)


class Mil8785Gusts:
    """MIL-F-8785C turbulence evaluated at the height above the ground, fed to JSBSim's
    gust inputs (module docstring): the patches' severity and wind at 20 ft, JSBSim's own
    milspec model switched off. `step` advances the gusts by `dt_s`."""

    BLOCK = 250  # sets of normal deviates drawn per call to the generator (a multiple of COEFF_EVERY)
    COEFF_EVERY = 5

    def __init__(self, fdm, rng: np.random.Generator, span_m: float, patches: TurbulencePatches):
        self.rng, self.patches = rng, patches
        self.b_ft = span_m / FT
        fdm["atmosphere/turb-type"] = 0
        pm = fdm.get_property_manager()
        self.nodes = [
            pm.get_node(p)
            for p in ("atmosphere/gust-north-fps", "atmosphere/gust-east-fps", "atmosphere/gust-down-fps")
        ]
        self.p_node = pm.get_node("atmosphere/chop/p-rad_sec", True)
        self.x = [0.0, 0.0, 0.0, 0.0]  # u, v, w (ft/s), p (rad/s)
        self._normals: list[float] = []
        self._i = 0
        self._coeff: list[tuple[float, float]] | None = None

    def step(self, dt_s: float, h_agl_m: float, tas_mps: float, psi_rad: float) -> None:
        """Advances the gusts by `dt_s` at `h_agl_m` above the ground, true airspeed
        `tas_mps` and heading `psi_rad`; u along the heading, v to its right, w down. The
        intensities, time constants and heading are re-evaluated every COEFF_EVERY steps
        (0.1 s at 50 Hz: the height changes by a few feet, the heading by < 0.5 deg)."""
        if self._i >= len(self._normals):
            self._normals, self._i = self.rng.standard_normal(4 * self.BLOCK).tolist(), 0
            self._coeff = None
        if self._coeff is None or self._i % (4 * self.COEFF_EVERY) == 0:
            self._coeff = self._coefficients(dt_s, h_agl_m, tas_mps)
            self._cs = math.cos(psi_rad), math.sin(psi_rad)
        n, i, x = self._normals, self._i, self.x
        self._i = i + 4
        (au, bu), (av, bv), (aw, bw), (ap, bp) = self._coeff
        u = x[0] = au * x[0] + bu * n[i]
        v = x[1] = av * x[1] + bv * n[i + 1]
        w = x[2] = aw * x[2] + bw * n[i + 2]
        p = x[3] = ap * x[3] + bp * n[i + 3]
        c, s = self._cs
        nn, ne, nd = self.nodes
        nn.set_double_value(u * c - v * s)
        ne.set_double_value(u * s + v * c)
        nd.set_double_value(w)
        self.p_node.set_double_value(p)

    def _coefficients(self, dt_s: float, h_agl_m: float, tas_mps: float) -> list[tuple[float, float]]:
        """(a, b) of x <- a x + b n for u, v, w (ft/s) and p (rad/s): the exact
        discretisation of the first-order Dryden forms, a = exp(-dt / tau),
        b = sigma sqrt(1 - a^2)."""
        su, sw, lu, lw = mil8785_intensity(h_agl_m / FT, self.patches.w20_mps / FT, self.patches.severity)
        v = max(tas_mps, 30.0) / FT  # ft/s
        out = []
        for sig, tau in (
            (su, lu / v),
            (su, lu / (2 * v)),
            (sw, lw / (2 * v)),
            (1.9 * sw / math.sqrt(lw * self.b_ft), math.sqrt(lw * self.b_ft) / 2.6 / v),
        ):
            a = math.exp(-dt_s / tau)
            out.append((a, sig * math.sqrt(1.0 - a * a)))
        return out


__all__ = [
    "Mil8785Gusts",
    "mil8785_intensity",
    "CHOP_QUANTILE_PROBS",
    "CHOP_SIGMA_W_QUANTILES",
    "ChopGusts",
    "POE_OF_SEVERITY",
    "PATCH_MEAN_M",
    "TurbulencePatches",
    "chop_sigma_w",
    "severity_of",
]
