"""The wind paper's heading-deviation method (aerotruth.analysis.wind.heading_correction and the
`heading fit` command function) against reports from an independent generator
(tests/obs_generator.py) whose deviation, noise and reference errors are known."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import obs_generator as gen
import pandas as pd
import pytest

from aerotruth.analysis.wind.heading_correction import TABLE_COLUMNS, FleetHeadingFit, HeadingDeviationFit
from aerotruth.analysis.wind.heading_errors import GateSpec, heading_errors, towards_from_report
from aerotruth.analysis.wind.observations import validate_observations
from aerotruth.app.heading_fit import heading_fit_main

REQUIRED_HEAD = (
    "aircraft, status, reason, n_used, A_deg, B_deg, C_deg, D_deg, E_deg, A_se_deg, B_se_deg, C_se_deg, "
    "D_se_deg, E_se_deg, lut_000_deg, lut_045_deg, lut_090_deg, lut_135_deg, lut_180_deg, lut_225_deg, "
    "lut_270_deg, lut_315_deg, valid_from, valid_to"
).split(", ")


@pytest.fixture(scope="module")
def fleet_run(tmp_path_factory):
    """12 regional jets x 40 hub-and-spoke flights (1000-1800 km legs), three reference
    models; the last aircraft flies one heading. Written as Parquet and run through the
    command's function. (Reference errors correlated over 30 min leave ~one independent
    error per half hour of flight: the standard errors reach 0.07 deg only with long, fast
    legs and three models; SAAB-like legs of 250-650 km with two models give ~0.11.)"""
    rng = np.random.default_rng(1)
    truths = gen.fleet(12, rng, tas_kt=(430.0, 480.0))
    obs = gen.generate(
        truths, rng, models=("rr", "rtfdda", "nam"), spoke_km=(1000.0, 1800.0), cruise_ft=(25000.0, 35000.0)
    )
    d = tmp_path_factory.mktemp("heading")
    obs.to_parquet(d / "obs.parquet")
    assert heading_fit_main(str(d / "obs.parquet"), str(d / "out")) == 0
    return truths, obs, d / "out"


def _z_scores(row: pd.Series, truth: gen.AircraftTruth, terms: str) -> dict[str, float]:
    return {t: (row[f"{t}_deg"] - getattr(truth, t)) / row[f"{t}_se_deg"] for t in terms}


@pytest.mark.slow
def test_heading_fit_recovers_each_aircrafts_deviation_within_three_standard_errors(fleet_run):
    truths, _, out = fleet_run
    table = pd.read_csv(out / "deviation_mag.csv").set_index("aircraft")  # the generator's frame: magnetic
    worst_z, worst_se = 0.0, 0.0
    for a in truths:
        row = table.loc[a.aircraft]
        if a.one_heading:
            continue
        assert row["status"] == "fitted", row["reason"]
        terms = "ABCDE" if (a.D, a.E) != (0.0, 0.0) else "ABC"
        assert row["terms"].startswith(terms), (a.aircraft, row["terms"], row["reason"])
        z = _z_scores(row, a, row["terms"])
        worst_z = max(worst_z, *map(abs, z.values()))
        worst_se = max(worst_se, *(row[f"{t}_se_deg"] for t in row["terms"]))
        assert all(abs(v) <= 3.0 for v in z.values()), (a.aircraft, z)
        assert all(row[f"{t}_se_deg"] <= 0.07 for t in row["terms"]), (
            a.aircraft,
            row[[f"{t}_se_deg" for t in "ABCDE"]],
        )
    print(f"worst |z| {worst_z:.2f}, worst se {worst_se:.3f} deg")


@pytest.mark.slow
def test_bootstrap_intervals_of_the_table_entries_hold_the_true_table(fleet_run):
    """deviation_mag_ci.csv (the generator's frame): the 95 % intervals of the 8 table
    entries of the fitted aircraft hold the true table -d(z_k) about 95 % of the time."""
    truths, _, out = fleet_run
    ci = pd.read_csv(out / "deviation_mag_ci.csv", dtype={"aircraft": str})
    assert list(ci.columns) == ["aircraft", "quantity", "estimate", "lo", "hi", "boot_se", "level", "n_boot", "method"]
    hits = []
    for a in truths:
        if a.one_heading:
            continue
        lut = ci[(ci["aircraft"] == a.aircraft) & ci["quantity"].str.startswith("lut_")]
        z = lut["quantity"].str[4:7].astype(float).to_numpy()
        true = -a.deviation(z)
        hits += list((lut["lo"].to_numpy() <= true) & (true <= lut["hi"].to_numpy()))
        assert (lut["lo"] < lut["estimate"]).all() and (lut["estimate"] < lut["hi"]).all()
    print(f"table entries covered: {np.mean(hits):.3f} of {len(hits)}")
    assert len(hits) == 88 and np.mean(hits) >= 0.85  # 95 % expected; binomial sd 0.023


@pytest.mark.slow
def test_an_aircraft_flying_one_heading_gets_the_offset_only_never_a_sinusoid(fleet_run):
    truths, _, out = fleet_run
    one = next(a for a in truths if a.one_heading)
    for name in ("deviation.csv", "deviation_mag.csv"):
        row = pd.read_csv(out / name).set_index("aircraft").loc[one.aircraft]
        assert row["status"] in ("offset_only", "refused")
        assert "coverage" in row["reason"]
        assert row[["B_deg", "C_deg", "D_deg", "E_deg"]].abs().max() == 0.0
        assert row[["B_se_deg", "C_se_deg"]].isna().all()
        luts = row[[c for c in TABLE_COLUMNS if c.startswith("lut_")]].to_numpy(dtype=float)
        assert np.allclose(luts, -row["A_deg"])


@pytest.mark.slow
def test_deviation_csv_has_the_documented_columns_and_a_figure_per_aircraft(fleet_run):
    truths, _, out = fleet_run
    table = pd.read_csv(out / "deviation.csv")
    assert list(table.columns[: len(REQUIRED_HEAD)]) == REQUIRED_HEAD
    assert len(table) == len(truths)
    assert set(table["status"]) <= {"fitted", "offset_only", "refused"}
    assert (table["valid_from"] <= table["valid_to"]).all()
    for a in truths:
        assert (out / "figures" / f"{a.aircraft}.png").stat().st_size > 10_000
    report = (out / "report.md").read_text()
    assert "after the lookup tables" in report and "three-report ground-track gates" in report


@pytest.mark.slow
def test_true_heading_fit_equals_the_magnetic_one_turned_by_the_declination(fleet_run):
    """On true heading z = z' + delta the same curve has B, C turned by delta (the generator's
    declination, +1 deg at the hub, varies by a few degrees: a small blur)."""
    truths, _, out = fleet_run
    tru = pd.read_csv(out / "deviation.csv").set_index("aircraft")
    mag = pd.read_csv(out / "deviation_mag.csv").set_index("aircraft")
    for a in truths:
        if a.one_heading or (a.D, a.E) != (0.0, 0.0):
            continue
        dl = np.radians(1.0)
        b_true = a.B * np.cos(dl) + a.C * np.sin(dl)
        c_true = a.C * np.cos(dl) - a.B * np.sin(dl)
        r = tru.loc[a.aircraft]
        assert abs(r["A_deg"] - mag.loc[a.aircraft, "A_deg"]) < 0.02
        assert abs(r["B_deg"] - b_true) < 3 * r["B_se_deg"] + 0.05
        assert abs(r["C_deg"] - c_true) < 3 * r["C_se_deg"] + 0.05


@pytest.mark.slow
def test_correcting_the_reports_removes_the_transverse_wind_error(fleet_run):
    """The paper's signature (Tables II-IV): the transverse component falls, the longitudinal
    does not. Reference errors are 4 kt per component, so ~4 kt is the floor."""
    _, _, out = fleet_run
    text = (out / "report.md").read_text()
    before = [float(x) for x in text.split("| before |")[1].split("\n")[0].strip(" |").split(" | ")]
    after = [float(x) for x in text.split("| after the lookup tables |")[1].split("\n")[0].strip(" |").split(" | ")]
    assert before[2] > 8.0 and after[2] < 4.6
    assert abs(after[1] - before[1]) < 0.3


def _cramer_rao(rows: pd.DataFrame, sigma_ms: float) -> np.ndarray:
    """CRB of (A, B, C) in deg^2 for independent Gaussian reference-wind errors of sd sigma
    per component: psi' moves by e_perp / |V_A| (rad), so d_i = x_i b + n_i with
    n_i ~ N(0, sigma^2/V_i^2) independent over (report, model) rows; the Fisher information
    is sum x_i x_i^T V_i^2 / sigma^2 (rad^-2), and its inverse is the bound."""
    u = rows[rows["gate"] == "used"]
    z = np.radians(u["heading_mag_deg"].to_numpy())
    X = np.column_stack([np.ones_like(z), np.sin(z), np.cos(z)])
    info = (X * (u["tas_ms"].to_numpy() ** 2 / sigma_ms**2)[:, None]).T @ X
    return np.linalg.inv(info) * np.degrees(1.0) ** 2


@pytest.mark.slow
def test_standard_errors_are_within_1_2_of_the_cramer_rao_bound():
    a = gen.AircraftTruth("N450XJ", A=1.5, B=-2.0, C=1.0, cruise_tas_kt=280.0)
    sigma_kt = 4.0
    zs, ratio = [], []
    for r in range(60):
        rng = np.random.default_rng([5, r])
        obs = gen.generate([a], rng, flights=12, models=("rr",), ref_tau_s=0.0, exact=True, ref_sigma_kt=sigma_kt)
        rows = heading_errors(obs)
        fit = HeadingDeviationFit(terms="sinusoid", heading="magnetic", min_clusters=5).fit(rows)
        crb = np.sqrt(np.diag(_cramer_rao(rows, sigma_kt * 1852 / 3600)))
        est = np.array([fit.coef_[t] for t in "ABC"])
        zs.append((est - [a.A, a.B, a.C]) / crb)
        ratio.append(np.array([fit.se_[t] for t in "ABC"]) / crb)
    spread = np.std(zs, axis=0, ddof=1)  # the estimator's sd in units of the bound
    print("sd / CRB", spread.round(3), "mean se / CRB", np.mean(ratio, axis=0).round(3))
    assert np.all(spread <= 1.2)
    assert np.all((np.mean(ratio, axis=0) > 0.8) & (np.mean(ratio, axis=0) <= 1.2))


def test_bootstrap_intervals_run_and_cover_in_a_loose_band():
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
    import heading_coverage

    res = heading_coverage.coverage(reps=12, n_boot=60, flights=16, seed=3)
    for t in "ABC":
        assert 0.6 <= res[f"coverage_{t}"] <= 1.0, res
    assert 0.6 <= res["coverage_lut_min"] <= res["coverage_lut_max"] <= 1.0, res


def test_reference_model_with_a_wind_bias_is_flagged_by_the_consistency_check():
    """A model that is 10 kt too strong from the west moves psi' by a sinusoid in heading:
    the two models' curves differ and the fit says so."""
    rng = np.random.default_rng(11)
    a = gen.AircraftTruth("N460XJ", A=0.5, B=1.0, C=0.5, cruise_tas_kt=280.0)
    obs = gen.generate([a], rng, flights=20)
    rr = obs["ref_source"] == "rr"
    u, v = towards_from_report(obs.loc[rr, "ref_wind_speed_kt"], obs.loc[rr, "ref_wind_dir_deg"])
    u = u + 10 * 1852 / 3600
    obs.loc[rr, "ref_wind_speed_kt"] = np.hypot(u, v) / (1852 / 3600)
    obs.loc[rr, "ref_wind_dir_deg"] = np.degrees(np.arctan2(-u, -v)) % 360
    fit = HeadingDeviationFit(terms="sinusoid", heading="magnetic").fit(obs)
    assert "disagree" in fit.reason_ and fit.consistency_p_ < 1e-4
    clean = HeadingDeviationFit(terms="sinusoid", heading="magnetic").fit(
        gen.generate([a], np.random.default_rng(11), flights=20)
    )
    assert "agree" in clean.reason_ and "disagree" not in clean.reason_


