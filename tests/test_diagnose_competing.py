"""`aerotruth diagnose` on observation tables, the parts that keep it from naming the data's
own noise or a wrong cause: screening covariates whose noise is independent of the
residual's, candidate terms fitted by partialling out the model (exactly the full fit),
and the held-out contest that decides whether a finding beats its rivals or is named with
them as confusable. Expectations are analytic (a covariance worked by hand, the
Frisch-Waugh-Lovell identity checked against the full least-squares fit) or come from the
independent generator (tests/obs_generator.py)."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import obs_generator as gen
import pandas as pd
import pytest
import straight_obs_generator as sog

from aerotruth.analysis.diagnose.wind import WindModelSpec, diagnose_wind, prepare
from aerotruth.analysis.diagnose.wind_data import isa_density_ratio, neighbour_rate, report_rates
from aerotruth.analysis.diagnose.wind_model import (
    PERMUTATION_STAGES,
    Basis,
    Block,
    State,
    cand_soft_iron,
    cand_tas_scale,
    choose_deviation_heading,
    cluster_jackknife,
    current_blocks,
    cusum_permutation,
    held_out_contest,
    rows_of_fold,
    slope_permutation,
    solve,
    stack_channels,
    train_rows,
)
from aerotruth.analysis.diagnose.wind_weights import working_weights


def test_the_angle_of_attack_shapes_are_one_over_the_dynamic_pressure():
    """The pitch signature's two angle-of-attack columns on the straight-flight table,
    against the generator's own ISA density ratio (its implementation, not the project's):
    q_250/q = (250 kt)^2 / (sigma(h) TAS^2), 1 at 250 kt at sea level; q_cruise/q is the
    same shape times a constant per flight, q_cruise / q_250, q_cruise the median q of the
    flight's level rows (its median q over all its rows where it has none)."""
    df = sog.generate(0)
    d = prepare(df)
    q_gen = sog._sigma(d.alt_ft) * d.tas**2  # the generator's q (sigma TAS^2, m2/s2)
    q_250 = (250.0 * sog.KT) ** 2
    np.testing.assert_allclose(d.inv_q, q_250 / q_gen, rtol=1e-9)
    for f in np.unique(d.flight)[:20]:
        rows = d.flight == f
        level = rows & (d.phase == "level")
        q_cruise = np.median(q_gen[level]) if level.any() else np.median(q_gen[rows])
        np.testing.assert_allclose(d.inv_q_cruise[rows], q_cruise / q_gen[rows], rtol=1e-9)


def test_the_turn_rate_leaves_the_reports_own_heading_out():
    """A straight flight with white heading noise: the old rate (z[k] - z[k-1]) / dt
    correlates with the noise e[k] by +sigma^2 / dt (hand-worked: var(e) / dt); the
    neighbours' rate (z[k+1] - z[k-1]) / (t[k+1] - t[k-1]) does not correlate at all."""
    rng = np.random.default_rng(5)
    n, dt, sigma = 200_000, 300.0, np.radians(0.3)
    t = np.arange(n) * dt
    e = rng.normal(0, sigma, n)
    z = np.radians(90.0) + e
    turn, _, _ = report_rates(np.zeros(n, int), t, z, np.full(n, 20000.0))
    inner = slice(1, n - 1)
    c_new = np.mean(np.radians(turn[inner]) * e[inner])
    old = np.r_[0.0, np.diff(z) / dt]
    c_old = np.mean(old[inner] * e[inner])
    assert c_old == pytest.approx(sigma**2 / dt, rel=0.02)
    assert abs(c_new) < 0.01 * sigma**2 / dt
    # a steady turn is still measured: 1 deg/s exactly
    z2 = np.radians(np.arange(20) * 1.0 * 10.0) % (2 * np.pi)
    turn2, _, _ = report_rates(np.zeros(20, int), np.arange(20) * 10.0, z2, np.zeros(20))
    assert np.allclose(turn2[1:-1], 1.0) and turn2[0] == 0.0 and turn2[-1] == 0.0


