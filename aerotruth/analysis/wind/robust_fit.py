"""The fit core of the wind paper's method (eq. 2 by robust regression): the design of
eq. 2, a Huber M-estimate with flight-cluster (CR3) standard errors, and its one-step
update from a nearby fit (`aerotruth.analysis.wind.heading_correction` uses them per aircraft
and per reference model).

Robust loss: Huber M-estimate, psi(u) = clip(u, -c, c) on u_i = sqrt(w_i) r_i / s,
c = 1.345 (95 % efficiency under Gaussian noise), scale s = 1.4826 MAD re-estimated each
iteration. Solved by Newton steps on the estimating equations sum_i x_i sqrt(w_i) psi(u_i)
= 0, b += B^-1 h with B = sum over |u_i| <= c of x_i x_i^T w_i and h = s sum_i x_i sqrt(w_i)
psi(u_i) (the Huber loss is piecewise quadratic, so a step is exact once the set of clipped
reports stops changing): 2.0 steps per fit from the least-squares start against IRLS's
4.1 on the method benchmark (12 aircraft x 1000 flights), coefficients equal to 1.6e-6 deg
(the same fixed point; IRLS takes over if a step's matrix is singular, condition number
> 1e10, or Newton has not converged in 20 steps). Where the unclipped reports
leave a term nearly unidentified (nearly all on one heading) the joint iteration of b and
s can have several fixed points and the two algorithms may stop at different ones.
Standard errors: cluster-robust sandwich with whole flights as clusters
(reference-model errors are correlated along a flight) in its jackknife form (CR3):
cov = (G-1)/G sum_g q_g q_g^T, q_g = (B - B_g)^-1 h_g, B = sum_i x_i x_i^T w_i psi'(u_i)/s,
B_g the same over flight g, h_g = sum_{i in g} x_i sqrt(w_i) psi(u_i) (the plain sandwich
B^-1 h_g undercovers by 5-10 % in se with ~40 flights of unequal size, measured).

The per-report sums (residuals, the median's window, a Newton step's B and h, the flight
clusters' B_g and h_g) are compiled loops (numba), one pass over the reports each: as numpy
expressions they took ~40 passes per Newton step and cluster sum, two thirds of the method's
time (`benchmarks/method_speed.py`). Same formulas, same fixed point; only the order of the
floating-point sums differs.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit

from aerotruth.analysis.wind.fast_trig import sincos_scalar
from aerotruth.units import DEG


def design(heading_deg: np.ndarray, k: int) -> np.ndarray:
    """Columns of wind paper eq. 2: 1, sin z, cos z, sin 2z, cos 2z (first k of them), (n, k)."""
    return design_t(heading_deg, k).T


def design_t(heading_deg: np.ndarray, k: int) -> np.ndarray:
    """The design of eq. 2 transposed, (k, n) with contiguous rows: the fits' per-report
    products and reductions run along rows. k is 1, 3 or 5."""
    if k not in (1, 3, 5):
        raise ValueError(f"design: k is 1, 3 or 5 terms, got {k}")
    z = np.ascontiguousarray(heading_deg, dtype=float).reshape(-1)
    XT = np.empty((k, len(z)))
    _design(z, XT)
    return XT


@njit(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")
def _design(z_deg: np.ndarray, XT: np.ndarray) -> None:
    k = XT.shape[0]
    for i in range(len(z_deg)):
        XT[0, i] = 1.0
        if k > 1:
            sz, cz = sincos_scalar(z_deg[i] * DEG)
            XT[1, i], XT[2, i] = sz, cz
            if k > 3:  # double-angle identities: no second evaluation
                XT[3, i], XT[4, i] = 2 * sz * cz, (cz - sz) * (cz + sz)


@dataclass
class _Fit:
    beta: np.ndarray
    cov: np.ndarray
    scale: float
    influence: np.ndarray  # (G, k): B^-1 h_g per flight cluster
    groups: np.ndarray  # cluster label of each influence row


def cluster_starts(groups: np.ndarray) -> np.ndarray:
    """Indices where a new cluster label starts (rows contiguous by cluster)."""
    new = np.empty(len(groups), dtype=bool)
    new[:1] = True
    np.not_equal(groups[1:], groups[:-1], out=new[1:])
    return np.flatnonzero(new)


def robust_fit(
    X: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    groups: np.ndarray,
    robust: bool = True,
    c: float = 1.345,
    max_iter: int = 50,
    beta0: np.ndarray | None = None,
) -> _Fit:
    """Huber M-estimate (or weighted least squares) with flight-cluster sandwich covariance
    on the (n, k) design X. Rows must be contiguous by `groups`."""
    return robust_fit_t(np.ascontiguousarray(X.T), y, w, groups, robust, c, max_iter, beta0)


def robust_fit_t(
    XT: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    groups: np.ndarray,
    robust: bool = True,
    c: float = 1.345,
    max_iter: int = 50,
    beta0: np.ndarray | None = None,
    scale_guess: float = math.nan,
) -> _Fit:
    """robust_fit on the transposed (k, n) design, rows contiguous (as design_t gives);
    `scale_guess` (a nearby scale, e.g. with beta0 that of a related fit) only speeds up
    the first median."""
    beta, scale, r = huber_t(XT, y, w, robust, c, max_iter, beta0, scale_guess)
    starts = cluster_starts(groups)
    bread_g, scores = _cluster_parts(XT, r, w, starts, scale, c if robust else np.inf)
    infl, cov = _cr3(bread_g, scores)
    return _Fit(beta, cov, scale, infl, groups[starts])


def fit_from_t(
    XT: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    groups: np.ndarray,
    beta: np.ndarray,
    scale_guess: float = math.nan,
    robust: bool = True,
    c: float = 1.345,
    tol_se: float = 0.1,
) -> _Fit:
    """The Huber fit of (XT, y, w) (as robust_fit_t) from a nearby start `beta`, as the
    one-step M-estimator (heading_correction's docstring, cross-model consistency): one Newton step of the
    estimating equations at the rows' own MAD scale, kept when the next step would move no
    coefficient by more than `tol_se` of its standard error, else iterated to convergence.
    The CR3 covariance of a kept step carries each flight's scores linearly to the new
    coefficients. `scale_guess` (a nearby scale) only speeds up the medians."""
    sw = np.sqrt(w)
    r, ar, scratch = np.empty(len(y)), np.empty(len(y)), np.empty(len(y))
    _residuals(beta, XT, y, sw, r, ar)
    scale = max(1.4826 * _median(ar, scratch, scale_guess / 1.4826), 1e-9)
    starts = cluster_starts(groups)
    bread_g, scores = _cluster_parts(XT, r, w, starts, scale, c if robust else np.inf)
    bread = bread_g.sum(axis=0)
    try:
        step = np.linalg.solve(bread, scores.sum(axis=0))
    except np.linalg.LinAlgError:
        return robust_fit_t(XT, y, w, groups, robust, c, beta0=beta, scale_guess=scale)
    new = beta + step
    scores -= bread_g @ step  # h_g(b + step) = h_g(b) - B_g step: the scores sum to 0 again
    infl, cov = _cr3(bread_g, scores)
    if robust:  # the next step, at the new coefficients and scale: B over the same reports
        _residuals(new, XT, y, sw, r, ar)
        s2 = max(1.4826 * _median(ar, scratch, scale / 1.4826), 1e-9)
        np.clip(r, -c * s2, c * s2, out=r)
        r *= sw
        nxt = np.linalg.solve(bread * scale, XT @ r)  # as huber_t's Newton step (its B is not divided by s)
        if np.any(np.abs(nxt) > tol_se * np.sqrt(np.diag(cov))):
            return robust_fit_t(XT, y, w, groups, robust, c, beta0=new, scale_guess=s2)
    return _Fit(new, cov, scale, infl, groups[starts])


# The per-report sums are compiled for the five columns of eq. 2 (a fit of k < 5 terms
# passes zero rows for the others: its sums there are 0), each in local scalars; reassociation
# lets the compiler run them in SIMD lanes (4x: the order of the additions is the compiler's,
# fixed for a build and CPU; results never depend on the data's split into workers).
MAX_TERMS = 5
_FAST = {"reassoc", "contract"}  # not "nnan"/"ninf": cc is inf for least squares


def _rows(XT: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The k rows of a (k, n) design and 5 - k zero rows: the kernels' five columns."""
    k, n = XT.shape
    if k > MAX_TERMS:
        raise ValueError(f"design: at most {MAX_TERMS} terms, got {k}")
    rows = [XT[a] for a in range(k)]
    if k < MAX_TERMS:
        rows += [np.zeros(n)] * (MAX_TERMS - k)  # one zero row, shared
    return rows[0], rows[1], rows[2], rows[3], rows[4]


@njit(cache=True, nogil=True, fastmath=_FAST, error_model="numpy")
def _residuals5(
    b0: float,
    b1: float,
    b2: float,
    b3: float,
    b4: float,
    x0: np.ndarray,
    x1: np.ndarray,
    x2: np.ndarray,
    x3: np.ndarray,
    x4: np.ndarray,
    y: np.ndarray,
    sw: np.ndarray,
    r: np.ndarray,
    ar: np.ndarray,
) -> None:
    for i in range(len(y)):
        v = (y[i] - (b0 * x0[i] + b1 * x1[i] + b2 * x2[i] + b3 * x3[i] + b4 * x4[i])) * sw[i]
        r[i] = v
        ar[i] = abs(v)


def _residuals(beta: np.ndarray, XT: np.ndarray, y: np.ndarray, sw: np.ndarray, r: np.ndarray, ar: np.ndarray) -> None:
    """r = sqrt(w) (y - X b) and ar = |r| into the given arrays, `sw` = sqrt(w)."""
    b = np.zeros(MAX_TERMS)
    b[: len(beta)] = beta
    _residuals5(b[0], b[1], b[2], b[3], b[4], *_rows(XT), y, sw, r, ar)


@njit(cache=True, nogil=True, fastmath=_FAST, error_model="numpy")
def _sums5(
    x0: np.ndarray,
    x1: np.ndarray,
    x2: np.ndarray,
    x3: np.ndarray,
    x4: np.ndarray,
    r: np.ndarray,
    w: np.ndarray,
    sw: np.ndarray,
    cut: float,
    scale: float,
    out: np.ndarray,
) -> None:
    """Over the reports, with u = r / scale: the 15 sums of x_a x_b w / scale over
    |u| <= cut (a <= b, row-major) and the 5 sums of x_a sqrt(w) clip(u, -cut, cut), into
    out[:15] and out[15:20]."""
    b00 = b01 = b02 = b03 = b04 = b11 = b12 = b13 = b14 = b22 = b23 = b24 = b33 = b34 = b44 = 0.0
    h0 = h1 = h2 = h3 = h4 = 0.0
    inv = 1.0 / scale
    for i in range(len(r)):  # (over range(lo, hi) the compiler leaves the loop scalar: 8x slower)
        u = r[i] * inv
        q = w[i] * inv if abs(u) <= cut else 0.0
        p = min(max(u, -cut), cut) * sw[i]
        z0, z1, z2, z3, z4 = x0[i], x1[i], x2[i], x3[i], x4[i]
        h0 += z0 * p
        h1 += z1 * p
        h2 += z2 * p
        h3 += z3 * p
        h4 += z4 * p
        y0, y1, y2, y3, y4 = z0 * q, z1 * q, z2 * q, z3 * q, z4 * q
        b00 += y0 * z0
        b01 += y0 * z1
        b02 += y0 * z2
        b03 += y0 * z3
        b04 += y0 * z4
        b11 += y1 * z1
        b12 += y1 * z2
        b13 += y1 * z3
        b14 += y1 * z4
        b22 += y2 * z2
        b23 += y2 * z3
        b24 += y2 * z4
        b33 += y3 * z3
        b34 += y3 * z4
        b44 += y4 * z4
    out[0], out[1], out[2], out[3], out[4] = b00, b01, b02, b03, b04
    out[5], out[6], out[7], out[8], out[9] = b11, b12, b13, b14, b22
    out[10], out[11], out[12], out[13], out[14] = b23, b24, b33, b34, b44
    out[15], out[16], out[17], out[18], out[19] = h0, h1, h2, h3, h4


@njit(cache=True, nogil=True, error_model="numpy")
def _cluster_sums5(
    x0: np.ndarray,
    x1: np.ndarray,
    x2: np.ndarray,
    x3: np.ndarray,
    x4: np.ndarray,
    r: np.ndarray,
    w: np.ndarray,
    sw: np.ndarray,
    cut: float,
    scale: float,
    starts: np.ndarray,
) -> np.ndarray:
    G, n = len(starts), len(r)
    out = np.empty((G, 20))
    for g in range(G):
        a, b = starts[g], starts[g + 1] if g + 1 < G else n
        _sums5(x0[a:b], x1[a:b], x2[a:b], x3[a:b], x4[a:b], r[a:b], w[a:b], sw[a:b], cut, scale, out[g])
    return out


# position of B[a, b] in _sums5's 15 upper-triangle sums (row-major), for every a, b
_SYM = np.array(
    [
        [
            a * MAX_TERMS - a * (a - 1) // 2 + b - a if a <= b else b * MAX_TERMS - b * (b - 1) // 2 + a - b
            for b in range(MAX_TERMS)
        ]
        for a in range(MAX_TERMS)
    ]
)


def _unpack(sums: np.ndarray, k: int) -> tuple[np.ndarray, np.ndarray]:
    """(..., 20) sums of _sums5 -> the symmetric (..., k, k) matrices and (..., k) vectors."""
    return sums[..., _SYM[:k, :k]], sums[..., 15 : 15 + k].copy()


def _weighted_sums(
    XT: np.ndarray, r: np.ndarray, w: np.ndarray, sw: np.ndarray, cut: float, scale: float
) -> tuple[np.ndarray, np.ndarray]:
    """_sums5 as (B, h): B = sum over |r / scale| <= cut of x x^T w / scale (k x k),
    h = sum x sqrt(w) clip(r / scale, -cut, cut)."""
    out = np.empty(20)
    _sums5(*_rows(XT), r, w, sw, cut, scale, out)
    return _unpack(out, XT.shape[0])


def _newton_system(
    XT: np.ndarray, r: np.ndarray, w: np.ndarray, sw: np.ndarray, cs: float
) -> tuple[np.ndarray, np.ndarray]:
    """A Newton step's B = sum over the unclipped reports (|r_i| <= c s) of x x^T w and
    h = sum x sqrt(w) clip(r, -c s, c s) (module docstring), r = sqrt(w) (y - X b)."""
    B, h = _weighted_sums(XT, r, w, sw, 1.0, cs)  # u = r / (c s) clipped at 1: times c s
    return B * cs, h * cs


def _wls(XT: np.ndarray, y: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Weighted least squares: b solving X^T W X b = X^T W y, the sums in one pass (r = sqrt(w)
    y, nothing clipped)."""
    sw = np.sqrt(w)
    return np.linalg.solve(*_weighted_sums(XT, y * sw, w, sw, np.inf, 1.0))


def weighted_gram_t(XT: np.ndarray, w: np.ndarray) -> np.ndarray:
    """X^T W X of the transposed (k, n) design, weights w: one compiled pass."""
    zero = np.zeros(len(w))
    return _weighted_sums(XT, zero, w, zero, np.inf, 1.0)[0]


def _cluster_parts(
    XT: np.ndarray, r: np.ndarray, w: np.ndarray, starts: np.ndarray, scale: float, cc: float
) -> tuple[np.ndarray, np.ndarray]:
    """Per flight cluster g: B_g = sum x x^T w psi'(u) / s and h_g = sum x sqrt(w) psi(u),
    u = r / s, r = sqrt(w) (y - X b) (psi the Huber function clipped at cc)."""
    sums = _cluster_sums5(*_rows(XT), r, w, np.sqrt(w), float(cc), float(scale), starts.astype(np.int64))
    return _unpack(sums, XT.shape[0])


def _cr3(bread_g: np.ndarray, scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Leave-one-flight-out influences q_g = (B - B_g)^-1 h_g (CR3, the linearised cluster
    jackknife: the plain sandwich undercovers with ~40 flights of unequal size) and the
    covariance (G-1)/G sum q_g q_g^T. B - B_g is symmetric positive definite unless flight g
    carries a term alone: solved by Cholesky (compiled), else as a general system."""
    G = len(bread_g)
    bread = bread_g.sum(axis=0)
    infl = np.empty(scores.shape)
    if G < 2 or not _loo_cholesky(bread, bread_g, scores, infl):
        loo = bread[None, :, :] - bread_g
        try:
            infl = np.linalg.solve(loo, scores[:, :, None])[:, :, 0] if G > 1 else scores @ np.linalg.pinv(bread).T
        except np.linalg.LinAlgError:  # a flight the rest cannot do without: its plain sandwich term
            infl = np.einsum("gij,gj->gi", np.linalg.pinv(loo), scores)
    cov = infl.T @ infl * ((G - 1) / G if G > 1 else 1.0)
    return infl, cov


@njit(cache=True, nogil=True, error_model="numpy")
def _loo_cholesky(bread: np.ndarray, bread_g: np.ndarray, scores: np.ndarray, out: np.ndarray) -> bool:
    """out[g] = (B - B_g)^-1 h_g by Cholesky factorisation, each g; False (out unfinished)
    as soon as one B - B_g is not numerically positive definite (a pivot below 1e-12 of
    its diagonal)."""
    G, k = scores.shape
    L = np.empty((k, k))
    z = np.empty(k)
    for g in range(G):
        for i in range(k):
            for j in range(i + 1):
                v = bread[i, j] - bread_g[g, i, j]
                for m in range(j):
                    v -= L[i, m] * L[j, m]
                if i == j:
                    if not v > 1e-12 * (bread[i, i] - bread_g[g, i, i]):
                        return False
                    L[i, i] = np.sqrt(v)
                else:
                    L[i, j] = v / L[j, j]
        for i in range(k):  # L z = h
            v = scores[g, i]
            for m in range(i):
                v -= L[i, m] * z[m]
            z[i] = v / L[i, i]
        for i in range(k - 1, -1, -1):  # L^T q = z
            v = z[i]
            for m in range(i + 1, k):
                v -= L[m, i] * out[g, m]
            out[g, i] = v / L[i, i]
    return True


def median(x: np.ndarray) -> float:
    """np.median of a finite 1-D array (_median: a partition, without np.median's machinery)."""
    return _median(np.asarray(x, dtype=float), np.empty(len(x)))


def _median(x: np.ndarray, scratch: np.ndarray, guess: float = math.nan, width: float = 0.05) -> float:
    """np.median of a finite 1-D array without its generic machinery (a third of an iteration's
    time): the middle element, or the mean of the two middle ones. `scratch` (same length)
    is partitioned in place, x left as it is. With a `guess` (the previous iteration's
    median) only the values within `width` of it are partitioned, after counting those
    below: the same order statistics, 10x cheaper; a guess that misses falls back. Without
    a guess, a large array takes the median of every 64th value as one, 10 % wide."""
    n = len(x)
    h = n // 2
    mid = h if n % 2 else (h - 1, h)
    if not guess > 0 and n >= 64 * 200:
        guess, width = float(np.median(x[::64])), 0.1
    if guess > 0:
        n_lo, m = _window(x, guess * (1 - width), guess * (1 + width), scratch)
        if n_lo <= h - (n % 2 == 0) and h - n_lo < m:
            sub = scratch[:m]
            if n % 2:
                sub.partition(h - n_lo)
                return float(sub[h - n_lo])
            sub.partition((h - 1 - n_lo, h - n_lo))
            return float(0.5 * (sub[h - 1 - n_lo] + sub[h - n_lo]))
    np.copyto(scratch, x)
    scratch.partition(mid)
    return float(scratch[h]) if n % 2 else float(0.5 * (scratch[h - 1] + scratch[h]))


@njit(cache=True, nogil=True, error_model="numpy")
def _window(x: np.ndarray, lo: float, hi: float, out: np.ndarray) -> tuple[int, int]:
    """The count of x below lo, and the m values of x within [lo, hi] into out[:m]: (count, m).
    Without branches (a data-dependent branch mispredicts on every few values): each value
    is written at out[m] and kept by advancing m."""
    n_lo = 0
    m = 0
    for v in x:
        n_lo += v < lo
        out[m] = v
        m += (v >= lo) & (v <= hi)
    return n_lo, m


_NEWTON_STEPS = 20  # then IRLS (module docstring)
_NEWTON_MAX_COND = 1e10  # a Newton matrix worse conditioned than this: the unclipped reports do not span the terms


def huber_t(
    XT: np.ndarray,
    y: np.ndarray,
    w: np.ndarray,
    robust: bool,
    c: float,
    max_iter: int = 50,
    beta0: np.ndarray | None = None,
    scale_guess: float = math.nan,
) -> tuple[np.ndarray, float, np.ndarray]:
    """Huber M-estimate on the transposed (k, n) design (module docstring: Newton steps,
    IRLS as the fallback): coefficients, the final MAD scale and the weighted residuals
    sqrt(w) (y - X b) at the solution. Normal equations (k <= 5 bounded columns: well conditioned
    whenever the coverage gate passes). The per-report work runs in buffers allocated once per fit (fresh
    arrays each step cost more in page faults than the arithmetic)."""
    n = XT.shape[1]
    r, ar, tmp = np.empty(n), np.empty(n), np.empty(n)
    sw = np.sqrt(w)
    beta = _wls(XT, y, w) if beta0 is None else beta0  # the least-squares start

    def residuals(b):  # r = sqrt(w) (y - X b), ar = |r|
        _residuals(b, XT, y, sw, r, ar)

    newton = robust
    mad = scale_guess / 1.4826  # the previous median: NaN (none) at first unless a scale is guessed
    for i in range(max_iter if robust else 0):
        residuals(beta)
        mad = _median(ar, tmp, mad)
        cs = c * max(1.4826 * mad, 1e-9)  # c s
        new = None
        if newton and i < _NEWTON_STEPS:
            # B^-1 h: B = sum over the unclipped reports of x x^T w, h = s sum x sqrt(w) psi(u)
            B, hs = _newton_system(XT, r, w, sw, cs)
            lam = np.linalg.eigvalsh(B)  # B is symmetric: its condition number from the eigenvalues
            if lam[0] > 0 and lam[-1] < _NEWTON_MAX_COND * lam[0]:  # singular shows as a huge condition
                new = beta + np.linalg.solve(B, hs)
            else:
                newton = False
        if new is None:  # IRLS step: weights w min(1, c s / |r|)
            new = _wls(XT, y, np.minimum(cs / np.maximum(ar, 1e-300), 1.0) * w)
        done = np.max(np.abs(new - beta)) < 1e-5  # deg: far below any standard error
        beta = new
        if done:
            break
    residuals(beta)
    scale = max(1.4826 * _median(ar, tmp, mad), 1e-9)
    return beta, scale, r
