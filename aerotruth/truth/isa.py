"""ICAO Standard Atmosphere (ISA) and its "ISA + dT" variant, by geopotential height.

Source: ICAO Doc 7488/3, Manual of the ICAO Standard Atmosphere (1993):
T0 = 288.15 K, p0 = 101325 Pa, g0 = 9.80665 m/s^2, R = 287.05287 J/(kg K), r0 = 6356766 m;
layers by geopotential height H: lapse -6.5 K/km from 0 (tables start at -5 km) to 11 km,
0 to 20 km, +1.0 K/km to 32 km, +2.8 K/km to 47 km.

"ISA + dT" keeps the layer heights and lapse rates, shifts every temperature by dT, and
gets pressure from the hypsometric equation in each layer, starting from the pressure
p_sl at H = 0:
    lapse L != 0:  p = p_b ((T_b + dT + L (H - H_b)) / (T_b + dT))^(-g0 / (R L))
    lapse L == 0:  p = p_b exp(-g0 (H - H_b) / (R (T_b + dT)))
Pressure altitude is the ISA (dT = 0, p_sl = 101325 Pa) geopotential height at which a
pressure occurs: what an altimeter set to 1013.25 hPa reads.

Array functions take and return numpy arrays; the `_point` variants take and return
floats (the flight loop calls them once per simulated second).
"""

from __future__ import annotations

import math

import numpy as np

from aerotruth.units import G0

ISA_T0_K = 288.15
ISA_P0_PA = 101325.0
ISA_R_AIR = 287.05287  # J/(kg K)
ISA_EARTH_RADIUS_M = 6356766.0  # r0 of the geopotential conversion
H_BASE_M = (0.0, 11000.0, 20000.0, 32000.0)  # layer bases, geopotential m
LAPSE_K_PER_M = (-6.5e-3, 0.0, 1.0e-3, 2.8e-3)
H_TOP_M = 47000.0
H_BOTTOM_M = -5000.0
T_BASE_K = tuple(
    ISA_T0_K + sum(LAPSE_K_PER_M[j] * (H_BASE_M[j + 1] - H_BASE_M[j]) for j in range(i)) for i in range(len(H_BASE_M))
)

_HB = np.array(H_BASE_M)
_L = np.array(LAPSE_K_PER_M)
_TB = np.array(T_BASE_K)


def _layer_ratio_point(j: int, dh: float, delta_t: float) -> float:
    """p(H_b + dh) / p(H_b) in layer j with temperatures shifted by delta_t."""
    tb = T_BASE_K[j] + delta_t
    lapse = LAPSE_K_PER_M[j]
    if lapse == 0.0:
        return math.exp(-G0 * dh / (ISA_R_AIR * tb))
    return ((tb + lapse * dh) / tb) ** (-G0 / (ISA_R_AIR * lapse))


def _base_ratios_point(delta_t: float) -> list[float]:
    out = [1.0]
    for j in range(len(H_BASE_M) - 1):
        out.append(out[-1] * _layer_ratio_point(j, H_BASE_M[j + 1] - H_BASE_M[j], delta_t))
    return out


_P_BASE_STD = tuple(ISA_P0_PA * r for r in _base_ratios_point(0.0))
P_TOP_PA = _P_BASE_STD[-1] * _layer_ratio_point(len(H_BASE_M) - 1, H_TOP_M - H_BASE_M[-1], 0.0)
P_BOTTOM_PA = ISA_P0_PA * _layer_ratio_point(0, H_BOTTOM_M, 0.0)


def geopotential_altitude_m(z_m):
    """Geopotential height H (m) of geometric altitude z (m): H = r0 z / (r0 + z) (Doc 7488)."""
    z = np.asarray(z_m, dtype=float)
    return ISA_EARTH_RADIUS_M * z / (ISA_EARTH_RADIUS_M + z)


def geometric_altitude_m(h_m):
    """Geometric altitude z (m) of geopotential height H (m): z = r0 H / (r0 - H)."""
    h = np.asarray(h_m, dtype=float)
    return ISA_EARTH_RADIUS_M * h / (ISA_EARTH_RADIUS_M - h)


def check_geopotential(h) -> None:
    """Raise ValueError unless every H is finite and within the tabulated ISA range."""
    h = np.asarray(h, dtype=float)
    if not np.all(np.isfinite(h)) or np.any(h < H_BOTTOM_M) or np.any(h > H_TOP_M):
        raise ValueError(f"altitude: geopotential height must be finite and within [{H_BOTTOM_M:.0f}, {H_TOP_M:.0f}] m")


def _layer_index(h: np.ndarray) -> np.ndarray:
    return np.clip(np.searchsorted(_HB, h, side="right") - 1, 0, _HB.size - 1)


