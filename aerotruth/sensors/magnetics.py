"""Heading from a pendulous flux valve and a slaved directional gyro, with the Earth's
field from IGRF: the physics behind the wind paper's magnetic deviation (eq. 2).

Frames: NED (x north, y east, z down); body (x forward, y right, z down); attitude
R_bn = Rz(psi) Ry(theta) Rx(phi) (body -> NED, heading psi true, about down). Field
B_ned = (X, Y, Z) nT: H = hypot(X, Y), declination D = atan2(Y, X) (east positive),
inclination I = atan2(Z, H). Angles in rad, field in nT.

Measurement equation (one aircraft; Poisson's equations of ship magnetism):

    b   = R_bn^T B_ned                       field in body axes
    m   = (I + S) b + p                      S soft iron (3x3, dimensionless), p hard iron (nT, body)
    v   = R_bv^T m,  R_bv = Rz(mu) Rx(gamma) Ry(beta)
    psi_valve = atan2(-v_y, v_x)             the valve senses v in its own plane

mu is the mounting error (the valve's reference line yawed right of the fore-aft axis);
gamma (outer gimbal, about the fore-aft axis) and beta (inner gimbal) put the valve's z
axis along the apparent vertical n = (g - a)/|g - a| (g = (0, 0, g0), a the kinematic
acceleration, NED): the valve hangs as a pendulum, quasi-statically (its own swing
dynamics and gimbal stops are not modelled). With n expressed in the mount frame,
sin beta = n_x, sin gamma = -n_y / cos beta, cos gamma = n_z / cos beta.

Deviation, sign convention: d = measured - true magnetic heading, wrapped to (-pi, pi];
wind paper eq. 2 (Bowditch, the paper's ref. [12]) writes it against the *measured*
heading z':   d = A + B sin z' + C cos z' + D sin 2z' + E cos 2z'.

Why it has that form (Archibald Smith's analysis, Admiralty Manual for the Deviations of
the Compass, 1862): level, unaccelerated flight, mu = 0, S = [[a, b, c], [d, e, f],
[g, h, k]], p = (P, Q, R), true magnetic heading psi. In the body, b = (H cos psi,
-H sin psi, Z), and with w = m_x - i m_y (arg w = z'):

    w = lambda H e^{i psi} [1 - i A' + (B' - i C') e^{-i psi} + (D' - i E') e^{-2 i psi}]
    lambda = 1 + (a + e)/2,  A' = (d - b)/(2 lambda),  B' = (c Z + P)/(lambda H),
    C' = (f Z + Q)/(lambda H),  D' = (a - e)/(2 lambda),  E' = (b + d)/(2 lambda)

so to first order in the small coefficients d = arg(...) gives eq. 2 with

    A = -A',  B = -B',  C = -C',  D = -D',  E = -E'.

Hence: permanent hard iron (P, Q) gives B, C proportional to 1/H; soft iron magnetised
by the vertical field (c, f) gives B, C proportional to Z/H; soft iron magnetised by the
horizontal field (a, b, d, e) gives D, E and A that do not depend on the field at all
(every term scales with H); the mounting error adds mu to A exactly; R, g, h, k only
act when the valve tilts. Hard iron (and c, f) alone is exact in z': the component of
w e^{-i z'} across the measured direction vanishes, so

    sin d = -((P + c Z) sin z' + (Q + f Z) cos z') / H          (wind paper eq. 2, D = E = 0)

a sinusoid of peak-to-peak 2 asin(|p_h| / H) (4 deg at H becomes 5.0 deg at 0.8 H and
3.4 deg at 1.18 H: the wind paper's section 7 and Fig. 7).

Tilt: in a steady coordinated turn the apparent vertical is the aircraft's own z axis,
so the valve reads the field in banked axes (roll phi, pitch 0); with b_y = -H cos phi
sin psi + Z sin phi and b_x = H cos psi:

    tan z' = (cos phi sin psi - sin phi tan I) / cos psi         (turning error)

north (psi = 0): z' = -atan(tan I sin phi), the valve shows a turn the other way; south:
the same amount ahead; east/west: none while tan phi tan I < 1 (beyond that bank the
vertical field dominates the valve's lateral axis and the reading flips). A forward
acceleration a_x on an east heading swings the pendulum aft, dipping the valve's front
edge by beta = atan(a_x / g): z' = 90 deg - atan(tan I sin beta), an apparent turn
towards north ("accelerate north").

Slaved gyro (the system heading): the directional gyro carries turns, the valve corrects
it slowly,

    dpsi/dt = r_gyro + s(t) (psi_valve - psi) / tau,   s = 1 if |phi| <= phi_cut else 0

r_gyro = dpsi_true/dt + drift (the gyro's azimuth rate; Earth and transport rate taken
as compensated). Optionally (`slaving_rate_max_deg_min`) the slaving term saturates at the
torquer's rate, clip((psi_valve - psi)/tau, -r_max, r_max): textbook slaved compasses
precess at about 2 deg/min whatever the error (an assumption; default off).
Written as psi = psi_g + e with psi_g = integral of r_gyro, the error e is a gated
first-order low-pass of u = psi_valve - psi_g. Exact discretisation for readings held
over a sample interval: e_k = e_{k-1} + s_{k-1} alpha (u_{k-1} - e_{k-1}),
alpha = 1 - exp(-dt/tau); at power-up the gyro is slewed to the valve (e_0 = u_0; `HeadingSystem`
uses the valve's static reading at the first heading: a track starts airborne, long after
the gyro was slaved on the ground).
Gated-out intervals leave e unchanged, so the filter runs (scipy lfilter) over the
slaved intervals only. The valve-minus-gyro difference is an angle: the loop acts on it
wrapped to (-pi, pi] (a synchro error signal), so u is unwrapped relative to e — where
the valve spins a full turn against the gyro (a violent transient tilting the pendulum)
the gyro does not chase it round.

True heading (wind paper section 4): psi_true,reported = psi_mag + D_table, D_table the
declination of the receiver's model for its epoch (`declination_epoch`); a stale table
is a heading offset of exactly D_epoch - D_date.

Earth's field: IGRF-14 through ppigrf (Laundal; geodetic coordinates, ellipsoidal
height), evaluated on a lat/lon/height grid for one date and interpolated trilinearly:
a 0.5 deg x 0.5 deg x 3.5 km grid is within ~1.5 nT and 0.002 deg of declination of
direct evaluation over the Mesaba and PenAir regions (tests). WMM is not used: its
epochs before 2010 are not available here, and IGRF is the definitive model for
2009-2010.
"""

