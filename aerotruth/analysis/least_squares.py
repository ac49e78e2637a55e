"""Ordinary least squares through the normal matrix, which the callers also need for the
coefficients' covariance: formed once, solved directly when well posed (several times
faster than an SVD solve on the tall, narrow designs of the diagnose fits), and left to
the minimum-norm SVD solution near rank deficiency. Columns that are zero on every row (a
wind spline with no sample under it once a fold or jackknife group is left out) get
coefficient 0, as in the minimum-norm solution, and the rest are solved on their own.
`clustered_se`: the cluster-robust (CR1) standard error of a one-parameter fit."""

from __future__ import annotations

import math

import numpy as np

WELL_POSED_COND = 1e12  # condition number of X'X (= cond(X)^2) up to which the normal equations are solved


def live_columns(xtx: np.ndarray) -> np.ndarray:
    """Mask of the columns of X that are not zero throughout, from X'X (a column's sum of
    squares is its diagonal entry)."""
    return np.diag(xtx) > 0


def ols(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(coefficients, X'X) of the least-squares fit of y on the columns of X."""
    xtx = X.T @ X
    live = live_columns(xtx)
    sub = xtx if live.all() else xtx[np.ix_(live, live)]
    if sub.shape[1] and np.linalg.cond(sub) < WELL_POSED_COND:
        coef = np.zeros(X.shape[1])
        coef[live] = np.linalg.solve(sub, (X.T @ y)[live])
        return coef, xtx
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return coef, xtx


def clustered_se(score: np.ndarray, groups: np.ndarray, scale: float) -> tuple[float, int]:
    """Standard error sqrt(G / (G - 1) sum_g (sum of `score` over group g)^2) / |scale| of an
    estimate whose linearised error is sum(score) / scale (for a slope b of y on x: score
    x (y - b x), scale sum x^2), and the number G of groups (non-negative integer codes);
    inf when G < 2."""
    sums = np.bincount(groups, score)
    g = int(np.count_nonzero(np.bincount(groups)))
    if g < 2:
        return math.inf, g
    return math.sqrt(float(sums @ sums) * g / (g - 1)) / abs(scale), g