def test_climb_rates_and_the_standard_atmosphere():
    """Climb rates from the altitudes (previous report; centred on the report), each flight
    on its own; ISA density ratio at 10,000 ft 0.7385 and 40,000 ft 0.2462 (ICAO tables)."""
    f = np.array([0, 0, 0, 1, 1])
    t = np.array([0.0, 60.0, 180.0, 0.0, 60.0])
    alt = np.array([1000.0, 2000.0, 2000.0, 5000.0, 4000.0])
    _, rate, rate_c = report_rates(f, t, np.zeros(5), alt)
    assert np.allclose(rate, [0.0, 1000.0, 0.0, 0.0, -1000.0])
    assert np.allclose(rate_c, [1000.0, 1000.0 * 60 / 180, 0.0, -1000.0, -1000.0])
    assert isa_density_ratio(np.array([10000.0]))[0] == pytest.approx(0.7385, abs=2e-4)
    assert isa_density_ratio(np.array([40000.0]))[0] == pytest.approx(0.2462, abs=2e-4)


def test_the_tas_rate_is_taken_between_the_neighbours():
    """Hand-worked: TAS 100, 103, 109, 109 m/s at 0, 60, 120, 240 s in one flight, 90 and 80
    at 0 and 100 s in another. Inner reports: (109 - 100) / 120 and (109 - 103) / 180;
    the ends one-sided with the report itself: 3 / 60, 0 / 120; the second flight -0.1 at
    both of its reports; a flight of one report: 0."""
    f = np.array([0, 0, 0, 0, 1, 1, 2])
    t = np.array([0.0, 60.0, 120.0, 240.0, 0.0, 100.0, 50.0])
    tas = np.array([100.0, 103.0, 109.0, 109.0, 90.0, 80.0, 70.0])
    r = neighbour_rate(f, t, tas)
    assert np.allclose(r, [3 / 60, 9 / 120, 6 / 180, 0.0, -0.1, -0.1, 0.0])


def test_a_wind_older_than_its_stamp_is_measured_in_seconds():
    """Hand-made table: one aircraft flies north at 120 m/s, climbing at 1,500 ft/min through
    a wind blowing towards the east at 10 m/s + 4 m/s per km of height (and 5 m/s towards
    the north), a report every 12 s. Its wind is the wind of 5 s before the stamp (a
    trailing mean stamped at its end), the two reference models give the wind at the stamp.
    The wind's rate between the neighbouring reports is 0.004 x 7.62 = 0.0305 m/s^2, and
    W_REF - W_TAM regressed on the two-channel column gives the lag, 5 s."""
    from aerotruth.analysis.diagnose.wind_model import wind_rate_column

    kt, lag = 1852.0 / 3600.0, 5.0
    t = np.arange(0.0, 1200.0, 12.0)
    h = 600.0 + 7.62 * t

    def wind(h_m):
        return 10.0 + 0.004 * h_m, np.full_like(h_m, 5.0)

    def speed_from(e, n):
        return np.hypot(e, n) / kt, np.degrees(np.arctan2(-e, -n)) % 360.0

    we, wn = wind(h)
    we_l, wn_l = wind(h - 7.62 * lag)
    va_e, va_n = -we_l, 120.0 - wn_l  # V_A = V_G - W_TAM
    ws, wd = speed_from(we_l, wn_l)
    rs, rd = speed_from(we, wn)
    base = pd.DataFrame(
        {
            "aircraft": "N1",
            "time": 1.25e9 + t,
            "lat": 44.0 + np.degrees(120.0 * t / 6367e3),
            "lon": -93.0,
            "pressure_altitude_ft": h / 0.3048,
            "wind_speed_kt": ws,
            "wind_dir_deg": wd,
            "heading_deg": np.degrees(np.arctan2(va_e, va_n)) % 360.0,
            "tas_kt": np.hypot(va_e, va_n) / kt,
        }
    )
    df = pd.concat(
        [base.assign(ref_source=m, ref_wind_speed_kt=rs, ref_wind_dir_deg=rd) for m in ("rr", "rtfdda")]
    ).sort_values(["time", "ref_source"], ignore_index=True)
    d = prepare(df)
    assert d.n >= 190
    assert np.allclose(d.wind_rate_e, 0.004 * 7.62) and np.allclose(d.wind_rate_n, 0.0, atol=1e-12)
    col, y = wind_rate_column(d), np.r_[d.trans, d.along]
    assert col @ y / (col @ col) == pytest.approx(lag, rel=0.01)