from __future__ import annotations

import datetime as _dt
import math
from dataclasses import dataclass
from typing import Annotated, Literal

import numpy as np
import pandas as pd
from numpy.typing import ArrayLike
from pydantic import Field, field_validator
from scipy.signal import lfilter

from aerotruth.schema import Section
from aerotruth.units import DEG, G0

TWO_PI = 2.0 * np.pi
IGRF_YEARS = (1900, 2030)  # IGRF-14 definitive/secular-variation span
Finite = Annotated[float, Field(allow_inf_nan=False)]
Vector3 = tuple[Finite, Finite, Finite]

# ----------------------------------------------------------------------------- field


def _as_datetime(when: _dt.date | _dt.datetime) -> _dt.datetime:
    if isinstance(when, _dt.datetime):
        return when
    if isinstance(when, _dt.date):
        return _dt.datetime(when.year, when.month, when.day)
    raise ValueError(f"when: expected a date or datetime, got {when!r}")


@dataclass(frozen=True)
class FieldComponents:
    """The geomagnetic field at points: NED components (nT) and derived angles."""

    north_nT: np.ndarray
    east_nT: np.ndarray
    down_nT: np.ndarray

    @property
    def horizontal_nT(self) -> np.ndarray:
        """H = hypot(X, Y)."""
        return np.hypot(self.north_nT, self.east_nT)

    @property
    def declination_rad(self) -> np.ndarray:
        """D = atan2(Y, X), east positive: true = magnetic + D."""
        return np.arctan2(self.east_nT, self.north_nT)

    @property
    def inclination_rad(self) -> np.ndarray:
        """I = atan2(Z, H), positive downwards (dip)."""
        return np.arctan2(self.down_nT, self.horizontal_nT)

    def ned_nT(self) -> np.ndarray:
        """(N, 3) array of (X, Y, Z)."""
        return np.stack([self.north_nT, self.east_nT, self.down_nT], axis=-1)


