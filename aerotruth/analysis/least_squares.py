"""Ordinary least squares through the normal matrix, which the callers also need for the
coefficients' covariance: formed once, solved directly when well posed (several times
faster than an SVD solve on the tall, narrow designs of the diagnose fits), and left to
the minimum-norm SVD solution near rank deficiency."""

from __future__ import annotations

import numpy as np

WELL_POSED_COND = 1e12  # condition number of X'X (= cond(X)^2) up to which the normal equations are solved


def ols(X: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(coefficients, X'X) of the least-squares fit of y on the columns of X."""
    xtx = X.T @ X
    if X.shape[1] and np.linalg.cond(xtx) < WELL_POSED_COND:
        return np.linalg.solve(xtx, X.T @ y), xtx
    coef, *_ = np.linalg.lstsq(X, y, rcond=None)
    return coef, xtx
