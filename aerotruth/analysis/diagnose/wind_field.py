"""The reference models' error as one field the fleet flies through, for `aerotruth diagnose`.

A weather model's analysis error is a field in space and time: aircraft that fly near each
other in the same hours see nearly the same error of that model (on aerotruth's own
simulated reports the error of one model at reports of two different flights within 50 km,
300 m and 15 min correlates ~0.8; between the two models at one report ~0.1). A per-aircraft
change (a recalibration's step, a drift) is then best measured against what the *other*
aircraft saw of the same field, not against the fleet's average over a 6-h block.

The field's covariance, per reference model and isotropic in its east and north components,

    Cov(f_i, f_j) = s_f^2 exp(-h_ij / L_h - |z_i - z_j| / L_z - |t_i - t_j| / L_t) I_2

(separable exponential: a product of valid kernels, so positive definite), is read off the
model's residual: the products of the residual's (east, north) vectors over pairs of rows
of *different aircraft*, same reference and same test unit, binned by horizontal distance
h, altitude and time apart; the kernel fitted to the bins' mean products by least squares
weighted by each bin's pair count (started from a log-linear fit of the bins with a clear
correlation).
Pairs of one aircraft are left out: its own errors (heading, airspeed) correlate along its
flights and are not the reference's. The rest of each channel's variance is the nugget.

Each row's field is then predicted from the other aircraft's rows of its unit and reference
(simple kriging on the residual, both channels, each row's (transverse, along) frame the
field's (east, north) rotated by its heading): f^_i = c_iN C_NN^-1 r_N over the M rows most
correlated with it. The tests' units (wind_data.dependence_units) bound it: where the
reference models' differences show no error shared between flights, the units are flights
and there is no field to predict (`fit_field_kernel` returns None).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import optimize

from aerotruth.analysis.diagnose.wind_data import WindData
from aerotruth.geo import enu
from aerotruth.units import FT

NEIGHBOURS = 16  # rows of other aircraft a row's field is predicted from (the most correlated)
MIN_PAIR_COUNT = 30  # pairs a bin needs before its mean product is used
MIN_CORR = 0.03  # a bin's correlation below this is not fitted (its log is noise)
MIN_SHARE = 0.05  # a field with less of the residual's variance than this is not used
MAX_SHARE = 0.99
# bin edges: horizontal distance (km), altitude apart (m), time apart (min); fine enough that the
# kernel varies little within a bin (the fit takes each bin's mean distances)
H_EDGES = np.array([0.0, 2.0, 5.0, 10.0, 20.0, 35.0, 50.0, 75.0, 100.0, 150.0, 200.0, 300.0, 400.0, np.inf])
Z_EDGES = np.array([0.0, 50.0, 100.0, 200.0, 350.0, 500.0, 750.0, 1000.0, 1500.0, 2000.0, 3000.0, 4000.0, np.inf])
T_EDGES = np.array([0.0, 2.0, 5.0, 10.0, 15.0, 22.0, 30.0, 45.0, 60.0, 90.0, 120.0, 180.0, 240.0, np.inf])


@dataclass(frozen=True)
class FieldKernel:
    """The reference error field's covariance (module docstring) and each channel's nugget
    (m/s)^2: what of the residual is not the field."""

    variance: float  # s_f^2, (m/s)^2 per component
    l_h_km: float
    l_z_m: float
    l_t_min: float
    nugget_transverse: float
    nugget_along: float
    share: float  # s_f^2 over the residual's variance per component
    pairs: int

    def params(self) -> dict:
        return {
            "field_rms_ms": math.sqrt(self.variance),
            "share": self.share,
            "horizontal_km": self.l_h_km,
            "vertical_m": self.l_z_m,
            "time_min": self.l_t_min,
            "pairs": self.pairs,
        }

    def correlation(self, h_km: np.ndarray, dz_m: np.ndarray, dt_min: np.ndarray) -> np.ndarray:
        return np.exp(-h_km / self.l_h_km - dz_m / self.l_z_m - dt_min / self.l_t_min)


def local_coordinates(d: WindData) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(east km, north km, altitude m, time min) of every row: east and north on the WGS-84
    tangent plane at the rows' mean position (geo.enu, at the ellipsoid), altitude as
    reported."""
    lat0, lon0 = float(np.mean(d.lat)), float(np.mean(d.lon))
    e, n, _ = enu(d.lat, d.lon, np.zeros(d.n), lat0, lon0, 0.0)
    return np.asarray(e) / 1000.0, np.asarray(n) / 1000.0, d.alt_ft * FT, d.time_s / 60.0


