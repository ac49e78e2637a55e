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
tested once; with more, each reference against the mean of the others present at each
report, Bonferroni over them.

What it cannot tell, and what it assumes. The differences see only what the references do
not share: a bias both models make alike (and an error of the measured wind along the wind,
the aircraft's) is not in them; with two references the contrast says that they differ, not
which of them errs (the finding's sizes, per reference, are the table's fit). The measured
wind's errors must be independent of the analyses': a model that assimilated these very
reports (a reanalysis taking in the aircraft's winds) carries part of their error, which
leans towards the measured wind's direction and would read as a bias of that model where
the other assimilated less of it.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.linalg import solve_triangular

from aerotruth.analysis.diagnose.wind_data import WindData, heading_components
from aerotruth.analysis.diagnose.wind_field import FieldKernel, heading_frames, local_coordinates
from aerotruth.analysis.diagnose.wind_model import cluster_robust, wald_p
from aerotruth.analysis.least_squares import ols
from aerotruth.units import KT

MAX_PIECE = 300  # reports whitened together (a Cholesky of 2 x 300 rows)
NUGGET_FLOOR = 0.1  # the nugget's least share of D's variance per channel
NUGGET_MIN = 1e-4  # (m/s)^2: and at least this (a reference listed twice has no difference at all)
MIN_UNITS = 5  # units with paired reports a test needs


def report_rows(d: WindData) -> np.ndarray:
    """(R, M) row index of each reference's row at every report (the first where a report
    has two rows of one reference), -1 where the report has no row of that reference."""
    m = len(d.sources)
    frame = pd.DataFrame({"report": d.report, "source": d.source, "row": np.arange(d.n)})
    wide = frame.pivot_table(index="report", columns="source", values="row", aggfunc="first")
    return wide.reindex(columns=range(m)).fillna(-1).to_numpy(dtype=np.int64)


def measured_wind_column(d: WindData, rows: np.ndarray) -> np.ndarray:
    """(len(rows), 2) the unit vector of the aircraft's reported wind on each row's
    (transverse, along) frame, in kt per kt of bias (reference_bias_column's convention);
    0 where the reported wind is calm."""
    e, n = d.wobs_e[rows], d.wobs_n[rows]
    sp = np.hypot(e, n)
    with np.errstate(invalid="ignore", divide="ignore"):
        ue, un = np.where(sp > 0, e / sp, 0.0), np.where(sp > 0, n / sp, 0.0)
    return np.column_stack(heading_components(ue, un, d.z[rows])) * KT


def _cholesky(C: np.ndarray) -> np.ndarray:
    """The lower Cholesky factor of a working covariance; with a little more on the diagonal
    where rounding leaves it not quite positive definite (two reports at one place and
    time), and the diagonal's square root where even that fails (ordinary weights)."""
    try:
        return np.linalg.cholesky(C)
    except np.linalg.LinAlgError:
        pass
    try:
        return np.linalg.cholesky(C + np.eye(len(C)) * 1e-6 * float(np.mean(np.diag(C))))
    except np.linalg.LinAlgError:
        return np.diag(np.sqrt(np.diag(C)))


def _whitening(d, coords, rows: np.ndarray, scale: np.ndarray, kernel: FieldKernel, nugget: np.ndarray):
    """Per piece of a unit's reports (time order, at most MAX_PIECE): (positions in `rows`,
    the lower Cholesky factor of D's working covariance over their (transverse, along)
    pairs, interleaved); `scale` each report's factor on the field's variance."""
    x, y, z, t = coords
    order = np.argsort(d.time_s[rows], kind="stable")
    out = []
    for piece in np.array_split(order, max(1, -(-len(order) // MAX_PIECE))):
        r = rows[piece]
        f = np.sqrt(scale[piece])
        K = (
            kernel.variance
            * f[:, None]
            * f[None, :]
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
        out.append((piece, _cholesky(C)))
    return out


def _contrast(d, coords, y: np.ndarray, rr: np.ndarray, j: int, kernel: FieldKernel) -> dict | None:
    """Reference j against the mean of the other references present at each report (module
    docstring): {"b_kt", "p", "reports", "units"}, None with fewer than MIN_UNITS units."""
    n = d.n
    mine = rr[:, j] >= 0
    others = (rr >= 0) & (np.arange(rr.shape[1]) != j)[None, :]
    k = others.sum(axis=1)
    use = mine & (k > 0)
    rr, others, k = rr[use], others[use], k[use]
    rows = rr[:, j]
    safe = np.where(others, rr, rows[:, None])  # a valid index where a reference is absent (masked out)
    mean_o = np.stack([(np.where(others, y[c * n + safe], 0.0)).sum(axis=1) / k for c in (0, 1)], axis=1)
    D = np.column_stack([y[rows], y[n + rows]]) - mean_o  # (R, 2)
    X = measured_wind_column(d, rows)
    ok = np.isfinite(D).all(axis=1) & np.isfinite(X).all(axis=1)
    rows, D, X, k = rows[ok], D[ok], X[ok], k[ok]
    units = d.cluster[rows]
    order = np.argsort(units, kind="stable")
    uniq, starts = np.unique(units[order], return_index=True)
    if len(uniq) < MIN_UNITS or not (D.var(axis=0) > 0).any():
        return None
    scale = 1.0 + 1.0 / k  # D's field variance over one model's, each report (independent models)
    nugget = np.maximum.reduce(
        [D.var(axis=0) - float(np.mean(scale)) * kernel.variance, NUGGET_FLOOR * D.var(axis=0), np.full(2, NUGGET_MIN)]
    )
    xs, ys, gs = [], [], []
    for u, pos in zip(uniq, np.split(order, starts[1:]), strict=True):
        for piece, L in _whitening(d, coords, rows[pos], scale[pos], kernel, nugget):
            at = pos[piece]
            xs.append(solve_triangular(L, X[at].reshape(-1), lower=True))
            ys.append(solve_triangular(L, D[at].reshape(-1), lower=True))
            gs.append(np.full(2 * len(at), u))
    xw, yw, g = np.concatenate(xs)[:, None], np.concatenate(ys), np.concatenate(gs)
    beta, xtx = ols(xw, yw)
    cov = cluster_robust(xw, yw - xw @ beta, g, xtx)
    return {
        "b_kt": float(beta[0]),
        "p": wald_p(beta, cov, len(uniq) - 1),
        "reports": int(len(rows)),
        "units": int(len(uniq)),
    }


def reference_difference_test(d: WindData, y: np.ndarray, kernel: FieldKernel | None) -> dict | None:
    """The references' biases tested on their differences at the same reports (module
    docstring), `y` the stacked residual less the model's known offsets. Returns {"p": the
    smallest p times the contrasts tested, "per": {reference: {"b_kt", "p", "reports",
    "units"}}, "test"}; None with one reference, no field (`kernel` None) or no contrast
    with MIN_UNITS units of paired reports."""
    m = len(d.sources)
    if m < 2 or kernel is None:
        return None
    rr = report_rows(d)
    coords = local_coordinates(d)
    tested = [0] if m == 2 else list(range(m))  # two references: one contrast
    per: dict[str, dict] = {}
    for j in tested:
        c = _contrast(d, coords, y, rr, j, kernel)
        if c is not None:
            per[d.sources[j]] = c
    if not per:
        return None
    p = float(min(1.0, min(v["p"] for v in per.values()) * len(tested)))
    if m == 2:  # the other reference's is the same contrast, of the other sign
        only = per[d.sources[0]]
        per[d.sources[1]] = {**only, "b_kt": -only["b_kt"]}
    return {
        "p": p,
        "per": per,
        "test": "the references' differences at the same reports along the aircraft's reported wind, weighted by "
        "the field's covariance, cluster-robust Wald on {units}",
    }
