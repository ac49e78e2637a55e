"""Gridded weather analyses as data services write them, read with xarray into a WindGrid
(aerotruth.analysis.wind.gridded_reference): u and v on time x pressure level x latitude x
longitude.

Formats, recognised from the file's first bytes (not its name): NetCDF (classic `CDF`, or
NetCDF-4 on HDF5) through xarray's netCDF4 engine; GRIB (editions 1 and 2) through cfgrib
on the ecCodes library (`pip install aerotruth[grib]`), its isobaric messages only
(typeOfLevel isobaricInhPa), with no index file written beside the data.

Names (matched case-insensitively; the first found wins):

* wind: `u`, `v` (ERA5 short names, and cfgrib's), `u_component_of_wind`,
  `v_component_of_wind` (the Climate Data Store's request names, the variables' names in
  the ARCO / WeatherBench ERA5 stores), `uwnd`, `vwnd` (NOAA PSL reanalyses), else the
  variables whose CF standard_name is eastward_wind / northward_wind;
* time: `valid_time` (the Climate Data Store's NetCDF since 2024, and cfgrib's valid time
  of a forecast step), `time`; a cfgrib forecast with a `step` dimension takes its
  `valid_time` along it;
* level: `pressure_level` (Climate Data Store since 2024), `level` (its NetCDF before, and
  ARCO/WeatherBench ERA5), `isobaricInhPa` (cfgrib), `plev`, `lev`;
* latitude, longitude: `latitude`/`longitude`, `lat`/`lon`.

The Climate Data Store's NetCDF since 2024 is cfgrib's dataset with its coordinates
renamed, `valid_time` the time dimension (even for one time) and `pressure_level` the
levels (ECMWF, "GRIB to netCDF conversion on new CDS and ADS systems", Copernicus
Knowledge Base); before it, ERA5 NetCDF held `time` and `level` (in millibars) and u, v
packed as 16-bit integers with scale_factor and add_offset, which xarray unpacks. Latitude
may run either way, longitude over 0..360 or -180..180 (aerotruth.analysis.wind.
gridded_reference puts them in order).

Units: u and v in m/s (`m s**-1`, `m s-1`, `m/s`, ...; taken as m/s where the variable has
no `units`); levels in hPa (`hPa`, `millibars`, `mbar`, `mb`) or Pa (`Pa`); a level without
units is hPa when every value is at most 1100, else Pa. Times decoded by xarray from their
CF `units` ("hours since ...") and taken as UTC. A dimension of length one besides these
(a single ensemble member, `expver`) is dropped; ERA5's `expver` of two values (ERA5 and
its preliminary ERA5T, each filling the times the other leaves empty) is merged, the first
where it has values.

Every problem is one DataError naming the file and the variable or dimension expected,
never a traceback.
"""

from __future__ import annotations

import logging
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from aerotruth.analysis.wind.gridded_reference import GridAxes, WindGrid, grid_axes, nodes_needed
from aerotruth.errors import DataError
from aerotruth.units import HPA

WIND_NAMES = {"u": ("u", "u_component_of_wind", "uwnd"), "v": ("v", "v_component_of_wind", "vwnd")}
STANDARD_NAMES = {"u": "eastward_wind", "v": "northward_wind"}
TIME_NAMES = ("valid_time", "time")
LEVEL_NAMES = ("pressure_level", "level", "isobaricinhpa", "plev", "lev")
LAT_NAMES = ("latitude", "lat")
LON_NAMES = ("longitude", "lon")
# u and v units that mean m/s, lower case without spaces: ERA5's "m s**-1", CF's "m s-1", ...
SPEED_UNITS = {
    "ms**-1",
    "ms-1",
    "ms^-1",
    "m/s",
    "m.s-1",
    "m.s**-1",
    "meter/second",
    "metre/second",
    "meters/second",
    "metres/second",
    "meterspersecond",
    "metrespersecond",
}
HPA_UNITS = {"hpa", "millibars", "millibar", "mbar", "mb"}
PA_UNITS = {"pa"}
MERGED_DIMS = ("expver",)
GRIB_MAGIC = b"GRIB"
NETCDF_MAGICS = (b"CDF\x01", b"CDF\x02", b"CDF\x05", b"\x89HDF\r\n\x1a\n")
EXPECTED = "a gridded analysis: NetCDF or GRIB with u and v on time, pressure level, latitude and longitude"


def file_format(path: Path) -> str:
    """ "netcdf" or "grib" from the file's first bytes (a GRIB message may follow a short
    header); DataError for anything else."""
    try:
        with open(path, "rb") as f:
            head = f.read(1024)
    except OSError as e:
        raise DataError(f"{path}: cannot be read ({e.strerror or e}); expected {EXPECTED}") from None
    if head.startswith(NETCDF_MAGICS):
        return "netcdf"
    if GRIB_MAGIC in head[:1024]:
        return "grib"
    raise DataError(f"{path}: neither NetCDF nor GRIB (by its content); expected {EXPECTED}")


