"""The truth atmosphere's synoptic waves against radiosonde wind-speed statistics: for each
variant (the wave amplitudes scaled by f, the surface fraction p), the truth's median and
90th percentile of the speed at 850, 500 and 300 hPa over each network's region box in
the wind campaigns' four periods (every day, 00 and 12 UTC, 100 points; the days' weather
seeds of campaign seed 2010, as campaigns/wind_climatology.yaml samples them) against the
Range Reference Atmosphere site standing for the region (Kodiak for PenAir's Alaska,
judged; Wallops Island and Great Falls for the Chautauqua and Mesaba regions, shown), and
the HWM14 mean-vector cells of the campaign off by more than 30 % and 5 kt.

Prints per variant `label: value` lines: `<site>.rms_log` (RMS of log(truth / RRA) over the
24 statistics), `<site>.worst_log`, `<site>.beyond_20pct`, `hwm14_cells_off`; with
`--station`, the same for Kodiak at the station's own column (`kod13_station.*`;
validation/plans/wind-speed-station.md). A variant f,p,L,S also sets the summer jet's
latitude L and its day-to-day sd S.

    python validation/wind_speed_calibration.py RRA_DIR 1.0,0.45 1.7,0.30 ...
    python validation/wind_speed_calibration.py RRA_DIR --station 1.7,0.30,51,5 1.9,0.30,53,7 ...

RRA_DIR holds the RRA tables T1/T2 of kod13, wal13 and gtf06 (tools/rra_wind_speed.py).
"""

from __future__ import annotations

import argparse
import dataclasses
import datetime as dt
import importlib.util
import math
from pathlib import Path

import numpy as np
import yaml

from aerotruth.sim.studies.wind_climatology import RegionBox, msl_height_of_flight_level, region_box, sample_points
from aerotruth.sim.tasks import weather_seed
from aerotruth.truth.atmosphere import TruthAtmosphere, WindFieldSpec
from aerotruth.truth.weather import NETWORK_REGION
from aerotruth.units import KT

ROOT = Path(__file__).resolve().parents[1]
PERIODS = {
    "aug_sep_2009": ("2009-08-15", "2009-09-15"),
    "oct_nov_2009": ("2009-10-21", "2009-11-21"),
    "jan_mar_2010": ("2010-01-09", "2010-03-09"),
    "mar_may_2010": ("2010-03-27", "2010-05-27"),
}
SITES = {"penair": "kod13", "chautauqua": "wal13", "mesaba": "gtf06"}
LEVELS = {50: 843.0, 180: 506.0, 300: 301.0}  # flight level: hPa


def _rra_tool():
    spec = importlib.util.spec_from_file_location("rra_wind_speed", ROOT / "tools" / "rra_wind_speed.py")
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def rra_cells(rra_dir: Path) -> dict[tuple[str, str, int], tuple[float, float]]:
    r = _rra_tool()
    out = {}
    for net, site in SITES.items():
        t1, t2 = r.read_tables(rra_dir / f"T1{site}.txt"), r.read_tables(rra_dir / f"T2{site}.txt")
        for per, (a, b) in PERIODS.items():
            for fl, p in LEVELS.items():
                cell, _, _ = r.period_cell(t1, t2, p, dt.date.fromisoformat(a), dt.date.fromisoformat(b), check=False)
                out[net, per, fl] = (cell["p50_speed_kt"], cell["p90_speed_kt"])
    return out


def period_samples(spec: WindFieldSpec, region, box, period: str, seed: int = 2010, points: int = 100):
    """{FL: (p50 kt, p90 kt, mean u, mean v)} of the truth over `box` in `period`: every day's
    realization of `region` (a network's region name or a centre), 00 and 12 UTC, `points`
    uniform over the box area at each flight level's height."""
    a, b = PERIODS[period]
    d, end = dt.date.fromisoformat(a), dt.date.fromisoformat(b)
    rng = np.random.default_rng(1)
    sp: dict[int, list] = {fl: [] for fl in LEVELS}
    uv: dict[int, list] = {fl: [] for fl in LEVELS}
    while d <= end:
        atm = TruthAtmosphere.for_day(d, weather_seed(seed, d), region, spec)
        for fl in LEVELS:
            for hour in (0, 12):
                lat, lon = sample_points(rng, box, points)
                t = np.full(points, hour * 3600.0)
                z = msl_height_of_flight_level(atm, lat, lon, fl, t)
                u, v, _ = (np.asarray(c) for c in atm.wind(lat, lon, z, t))
                sp[fl].append(np.hypot(u, v) / KT)
                uv[fl].append(np.c_[u, v])
        d += dt.timedelta(days=1)
    out = {}
    for fl in LEVELS:
        s, w = np.concatenate(sp[fl]), np.concatenate(uv[fl])
        out[fl] = (*np.percentile(s, [50, 90]), *w.mean(axis=0))
    return out


