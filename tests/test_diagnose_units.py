"""The diagnosis's independent units: the sign-flip test of reference-model error shared
between flights (wind_data.reference_sharing) and the units it chooses (dependence_units).

The tables here are made by hand: flights of two reference models' winds at the same
reports, each model erring by a per-flight offset and white noise, and where stated by an
error of the wind's speed common to every flight in the same hours, or a constant bias
along the wind. Under no sharing the test is exact (random sign flips of independent,
symmetric flight means), so its rejections at a level follow the binomial."""

from __future__ import annotations

import numpy as np
import pytest
from scipy import stats

from aerotruth.analysis.diagnose.wind_data import (
    MIN_SHARING_BLOCKS,
    N_FOLDS,
    SHARING_LEVEL,
    WEATHER_BLOCK_S,
    dependence_units,
    reference_sharing,
    weather_blocks,
)

H = 3600.0


def _table(rng, *, shared_ms=0.0, bias_ms=0.0, flights=240, days=10.0, reports=15):
    """Rows (report, source, flight, time, ref east, ref north) of two references at every
    report. Each flight: a wind of 8-25 m/s from a random direction, one hour long; each
    reference: the wind plus a flight offset (1 m/s per component) and report noise (2 m/s).
    shared_ms: reference 0 also errs by s(t) along each flight's wind, s a sum of five
    sinusoids of periods 4-16 h (rms shared_ms): common to the flights of the same hours.
    bias_ms: reference 0 is too strong by this much along the wind, at every report."""
    mid = np.sort(rng.uniform(0.0, days * 86400.0, flights))
    per = rng.uniform(4 * H, 16 * H, 5)
    ph = rng.uniform(0, 2 * np.pi, 5)

    def s(t):
        return shared_ms * np.sqrt(2.0 / 5.0) * np.sum(np.cos(2 * np.pi * t[:, None] / per + ph), axis=1)

    rows = []
    rep = 0
    for f, m in enumerate(mid):
        t = m + np.linspace(-0.5 * H, 0.5 * H, reports)
        ang = rng.uniform(0, 2 * np.pi)
        u = np.array([np.sin(ang), np.cos(ang)])
        w = rng.uniform(8.0, 25.0) * u
        for src in (0, 1):
            err = rng.normal(0.0, 1.0, 2) + rng.normal(0.0, 2.0, (reports, 2))
            if src == 0:
                err = err + (s(t) + bias_ms)[:, None] * u
            v = w + err
            rows.append(np.column_stack([rep + np.arange(reports), np.full(reports, src), np.full(reports, f), t, v]))
        rep += reports
    a = np.concatenate(rows)
    return a[:, 0].astype(int), a[:, 1].astype(int), a[:, 2].astype(int), a[:, 3], a[:, 4], a[:, 5]


def _rejections(n, **kw):
    rng = np.random.default_rng(20261130)
    ps = [reference_sharing(*_table(rng, **kw))["p"] for _ in range(n)]
    return int(np.sum(np.array(ps) < SHARING_LEVEL)), ps


def test_without_shared_error_the_test_rejects_at_its_level():
    n = 120
    k, ps = _rejections(n)
    lo, hi = stats.binom.ppf([0.0005, 0.9995], n, SHARING_LEVEL)  # 99.9 % of what an exact test gives
    assert lo <= k <= hi, (k, n)
    assert stats.kstest(ps, "uniform").pvalue > 0.001  # the p-values are uniform, not only at 0.1


def test_a_reference_bias_along_the_wind_is_not_taken_for_sharing():
    """2 m/s along the wind in every report of one reference: the same sign in every
    flight's along-wind mean, so without the pair's bias fitted out first every dataset
    would reject."""
    n = 80
    k, _ = _rejections(n, bias_ms=2.0)
    hi = stats.binom.ppf(0.9995, n, SHARING_LEVEL)
    assert k <= hi, (k, n)


def test_a_wind_speed_error_common_to_the_same_hours_is_found():
    """1.5 m/s rms along the wind, shared by the flights of the same hours (their own
    errors: 1 m/s per flight plus 2 m/s per report): found in nearly every dataset."""
    n = 40
    k, ps = _rejections(n, shared_ms=1.5)
    assert k >= 0.9 * n, sorted(ps)


