"""Embedded airport table: real airports, runway ends and geoid undulations of the
three 2009–2010 airline networks the project flies (Mesaba and PenAir SAAB 340s,
Chautauqua ERJ-145s).

The table is ``aerotruth/truth/data/airports.csv``, one row per runway end, built by
``tools/build_airports.py`` from OurAirports (public domain, runway ends, displaced
thresholds, elevations) and the EGM2008 geoid (undulation N at each airport); its
sources are stated in ``aerotruth/truth/data/README.md``. Runtime only reads the CSV.

Published elevations are above mean sea level (the geoid); GNSS and the truth use
WGS-84 ellipsoidal heights. The one conversion between them is
:func:`ellipsoidal_height_m` (h = H + N), used by every caller (docs/conventions.md, Heights and the geoid: "convert
with the geoid undulation of each airport in one place").
"""

from __future__ import annotations

import csv
from collections.abc import Mapping
from dataclasses import dataclass
from functools import lru_cache
from importlib import resources
from types import MappingProxyType

from aerotruth.units import FT

AIRPORTS_CSV = "airports.csv"


def ellipsoidal_height_m(height_msl_m, undulation_m):
    """WGS-84 ellipsoidal height h = H + N (m) from a height H above mean sea level
    (the geoid) and the geoid undulation N at the place (EGM2008, positive when the
    geoid lies above the ellipsoid). The project's single MSL -> ellipsoid conversion."""
    return height_msl_m + undulation_m


@dataclass(frozen=True)
class Runway:
    """One runway end, as an aircraft landing on it sees it.

    ``threshold_*`` is the landing threshold (displaced thresholds applied), centre of
    the runway width; ``true_course_deg`` is the direction an aircraft landing on this
    end flies; ``start_*`` is the physical runway end where a take-off on this runway
    begins its roll (equal to the threshold unless displaced). ``elevation_m`` is the
    threshold elevation above mean sea level, ``undulation_m`` the airport's geoid
    undulation (EGM2008).
    """

    airport: str
    ident: str
    threshold_lat: float
    threshold_lon: float
    elevation_m: float
    true_course_deg: float
    length_m: float
    width_m: float
    undulation_m: float
    displaced_threshold_m: float
    start_lat: float
    start_lon: float
    reciprocal_ident: str
    surface: str

    @property
    def threshold_height_ellipsoid_m(self) -> float:
        """WGS-84 ellipsoidal height of the threshold (m), through :func:`ellipsoidal_height_m`."""
        return ellipsoidal_height_m(self.elevation_m, self.undulation_m)


@dataclass(frozen=True)
class Airport:
    """An airport: ICAO code, name, reference point (deg), field elevation above mean
    sea level (m), EGM2008 geoid undulation at the reference point (m) and its runway
    ends (two per runway)."""

    icao: str
    name: str
    lat: float
    lon: float
    elevation_m: float
    undulation_m: float
    runways: tuple[Runway, ...]

    @property
    def elevation_ellipsoid_m(self) -> float:
        """WGS-84 ellipsoidal height of the field elevation (m)."""
        return ellipsoidal_height_m(self.elevation_m, self.undulation_m)

    def runway(self, ident: str) -> Runway:
        """The runway end named ``ident`` (e.g. '12R'); ValueError listing the ends if absent."""
        for rw in self.runways:
            if rw.ident == ident:
                return rw
        known = ", ".join(rw.ident for rw in self.runways)
        raise ValueError(f"runway: airport {self.icao} has no runway end {ident!r}; it has {known}")


@dataclass(frozen=True)
class Network:
    """An airline network of 2009–2010: hubs, the spokes flown from each hub, and
    each hub's time zone (IANA name; local times come from the tz database)."""

    name: str
    operator: str
    aircraft_type: str
    hubs: tuple[str, ...]
    spokes_by_hub: Mapping[str, tuple[str, ...]]
    hub_timezone: Mapping[str, str]

    @property
    def spokes(self) -> tuple[str, ...]:
        """All spokes of the network, sorted, each once."""
        return tuple(sorted({s for spokes in self.spokes_by_hub.values() for s in spokes}))

    @property
    def airports(self) -> tuple[str, ...]:
        """Hubs then spokes (ICAO codes)."""
        return self.hubs + tuple(s for s in self.spokes if s not in self.hubs)


def _network(name, operator, aircraft_type, spokes_by_hub, timezones) -> Network:
    return Network(
        name=name,
        operator=operator,
        aircraft_type=aircraft_type,
        hubs=tuple(spokes_by_hub),
        spokes_by_hub=MappingProxyType({h: tuple(s) for h, s in spokes_by_hub.items()}),
        hub_timezone=MappingProxyType(dict(timezones)),
    )


