"""Leg plans and schedules: runway choice into wind, cruise level rule, lateral path
geometry, vertical targets, schedule timing and determinism."""

from __future__ import annotations

import math
from datetime import UTC, date, datetime, timedelta

import numpy as np
import pytest

from aerotruth.geo import forward, inverse, wrap180
from aerotruth.truth.airports import Airport, Runway, airport, network
from aerotruth.truth.routes import (
    LegPlan,
    block_time_s,
    choose_runway,
    cross_track_to_centreline_m,
    cruise_altitude_ft,
    day_schedule,
    headwind_mps,
    hub_utc_offset_h,
    plan_leg,
    runway_frame_xy_m,
    semicircular_altitude_ft,
    with_airway,
)
from aerotruth.units import FT, KT, NM

T0 = datetime(2009, 8, 15, 12, 0, tzinfo=UTC)


def wind_from(direction_deg: float, speed: float) -> tuple[float, float]:
    """Meteorological wind (from direction) -> towards components (u east, v north)."""
    to = math.radians(direction_deg + 180.0)
    return speed * math.sin(to), speed * math.cos(to)


def synthetic_airport(
    icao: str,
    lat: float,
    lon: float,
    course_deg: float,
    elev_ft: float = 1000.0,
    undulation_m: float = -30.0,
    length_ft: float = 8000.0,
) -> Airport:
    """One-runway airport: runway centred on (lat, lon) with the given landing course for
    end '09'-like ident 'A' and its reciprocal 'B'."""
    half = length_ft * FT / 2.0
    a_lat, a_lon, _ = forward(lat, lon, course_deg + 180.0, half)
    b_lat, b_lon, _ = forward(lat, lon, course_deg, half)
    common = dict(
        airport=icao,
        elevation_m=elev_ft * FT,
        length_m=length_ft * FT,
        width_m=45.0,
        undulation_m=undulation_m,
        displaced_threshold_m=0.0,
        surface="ASP",
    )
    rw_a = Runway(
        ident="A",
        threshold_lat=a_lat,
        threshold_lon=a_lon,
        true_course_deg=course_deg % 360,
        start_lat=a_lat,
        start_lon=a_lon,
        reciprocal_ident="B",
        **common,
    )
    rw_b = Runway(
        ident="B",
        threshold_lat=b_lat,
        threshold_lon=b_lon,
        true_course_deg=(course_deg + 180) % 360,
        start_lat=b_lat,
        start_lon=b_lon,
        reciprocal_ident="A",
        **common,
    )
    return Airport(
        icao=icao,
        name=icao,
        lat=lat,
        lon=lon,
        elevation_m=elev_ft * FT,
        undulation_m=undulation_m,
        runways=(rw_a, rw_b),
    )


# ---------------------------------------------------------------- runway choice


def test_headwind_component_by_hand():
    east = synthetic_airport("XEAS", 45.0, -93.0, 90.0).runway("A")  # landing due east
    assert headwind_mps(east, (-5.0, 0.0)) == pytest.approx(5.0)  # air moving west: on the nose
    assert headwind_mps(east, (0.0, 7.0)) == pytest.approx(0.0, abs=1e-12)  # pure crosswind
    assert headwind_mps(east, wind_from(60.0, 10.0)) == pytest.approx(10.0 * math.cos(math.radians(30.0)))


@pytest.mark.parametrize(
    "from_deg, expected",
    [(170.0, "17"), (350.0, "35"), (45.0, "04"), (225.0, "22")],
)
def test_runway_most_into_the_wind_is_chosen(from_deg, expected):
    """KMSP runways 04/22 (045/225 T), 12/30 (121/301 T), 17/35 (170/350 T): a wind
    from a runway's heading makes that runway the one most into the wind."""
    assert choose_runway(airport("KMSP"), wind_from(from_deg, 8.0)).ident == expected


