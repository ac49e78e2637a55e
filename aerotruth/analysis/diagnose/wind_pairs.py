"""A reference model's bias from the differences of the reference models at the same reports.

At one report the aircraft's measured wind is the same in every reference's row, so the
difference of a reference's residual and the mean of the other references' residuals there,

    D_m = y_m - mean over o != m of y_o      (each channel, transverse and along),

carries only the analyses' errors: the heading deviation, the airspeed error and every term
of the aircraft's model cancel exactly. A bias b of model m along the wind (the reference's
wind too strong by b) enters D_m as b times the wind's unit vector on the row's
(transverse, along) frame, the column of `wind_model.reference_bias_column`. The unit vector
here is the aircraft's own reported wind: its errors are the aircraft's, independent of the
analyses' in D_m (a reference's direction, or the references' mean, would carry errors that
are in D_m: errors in variables, a bias of the test itself). The aircraft's heading deviation
turns it by up to TAS d / |W|; that attenuates the estimate and leaves the test valid.

Where the units are weather blocks and the residual shows the analyses' error as a field
the aircraft share (wind_field), D_m's covariance within a unit is that field's, times
1 + 1/(M - 1) for M independent analyses, rotated into each row's frame, plus a nugget per
channel (D_m's variance less the field's, at least NUGGET_FLOOR of it). The test whitens each
unit's reports by the Cholesky factor of that covariance (in time-ordered pieces of at most
MAX_PIECE reports; block-diagonal across pieces, a choice of weights), fits b by least
squares on the whitened rows and tests it with the cluster-robust covariance over the units,
valid whatever the covariance (the working covariance decides only the weights): reports
where many aircraft fly close together see one draw of the field, and count about once
rather than once per aircraft. With two references the two differences are one contrast,
tested once; with more, each reference against the others, Bonferroni over them.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.linalg import solve_triangular

from aerotruth.analysis.diagnose.wind_data import WindData
from aerotruth.analysis.diagnose.wind_field import FieldKernel, heading_frames, local_coordinates
from aerotruth.analysis.diagnose.wind_model import cluster_robust, wald_p
from aerotruth.analysis.least_squares import ols
from aerotruth.units import KT

MAX_PIECE = 400  # reports whitened together (a Cholesky of 2 x 400 rows)
NUGGET_FLOOR = 0.1  # the nugget's least share of D's variance per channel
MIN_UNITS = 5  # units with paired reports a test needs


def paired_reports(d: WindData) -> np.ndarray:
    """(R, M) row index of each reference's row at every report that has a row of each of
    the M references (reports missing one are left out)."""
    m = len(d.sources)
    frame = pd.DataFrame({"report": d.report, "source": d.source, "row": np.arange(d.n)})
    wide = frame.pivot_table(index="report", columns="source", values="row", aggfunc="first")
    wide = wide.reindex(columns=range(m)).dropna()
    return wide.to_numpy(dtype=np.int64)


def measured_wind_column(d: WindData, rows: np.ndarray) -> np.ndarray:
    """(len(rows), 2) the unit vector of the aircraft's reported wind on each row's
    (transverse, along) frame, in kt per kt of bias (reference_bias_column's convention);
    0 where the reported wind is calm."""
    e, n = d.wobs_e[rows], d.wobs_n[rows]
    sp = np.hypot(e, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        ue, un = np.where(sp > 0, e / sp, 0.0), np.where(sp > 0, n / sp, 0.0)
    z = d.z[rows]
    return np.column_stack([ue * np.cos(z) - un * np.sin(z), ue * np.sin(z) + un * np.cos(z)]) * KT


def _whitening(d: WindData, rows: np.ndarray, kernel: FieldKernel, factor: float, nugget: np.ndarray):
    """Per piece of a unit's reports (time order, at most MAX_PIECE): (positions in `rows`,
    the lower Cholesky factor of D's working covariance over their (transverse, along)
    pairs, interleaved)."""
    x, y, z, t = local_coordinates(d)
    order = np.argsort(d.time_s[rows], kind="stable")
    out = []
    for piece in np.array_split(order, max(1, -(-len(order) // MAX_PIECE))):
        r = rows[piece]
        K = (
            factor
            * kernel.variance
            * kernel.correlation(
                np.hypot(x[r][:, None] - x[r][None, :], y[r][:, None] - y[r][None, :]),
                np.abs(z[r][:, None] - z[r][None, :]),
                np.abs(t[r][:, None] - t[r][None, :]),
            )
        )
        R = heading_frames(d.z[r])
        k = len(r)
        C = (np.einsum("iab,jcb->iajc", R, R) * K[:, None, :, None]).reshape(2 * k, 2 * k)
        diag = np.arange(2 * k)
        C[diag[0::2], diag[0::2]] += nugget[0]
        C[diag[1::2], diag[1::2]] += nugget[1]
        out.append((piece, np.linalg.cholesky(C)))
    return out


def reference_difference_test(d: WindData, y: np.ndarray, kernel: FieldKernel | None) -> dict | None:
    """The references' biases tested on their differences at the same reports (module
    docstring), `y` the stacked residual less the model's known offsets. Returns {"p": the
    smallest p times the contrasts tested, "per": {reference: {"b_kt", "p"}}, "reports",
    "units", "test"}; None with one reference, no field (`kernel` None) or fewer than
    MIN_UNITS units with paired reports."""
    m = len(d.sources)
    if m < 2 or kernel is None:
        return None
    idx = paired_reports(d)
    if len(idx) == 0:
        return None
    units = d.cluster[idx[:, 0]]
    uniq = np.unique(units)
    if len(uniq) < MIN_UNITS:
        return None
    n = d.n
    Y = np.stack([np.column_stack([y[idx[:, j]], y[n + idx[:, j]]]) for j in range(m)], axis=1)  # (R, M, 2)
    X = measured_wind_column(d, idx[:, 0])  # the same at every row of a report
    factor = 1.0 + 1.0 / (m - 1)
    tested = [0] if m == 2 else list(range(m))  # two references: one contrast
    per: dict[str, dict] = {}
    for j in tested:
        D = Y[:, j] - (Y.sum(axis=1) - Y[:, j]) / (m - 1)  # (R, 2)
        nugget = np.maximum(D.var(axis=0) - factor * kernel.variance, NUGGET_FLOOR * D.var(axis=0))
        xs, ys, gs = [], [], []
        for u in uniq:
            pos = np.flatnonzero(units == u)
            for piece, L in _whitening(d, idx[pos, 0], kernel, factor, nugget):
                rows = pos[piece]
                xs.append(solve_triangular(L, X[rows].reshape(-1), lower=True))
                ys.append(solve_triangular(L, D[rows].reshape(-1), lower=True))
                gs.append(np.full(2 * len(rows), u))
        xw, yw, g = np.concatenate(xs)[:, None], np.concatenate(ys), np.concatenate(gs)
        beta, xtx = ols(xw, yw)
        cov = cluster_robust(xw, yw - xw @ beta, g, xtx)
        per[d.sources[j]] = {"b_kt": float(beta[0]), "p": wald_p(beta, cov, len(uniq) - 1)}
    if m == 2:  # the other reference's is the same contrast, of the other sign
        only = per[d.sources[0]]
        per[d.sources[1]] = {"b_kt": -only["b_kt"], "p": only["p"]}
    return {
        "p": float(min(1.0, min(v["p"] for v in per.values()) * len(tested))),
        "per": per,
        "reports": int(len(idx)),
        "units": int(len(uniq)),
        "test": "the references' differences at the same reports along the aircraft's reported wind, weighted by "
        "the field's covariance, cluster-robust Wald on {units}",
    }