def isa_temperature_k(h_geopotential_m, delta_t_k=0.0):
    """Temperature (K) of the ISA + delta_t atmosphere at geopotential height H (m)."""
    h = np.asarray(h_geopotential_m, dtype=float)
    check_geopotential(h)
    i = _layer_index(h)
    return _TB[i] + _L[i] * (h - _HB[i]) + np.asarray(delta_t_k, dtype=float)


def isa_pressure_pa(h_geopotential_m, delta_t_k=0.0, p_sea_level_pa=ISA_P0_PA):
    """Static pressure (Pa) at geopotential height H (m) of the ISA + delta_t column whose
    pressure at H = 0 is p_sea_level_pa (hypsometric equation per layer)."""
    h = np.asarray(h_geopotential_m, dtype=float)
    check_geopotential(h)
    h, dt, psl = np.broadcast_arrays(h, np.asarray(delta_t_k, dtype=float), np.asarray(p_sea_level_pa, dtype=float))
    i = _layer_index(h)
    base = np.ones(h.shape)
    for j in range(_HB.size - 1):  # pressure ratio at the base of each point's layer
        tb = _TB[j] + dt
        if _L[j] == 0.0:
            r = np.exp(-G0 * (_HB[j + 1] - _HB[j]) / (ISA_R_AIR * tb))
        else:
            r = ((tb + _L[j] * (_HB[j + 1] - _HB[j])) / tb) ** (-G0 / (ISA_R_AIR * _L[j]))
        base = np.where(i > j, base * r, base)
    tb, lapse, dh = _TB[i] + dt, _L[i], h - _HB[i]
    safe_lapse = np.where(lapse == 0.0, 1.0, lapse)
    power = ((tb + lapse * dh) / tb) ** (-G0 / (ISA_R_AIR * safe_lapse))
    within = np.where(lapse == 0.0, np.exp(-G0 * dh / (ISA_R_AIR * tb)), power)
    return psl * base * within


def isa_point(
    h_geopotential_m: float, delta_t_k: float = 0.0, p_sea_level_pa: float = ISA_P0_PA
) -> tuple[float, float]:
    """(temperature K, pressure Pa) of the ISA + delta_t column at one height; floats. The
    one-point form of isa_temperature_k and isa_pressure_pa for the truth loop's per-step
    calls, where numpy's per-call overhead made the array form ~150x slower on one point;
    the same temperature to the last bit and the same pressure within two units in the last
    place (numpy's vectorised exp and power may round otherwise than math's;
    tests/test_atmosphere.py)."""
    h = float(h_geopotential_m)
    if not (H_BOTTOM_M <= h <= H_TOP_M):
        raise ValueError(
            f"altitude: geopotential height must be finite and within [{H_BOTTOM_M:.0f}, {H_TOP_M:.0f}] m, got {h!r}"
        )
    j = 0
    while j + 1 < len(H_BASE_M) and h >= H_BASE_M[j + 1]:
        j += 1
    ratio = 1.0
    for i in range(j):
        ratio *= _layer_ratio_point(i, H_BASE_M[i + 1] - H_BASE_M[i], delta_t_k)
    dh = h - H_BASE_M[j]
    temperature = T_BASE_K[j] + LAPSE_K_PER_M[j] * dh + delta_t_k
    return temperature, p_sea_level_pa * ratio * _layer_ratio_point(j, dh, delta_t_k)


def pressure_altitude_m(p_pa):
    """Pressure altitude (m, ISA geopotential) of static pressure p (Pa): the exact inverse
    of `isa_pressure_pa` with delta_t = 0 and p_sl = 101325 Pa."""
    p = np.asarray(p_pa, dtype=float)
    if not np.all(np.isfinite(p)) or np.any(p < P_TOP_PA) or np.any(p > P_BOTTOM_PA):
        raise ValueError(f"pressure_altitude_m: p_pa must be finite and within [{P_TOP_PA:.1f}, {P_BOTTOM_PA:.1f}] Pa")
    pb_all = np.array(_P_BASE_STD)
    i = np.clip(np.searchsorted(-pb_all, -p, side="right") - 1, 0, _HB.size - 1)
    tb, lapse, pb = _TB[i], _L[i], pb_all[i]
    safe_lapse = np.where(lapse == 0.0, 1.0, lapse)
    grad = tb / safe_lapse * ((p / pb) ** (-ISA_R_AIR * lapse / G0) - 1.0)
    iso = -ISA_R_AIR * tb / G0 * np.log(p / pb)
    return _HB[i] + np.where(lapse == 0.0, iso, grad)
