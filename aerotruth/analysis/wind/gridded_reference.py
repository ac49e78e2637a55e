"""Reference winds from a gridded weather analysis: u, v on time x pressure level x
latitude x longitude (ERA5's pressure-level layout), interpolated in four dimensions to each
aircraft report. Arrays in, arrays out; reading the file is aerotruth.measured.gridded.

Conventions. u towards east, v towards north, m/s, on the analysis's latitude/longitude
grid (the components of the wind, not grid-relative ones); time in UTC epoch seconds;
pressure in Pa; latitude and longitude in degrees. `grid_axes` puts each axis in ascending
order whatever the file's (ERA5 stores latitude from 90 down to -90, levels either way) and
unwraps longitude into one ascending run of less than 360 deg starting after the largest
gap between neighbouring longitudes, so a regional grid across the 180-deg meridian or the
0/360 seam stays in one piece; a grid whose largest gap, the seam included, is at most 1.5
times its median spacing is global, and its first column is repeated 360 deg on, so that
reports between its last and first longitudes are interpolated across the seam. A report's
longitude is taken modulo 360 into the axis's run, so -93 and 267 are the same place.

A report's level is its static pressure: pressure altitude is by definition the height of
the ICAO Standard Atmosphere at which that pressure occurs (ICAO Doc 7488/3), so
p = p_ISA(pressure altitude) exactly (aerotruth.truth.isa), with no temperature or
geopotential correction: an analysis on pressure levels is already in that coordinate.

Interpolation, in each of the four coordinates in turn (a tensor product, the order does not
matter): linear in time between the two analyses around the report, linear in ln p between
the two levels around it, and bilinear in latitude and longitude (degrees) between the four
grid columns around it. A report outside the span of the times, of the levels (above the
highest, below the lowest; nothing is extrapolated) or of the area gets no reference, and
is counted as such, in that order of precedence; so does a report whose surrounding grid
values include a missing one (NaN, e.g. a level below the ground in a model that masks it).

Error bound of the interpolation. Write the coordinates x_1..x_4 = (t, ln p, lat, lon), the
report's cell [a_i, a_i + h_i] on each and its offset s_i = x_i - a_i. In one dimension the
remainder of linear interpolation between two nodes is
    f(x) - L f(x) = -(s (h - s) / 2) f''(xi)  for some xi in the cell
(the interpolation-error theorem of polynomial interpolation, n = 1: e.g. K. E. Atkinson, An
Introduction to Numerical Analysis, 2nd ed., Wiley 1989, sec. 3.1), so |f - L f| <= h^2/8
max|f''|, the maximum at mid-cell. The four-dimensional interpolant is L = L_1 L_2 L_3 L_4,
and f - L f = (f - L_1 f) + L_1 (f - L_2 f) + L_1 L_2 (f - L_3 f) + L_1 L_2 L_3 (f - L_4 f);
each L_i is a convex combination (weights in [0, 1] summing to 1) of values at the same
other coordinates, so it never enlarges a maximum, and
    |f - L f| <= sum_i s_i (h_i - s_i) / 2 * M_i <= sum_i h_i^2 / 8 * M_i,
    M_i = max over the cell of |d^2 f / d x_i^2|,
for u and v each (the vector error is at most the root sum of squares of the two). For a
wave of amplitude A and wavelength lambda along an axis, M = A (2 pi / lambda)^2 and the
term is A (pi h / lambda)^2 / 2: 0.31 A at lambda = 4 h, 0.019 A at lambda = 16 h; the same
holds for a period in time and a vertical wavelength in ln p. The bound is on the
interpolation alone: what the analysis does not resolve between its nodes, and its own error
against the atmosphere, are further errors of the reference. A field with a kink (a slope
that jumps by D inside the cell) is not twice differentiable there; linear interpolation
then errs by at most h |D| / 4 along that axis.

References. ERA5 (Hersbach et al. 2020, Q. J. R. Meteorol. Soc. 146, 1999-2049; ECMWF's
"ERA5: data documentation"): u and v (GRIB parameters 131 and 132, "U/V component of
wind", m s**-1) on 37 pressure levels from 1000 to 1 hPa, hourly, on a 0.25-deg
latitude/longitude grid whose latitudes run from 90 down to -90 and longitudes from 0 to
359.75.
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

import numpy as np
import pandas as pd

from aerotruth.analysis.wind.consensus import build_observation_table, sample_winds
from aerotruth.truth.isa import H_BOTTOM_M, H_TOP_M, isa_pressure_pa
from aerotruth.units import FT, HPA, KT

PERIODIC_GAP_RATIO = 1.5  # a longitude axis whose largest gap is at most this times its median spacing is global


def _strictly_ascending(name: str, values, order: np.ndarray) -> np.ndarray:
    """The values in `order`, checked strictly ascending (ValueError naming the axis)."""
    out = np.asarray(values, dtype=float)[order]
    if out.size and np.any(np.diff(out) <= 0):
        raise ValueError(f"{name}: repeated coordinate values (each grid line once expected)")
    return out


@dataclass(frozen=True)
class GridAxes:
    """The four axes of an analysis in ascending order (module docstring): time_s (UTC epoch
    s), pressure_pa, lat_deg, lon_deg (one ascending run; a global axis ends with its first
    longitude + 360); `source_index[k][j]` is the position in the file's own order of node j
    of axis k (time, pressure, lat, lon), for reading the nodes from the file."""

    time_s: np.ndarray
    pressure_pa: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    source_index: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    periodic_lon: bool = False

    def take(self, nodes: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]) -> GridAxes:
        """The axes of the nodes `nodes` (positions on each axis, ascending)."""
        arrays = (self.time_s, self.pressure_pa, self.lat_deg, self.lon_deg)
        t, p, y, x = (a[i] for a, i in zip(arrays, nodes, strict=True))
        src = tuple(s[i] for s, i in zip(self.source_index, nodes, strict=True))
        return GridAxes(t, p, y, x, (src[0], src[1], src[2], src[3]), False)

    def describe(self) -> str:
        """The span in words: times, levels, latitudes, longitudes."""

        def when(s: float) -> str:
            return (dt.datetime(1970, 1, 1) + dt.timedelta(seconds=float(s))).strftime("%Y-%m-%d %H:%M")

        if self.time_s.size == 0:
            return "no grid nodes"
        times = when(self.time_s[0]) + ("" if self.time_s.size == 1 else f" to {when(self.time_s[-1])}") + " UTC"
        lo, hi = self.pressure_pa[0] / HPA, self.pressure_pa[-1] / HPA
        levels = f"{lo:g} hPa" if self.pressure_pa.size == 1 else f"{lo:g}-{hi:g} hPa"
        lats = f"lat {self.lat_deg[0]:g} to {self.lat_deg[-1]:g}"
        if self.periodic_lon:
            lons = "all longitudes"
        else:
            w0, w1 = ((self.lon_deg[[0, -1]] + 180.0) % 360.0) - 180.0
            lons = f"lon {w0:g} to {w1:g}"
        return f"{times}, {levels}, {lats}, {lons}"


def grid_axes(time_s, pressure_pa, lat_deg, lon_deg) -> GridAxes:
    """The GridAxes of an analysis's coordinates in the file's own order (1-D arrays; a
    scalar coordinate is an axis of one node). ValueError naming the axis on non-finite,
    repeated or out-of-range values."""
    arrays = {}
    for name, values in (("time", time_s), ("pressure", pressure_pa), ("latitude", lat_deg), ("longitude", lon_deg)):
        a = np.atleast_1d(np.asarray(values, dtype=float))
        if a.ndim != 1 or a.size == 0:
            raise ValueError(f"{name}: expected a 1-D coordinate with at least one value")
        if not np.all(np.isfinite(a)):
            raise ValueError(f"{name}: coordinate values must be finite numbers")
        arrays[name] = a
    if np.any(arrays["pressure"] <= 0):
        raise ValueError("pressure: levels must be positive")
    if np.any(np.abs(arrays["latitude"]) > 90.0):
        raise ValueError("latitude: values must lie within -90..90 deg")
    orders = {k: np.argsort(arrays[k], kind="stable") for k in ("time", "pressure", "latitude")}
    t = _strictly_ascending("time", arrays["time"], orders["time"])
    p = _strictly_ascending("pressure", arrays["pressure"], orders["pressure"])
    y = _strictly_ascending("latitude", arrays["latitude"], orders["latitude"])
    wrapped = arrays["longitude"] % 360.0
    lon_order = np.argsort(wrapped, kind="stable")
    sorted_lon = _strictly_ascending("longitude", wrapped, lon_order)
    n = sorted_lon.size
    periodic = False
    if n >= 2:
        gaps = np.diff(np.r_[sorted_lon, sorted_lon[0] + 360.0])  # the gap after each longitude, the seam's last
        if n >= 3 and gaps.max() <= PERIODIC_GAP_RATIO * np.median(gaps):
            periodic = True
            lon_order = np.r_[lon_order, lon_order[0]]
        else:
            lon_order = np.roll(lon_order, -((int(np.argmax(gaps)) + 1) % n))  # start after the largest gap
    x = wrapped[lon_order]
    x = x[0] + (x - x[0]) % 360.0
    if periodic:
        x[-1] = x[0] + 360.0
    return GridAxes(t, p, y, x, (orders["time"], orders["pressure"], orders["latitude"], lon_order), periodic)


@dataclass(frozen=True)
class WindGrid:
    """An analysis's winds: u_ms, v_ms (m/s, towards east and north) of shape (time,
    pressure, lat, lon) on `axes`; `span` the axes of the whole analysis (whose nodes `axes`
    may be a subset of: those around the reports), `name` the reference's label."""

    axes: GridAxes
    u_ms: np.ndarray
    v_ms: np.ndarray
    name: str
    span: GridAxes

    def __post_init__(self) -> None:
        shape = tuple(a.size for a in (self.axes.time_s, self.axes.pressure_pa, self.axes.lat_deg, self.axes.lon_deg))
        if self.u_ms.shape != shape or self.v_ms.shape != shape:
            raise ValueError(f"u and v must have the axes' shape {shape}, got {self.u_ms.shape} and {self.v_ms.shape}")