class GeomagneticField:
    """IGRF for one date on a regular lat/lon/height grid, interpolated trilinearly.

    Built once per date and region (ppigrf on the grid: ~0.1 s for a 12 x 22 deg box),
    then cheap for millions of points. Longitudes are taken modulo 360 from `lon_deg[0]`,
    so a box may cross the antimeridian (lon_deg=(170, 200)).
    """

    def __init__(
        self,
        when: _dt.date | _dt.datetime,
        lat_deg: tuple[float, float],
        lon_deg: tuple[float, float],
        h_m: tuple[float, float] = (-1000.0, 13000.0),
        step_deg: float = 0.5,
        h_step_m: float = 3500.0,
    ):
        self.when = _as_datetime(when)
        if not IGRF_YEARS[0] <= self.when.year < IGRF_YEARS[1]:
            raise ValueError(f"when: IGRF covers {IGRF_YEARS[0]}-{IGRF_YEARS[1]}, got {self.when:%Y-%m-%d}")
        (lat0, lat1), (lon0, lon1), (h0, h1) = (tuple(map(float, r)) for r in (lat_deg, lon_deg, h_m))
        if not -90.0 <= lat0 < lat1 <= 90.0:
            raise ValueError(f"lat_deg: expected -90 <= low < high <= 90, got {lat_deg}")
        if not (lon0 < lon1 <= lon0 + 360.0):
            raise ValueError(f"lon_deg: expected low < high <= low + 360, got {lon_deg}")
        if not h0 < h1:
            raise ValueError(f"h_m: expected low < high, got {h_m}")
        if not (step_deg > 0 and h_step_m > 0):
            raise ValueError(f"step_deg, h_step_m: expected > 0, got {step_deg}, {h_step_m}")
        self.lat_deg, self.lon_deg, self.h_m = (lat0, lat1), (lon0, lon1), (h0, h1)
        self.step_deg, self.h_step_m = float(step_deg), float(h_step_m)
        n_lat = int(math.ceil((lat1 - lat0) / step_deg - 1e-9)) + 1
        n_lon = int(math.ceil((lon1 - lon0) / step_deg - 1e-9)) + 1
        n_h = max(2, int(math.ceil((h1 - h0) / h_step_m - 1e-9)) + 1)
        self._lat_nodes = np.linspace(lat0, lat1, n_lat)  # spacing <= step_deg, ends on the box
        self._lon_nodes = np.linspace(lon0, lon1, n_lon)
        self._h_nodes = np.linspace(h0, h1, n_h)
        self._shape = (n_lat, n_lon, n_h)
        self._spacing = tuple(float(nodes[1] - nodes[0]) for nodes in (self._lat_nodes, self._lon_nodes, self._h_nodes))
        import ppigrf

        lat_g, lon_g, h_g = np.meshgrid(self._lat_nodes, self._lon_nodes, self._h_nodes, indexing="ij")
        be, bn, bu = ppigrf.igrf(lon_g, lat_g, h_g / 1000.0, self.when)
        nodes = np.stack([bn[0], be[0], -bu[0]], axis=-1)  # (n_lat, n_lon, n_h, 3) NED
        # each cell's 8 corner values side by side (cell, component, corner): one gather per point
        corners = [
            nodes[di : n_lat - 1 + di, dj : n_lon - 1 + dj, dk : n_h - 1 + dk]
            for di in (0, 1)
            for dj in (0, 1)
            for dk in (0, 1)
        ]
        self._cells = np.ascontiguousarray(np.stack(corners, axis=-1).reshape(-1, 3, 8))
        self._other_dates: dict[_dt.datetime, GeomagneticField] = {}

    @classmethod
    def covering(
        cls, lat_deg: ArrayLike, lon_deg: ArrayLike, when: _dt.date | _dt.datetime, margin_deg: float = 0.5, **grid
    ) -> GeomagneticField:
        """A field whose box holds the given points with a margin (e.g. a track, a fleet's region)."""
        lat, lon = np.asarray(lat_deg, float).ravel(), np.asarray(lon_deg, float).ravel()
        if lat.size == 0 or not (np.all(np.isfinite(lat)) and np.all(np.isfinite(lon))):
            raise ValueError("lat_deg, lon_deg: expected finite coordinates (at least one point)")
        lon180 = (lon + 180.0) % 360.0 - 180.0
        lon360 = lon % 360.0
        lon_use = lon180 if np.ptp(lon180) <= np.ptp(lon360) else lon360
        return cls(
            when,
            (max(-90.0, lat.min() - margin_deg), min(90.0, lat.max() + margin_deg)),
            (lon_use.min() - margin_deg, lon_use.max() + margin_deg),
            **grid,
        )

    def for_date(self, when: _dt.date | _dt.datetime) -> GeomagneticField:
        """The same box and grid for another date (e.g. a receiver's declination epoch);
        built once per date and kept."""
        when = _as_datetime(when)
        if when == self.when:
            return self
        if when not in self._other_dates:
            self._other_dates[when] = GeomagneticField(
                when, self.lat_deg, self.lon_deg, self.h_m, self.step_deg, self.h_step_m
            )
        return self._other_dates[when]

    def along(self, lat_deg: ArrayLike, lon_deg: ArrayLike, h_m: ArrayLike, stride: int = 50) -> FieldComponents:
        """Field along a densely sampled track (1-D arrays in time order): evaluated at every
        `stride`-th sample and the last, linear in sample number between them. A 10 Hz
        track moves < 1 km and < 100 m in height in 50 samples, where the field is linear
        to far below 0.1 nT; this is ~10x cheaper than `at` on every sample."""
        lat, lon, h = (np.asarray(a, dtype=float) for a in (lat_deg, lon_deg, h_m))
        n = lat.size
        if lat.ndim != 1 or lon.shape != (n,) or h.shape != (n,):
            raise ValueError(
                f"lat_deg, lon_deg, h_m: expected 1-D arrays of one length, got {lat.shape}, {lon.shape}, {h.shape}"
            )
        if stride < 1:
            raise ValueError(f"stride: expected >= 1, got {stride}")
        if n <= 2 * stride:
            return self.at(lat, lon, h)
        knots = np.r_[np.arange(0, n - 1, stride), n - 1]
        c = self.at(lat[knots], lon[knots], h[knots])
        k = np.arange(n)
        return FieldComponents(*(np.interp(k, knots, comp) for comp in (c.north_nT, c.east_nT, c.down_nT)))

    def at(self, lat_deg: ArrayLike, lon_deg: ArrayLike, h_m: ArrayLike) -> FieldComponents:
        """Field at points (geodetic deg, ellipsoidal height m); inputs broadcast together."""
        lat, lon, h = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (lat_deg, lon_deg, h_m)))
        shape = lat.shape
        lat, lon, h = lat.ravel(), lon.ravel(), h.ravel()
        offsets = (lat - self.lat_deg[0], (lon - self.lon_deg[0]) % 360.0, h - self.h_m[0])
        idx, weights = [], []
        for name, raw, x, n, spacing, box in zip(
            ("lat_deg", "lon_deg", "h_m"),
            (lat, lon, h),
            offsets,
            self._shape,
            self._spacing,
            (self.lat_deg, self.lon_deg, self.h_m),
            strict=False,
        ):
            f = x / spacing
            bad = ~((f >= -1e-9) & (f <= n - 1 + 1e-9))
            if bad.any():
                raise ValueError(
                    f"{name}: {int(bad.sum())} point(s) outside the field's box [{box[0]}, {box[1]}], "
                    f"e.g. {raw[bad][0]}"
                )
            i = np.clip(np.floor(f).astype(np.intp), 0, n - 2)
            idx.append(i)
            weights.append(np.clip(f - i, 0.0, 1.0))
        (i, j, k), (ti, tj, tk) = idx, weights
        cell = (i * (self._shape[1] - 1) + j) * (self._shape[2] - 1) + k
        w = np.empty((lat.size, 8))  # trilinear weights, corners in (di, dj, dk) order
        si, sj, sk = 1.0 - ti, 1.0 - tj, 1.0 - tk
        for q, wij in enumerate((si * sj, si * tj, ti * sj, ti * tj)):
            np.multiply(wij, sk, out=w[:, 2 * q])
            np.multiply(wij, tk, out=w[:, 2 * q + 1])
        out = np.einsum("nck,nk->nc", self._cells.take(cell, axis=0), w)
        return FieldComponents(out[:, 0].reshape(shape), out[:, 1].reshape(shape), out[:, 2].reshape(shape))


