"""A gridded weather analysis as the reference wind (aerotruth.measured.gridded reads it,
aerotruth.analysis.wind.gridded_reference interpolates it, `aerotruth reports --reference
FILE` writes the observation table): analyses written here in ERA5's layouts from fields
whose values and second derivatives are known, the interpolation error held to the bound of
the module docstring, sum_i s_i (h_i - s_i) / 2 * max|d2f/dx_i2| over the report's cell,
computed from the field, not tuned."""

from __future__ import annotations

import datetime as dt
import re

import numpy as np
import pandas as pd
import pytest
import traffic_generator as gen
import xarray as xr

from aerotruth.analysis.wind.gridded_reference import interpolate_wind
from aerotruth.measured.gridded import read_wind_grid

DAY0 = dt.datetime(2024, 6, 1, tzinfo=dt.UTC).timestamp()
ERA5_LEVELS_HPA = (1000, 975, 950, 925, 900, 875, 850, 825, 800, 775, 750, 700, 650, 600, 550, 500, 450, 400, 350,
                   300, 250, 225, 200, 175, 150)  # fmt: skip
# ICAO standard atmosphere, troposphere (Doc 7488/3): for the pressure altitude of a level
T0, P0, LAPSE, R_AIR, G0 = 288.15, 101325.0, 0.0065, 287.05287, 9.80665
EXPONENT = R_AIR * LAPSE / G0
FT = 0.3048
KT = 1852.0 / 3600.0


def isa_pressure_pa(alt_ft):
    """Tropospheric ISA pressure (Pa) at a pressure altitude (ft), written out here."""
    return P0 * (1.0 - LAPSE * np.asarray(alt_ft, float) * FT / T0) ** (1.0 / EXPONENT)


def isa_altitude_ft(p_pa):
    """Its inverse: the pressure altitude (ft) of a pressure (Pa), troposphere."""
    return T0 / LAPSE * (1.0 - (np.asarray(p_pa, float) / P0) ** EXPONENT) / FT


def write_analysis(path, times_s, levels_hpa, lats, lons, u, v, layout, pack=False):
    """u, v (m/s, shape time x level x lat x lon in the given coordinate orders) as a NetCDF
    file in one of the layouts data services write (module docstring of measured/gridded)."""
    names = {
        "cds": ("valid_time", "pressure_level", "latitude", "longitude", "u", "v", "hPa"),  # CDS since 2024
        "cds_legacy": ("time", "level", "latitude", "longitude", "u", "v", "millibars"),  # CDS before, packed
        "arco": ("time", "level", "lat", "lon", "u_component_of_wind", "v_component_of_wind", None),
    }[layout]
    t, lev, y, x, un, vn, level_units = names
    dims = (t, lev, y, x)
    wind_attrs = {"units": "m s**-1"}
    ds = xr.Dataset(
        {un: (dims, np.asarray(u, "f4"), wind_attrs), vn: (dims, np.asarray(v, "f4"), wind_attrs)},
        coords={
            t: pd.to_datetime(np.asarray(times_s), unit="s"),
            lev: (lev, np.asarray(levels_hpa, float), {} if level_units is None else {"units": level_units}),
            y: (y, np.asarray(lats, float), {"units": "degrees_north"}),
            x: (x, np.asarray(lons, float), {"units": "degrees_east"}),
        },
    )
    encoding = {}
    if pack:  # ERA5's NetCDF before 2024: 16-bit integers with a scale and offset per variable
        for n in (un, vn):
            lo, hi = float(ds[n].min()), float(ds[n].max())
            scale, offset = (hi - lo) / 65000.0, (hi + lo) / 2
            encoding[n] = {"dtype": "int16", "scale_factor": scale, "add_offset": offset, "_FillValue": -32767}
    ds.to_netcdf(path, encoding=encoding)
    return {n: encoding.get(n, {}).get("scale_factor", 0.0) / 2 for n in (un, vn)}  # packing's rounding


def cells(axis, x):
    """The report's cell on an ascending axis, computed here: (offset from the lower node, width)."""
    i = np.clip(np.searchsorted(axis, x, side="right") - 1, 0, axis.size - 2)
    return x - axis[i], axis[i + 1] - axis[i], i