def test_the_sign_flip_z_is_the_statistic_over_its_exact_standard_deviation():
    rng = np.random.default_rng(5)
    out = reference_sharing(*_table(rng, shared_ms=3.0))
    assert out["tested"] and out["p"] < 0.01 and out["z"] > 3 and 0 < out["rho"] < 1
    # one reference: nothing to compare with
    rep, src, fl, t, e, n = _table(rng)
    one = src == 0
    assert reference_sharing(rep[one], src[one], fl[one], t[one], e[one], n[one])["tested"] is False


def test_flights_are_the_units_only_with_the_data_to_show_no_sharing():
    # 30 flights, one every 4 h (mid-times in order), 2 rows each
    flight = np.repeat(np.arange(30)[::-1], 2)  # ids in reverse time order: the units follow time, not ids
    t = np.repeat(np.arange(30)[::-1] * 4 * H, 2) + np.tile([0.0, 600.0], 30)
    block, _ = weather_blocks(flight, t)
    n_blocks = len(np.unique(block))
    assert n_blocks == 20 == MIN_SHARING_BLOCKS  # 4-h spacing: 30 flights in 20 six-hour blocks
    none = {"tested": True, "p": 0.5}
    cluster, fold, unit = dependence_units(flight, t, block, none)
    assert unit == "flight"
    in_time = np.repeat(np.arange(30)[::-1], 2)  # the row's flight is the k-th in time
    assert cluster.tolist() == in_time.tolist()  # unit k
    assert fold.tolist() == (in_time % N_FOLDS).tolist()
    for sharing in ({"tested": True, "p": SHARING_LEVEL / 2}, {"tested": False, "why": "one reference"}):
        cluster, fold, unit = dependence_units(flight, t, block, sharing)
        assert unit == "weather block" and cluster.tolist() == block.tolist()
    few = t < 19 * 6 * H  # fewer blocks than the test needs to see sharing: blocks, whatever p says
    b2, _ = weather_blocks(flight[few], t[few])
    assert len(np.unique(b2)) < MIN_SHARING_BLOCKS
    assert dependence_units(flight[few], t[few], b2, none)[2] == "weather block"
    assert WEATHER_BLOCK_S == 6 * H


def test_the_independent_generators_shared_error_keeps_the_weather_blocks():
    """tests/obs_generator's wind-speed error common to every aircraft in the same hours
    (3 kt, 3-h e-folding; each flight's own 2 kt): the references' differences carry it."""
    import obs_generator as gen

    from aerotruth.analysis.diagnose.wind_data import prepare, units_reason

    rng = np.random.default_rng(21)
    fleet = gen.fleet(12, rng, de_every=0, one_heading_last=False)
    obs = gen.generate(fleet, rng, flights=40, ref_sigma_kt=2.0, shared_ref_sigma_kt=3.0)
    d = prepare(obs)
    assert d.unit == "weather block" and d.sharing["p"] < 0.01, d.sharing
    assert d.sharing["component"] == "along the wind"  # the generator's error is one of the wind's speed
    assert units_reason(d).startswith("the reference models' differences show error shared between flights")


@pytest.mark.slow
def test_the_report_says_which_units_and_why(tmp_path):
    """Without a shared error (the generator's own errors are each flight's): the report's
    line names the units the tests used, their number and the sharing test's p."""
    import obs_generator as gen

    from aerotruth.analysis.diagnose.wind import WindModelSpec, diagnose_wind, prepare
    from aerotruth.app.diagnose import write_wind_diagnosis

    rng = np.random.default_rng(22)
    fleet = gen.fleet(12, rng, de_every=0, one_heading_last=False)
    d = prepare(gen.generate(fleet, rng, flights=40))
    findings, baseline, _, plots = diagnose_wind(d, WindModelSpec())
    write_wind_diagnosis("obs", findings, baseline, WindModelSpec(), WindModelSpec(), plots, tmp_path)
    u = baseline["units"]
    what = {"flight": "flights", "weather block": "six-hour weather blocks"}[u["unit"]]
    n_flights = len(np.unique(d.flight))
    assert u["count"] == (n_flights if u["unit"] == "flight" else baseline["weather_blocks"])
    assert f"Tests on {u['count']} {what}: {u['why']}." in (tmp_path / "report.md").read_text()
    assert f"(p {u['sharing_test']['p']:.2g}," in u["why"]