@dataclass(frozen=True)
class Bracket:
    """Where points lie on one axis: lower and upper node, the weight of the upper one, and
    whether the point is within the axis's span."""

    lower: np.ndarray
    upper: np.ndarray
    weight: np.ndarray
    inside: np.ndarray


def bracket(axis: np.ndarray, x: np.ndarray) -> Bracket:
    """The nodes of an ascending axis around each x (NaN is outside); an axis of one node
    holds only its own value."""
    x = np.asarray(x, dtype=float)
    n = axis.size
    if n < 2:
        zero = np.zeros(x.shape, dtype=np.int64)
        inside = x == axis[0] if n == 1 else np.zeros(x.shape, dtype=bool)
        return Bracket(zero, zero, np.zeros(x.shape), inside)
    inside = (x >= axis[0]) & (x <= axis[-1])
    xc = np.where(inside, x, axis[0])
    i = np.clip(np.searchsorted(axis, xc, side="right") - 1, 0, n - 2)
    w = (xc - axis[i]) / (axis[i + 1] - axis[i])
    return Bracket(i, i + 1, w, inside)


def report_pressure_pa(pressure_altitude_ft) -> np.ndarray:
    """Static pressure (Pa) of each report from its pressure altitude (ft): the ISA pressure
    at that geopotential height (module docstring); NaN outside the ISA table (-5..47 km)."""
    h = np.asarray(pressure_altitude_ft, dtype=float) * FT
    ok = np.isfinite(h) & (h >= H_BOTTOM_M) & (h <= H_TOP_M)
    out = np.full(h.shape, np.nan)
    out[ok] = isa_pressure_pa(h[ok])
    return out