@pytest.mark.slow
def test_a_flux_valves_acceleration_error_is_named_by_its_signature():
    """A pendulous valve tilted aft by a speed change reads part of the vertical field: a
    heading error k tan(I) (dTAS/dt)/g sin(magnetic heading), hidden by the straight-flight
    generator with its own dipole field (k = -40 deg per unit, ~-1 deg in a climb on an
    east heading) against the wind paper's model: the acceleration-error signature first
    and alone (before the covariate existed: a pitch-coupled signature and a flight-phase
    term on seeds 0 and 1, wrong causes, nothing on seed 2; the null of this seed stays
    empty: test_the_straight_flight_cases). Its slope within 35 % of k: the
    generator's dipole dip (tan I 2.8 at the network's centre) is not IGRF's (3.3), and
    the rate between reports 3-7 min apart blurs the climb's ends (seeds 0-2 gave -43,
    -47, -30)."""
    spec = WindModelSpec(deviation_terms=3)
    found, _, _, _ = diagnose_wind(prepare(sog.generate(0, accel_error_deg=-40.0)), spec)
    assert [f.effect for f in found] == ["unexplained:transverse:accel_error"], [_group(f) for f in found]
    assert found[0].parameters["terms"][0]["slope"] == pytest.approx(-40.0, rel=0.35)


@pytest.fixture(scope="module")
def data():
    rng = np.random.default_rng(11)
    fleet = gen.fleet(8, rng, de_every=0, one_heading_last=False)
    return prepare(gen.generate(fleet, rng, flights=30))


@pytest.mark.parametrize("weighted", [False, True])
def test_partialling_out_is_the_full_fit(data, weighted):
    """Frisch-Waugh-Lovell: a candidate's coefficients and residuals from Basis.fit equal
    those of solving the whole design, on all rows and on a fold's training rows, by
    ordinary least squares and by generalised least squares with the working covariance
    (the residuals in the original units in both)."""
    d = data
    st = State(WindModelSpec(), [], 0.0, {}, set(), [])
    y = stack_channels(d.trans, d.along, d.n)
    clusters = np.r_[d.cluster, d.cluster]
    if weighted:
        st.weights = working_weights(d, solve(current_blocks(d, st), y, clusters, with_cov=False).resid)
        assert st.weights is not None  # the generator's reference errors are correlated along a flight
    basis = Basis(d, st, y, clusters)
    blocks = cand_soft_iron(d, st, None) + cand_tas_scale(d, st, None)
    cur = current_blocks(d, st)
    full = solve(cur + blocks, y, clusters, weights=st.weights)
    part = basis.fit(blocks)
    k = sum(b.cols.shape[1] for b in cur)
    assert np.allclose(part.beta, full.beta[k:], rtol=1e-7, atol=1e-10)
    assert np.allclose(part.resid, full.resid, atol=1e-8)
    assert np.all(np.isfinite(np.diag(part.cov))) and np.all(np.diag(part.cov) > 0)
    train = train_rows(d, 0)  # every fold but 0: what predicts fold 0
    assert not np.any(train & rows_of_fold(d, 0)) and np.all(train | rows_of_fold(d, 0))
    full0 = solve(cur + blocks, y, clusters, train, False, st.weights)
    part0 = basis.fit(blocks, 0, False)
    assert np.allclose(part0.resid, full0.resid, atol=1e-8)
    # a column the model already spans gets coefficient 0, not a number made of rounding
    dup = Block("x", "dup", cur[0].cols[:, :1] * 2.0)
    assert basis.fit([dup]).beta[0] == 0.0