def _one_line(e: BaseException) -> str:
    text = str(e).strip().splitlines()
    return text[0] if text else type(e).__name__


def _open(path: Path, kind: str):
    """The file as an xarray Dataset (lazily loaded)."""
    import xarray as xr

    try:
        if kind == "grib":
            try:
                import cfgrib  # noqa: F401
            except Exception as e:  # cfgrib, or the ecCodes library under it, missing
                raise DataError(
                    f"{path}: a GRIB file, and reading GRIB needs cfgrib with ecCodes "
                    f"(pip install 'aerotruth[grib]'): {_one_line(e)}"
                ) from None
            return xr.open_dataset(
                path,
                engine="cfgrib",
                backend_kwargs={"indexpath": "", "filter_by_keys": {"typeOfLevel": "isobaricInhPa"}},
            )
        return xr.open_dataset(path, engine="netcdf4")
    except DataError:
        raise
    except Exception as e:  # the backends raise many kinds: OSError, ValueError, KeyError, ...
        raise DataError(f"{path}: cannot be read as {kind.upper()} ({_one_line(e)}); expected {EXPECTED}") from None


@contextmanager
def _quiet_cfgrib() -> Iterator[None]:
    """cfgrib logs each damaged GRIB message with its traceback; the reader says the problem
    in one line instead, so its logger is off while a file is read."""
    logger = logging.getLogger("cfgrib")  # its modules' loggers inherit this level
    was = logger.level
    logger.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        logger.setLevel(was)


def _lower_names(names) -> dict[str, str]:
    return {str(n).lower(): str(n) for n in names}


def _wind_variable(ds, path: Path, component: str):
    names = _lower_names(ds.data_vars)
    for candidate in WIND_NAMES[component]:
        if candidate in names:
            return ds[names[candidate]]
    for name in ds.data_vars:
        if str(ds[name].attrs.get("standard_name", "")).lower() == STANDARD_NAMES[component]:
            return ds[name]
    have = ", ".join(map(str, ds.data_vars)) or "none"
    raise DataError(
        f"{path}: no {component} wind variable (expected one of {', '.join(WIND_NAMES[component])}, or standard_name "
        f"{STANDARD_NAMES[component]}); its variables: {have}"
    )


def _find(names: tuple[str, ...], candidates) -> str | None:
    lower = _lower_names(candidates)
    return next((lower[n] for n in names if n in lower), None)


def _epoch_seconds(values, path: Path, name: str) -> np.ndarray:
    a = np.asarray(values)
    if np.issubdtype(a.dtype, np.datetime64):
        return (a.astype("datetime64[ns]").astype(np.int64) / 1e9).astype(float)
    raise DataError(
        f"{path}: time coordinate '{name}' is not a date (expected CF units such as 'hours since 1900-01-01')"
    )


def _speed_factor(var, path: Path) -> float:
    units = var.attrs.get("units")
    if units is None or str(units).strip().lower().replace(" ", "") in SPEED_UNITS:
        return 1.0
    raise DataError(f"{path}: variable {var.name} has units '{units}', expected m/s (m s**-1)")


def _pressure_pa(coord, path: Path) -> np.ndarray:
    values = np.atleast_1d(np.asarray(coord.values, dtype=float))
    units = coord.attrs.get("units")
    if units is None:
        return values * (HPA if np.all(values <= 1100.0) else 1.0)
    key = str(units).strip().lower()
    if key in HPA_UNITS:
        return values * HPA
    if key in PA_UNITS:
        return values
    raise DataError(f"{path}: level coordinate '{coord.name}' has units '{units}', expected hPa or Pa")