# Networks flown 2009-2010 (the airlines' published route maps of those years). Mesaba's
# Minneapolis and Detroit spokes are those named there; the Memphis spokes are real
# regional airports Northwest Airlink served from Memphis. Chautauqua's spokes are
# real eastern airports 90-500 nm from each hub: plausible ERJ-145 legs, not a
# reconstruction of a timetable.
_NETWORKS: dict[str, Network] = {
    "mesaba": _network(
        "mesaba",
        "Mesaba Airlines (Northwest Airlink)",
        "SAAB 340B",
        {
            "KMSP": (
                "KDLH",
                "KRST",
                "KBRD",
                "KBJI",
                "KHIB",
                "KINL",
                "KGFK",
                "KFAR",
                "KBIS",
                "KFSD",
                "KDSM",
                "KCID",
                "KLSE",
                "KEAU",
                "KCWA",
                "KRHI",
                "KGRB",
                "KATW",
                "KMSN",
            ),
            "KDTW": ("KTVC", "KMBS", "KFNT", "KLAN", "KGRR", "KAZO", "KSAW", "KESC", "KPLN"),
            "KMEM": ("KLIT", "KXNA", "KTYS", "KCHA", "KHSV", "KJAN", "KTUP", "KMLU"),
        },
        {"KMSP": "America/Chicago", "KDTW": "America/Detroit", "KMEM": "America/Chicago"},
    ),
    "penair": _network(
        "penair",
        "PenAir (Peninsula Airways)",
        "SAAB 340B",
        {"PANC": ("PADL", "PAKN", "PADU", "PACD", "PASD")},
        {"PANC": "America/Anchorage"},
    ),
    "chautauqua": _network(
        "chautauqua",
        "Chautauqua Airlines",
        "ERJ-145",
        {
            "KIND": ("KPIT", "KCLE", "KBNA", "KMKE", "KCLT", "KRDU", "KDCA"),
            "KCMH": ("KLGA", "KDCA", "KPHL", "KBUF", "KRDU", "KCLT", "KBNA", "KMKE"),
            "KSTL": ("KBNA", "KMKE", "KCLE", "KTYS", "KCHA", "KDSM", "KMCI", "KOMA"),
            "KORD": ("KPIT", "KCLE", "KBNA", "KBUF", "KROC", "KDAY", "KSDF", "KTYS"),
        },
        {
            "KIND": "America/Indiana/Indianapolis",
            "KCMH": "America/New_York",
            "KSTL": "America/Chicago",
            "KORD": "America/Chicago",
        },
    ),
}


def networks() -> dict[str, Network]:
    """The three networks by name: 'mesaba', 'penair', 'chautauqua'."""
    return dict(_NETWORKS)


def network(name: str) -> Network:
    """One network by name; ValueError naming the known networks otherwise."""
    try:
        return _NETWORKS[name]
    except (KeyError, TypeError):
        raise ValueError(f"network: unknown network {name!r}; expected one of {', '.join(sorted(_NETWORKS))}") from None


def network_airport_codes() -> tuple[str, ...]:
    """Every ICAO code of every network, sorted, each once (what the table must hold)."""
    return tuple(sorted({code for net in _NETWORKS.values() for code in net.airports}))


def _float(row: dict, column: str, line: int) -> float:
    try:
        return float(row[column])
    except (KeyError, ValueError):
        raise ValueError(
            f"{AIRPORTS_CSV} line {line}: column {column!r} must be a number, got {row.get(column)!r}"
        ) from None


@lru_cache(maxsize=1)
def _load() -> dict[str, Airport]:
    """Read the embedded CSV once (feet at the file's edge -> metres inside)."""
    text = resources.files("aerotruth.truth").joinpath("data").joinpath(AIRPORTS_CSV).read_text(encoding="utf-8")
    rows = list(csv.DictReader(text.splitlines()))
    runways: dict[str, list[Runway]] = {}
    heads: dict[str, dict] = {}
    for line, row in enumerate(rows, start=2):
        icao = row["icao"]
        heads.setdefault(icao, {**row, "_line": line})
        runways.setdefault(icao, []).append(
            Runway(
                airport=icao,
                ident=row["ident"],
                threshold_lat=_float(row, "threshold_lat_deg", line),
                threshold_lon=_float(row, "threshold_lon_deg", line),
                elevation_m=_float(row, "threshold_elevation_ft", line) * FT,
                true_course_deg=_float(row, "true_course_deg", line),
                length_m=_float(row, "length_ft", line) * FT,
                width_m=_float(row, "width_ft", line) * FT,
                undulation_m=_float(row, "undulation_m", line),
                displaced_threshold_m=_float(row, "displaced_threshold_ft", line) * FT,
                start_lat=_float(row, "start_lat_deg", line),
                start_lon=_float(row, "start_lon_deg", line),
                reciprocal_ident=row["reciprocal_ident"],
                surface=row["surface"],
            )
        )
    table = {}
    for icao, head in heads.items():
        line = head["_line"]
        table[icao] = Airport(
            icao=icao,
            name=head["name"],
            lat=_float(head, "airport_lat_deg", line),
            lon=_float(head, "airport_lon_deg", line),
            elevation_m=_float(head, "airport_elevation_ft", line) * FT,
            undulation_m=_float(head, "undulation_m", line),
            runways=tuple(runways[icao]),
        )
    return table


def airports() -> dict[str, Airport]:
    """Every airport of the embedded table by ICAO code."""
    return dict(_load())


def airport(icao: str) -> Airport:
    """The airport with this ICAO code (case-insensitive); ValueError listing the
    networks' airports if the table does not hold it."""
    if not isinstance(icao, str):
        raise ValueError(f"airport: ICAO code must be a string, got {icao!r}")
    table = _load()
    code = icao.strip().upper()
    if code in table:
        return table[code]
    listing = "; ".join(f"{net.name}: {', '.join(net.airports)}" for net in _NETWORKS.values())
    raise ValueError(f"airport: unknown ICAO code {icao!r}; the embedded table holds the network airports ({listing})")