def test_the_cluster_jackknife_is_leave_one_cluster_out():
    """cluster_jackknife against refitting with each cluster left out, by hand."""
    rng = np.random.default_rng(8)
    g = np.repeat(np.arange(12), 30)
    X = np.c_[np.ones(g.size), rng.normal(size=g.size), np.repeat(rng.normal(size=12), 30)]
    y = X @ [1.0, 0.5, -0.3] + np.repeat(rng.normal(size=12), 30) + rng.normal(size=g.size)
    V = cluster_jackknife(X, y, g, X.T @ X)
    bs = np.array([np.linalg.lstsq(X[g != k], y[g != k], rcond=None)[0] for k in range(12)])
    dev = bs - bs.mean(axis=0)
    assert np.allclose(V, 11 / 12 * dev.T @ dev, rtol=1e-9)


def test_the_block_permutation_cusum_is_calibrated():
    """Pure noise: p < 0.05 in about 5 % of 400 series of 30 blocks (binomial 95 % band
    2.9-7.6 %); a step of 2 sd half-way: p < 0.01 at the right place."""
    rng = np.random.default_rng(4)
    ps = np.array([cusum_permutation(rng.normal(size=30), (999,))[0] for _ in range(400)])
    assert 0.025 <= np.mean(ps < 0.05) <= 0.08
    p, k = cusum_permutation(np.r_[rng.normal(size=15), rng.normal(size=15) + 2.0])
    assert p < 0.01 and 12 <= k <= 16


def test_a_per_aircraft_scan_resolves_below_its_bonferroni_level():
    """The per-aircraft scans' permutations go on to 399,999 where p is below 0.002: a step
    of 10 sd half-way through 30 blocks is exceeded only by the permutations that keep its
    two halves apart, 2 / C(30, 15) = 1.3e-8 of them, so none of 399,999 and p = 1 / 400,000
    (at 39,999 it stopped at 1 / 40,000, above the ~7.5e-5 an aircraft of twelve must beat
    at the library's level); a p of ~0.01 stops at 39,999 (p x 40,000 a whole number)."""
    rng = np.random.default_rng(9)
    step = np.r_[np.zeros(15), np.full(15, 10.0)] + rng.normal(size=30)
    assert cusum_permutation(step, PERMUTATION_STAGES)[0] == 1 / 400_000
    assert cusum_permutation(step)[0] == 1 / 40_000
    t = np.arange(30.0)
    x = next(x for x in (rng.normal(size=30) + 0.02 * t for _ in range(2000)) if 0.004 < slope_permutation(t, x) < 0.02)
    p = slope_permutation(t, x, PERMUTATION_STAGES)
    assert p == slope_permutation(t, x)
    assert abs(p * 40_000 - round(p * 40_000)) < 1e-6


def test_the_block_slope_permutation_is_calibrated():
    """Pure noise on 28 blocks at uneven times: p < 0.05 in about 5 % of 400 series (band
    2.5-8 %) and p < 0.01 in about 1 %; a trend of 1.5 sd over the span: p < 0.001. (The
    slope's t test with a Bartlett lag-2 variance it replaces rejected 4.2 times the level
    at 0.01 on such series: 100,000 series measured.)"""
    rng = np.random.default_rng(8)
    t = np.sort(rng.uniform(0.0, 7.4, 28))
    ps = np.array([slope_permutation(t, rng.normal(size=28), (999,)) for _ in range(400)])
    assert 0.025 <= np.mean(ps < 0.05) <= 0.08
    assert np.mean(ps < 0.01) <= 0.025
    assert slope_permutation(t, 1.5 * t / 7.4 / 0.3 + rng.normal(size=28)) < 0.001