def storage_error(u_ms, v_ms):
    """float32 rounding of the stored values (half an ulp of the largest)."""
    return float(np.finfo(np.float32).eps) * max(np.abs(u_ms).max(), np.abs(v_ms).max())


# --- 1. an analytic field: exact second derivatives ---------------------------------
OMEGA = 2 * np.pi / (6 * 3600.0)  # a 6-h period in time
Q_JET, SIGMA_Q = np.log(25000.0), 0.35  # a jet in ln p around 250 hPa
KY = 2 * np.pi / 8.0  # 8-deg waves in latitude
KX = 24 * np.pi / 180.0  # 24 waves round the earth in longitude: continuous across every seam


def analytic(t_s, p_pa, lat, lon):
    """(u, v) m/s at (UTC epoch s, Pa, deg, deg), smooth and periodic in longitude."""
    tt = np.asarray(t_s, float) - DAY0
    g = np.exp(-(((np.log(p_pa) - Q_JET) / SIGMA_Q) ** 2))
    lon_r = np.asarray(lon, float) * KX
    u = 20 + 8 * np.sin(OMEGA * tt + 0.3) + 15 * g + 6 * np.sin(KY * lat) * np.cos(lon_r)
    v = -4 + 5 * np.cos(OMEGA * tt) + 10 * g + 3 * np.cos(KY * lat) * np.sin(lon_r) + 0.5 * lat
    return u, v


# sup over all space of |d2/dx_i2| per term: (t, ln p, lat, lon) for u and for v
# (|d2/ds2 exp(-s^2)| <= 2 at s = 0, s = (q - q_jet) / sigma)
M_U = np.array([8 * OMEGA**2, 15 * 2 / SIGMA_Q**2, 6 * KY**2, 6 * KX**2])
M_V = np.array([5 * OMEGA**2, 10 * 2 / SIGMA_Q**2, 3 * KY**2, 3 * KX**2])

LAYOUTS = {
    # ERA5 from the CDS since 2024: valid_time, pressure_level, latitude 90 -> -90, longitude 0..360
    "cds_descending_0_360": dict(
        layout="cds", lats=np.arange(50.0, 39.99, -0.25), lons=np.arange(250.0, 280.01, 0.25), lon_q=(-105.0, -80.0)
    ),
    # ERA5 NetCDF before: time, level (millibars), packed int16; here latitude ascending and
    # longitude in -180..180 across the antimeridian (170 .. 180, -180 .. -170)
    "legacy_ascending_antimeridian": dict(
        layout="cds_legacy",
        lats=np.arange(40.0, 50.01, 0.25),
        lons=np.r_[np.arange(-180.0, -169.99, 0.25), np.arange(170.0, 179.99, 0.25)],
        lon_q=(170.0, 190.0),
        pack=True,
    ),
    # long names, lat/lon, a global 2.5-deg grid: reports between 357.5 and 360 take the seam
    "arco_global": dict(
        layout="arco", lats=np.arange(90.0, -90.01, -2.5), lons=np.arange(0.0, 359.99, 2.5), lon_q=(-5.0, 5.0)
    ),
}


