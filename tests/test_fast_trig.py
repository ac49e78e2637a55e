"""sin_cos against numpy's double-precision sin and cos: the bound its docstring states,
for angles in one turn either way, far beyond it, and with missing values."""

import numpy as np

from aerotruth.analysis.fast_trig import sin_cos


def test_within_the_stated_bound_of_double_precision_for_any_angle():
    rng = np.random.default_rng(5)
    for lo, hi in ((-2 * np.pi, 2 * np.pi), (-1e4, 1e4)):  # the second: wrapped first
        x = rng.uniform(lo, hi, 200_000)
        s, c = sin_cos(x)
        assert s.dtype == np.float64 and c.dtype == np.float64
        assert np.max(np.abs(s - np.sin(x))) < 3e-7 and np.max(np.abs(c - np.cos(x))) < 3e-7


def test_keeps_shape_and_missing_values():
    x = np.array([[0.0, np.nan], [np.pi / 2, 1e5]])
    s, c = sin_cos(x)
    assert s.shape == (2, 2) and np.isnan(s[0, 1]) and np.isnan(c[0, 1])
    assert abs(s[1, 0] - 1.0) < 3e-7 and abs(c[0, 0] - 1.0) < 3e-7
    assert abs(s[1, 1] - np.sin(1e5)) < 3e-7
    assert sin_cos(np.array([]))[0].shape == (0,)
