"""Sine, cosine and arctangent of reported quantities at vector speed.

numpy's float64 sin, cos and arctan2 call the C library once per value here (~15, ~15 and
~35 ms per million, numpy 2.4 on x86-64); its float32 sin and cos run in SIMD lanes but
lose 2.6e-7 and cost two conversions. The wind method takes them of every report. These
are compiled (numba) loops without branches, so the compiler runs them in SIMD lanes
(2-3 ns a value), to double precision:

* `sin_cos`: x = n pi/2 + r with n = round(2x/pi) and r by the two-part pi/2 of Cody and
  Waite (fdlibm's split: n pi/2 exact below |x| ~ 1.6e6; larger arguments are first
  wrapped to [-pi, pi) in float64, to ~2e-16 |x|), sin r and cos r by their Taylor series to r^15 and r^16
  on |r| <= pi/4 (truncation below 5e-17), then the quadrant n mod 4. Within 3e-16 of
  numpy's float64 sin and cos (measured, 2 million angles in [-7, 7] and in +-1e5).
* `arctan2`: the usual reduction to t = min(|y|, |x|) / max(|y|, |x|) in [0, 1], then to
  |t| <= tan(pi/8) by atan(t) = pi/4 + atan((t - 1) / (t + 1)), and there atan(t) = t
  P(t^2) with P of degree 8, least squares on 400 Chebyshev nodes of t^2 in
  [0, tan^2(pi/8)] against numpy's arctan (coefficients below, computed once so): at most
  1.1e-14 rad from numpy's, for finite or NaN arguments (NaN gives NaN; signed zeros as
  numpy's).
* `hypot`: sqrt(x^2 + y^2) in one pass (numpy's hypot guards against overflow at ~25 ns a
  value; these are speeds and distances, far from it).

The scalar forms (`sincos_scalar`, `atan2_scalar`) serve compiled loops that need them
inside. NaN and infinite arguments give NaN, as numpy's.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

_WRAP_ABOVE = 1e5  # |x| beyond this is wrapped to [-pi, pi) first (the split of pi/2 is exact to ~1.6e6)
_TWO_OVER_PI = 2.0 / math.pi
_PIO2_HI = 1.57079632673412561417e00  # pi/2 in 33 bits, and the rest (fdlibm's pio2_1, pio2_1t)
_PIO2_LO = 6.07710050650619224932e-11
_SIN = tuple((-1) ** k / math.factorial(2 * k + 1) for k in range(8))  # r, r^3, ..., r^15
_COS = tuple((-1) ** k / math.factorial(2 * k) for k in range(9))  # 1, r^2, ..., r^16


@njit(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy", inline="always")
def sincos_scalar(x: float) -> tuple[float, float]:
    """(sin x, cos x) of one value, |x| <= 1e5 (module docstring)."""
    s0, s1, s2, s3, s4, s5, s6, s7 = _SIN
    c0, c1, c2, c3, c4, c5, c6, c7, c8 = _COS
    n = np.round(x * _TWO_OVER_PI)
    r = (x - n * _PIO2_HI) - n * _PIO2_LO
    z = r * r
    s = r * (s0 + z * (s1 + z * (s2 + z * (s3 + z * (s4 + z * (s5 + z * (s6 + z * s7)))))))
    c = c0 + z * (c1 + z * (c2 + z * (c3 + z * (c4 + z * (c5 + z * (c6 + z * (c7 + z * c8)))))))
    q = (int(n) if math.isfinite(n) else 0) & 3  # the quadrant (NaN, inf: r is NaN already)
    sv = c if q & 1 else s
    cv = s if q & 1 else c
    sv = -sv if q & 2 else sv
    cv = -cv if (q == 1 or q == 2) else cv
    return sv, cv


@njit(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")
def _sin_cos(x: np.ndarray, s: np.ndarray, c: np.ndarray) -> None:
    for i in range(len(x)):
        s[i], c[i] = sincos_scalar(x[i])


def sin_cos(angle_rad) -> tuple[np.ndarray, np.ndarray]:
    """(sin, cos) of `angle_rad` (array-like, radians) as float64 arrays, to 3e-16 for
    |x| <= 1e5, to the float64 wrap's ~2e-16 |x| beyond (module docstring); the shape of the
    input."""
    x = np.asarray(angle_rad, dtype=float)
    if x.size and not (-_WRAP_ABOVE <= np.fmin.reduce(x, axis=None) and np.fmax.reduce(x, axis=None) <= _WRAP_ABOVE):
        with np.errstate(invalid="ignore"):  # (NaNs are skipped by fmin/fmax; inf gives NaN, as numpy's sin)
            x = x - 2.0 * math.pi * np.floor((x + math.pi) / (2.0 * math.pi))
    s, c = np.empty(x.shape), np.empty(x.shape)
    _sin_cos(np.ascontiguousarray(x).reshape(-1), s.reshape(-1), c.reshape(-1))
    return s, c


_TAN_PI_8 = math.tan(math.pi / 8)
# atan(t) / t as a polynomial in t^2 on [0, tan^2(pi/8)] (module docstring), lowest power first
_P = (
    0.9999999999999748,
    -0.33333333330881876,
    0.1999999961402857,
    -0.14285690839989396,
    0.11110394439495343,
    -0.09078507709649432,
    0.07564494118798457,
    -0.05877324461224619,
    0.030703317315800657,
)


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
    return _binary(_arctan2, "arctan2", y, x, out)


@njit(cache=True, nogil=True, fastmath={"contract"}, error_model="numpy")
def _hypot(x: np.ndarray, y: np.ndarray, out: np.ndarray) -> None:
    for i in range(len(x)):
        out[i] = math.sqrt(x[i] * x[i] + y[i] * y[i])


def hypot(x, y, out: np.ndarray | None = None) -> np.ndarray:
    """sqrt(x^2 + y^2) of equal-shaped x, y (module docstring: no overflow guard); into `out` when given."""
    return _binary(_hypot, "hypot", x, y, out)


def _binary(kernel, name: str, a, b, out: np.ndarray | None) -> np.ndarray:
    """kernel(a, b, result) over equal-shaped a, b of any shape (flattened), into `out` when given."""
    a = np.ascontiguousarray(a, dtype=float)
    b = np.ascontiguousarray(b, dtype=float)
    if a.shape != b.shape:
        raise ValueError(f"{name}: the two arguments differ in shape ({a.shape} vs {b.shape})")
    res = _result(out, a.shape, a, b)
    kernel(a.reshape(-1), b.reshape(-1), res.reshape(-1))
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