@pytest.mark.parametrize("name", list(LAYOUTS))
def test_an_analytic_field_is_interpolated_within_its_bound(tmp_path, name):
    c = LAYOUTS[name]
    times = DAY0 + 3600.0 * np.arange(9, 15)
    levels = np.array(ERA5_LEVELS_HPA, float)
    grid_args = np.meshgrid(times, levels * 100, c["lats"], c["lons"], indexing="ij")
    u, v = analytic(*grid_args)
    rounding = write_analysis(
        tmp_path / "a.nc", times, levels, c["lats"], c["lons"], u, v, c["layout"], pack=c.get("pack", False)
    )
    rng = np.random.default_rng(4)
    n = 400
    t = rng.uniform(times[0], times[-1], n)
    p = isa_pressure_pa(rng.uniform(2000.0, 36000.0, n))
    lat = rng.uniform(41.0, 49.0, n)
    lon = rng.uniform(*c["lon_q"], n)
    ref = interpolate_wind(read_wind_grid(tmp_path / "a.nc"), t, p, lat, lon)
    assert not np.any(ref.outside_time | ref.outside_level | ref.outside_area | ref.missing_value)
    tu, tv = analytic(t, p, lat, lon)
    # the bound, each axis's cell computed here from the grid as written
    lon_axis = np.sort(c["lons"] % 360.0)
    if name == "arco_global":
        lon_axis = np.r_[lon_axis, 360.0]
    else:
        lon_axis = np.sort(np.where(lon_axis < 100.0, lon_axis + 360.0, lon_axis))  # one run across the seam
    lon_q = np.where(lon % 360.0 < lon_axis[0], lon % 360.0 + 360.0, lon % 360.0)
    terms = [
        cells(times, t),
        cells(np.log(np.sort(levels * 100)), np.log(p)),
        cells(np.sort(c["lats"]), lat),
        cells(lon_axis, lon_q),
    ]
    weight = np.column_stack([s * (h - s) / 2 for s, h, _ in terms])
    stored = storage_error(u, v)
    bound_u = weight @ M_U + stored + max(rounding.values())
    bound_v = weight @ M_V + stored + max(rounding.values())
    err_u, err_v = np.abs(ref.u_ms - tu), np.abs(ref.v_ms - tv)
    assert np.all(err_u <= bound_u) and np.all(err_v <= bound_v)
    # and the bound is not vacuous: the largest errors reach a good part of it
    ratio = max(np.max(err_u / bound_u), np.max(err_v / bound_v))
    assert ratio > 0.2
    print(
        f"{name}: |error| max {max(err_u.max(), err_v.max()):.4f} m/s, bound median "
        f"{np.median(np.r_[bound_u, bound_v]):.4f} m/s, error/bound max {ratio:.2f}"
    )
    # reading only the nodes around the reports gives the same numbers
    near = interpolate_wind(read_wind_grid(tmp_path / "a.nc", near=(t, p, lat, lon)), t, p, lat, lon)
    assert np.array_equal(near.u_ms, ref.u_ms) and np.array_equal(near.v_ms, ref.v_ms)


def test_reports_outside_the_grid_get_no_reference_and_are_counted(tmp_path):
    times = DAY0 + 3600.0 * np.arange(10, 13)
    levels, lats, lons = np.array([500.0, 300.0, 250.0]), np.arange(40.0, 50.01, 0.5), np.arange(-100.0, -85.0, 0.5)
    u, v = analytic(*np.meshgrid(times, levels * 100, lats, lons, indexing="ij"))
    write_analysis(tmp_path / "a.nc", times, levels, lats, lons, u, v, "cds")
    grid = read_wind_grid(tmp_path / "a.nc")
    t = np.array([DAY0 + 9.5 * 3600, DAY0 + 11 * 3600, DAY0 + 11 * 3600, DAY0 + 11 * 3600, DAY0 + 12 * 3600])
    p = np.array([40000.0, 60000.0, 40000.0, 40000.0, 25000.0])  # 600 hPa is below the lowest level
    lat = np.array([45.0, 45.0, 51.0, 45.0, 50.0])
    lon = np.array([-90.0, -90.0, -90.0, 275.0 - 360.0 + 0.2, -85.5])  # 275.2 E = -84.8: east of the grid
    ref = interpolate_wind(grid, t, p, lat, lon)
    assert ref.outside_time.tolist() == [True, False, False, False, False]
    assert ref.outside_level.tolist() == [False, True, False, False, False]
    assert ref.outside_area.tolist() == [False, False, True, True, False]
    assert np.isnan(ref.u_ms[:4]).all() and np.isfinite(ref.u_ms[4])  # the grid's corner is inside
    assert np.allclose((ref.u_ms[4], ref.v_ms[4]), analytic(t[4], p[4], lat[4], lon[4]), atol=1e-4)