def test_true_heading_aircraft_get_an_offset_only_table():
    rng = np.random.default_rng(12)
    a = gen.AircraftTruth("N470XJ", A=-3.0, B=1.5, C=0.0, cruise_tas_kt=280.0)
    obs = gen.generate([a], rng, flights=16).assign(heading_input="true")
    fit = FleetHeadingFit(heading="magnetic").fit(obs).fits_["N470XJ"]
    assert fit.status_ == "offset_only" and "true heading" in fit.reason_
    assert fit.coef_["B"] == 0.0 and np.isnan(fit.se_["B"])
    assert abs(fit.coef_["A"] - a.A) < 4 * fit.se_["A"]  # hub-and-spoke headings average the sinusoid out
    assert np.allclose(fit.lut_, -fit.coef_["A"])


def test_one_route_flown_both_ways_fixes_the_sinusoid_along_its_axis_only():
    """Out and back on one spoke: the data hold d(z_a) and d(z_a + 180), so A and the
    sinusoid's component along the axis, s = B sin z_a + C cos z_a, are identified, the
    perpendicular component is not (the fit sets it to 0), and the table corrects the
    headings flown."""
    rng = np.random.default_rng(21)
    a = gen.AircraftTruth("N490XJ", A=1.0, B=2.0, C=-1.5, cruise_tas_kt=280.0, spoke=2)
    obs = gen.generate([a], rng, flights=30)
    fit = HeadingDeviationFit(heading="magnetic").fit(obs)
    assert fit.status_ == "fitted" and "one axis" in fit.reason_, fit.reason_
    rows = heading_errors(obs)
    z = rows.loc[rows["gate"] == "used", "heading_mag_deg"].to_numpy()
    z2 = np.radians(2 * z)
    za = 0.5 * np.arctan2(np.sin(z2).mean(), np.cos(z2).mean())  # the flown axis: mean doubled angle
    along = np.array([np.sin(za), np.cos(za)])
    s_true = along @ [a.B, a.C]
    s_fit = along @ [fit.coef_["B"], fit.coef_["C"]]
    se_s = np.hypot(fit.se_["B"], fit.se_["C"])  # the two are one parameter projected
    assert abs(s_fit - s_true) < 3 * se_s + 0.05, (s_fit, s_true, se_s)
    assert abs(fit.coef_["A"] - a.A) < 3 * fit.se_["A"] + 0.05
    perp = np.array([np.cos(za), -np.sin(za)]) @ [fit.coef_["B"], fit.coef_["C"]]
    assert abs(perp) < 0.15 * abs(s_fit)  # the fitted axis is the flown one (+- the spread of headings)
    for h in (np.degrees(za), np.degrees(za) + 180):  # on the headings flown the table is right
        # within 3 standard errors of the table there (A and the along-axis s), plus 0.05 deg
        # for the short-span reports whose heading axis comes from rounded positions
        # (errors in variables flatten the sinusoid by ~exp(-sd^2 / 2))
        se_h = np.hypot(
            fit.se_["A"], np.hypot(fit.se_["B"] * np.sin(np.radians(h)), fit.se_["C"] * np.cos(np.radians(h)))
        )
        assert abs(float(fit.correction(h)) + float(a.deviation(h))) < 3 * se_h + 0.05
    offset = HeadingDeviationFit(heading="magnetic", terms="offset").fit(obs)
    assert abs(float(offset.correction(np.degrees(za))) + float(a.deviation(np.degrees(za)))) > 0.7 * abs(
        s_true
    )  # what an offset misses