def truth_cells(spec: WindFieldSpec):
    """{(network, period, FL): (p50 kt, p90 kt, mean u, mean v)} of the truth over each
    network's region box, in its region's realization."""
    out = {}
    for net in SITES:
        box = region_box(RegionBox(name=net, network=net))
        for per in PERIODS:
            for fl, cell in period_samples(spec, NETWORK_REGION[net], box, per).items():
                out[net, per, fl] = cell
    return out


KODIAK_BOX = (56.75, 58.75, -152.0, -149.0)  # the campaign's region kodiak: +-1 deg around the station


def station_cells(spec: WindFieldSpec):
    """{(period, FL): (p50 kt, p90 kt, mean u, mean v)} of the truth at Kodiak's column (its
    own realization, centred on the box, as the campaign samples an explicit box)."""
    s_, n_, w_, e_ = KODIAK_BOX
    centre = (0.5 * (s_ + n_), 0.5 * (w_ + e_))
    out = {}
    for per in PERIODS:
        for fl, cell in period_samples(spec, centre, KODIAK_BOX, per).items():
            out[per, fl] = cell
    return out


def hwm14_off(truth) -> int:
    doc = yaml.safe_load((ROOT / "campaigns" / "wind_climatology.yaml").read_text())
    ref = doc["studies"]["wind_climatology"]["references"][0]
    net_of = {region: net for net, region in NETWORK_REGION.items()}
    off = 0
    for c in ref["cells"]:
        t = truth[net_of[c["region"]], c["period"], c["flight_level"]]
        tv, sv = math.hypot(t[2], t[3]), math.hypot(c["mean_u_mps"], c["mean_v_mps"])
        off += abs(tv - sv) > max(ref["tolerance"] * sv, ref["min_difference_kt"] * KT)
    return off


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("rra_dir", type=Path)
    ap.add_argument(
        "variants",
        nargs="+",
        help="f,p[,L,S]: the wave amplitudes' factor and the surface fraction, and optionally the summer jet's "
        "latitude L and its day-to-day sd S (deg)",
    )
    ap.add_argument(
        "--station",
        action="store_true",
        help="also compare Kodiak's soundings with the truth at the station's own column (+-1 deg, the "
        "atmosphere's realization centred there, as the campaign's region kodiak): `kod13_station.*` lines",
    )
    a = ap.parse_args()
    ref = rra_cells(a.rra_dir)
    base = WindFieldSpec()
    lo0, hi0 = (8.0, 18.0)  # the amplitudes before calibration (m/s at the jet, x jet speed / 45)
    for variant in a.variants:
        vals = [float(x) for x in variant.split(",")]
        f, p = vals[0], vals[1]
        spec = dataclasses.replace(base, wave_amplitude_ms=(lo0 * f, hi0 * f), wave_surface_fraction=p)
        label = f"f{f:g}_p{p:g}"
        if len(vals) == 4:
            spec = dataclasses.replace(spec, jet_latitude_summer_deg=vals[2], jet_latitude_sd_deg=vals[3])
            label += f"_lat{vals[2]:g}_sd{vals[3]:g}"
        truth = truth_cells(spec)
        if a.station:
            st = station_cells(spec)
            logs = [math.log(st[k[1:]][i] / ref[k][i]) for k in ref if k[0] == "penair" for i in (0, 1)]
            print(f"{label}.kod13_station.rms_log: {math.sqrt(np.mean(np.square(logs))):.3f}")
            print(f"{label}.kod13_station.worst_log: {max(map(abs, logs)):.3f}")
            print(f"{label}.kod13_station.beyond_20pct: {sum(not 0.8 <= math.exp(x) <= 1.2 for x in logs)}")
        for net, site in SITES.items():
            logs = [math.log(truth[k][i] / ref[k][i]) for k in ref if k[0] == net for i in (0, 1)]
            print(f"{label}.{site}.rms_log: {math.sqrt(np.mean(np.square(logs))):.3f}")
            print(f"{label}.{site}.worst_log: {max(map(abs, logs)):.3f}")
            print(f"{label}.{site}.beyond_20pct: {sum(not 0.8 <= math.exp(x) <= 1.2 for x in logs)}")
        print(f"{label}.hwm14_cells_off: {hwm14_off(truth)}", flush=True)


if __name__ == "__main__":
    main()
