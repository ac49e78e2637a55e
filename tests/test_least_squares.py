"""analysis.least_squares.ols against numpy's SVD least squares: the same coefficients on a
well-posed tall design, and the minimum-norm solution when two columns coincide."""

import numpy as np
import pytest

from aerotruth.analysis.least_squares import ols


def test_well_posed_design_matches_the_svd_solution_and_returns_the_normal_matrix():
    rng = np.random.default_rng(3)
    X = rng.normal(size=(5000, 12)) * np.logspace(0, 3, 12)  # columns over three decades
    beta = rng.normal(size=12)
    y = X @ beta + rng.normal(scale=0.1, size=5000)
    coef, xtx = ols(X, y)
    ref, *_ = np.linalg.lstsq(X, y, rcond=None)
    assert coef == pytest.approx(ref, rel=1e-9, abs=1e-12)
    assert xtx == pytest.approx(X.T @ X)
    assert coef == pytest.approx(beta, abs=0.01)


def test_a_repeated_column_gets_the_minimum_norm_solution():
    rng = np.random.default_rng(4)
    a, b = rng.normal(size=(2, 400))
    X = np.column_stack([a, a, b])  # the first two columns identical: only their sum is identified
    y = 2.0 * a - b
    coef, _ = ols(X, y)
    # minimum norm splits the identified sum equally (by hand: argmin c1^2 + c2^2 with c1 + c2 = 2)
    assert coef == pytest.approx([1.0, 1.0, -1.0], abs=1e-9)