def test_the_deviation_heading_is_the_one_the_data_follow(data):
    """Transverse residuals made by hand from a once-round deviation of the magnetic
    heading (the reported true heading less the IGRF declination) or of the true heading:
    "auto" picks the one they were made of; a spec that names one keeps it."""
    from dataclasses import replace

    d0 = data
    rng = np.random.default_rng(12)
    assert np.ptp(np.degrees(d0.z - d0.z_mag)) > 3.0  # the network spans degrees of declination
    clusters = np.r_[d0.cluster, d0.cluster]
    for made_of, z in (("magnetic", d0.z_mag), ("true", d0.z)):
        dev = np.radians(0.5 + 3.0 * np.sin(z) - 2.0 * np.cos(z))
        d = replace(d0, trans=d0.tas * dev + rng.normal(0.0, 0.2, d0.n), along=rng.normal(0.0, 0.2, d0.n))
        y = stack_channels(d.trans, d.along, d.n)
        got = choose_deviation_heading(d, WindModelSpec(), y, clusters)
        assert got["chosen"] == made_of, got
        other = "true" if made_of == "magnetic" else "magnetic"
        assert got["transverse_rms_kt"][other] > 1.2 * got["transverse_rms_kt"][made_of]
        assert choose_deviation_heading(d, WindModelSpec(deviation_heading=other), y, clusters)["chosen"] == other


def test_the_held_out_contest():
    """x predicts every block better than y by a known amount: t large, p tiny; the same
    residuals: no winner; y better: p near 1."""
    rng = np.random.default_rng(3)
    g = np.repeat(np.arange(40), 50)
    truth = rng.normal(0, 1, g.size)
    r_x = rng.normal(0, 1.0, g.size)
    r_y = r_x + 0.5 * np.sign(rng.normal(size=g.size)) + 0.0 * truth
    t, p = held_out_contest(r_x, r_y, g)
    assert t > 10 and p < 1e-6
    t0, p0 = held_out_contest(r_x, r_x.copy(), g)
    assert p0 == 1.0
    t1, p1 = held_out_contest(r_y, r_x, g)
    assert p1 > 0.99


def _signature_covariates(f) -> list[str]:
    return [t["covariate"] for t in f.parameters.get("terms", [])]


def _group(f) -> list[str]:
    return [f.effect] + [c["effect"] for c in f.parameters.get("confusable_with", [])]


PITCH_LIKE = ("flight_path_angle_deg", "phase_ascent", "phase_descent")
# what the pitch signature's proxy is computed from: the climb rate (its sign the phase),
# the pressure altitude and the TAS (the dynamic pressure)
PROXY_MADE_OF = {"tas_kt", "pressure_altitude_ft", "phase_ascent", "phase_descent"}


@pytest.mark.slow
@pytest.mark.parametrize("seed", [0, 1])
def test_the_straight_flight_cases(seed):
    """The cases of a generator that is not the project's (tests/straight_obs_generator.py:
    straight legs, 0.3 deg of white heading noise per report, 2.2 m/s white reference
    errors, reports every 3-7 min) against the wind paper's model (A, B, C): nothing hidden,
    nothing found (before: a turn-rate term at ~+100 deg per deg/s, p < 1e-9, made of the
    heading noise); soft iron 1 deg: soft iron first and alone; a pitch-coupled heading error
    of 0.4 deg per deg of pitch (not in the library), its angle of attack at one cruise lift
    coefficient (each leg's cruise angle 2 deg) and at one weight (2 deg at 265 kt and
    19,000 ft, every leg): its signature first (flight-path angle, slope within 0.15 of 0.4),
    and no library cause named alone before it or after it. What the signature leaves of the
    pitch (in climbs whose flight-path angle three reports cannot resolve: a flight-phase
    term, seed 0) is said as confusable with the pitch term's shape, never alone (before:
    "transverse residual depends on the flight phase" as a second cause)."""
    spec = WindModelSpec(deviation_terms=3)
    null, _, _, _ = diagnose_wind(prepare(sog.generate(seed)), spec)
    assert null == [], [f.effect for f in null]
    soft, _, _, _ = diagnose_wind(prepare(sog.generate(seed, soft_iron_deg=1.0)), spec)
    assert [f.effect for f in soft] == ["soft_iron"], [_group(f) for f in soft]
    assert soft[0].parameters["size"] == pytest.approx(1.0, abs=0.25)
    for shape in ("cruise", "weight"):
        pitch, _, _, _ = diagnose_wind(prepare(sog.generate(seed, pitch_deg_per_deg=0.4, alpha_shape=shape)), spec)
        assert pitch, "nothing found"
        first = pitch[0]
        assert first.effect.startswith("unexplained:"), (shape, _group(first))
        covs = _signature_covariates(first)
        assert covs[0] == "flight_path_angle_deg", (shape, covs)
        assert first.parameters["terms"][0]["slope"] == pytest.approx(0.4, abs=0.15), shape
        for f in pitch:  # no library cause named alone
            assert f.effect.startswith("unexplained:") or any(
                c in PITCH_LIKE for r in f.parameters.get("confusable_with", []) for c in r.get("covariates", [])
            ), (shape, _group(f))
        for f in pitch[1:]:  # what the proxy leaves is said as the pitch term's shape, never alone
            if set(_signature_covariates(f)) <= PROXY_MADE_OF:
                assert any(
                    r.get("covariates", [""])[0] == "flight_path_angle_deg"
                    for r in f.parameters.get("confusable_with", [])
                ), (shape, _group(f))


