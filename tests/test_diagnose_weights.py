"""The wind diagnosis's working covariance (aerotruth.analysis.diagnose.wind_weights) against
hand-worked numbers and processes of known covariance."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from aerotruth.analysis.diagnose.wind_weights import MAX_PIECE, correlation_model, rounding_variance, working_weights


def _series_data(n_series: int, rows: int, rng: np.random.Generator, lo_s: float = 180.0, hi_s: float = 420.0):
    """A WindData-shaped namespace: n_series flights of one reference, reports lo_s-hi_s apart."""
    t = np.concatenate([np.cumsum(rng.uniform(lo_s, hi_s, rows)) for _ in range(n_series)])
    flight = np.repeat(np.arange(n_series), rows)
    n = len(t)
    return SimpleNamespace(
        n=n,
        unit="flight",
        time_s=t,
        flight=flight,
        source=np.zeros(n, dtype=int),
        lat=np.full(n, 45.0),
        track_span_s=np.full(n, np.nan),
        position_step_deg=0.0,
    )


def _ou(t: np.ndarray, flight: np.ndarray, tau: float, rng: np.random.Generator) -> np.ndarray:
    """Unit-variance Ornstein-Uhlenbeck values at times t, restarted per flight (exact)."""
    x = np.empty(len(t))
    for i in range(len(t)):
        if i == 0 or flight[i] != flight[i - 1]:
            x[i] = rng.normal()
        else:
            r = np.exp(-(t[i] - t[i - 1]) / tau)
            x[i] = r * x[i - 1] + np.sqrt(1 - r * r) * rng.normal()
    return x


def test_rounding_variance_is_the_hand_worked_one():
    """0.01-deg positions at 60 N, neighbours 100 s apart: on WGS-84 a degree of latitude
    there is 111,412.29 m and a degree of longitude 55,800.00 m (geodesy tables), so q_n =
    1114.12 m, q_e = 558.00 m; (q_n^2 + q_e^2) / 12 / 100^2 = 12.94 (m/s)^2 (a sphere of
    6,371 km gives 12.88). Not rounded, or the span unknown: 0."""
    d = SimpleNamespace(position_step_deg=0.01, lat=np.array([60.0, 60.0]), track_span_s=np.array([100.0, np.nan]))
    v = rounding_variance(d)
    assert v[0] == pytest.approx(12.9386, abs=0.001)
    assert v[1] == 0.0
    d0 = SimpleNamespace(position_step_deg=0.0, lat=np.array([60.0]), track_span_s=np.array([100.0]))
    assert rounding_variance(d0)[0] == 0.0


def test_correlation_model_recovers_an_ornstein_uhlenbeck_error_with_a_white_part():
    """corr(dt) = 0.9 exp(-dt / 1800 s), reports 3-7 min apart: c within 0.05, tau within 20 %."""
    rng = np.random.default_rng(3)
    d = _series_data(150, 25, rng)
    e = np.sqrt(0.9) * _ou(d.time_s, d.flight, 1800.0, rng) + np.sqrt(0.1) * rng.normal(size=d.n)
    c, tau = correlation_model(d.time_s, d.flight, e)
    assert c == pytest.approx(0.9, abs=0.05)
    assert tau == pytest.approx(1800.0, rel=0.2)


def test_white_residual_gives_no_weights():
    rng = np.random.default_rng(4)
    d = _series_data(60, 20, rng)
    assert working_weights(d, rng.normal(size=2 * d.n)) is None


def test_no_weights_where_the_units_are_weather_blocks():
    """A residual correlated along each flight (c 0.95, 25 min) is weighted where the tests'
    units are flights and not where they are weather blocks (an error the flights share)."""
    rng = np.random.default_rng(7)
    d = _series_data(80, 20, rng)
    e = _ou(d.time_s, d.flight, 1500.0, rng)
    assert working_weights(d, np.r_[e, e]) is not None
    d.unit = "weather block"
    assert working_weights(d, np.r_[e, e]) is None


def test_whitened_process_of_the_working_covariance_is_white():
    """A correctly specified Gaussian process whitened by its own covariance is independent
    N(0, 1): variance 1 and no correlation between neighbours, in both channels; pieces of a
    long series are whitened apart (no weight across a cut)."""
    rng = np.random.default_rng(5)
    d = _series_data(120, 2 * MAX_PIECE + 5, rng)
    e = np.sqrt(0.95) * _ou(d.time_s, d.flight, 1500.0, rng) + np.sqrt(0.05) * rng.normal(size=d.n)
    along = np.sqrt(0.95) * _ou(d.time_s, d.flight, 1500.0, rng) + np.sqrt(0.05) * rng.normal(size=d.n)
    w = working_weights(d, np.r_[e, along])
    assert w is not None
    for ch in ("transverse", "along"):
        assert w.params[ch]["correlated_share"] == pytest.approx(0.95, abs=0.04)
    z = w.whiten(np.r_[e, along])
    for part in (z[: d.n], z[d.n :]):
        assert np.var(part) == pytest.approx(1.0, abs=0.08)
        same = d.flight[1:] == d.flight[:-1]
        r1 = np.corrcoef(part[1:][same], part[:-1][same])[0, 1]
        assert abs(r1) < 0.05
    first_piece = np.arange(MAX_PIECE)  # rows of flight 0 (rows are in time order already)
    second = MAX_PIECE + np.arange(MAX_PIECE)
    assert w.matrix[second][:, first_piece].nnz == 0
    assert w.matrix[second][:, second].nnz == MAX_PIECE * (MAX_PIECE + 1) // 2


def test_rounding_weighs_down_the_rows_whose_ground_track_is_short():
    """Two rows of equal reference error, one with a ground track over 80 s and one over 600
    s: after whitening (0.01-deg positions) the short one's weight is the smaller."""
    rng = np.random.default_rng(6)
    d = _series_data(80, 20, rng)
    d.position_step_deg = 0.01
    d.track_span_s = np.where(np.arange(d.n) % 2 == 0, 80.0, 600.0)
    e = _ou(d.time_s, d.flight, 1800.0, rng) * 2.0
    w = working_weights(d, np.r_[e, e])
    assert w is not None
    col_norm = np.asarray(np.sqrt(w.matrix.multiply(w.matrix).sum(axis=0))).ravel()[: d.n]
    assert np.median(col_norm[::2]) < 0.5 * np.median(col_norm[1::2])