# --- 1b. the simulation's truth atmosphere ----------------------------------------------
def truth_wind_on_pressure(atm, t_s, p_pa, lat, lon):
    """The truth wind (m/s) where the truth atmosphere has pressure p: the geometric height
    from Newton on the hypsometric equation of its ISA + dT column, then `wind` there."""
    from aerotruth.truth.isa import geometric_altitude_m, isa_temperature_k, pressure_altitude_m
    from aerotruth.truth.isa import isa_pressure_pa as column_pressure_pa

    t, p, lat, lon = np.broadcast_arrays(np.asarray(t_s, float) - DAY0, p_pa, lat, lon)
    d_t, p_sl = atm.delta_t(lat, lon, t), atm.sea_level_pressure(lat, lon, t)
    h = pressure_altitude_m(p)
    for _ in range(6):
        h = h + R_AIR * isa_temperature_k(h, d_t) / G0 * np.log(column_pressure_pa(h, d_t, p_sl) / p)
    u, v, _ = atm.wind(lat, lon, geometric_altitude_m(h), t)
    return u, v


def second_derivative_max(f, lower, width, sub=4):
    """max over each report's cell of |d2f/dx_i2| per axis (x = t, ln p, lat, lon): second
    differences at step h_i / sub on a sub x sub x sub x sub lattice of the cell. f(x) with x
    of shape (4, ...) returns (u, v); out: two arrays (reports, 4)."""
    frac = np.linspace(0.0, 1.0, sub)
    lattice = np.stack(np.meshgrid(frac, frac, frac, frac, indexing="ij")).reshape(4, -1)  # (4, sub^4)
    x = lower[:, :, None] + width[:, :, None] * lattice[None]  # (reports, 4, points)
    x = np.moveaxis(x, 1, 0)  # (4, reports, points)
    f0 = f(x)
    mu, mv = np.empty(lower.shape), np.empty(lower.shape)
    for i in range(4):
        step = width[:, i] / sub
        xp, xm = x.copy(), x.copy()
        xp[i] += step[:, None]
        xm[i] -= step[:, None]
        fp, fm = f(xp), f(xm)
        mu[:, i] = np.abs(fp[0] - 2 * f0[0] + fm[0]).max(axis=1) / step**2
        mv[:, i] = np.abs(fp[1] - 2 * f0[1] + fm[1]).max(axis=1) / step**2
    return mu, mv


@pytest.mark.parametrize("min_wavelength_km", [4.0, 100.0])
def test_the_truth_atmosphere_is_interpolated_within_the_bound_of_its_own_curvature(tmp_path, min_wavelength_km):
    """The truth atmosphere of a day on ERA5's grid (0.25 deg, hourly, its 25 levels 1000-150
    hPa; CDS names, latitude descending, longitude 0..360). With its full mesoscale spectrum
    (down to 4-km waves, which no 0.25-deg grid carries) and with waves of 100 km and more
    (what an analysis at that spacing resolves); the bound from the field's own second
    derivatives in each report's cell."""
    from aerotruth.truth.atmosphere import TruthAtmosphere, WindFieldSpec
    from aerotruth.truth.mesoscale import MesoscaleSpec

    spec = WindFieldSpec(mesoscale=MesoscaleSpec(min_wavelength_m=min_wavelength_km * 1e3))
    atm = TruthAtmosphere.for_day(dt.date(2024, 6, 1), 11, "upper_midwest", spec)
    times = DAY0 + 3600.0 * np.arange(10, 15)
    levels = np.array(ERA5_LEVELS_HPA, float)
    lats, lons = np.arange(47.0, 42.99, -0.25), np.arange(266.0, 272.01, 0.25)
    u, v = truth_wind_on_pressure(atm, *np.meshgrid(times, levels * 100, lats, lons, indexing="ij"))
    write_analysis(tmp_path / "era5.nc", times, levels, lats, lons, u, v, "cds")
    rng = np.random.default_rng(2)
    n = 16
    t = rng.uniform(times[0], times[-1], n)
    p = isa_pressure_pa(rng.uniform(5000.0, 36000.0, n))
    lat, lon = rng.uniform(43.1, 46.9, n), rng.uniform(-93.9, -88.1, n)
    ref = interpolate_wind(read_wind_grid(tmp_path / "era5.nc"), t, p, lat, lon)
    tu, tv = truth_wind_on_pressure(atm, t, p, lat, lon)
    axes = (times, np.log(np.sort(levels * 100)), np.sort(lats), np.sort(lons) - 360.0)
    terms = [cells(a, x) for a, x in zip(axes, (t, np.log(p), lat, lon), strict=True)]
    offset = np.column_stack([s for s, _, _ in terms])
    width = np.column_stack([h for _, h, _ in terms])
    lower = np.column_stack([x - s for x, (s, _, _) in zip((t, np.log(p), lat, lon), terms, strict=True)])

    def field(x):
        return truth_wind_on_pressure(atm, x[0], np.exp(x[1]), x[2], x[3])

    mu, mv = second_derivative_max(field, lower, width)
    weight = offset * (width - offset) / 2
    stored = storage_error(u, v)
    bound_u, bound_v = (weight * mu).sum(axis=1) + stored, (weight * mv).sum(axis=1) + stored
    err_u, err_v = np.abs(ref.u_ms - tu), np.abs(ref.v_ms - tv)
    assert np.all(err_u <= bound_u) and np.all(err_v <= bound_v)
    print(
        f"truth, waves >= {min_wavelength_km:g} km: |error| median {np.median(np.r_[err_u, err_v]):.3f}, max "
        f"{max(err_u.max(), err_v.max()):.3f} m/s; bound median {np.median(np.r_[bound_u, bound_v]):.3f} m/s; "
        f"error/bound max {max((err_u / bound_u).max(), (err_v / bound_v).max()):.2f}"
    )