def _fleet_blocks(step_deg: dict[int, float], rng, n_ac=8, n_blocks=30, shared_deg=2.0, own_deg=0.1):
    """Each of n_ac aircraft flies one report in each of n_blocks weather blocks (block b at
    b x 6 h): a shared error per block (the reference models' field, shared_deg), the
    aircraft's own noise (own_deg), and a step of step_deg[i] from block 15 on. A stand-in
    for WindData and Fit with what the fleet contrasts read."""
    from types import SimpleNamespace

    ac = np.repeat(np.arange(n_ac), n_blocks)
    blk = np.tile(np.arange(n_blocks), n_ac)
    t = blk * 6 * 3600.0 + 1800.0 + ac * 60.0
    shared = rng.normal(0, shared_deg, n_blocks)[blk]
    step = np.array([step_deg.get(i, 0.0) for i in range(n_ac)])[ac] * (blk >= 15)
    off_deg = shared + rng.normal(0, own_deg, len(ac)) + step
    tas = np.full(len(ac), 120.0)
    d = SimpleNamespace(
        n=len(ac), aircraft=ac, cluster=blk, block=blk, time_s=t, tas=tas, names=[f"N{401 + i}XJ" for i in range(n_ac)]
    )
    fit = SimpleNamespace(resid=np.r_[np.deg2rad(off_deg) * tas, np.zeros(len(ac))])
    return d, fit, 15 * 6 * 3600.0


def test_the_fleet_contrasts_find_the_aircraft_that_carry_a_fleet_step():
    """A fleet step of 1 deg on every aircraft, plus 0.6 deg more on aircraft 3 alone, under a
    shared block error 20 times the aircraft's own noise. Hand-worked contrast of aircraft 3:
    0.6 deg from block 15 on (its own mean minus the median of the seven others, which do not
    step); the others' medians include aircraft 3 at most as one of seven, above the middle.
    The shared error and the fleet's 1 deg cancel in every contrast, so only
    aircraft 3 is selected (Bonferroni over the 8 at 0.05), its step within 3 standard errors
    of 0.6 deg; with the same step on every aircraft, none is."""
    from aerotruth.analysis.diagnose.wind_model import carried_by, fleet_contrasts, selected_aircraft

    rng = np.random.default_rng(7)
    d, fit, t_step = _fleet_blocks({i: 1.0 for i in range(8)} | {3: 1.6}, rng)
    t, u = fleet_contrasts(d, fit)[3]
    after = t > t_step
    se = 0.1 * np.sqrt(1 + np.pi / 2 / 7) * np.sqrt(1 / 15 + 1 / 15)  # a median's variance: pi/2 a mean's
    assert abs(np.rad2deg(u[after].mean() - u[~after].mean()) - 0.6) < 3 * se
    ps = carried_by(d, fit, t_step)
    assert set(selected_aircraft(ps["recalibration"])) == {3}
    d, fit, t_step = _fleet_blocks({i: 1.0 for i in range(8)}, np.random.default_rng(8))
    assert selected_aircraft(carried_by(d, fit, t_step)["recalibration"]) == {}