def _lon_on_axis(axis: np.ndarray, lon) -> np.ndarray:
    """Longitudes moved by whole turns into the axis's run [axis[0], axis[0] + 360)."""
    lon = np.asarray(lon, dtype=float)
    if axis.size == 0:
        return lon
    return axis[0] + (lon - axis[0]) % 360.0


def locate(axes: GridAxes, time_s, pressure_pa, lat_deg, lon_deg) -> tuple[Bracket, Bracket, Bracket, Bracket]:
    """The brackets of points on each axis (time, ln p, lat, lon); pressure in Pa."""
    with np.errstate(invalid="ignore", divide="ignore"):
        lnp = np.log(np.asarray(pressure_pa, dtype=float))
    return (
        bracket(axes.time_s, time_s),
        bracket(np.log(axes.pressure_pa), lnp),
        bracket(axes.lat_deg, lat_deg),
        bracket(axes.lon_deg, _lon_on_axis(axes.lon_deg, lon_deg)),
    )


def nodes_needed(axes: GridAxes, time_s, pressure_pa, lat_deg, lon_deg) -> tuple[np.ndarray, ...]:
    """Per axis, the nodes (ascending positions) around the points inside the grid: all a
    reader has to load to interpolate to them."""
    b = locate(axes, time_s, pressure_pa, lat_deg, lon_deg)
    inside = b[0].inside & b[1].inside & b[2].inside & b[3].inside
    return tuple(np.union1d(k.lower[inside], k.upper[inside]) for k in b)