# --- 2. GRIB through cfgrib ---------------------------------------------------------
def test_a_grib2_analysis_is_read_through_cfgrib(tmp_path):
    """GRIB2 messages made with ecCodes from its pressure-level sample (u, v at two times and
    two levels, latitude north to south, longitude 0..360), read through cfgrib: a field
    linear in time, ln p, latitude and longitude is interpolated exactly, to GRIB's packing."""
    try:
        import cfgrib  # noqa: F401
        import eccodes
    except Exception as e:  # the ecCodes library missing on this machine
        pytest.skip(f"ecCodes cannot be loaded: {e}")
    lats, lons = np.arange(50.0, 39.99, -0.5), np.arange(250.0, 260.01, 0.5)
    bits = 24

    def linear(t_s, p_pa, lat, lon):
        base = 10.0 + (np.asarray(t_s) - DAY0) / 3600.0 + 4.0 * np.log(p_pa / 1e5) + 0.3 * lat + 0.05 * (lon % 360)
        return base, 2.0 - 0.5 * base

    path = tmp_path / "an.grib2"
    with open(path, "wb") as f:
        for hour in (12, 13):
            for level in (500, 300):
                y, x = np.meshgrid(lats, lons, indexing="ij")
                u, v = linear(DAY0 + hour * 3600.0, level * 100.0, y, x)
                for short, values in (("u", u), ("v", v)):
                    gid = eccodes.codes_grib_new_from_samples("regular_ll_pl_grib2")
                    keys = {
                        "Ni": lons.size,
                        "Nj": lats.size,
                        "latitudeOfFirstGridPointInDegrees": 50.0,
                        "latitudeOfLastGridPointInDegrees": 40.0,
                        "longitudeOfFirstGridPointInDegrees": 250.0,
                        "longitudeOfLastGridPointInDegrees": 260.0,
                        "iDirectionIncrementInDegrees": 0.5,
                        "jDirectionIncrementInDegrees": 0.5,
                        "jScansPositively": 0,
                        "shortName": short,
                        "typeOfLevel": "isobaricInhPa",
                        "level": level,
                        "dataDate": 20240601,
                        "dataTime": hour * 100,
                        "bitsPerValue": bits,
                    }
                    for key, value in keys.items():
                        eccodes.codes_set(gid, key, value)
                    eccodes.codes_set_values(gid, values.ravel())
                    eccodes.codes_write(gid, f)
                    eccodes.codes_release(gid)
    grid = read_wind_grid(path)
    assert grid.name == "an" and grid.u_ms.shape == (2, 2, lats.size, lons.size)
    assert not list(tmp_path.glob("*.idx"))  # no index file left beside the data
    rng = np.random.default_rng(1)
    t = DAY0 + rng.uniform(12, 13, 50) * 3600.0
    p, lat, lon = rng.uniform(30000.0, 50000.0, 50), rng.uniform(40.0, 50.0, 50), rng.uniform(-110.0, -100.0, 50)
    ref = interpolate_wind(grid, t, p, lat, lon)
    tu, tv = linear(t, p, lat, lon)
    packing = 2.0 * 30.0 / 2**bits  # GRIB simple packing: the message's range over 2^bits, ranges < 30 m/s here
    assert np.abs(ref.u_ms - tu).max() < packing and np.abs(ref.v_ms - tv).max() < packing