# ----------------------------------------------------------------------------- specs


class FluxValveSpec(Section):
    """One aircraft's flux valve and compass system (nT, deg, s at this edge)."""

    hard_iron_nT: Vector3 = Field(default=(0.0, 0.0, 0.0), description="permanent magnetism p (body x, y, z), nT")
    soft_iron: tuple[Vector3, Vector3, Vector3] = Field(
        default=((0.0, 0.0, 0.0),) * 3,
        description="induced magnetism S (3x3, dimensionless, rows body x, y, z): m = (I + S) b + p",
    )
    mounting_deg: Finite = Field(
        default=0.0, ge=-180, le=180, description="valve reference line yawed right of the fore-aft axis"
    )
    slaving_tau_s: Finite = Field(
        default=60.0, gt=0, description="slaving time constant (assumption: ~1 deg/min per deg of error)"
    )
    slaving_rate_max_deg_min: Finite | None = Field(
        default=None, gt=0, description="the slaving torquer's largest correction rate (None: the loop never saturates)"
    )
    slaving_cutout_bank_deg: Finite = Field(
        default=10.0, gt=0, le=90, description="no slaving while |roll| exceeds this"
    )
    gyro_drift_deg_h: Finite = Field(default=0.0, description="uncompensated directional-gyro drift")
    declination_epoch: _dt.date | Literal["truth"] = Field(
        default="truth",
        description="date of the declination model the system converts with; 'truth' = the flight's date",
    )

    @field_validator("soft_iron")
    @classmethod
    def _small_soft_iron(cls, v: tuple) -> tuple:
        if any(abs(x) > 0.5 for row in v for x in row):
            raise ValueError(f"expected |S_ij| <= 0.5 (induced fields are small fractions of the Earth's), got {v}")
        return v