@pytest.mark.parametrize(
    ("step_ps", "ramp_ps", "expected"),
    [
        # aircraft 3's step clears the bar (0.001 x 8 = 0.008 < 0.05); its ramp does not
        # (0.02 x 8 = 0.16) but is supported at 5 %: both named, the ramp on aircraft 3 only
        # (aircraft 5's ramp, 0.03, carries no step)
        ({3: 0.001}, {3: 0.02, 5: 0.03}, {"recalibration": ["N404XJ"], "offset_drift": ["N404XJ"]}),
        # the ramp not supported on the step's carrier (0.2): the step alone
        ({3: 0.001}, {3: 0.2}, {"recalibration": ["N404XJ"]}),
        # the other way round: aircraft 1's ramp clears the bar, its step is supported
        ({1: 0.04}, {1: 0.0005}, {"offset_drift": ["N402XJ"], "recalibration": ["N402XJ"]}),
        # both forms over the bar on their own aircraft: each its own, nothing added
        ({2: 0.001}, {6: 0.001, 2: 0.3}, {"recalibration": ["N403XJ"], "offset_drift": ["N407XJ"]}),
    ],
)
def test_a_fleet_change_carrier_is_said_in_both_forms_where_both_are_supported(monkeypatch, step_ps, ramp_ps, expected):
    """One aircraft's step in the middle of the period and its ramp are nearly the same
    series, so a carrier selected in one form (Bonferroni over the 8 aircraft at 0.05) is
    named in the other too where that form's unadjusted p is below ALPHA_RIVAL (5 %) and no
    aircraft was selected in it. The carriers' p-values are given (8 aircraft, 0.5 where not
    listed); what is named is worked by hand above each case."""
    from types import SimpleNamespace

    import aerotruth.analysis.diagnose.wind as wind

    def fake(d, fit, step_at):
        return {
            "recalibration": {i: step_ps.get(i, 0.5) for i in range(8)},
            "offset_drift": {i: ramp_ps.get(i, 0.5) for i in range(8)},
        }

    monkeypatch.setattr(wind, "carried_by", fake)
    d = SimpleNamespace(names=[f"N{401 + i}XJ" for i in range(8)])
    cand = {"key": "fleet_step", "sigs": [{"covariate": "fleet_step_86400"}]}
    got = {c["effect"]: c["aircraft"] for c in wind._carriers(d, None, cand)}
    assert got == expected


@pytest.mark.slow
def test_a_step_is_not_named_as_a_drift_that_holds_nothing_beside_it():
    """Three of twelve aircraft recalibrated mid-period by 0.75 deg (the independent
    generator, the confusion matrix's seed 70017): a ramp fitted to their offsets catches
    most of the step, and there its slope test is significant where the step's CUSUM scan
    is not yet (p 0.002 against the library's 0.001). The step beside the ramp still explains
    more, the ramp beside the step nothing: the ramp is a partial copy of the step, so it
    is not named alone (it was, before the lead was tested beside its weak rivals); the
    finding names the recalibration, alone or as confusable with the drift."""
    rng = np.random.default_rng(70017)
    fleet = gen.fleet(12, rng, de_every=0, one_heading_last=False)
    fleet = [replace(a, a_step_deg=0.75) if i < 3 else a for i, a in enumerate(fleet)]
    d = prepare(gen.generate(fleet, rng, flights=40))
    findings, _, _, _ = diagnose_wind(d, WindModelSpec())
    assert findings, "nothing found"
    f = findings[0]
    named = [f.effect, *(c["effect"] for c in f.parameters.get("confusable_with", []))]
    assert "recalibration" in named, named
    rival = f.evidence["rivals"].get("recalibration") if f.effect != "recalibration" else None
    if rival is not None:  # the drift led: the step is its confusable rival, not left apart
        assert rival["verdict"] == "confusable", rival