def test_parallel_runways_into_wind_choose_one_of_the_pair():
    rw = choose_runway(airport("KMSP"), wind_from(300.0, 12.0))
    assert rw.ident in {"30L", "30R"}


def test_no_wind_or_calm_chooses_the_longest_runway():
    assert choose_runway(airport("KMSP")).ident == "04"  # 04/22, 11,006 ft, lower ident
    assert choose_runway(airport("KMSP"), (0.0, 0.0)).ident == "04"
    assert choose_runway(airport("PANC")).ident == "15"  # 15/33, 11,584 ft


def test_bad_wind_is_rejected():
    with pytest.raises(ValueError, match="wind_uv"):
        choose_runway(airport("KMSP"), (1.0,))
    with pytest.raises(ValueError, match="finite"):
        choose_runway(airport("KMSP"), (float("nan"), 1.0))


# ---------------------------------------------------------------- cruise level


def test_semicircular_rule_odd_eastbound_even_westbound():
    assert semicircular_altitude_ft(17200.0, 90.0, floor_ft=14000, ceiling_ft=25000) == 17000.0
    assert semicircular_altitude_ft(17200.0, 270.0, floor_ft=14000, ceiling_ft=25000) == 18000.0
    assert semicircular_altitude_ft(17000.0, 179.9, floor_ft=14000, ceiling_ft=25000) == 17000.0
    assert semicircular_altitude_ft(17000.0, 180.0, floor_ft=14000, ceiling_ft=25000) == 16000.0  # tie -> lower
    assert semicircular_altitude_ft(30000.0, 0.0, floor_ft=14000, ceiling_ft=25000) == 25000.0
    assert semicircular_altitude_ft(30000.0, 359.0, floor_ft=14000, ceiling_ft=25000) == 24000.0


@pytest.mark.parametrize(
    "nm, course, expected_ft",
    [
        (100.0, 90.0, 15000.0),  # short: FL140-160
        (100.0, 270.0, 14000.0),
        (60.0, 270.0, 14000.0),  # floor FL140 by the rule (profile limits apply in plan_leg)
        (175.0, 45.0, 19000.0),  # halfway FL140 -> FL230 is 18,500 ft -> nearest odd
        (250.0, 90.0, 23000.0),  # >= 250 nm: FL220-250
        (250.0, 200.0, 22000.0),
        (400.0, 10.0, 25000.0),  # ceiling
        (400.0, 190.0, 24000.0),
    ],
)
def test_cruise_level_by_leg_length(nm, course, expected_ft):
    assert cruise_altitude_ft(nm * NM, course) == expected_ft


def test_cruise_level_jitter_keeps_rule_and_range():
    rng = np.random.default_rng(5)
    levels = {cruise_altitude_ft(175 * NM, 45.0, rng=rng) for _ in range(60)}
    assert levels == {17000.0, 19000.0, 21000.0}


