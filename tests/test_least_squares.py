"""analysis.least_squares.ols against numpy's SVD least squares: the same coefficients on a
well-posed tall design, and the minimum-norm solution when two columns coincide or one is zero throughout."""

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


def test_a_column_zero_on_every_row_gets_coefficient_zero_and_the_rest_their_fit():
    """A wind spline with no sample under it (a fold left out): the minimum-norm solution
    puts 0 on that column; the others are the fit without it (y built exactly from them)."""
    rng = np.random.default_rng(5)
    a, b = rng.normal(size=(2, 300))
    X = np.column_stack([a, np.zeros(300), b])
    coef, xtx = ols(X, 3.0 * a + 0.5 * b)
    assert coef == pytest.approx([3.0, 0.0, 0.5], abs=1e-12)
    assert xtx[1] == pytest.approx(np.zeros(3))
    # with a repeated column beside it the rest is still rank-deficient: minimum norm again
    coef, _ = ols(np.column_stack([a, np.zeros(300), a]), 2.0 * a)
    assert coef == pytest.approx([1.0, 0.0, 1.0], abs=1e-9)