def test_heading_error_equals_the_deviation_on_noise_free_reports():
    """Eqs. 3 and 4 with a perfect reference: psi - psi' is the deviation at the measured heading.
    Only the 0.01-deg position quantisation blurs the heading axis: <= ~1.1 km over a >= 10-km
    baseline is up to ~6 deg of heading, times the curve's slope (<= 4.2 deg/rad here) ~0.45 deg."""
    a = gen.AircraftTruth("N480XJ", A=2.0, B=-1.0, C=3.0, D=0.5, cruise_tas_kt=280.0)
    obs = gen.generate([a], np.random.default_rng(13), flights=6, ref_sigma_kt=0.0, exact=True)
    rows = heading_errors(obs, GateSpec(min_baseline_km=10.0))  # the bound below is for >= 10-km spans
    u = rows[rows["gate"] == "used"]
    resid = u["error_deg"].to_numpy() - a.deviation(u["heading_mag_deg"].to_numpy())
    assert np.median(np.abs(resid)) < 0.05 and np.max(np.abs(resid)) < 0.45


def test_reported_wind_from_the_west_blows_towards_the_east():
    # to the single-precision trig's bound (aerotruth.analysis.wind.fast_trig: 2.6e-7 of the speed)
    u, v = towards_from_report([10.0, 10.0], [270.0, 0.0])
    assert np.allclose(u, [10 * 1852 / 3600, 0.0], atol=2e-6) and np.allclose(v, [0.0, -10 * 1852 / 3600], atol=2e-6)


def test_lookup_table_correction_is_piecewise_linear_round_the_circle():
    """A = 1, C = 2: d(0) = 3, d(45) = 1 + sqrt 2, d(315) = 1 + sqrt 2; corrections are -d."""
    row = {c: 0.0 for c in TABLE_COLUMNS}
    row.update(
        aircraft="X",
        status="fitted",
        reason="",
        n_used=100,
        A_deg=1.0,
        C_deg=2.0,
        valid_from="2009-01-01",
        valid_to="2009-02-01",
        A_se_deg=0.1,
        B_se_deg=0.1,
        C_se_deg=0.1,
        D_se_deg=np.nan,
        E_se_deg=np.nan,
    )
    z = np.radians(np.arange(0, 360, 45))
    for c, val in zip([c for c in TABLE_COLUMNS if c.startswith("lut_")], -(1 + 2 * np.cos(z)), strict=False):
        row[c] = val
    fit = HeadingDeviationFit.from_table(pd.DataFrame([row]))
    s2 = np.sqrt(2)
    assert fit.correct(22.5) == pytest.approx(22.5 - (3 + 1 + s2) / 2)
    assert fit.correct(350.0) == pytest.approx(350.0 - ((1 + s2) * (10 / 45) + 3 * (35 / 45)))
    assert fit.correct(0.5) == pytest.approx((0.5 - (3 * (44.5 / 45) + (1 + s2) * (0.5 / 45))) % 360.0)
    assert fit.correct(90.0) == pytest.approx(89.0)  # d(90) = 1
    assert fit.correct(1.0) == pytest.approx(fit.correct(361.0))
    assert fit.correct(-22.5) == pytest.approx((-22.5 - (3 + 1 + s2) / 2) % 360.0)  # below 0: round the circle
    assert np.isnan(fit.correct(np.array([np.nan, np.inf]))).all()  # no heading, no correction


def test_lookup_tables_chosen_per_heading_interpolate_their_own_table():
    """Several tables (one per aircraft) and a table index per heading: each heading takes
    its own table's two neighbouring points (hand-worked)."""
    from aerotruth.analysis.wind.heading_correction import lut_correction

    luts = np.vstack([np.arange(8.0), 10.0 * np.arange(8.0)])
    got = lut_correction(luts, np.array([22.5, 22.5, 337.5, 315.0]), table=np.array([0, 1, 1, 0]))
    assert got == pytest.approx([0.5, 5.0, 35.0, 7.0])  # 337.5: halfway from 70 back to 0
    with pytest.raises(ValueError, match="lut"):
        lut_correction(np.zeros(7), np.array([1.0]))