def test_short_leg_cruise_is_lowered_until_climb_and_descent_fit():
    """KDTW-KFNT (48 nm): FL140 would not fit; the plan flies lower, on the rule's
    parity, with a 350 ft/nm climb, 3 deg descent and >= 10 nm cruise inside the path."""
    leg = plan_leg("KDTW", "KFNT", T0)
    cruise_ft = leg.cruise_pressure_altitude_m / FT
    assert 6000.0 <= cruise_ft < 14000.0
    assert (int(cruise_ft) // 1000) % 2 == (1 if leg.true_course_deg < 180 else 0)
    climb_nm = (cruise_ft - (leg.initial_height_m - leg.origin.undulation_m) / FT) / 350.0
    assert climb_nm * NM + leg.top_of_descent_to_go_m + 10.0 * NM <= leg.total_distance_m + 1.0
    # one level higher would not fit
    higher = cruise_ft + 2000.0
    climb_hi = (higher - (leg.initial_height_m - leg.origin.undulation_m) / FT) / 350.0 * NM
    tod_hi = LegPlan.descent_distance_m(higher * FT, leg.arrival_height_msl_m)
    assert climb_hi + tod_hi + 10.0 * NM > leg.total_distance_m


def test_leg_too_short_for_any_profile_is_an_error():
    a = synthetic_airport("XAAA", 45.0, -93.0, 90.0)
    b = synthetic_airport("XBBB", 45.0, -92.75, 90.0)  # ~10.6 nm east
    with pytest.raises(ValueError, match="too short"):
        plan_leg(a, b, T0)


def test_long_legs_cruise_high_and_short_legs_low():
    long_leg = plan_leg("PANC", "PADU", T0)  # ~690 nm
    assert 22000 <= long_leg.cruise_pressure_altitude_m / FT <= 25000
    short_leg = plan_leg("KMSP", "KBRD", T0)  # ~99 nm
    assert 13000 <= short_leg.cruise_pressure_altitude_m / FT <= 16000


# ---------------------------------------------------------------- lateral path


def test_intermediate_and_final_points_on_the_extended_centreline():
    leg = plan_leg("KMSP", "KDLH", T0, wind_uv=wind_from(270.0, 10.0))
    rw = leg.arrival_runway
    assert rw.ident == "27"
    names = [w.name for w in leg.waypoints]
    wp = {w.name: w for w in leg.waypoints}
    assert names[0] == "DEP" and names[-2:] == ["IF", "FINAL"]
    x_if, y_if = runway_frame_xy_m(rw, wp["IF"].lat, wp["IF"].lon)
    assert abs(y_if) < 1.0 and abs(cross_track_to_centreline_m(rw, wp["IF"].lat, wp["IF"].lon)) < 1.0
    assert x_if == pytest.approx(-12.0 * NM, abs=1.0)
    x_f, y_f = runway_frame_xy_m(rw, wp["FINAL"].lat, wp["FINAL"].lon)
    assert abs(y_f) < 1.0 and x_f == pytest.approx(-6.0 * NM, abs=1.0)


def test_runway_frame_axes_by_hand():
    """Runway landing due north at the equator-ish: a point 1 nm east is 1 nm to the
    right (y = -1852 m), 1 nm north is 1 nm past the threshold (x = +1852 m)."""
    rw = synthetic_airport("XNOR", 10.0, 20.0, 0.0).runway("A")
    lat_e, lon_e, _ = forward(rw.threshold_lat, rw.threshold_lon, 90.0, NM)
    x, y = runway_frame_xy_m(rw, lat_e, lon_e)
    assert x == pytest.approx(0.0, abs=0.5) and y == pytest.approx(-NM, abs=0.5)
    lat_n, lon_n, _ = forward(rw.threshold_lat, rw.threshold_lon, 0.0, NM)
    x, y = runway_frame_xy_m(rw, lat_n, lon_n)
    assert x == pytest.approx(NM, abs=0.5) and y == pytest.approx(0.0, abs=0.5)
    lats, lons = np.array([lat_e, lat_n]), np.array([lon_e, lon_n])
    assert np.allclose(cross_track_to_centreline_m(rw, lats, lons), [-NM, 0.0], atol=0.5)


def test_departure_starts_over_the_far_end_on_the_runway_course():
    leg = plan_leg("KMSP", "KRST", T0, wind_uv=wind_from(300.0, 10.0), arrival_wind_uv=None)
    dep = leg.departure_runway
    far = leg.origin.runway(dep.reciprocal_ident)
    start, climb = leg.waypoints[0], leg.waypoints[1]
    assert (start.lat, start.lon) == (far.start_lat, far.start_lon)
    assert leg.initial_course_deg == dep.true_course_deg
    az, _, dist = inverse(start.lat, start.lon, climb.lat, climb.lon)
    assert float(wrap180(az - dep.true_course_deg)) == pytest.approx(0.0, abs=1e-6)
    assert dist == pytest.approx(5.0 * NM, abs=0.01)
    # distance from the take-off start to the initial point is the runway length
    assert inverse(dep.start_lat, dep.start_lon, start.lat, start.lon)[2] == pytest.approx(dep.length_m, rel=0.05)
    assert leg.arrival_runway.ident == "13"  # arrival_wind_uv=None: KRST's longest, 13/31 (9,033 ft)


def test_heights_are_ellipsoidal_through_the_airport_undulation():
    """Initial point 400 ft above the far runway end, final point 2,000 ft above the
    arrival threshold, both plus the airport's N (hand: KDLH 27 threshold 1,419 ft,
    N = -28.393 m -> (1419 + 2000) ft * 0.3048 - 28.393 = 1013.718 m)."""
    leg = plan_leg("KMSP", "KDLH", T0, wind_uv=wind_from(270.0, 10.0))
    far = leg.origin.runway(leg.departure_runway.reciprocal_ident)
    assert leg.initial_height_m == pytest.approx((far.elevation_m + 400 * FT) + leg.origin.undulation_m, abs=1e-6)
    assert leg.initial_height_m - leg.origin.undulation_m - far.elevation_m <= 500 * FT
    assert leg.arrival_runway.elevation_m == pytest.approx(1419 * FT, abs=0.01)
    assert leg.destination.undulation_m == pytest.approx(-28.393, abs=1e-3)
    assert leg.arrival_height_m == pytest.approx(1013.718, abs=0.01)


def test_base_point_inserted_when_the_turn_at_the_if_would_exceed_90_degrees():
    """Destination runway lands due east; origin lies 150 nm east, so a direct to the
    IF (12 nm west of the threshold) would reverse course there: a BASE point 5 nm
    abeam the IF is inserted and the turn at the IF is 90 deg."""
    dst = synthetic_airport("XDST", 45.0, -93.0, 90.0)
    org_lat, org_lon, _ = forward(45.1, -93.0, 90.0, 150 * NM)
    org = synthetic_airport("XORG", org_lat, org_lon, 90.0)
    leg = plan_leg(org, dst, T0, wind_uv=(-5.0, 0.0))  # easterly wind: runway "A" (090) at both
    assert leg.arrival_runway.ident == "A"
    names = [w.name for w in leg.waypoints]
    assert names == ["DEP", "CLIMB", "BASE", "IF", "FINAL"]
    base, fix = leg.waypoints[2], leg.waypoints[3]
    x, y = runway_frame_xy_m(leg.arrival_runway, base.lat, base.lon)
    assert x == pytest.approx(-12.0 * NM, abs=2.0) and abs(y) == pytest.approx(5.0 * NM, abs=2.0)
    assert y > 0  # origin north of the centreline: left of the eastbound landing direction
    _, back, _ = inverse(base.lat, base.lon, fix.lat, fix.lon)
    rw = leg.arrival_runway
    final_course, _, _ = inverse(fix.lat, fix.lon, rw.threshold_lat, rw.threshold_lon)  # centreline at the IF
    assert abs(float(wrap180(final_course - (back + 180.0)))) == pytest.approx(90.0, abs=0.01)


def test_no_base_point_for_a_straight_in_arrival():
    dst = synthetic_airport("XDST", 45.0, -93.0, 90.0)
    org_lat, org_lon, _ = forward(45.0, -93.0, 270.0, 150 * NM)
    org = synthetic_airport("XORG", org_lat, org_lon, 90.0)
    leg = plan_leg(org, dst, T0, wind_uv=(-5.0, 0.0))
    assert [w.name for w in leg.waypoints] == ["DEP", "CLIMB", "IF", "FINAL"]


def test_distance_to_go_and_total_distance():
    leg = plan_leg("KMSP", "KFAR", T0)
    w = leg.waypoints
    by_hand = sum(inverse(a.lat, a.lon, b.lat, b.lon)[2] for a, b in zip(w[:-1], w[1:], strict=False))
    assert leg.total_distance_m == pytest.approx(by_hand, abs=1e-6)
    assert leg.distance_to_go_m(0, w[0].lat, w[0].lon) == pytest.approx(leg.total_distance_m, abs=1e-6)
    assert leg.distance_to_go_m(1, w[0].lat, w[0].lon) == pytest.approx(leg.total_distance_m, abs=1e-6)
    assert leg.distance_to_go_m(len(w) - 1, w[-1].lat, w[-1].lon) == pytest.approx(0.0, abs=1e-6)
    # great circle at least as long as the straight distance, and not much longer
    assert leg.distance_m * 0.85 < leg.total_distance_m < leg.distance_m * 1.3
    with pytest.raises(ValueError, match="index"):
        leg.distance_to_go_m(len(w), w[0].lat, w[0].lon)


def test_segment_cross_track_is_zero_on_the_segment_and_signed_off_it():
    leg = plan_leg("KMSP", "KFAR", T0)
    a, b = leg.waypoints[1], leg.waypoints[2]
    course, _, dist = inverse(a.lat, a.lon, b.lat, b.lon)
    mid_lat, mid_lon, _ = forward(a.lat, a.lon, course, dist / 2)
    assert abs(leg.cross_track_m(2, mid_lat, mid_lon)) < 1.0
    left_lat, left_lon, _ = forward(a.lat, a.lon, course - 90.0, 1000.0)
    assert leg.cross_track_m(2, left_lat, left_lon) == pytest.approx(1000.0, abs=1.0)


def test_three_degree_descent_is_318_ft_per_nm():
    assert LegPlan.descent_distance_m(3184.0 * FT, 0.0) == pytest.approx(10.0 * NM, rel=1e-3)
    leg = plan_leg("KMSP", "KBIS", T0)
    expected = (leg.cruise_pressure_altitude_m - leg.arrival_height_msl_m) / FT / 318.4 * NM
    assert leg.top_of_descent_to_go_m == pytest.approx(expected, rel=1e-3)


def test_plan_leg_rejects_bad_input():
    with pytest.raises(ValueError, match="departure_utc"):
        plan_leg("KMSP", "KDLH", datetime(2009, 8, 15, 12))
    with pytest.raises(ValueError, match="must differ"):
        plan_leg("KMSP", "kmsp", T0)
    with pytest.raises(ValueError, match="origin"):
        plan_leg(42, "KDLH", T0)
    with pytest.raises(ValueError, match="unknown ICAO"):
        plan_leg("KMSP", "KZZZ", T0)


def test_every_network_leg_plans_within_limits():
    for name in ("mesaba", "penair", "chautauqua"):
        net = network(name)
        for hub, spokes in net.spokes_by_hub.items():
            for spoke in spokes:
                for a, b in ((hub, spoke), (spoke, hub)):
                    leg = plan_leg(a, b, T0)
                    assert 6000 <= leg.cruise_pressure_altitude_m / FT <= 25000, (a, b)
                    assert leg.total_distance_m < 1.4 * leg.distance_m + 30 * NM, (a, b)


# ---------------------------------------------------------------- schedule


def test_block_time_is_distance_at_250_kt_plus_15_min():
    assert block_time_s(250 * NM) == pytest.approx(75 * 60.0)
    assert block_time_s(0.0) == pytest.approx(15 * 60.0)
    assert 250 * KT == pytest.approx(128.611, abs=1e-3)


def test_hub_offsets_by_hand():
    mesaba, penair, cq = network("mesaba"), network("penair"), network("chautauqua")
    assert hub_utc_offset_h(mesaba, "KMSP", date(2009, 8, 15)) == -5  # CDT
    assert hub_utc_offset_h(mesaba, "KMSP", date(2009, 1, 15)) == -6  # CST
    assert hub_utc_offset_h(mesaba, "KDTW", date(2009, 8, 15)) == -4  # EDT
    assert hub_utc_offset_h(penair, "PANC", date(2010, 7, 1)) == -8  # AKDT
    assert hub_utc_offset_h(penair, "PANC", date(2010, 12, 1)) == -9  # AKST
    assert hub_utc_offset_h(cq, "KIND", date(2009, 8, 15)) == -4
    assert hub_utc_offset_h(cq, "KSTL", date(2009, 8, 15)) == -5
    with pytest.raises(ValueError, match="not a hub"):
        hub_utc_offset_h(mesaba, "KDLH", date(2009, 8, 15))


@pytest.mark.parametrize("name", ["mesaba", "penair", "chautauqua"])
def test_schedule_alternates_hub_and_spoke_with_turn_times(name):
    net = network(name)
    for seed in range(6):
        day = date(2009, 8, 15) if seed % 2 else date(2010, 1, 20)
        legs = day_schedule(name, day, np.random.default_rng(seed), aircraft_id="N401XJ")
        assert 4 <= len(legs) <= 8
        hub = legs[0].origin.icao
        assert hub in net.hubs
        for k, leg in enumerate(legs):
            assert leg.flight_id == f"N401XJ-{day:%Y%m%d}-{k + 1}"
            if k % 2 == 0:
                assert leg.origin.icao == hub and leg.destination.icao in net.spokes_by_hub[hub]
            else:
                assert leg.destination.icao == hub and leg.origin.icao in net.spokes_by_hub[hub]
            if k > 0:
                assert leg.origin.icao == legs[k - 1].destination.icao
                turn = leg.departure_utc - legs[k - 1].departure_utc - timedelta(seconds=legs[k - 1].block_time_s)
                assert timedelta(minutes=30) <= turn <= timedelta(minutes=60)
        local = legs[0].departure_utc + timedelta(hours=hub_utc_offset_h(net, hub, day))
        assert local.date() == day
        assert 6 * 60 <= local.hour * 60 + local.minute <= 8 * 60
        assert legs[0].departure_utc.tzinfo == UTC


def test_schedule_is_deterministic_given_the_rng():
    a = day_schedule("mesaba", date(2009, 8, 15), np.random.default_rng(7), aircraft_id="N1")
    b = day_schedule("mesaba", date(2009, 8, 15), np.random.default_rng(7), aircraft_id="N1")
    assert a == b
    others = [
        day_schedule("mesaba", date(2009, 8, 15), np.random.default_rng(s), aircraft_id="N1") for s in range(8, 12)
    ]
    assert any(o != a for o in others)


def test_schedule_uses_the_surface_wind_for_runways():
    calls = []

    def wind(apt, t):
        calls.append((apt.icao, t))
        return wind_from(170.0, 10.0)

    legs = day_schedule("mesaba", date(2009, 8, 15), np.random.default_rng(3), aircraft_id="N2", surface_wind=wind)
    for leg in legs:
        assert leg.departure_runway == choose_runway(leg.origin, wind_from(170.0, 10.0))
        assert leg.arrival_runway == choose_runway(leg.destination, wind_from(170.0, 10.0))
        # a southerly wind: every chosen runway points south-ish, into it
        assert headwind_mps(leg.departure_runway, wind_from(170.0, 10.0)) > 0.0
    assert any(leg.departure_runway != choose_runway(leg.origin) for leg in legs)
    assert len(calls) == 2 * len(legs)
    assert calls[0] == (legs[0].origin.icao, legs[0].departure_utc)


def test_schedule_rejects_bad_input():
    rng = np.random.default_rng(0)
    with pytest.raises(ValueError, match="unknown network"):
        day_schedule("ryanair", date(2009, 8, 15), rng, aircraft_id="N1")
    with pytest.raises(ValueError, match="rng"):
        day_schedule("mesaba", date(2009, 8, 15), 7, aircraft_id="N1")
    with pytest.raises(ValueError, match="aircraft_id"):
        day_schedule("mesaba", date(2009, 8, 15), rng, aircraft_id="")


def _courses(plan):
    return [
        float(inverse(a.lat, a.lon, b.lat, b.lon)[0])
        for a, b in zip(plan.waypoints[:-1], plan.waypoints[1:], strict=False)
    ]


def test_airway_fixes_keep_the_ends_their_margins_and_the_paths_closure():
    plan = plan_leg("KMSP", "KDTW", datetime(2009, 8, 15, 13, tzinfo=UTC))
    names = [w.name for w in plan.waypoints]
    i = names.index("CLIMB")
    climb, nxt = plan.waypoints[i], plan.waypoints[i + 1]
    rng = np.random.default_rng(3)
    n_with = 0
    for _ in range(50):
        q = with_airway(plan, rng)
        awy = [w for w in q.waypoints if w.name.startswith("AWY")]
        n_with += bool(awy)
        # the ends are unchanged, the fixes sit between CLIMB and the next waypoint
        assert q.waypoints[: i + 1] == plan.waypoints[: i + 1]
        assert q.waypoints[i + 1 + len(awy) :] == plan.waypoints[i + 1 :]
        assert [w.name for w in q.waypoints[i + 1 : i + 1 + len(awy)]] == [f"AWY{k}" for k in range(1, len(awy) + 1)]
        for w in awy:
            assert inverse(climb.lat, climb.lon, w.lat, w.lon)[2] > 20 * NM * 0.95
            assert inverse(w.lat, w.lon, nxt.lat, nxt.lon)[2] > 20 * NM * 0.95
        assert q.segment_lengths_m == pytest.approx(
            [inverse(a.lat, a.lon, b.lat, b.lon)[2] for a, b in zip(q.waypoints[:-1], q.waypoints[1:], strict=False)]
        )
    assert n_with >= 45  # a 466-nm leg: ~4 fixes on average


def test_airway_course_changes_have_the_stated_size_and_cost_about_one_percent():
    # independent expectation: segment courses N(0, 9 deg) -> a change at a fix with rms
    # sqrt(2) x 9 = 12.7 deg, mean |change| sqrt(2/pi) x 12.7 = 10.2 deg; extra distance
    # E(1 - cos theta) = 9^2 / 2 deg^2 = 1.2 %
    plan = plan_leg("KMSP", "KDTW", datetime(2009, 8, 15, 13, tzinfo=UTC))
    rng = np.random.default_rng(11)
    changes, extra, counts = [], [], []
    for _ in range(400):
        q = with_airway(plan, rng)
        c = _courses(q)
        names = [w.name for w in q.waypoints]
        changes += [(c[k] - c[k - 1] + 180) % 360 - 180 for k in range(1, len(c)) if names[k].startswith("AWY")]
        extra.append(q.total_distance_m / plan.total_distance_m - 1)
        counts.append(sum(n.startswith("AWY") for n in names))
    assert 9.0 < np.mean(np.abs(changes)) < 11.5
    assert 0.004 < np.mean(extra) < 0.015
    # gamma(2) spacing of mean 100 nm over (466 - 5 - 12 - 2 x 20) nm of en-route path
    assert 3.3 < np.mean(counts) < 4.8


def test_airway_is_deterministic_and_short_legs_stay_direct():
    plan = plan_leg("KMSP", "KDTW", datetime(2009, 8, 15, 13, tzinfo=UTC))
    assert with_airway(plan, np.random.default_rng(7)) == with_airway(plan, np.random.default_rng(7))
    short = plan_leg("KDTW", "KFNT", datetime(2009, 8, 15, 13, tzinfo=UTC))
    assert with_airway(short, np.random.default_rng(7)) == short
    with pytest.raises(ValueError, match="rng"):
        with_airway(plan, 7)
