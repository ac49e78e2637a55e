"""The fit core of the wind paper's method (eq. 2 by robust regression): the design of
eq. 2, a Huber M-estimate with flight-cluster (CR3) standard errors, and its one-step
update from a nearby fit (`aerotruth.analysis.heading_correction` uses them per aircraft
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
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from aerotruth.analysis.fast_trig import sin_cos
from aerotruth.units import DEG


def design(heading_deg: np.ndarray, k: int) -> np.ndarray:
    """Columns of wind paper eq. 2: 1, sin z, cos z, sin 2z, cos 2z (first k of them), (n, k)."""
    return design_t(heading_deg, k).T


def design_t(heading_deg: np.ndarray, k: int) -> np.ndarray:
    """The design of eq. 2 transposed, (k, n) with contiguous rows: the fits' per-report
    products and reductions run along rows."""
    z = np.asarray(heading_deg, dtype=float) * DEG
    XT = np.empty((k, len(z)))
    XT[0] = 1.0
    if k > 1:
        XT[1], XT[2] = sin_cos(z)
        if k > 3:  # double-angle identities: two fewer trig evaluations
            sz, cz = XT[1], XT[2]
            XT[3], XT[4] = 2 * sz * cz, (cz - sz) * (cz + sz)
    return XT


@dataclass
class _Fit:
    beta: np.ndarray
    cov: np.ndarray
    scale: float
    influence: np.ndarray  # (G, k): B^-1 h_g per flight cluster
    groups: np.ndarray  # cluster label of each influence row


def cluster_starts(groups: np.ndarray) -> np.ndarray:
    return np.flatnonzero(np.r_[True, groups[1:] != groups[:-1]])


def robust_fit(X: np.ndarray, y: np.ndarray, w: np.ndarray, groups: np.ndarray, robust: bool = True,
               c: float = 1.345, max_iter: int = 50, beta0: np.ndarray | None = None) -> _Fit:
    """Huber M-estimate (or weighted least squares) with flight-cluster sandwich covariance
    on the (n, k) design X. Rows must be contiguous by `groups`."""
    return robust_fit_t(np.ascontiguousarray(X.T), y, w, groups, robust, c, max_iter, beta0)


def robust_fit_t(XT: np.ndarray, y: np.ndarray, w: np.ndarray, groups: np.ndarray, robust: bool = True,
                 c: float = 1.345, max_iter: int = 50, beta0: np.ndarray | None = None,
                 scale_guess: float = math.nan) -> _Fit:
    """robust_fit on the transposed (k, n) design, rows contiguous (as design_t gives);
    `scale_guess` (a nearby scale, e.g. with beta0 that of a related fit) only speeds up
    the first median."""
    beta, scale, r = huber_t(XT, y, w, robust, c, max_iter, beta0, scale_guess)
    starts = cluster_starts(groups)
    bread_g, scores = _cluster_parts(XT, r, w, starts, scale, c if robust else np.inf)
    infl, cov = _cr3(bread_g, scores)
    return _Fit(beta, cov, scale, infl, groups[starts])


def fit_from_t(XT: np.ndarray, y: np.ndarray, w: np.ndarray, groups: np.ndarray, beta: np.ndarray,
               scale_guess: float = math.nan, robust: bool = True, c: float = 1.345, tol_se: float = 0.1) -> _Fit:
    """The Huber fit of (XT, y, w) (as robust_fit_t) from a nearby start `beta`, as the
    one-step M-estimator (heading_correction's docstring, cross-model consistency): one Newton step of the
    estimating equations at the rows' own MAD scale, kept when the next step would move no
    coefficient by more than `tol_se` of its standard error, else iterated to convergence.
    The CR3 covariance of a kept step carries each flight's scores linearly to the new
    coefficients. `scale_guess` (a nearby scale) only speeds up the medians."""
    sw = np.sqrt(w)
    r = _weighted_residuals(beta, XT, y, sw, np.empty(len(y)))
    ar, scratch = np.abs(r), np.empty(len(r))
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
        _weighted_residuals(new, XT, y, sw, r)
        np.abs(r, out=ar)
        s2 = max(1.4826 * _median(ar, scratch, scale / 1.4826), 1e-9)
        np.clip(r, -c * s2, c * s2, out=r)
        r *= sw
        nxt = np.linalg.solve(bread * scale, XT @ r)  # as huber_t's Newton step (its B is not divided by s)
        if np.any(np.abs(nxt) > tol_se * np.sqrt(np.diag(cov))):
            return robust_fit_t(XT, y, w, groups, robust, c, beta0=new, scale_guess=s2)
    return _Fit(new, cov, scale, infl, groups[starts])


def _weighted_residuals(beta: np.ndarray, XT: np.ndarray, y: np.ndarray, sw: np.ndarray, out: np.ndarray) -> np.ndarray:
    """r = sqrt(w) (y - X b) into `out` (no fresh array), `sw` = sqrt(w)."""
    np.matmul(beta, XT, out=out)
    np.subtract(y, out, out=out)
    np.multiply(out, sw, out=out)
    return out


def _cluster_parts(XT: np.ndarray, r: np.ndarray, w: np.ndarray, starts: np.ndarray, scale: float,
                   cc: float) -> tuple[np.ndarray, np.ndarray]:
    """Per flight cluster g: B_g = sum x x^T w psi'(u) / s and h_g = sum x sqrt(w) psi(u),
    u = r / s, r = sqrt(w) (y - X b) (psi the Huber function clipped at cc)."""
    k, n = XT.shape
    u = r / scale
    psi = np.clip(u, -cc, cc)
    wb = w * (np.abs(u) <= cc) / scale  # B's weights: psi'(u) w / s
    swpsi = np.sqrt(w)
    swpsi *= psi
    G = len(starts)
    # B_g (upper triangle) and h_g, one product at a time in reused buffers (no fresh
    # (k(k+1)/2, n) arrays: 5x faster here)
    bread_g = np.empty((G, k, k))
    scores = np.empty((G, k))
    buf, xw = np.empty(n), np.empty(n)
    for i in range(k):
        np.multiply(XT[i], wb, out=xw)
        for j in range(i, k):
            bread_g[:, i, j] = bread_g[:, j, i] = np.add.reduceat(np.multiply(xw, XT[j], out=buf), starts)
        scores[:, i] = np.add.reduceat(np.multiply(XT[i], swpsi, out=buf), starts)
    return bread_g, scores


def _cr3(bread_g: np.ndarray, scores: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Leave-one-flight-out influences q_g = (B - B_g)^-1 h_g (CR3, the linearised cluster
    jackknife: the plain sandwich undercovers with ~40 flights of unequal size) and the
    covariance (G-1)/G sum q_g q_g^T."""
    G = len(bread_g)
    bread = bread_g.sum(axis=0)
    loo = bread[None, :, :] - bread_g
    try:
        infl = np.linalg.solve(loo, scores[:, :, None])[:, :, 0] if G > 1 else scores @ np.linalg.pinv(bread).T
    except np.linalg.LinAlgError:  # a flight the rest cannot do without: its plain sandwich term
        infl = np.einsum("gij,gj->gi", np.linalg.pinv(loo), scores)
    cov = infl.T @ infl * ((G - 1) / G if G > 1 else 1.0)
    return infl, cov


def _median(x: np.ndarray, scratch: np.ndarray, guess: float = math.nan, width: float = 0.05) -> float:
    """np.median of a finite 1-D array without its generic machinery (a third of an iteration's
    time): the middle element, or the mean of the two middle ones. `scratch` (same length)
    is partitioned in place, x left as it is. With a `guess` (the previous iteration's
    median) only the values within `width` of it are partitioned, after counting those
    below: the same order statistics, 10x cheaper; a guess that misses falls back."""
    n = len(x)
    h = n // 2
    mid = h if n % 2 else (h - 1, h)
    if guess > 0:
        lo, hi = guess * (1 - width), guess * (1 + width)
        inside = np.greater_equal(x, lo, out=scratch.view(np.uint8)[:n].view(bool))
        inside &= x <= hi
        n_lo = np.count_nonzero(x < lo)
        sub = x[inside]
        if n_lo <= h - (n % 2 == 0) and h - n_lo < len(sub):
            if n % 2:
                sub.partition(h - n_lo)
                return float(sub[h - n_lo])
            sub.partition((h - 1 - n_lo, h - n_lo))
            return float(0.5 * (sub[h - 1 - n_lo] + sub[h - n_lo]))
    np.copyto(scratch, x)
    scratch.partition(mid)
    return float(scratch[h]) if n % 2 else float(0.5 * (scratch[h - 1] + scratch[h]))


_NEWTON_STEPS = 20  # then IRLS (module docstring)
_NEWTON_MAX_COND = 1e10  # a Newton matrix worse conditioned than this: the unclipped reports do not span the terms


def huber_t(XT: np.ndarray, y: np.ndarray, w: np.ndarray, robust: bool, c: float, max_iter: int = 50,
             beta0: np.ndarray | None = None, scale_guess: float = math.nan) -> tuple[np.ndarray, float, np.ndarray]:
    """Huber M-estimate on the transposed (k, n) design (module docstring: Newton steps,
    IRLS as the fallback): coefficients, the final MAD scale and the weighted residuals
    sqrt(w) (y - X b) at the solution. Normal equations (k <= 5 bounded columns: well conditioned
    whenever the coverage gate passes). The per-report work runs in buffers allocated once per fit (fresh
    arrays each step cost more in page faults than the arithmetic)."""
    k, n = XT.shape
    XW = np.empty((k, n))
    r, ar, wt, tmp = np.empty(n), np.empty(n), np.empty(n), np.empty(n)
    gram_w = None  # X^T W X over every report

    def solve(weights):  # weighted least squares: b and X^T W X
        np.multiply(XT, weights, out=XW)
        A = XW @ XT.T
        return np.linalg.solve(A, XW @ y), A

    def residuals(b):  # r = sqrt(w) (y - X b), ar = |r|
        _weighted_residuals(b, XT, y, sw, r)
        np.abs(r, out=ar)

    if beta0 is None:
        beta, gram_w = solve(w)
    else:
        beta = beta0
    sw = np.sqrt(w)
    newton = robust
    mad = scale_guess / 1.4826  # the previous median: NaN (none) at first unless a scale is guessed
    for i in range(max_iter if robust else 0):
        residuals(beta)
        mad = _median(ar, tmp, mad)
        cs = c * max(1.4826 * mad, 1e-9)  # c s
        new = None
        if newton and i < _NEWTON_STEPS:
            # B^-1 h: B over the unclipped reports (all of them less the clipped fifth: a
            # third of the work of summing the unclipped), h = s sum x sqrt(w) psi(u)
            if gram_w is None:
                np.multiply(XT, w, out=XW)
                gram_w = XW @ XT.T
            out = np.flatnonzero(ar > cs)
            Xc = XT[:, out]
            B = gram_w - (Xc * w[out]) @ Xc.T
            if np.linalg.cond(B) < _NEWTON_MAX_COND:  # by difference: singular shows as a huge condition
                np.clip(r, -cs, cs, out=tmp)
                np.multiply(tmp, sw, out=tmp)
                new = beta + np.linalg.solve(B, XT @ tmp)
            else:
                newton = False
        if new is None:  # IRLS step
            np.maximum(ar, 1e-300, out=wt)
            np.divide(cs, wt, out=wt)
            np.minimum(wt, 1.0, out=wt)
            np.multiply(wt, w, out=wt)
            new = solve(wt)[0]
        done = np.max(np.abs(new - beta)) < 1e-5  # deg: far below any standard error
        beta = new
        if done:
            break
    residuals(beta)
    scale = max(1.4826 * _median(ar, tmp, mad), 1e-9)
    return beta, scale, r
