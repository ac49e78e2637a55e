"""The working covariance of `aerotruth diagnose`'s wind model: how much a row of an
observation table repeats its neighbours' error, and how precise its ground track is.

A flight's consecutive reports share their reference model's error (an analysis error is one
field the aircraft flies through: on the independent test generator the model's residual
correlates ~0.9 between neighbouring reports of one flight and reference, 3-7 min apart), so
an ordinary fit weighs each report as new information where most of it repeats the last.
Per (flight, reference) series and channel, rows in time order, the working covariance is

    Sigma_ij = s^2 [c exp(-|t_i - t_j| / tau) + (1 - c) delta_ij] + delta_ij v_i

* s^2: the channel's residual variance; c and tau: the residual's correlation at lags 1-4
  within series, fitted as c exp(-dt / tau) (least squares on the log of the correlation in
  bins of the time apart): an Ornstein-Uhlenbeck error with a white part 1 - c;
* v_i: the row's ground-track rounding variance. A report's ground velocity is its
  neighbours' displacement over their time apart T_i (wind paper section 5.1;
  aerotruth.analysis.wind.heading_errors.ground_track); positions rounded to q degrees give
  it an error of variance 2 (q_m^2 / 12) / T_i^2 per axis (two endpoints, each uniform over
  the step), q_m the step in metres (north q R, east q R cos lat): v_i is its mean over the
  two axes, (q_n^2 + q_e^2) / 12 / T_i^2. Near 5 m/s for the 0.01-deg positions of reports
  80 s apart (climbs and descents), 0.7 m/s at 10 min. All of it is counted, as a weight
  for the row's geometry, not as a claim of how much reaches the residual: weighted by the
  reference error's smoothness alone, the dense rows carried most of the weight and, with
  it, structure of the rounding (anisotropic between north and east) that the screening's
  signatures then found in null data (validation/diagnose_confusion_plan.md, "The residual's
  correlation along a flight").

The fit is generalised least squares with it (the rows whitened by W, W' W = Sigma^-1 per
series); the tests stay cluster-robust on the whitened rows, so they are valid whatever the
working covariance is, which decides only how efficient they are. A series longer than
MAX_PIECE rows is cut into consecutive pieces (the covariance block-diagonal across the cut:
a choice of weights that keeps W sparse on dense data). A channel whose residual shows no
correlation gets c = 0; where neither does, there are no weights (the ordinary fit).

The working covariance is the tests' unit's: it is used where the units are flights
(wind_data.dependence_units: the reference models' differences show no error shared between
flights), so that what the fit weighs within a unit is what the clustered tests take as that
unit's whole dependence. Where the units are weather blocks the error is a field the
flights of a block share (wind_field); a per-flight covariance describes only its part along
each flight, and there the fit is the ordinary one. (The field itself as the working
covariance within a block was tried and named wrong causes on aerotruth's own reports; the
per-flight one there weighed the dense climb and descent reports, where the sensors' heading
system departs from the model, and its null rose to 17 of 100: the plan's section "The
residual's correlation along a flight".)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import sparse

from aerotruth.analysis.diagnose.wind_data import WindData, metres_per_degree

MAX_PIECE = 30  # rows of one series whitened together at most
LAGS = 4  # the residual's correlation is read at lags 1..LAGS within series
N_BINS = 8  # bins of the time apart (quantiles) its correlation is fitted over
MIN_CORR = 0.02  # a bin's correlation below this is not fitted (its log is noise)
MAX_C = 0.99  # the correlated share at most (a white part keeps Sigma well conditioned)


@dataclass(frozen=True)
class Weights:
    """The whitening W (2n x 2n, block lower-triangular per piece of a series) and what it
    was made of, per channel (`params`)."""

    matrix: sparse.csr_matrix
    params: dict

    def whiten(self, x: np.ndarray) -> np.ndarray:
        return self.matrix @ x


def rounding_variance(d: WindData) -> np.ndarray:
    """(m/s)^2 per row: the mean over north and east of the ground velocity's rounding
    variance, (q_n^2 + q_e^2) / 12 / T^2 (module docstring); 0 where the positions are not
    rounded or the span is unknown."""
    m_lat, m_lon = metres_per_degree(d.lat)
    q_n, q_e = d.position_step_deg * m_lat, d.position_step_deg * m_lon
    with np.errstate(invalid="ignore", divide="ignore"):
        v = (q_n**2 + q_e**2) / 12.0 / d.track_span_s**2
    return np.where(np.isfinite(v), v, 0.0)


def _series(d: WindData) -> tuple[np.ndarray, np.ndarray]:
    """(rows in (flight, reference, time) order, the series id of each of them)."""
    order = np.lexsort((d.time_s, d.source, d.flight))
    new = np.ones(d.n, dtype=bool)
    new[1:] = (d.flight[order][1:] != d.flight[order][:-1]) | (d.source[order][1:] != d.source[order][:-1])
    return order, np.cumsum(new) - 1


def correlation_model(t: np.ndarray, series: np.ndarray, e: np.ndarray) -> tuple[float, float]:
    """(c, tau_s) of corr(dt) = c exp(-dt / tau) fitted to the products of e at lags
    1..LAGS within series (rows in time order within each); (0, nan) where fewer than two
    bins show a correlation above MIN_CORR or it does not fall with dt."""
    var = float(np.mean(e**2))
    if not var > 0:
        return 0.0, math.nan
    dts, prods = [], []
    for lag in range(1, LAGS + 1):
        same = series[lag:] == series[:-lag]
        dts.append((t[lag:] - t[:-lag])[same])
        prods.append((e[lag:] * e[:-lag])[same])
    dt, pr = np.concatenate(dts), np.concatenate(prods)
    if len(dt) < 10 * N_BINS:
        return 0.0, math.nan
    edges = np.unique(np.quantile(dt, np.linspace(0.0, 1.0, N_BINS + 1)))
    which = np.clip(np.searchsorted(edges, dt, side="right") - 1, 0, len(edges) - 2)
    x, ylog = [], []
    for b in range(len(edges) - 1):
        m = which == b
        r = float(np.mean(pr[m])) / var if m.any() else 0.0
        if r > MIN_CORR:
            x.append(float(np.median(dt[m])))
            ylog.append(math.log(r))
    if len(x) < 2 or np.ptp(x) <= 0:
        return 0.0, math.nan
    slope, icpt = np.polyfit(x, ylog, 1)
    if not slope < 0:
        return 0.0, math.nan
    return float(min(math.exp(icpt), MAX_C)), float(-1.0 / slope)


def working_weights(d: WindData, resid: np.ndarray) -> Weights | None:
    """The whitening of the working covariance (module docstring) from the model's residual
    (2n, the stacked channels); None where the tests' units are not flights or neither
    channel's residual is correlated."""
    if d.unit != "flight":
        return None
    n = d.n
    order, series = _series(d)
    t = d.time_s[order]
    v = rounding_variance(d)[order]
    # pieces: consecutive rows of one series, at most MAX_PIECE
    start = np.ones(n, dtype=bool)
    start[1:] = series[1:] != series[:-1]
    pos = np.arange(n) - np.maximum.accumulate(np.where(start, np.arange(n), 0))
    piece = np.cumsum(start | (pos % MAX_PIECE == 0)) - 1
    cuts = np.flatnonzero(np.diff(piece)) + 1
    bounds = list(zip(np.r_[0, cuts], np.r_[cuts, n], strict=True))
    params: dict = {"position_step_deg": d.position_step_deg, "max_piece_rows": MAX_PIECE}
    rows, cols, vals = [], [], []
    any_corr = False
    for ch, off in (("transverse", 0), ("along", n)):
        e = resid[off : off + n][order]
        s2 = float(np.mean(e**2))
        c, tau = correlation_model(t, series, e)
        any_corr |= c > 0
        params[ch] = {"correlated_share": c, "tau_s": tau, "residual_rms": math.sqrt(s2)}
        for a, b in bounds:
            ts = t[a:b]
            S = np.diag(s2 * (1.0 - c) + v[a:b])
            if c > 0:
                S += s2 * c * np.exp(-np.abs(ts[:, None] - ts[None, :]) / tau)
            Wp = np.linalg.inv(np.linalg.cholesky(S))
            i, j = np.tril_indices(b - a)
            rows.append(off + order[a:b][i])
            cols.append(off + order[a:b][j])
            vals.append(Wp[i, j])
    if not any_corr:
        return None
    W = sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(2 * n, 2 * n))
    params["rows_rounding_above_half"] = int(np.sum(v > 0.5 * float(np.mean(resid**2))))
    return Weights(W, params)