@dataclass(frozen=True)
class GridReference:
    """The reference wind at each report (u_ms, v_ms, NaN without one) and why a report has
    none: outside the analysis times, else outside its levels, else outside its area, else a
    missing grid value around it (each report counted once, in that order)."""

    u_ms: np.ndarray
    v_ms: np.ndarray
    outside_time: np.ndarray
    outside_level: np.ndarray
    outside_area: np.ndarray
    missing_value: np.ndarray

    def counts(self) -> dict[str, int]:
        """How many reports lack a reference, by reason."""
        return {
            "outside_time": int(self.outside_time.sum()),
            "outside_level": int(self.outside_level.sum()),
            "outside_area": int(self.outside_area.sum()),
            "missing_value": int(self.missing_value.sum()),
        }


def interpolate_wind(grid: WindGrid, time_s, pressure_pa, lat_deg, lon_deg) -> GridReference:
    """The analysis's wind at each point (time UTC epoch s, pressure Pa, lat, lon deg):
    linear in time and in ln p, bilinear in latitude and longitude (module docstring)."""
    full = locate(grid.span, time_s, pressure_pa, lat_deg, lon_deg)
    out_t = ~full[0].inside
    out_p = ~out_t & ~full[1].inside
    out_a = ~out_t & ~out_p & ~(full[2].inside & full[3].inside)
    inside = ~(out_t | out_p | out_a)
    b = locate(grid.axes, time_s, pressure_pa, lat_deg, lon_deg)
    loaded = b[0].inside & b[1].inside & b[2].inside & b[3].inside
    if np.any(inside & ~loaded):
        raise ValueError("grid: its nodes were loaded for other positions than these (nodes_needed of these points)")
    shape = grid.u_ms.shape
    u = np.zeros(inside.shape)
    v = np.zeros(inside.shape)
    for corner in range(16):
        idx = np.zeros(inside.shape, dtype=np.int64)
        weight = np.ones(inside.shape)
        for k in range(4):
            upper = (corner >> (3 - k)) & 1
            node = b[k].upper if upper else b[k].lower
            idx = idx * shape[k] + np.where(inside, node, 0)
            weight = weight * (b[k].weight if upper else 1.0 - b[k].weight)
        used = inside & (weight > 0)
        if not used.any():
            continue
        u[used] += weight[used] * grid.u_ms.reshape(-1)[idx[used]]
        v[used] += weight[used] * grid.v_ms.reshape(-1)[idx[used]]
    missing = inside & ~(np.isfinite(u) & np.isfinite(v))
    ok = inside & ~missing
    return GridReference(np.where(ok, u, np.nan), np.where(ok, v, np.nan), out_t, out_p, out_a, missing)


def report_positions(traffic: pd.DataFrame) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(time UTC epoch s, pressure Pa, lat, lon) of each sample of a canonical traffic frame
    (aerotruth.measured.traffic): where a gridded reference is wanted."""
    return (
        traffic["time_s"].to_numpy(float),
        report_pressure_pa(traffic["pressure_altitude_ft"].to_numpy(float)),
        traffic["lat"].to_numpy(float),
        traffic["lon"].to_numpy(float),
    )


def gridded_observation_table(traffic: pd.DataFrame, grid: WindGrid) -> pd.DataFrame:
    """The observation table (docs/data-formats.md) of traffic against a gridded analysis:
    each sample's wind as aerotruth.analysis.wind.consensus.sample_winds computes it, the
    reference the analysis interpolated to it (interpolate_wind), `ref_source` the grid's
    name; one row per sample with a reference. attrs: samples, without_reference and its
    parts outside_time, outside_level, outside_area, missing_value (GridReference)."""
    winds = sample_winds(traffic)
    ref = interpolate_wind(grid, *report_positions(traffic))
    out = build_observation_table(traffic, winds, ref.u_ms / KT, ref.v_ms / KT, grid.name)
    out.attrs.update(ref.counts())
    return out