class FluxValveFleetSpec(Section):
    """How flux valves vary over a fleet; `draw(rng)` gives one aircraft's FluxValveSpec.

    An aircraft is "poor" with probability `poor_fraction` (about half of Mesaba's SAAB
    340s: wind paper section 4), or, with `poor_count` k, exactly k of the fleet's aircraft
    are (a fleet whose composition is known, e.g. PenAir's 4 poor + 3 healthy in Table III;
    which k is drawn by `poor_valves` from the fleet's own stream, and the aircraft's own
    stream is consumed as with the fraction, so that its valve draws stay the same and a
    paired run differs only in the classes). Each body component of its hard iron is N(0, sigma^2)
    with sigma of its class, so the horizontal magnitude is Rayleigh (median 1.18 sigma:
    500 nT gives the paper's ~4 deg peak-to-peak at H = 17,400 nT). Soft-iron elements are
    N(0, soft_iron_sigma^2), the mounting error N(0, mounting_sigma_deg^2).
    """

    poor_fraction: Finite = Field(default=0.5, ge=0, le=1, description="probability that an aircraft's valve is poor")
    poor_count: int | None = Field(
        default=None,
        ge=0,
        description="exactly this many of the fleet's aircraft have "
        "poor valves (replaces poor_fraction; which ones is drawn per campaign seed)",
    )
    poor_hard_iron_sigma_nT: Finite = Field(default=500.0, ge=0, description="per-axis hard-iron sigma, poor valves")
    healthy_hard_iron_sigma_nT: Finite = Field(
        default=100.0, ge=0, description="per-axis hard-iron sigma, healthy valves"
    )
    soft_iron_sigma: Finite = Field(default=0.005, ge=0, le=0.1, description="sigma of each soft-iron element")
    mounting_sigma_deg: Finite = Field(default=1.0, ge=0, description="sigma of the mounting error")
    poor_mounting_sigma_deg: Finite | None = Field(
        default=None,
        ge=0,
        description="sigma of the mounting (offset) error of poor systems (default: mounting_sigma_deg)",
    )
    slaving_tau_s: Finite = Field(default=60.0, gt=0)
    slaving_rate_max_deg_min: Finite | None = Field(default=None, gt=0)
    slaving_cutout_bank_deg: Finite = Field(default=10.0, gt=0, le=90)
    gyro_drift_deg_h: Finite = 0.0
    declination_epoch: _dt.date | Literal["truth"] = "truth"

    def draw(self, rng: np.random.Generator) -> FluxValveSpec:
        """One aircraft's valve: class, hard iron (3), soft iron (9), mounting, in that order."""
        return self.draw_with_class(rng)[1]

    def draw_with_class(self, rng: np.random.Generator, poor: bool | None = None) -> tuple[str, FluxValveSpec]:
        """("poor" | "healthy", valve) of one aircraft; the same draws as `draw`. `poor`
        given (the class decided for the fleet, `poor_count`): the class draw is made and
        ignored, so that the valve's draws are those of the fraction's path."""
        by_fraction = rng.random() < self.poor_fraction
        poor = by_fraction if poor is None else bool(poor)
        sigma = self.poor_hard_iron_sigma_nT if poor else self.healthy_hard_iron_sigma_nT
        p = rng.normal(0.0, 1.0, 3) * sigma
        s = np.clip(rng.normal(0.0, 1.0, (3, 3)) * self.soft_iron_sigma, -0.5, 0.5)
        m_sigma = (
            self.poor_mounting_sigma_deg
            if poor and self.poor_mounting_sigma_deg is not None
            else self.mounting_sigma_deg
        )
        mount = float(np.clip(rng.normal() * m_sigma, -180.0, 180.0))
        return ("poor" if poor else "healthy"), FluxValveSpec(
            hard_iron_nT=tuple(p.tolist()),
            soft_iron=tuple(tuple(r) for r in s.tolist()),
            mounting_deg=mount,
            slaving_tau_s=self.slaving_tau_s,
            slaving_rate_max_deg_min=self.slaving_rate_max_deg_min,
            slaving_cutout_bank_deg=self.slaving_cutout_bank_deg,
            gyro_drift_deg_h=self.gyro_drift_deg_h,
            declination_epoch=self.declination_epoch,
        )


def poor_valves(aircraft: list[str] | tuple[str, ...], count: int, rng: np.random.Generator) -> frozenset[str]:
    """Which `count` of the fleet's `aircraft` have poor valves: a draw without replacement
    over the ids in sorted order (the YAML's listing order does not matter)."""
    ids = sorted(set(aircraft))
    if not 0 <= count <= len(ids):
        raise ValueError(f"poor_count: expected 0..{len(ids)} (the fleet's aircraft), got {count}")
    return frozenset(ids[i] for i in rng.choice(len(ids), size=count, replace=False))


# ----------------------------------------------------------------------------- physics


