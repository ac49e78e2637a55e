"""sin_cos against numpy's double-precision sin and cos, arctan2 against numpy's arctan2 and
hypot against numpy's hypot: the bounds the docstring states, for angles in one turn either
way, far beyond it, every quadrant and magnitude, signed zeros and missing values."""

import numpy as np
import pytest

from aerotruth.analysis.wind.fast_trig import arctan2, hypot, sin_cos


def test_within_the_stated_bound_of_double_precision_for_any_angle():
    rng = np.random.default_rng(5)
    for lo, hi, bound in ((-2 * np.pi, 2 * np.pi, 3e-16), (-1e5, 1e5, 3e-16), (-1e7, 1e7, 2e-16 * 1e7)):
        x = rng.uniform(lo, hi, 200_000)  # the last: wrapped first
        s, c = sin_cos(x)
        assert s.dtype == np.float64 and c.dtype == np.float64
        assert np.max(np.abs(s - np.sin(x))) < bound and np.max(np.abs(c - np.cos(x))) < bound
    # the quadrants' seams, exactly where numpy is exact
    x = np.array([0.0, np.pi / 2, np.pi, 3 * np.pi / 2, -np.pi / 2, np.pi / 4])
    s, c = sin_cos(x)
    assert np.max(np.abs(s - np.sin(x))) < 3e-16 and np.max(np.abs(c - np.cos(x))) < 3e-16


def test_keeps_shape_and_missing_values():
    x = np.array([[0.0, np.nan], [np.pi / 2, 1e5]])
    s, c = sin_cos(x)
    assert s.shape == (2, 2) and np.isnan(s[0, 1]) and np.isnan(c[0, 1])
    assert abs(s[1, 0] - 1.0) < 3e-16 and abs(c[0, 0] - 1.0) < 3e-16
    assert abs(s[1, 1] - np.sin(1e5)) < 3e-16
    assert sin_cos(np.array([]))[0].shape == (0,)
    assert sin_cos(0.5)[0].shape == () and abs(sin_cos(0.5)[1] - np.cos(0.5)) < 3e-16
    assert np.isnan(sin_cos(np.array([np.inf, -np.inf]))[0]).all()


def test_arctan2_within_its_bound_in_every_quadrant_and_magnitude():
    rng = np.random.default_rng(11)
    n = 400_000
    y = rng.standard_normal(n) * 10 ** rng.uniform(-8, 8, n)
    x = rng.standard_normal(n) * 10 ** rng.uniform(-8, 8, n)
    a = arctan2(y, x)
    assert a.dtype == np.float64 and a.shape == (n,)
    assert np.max(np.abs(a - np.arctan2(y, x))) < 1.2e-14
    # the reduction's seams: |y| = |x| tan(pi/8), |y| = |x|, the axes
    t = np.tan(np.pi / 8)
    ys = np.array([t, t * (1 + 1e-15), 1.0, 1.0, 0.0, 3.0, -t, -1.0])
    xs = np.array([1.0, 1.0, 1.0, -1.0, -2.0, 0.0, -1.0, -1.0])
    assert np.max(np.abs(arctan2(ys, xs) - np.arctan2(ys, xs))) < 1.2e-14


def test_arctan2_signed_zeros_missing_values_shape_and_overlapping_output():
    y = np.array([0.0, -0.0, 0.0, -0.0, 0.0, np.nan, 1.0, np.nan])
    x = np.array([1.0, 1.0, -1.0, -1.0, 0.0, 1.0, np.nan, np.nan])
    a, b = arctan2(y, x), np.arctan2(y, x)
    assert np.array_equal(a, b, equal_nan=True)
    assert np.array_equal(np.signbit(a), np.signbit(b))
    m = np.arange(12.0).reshape(3, 4) - 5
    assert arctan2(m, m.T.copy().reshape(3, 4)).shape == (3, 4)
    yy = np.linspace(-3, 3, 1001)
    xx = np.cos(yy)
    want = np.arctan2(yy, xx)
    got = arctan2(yy, xx, out=yy)  # in place over an input
    assert got is yy and np.max(np.abs(got - want)) < 1.2e-14
    with pytest.raises(ValueError, match="shape"):
        arctan2(np.zeros(3), np.zeros(4))


def test_hypot_as_numpy_for_speeds_and_distances():
    rng = np.random.default_rng(12)
    x, y = rng.normal(0, 300, 10_000), rng.normal(0, 300, 10_000)
    assert np.allclose(hypot(x, y), np.hypot(x, y), rtol=1e-15, atol=0)
    assert np.isnan(hypot(np.array([np.nan]), np.array([1.0]))[0])