# --- 3. end to end through the command line -------------------------------------------
def generator_analysis(path, lats, lons, times, levels_hpa=(500, 450, 400, 350, 300, 250), units="m s**-1"):
    """The traffic generator's wind (gen.wind_kt at the levels' pressure altitudes) as an
    ERA5 NetCDF in m/s, constant in time; (u, v) as written."""
    levels = np.asarray(levels_hpa, float)
    _, pp, yy, xx = np.meshgrid(times, levels * 100, lats, lons, indexing="ij")
    u_kt, v_kt = gen.wind_kt(yy, xx, isa_altitude_ft(pp))
    u, v = np.broadcast_to(u_kt * KT, pp.shape), np.broadcast_to(v_kt * KT, pp.shape)
    ds = write_analysis(path, times, levels, lats, lons, u, v, "cds")
    if units != "m s**-1":
        with xr.open_dataset(path) as d:
            d = d.load()
        d["u"].attrs["units"] = units
        d.to_netcdf(path)
    return u, v, ds


def test_reports_against_an_era5_file_end_to_end(tmp_path, capsys):
    """`aerotruth reports STATES.csv --reference era5.nc`: the reference is the generator's own
    wind within the interpolation bound, the table passes the observation reader, and the wind
    method's heading errors against that truth reference are the generator's heading offsets."""
    from aerotruth.analysis.wind.heading_errors import GateSpec, heading_errors
    from aerotruth.app.cli import main
    from aerotruth.contracts import OBSERVATION_REQUIRED
    from aerotruth.measured.observations import read_observation_table

    df, offsets = gen.make_traffic(6, seed=7, minutes=40)
    df.to_csv(tmp_path / "states.csv", index=False)
    times = DAY0 + 3600.0 * np.arange(11, 15)
    lats, lons = np.arange(48.0, 41.99, -0.25), np.arange(260.0, 275.01, 0.25)  # descending, 0..360
    u, v, _ = generator_analysis(tmp_path / "era5_20240601.nc", lats, lons, times)
    out = tmp_path / "obs.parquet"
    assert main(["reports", str(tmp_path / "states.csv"), "--reference", str(tmp_path / "era5_20240601.nc"),
                 "--out", str(out)]) == 0  # fmt: skip
    said = capsys.readouterr().out
    assert re.search(r"0 without a reference .*; \d+ reports of 6 aircraft against era5_20240601", said), said
    obs = read_observation_table(out)
    assert len(obs) == len(df) and set(OBSERVATION_REQUIRED) - {"time"} <= set(obs.columns)
    assert (obs["ref_source"] == "era5_20240601").all() and "ref_aircraft" not in obs.columns
    ru = -obs["ref_wind_speed_kt"].to_numpy() * np.sin(np.radians(obs["ref_wind_dir_deg"].to_numpy()))
    rv = -obs["ref_wind_speed_kt"].to_numpy() * np.cos(np.radians(obs["ref_wind_dir_deg"].to_numpy()))
    lat, lon, alt = obs["lat"].to_numpy(), obs["lon"].to_numpy(), obs["pressure_altitude_ft"].to_numpy()
    gu, gv = gen.wind_kt(lat, lon, alt)
    # the bound: the generator's second derivatives in kt per deg^2 and per (ln p)^2, written out
    p = isa_pressure_pa(alt)
    s_y, h_y, _ = cells(np.sort(lats), lat)
    s_x, h_x, _ = cells(np.sort(lons) - 360.0, lon)
    levels = np.log(np.array([250, 300, 350, 400, 450, 500]) * 100.0)
    s_q, h_q, i_q = cells(levels, np.log(p))
    p_cell_max = np.exp(levels[i_q + 1])  # |d2 alt / dq2| = (T0 / L) EXPONENT^2 (p / p0)^EXPONENT grows with p
    m_q = 0.002 * T0 / LAPSE * EXPONENT**2 * (p_cell_max / P0) ** EXPONENT / FT
    m_y = 5.0 * (20.0 * np.pi / 180.0) ** 2
    m_x = 4.0 * (15.0 * np.pi / 180.0) ** 2
    stored = storage_error(u, v) / KT
    bound_u = s_q * (h_q - s_q) / 2 * m_q + s_y * (h_y - s_y) / 2 * m_y + stored
    bound_v = s_x * (h_x - s_x) / 2 * m_x + stored
    err_u, err_v = np.abs(ru - gu), np.abs(rv - gv)
    assert np.all(err_u <= bound_u + 1e-9) and np.all(err_v <= bound_v + 1e-9)
    assert err_u.max() > 0.1 * bound_u.max()  # the curvature shows: the bound is not vacuous
    print(f"generator wind: |error| max {max(err_u.max(), err_v.max()):.4f} kt, bound max {bound_u.max():.4f} kt")
    # the wind method on the table: against the generator's wind, each aircraft's heading
    # error is its offset (BDS 6,0's 90/512-deg steps and 2-kt TAS steps around it); ADS-B
    # positions come to ~1e-5 deg, not TAMDAR's 0.01 deg the default ground-track gate assumes
    rows = heading_errors(obs, GateSpec(position_step_deg=1e-5))
    used = rows[rows["gate"] == "used"]
    assert used["aircraft"].nunique() == 6
    for aircraft, d in used.groupby("aircraft", observed=True)["error_deg"]:
        assert abs(d.median() - offsets[str(aircraft)]) < 0.1