def ned_to_body(
    v_ned: ArrayLike, roll_rad: ArrayLike, pitch_rad: ArrayLike, heading_rad: ArrayLike
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Body components of NED vectors (..., 3): R_bn^T v with R_bn = Rz(psi) Ry(theta) Rx(phi)."""
    v = np.asarray(v_ned, dtype=float)
    return _rotate_to_body(_attitude_trig(roll_rad, pitch_rad, heading_rad), v[..., 0], v[..., 1], v[..., 2])


def _attitude_trig(roll_rad: ArrayLike, pitch_rad: ArrayLike, heading_rad: ArrayLike) -> tuple[np.ndarray, ...]:
    return (
        np.cos(heading_rad),
        np.sin(heading_rad),
        np.cos(pitch_rad),
        np.sin(pitch_rad),
        np.cos(roll_rad),
        np.sin(roll_rad),
    )


def _rotate_to_body(trig: tuple[np.ndarray, ...], x, y, z) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    cps, sps, cth, sth, cph, sph = trig
    x1, y1 = cps * x + sps * y, cps * y - sps * x  # Rz(psi)^T
    x2, z2 = cth * x1 - sth * z, sth * x1 + cth * z  # Ry(theta)^T
    return x2, cph * y1 + sph * z2, cph * z2 - sph * y1  # Rx(phi)^T


def track_acceleration_ned(time_s: ArrayLike, v_mps: ArrayLike) -> np.ndarray:
    """Kinematic acceleration (m/s^2) from sampled velocity (N or N x 3), central differences."""
    t, v = np.asarray(time_s, dtype=float), np.asarray(v_mps, dtype=float)
    if t.size < 2:
        return np.zeros_like(v)
    step = _uniform_step(t)
    return np.gradient(v, t if step is None else step, axis=0)  # a scalar step is ~10x faster


def _uniform_step(t: np.ndarray) -> float | None:
    """The sample interval if `t` is strictly increasing and equally spaced (to 1e-6), else None."""
    if t.size < 2:
        return None
    dt = np.diff(t)
    step = float(t[-1] - t[0]) / (t.size - 1)
    return step if step > 0 and np.all(np.abs(dt - step) <= 1e-6 * step) else None


def _mod_2pi(x: np.ndarray) -> np.ndarray:
    """x modulo 2 pi in [0, 2 pi) (np.mod, several times cheaper)."""
    r = x - TWO_PI * np.floor(x * (1.0 / TWO_PI))
    return np.where(r >= TWO_PI, 0.0, r)


class FluxValve:
    """A pendulous flux valve with the aircraft's hard and soft iron and its mounting error
    (the measurement equation of the module docstring)."""

    def __init__(self, spec: FluxValveSpec):
        self.spec = spec
        self.m = np.eye(3) + np.asarray(spec.soft_iron, dtype=float)
        self.soft = bool(np.any(np.asarray(spec.soft_iron) != 0.0))
        self.p = np.asarray(spec.hard_iron_nT, dtype=float)
        self.mounting_rad = spec.mounting_deg * DEG

    def heading_mag(
        self,
        field_ned_nT: ArrayLike,
        roll_rad: ArrayLike,
        pitch_rad: ArrayLike,
        heading_rad: ArrayLike,
        accel_ned_mps2: ArrayLike | None = None,
    ) -> np.ndarray:
        """Valve heading (rad, [0, 2 pi)) for the Earth's field (NED, nT), attitude (heading
        true) and kinematic acceleration (NED; None = unaccelerated). Inputs broadcast."""
        trig = _attitude_trig(roll_rad, pitch_rad, heading_rad)
        b = np.asarray(field_ned_nT, dtype=float)
        mx, my, mz = _rotate_to_body(trig, b[..., 0], b[..., 1], b[..., 2])
        if self.soft:
            m = self.m
            mx, my, mz = (
                m[0, 0] * mx + m[0, 1] * my + m[0, 2] * mz,
                m[1, 0] * mx + m[1, 1] * my + m[1, 2] * mz,
                m[2, 0] * mx + m[2, 1] * my + m[2, 2] * mz,
            )
        mx, my, mz = mx + self.p[0], my + self.p[1], mz + self.p[2]
        if accel_ned_mps2 is None:
            dx, dy, dz = _rotate_to_body(trig, 0.0, 0.0, 1.0)
        else:
            a = np.asarray(accel_ned_mps2, dtype=float)
            dx, dy, dz = _rotate_to_body(trig, -a[..., 0], -a[..., 1], G0 - a[..., 2])
        cm, sm = math.cos(self.mounting_rad), math.sin(self.mounting_rad)
        if sm != 0.0:  # into the mount frame: Rz(mu)^T
            mx, my = cm * mx + sm * my, cm * my - sm * mx
            dx, dy = cm * dx + sm * dy, cm * dy - sm * dx
        norm = np.sqrt(dx * dx + dy * dy + dz * dz)
        dx, dy, dz = dx / norm, dy / norm, dz / norm
        # v = Ry(beta)^T Rx(gamma)^T m, both components multiplied by cos(beta) > 0
        vy = dz * my - dy * mz
        vx = (dy * dy + dz * dz) * mx - dx * (dy * my + dz * mz)
        return _mod_2pi(np.arctan2(-vy, vx))

    def measure(self, track: pd.DataFrame, field: GeomagneticField | FieldComponents) -> np.ndarray:
        """Valve heading (rad) at each TruthTrack sample. `field`: the Earth's field for the
        flight's date (evaluated along the track), or its components at the samples. The
        acceleration that tilts the pendulum comes from the track's NED velocity."""
        df = getattr(track, "df", track)
        _require(
            df,
            (
                "time_s",
                "lat_deg",
                "lon_deg",
                "h_ellipsoid_m",
                "vn_mps",
                "ve_mps",
                "vd_mps",
                "roll_rad",
                "pitch_rad",
                "heading_rad",
            ),
        )
        b = _along(df, field) if isinstance(field, GeomagneticField) else field
        if b.north_nT.shape != (len(df),):
            raise ValueError(f"field: expected components at the {len(df)} samples, got shape {b.north_nT.shape}")
        t = df["time_s"].to_numpy(float)
        acc = track_acceleration_ned(
            t, np.column_stack([df[c].to_numpy(float) for c in ("vn_mps", "ve_mps", "vd_mps")])
        )
        return self.heading_mag(
            b.ned_nT(),
            df["roll_rad"].to_numpy(float),
            df["pitch_rad"].to_numpy(float),
            df["heading_rad"].to_numpy(float),
            acc,
        )


def _along(df: pd.DataFrame, field: GeomagneticField) -> FieldComponents:
    _require(df, ("lat_deg", "lon_deg", "h_ellipsoid_m"))
    return field.along(
        df["lat_deg"].to_numpy(float), df["lon_deg"].to_numpy(float), df["h_ellipsoid_m"].to_numpy(float)
    )


def _require(df: pd.DataFrame, columns: tuple[str, ...]) -> None:
    missing = [c for c in columns if c not in df.columns]
    if missing:
        raise ValueError(f"track: missing columns {missing}")