class _Layout:
    """The dimensions of u (and v) and the coordinates of each axis."""

    def __init__(self, ds, u, path: Path):
        dims = list(u.dims)
        coords = set(map(str, ds.coords)) | set(map(str, u.coords))
        lat = _find(LAT_NAMES, coords)
        lon = _find(LON_NAMES, coords)
        for what, name, names in (("latitude", lat, LAT_NAMES), ("longitude", lon, LON_NAMES)):
            if name is None:
                raise DataError(f"{path}: no {what} coordinate (expected one of {', '.join(names)})")
            if ds[name].ndim != 1 or ds[name].dims[0] not in dims:
                raise DataError(
                    f"{path}: {what} '{name}' is not a 1-D dimension of {u.name} (a regular latitude/longitude "
                    f"grid is expected, not a projected one)"
                )
        self.lat_dim, self.lon_dim = ds[lat].dims[0], ds[lon].dims[0]
        self.lat, self.lon = lat, lon
        level = _find(LEVEL_NAMES, coords)
        if level is None:
            raise DataError(
                f"{path}: no pressure-level dimension for {u.name} (expected one of pressure_level, level, "
                f"isobaricInhPa, plev, lev); dimensions: {', '.join(map(str, dims))}"
            )
        if ds[level].ndim > 1 or (ds[level].ndim == 1 and ds[level].dims[0] not in dims):
            raise DataError(f"{path}: level coordinate '{level}' is not a dimension of {u.name}")
        self.level = level
        self.level_dim = ds[level].dims[0] if ds[level].ndim == 1 else None
        self.time_dim, self.time = self._time(ds, dims, coords, path, u.name)
        used = {self.time_dim, self.level_dim, self.lat_dim, self.lon_dim}
        self.extra = [d for d in dims if d not in used]
        for d in self.extra:
            if u.sizes[d] > 1 and d not in MERGED_DIMS:
                raise DataError(
                    f"{path}: {u.name} has a dimension '{d}' of {u.sizes[d]} values besides time, level, latitude and "
                    f"longitude (expected one field per time and level: select one {d})"
                )

    @staticmethod
    def _time(ds, dims, coords, path: Path, var) -> tuple[str | None, str]:
        """(time dimension or None for a single time, time coordinate)."""
        lower = {str(d).lower(): d for d in dims}
        for name in TIME_NAMES:
            if name in lower:
                vt = _find(("valid_time",), coords)  # cfgrib's time is the forecast's base time
                if vt is not None and ds[vt].dims == (lower[name],):
                    return lower[name], vt
                return lower[name], lower[name]
        if "step" in lower and ds[lower["step"]].size > 1:  # a cfgrib forecast: valid_time along step
            vt = _find(("valid_time",), coords)
            if vt is None or ds[vt].dims != (lower["step"],):
                raise DataError(f"{path}: {var} has forecast steps without a valid_time along them")
            return lower["step"], vt
        scalar = _find(TIME_NAMES, coords)  # one analysis time
        if scalar is None or ds[scalar].ndim != 0:
            raise DataError(
                f"{path}: no time dimension for {var} (expected one of valid_time, time); "
                f"dimensions: {', '.join(map(str, dims))}"
            )
        return None, scalar


def _field(var, lay: _Layout, axes: GridAxes, nodes: tuple[np.ndarray, ...]) -> np.ndarray:
    """var's values at the nodes, shaped (time, level, lat, lon), float64."""
    for d in lay.extra:
        if d in MERGED_DIMS and var.sizes[d] > 1:
            merged = var.isel({d: 0})
            for k in range(1, var.sizes[d]):
                merged = merged.fillna(var.isel({d: k}))
            var = merged
        else:
            var = var.isel({d: 0})
    src = [s[n] for s, n in zip(axes.source_index, nodes, strict=True)]
    order = []
    for dim, index in zip((lay.time_dim, lay.level_dim, lay.lat_dim, lay.lon_dim), src, strict=True):
        if dim is None:
            continue
        var = var.isel({dim: np.asarray(index, dtype=np.int64)})
        order.append(dim)
    values = np.asarray(var.transpose(*order).values, dtype=float)
    shape = tuple(i.size for i in src)
    return values.reshape(shape)


def read_wind_grid(
    path: str | Path,
    near: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None = None,
    name: str | None = None,
) -> WindGrid:
    """The analysis in `path` as a WindGrid named `name` (default: the file's stem). With
    `near` = (time UTC epoch s, pressure Pa, lat, lon) of the reports, only the grid nodes
    around those inside the grid are read (all of a large file's that matter); without it,
    every node. DataError (one line naming the file and what was expected) on any problem."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file; expected {EXPECTED}")
    kind = file_format(path)
    with _quiet_cfgrib(), _open(path, kind) as ds:
        u, v = _wind_variable(ds, path, "u"), _wind_variable(ds, path, "v")
        if u.dims != v.dims:
            raise DataError(f"{path}: {u.name} and {v.name} differ in dimensions ({u.dims} against {v.dims})")
        lay = _Layout(ds, u, path)
        factor = _speed_factor(u, path), _speed_factor(v, path)
        try:
            time_s = _epoch_seconds(ds[lay.time].values, path, lay.time)
            axes = grid_axes(time_s, _pressure_pa(ds[lay.level], path), ds[lay.lat].values, ds[lay.lon].values)
        except ValueError as e:
            if isinstance(e, DataError):
                raise
            raise DataError(f"{path}: {e}") from None
        if near is None:
            nodes: tuple[np.ndarray, ...] = tuple(np.arange(a.size) for a in axes.source_index)
        else:
            nodes = nodes_needed(axes, *near)
        try:
            uu = _field(u, lay, axes, nodes) * factor[0]
            vv = _field(v, lay, axes, nodes) * factor[1]
        except Exception as e:  # a damaged file shows only when its values are read
            raise DataError(f"{path}: cannot read {u.name}/{v.name} ({_one_line(e)})") from None
    loaded = axes if near is None else axes.take((nodes[0], nodes[1], nodes[2], nodes[3]))
    return WindGrid(loaded, uu, vv, path.stem if name is None else name, axes)