def test_the_consensus_reference_keeps_its_own_columns(tmp_path, capsys):
    """The same table builder serves the consensus: `ref_source` consensus and `ref_aircraft`."""
    from aerotruth.analysis.wind.consensus import observation_table
    from aerotruth.measured.traffic import read_traffic

    df, _ = gen.make_traffic(5, seed=2, minutes=25, levels_ft=(30000.0,))
    df.to_csv(tmp_path / "states.csv", index=False)
    obs = observation_table(read_traffic(tmp_path / "states.csv"))
    assert list(obs.columns[12:15]) == ["declination_deg", "ref_source", "ref_aircraft"]
    assert (obs["ref_source"] == "consensus").all() and (obs["ref_aircraft"] >= 2).all()
    assert obs.attrs["samples"] == len(df) and obs.attrs["without_reference"] == len(df) - len(obs)


# --- 4. bad input, one line each --------------------------------------------------------
def _bad_files(tmp_path):
    times = DAY0 + 3600.0 * np.arange(0, 4)
    lats, lons, levels = np.arange(44.0, 46.01, 0.5), np.arange(-95.0, -90.99, 0.5), np.array([500.0, 300.0])
    shape = (times.size, levels.size, lats.size, lons.size)
    dims = ("valid_time", "pressure_level", "latitude", "longitude")
    coords = {"valid_time": pd.to_datetime(times, unit="s"), "pressure_level": levels, "latitude": lats,
              "longitude": lons}  # fmt: skip
    (tmp_path / "text.nc").write_text("valid_time,u,v\n2024-06-01,1,2\n")
    (tmp_path / "junk.grib").write_bytes(b"GRIB" + bytes(200))
    xr.Dataset({"t": (dims, np.zeros(shape))}, coords=coords).to_netcdf(tmp_path / "no_wind.nc")
    flat = {k: v for k, v in coords.items() if k != "pressure_level"}
    flat_dims, flat_shape = dims[:1] + dims[2:], shape[:1] + shape[2:]
    no_level = {"u": (flat_dims, np.zeros(flat_shape)), "v": (flat_dims, np.zeros(flat_shape))}
    xr.Dataset(no_level, coords=flat).to_netcdf(tmp_path / "no_level.nc")
    knots = {"units": "knots"}
    xr.Dataset({"u": (dims, np.zeros(shape), knots), "v": (dims, np.zeros(shape), knots)}, coords=coords).to_netcdf(
        tmp_path / "knots.nc"
    )
    xr.Dataset({"u": (dims, np.zeros(shape)), "v": (dims, np.zeros(shape))}, coords=coords).to_netcdf(
        tmp_path / "early.nc"
    )  # 00-03 UTC; the traffic flies 12-13 UTC