def unit_groups(d: WindData) -> list[np.ndarray]:
    """Row indices of each (reference, test unit), in time order."""
    key = d.source.astype(np.int64) * (int(d.cluster.max()) + 1) + d.cluster.astype(np.int64)
    order = np.lexsort((d.time_s, key))
    cuts = np.flatnonzero(np.diff(key[order])) + 1
    return [g for g in np.split(order, cuts) if len(g)]


def earth_components(d: WindData, resid: np.ndarray) -> np.ndarray:
    """(n, 2) east and north of the stacked (transverse, along) residual: transverse is the
    difference on (cos z, -sin z), along on (sin z, cos z) (wind.py's module docstring)."""
    t, a = resid[: d.n], resid[d.n :]
    c, s = np.cos(d.z), np.sin(d.z)
    return np.c_[t * c + a * s, -t * s + a * c]


def fit_field_kernel(d: WindData, resid: np.ndarray) -> FieldKernel | None:
    """The field's covariance from the model's residual (module docstring); None where the
    tests' units are flights (the data show no error shared between flights), where too few
    bins show a correlation, or where the field is less than MIN_SHARE of the residual."""
    if d.unit == "flight":
        return None
    x, y, z, t = local_coordinates(d)
    e = earth_components(d, resid)
    var = float(np.mean(e**2))
    if not var > 0:
        return None
    shape = (len(H_EDGES) - 1, len(Z_EDGES) - 1, len(T_EDGES) - 1)
    size = int(np.prod(shape))
    sums = np.zeros((4, size))  # product, h, dz, dt summed per bin
    count = np.zeros(size)
    for g in unit_groups(d):
        i, j = np.triu_indices(len(g), 1)
        i, j = g[i], g[j]
        other = d.aircraft[i] != d.aircraft[j]
        i, j = i[other], j[other]
        h = np.hypot(x[i] - x[j], y[i] - y[j])
        dz, dt = np.abs(z[i] - z[j]), np.abs(t[i] - t[j])
        b = np.ravel_multi_index(
            (
                np.searchsorted(H_EDGES, h, side="right") - 1,
                np.searchsorted(Z_EDGES, dz, side="right") - 1,
                np.searchsorted(T_EDGES, dt, side="right") - 1,
            ),
            shape,
        )
        prod = np.einsum("ij,ij->i", e[i], e[j]) / 2.0 / var
        for k, v in enumerate((prod, h, dz, dt)):
            sums[k] += np.bincount(b, weights=v, minlength=size)
        count += np.bincount(b, minlength=size)
    ok = count >= MIN_PAIR_COUNT
    if ok.sum() < 5:
        return None
    mean = sums[:, ok] / count[ok]
    r, h, dz, dt, w = mean[0], mean[1], mean[2], mean[3], np.sqrt(count[ok])
    # start: log-linear on the bins with a clear correlation; then the bins' means themselves
    # (every bin, noise and all, weighted by its pairs), so that bins near zero count as zero
    clear = r > MIN_CORR
    if clear.sum() < 4:
        return None
    X = np.c_[np.ones(clear.sum()), h[clear], dz[clear], dt[clear]]
    b0 = np.linalg.lstsq(X * w[clear, None], np.log(r[clear]) * w[clear], rcond=None)[0]
    start = np.r_[min(math.exp(b0[0]), MAX_SHARE), [1.0 / max(-b, 1e-6) for b in b0[1:]]]
    scale = np.array([1.0, 100.0, 1000.0, 100.0])  # km, m, min

    def misfit(q: np.ndarray) -> np.ndarray:
        c, lh, lz, lt = q * scale
        return w * (c * np.exp(-h / lh - dz / lz - dt / lt) - r)

    lo = np.array([0.0, 1.0, 10.0, 1.0]) / scale
    hi = np.array([MAX_SHARE, 1e5, 1e6, 1e5]) / scale
    sol = optimize.least_squares(misfit, np.clip(start / scale, lo * 1.001, hi * 0.999), bounds=(lo, hi))
    share, lh, lz, lt = sol.x * scale
    lengths = [float(lh), float(lz), float(lt)]
    if not sol.success or share < MIN_SHARE:
        return None
    sf2 = share * var
    m_t, m_a = float(np.mean(resid[: d.n] ** 2)), float(np.mean(resid[d.n :] ** 2))
    return FieldKernel(
        variance=sf2,
        l_h_km=lengths[0],
        l_z_m=lengths[1],
        l_t_min=lengths[2],
        nugget_transverse=max(m_t - sf2, 0.05 * m_t),
        nugget_along=max(m_a - sf2, 0.05 * m_a),
        share=share,
        pairs=int(count.sum()),
    )