def _unwrap(x: np.ndarray) -> np.ndarray:
    """Remove 2 pi jumps between consecutive samples (numpy.unwrap, in fewer passes)."""
    if x.size < 2:
        return x.copy()
    jumps = np.round(np.diff(x) * (1.0 / TWO_PI))
    out = x.copy()
    out[1:] -= TWO_PI * np.cumsum(jumps)
    return out


def slaved_heading(
    time_s: ArrayLike,
    valve_heading_mag_rad: ArrayLike,
    heading_rad: ArrayLike,
    roll_rad: ArrayLike,
    tau_s: float,
    cutout_bank_rad: float,
    drift_rad_s: float = 0.0,
    initial_valve_rad: float | None = None,
    rate_max_rad_s: float | None = None,
) -> np.ndarray:
    """Magnetic heading (rad, [0, 2 pi)) of a directional gyro slaved to the valve:
    dpsi/dt = r_gyro + s (psi_valve - psi)/tau, s = 0 while |roll| > cutout (module
    docstring). `heading_rad` is the true heading whose rate the gyro senses; samples
    must be equally spaced in time. `initial_valve_rad`: the valve reading the gyro was
    slewed to at power-up (default: the first sample's reading). `rate_max_rad_s`: the
    slaving correction saturates at this rate (the torquer's limit), the slaving term
    becoming clip((psi_valve - psi)/tau, -rate_max, rate_max)."""
    t = np.asarray(time_s, dtype=float)
    fv, psi, roll = (np.asarray(a, dtype=float) for a in (valve_heading_mag_rad, heading_rad, roll_rad))
    n = t.size
    for name, a in (("valve_heading_mag_rad", fv), ("heading_rad", psi), ("roll_rad", roll)):
        if a.shape != (n,):
            raise ValueError(f"{name}: expected {n} values (one per time_s), got shape {a.shape}")
    if not tau_s > 0:
        raise ValueError(f"tau_s: expected > 0, got {tau_s}")
    if n == 0:
        return fv.copy()
    psi_g = _unwrap(psi) + drift_rad_s * (t - t[0])
    u = _unwrap(_mod_2pi(fv - psi_g + np.pi) - np.pi)
    if initial_valve_rad is not None:
        e_init = float(_mod_2pi(np.asarray(initial_valve_rad - psi_g[0] + np.pi)) - np.pi)
        u = u - TWO_PI * np.round((u[0] - e_init) / TWO_PI)  # same branch as the initial error
    if n == 1:
        return _mod_2pi(psi_g + u)
    step = _uniform_step(t)
    if step is None:
        raise ValueError("time_s: expected strictly increasing, equally spaced samples")
    alpha = -math.expm1(-step / tau_s)
    on = np.abs(roll[:-1]) <= cutout_bank_rad  # slaving during interval k-1 -> k
    e0 = u[0] if initial_valve_rad is None else e_init
    if rate_max_rad_s is None:
        e_on = _slaving_filter(u[:-1][on], alpha, e0)
    else:
        if not rate_max_rad_s > 0:
            raise ValueError(f"rate_max_rad_s: expected > 0, got {rate_max_rad_s}")
        e_on = _saturating_slaving_filter(u[:-1][on], alpha, e0, rate_max_rad_s * step)
    e = np.concatenate(([e0], e_on))[np.concatenate(([0], np.cumsum(on)))]
    return _mod_2pi(psi_g + e)


_SLAVING_BLOCK = 50  # samples per block where the error must be re-wrapped (5 s at 10 Hz)


def _slaving_filter(x: np.ndarray, alpha: float, e0: float) -> np.ndarray:
    """e_k = e_{k-1} + alpha wrap(x_{k-1} - e_{k-1}), outputs after each input (lfilter).

    Linear stretches, where the unwrapped input stays within pi of e, are one lfilter pass
    each (the normal case: the whole leg). From an input that gets further (the valve
    swinging past the synchro's null, or a 2 pi branch left behind by a bank cutout),
    blocks of _SLAVING_BLOCK inputs are wrapped to within pi of e at the block's start: e
    moves at most alpha x pi per sample (0.26 rad per block at tau = 60 s, 10 Hz), so this
    differs from the exact per-sample wrap only for inputs within that of the unstable
    null, 180 deg off. After the first block that needs no wrap the input is shifted by
    2 pi m onto e's branch and filtered linearly again, in chunks doubling from one block
    (a chunk that fails is re-done from its first far input). Cost O(n) whatever the
    input (a valve swinging wildly in noise included)."""
    b, a = [alpha], [1.0, alpha - 1.0]
    n = x.size
    y = np.empty(n)
    e, s, chunk, wrapped = float(e0), 0, n, False
    while s < n:
        if not wrapped:  # linear: the input shifted onto e's branch
            seg = x[s : s + chunk] + TWO_PI * np.round((e - x[s]) / TWO_PI)
            ys = lfilter(b, a, seg, zi=[(1.0 - alpha) * e])[0]
            prev = np.concatenate(([e], ys[:-1]))
            far = np.flatnonzero(np.abs(seg - prev) > np.pi)
            k = int(far[0]) if far.size else seg.size
            y[s : s + k] = ys[:k]
            e = float(prev[k]) if far.size else float(ys[-1])
            s += k
            chunk = min(2 * chunk, n)
            wrapped = bool(far.size)
            continue
        xb = x[s : s + _SLAVING_BLOCK]
        d = xb - e
        d += TWO_PI * np.round(-d[0] / TWO_PI)  # onto e's branch (the wrap below is branch-blind)
        wrapped = bool(np.any(np.abs(d) > np.pi))  # this block needed the wrap: so may the next
        xb = e + (np.mod(d + np.pi, TWO_PI) - np.pi)
        y[s : s + xb.size] = lfilter(b, a, xb, zi=[(1.0 - alpha) * e])[0]
        e = float(y[s + xb.size - 1])
        s += xb.size
        chunk = _SLAVING_BLOCK
    return y