@pytest.mark.parametrize(
    ("reference", "message"),
    [
        ("missing.nc", r"--reference: expected one of consensus, got '.*missing.nc', which is not an existing file"),
        ("text.nc", r"text.nc: neither NetCDF nor GRIB \(by its content\); expected a gridded analysis"),
        ("junk.grib", r"junk.grib: cannot be read as GRIB \(.*\); expected a gridded analysis"),
        ("no_wind.nc", r"no_wind.nc: no u wind variable \(expected one of u, u_component_of_wind, uwnd.*variables: t$"),
        ("no_level.nc", r"no_level.nc: no pressure-level dimension for u \(expected one of pressure_level, level"),
        ("knots.nc", r"knots.nc: variable u has units 'knots', expected m/s"),
        (
            "early.nc",
            r"no sample lies inside the analysis .*early.nc \(2024-06-01 00:00 to 2024-06-01 03:00 UTC, 300-500 hPa, "
            r"lat 44 to 46, lon -95 to -91\): \d+ outside its times, 0 outside its levels",
        ),
    ],
)
def test_bad_analyses_are_refused_in_one_line(tmp_path, capsys, caplog, reference, message):
    from aerotruth.app.cli import main

    _bad_files(tmp_path)
    df, _ = gen.make_traffic(2, seed=1, minutes=25, levels_ft=(30000.0,))
    df.to_csv(tmp_path / "states.csv", index=False)
    argv = ["reports", str(tmp_path / "states.csv"), "--reference", str(tmp_path / reference)]
    assert main(argv + ["--out", str(tmp_path / "o.parquet")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and re.search(message, err), err
    assert not [r for r in caplog.records if r.exc_info]  # no library's traceback logged either
    assert not (tmp_path / "o.parquet").exists()


def test_reports_partly_outside_the_analysis_are_counted_in_the_line(tmp_path, capsys):
    """Levels 500-350 hPa north to 45 N: FL300 (301 hPa) is above the top level, FL240 north of
    45 N outside the area; each counted once, level before area."""
    from aerotruth.app.cli import main

    df, _ = gen.make_traffic(6, seed=3, minutes=40, levels_ft=(24000.0, 30000.0))
    df.to_csv(tmp_path / "states.csv", index=False)
    times = DAY0 + 3600.0 * np.arange(11, 15)
    lats, lons = np.arange(45.0, 41.99, -0.25), np.arange(260.0, 275.01, 0.25)  # the area's north edge at 45 N
    generator_analysis(tmp_path / "south.nc", lats, lons, times, levels_hpa=(500, 400, 350))
    assert main(["reports", str(tmp_path / "states.csv"), "--reference", str(tmp_path / "south.nc"),
                 "--out", str(tmp_path / "o.csv")]) == 0  # fmt: skip
    said = capsys.readouterr().out
    above = int((df["altitude"] == 30000.0).sum())
    north = int(((df["altitude"] == 24000.0) & (df["latitude"] > 45.0)).sum())
    assert above > 0 and north > 0 and above + north < len(df)
    m = re.search(
        r"(\d+) without a reference \(0 outside its times, (\d+) outside its levels, (\d+) outside its area", said
    )
    assert m and (int(m[2]), int(m[3]), int(m[1])) == (above, north, above + north), said
    assert len(pd.read_csv(tmp_path / "o.csv")) == len(df) - above - north