def heading_frames(z: np.ndarray) -> np.ndarray:
    """(k, 2, 2): each row's (transverse, along) from (east, north)."""
    c, s = np.cos(z), np.sin(z)
    return np.stack([np.stack([c, -s], axis=-1), np.stack([s, c], axis=-1)], axis=-2)


def other_aircraft_field(
    d: WindData, resid: np.ndarray, kernel: FieldKernel, neighbours: int = NEIGHBOURS
) -> np.ndarray:
    """(2n,) each row's field in its (transverse, along) channels, stacked like the residual,
    predicted from the residual of the other aircraft's rows of its reference and unit (the
    `neighbours` most correlated; simple kriging, module docstring); 0 where no other
    aircraft flew in the unit."""
    x, y, z, t = local_coordinates(d)
    out = np.zeros(2 * d.n)
    for g in unit_groups(d):
        K = kernel.variance * kernel.correlation(
            np.hypot(x[g][:, None] - x[g][None, :], y[g][:, None] - y[g][None, :]),
            np.abs(z[g][:, None] - z[g][None, :]),
            np.abs(t[g][:, None] - t[g][None, :]),
        )
        R = heading_frames(d.z[g])
        rg = np.stack([resid[g], resid[d.n :][g]], axis=-1)  # (k, 2): the rows' (transverse, along)
        for a in np.unique(d.aircraft[g]):
            rows = np.flatnonzero(d.aircraft[g] == a)
            others = np.flatnonzero(d.aircraft[g] != a)
            m = min(neighbours, len(others))
            if m < 1:
                continue
            # each row's m most correlated rows of the other aircraft
            pick = np.argpartition(-K[np.ix_(rows, others)], m - 1, axis=1)[:, :m] if m < len(others) else None
            nb = others[pick] if pick is not None else np.broadcast_to(others, (len(rows), m))
            Rn = R[nb]  # (k, m, 2, 2)
            C = np.einsum("kiab,kjcb->kiajc", Rn, Rn) * K[nb[:, :, None], nb[:, None, :]][:, :, None, :, None]
            C = C.reshape(len(rows), 2 * m, 2 * m)
            diag = np.arange(2 * m)
            C[:, diag[0::2], diag[0::2]] += kernel.nugget_transverse
            C[:, diag[1::2], diag[1::2]] += kernel.nugget_along
            ci = np.einsum("kab,kjcb->kajc", R[rows], Rn) * K[rows[:, None], nb][:, None, :, None]
            ci = ci.reshape(len(rows), 2, 2 * m)
            f = np.einsum("kab,kb->ka", ci, np.linalg.solve(C, rg[nb].reshape(len(rows), 2 * m, 1))[..., 0])
            out[g[rows]] = f[:, 0]
            out[d.n + g[rows]] = f[:, 1]
    return out