def _saturating_slaving_filter(x: np.ndarray, alpha: float, e0: float, max_step: float) -> np.ndarray:
    """e_k = e_{k-1} + clip(alpha wrap(x_{k-1} - e_{k-1}), -max_step, max_step): the slaving
    loop of `_slaving_filter` with its correction per sample limited (a saturating
    torquer). Runs the linear filter block by block while no step reaches the limit; from
    the first sample that does, steps sample by sample for 20 blocks, then tries the
    linear filter again."""
    y = np.empty_like(x)
    e = float(e0)
    k, n = 0, x.size
    band = max_step / alpha  # |x - e| below this: the linear loop
    while k < n:
        lin = _slaving_filter(x[k : k + _SLAVING_BLOCK], alpha, e)
        prev = np.concatenate(([e], lin[:-1]))
        over = np.flatnonzero(np.abs(x[k : k + lin.size] - prev) > band)
        if over.size == 0:  # the whole block is linear
            y[k : k + lin.size] = lin
            e = float(lin[-1])
            k += lin.size
            continue
        j = k + int(over[0])
        y[k:j] = lin[: j - k]
        e = float(prev[j - k])
        end = min(n, j + 20 * _SLAVING_BLOCK)  # saturated stretch: sample by sample
        for i in range(j, end):
            d = (x[i] - e + math.pi) % (2 * math.pi) - math.pi
            e += min(max(alpha * d, -max_step), max_step)
            y[i] = e
        k = end
    return y


class HeadingSystem:
    """Flux valve + slaved gyro + the receiver's declination: what a SAAB 340 hands TAMDAR."""

    def __init__(self, spec: FluxValveSpec):
        self.spec = spec
        self.valve = FluxValve(spec)

    def apply(
        self, track: pd.DataFrame, field: GeomagneticField, receiver_field: GeomagneticField | None = None
    ) -> pd.DataFrame:
        """Per-sample headings of the system on a TruthTrack flown on `field`'s date.

        Returns columns `heading_mag_rad` (system, magnetic), `heading_rad` (true, after
        the receiver's declination), `valve_heading_mag_rad`, `declination_rad` (the
        receiver's table) and `slaving` (bool). `receiver_field`: the declination model
        for `spec.declination_epoch` (built from `field` when None; pass one to reuse it).
        """
        df = getattr(track, "df", track)
        comps = _along(df, field)
        fv = self.valve.measure(df, comps)
        roll = df["roll_rad"].to_numpy(float)
        cutout = self.spec.slaving_cutout_bank_deg * DEG
        # the gyro was slaved on the ground, level and unaccelerated, long before the
        # track starts: its initial error is the valve's static deviation at the first
        # heading, not the reading of a pendulum swinging in the first second of a climb
        psi0 = df["heading_rad"].to_numpy(float)[:1]
        fv0 = float(self.valve.heading_mag(comps.ned_nT()[:1], 0.0, 0.0, psi0)[0])
        psi_mag = slaved_heading(
            df["time_s"].to_numpy(float),
            fv,
            df["heading_rad"].to_numpy(float),
            roll,
            self.spec.slaving_tau_s,
            cutout,
            self.spec.gyro_drift_deg_h * DEG / 3600.0,
            initial_valve_rad=fv0,
            rate_max_rad_s=(
                None if self.spec.slaving_rate_max_deg_min is None else self.spec.slaving_rate_max_deg_min * DEG / 60.0
            ),
        )
        epoch = self.spec.declination_epoch
        want = field.when if epoch == "truth" else _as_datetime(epoch)
        if receiver_field is not None and receiver_field.when != want:
            raise ValueError(
                f"receiver_field: expected a field for declination_epoch {epoch} ({want:%Y-%m-%d}), "
                f"got one for {receiver_field.when:%Y-%m-%d}"
            )
        rx = field.for_date(want) if receiver_field is None else receiver_field
        dec = comps.declination_rad if rx is field else _along(df, rx).declination_rad
        return pd.DataFrame(
            {
                "heading_mag_rad": psi_mag,
                "heading_rad": _mod_2pi(psi_mag + dec),
                "valve_heading_mag_rad": fv,
                "declination_rad": dec,
                "slaving": np.abs(roll) <= cutout,
            }
        )
