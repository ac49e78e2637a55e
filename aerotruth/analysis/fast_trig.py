"""Sine, cosine and arctangent of reported quantities at vector speed.

numpy's float64 sin/cos run a scalar loop here (~15 ms per million values, numpy 2.4 on
x86-64), its float32 ones a SIMD loop (~0.5 ms). The wind method takes the sines and
cosines of reported angles (wind directions to 1 deg, headings to 0.1 deg, positions to
0.01 deg): evaluated in float32 and returned as float64, each value is off by at most
~2.6e-7 (measured over 2 million uniform angles in [-2 pi, 2 pi]: 2.5e-7 for sin, 2.6e-7
for cos; the float32 rounding of the argument dominates), i.e. an angle error of 1.5e-5 deg,
three orders below the coarsest of those resolutions. Angles beyond 2 pi in magnitude are
first wrapped to [-pi, pi) in float64, so the bound holds for any argument.

numpy's arctan2 calls the C library once per value in either precision (~35 ms per
million here, the largest single cost of the heading errors). `arctan2` below is compiled
(numba) and runs in SIMD lanes: the usual reduction to t = min(|y|, |x|) / max(|y|, |x|) in
[0, 1], then to |t| <= tan(pi/8) by atan(t) = pi/4 + atan((t - 1) / (t + 1)), and there
atan(t) = t P(t^2) with P of degree 8, least squares on 400 Chebyshev nodes of
t^2 in [0, tan^2(pi/8)] against numpy's arctan (coefficients below, computed once so):
at most 1.1e-14 rad from numpy's, for finite or NaN arguments (NaN gives NaN; signed zeros
as numpy's). ~2 ns a value. `hypot` likewise: sqrt(x^2 + y^2) in one pass (numpy's hypot
guards against overflow at ~25 ns a value; these are speeds and distances, far from it).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_LIMIT = 2.0 * math.pi


def sin_cos(angle_rad) -> tuple[np.ndarray, np.ndarray]:
    """(sin, cos) of `angle_rad` (array-like, radians) as float64 arrays, to ~2.6e-7 (module
    docstring); the shape of the input."""
    x = np.asarray(angle_rad, dtype=float)
    if x.size and not (-_LIMIT <= np.fmin.reduce(x, axis=None) and np.fmax.reduce(x, axis=None) <= _LIMIT):  # NaNs skipped
        x = x - 2.0 * math.pi * np.floor((x + math.pi) / (2.0 * math.pi))
    a = x.astype(np.float32)
    s = np.sin(a).astype(float)
    c = np.cos(a, out=a).astype(float)
    return s, c


_TAN_PI_8 = math.tan(math.pi / 8)
# atan(t) / t as a polynomial in t^2 on [0, tan^2(pi/8)] (module docstring), lowest power first
_P = (0.9999999999999748, -0.33333333330881876, 0.1999999961402857, -0.14285690839989396, 0.11110394439495343,
      -0.09078507709649432, 0.07564494118798457, -0.05877324461224619, 0.030703317315800657)


@njit(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy", inline="always")
def atan2_scalar(yi: float, xi: float) -> float:
    """One value of `arctan2`, for compiled loops (numba) that need it inside."""
    # both sides of every choice computed, then selected: no branch in a loop (SIMD lanes;
    # error_model="numpy": no ZeroDivisionError branch, 0/0 gives NaN and is selected away)
    p0, p1, p2, p3, p4, p5, p6, p7, p8 = _P
    ay, ax = abs(yi), abs(xi)
    swap = ay > ax
    big = ay if swap else ax
    small = ax if swap else ay
    r = small / big
    t = r if big > 0 else 0.0
    hi = t > _TAN_PI_8
    uh = (t - 1.0) / (t + 1.0)
    u = uh if hi else t
    s = u * u
    a = u * (p0 + s * (p1 + s * (p2 + s * (p3 + s * (p4 + s * (p5 + s * (p6 + s * (p7 + s * p8))))))))
    a += 0.25 * math.pi if hi else 0.0
    b = 0.5 * math.pi - a
    a = b if swap else a
    c = math.pi - a
    a = c if math.copysign(1.0, xi) < 0 else a
    a = math.copysign(a, yi)
    return a if (ay == ay and ax == ax) else math.nan


@njit(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")
def _arctan2(y: np.ndarray, x: np.ndarray, out: np.ndarray) -> None:
    for i in range(len(y)):
        out[i] = atan2_scalar(y[i], x[i])


def arctan2(y, x, out: np.ndarray | None = None) -> np.ndarray:
    """np.arctan2(y, x) (radians, (-pi, pi]) to 1.1e-14 rad (module docstring), 1-D or any
    shape of equal y, x; into `out` when given."""
    y = np.ascontiguousarray(y, dtype=float)
    x = np.ascontiguousarray(x, dtype=float)
    if y.shape != x.shape:
        raise ValueError(f"arctan2: y and x differ in shape ({y.shape} vs {x.shape})")
    res = _result(out, y.shape, x, y)
    _arctan2(y.reshape(-1), x.reshape(-1), res.reshape(-1))
    return _deliver(res, out)


@njit(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")
def _hypot(x: np.ndarray, y: np.ndarray, out: np.ndarray) -> None:
    for i in range(len(x)):
        out[i] = math.sqrt(x[i] * x[i] + y[i] * y[i])


def hypot(x, y, out: np.ndarray | None = None) -> np.ndarray:
    """sqrt(x^2 + y^2) of equal-shaped x, y (module docstring: no overflow guard); into `out` when given."""
    x = np.ascontiguousarray(x, dtype=float)
    y = np.ascontiguousarray(y, dtype=float)
    if y.shape != x.shape:
        raise ValueError(f"hypot: x and y differ in shape ({x.shape} vs {y.shape})")
    res = _result(out, x.shape, x, y)
    _hypot(x.reshape(-1), y.reshape(-1), res.reshape(-1))
    return _deliver(res, out)


def _result(out: np.ndarray | None, shape: tuple, *inputs: np.ndarray) -> np.ndarray:
    """Where a kernel writes: `out`, unless it overlaps an input (the compiled loop then runs
    scalar, 6x slower: the SIMD loop's runtime overlap check fails): a fresh array."""
    if out is None or any(np.shares_memory(out, a) for a in inputs):
        return np.empty(shape)
    return out


def _deliver(res: np.ndarray, out: np.ndarray | None) -> np.ndarray:
    if out is None or res is out:
        return res
    np.copyto(out, res)
    return out