def test_learned_state_survives_to_table_and_from_table():
    obs = gen.generate([gen.AircraftTruth("N490XJ", A=1.0, B=2.0, C=-1.0)], np.random.default_rng(14), flights=12)
    fleet = FleetHeadingFit(heading="magnetic").fit(obs)
    back = FleetHeadingFit.from_table(fleet.to_table())
    h = np.linspace(0, 359, 50)
    assert np.allclose(back.correct("N490XJ", h), fleet.correct("N490XJ", h))
    assert back.fits_["N490XJ"].status_ == fleet.fits_["N490XJ"].status_
    assert np.allclose(fleet.correct("unknown", h), h)  # no table, no correction


def test_shuffled_table_with_repeated_rows_gives_the_same_fit():
    obs = gen.generate([gen.AircraftTruth("N500XJ", A=1.0, B=2.0, C=-1.0)], np.random.default_rng(15), flights=10)
    shuffled = pd.concat([obs, obs.iloc[:50]]).sample(frac=1.0, random_state=1)
    shuffled["time"] = pd.to_datetime(shuffled["time"], unit="s", utc=True).dt.strftime("%Y-%m-%dT%H:%M:%SZ")
    a = HeadingDeviationFit(heading="magnetic").fit(obs)
    b = HeadingDeviationFit(heading="magnetic").fit(shuffled)
    assert a.coef_ == pytest.approx(b.coef_)


def test_rows_are_ordered_as_a_full_sort_by_aircraft_time_and_model():
    """validate_observations orders rows by aircraft, time, reference model (two stable
    sorts, then the runs of one aircraft and time by reference; an ordered table is kept as
    it is). Against numpy's lexsort on random small tables, time-ordered or not, up to three
    reference models a report, with missing aircraft and times (rows that are then dropped
    may sit anywhere)."""
    from aerotruth.analysis.wind.observations import _sort_order

    rng = np.random.default_rng(0)
    for trial in range(2000):
        n = int(rng.integers(1, 40))
        ac = rng.integers(-1, 4, n).astype(np.int8)
        t = rng.integers(0, 5, n).astype(float)
        if trial % 3 == 0:
            t[rng.random(n) < 0.1] = np.nan
        if trial % 2 == 0:
            t = np.sort(t)
        ref = rng.integers(0, 3, n).astype(np.int8)
        got, want = _sort_order(ac, t, ref), np.lexsort((ref, t, ac))
        keep = (ac >= 0) & np.isfinite(t)
        assert np.array_equal(got[keep[got]], want[keep[want]])


@pytest.mark.parametrize(
    "mutate, words",
    [
        (lambda df: df.drop(columns="wind_dir_deg"), ["obs.csv", "missing column 'wind_dir_deg'"]),
        (
            lambda df: df.assign(ref_wind_speed_kt=df["ref_wind_speed_kt"].astype(object).where(df.index != 3, "calm")),
            ["obs.csv", "column 'ref_wind_speed_kt'", "data row 4", "'calm'"],
        ),
        (
            lambda df: df.assign(time=df["time"].astype(object).where(df.index != 2, "yesterday")),
            ["obs.csv", "column 'time'", "'yesterday'"],
        ),
        (lambda df: df.assign(lat=df["lat"].where(df.index != 0, 123.0)), ["obs.csv", "column 'lat'", "outside"]),
        (
            lambda df: df.assign(time=(df["time"] * 1000).astype("int64")),  # epoch milliseconds
            ["obs.csv", "column 'time'", "data row 1", "epoch seconds (milliseconds?)"],
        ),
        # one report whose second reference model's row carries another reported wind
        (
            lambda df: df.assign(
                wind_speed_kt=df["wind_speed_kt"].where(
                    ~((df["time"] == df["time"].iloc[5]) & (df["ref_source"] != df["ref_source"].iloc[5])), 99.0
                )
            ),
            ["obs.csv", "column 'wind_speed_kt'", "rows of one report", "N510XJ", "99"],
        ),
    ],
)
def test_bad_observation_tables_raise_one_line_naming_file_and_column(tmp_path, mutate, words):
    obs = gen.generate([gen.AircraftTruth("N510XJ", A=0.0, B=0.0, C=0.0)], np.random.default_rng(16), flights=2)
    mutate(obs).to_csv(tmp_path / "obs.csv", index=False)
    with pytest.raises(ValueError) as e:
        heading_fit_main(str(tmp_path / "obs.csv"), str(tmp_path / "out"))
    msg = str(e.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


@pytest.mark.parametrize(
    "columns, factor, words",
    [
        (("wind_speed_kt", "ref_wind_speed_kt"), 1852 / 3600, ["column 'wind_speed_kt'", "in m/s? expected knots"]),
        (("wind_speed_kt", "ref_wind_speed_kt"), 1.852, ["column 'wind_speed_kt'", "in km/h? expected knots"]),
        (("ref_wind_speed_kt",), 1852 / 3600, ["column 'ref_wind_speed_kt'", "in m/s? expected knots"]),
        (("wind_speed_kt",), 1.852, ["column 'wind_speed_kt'", "in km/h? expected knots"]),
    ],
)
def test_wind_speeds_in_another_unit_are_named_not_fitted(tmp_path, columns, factor, words):
    """Winds written in m/s or km/h under the _kt names: a reported wind so written makes the
    wind triangle's airspeed follow the along-track wind (slope (1 - f) / f: +0.94 in m/s,
    -0.46 in km/h); a reference wind so written is f x the reported one. Either way the
    deviation fit would silently scale by ~f: refused, naming the column and the unit."""
    obs = gen.generate([gen.AircraftTruth("N511XJ", A=1.0, B=3.0, C=-2.0)], np.random.default_rng(17), flights=12)
    obs.to_csv(tmp_path / "kt.csv", index=False)
    heading_fit_main(str(tmp_path / "kt.csv"), str(tmp_path / "out_kt"), n_boot=0)  # in knots: fitted
    for c in columns:
        obs[c] = obs[c] * factor
    obs.to_csv(tmp_path / "obs.csv", index=False)
    with pytest.raises(ValueError) as e:
        heading_fit_main(str(tmp_path / "obs.csv"), str(tmp_path / "out"), n_boot=0)
    msg = str(e.value)
    assert "\n" not in msg and all(w in msg for w in ["obs.csv", *words]), msg


def _turned(obs: pd.DataFrame, col: str, f, source: str | None = None) -> pd.DataFrame:
    """obs with f applied to column col (only on reference `source`'s rows if given)."""
    obs = obs.copy()
    rows = obs.index if source is None else obs.index[obs["ref_source"] == source]
    obs.loc[rows, col] = f(obs.loc[rows, col])
    return obs


@pytest.mark.parametrize(
    "mutate, words",
    [
        (lambda o: _turned(o, "wind_dir_deg", lambda d: (d + 180) % 360), ["column 'wind_dir_deg'", "blows to?"]),
        (
            lambda o: _turned(o, "ref_wind_dir_deg", lambda d: (d + 180) % 360, "rtfdda"),
            ["column 'ref_wind_dir_deg' (reference 'rtfdda')", "as if the reference wind were -", "blows to?"],
        ),
        (
            lambda o: _turned(o, "ref_wind_speed_kt", lambda v: v * 1852 / 3600, "rtfdda"),
            ["column 'ref_wind_speed_kt' (reference 'rtfdda')", "in m/s?"],
        ),
        (
            lambda o: _turned(o, "ref_wind_dir_deg", lambda d: (90 - d) % 360),
            ["'ref_wind_dir_deg'", "does not follow the wind", "direction convention"],
        ),
        (lambda o: _turned(o, "wind_dir_deg", np.radians), ["column 'wind_dir_deg'", "in radians? expected degrees"]),
        (lambda o: _turned(o, "heading_deg", np.radians), ["column 'heading_deg'", "N514XJ", "in radians?"]),
        (
            lambda o: _turned(o, "heading_deg", lambda h: (h + 90) % 360),
            ["column 'heading_deg'", "N514XJ", "median of"],
        ),
    ],
)
def test_wind_and_heading_conventions_are_named_not_fitted(tmp_path, mutate, words):
    """A wind direction written where the wind blows to (the reported wind's: the triangle's
    airspeed then follows the along-track wind at slope -2; a reference's: the airspeed it
    implies, at slope +2), a reference in m/s on one model only, a mirrored (mathematical) direction, and
    angles in radians: each refused in one line naming the column (and the reference), where
    the fit would have run on them and returned a wrong deviation."""
    obs = gen.generate(
        [gen.AircraftTruth("N514XJ", A=1.0, B=3.0, C=-2.0)], np.random.default_rng(19), flights=12, include_heading=True
    )
    obs.to_csv(tmp_path / "ok.csv", index=False)
    heading_fit_main(str(tmp_path / "ok.csv"), str(tmp_path / "out_ok"), n_boot=0)  # as generated: fitted
    mutate(obs).to_csv(tmp_path / "obs.csv", index=False)
    with pytest.raises(ValueError) as e:
        heading_fit_main(str(tmp_path / "obs.csv"), str(tmp_path / "out"), n_boot=0)
    msg = str(e.value)
    assert "\n" not in msg and all(w in msg for w in ["obs.csv", *words]), msg


def test_light_prevailing_wind_and_a_large_deviation_are_not_taken_for_a_unit_error():
    """Light winds (4-6 kt low, from the west) and a once-round deviation of 8 deg: the
    reported wind is then mostly the heading error's (TAS x 8 deg ~ 40 kt across track), and
    on average it points against the wind (the dot product of the two winds is negative), so
    comparing the wind vectors would call a table in knots "not following the wind". The
    check compares airspeeds, which a heading error does not change: fitted, C recovered."""
    a = gen.AircraftTruth("N518XJ", A=1.0, B=0.0, C=8.0)
    obs = gen.generate(
        [a], np.random.default_rng([21, 0]), flights=150, wind_ms=(2.0, 3.0), wind_from_deg=270.0, models=("rr",)
    )
    te, tn = towards_from_report(obs["wind_speed_kt"], obs["wind_dir_deg"])
    re_, rn = towards_from_report(obs["ref_wind_speed_kt"], obs["ref_wind_dir_deg"])
    assert float(np.sum(te * re_ + tn * rn)) < 0  # the case: the two winds disagree on average
    fit = FleetHeadingFit().fit(obs).fits_["N518XJ"]
    assert fit.status_ == "fitted" and abs(fit.coef_["C"] - 8.0) < 3 * fit.se_["C"] + 0.05, (fit.coef_, fit.se_)


def test_a_heading_column_offset_from_the_air_vector_is_said(tmp_path, capsys):
    """`heading_deg` 30 deg from the heading the reported wind was computed with (and not
    minus the declination): fitted, with a warning naming the aircraft and the offset."""
    obs = gen.generate(
        [gen.AircraftTruth("N515XJ", A=1.0, B=3.0, C=-2.0)], np.random.default_rng(20), flights=12, include_heading=True
    )
    _turned(obs, "heading_deg", lambda h: (h + 30) % 360).to_csv(tmp_path / "obs.csv", index=False)
    heading_fit_main(str(tmp_path / "obs.csv"), str(tmp_path / "out"), n_boot=0)
    err = capsys.readouterr().err
    m = re.search(r"aircraft N515XJ: `heading_deg` is \+(\d+\.\d) deg", err)
    assert m and abs(float(m.group(1)) - 30.0) < 1.0 and "computed with?" in err and "magnetic?" not in err, err
    assert "computed with?" in (tmp_path / "out" / "report.md").read_text()


def test_a_magnetic_heading_in_the_true_heading_column_is_said(tmp_path, capsys):
    """Around Anchorage (declination ~ +18 deg): `heading_deg` written as the reports' own
    air-vector heading (true) gives no warning; the same minus the IGRF declination
    (ppigrf here, at each report) is named as magnetic, in the report and on stderr."""
    import datetime as dt

    import ppigrf

    obs = gen.generate(
        [gen.AircraftTruth("N513XJ", A=1.0, B=2.0, C=-1.0)], np.random.default_rng(18), flights=12, hub=(61.17, -150.0)
    )
    v = validate_observations(obs)
    rows = heading_errors(v)  # one row per validated row, same order
    true_h = np.degrees(np.arctan2(rows["va_e"].to_numpy(), rows["va_n"].to_numpy())) % 360
    when = dt.datetime(1970, 1, 1) + dt.timedelta(seconds=float(v["time_s"].median()))
    be, bn, _ = ppigrf.igrf(
        v["lon"].to_numpy(), v["lat"].to_numpy(), v["pressure_altitude_ft"].to_numpy() * 0.3048e-3, when
    )
    decl = np.degrees(np.arctan2(np.ravel(be), np.ravel(bn)))
    assert decl.min() > 10
    table = v.drop(columns=["time_s"]).assign(time=v["time_s"])
    for name, h in (("true", true_h), ("mag", (true_h - decl) % 360)):
        table.assign(heading_deg=h).to_csv(tmp_path / f"{name}.csv", index=False)
        heading_fit_main(str(tmp_path / f"{name}.csv"), str(tmp_path / name), n_boot=0)
    err = capsys.readouterr().err
    assert "true.csv" not in err and "Warnings" not in (tmp_path / "true" / "report.md").read_text()
    assert "mag.csv: aircraft N513XJ: `heading_deg`" in err and "is it magnetic?" in err, err
    assert "is it magnetic?" in (tmp_path / "mag" / "report.md").read_text()


def test_missing_file_and_wrong_extension_are_named(tmp_path):
    with pytest.raises(ValueError, match=r"nothere\.csv: no such file"):
        heading_fit_main(str(tmp_path / "nothere.csv"), str(tmp_path / "out"))
    (tmp_path / "obs.json").write_text("{}")
    with pytest.raises(ValueError, match=r"obs\.json: expected a \.csv, \.csv\.gz or \.parquet"):
        heading_fit_main(str(tmp_path / "obs.json"), str(tmp_path / "out"))


def test_estimator_parameters_are_checked():
    with pytest.raises(ValueError, match="terms"):
        HeadingDeviationFit(terms="cubic").fit(pd.DataFrame())
    with pytest.raises(ValueError, match="heading"):
        FleetHeadingFit(heading="grid")


def _huber_by_irls_and_newton(XT, y, w, monkeypatch):
    import aerotruth.analysis.wind.robust_fit as rf

    newton = rf.huber_t(XT, y, w, True, 1.345)[:2]
    monkeypatch.setattr(rf, "_NEWTON_STEPS", 0)  # IRLS steps only: another algorithm, the same estimator
    irls = rf.huber_t(XT, y, w, True, 1.345)[:2]
    return newton, irls


def test_newton_huber_steps_reach_the_irls_fixed_point(monkeypatch):
    """Heavy-tailed noise (t with 2 dof) and 10 % gross errors: the Newton solution equals
    the IRLS one (both iterate to 1e-5 deg), scale included."""
    rng = np.random.default_rng(7)
    z = rng.uniform(0.0, 360.0, 4000)
    X = np.column_stack(
        [
            np.ones_like(z),
            np.sin(np.radians(z)),
            np.cos(np.radians(z)),
            np.sin(np.radians(2 * z)),
            np.cos(np.radians(2 * z)),
        ]
    )
    y = X @ np.array([1.5, -2.0, 0.7, 0.3, -0.2]) + rng.standard_t(2, len(z))
    y[rng.random(len(z)) < 0.1] += 25.0
    w = rng.uniform(0.6, 1.4, len(z))
    (bn, sn), (bi, si) = _huber_by_irls_and_newton(np.ascontiguousarray(X.T), y, w, monkeypatch)
    assert np.max(np.abs(bn - bi)) < 5e-5
    assert sn == pytest.approx(si, rel=1e-4)


def test_newton_huber_falls_back_to_irls_when_its_matrix_is_singular(monkeypatch):
    """Most reports at one heading with tiny residuals, the rest far off at three others:
    the unclipped reports then span one direction only (singular Newton matrix); the fit
    must still reach the IRLS solution, finite."""
    rng = np.random.default_rng(3)
    n0, n1 = 600, 400
    z = np.r_[np.zeros(n0), rng.choice([90.0, 180.0, 270.0], n1)]
    X = np.column_stack([np.ones_like(z), np.sin(np.radians(z)), np.cos(np.radians(z))])
    y = np.r_[1e-4 * rng.standard_normal(n0), rng.choice([-30.0, 40.0], n1) + rng.standard_normal(n1)]
    w = np.ones_like(z)
    (bn, sn), (bi, si) = _huber_by_irls_and_newton(np.ascontiguousarray(X.T), y, w, monkeypatch)
    assert np.all(np.isfinite(bn))
    assert np.max(np.abs(bn - bi)) < 5e-5


@pytest.mark.parametrize("k", [1, 2, 3, 5])
@pytest.mark.parametrize("cc", [1.345, np.inf])
def test_compiled_flight_sums_equal_the_sums_written_out(k, cc):
    """The fit's per-flight B_g = sum x x^T w psi'(u) / s and h_g = sum x sqrt(w) psi(u)
    (compiled, the columns beyond k zero) and a Newton step's B and h, against the same
    sums written as plain numpy per flight; Huber clipping (1.345) and least squares (inf)."""
    import aerotruth.analysis.wind.robust_fit as rf

    rng = np.random.default_rng(31)
    lens = rng.integers(1, 60, 25)
    g = np.repeat(np.arange(len(lens)), lens)
    n = len(g)
    XT = rf.design_t(rng.uniform(0, 360, n), 5)[:k].copy()
    r, w, s = 2.0 * rng.standard_t(3, n), rng.uniform(0.5, 1.5, n), 1.7
    bread_g, scores = rf._cluster_parts(XT, r, w, rf.cluster_starts(g), s, cc)
    u = r / s
    psi, inside = np.clip(u, -cc, cc), np.abs(u) <= cc
    for j in range(len(lens)):
        m = g == j
        X = XT[:, m]
        want_b = (X * (w[m] * inside[m] / s)) @ X.T
        want_h = X @ (np.sqrt(w[m]) * psi[m])
        assert np.allclose(bread_g[j], want_b, rtol=1e-12, atol=1e-12)
        assert np.allclose(scores[j], want_h, rtol=1e-12, atol=1e-12)
    cs = 1.345 * s
    B, h = rf._newton_system(XT, r, w, np.sqrt(w), cs)
    keep = np.abs(r) <= cs
    assert np.allclose(B, (XT[:, keep] * w[keep]) @ XT[:, keep].T, rtol=1e-12)
    assert np.allclose(h, XT @ (np.clip(r, -cs, cs) * np.sqrt(w)), rtol=1e-12)


def test_the_fits_median_is_numpys_with_any_guess():
    """The scale's median (a window round a guess, a subsample's median as the guess of a
    large array, else a full partition) is np.median exactly: odd and even sizes, heavy
    tails, half zeros, sorted values, guesses that miss."""
    import aerotruth.analysis.wind.robust_fit as rf

    rng = np.random.default_rng(3)
    for n in (1, 2, 12799, 12800, 12801, 90000):
        for x in (
            np.abs(rng.standard_t(2, n)),
            np.abs(rng.standard_normal(n)) * (rng.random(n) < 0.5),
            np.sort(rng.random(n)),
        ):
            want = np.median(x)
            for guess in (np.nan, want, 1.04 * want, 3.0 * want + 1.0, 0.0):
                assert rf._median(x, np.empty(n), guess) == want


def test_leave_one_flight_out_influences_solve_each_system_or_fall_back():
    """CR3's q_g = (B - B_g)^-1 h_g (compiled Cholesky) against numpy's general solver; and
    with a term carried by one flight alone (B - B_0 singular) the plain sandwich term
    pinv(B - B_g) h_g for every flight, as before the compiled path."""
    import aerotruth.analysis.wind.robust_fit as rf

    rng = np.random.default_rng(2)
    G, k = 30, 5
    X = [rng.standard_normal((k, 25)) for _ in range(G)]
    bread_g = np.array([x @ x.T for x in X])
    scores = rng.standard_normal((G, k))
    loo = bread_g.sum(axis=0)[None] - bread_g
    infl, cov = rf._cr3(bread_g, scores)
    want = np.linalg.solve(loo, scores[:, :, None])[:, :, 0]
    assert np.allclose(infl, want, rtol=1e-10, atol=1e-14)
    assert np.allclose(cov, want.T @ want * (G - 1) / G, rtol=1e-10)
    for x in X[1:]:
        x[4] = 0.0  # term 4 in flight 0 only
    bread_g = np.array([x @ x.T for x in X])
    loo = bread_g.sum(axis=0)[None] - bread_g
    infl, _ = rf._cr3(bread_g, scores)
    assert np.allclose(infl, np.einsum("gij,gj->gi", np.linalg.pinv(loo), scores), rtol=1e-8, atol=1e-12)


@pytest.mark.parametrize("start_se", [1.0, 5.0, 20.0])
def test_fit_from_a_nearby_start_matches_the_iterated_fit(start_se):
    """The consistency check fits each reference model from the pooled coefficients
    (fit_from_t: one Newton step, iterated on when the next step would still move a
    coefficient by more than 0.1 SE). Against the fully iterated Huber fit of the same rows
    (robust_fit_t), started 1, 5 and 20 standard errors away (one step alone lands 1-2 SE
    off from 20): coefficients within a tenth of a standard error and standard errors within
    5 %, on heavy-tailed (t3) noise correlated within 40 flights."""
    from aerotruth.analysis.wind.robust_fit import design_t, fit_from_t, robust_fit_t

    rng = np.random.default_rng(21)
    G, per = 40, 150
    g = np.repeat(np.arange(G), per)
    z = np.concatenate([rng.choice([20.0, 110.0, 200.0, 290.0]) + rng.normal(0, 40, per) for _ in range(G)]) % 360
    XT = design_t(z, 5)
    beta = np.array([0.4, 1.2, -0.7, 0.3, 0.2])
    y = beta @ XT + np.repeat(rng.normal(0, 0.3, G), per) + 1.5 * rng.standard_t(3, G * per)
    w = rng.uniform(0.7, 1.3, G * per)
    full = robust_fit_t(XT, y, w, g)
    se = np.sqrt(np.diag(full.cov))
    start = full.beta + start_se * se * np.array([1, -1, 1, -1, 1]) / np.sqrt(5)
    near = fit_from_t(XT, y, w, g, start)
    assert np.all(np.abs(near.beta - full.beta) < 0.1 * se), (near.beta - full.beta) / se
    assert np.allclose(np.sqrt(np.diag(near.cov)), se, rtol=0.05)


def test_wind_errors_before_after_against_a_hand_rotation():
    """Before/after wind error components on rows paired by report (two reference models
    each, so the trigonometry is shared per report): against the wind recomputed by hand
    with V_A rotated clockwise by the correction, and components along/across the heading."""
    from aerotruth.analysis.wind.metrics import wind_errors_before_after
    from aerotruth.units import KT

    rng = np.random.default_rng(4)
    n_rep = 20
    h = np.repeat(rng.uniform(0, 360, n_rep), 2)
    tas = np.repeat(rng.uniform(100, 150, n_rep), 2)
    va_e, va_n = tas * np.sin(np.radians(h)), tas * np.cos(np.radians(h))
    dw_e, dw_n = rng.normal(0, 3, 2 * n_rep), rng.normal(0, 3, 2 * n_rep)
    c = np.repeat(rng.uniform(-4, 4, n_rep), 2)
    rows = pd.DataFrame({"heading_deg": h, "va_e": va_e, "va_n": va_n, "dw_e": dw_e, "dw_n": dw_n})
    before, after = wind_errors_before_after(rows, c)

    def comps(e, n, hd):
        lon = e * np.sin(np.radians(hd)) + n * np.cos(np.radians(hd))
        tr = e * np.cos(np.radians(hd)) - n * np.sin(np.radians(hd))
        r = lambda x: np.sqrt(np.mean(x**2)) / KT  # noqa: E731
        return r(np.hypot(e, n)), r(lon), r(tr)

    # corrected heading h + c: V_A' = TAS (sin(h + c), cos(h + c)); wind' = wind + V_A - V_A'
    e2 = dw_e + va_e - tas * np.sin(np.radians(h + c))
    n2 = dw_n + va_n - tas * np.cos(np.radians(h + c))
    for got, want in ((before, comps(dw_e, dw_n, h)), (after, comps(e2, n2, h + c))):
        # single-precision trig (aerotruth.analysis.wind.fast_trig): ~2.6e-7 of |V_A| per report,
        # 4e-5 m/s here against 3-m/s errors; the RMS averages it further
        assert np.allclose([got["rms_kt"], got["longitudinal_kt"], got["transverse_kt"]], want, rtol=1e-6)


@pytest.mark.parametrize("storage", ["object", "arrow", "arrow-chunks", "python"])
def test_text_labels_are_read_the_same_whatever_their_storage(storage):
    """Aircraft and reference labels stripped, empty reference -> "ref", rows sorted by
    aircraft, time and reference (labels in order of first appearance): by hand, for text
    held as Python objects, Arrow strings (one chunk, or several as a concatenation leaves
    them) or pandas' Python strings."""
    rows = {
        "aircraft": [" N2", "N1", "N1 ", "N2", "N1"],
        "time": [5.0, 9.0, 1.0, 2.0, 1.0],
        "ref_source": ["rr", "rr", "", "rr", "rr"],
    }
    n = len(rows["time"])
    obs = pd.DataFrame(
        {
            **rows,
            "lat": 45.0,
            "lon": -93.0,
            "pressure_altitude_ft": 9000.0,
            "wind_speed_kt": 20.0,
            "wind_dir_deg": 270.0,
            "ref_wind_speed_kt": 18.0,
            "ref_wind_dir_deg": 265.0,
        },
        index=range(n),
    )
    for c in ("aircraft", "ref_source"):
        if storage == "arrow":
            obs[c] = obs[c].astype("string[pyarrow]")
        elif storage == "arrow-chunks":
            obs[c] = pd.concat(
                [obs[c][:2].astype("string[pyarrow]"), obs[c][2:].astype("string[pyarrow]")], ignore_index=True
            )
        elif storage == "python":
            obs[c] = obs[c].astype("string[python]")
    df = validate_observations(obs)
    assert list(df["aircraft"].astype(str)) == ["N2", "N2", "N1", "N1", "N1"]
    assert list(df["time_s"]) == [2.0, 5.0, 1.0, 1.0, 9.0]
    assert list(df["ref_source"].astype(str)) == ["rr", "rr", "rr", "ref", "rr"]
    assert set(df["aircraft"].cat.categories) == {"N1", "N2"}


def test_step_noise_matches_rounding_by_monte_carlo_and_lets_a_straight_climb_through():
    """The sd of the course change, the speed change and V_G that 0.01-deg rounding makes
    on a straight, constant-speed track (step_noise) against a Monte-Carlo of the rounding
    itself (random offsets of the track against the grid); then the gates: a straight
    departure climb reported every 10 s (1.6-km spans, where rounding alone bends the
    track by tens of degrees) passes, a 30-deg turn over 10-km segments does not."""
    from pyproj import Geod

    from aerotruth.analysis.wind.heading_errors import step_noise

    geod = Geod(ellps="WGS84")
    rng = np.random.default_rng(3)
    lat0 = 61.2
    dc, dsp, dvg, var_c, var_s, var_v = [], [], [], [], [], []
    for _ in range(4000):
        # 3-km segments near Anchorage (errors small against them), speed and course drawn
        # so that the grid's fractions vary as along real tracks (a fixed displacement
        # correlates the rounding of neighbouring points)
        course, gs, dt = 233.0 + rng.uniform(-20, 20), 150.0 * rng.uniform(0.8, 1.2), 20.0
        la, lo = lat0 + rng.uniform(-0.05, 0.05), -150.0 + rng.uniform(-0.05, 0.05)
        lo1, la1, _ = geod.fwd(lo, la, course, gs * dt)
        lo2, la2, _ = geod.fwd(lo1, la1, course, gs * dt)
        q = np.round(np.array([[la, lo], [la1, lo1], [la2, lo2]]) / 0.01) * 0.01
        az1, _, d1 = geod.inv(q[0, 1], q[0, 0], q[1, 1], q[1, 0])
        az2, _, d2 = geod.inv(q[1, 1], q[1, 0], q[2, 1], q[2, 0])
        _, _, dspan = geod.inv(q[0, 1], q[0, 0], q[2, 1], q[2, 0])
        dc.append((az2 - az1 + 180.0) % 360.0 - 180.0)
        dsp.append((d2 - d1) / dt / gs)
        dvg.append(dspan / (2 * dt) / gs - 1.0)
        e, n = np.sin(np.radians(course)) * 2 * gs * dt, np.cos(np.radians(course)) * 2 * gs * dt
        c, sp, r = step_noise(
            np.array([np.radians(la1)]),
            np.array([e]),
            np.array([n]),
            np.array([np.hypot(e, n)]),
            np.array([gs]),
            np.array([gs]),
            np.array([dt]),
            np.array([dt]),
            0.01,
        )
        var_c.append(c[0] ** 2)
        var_s.append(sp[0] ** 2)
        var_v.append(r[0] ** 2)
    # the formula is linear in the errors: the Monte-Carlo sd agrees within its own spread
    # (4000 draws: ~1 %) and the small-angle linearisation (a few % at these sizes)
    assert np.sqrt(np.mean(var_c)) == pytest.approx(np.std(dc), rel=0.08)
    assert np.sqrt(np.mean(var_s)) == pytest.approx(np.std(dsp), rel=0.08)
    # |V_G|'s error along the track is one of the two axes the formula adds: half its variance
    assert np.sqrt(np.mean(var_v) / 2) == pytest.approx(np.std(dvg), rel=0.25)
    assert np.std(dc) > 5.0  # already half the old fixed 10-deg limit on 3-km segments

    def track(legs, step_s):
        """Reports every step_s along legs of (course deg, ground speed m/s, seconds)."""
        rows, la, lo, t = [], lat0, -150.0, 0.0
        for crs, v, dur in legs:
            for _ in range(int(dur / step_s)):
                rows.append((t, round(la, 2), round(lo, 2)))
                lo, la, _ = geod.fwd(lo, la, crs, v * step_s)
                t += step_s
        wind = [(t_, 10.0, 270.0) for t_, _, _ in rows]
        return pd.DataFrame(
            {
                "aircraft": "N1",
                "time": [r[0] + 1.27e9 for r in rows],
                "lat": [r[1] for r in rows],
                "lon": [r[2] for r in rows],
                "wind_speed_kt": [w[1] for w in wind],
                "wind_dir_deg": [w[2] for w in wind],
                "ref_wind_speed_kt": 10.0,
                "ref_wind_dir_deg": 270.0,
                "roll_deg": 0.0,
                "pressure_altitude_ft": 5000.0,
            }
        )

    climb = heading_errors(track([(330.0, 80.0, 120.0)], 10.0))
    interior = climb.iloc[1:-1]
    assert (interior["gate"] == "used").mean() > 0.9
    turn = heading_errors(track([(200.0, 120.0, 250.0), (230.0, 120.0, 250.0), (260.0, 120.0, 250.0)], 83.0))
    at_turns = turn[turn["gate"] == "collinearity"]
    assert len(at_turns) >= 2  # the two corners, 30 deg each over 10-km segments


def test_bootstrap_leaves_out_resamples_that_cannot_be_fitted(monkeypatch):
    """A resample whose flights cannot identify the terms raises in the fit: it is left out
    (a few: intervals from the rest; more than a tenth: NaN intervals, no crash)."""
    import aerotruth.analysis.wind.heading_correction as hc

    a = gen.AircraftTruth("N480XJ", A=1.0, B=2.0, C=-1.0, cruise_tas_kt=280.0)
    fit = HeadingDeviationFit(terms="sinusoid", heading="magnetic").fit(
        gen.generate([a], np.random.default_rng(2), flights=12)
    )
    clean = fit.bootstrap(100, np.random.default_rng(0))
    real, calls = hc.robust_fit_t, [0]

    def failing_every(n):
        def fit_or_fail(*args, **kw):
            calls[0] += 1
            if calls[0] % n == 0:
                raise np.linalg.LinAlgError("singular")
            return real(*args, **kw)

        return fit_or_fail

    monkeypatch.setattr(hc, "robust_fit_t", failing_every(25))  # 4 of 100 left out
    few = fit.bootstrap(100, np.random.default_rng(0))
    assert np.isfinite(few[["lo", "hi"]].to_numpy()).all()
    assert np.allclose(few["hi"] - few["lo"], clean["hi"] - clean["lo"], rtol=0.25)
    calls[0] = 0
    monkeypatch.setattr(hc, "robust_fit_t", failing_every(5))  # 20 of 100: no interval
    many = fit.bootstrap(100, np.random.default_rng(0))
    assert many[["lo", "hi"]].isna().all().all() and np.allclose(many["estimate"], clean["estimate"])
