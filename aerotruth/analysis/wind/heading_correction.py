"""The wind paper's heading-deviation correction as an estimator: learn an aircraft's
flux-valve deviation from its wind reports and reference-model winds, then correct.

The heading errors d (section 5.1, eqs. 3-4) come from `aerotruth.analysis.wind.heading_errors`,
the observation table's checks from `aerotruth.analysis.wind.observations`, the robust fit with
its cluster standard errors from `aerotruth.analysis.wind.robust_fit`, and the wind metrics
before and after a correction from `aerotruth.analysis.wind.metrics`.

Model (wind paper eq. 2), d as a function of the measured heading z':

    d = A + B sin z' + C cos z' + D sin 2z' + E cos 2z'

Noise: a reference-wind error e (per component sd sigma) moves psi' by e_perp/TAS, so
d_i = x_i b + n_i with var(n_i) = sigma^2 / TAS_i^2: base weights w_i = (TAS_i/median)^2.
For independent Gaussian errors the Cramer-Rao bound of b is sigma_d^2 (X^T W X)^-1
(sigma_d the sd at the median TAS), which weighted least squares attains.

Bootstrap (`HeadingDeviationFit.bootstrap`): whole flights resampled with replacement,
symmetric bootstrap-t intervals b -+ q se with q the quantile of |b* - b| / se* (CR3 se of
each resample); percentile intervals on request (they undercover with ~40 flights).

Identifiability of the sinusoid: the weighted covariance of (sin z', cos z') over the
used reports has two eigenvalues (headings uniform round the compass give 0.5 and 0.5).
Both >= 0.1: B, C are fitted. Only the larger one (one route flown both ways, e.g. a hub
with its spokes on one side, as PenAir's Anchorage-south-west network; 1 and ~0): the
data fix the deviation on the flown headings z_a and z_a + 180 and so the sinusoid's
component along that axis, s cos(z' - z_a), but nothing of the perpendicular
component; the fit is A + s cos(z' - z_a) (B = s sin z_a, C = s cos z_a, their standard
errors the one of s projected, status `fitted`, the axis named in `reason`): the minimum-
norm sinusoid, exact on the headings flown. (Measured on the PenAir campaign, 5 seeds,
spread ~0.04: fitting both terms anyway, from the few gated off-axis climb reports, made
the uploaded table's steady-flight heading error worse by 0.14 +- 0.06 deg, paired on the
same flights.) Both < 0.1 (one heading): only the offset A
(status `offset_only`, said in `reason`). D, E need the same of (sin 2z', cos 2z') and are kept only when the
cluster-robust Wald test of D = E = 0 rejects at level 0.001 (F(2, G-1), G flights) —
a Wald test on flight clusters, not dBIC: BIC counts correlated reports as independent.

Several reference models ("combined references"): every (report, model) pair is a row
of the fit, clustered by flight. Cross-model consistency (wind paper section 5: "if both
models predicted a similar curve then the results are believable"): each model fitted
alone with the same terms, from the pooled coefficients as the one-step M-estimator (one
Newton step of that model's own estimating equations at its own MAD scale; Bickel 1975,
JASA 70: from a root-n consistent start, asymptotically the fully iterated fit), kept when
a further step would move no coefficient by more than 0.1 standard error, else iterated to
convergence (models far apart). On the method benchmark's 12 aircraft x 1000 flights
every step is kept: p-values within 0.002 and curve differences within 1e-4 deg of the
iterated fits, the fit stage 15 % faster; for each pair a Wald test of equal coefficients
with the covariance of the difference from the flight-cluster influences (the fits share
the reports), F(k, G-1), Bonferroni-adjusted over the pairs; p < 0.01 is reported as a
disagreement (the fit is kept; `reason` says so).

Lookup table (wind paper section 8.1): corrections to *add* to the measured heading at
0, 45, ..., 315 deg, lut_k = -d(z_k); `correct` interpolates it piecewise linearly round
the circle. Aircraft whose avionics give TAMDAR true heading can only have an offset
corrected (wind paper section 8.4, Chautauqua ERJs): offset-only fit and table.

Heading frames: `heading="true"` fits on the true measured heading (the paper's choice);
`heading="magnetic"` on the magnetic heading the onboard table is indexed by: the
`heading_mag_deg` column, else true heading minus `declination_deg` (east positive).

Flights (the clusters of the standard errors and of the bootstrap): the `flight` column
when present, else a new flight wherever an aircraft's consecutive reports are more than
30 min apart (`heading_errors.report_flights`).
"""

from __future__ import annotations

import datetime as dt
import math

import numpy as np
import pandas as pd
from numba import njit
from scipy import stats

from aerotruth.analysis.wind.heading_errors import GateSpec, heading_errors
from aerotruth.analysis.wind.robust_fit import (
    cluster_starts,
    design,
    design_t,
    fit_from_t,
    huber_t,
    median,
    robust_fit_t,
    weighted_gram_t,
)

TERM_NAMES = ("A", "B", "C", "D", "E")
LUT_HEADINGS_DEG = np.arange(0.0, 360.0, 45.0)
LUT_COLUMNS = tuple(f"lut_{int(h):03d}_deg" for h in LUT_HEADINGS_DEG)
TABLE_COLUMNS = (
    "aircraft",
    "status",
    "reason",
    "n_used",
    *(f"{t}_deg" for t in TERM_NAMES),
    *(f"{t}_se_deg" for t in TERM_NAMES),
    *LUT_COLUMNS,
    "valid_from",
    "valid_to",
)
STATUSES = ("fitted", "offset_only", "refused")
MIN_BOOTSTRAP_CLUSTERS = 10  # fewer: t intervals instead of resampling (HeadingDeviationFit.bootstrap)


def heading_axes(heading_deg: np.ndarray, w: np.ndarray, harmonic: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Eigenvalues (ascending) and unit eigenvectors (columns, in (sin nz, cos nz)) of the
    weighted covariance of (sin nz, cos nz) of the headings, n = `harmonic` (1 or 2)."""
    return _gram_axes(
        weighted_gram_t(design_t(np.asarray(heading_deg, dtype=float), 5), np.asarray(w, dtype=float)), harmonic
    )


def _gram_axes(gram: np.ndarray, harmonic: int) -> tuple[np.ndarray, np.ndarray]:
    """heading_axes from X^T W X of the design of eq. 2 (1, sin z, cos z, sin 2z, cos 2z): the
    weights' sum, the weighted sums of (sin nz, cos nz) and of their products."""
    j = [1, 2] if harmonic == 1 else [3, 4]
    mu = gram[0, j] / gram[0, 0]
    return np.linalg.eigh(gram[np.ix_(j, j)] / gram[0, 0] - np.outer(mu, mu))


def heading_spread(heading_deg: np.ndarray, w: np.ndarray, harmonic: int = 1) -> float:
    """Smaller eigenvalue of the weighted covariance of (sin nz, cos nz): 0.5 for headings
    uniform round the compass, 0 for one heading (or, n = 1, one route both ways)."""
    return float(heading_axes(heading_deg, w, harmonic)[0][0])


def octants_occupied(heading_deg: np.ndarray, min_share: float = 0.03) -> int:
    """45-deg heading sectors holding at least `min_share` of the reports."""
    o = (
        np.floor(np.asarray(heading_deg, dtype=float) / 45.0).astype(np.intp) & 7
    )  # mod 8 (not float % and //: 5x slower)
    return int(np.sum(np.bincount(o, minlength=8) >= min_share * max(len(o), 1)))


def lut_correction(lut: np.ndarray, heading_deg: np.ndarray, table: np.ndarray | None = None) -> np.ndarray:
    """Correction (deg) at the measured heading from an 8-point table at 0, 45, ..., 315 deg,
    linear between points and round the circle (wind paper 8.1). `lut` (8,), or several
    tables (T, 8) with `table` the row (0..T-1) to use at each heading."""
    h = np.asarray(heading_deg, dtype=float)
    lut = np.asarray(lut, dtype=float)
    if lut.shape == (8,):
        rows = np.zeros(0, dtype=np.int64)
    elif table is not None and lut.ndim == 2 and lut.shape[1] == 8:
        rows = np.ascontiguousarray(np.broadcast_to(np.asarray(table, dtype=np.int64), h.shape)).reshape(-1)
    else:
        raise ValueError(f"lut: expected (8,), or (T, 8) with `table`, got shape {lut.shape}")
    out = np.empty(h.shape)
    _lut_interp(np.ascontiguousarray(lut).reshape(-1), rows, np.ascontiguousarray(h).reshape(-1), out.reshape(-1))
    return out


@njit(cache=True, nogil=True, error_model="numpy")
def _lut_interp(lut: np.ndarray, rows: np.ndarray, h: np.ndarray, out: np.ndarray) -> None:
    """lut_correction's loop: `lut` the tables flattened (8 a row), `rows` each heading's
    table (empty: table 0 throughout)."""
    for k in range(len(h)):
        x = h[k] / 45.0  # in table steps (no float remainder: 5x slower)
        q = np.floor(x)  # (math.floor gives an integer)
        frac = x - q
        i = (int(q) if math.isfinite(q) else 0) & 7  # i mod 8, negative i too (two's complement); NaN, inf -> NaN below
        base = rows[k] * 8 if len(rows) else 0
        lo = lut[base + i]
        out[k] = (lut[base + ((i + 1) & 7)] - lo) * frac + lo  # the point below plus the step to the next times frac


def _iso_date(t: float) -> str:
    return dt.datetime.fromtimestamp(t, tz=dt.UTC).date().isoformat()


def _iso_time(t: float) -> str:
    """UTC time to the second below/above: a span written this way still holds its reports."""
    return dt.datetime.fromtimestamp(t, tz=dt.UTC).strftime("%Y-%m-%dT%H:%M:%S.%fZ")


# ----------------------------------------------------------------------------- estimator


def _used_arrays(rows: pd.DataFrame, heading: str) -> dict:
    """The columns a fit needs, as arrays, and the mask of rows it may use."""
    col = "heading_deg" if heading == "true" else "heading_mag_deg"
    z = rows[col].to_numpy()
    used = (rows["gate"].cat.codes.to_numpy() == 0) & np.isfinite(z)
    if heading == "magnetic" and not np.isfinite(z).any():
        raise ValueError(
            "heading='magnetic' needs a heading_mag_deg or declination_deg column in the observation table"
        )
    src = pd.Categorical(rows["ref_source"])
    return {
        "used": used,
        "z": z,
        "y": rows["error_deg"].to_numpy(),
        "tas": rows["tas_ms"].to_numpy(),
        "g": rows["cluster"].to_numpy() if "cluster" in rows.columns else rows["flight"].to_numpy(),
        "flight": rows["flight"].to_numpy(),
        "t": rows["time_s"].to_numpy(),
        "src": src.codes.astype(np.int64),
        "src_names": list(src.categories),
    }


# a lookup-table entry read from a file may not exceed the largest heading error the method
# takes as a measurement (GateSpec.max_heading_error_deg: beyond it a report is a gross error)
_MAX_TABLE_CORRECTION_DEG = GateSpec().max_heading_error_deg
# a table's entries read back agree with its coefficients within this (a file rounded to 0.01 deg passes)
LUT_AGREEMENT_DEG = 0.05


class HeadingDeviationFit:
    """One aircraft's heading deviation (wind paper eq. 2) learned from its reports.

    Parameters: `terms` "auto" (offset + sinusoid, D, E when the Wald test keeps them),
    "offset", "sinusoid" (A, B, C), "full" (A..E); `robust` Huber M-estimate (else weighted
    least squares); `heading` "true" or "magnetic" (the frame of z'); `offset_only` for
    aircraft whose avionics hand TAMDAR true heading (wind paper 8.4); thresholds as in
    the module docstring. Learned: coef_, se_ (deg, dicts A..E; 0 and NaN for terms not
    fitted), status_, reason_, lut_ (8 corrections to add, deg), n_used_, n_flights_,
    valid_from_, valid_to_, terms_, scale_deg_, coverage_, octants_, consistency_.
    """

    def __init__(
        self,
        terms: str = "auto",
        robust: bool = True,
        heading: str = "true",
        offset_only: bool = False,
        huber_c: float = 1.345,
        min_coverage: float = 0.1,
        de_level: float = 0.001,
        consistency_level: float = 0.01,
        min_reports: int = 30,
        min_clusters: int = 5,
        max_sinusoid_se_deg: float = 1.0,
        gates: GateSpec | None = None,
    ):
        self.terms = terms
        self.robust = robust
        self.heading = heading
        self.offset_only = offset_only
        self.huber_c = huber_c
        self.min_coverage = min_coverage
        self.de_level = de_level
        self.consistency_level = consistency_level
        self.min_reports = min_reports
        self.min_clusters = min_clusters
        self.max_sinusoid_se_deg = max_sinusoid_se_deg
        self.gates = gates

    def _check_params(self) -> None:
        if self.terms not in ("auto", "offset", "sinusoid", "full"):
            raise ValueError(f"terms: expected 'auto', 'offset', 'sinusoid' or 'full', got {self.terms!r}")
        if self.heading not in ("true", "magnetic"):
            raise ValueError(f"heading: expected 'true' or 'magnetic', got {self.heading!r}")
        if not self.huber_c > 0:
            raise ValueError(f"huber_c: expected a positive number, got {self.huber_c!r}")
        if not 0 <= self.min_coverage <= 0.5:
            raise ValueError(f"min_coverage: expected 0..0.5 (0.5 = uniform headings), got {self.min_coverage!r}")
        if not (isinstance(self.min_reports, int | np.integer) and self.min_reports >= 1):
            raise ValueError(f"min_reports: expected a whole number >= 1, got {self.min_reports!r}")
        if not (isinstance(self.min_clusters, int | np.integer) and self.min_clusters >= 2):
            raise ValueError(
                f"min_clusters: expected a whole number >= 2 (standard errors come from clusters), "
                f"got {self.min_clusters!r}"
            )
        if not self.max_sinusoid_se_deg > 0:
            raise ValueError(f"max_sinusoid_se_deg: expected a positive number, got {self.max_sinusoid_se_deg!r}")

    # -- fitting
    def fit(self, obs: pd.DataFrame) -> HeadingDeviationFit:
        """Learn from one aircraft's observation table (or its `heading_errors` rows)."""
        self._check_params()
        rows = obs if "error_deg" in obs.columns else heading_errors(obs, self.gates)
        acs = pd.unique(rows["aircraft"])
        if len(acs) != 1:
            raise ValueError(f"obs: HeadingDeviationFit takes one aircraft, got {len(acs)} (use FleetHeadingFit)")
        g = rows["cluster"] if "cluster" in rows.columns else rows["flight"]
        order = np.lexsort((rows["time_s"].to_numpy(), g.to_numpy()))
        return self._fit_arrays(str(acs[0]), _used_arrays(rows, self.heading), order)

    def _fit_arrays(self, aircraft: str, a: dict, sel: np.ndarray) -> HeadingDeviationFit:
        """The fit on rows `sel` of the arrays of `_used_arrays` (rows contiguous by cluster)."""
        self.aircraft_ = aircraft
        # integer gathers throughout: numpy's boolean-mask indexing is 5-15x slower here
        sel = sel.take(np.flatnonzero(a["used"].take(sel)))
        self._z, self._y, self._g, self._src = (a[c].take(sel) for c in ("z", "y", "g", "src"))
        tas = a["tas"].take(sel)
        times = a["t"].take(sel)
        self._w = (tas / median(tas)) ** 2 if len(tas) else tas
        self.n_used_ = int(len(sel))
        self.n_clusters_ = int(len(cluster_starts(self._g))) if len(sel) else 0
        self.n_flights_ = int(len(np.unique(a["flight"].take(sel))))
        self._src_names = [str(x) for x in a["src_names"]]
        # by name: nothing the fit writes follows the order of the table's rows
        self.ref_sources_ = sorted(self._src_names[i] for i in np.flatnonzero(np.bincount(self._src)))
        self.valid_from_ = _iso_date(times.min()) if len(times) else ""
        self.valid_to_ = _iso_date(times.max()) if len(times) else ""
        self.data_from_ = _iso_time(times.min()) if len(times) else ""
        self.data_to_ = _iso_time(times.max()) if len(times) else ""
        self.heading_frame_ = self.heading
        self.consistency_: dict[str, dict[str, float]] = {}
        self._XT = design_t(self._z, 5)
        gram = weighted_gram_t(self._XT, self._w)  # the headings' spreads from its sums
        self.coverage_ = float(_gram_axes(gram, 1)[0][0]) if self.n_used_ >= 3 else 0.0
        self.octants_ = octants_occupied(self._z)
        self.de_p_ = math.nan
        if self.n_used_ < self.min_reports or self.n_clusters_ < self.min_clusters:
            clusters = "cluster" if self.n_clusters_ == 1 else "clusters"
            return self._refuse(
                f"too little data: {self.n_used_} usable reports in {self.n_clusters_} {clusters} "
                f"(need {self.min_reports} in {self.min_clusters}; --min-reports, --min-clusters)"
            )
        reason = []
        full = None
        T = None  # fitted parameters -> A..E (None: the first k terms themselves)
        if self.offset_only or self.terms == "offset":
            k = 1
            reason.append(
                "aircraft gives true heading: only an offset can be corrected"
                if self.offset_only
                else "offset only, as asked"
            )
        elif self.coverage_ < self.min_coverage:
            k = 1
            lam, vec = _gram_axes(gram, 1)
            if lam[1] >= self.min_coverage:  # one axis flown both ways: its component of the sinusoid
                k = 3
                u = vec[:, 1]
                T = np.zeros((5, 2))
                T[0, 0], T[1, 1], T[2, 1] = 1.0, u[0], u[1]
                za = math.degrees(math.atan2(u[0], u[1])) % 180.0
                reason.append(
                    f"headings on one axis ({za:.0f}/{za + 180:.0f} deg; spread {self.coverage_:.2f} < "
                    f"{self.min_coverage}): sinusoid fitted along that axis only, its perpendicular part "
                    f"(not identifiable) set to 0"
                )
            else:
                reason.append(
                    f"heading coverage cannot identify the sinusoid (spread {self.coverage_:.2f} < "
                    f"{self.min_coverage}, {self.octants_} of 8 octants occupied): offset only fitted"
                )
        else:
            k = 5 if self.terms == "full" else 3
            if self.terms in ("auto", "full"):
                spread2 = float(_gram_axes(gram, 2)[0][0])
                if spread2 < self.min_coverage:
                    k = 3
                    reason.append(f"D, E not identifiable (2z spread {spread2:.2f})")
                elif self.terms == "auto":
                    full = robust_fit_t(self._XT, self._y, self._w, self._g, self.robust, self.huber_c)
                    de, V = full.beta[3:], full.cov[3:, 3:]
                    wald = float(de @ np.linalg.pinv(V) @ de)
                    G = self.n_flights_
                    self.de_p_ = float(stats.f.sf(wald / 2, 2, max(G - 1, 1)))
                    if self.de_p_ < self.de_level:
                        k = 5
                        reason.append(f"D, E kept (Wald p = {self.de_p_:.1e})")
        self._k = k
        self._T = np.eye(5)[:, :k] if T is None else T
        if k == 5 and full is not None:
            f = full
        elif full is not None:  # D, E dropped: the 5-term fit's A, B, C are a near start
            f = robust_fit_t(
                self._fit_design(),
                self._y,
                self._w,
                self._g,
                self.robust,
                self.huber_c,
                beta0=full.beta[:k],
                scale_guess=full.scale,
            )
        else:
            f = robust_fit_t(self._fit_design(), self._y, self._w, self._g, self.robust, self.huber_c)
        if k >= 3:
            cov_bc = (self._T @ f.cov @ self._T.T)[1:3, 1:3]
            se_amp = math.sqrt(max(float(np.linalg.eigvalsh(cov_bc)[-1]), 0.0))
            if not se_amp <= self.max_sinusoid_se_deg:  # NaN too
                k, reason = 1, [r for r in reason if not r.startswith("D, E")]
                reason.append(
                    f"sinusoid not determined by the data (standard error {se_amp:.2g} deg > "
                    f"{self.max_sinusoid_se_deg:g} deg, --max-sinusoid-se-deg): offset only fitted"
                )
                self._k, self._T = 1, np.eye(5)[:, :1]
                f = robust_fit_t(self._fit_design(), self._y, self._w, self._g, self.robust, self.huber_c)
        self._fit = f
        self.terms_ = TERM_NAMES[:k]
        beta = self._T @ f.beta
        cov = self._T @ f.cov @ self._T.T
        self.coef_ = {t: (float(beta[i]) if i < k else 0.0) for i, t in enumerate(TERM_NAMES)}
        se = np.sqrt(np.diag(cov))
        self.se_ = {t: (float(se[i]) if i < k else math.nan) for i, t in enumerate(TERM_NAMES)}
        self.cov_ = cov[:k, :k]
        self.scale_deg_ = float(f.scale)
        self.status_ = "offset_only" if k == 1 else "fitted"
        self._consistency(k, reason)
        self.reason_ = "; ".join(reason) if reason else "offset and sinusoid fitted"
        self.lut_ = -self.deviation(LUT_HEADINGS_DEG)
        return self

    def _fit_design(self, rows: np.ndarray | None = None) -> np.ndarray:
        """The (p, n) design of the fitted parameters, T^T X^T (X^T's first k rows when the
        parameters are the first k terms), of all used rows or of `rows` (indices)."""
        T = self._T
        if np.array_equal(T, np.eye(5)[:, : T.shape[1]]):
            XT = self._XT[: T.shape[1]]
            return XT if rows is None else XT.take(rows, axis=1)
        return T.T @ (self._XT if rows is None else self._XT.take(rows, axis=1))

    def _refuse(self, why: str) -> HeadingDeviationFit:
        self.status_, self.reason_ = "refused", why
        self.terms_ = ()
        self.coef_ = {t: math.nan for t in TERM_NAMES}
        self.se_ = {t: math.nan for t in TERM_NAMES}
        self.scale_deg_ = math.nan
        self.lut_ = np.full(8, math.nan)
        self._k = 0
        return self

    def _consistency(self, k: int, reason: list[str]) -> None:
        """Each reference model alone, pairwise Wald test of equal coefficients."""
        counts = np.bincount(self._src)
        srcs = sorted(self._src_names[c] for c in np.flatnonzero(counts >= max(self.min_reports, 1)))
        if len(srcs) < 2:
            return
        flights = self._g[cluster_starts(self._g)]  # rows are sorted by flight
        fits = {}
        for s in srcs:
            m = np.flatnonzero(self._src == self._src_names.index(s))  # indices: faster gathers than a mask
            f = fit_from_t(
                self._fit_design(m),
                self._y.take(m),
                self._w.take(m),
                self._g.take(m),
                self._fit.beta,
                self._fit.scale,
                self.robust,
                self.huber_c,
            )
            infl = np.zeros((len(flights), self._T.shape[1]))
            infl[np.searchsorted(flights, f.groups)] = f.influence
            fits[s] = (f.beta, infl)
        G = len(flights)
        n_pairs = len(srcs) * (len(srcs) - 1) // 2
        zz = design(np.arange(360.0), 5) @ self._T
        worst = None
        for i, a in enumerate(srcs):
            for b in srcs[i + 1 :]:
                delta = fits[a][0] - fits[b][0]
                dh = fits[a][1] - fits[b][1]
                V = dh.T @ dh * G / max(G - 1, 1)
                W = float(delta @ np.linalg.pinv(V) @ delta)
                q = len(delta)
                p = min(1.0, float(stats.f.sf(W / q, q, max(G - 1, 1))) * n_pairs)  # Bonferroni over pairs
                diff = float(np.max(np.abs(zz @ delta)))
                self.consistency_[f"{a}-{b}"] = {"p": p, "max_diff_deg": diff}
                if worst is None or p < worst[1]:
                    worst = (f"{a} vs {b}", p, diff)
        assert worst is not None  # two sources or more: one pair at least
        self.consistency_p_ = worst[1]
        self.consistency_max_diff_deg_ = worst[2]
        if worst[1] < self.consistency_level:
            reason.append(
                f"reference models disagree ({worst[0]}: p = {worst[1]:.1e}, curves differ by up to "
                f"{worst[2]:.2f} deg): check the models for bias"
            )
        else:
            reason.append(f"reference models agree ({worst[0]}: p = {worst[1]:.2f})")

    # -- applying
    def deviation(self, heading_deg) -> np.ndarray:
        """d(z') of wind paper eq. 2 from the fitted coefficients (deg)."""
        c = np.array([self.coef_[t] for t in TERM_NAMES])
        return design(np.atleast_1d(np.asarray(heading_deg, dtype=float)), 5) @ c

    def correction(self, heading_deg) -> np.ndarray:
        """Correction to add (deg): the lookup table interpolated piecewise linearly round the
        circle (as the TAMDAR firmware does, wind paper 8.1); 0 for a refused aircraft."""
        h = np.asarray(heading_deg, dtype=float)
        return lut_correction(np.nan_to_num(np.asarray(self.lut_, dtype=float)), h)

    def correct(self, heading_deg) -> np.ndarray:
        """Corrected heading (deg, [0, 360)) = measured + lookup-table correction."""
        h = np.asarray(heading_deg, dtype=float)
        return (h + self.correction(h)) % 360.0

    # -- uncertainty
    def bootstrap(
        self,
        n_boot: int = 1000,
        rng: np.random.Generator | None = None,
        level: float = 0.95,
        method: str = "studentized",
    ) -> pd.DataFrame:
        """Intervals for the fitted coefficients and the 8 table entries from resampling whole
        flights with replacement (terms fixed to the fitted ones). Each quantity q = L b is
        linear in the fitted parameters b (a coefficient: one parameter times a constant; a
        table entry lut_k = -d(z_k)). `method` "studentized" (symmetric bootstrap-t: the
        `level` quantile of |q* - q| / se*(q) with the flight-clustered covariance of each
        resample, interval q -+ that quantile x se(q)) or "percentile" (quantiles of q*;
        measured to undercover with ~40 flights: 0.92-0.94 for a 95 % interval). A resample
        whose flights cannot identify the terms (a singular fit) is left out; with more than
        a tenth of them left out the intervals are NaN. Rows: the terms, then lut_000_deg ...
        lut_315_deg; columns estimate, lo, hi, boot_se, method. With fewer than
        MIN_BOOTSTRAP_CLUSTERS clusters a resample repeats one or two of them and its se* is
        near zero (the bootstrap-t quantile explodes; with few clusters the pairs cluster
        bootstrap is unreliable: Cameron, Gelbach & Miller 2008, Rev. Econ. Stat. 90, 414):
        the interval is then q -+ t(G - 1) se(q) from the CR3 covariance, method "t, G-1 df"."""
        if self.status_ == "refused":
            raise ValueError(f"bootstrap: aircraft {self.aircraft_} was refused ({self.reason_})")
        if not 0 < level < 1:
            raise ValueError(f"level: expected a number in (0, 1), got {level!r}")
        if method not in ("studentized", "percentile"):
            raise ValueError(f"method: expected 'studentized' or 'percentile', got {method!r}")
        rng = rng or np.random.default_rng()
        k = self._k
        T = self._T  # fitted parameters -> A..E (an axis fit has 2 parameters for A, B, C)
        L = np.vstack([T[:k], -design(LUT_HEADINGS_DEG, 5) @ T])  # (terms + 8 entries, p)
        XT = self._fit_design()
        starts = cluster_starts(self._g)
        ends = np.r_[starts[1:], len(self._g)]
        G = len(starts)
        names = list(self.terms_) + list(LUT_COLUMNS)
        if G < MIN_BOOTSTRAP_CLUSTERS:  # too few clusters to resample: t(G - 1) on the CR3 se
            q_hat = L @ self._fit.beta
            se_hat = np.sqrt(np.einsum("ij,jk,ik->i", L, self._fit.cov, L))
            half = float(stats.t.ppf(0.5 + level / 2, max(G - 1, 1))) * se_hat
            nan = np.full(len(names), np.nan)
            return pd.DataFrame(
                {"estimate": q_hat, "lo": q_hat - half, "hi": q_hat + half, "boot_se": nan}, index=names
            ).assign(method=f"t, {G - 1} df")
        p = T.shape[1]
        est = np.empty((n_boot, p))
        covs = np.empty((n_boot, p, p))
        beta = self._fit.beta
        for b in range(n_boot):
            pick = rng.integers(0, G, G)
            lens = ends[pick] - starts[pick]
            idx = np.repeat(starts[pick] - np.r_[0, np.cumsum(lens)[:-1]], lens) + np.arange(lens.sum())
            try:
                if method == "percentile":
                    est[b] = huber_t(XT[:, idx], self._y[idx], self._w[idx], self.robust, self.huber_c)[0]
                    continue
                f = robust_fit_t(
                    XT[:, idx],
                    self._y[idx],
                    self._w[idx],
                    np.repeat(np.arange(G), lens),
                    self.robust,
                    self.huber_c,
                    beta0=beta,
                )
                est[b], covs[b] = f.beta, f.cov
            except np.linalg.LinAlgError:  # a resample whose flights cannot identify the terms: left out
                est[b], covs[b] = np.nan, np.nan
        a = (1 - level) / 2
        q_hat = L @ beta
        full = est @ L.T  # (n_boot, quantities)
        ok = np.isfinite(est).all(axis=1)
        if ok.sum() < max(2, 0.9 * n_boot):  # too many degenerate resamples: no interval
            nan = np.full(len(names), np.nan)
            return pd.DataFrame({"estimate": q_hat, "lo": nan, "hi": nan, "boot_se": nan}, index=names).assign(
                method=method
            )
        full = full[ok]
        if method == "percentile":
            lo, hi = np.quantile(full, a, axis=0), np.quantile(full, 1 - a, axis=0)
        else:
            se_hat = np.sqrt(np.einsum("ij,jk,ik->i", L, self._fit.cov, L))
            se_star = np.sqrt(np.einsum("ij,bjk,ik->bi", L, covs[ok], L))
            with np.errstate(divide="ignore", invalid="ignore"):
                t = np.abs(full - q_hat) / se_star
            q = np.quantile(t, level, axis=0)  # symmetric bootstrap-t, per quantity
            lo, hi = q_hat - q * se_hat, q_hat + q * se_hat
        return pd.DataFrame(
            {"estimate": q_hat, "lo": lo, "hi": hi, "boot_se": full.std(axis=0, ddof=1)}, index=names
        ).assign(method=method)

    # -- learned state
    def to_table(self) -> pd.DataFrame:
        """One row with the deviation.csv columns, then extras (heading frame, terms, scale,
        coverage, octants, flights, D/E Wald p, reference sources, consistency)."""
        row = {"aircraft": self.aircraft_, "status": self.status_, "reason": self.reason_, "n_used": self.n_used_}
        row.update({f"{t}_deg": self.coef_[t] for t in TERM_NAMES})
        row.update({f"{t}_se_deg": self.se_[t] for t in TERM_NAMES})
        row.update(dict(zip(LUT_COLUMNS, map(float, self.lut_), strict=False)))
        row.update(
            valid_from=self.valid_from_,
            valid_to=self.valid_to_,
            heading_frame=self.heading_frame_,
            terms="".join(self.terms_),
            n_flights=self.n_flights_,
            n_clusters=getattr(self, "n_clusters_", self.n_flights_),
            data_from=getattr(self, "data_from_", ""),
            data_to=getattr(self, "data_to_", ""),
            residual_scale_deg=self.scale_deg_,
            heading_spread=self.coverage_,
            octants_occupied=self.octants_,
            de_wald_p=self.de_p_,
            ref_sources=" ".join(self.ref_sources_),
            consistency_p=getattr(self, "consistency_p_", math.nan),
            consistency_max_diff_deg=getattr(self, "consistency_max_diff_deg_", math.nan),
        )
        return pd.DataFrame([row])

    def _check_entries_against_coefficients(self) -> None:
        """A table read back holds its eight entries and the coefficients they came from
        (lut = -d(z) at z = 0, 45, ..., 315 deg): each coefficient must be a finite number of
        degrees and each entry its coefficients' value within LUT_AGREEMENT_DEG (a hand-edited
        or rounded file passes). Otherwise (an entry or a coefficient in radians, a damaged
        cell) a ValueError naming the aircraft and the column: which of the two is right
        cannot be told, and `heading apply` would correct by the entries alone."""
        where = f"table: aircraft {self.aircraft_!r} ({self.status_})"
        for t in TERM_NAMES:
            v = self.coef_[t]
            if not (math.isfinite(v) and abs(v) <= _MAX_TABLE_CORRECTION_DEG):
                raise ValueError(
                    f"{where}, column '{t}_deg': {v:g}; expected a finite coefficient of at most "
                    f"{_MAX_TABLE_CORRECTION_DEG:g} deg (0 for a term not fitted)"
                )
        implied = -self.deviation(LUT_HEADINGS_DEG)
        off = np.abs(self.lut_ - implied)
        if not (off <= LUT_AGREEMENT_DEG).all():
            i = int(np.argmax(np.where(np.isfinite(off), off, np.inf)))
            ratio = float(self.lut_ @ implied / (implied @ implied)) if (implied @ implied) > 0 else math.nan
            hint = (
                " (the entries in radians?)"
                if abs(ratio * 180 / math.pi - 1) < 0.05
                else " (the coefficients in radians?)"
                if abs(ratio * math.pi / 180 - 1) < 0.05
                else ""
            )
            raise ValueError(
                f"{where}, column '{LUT_COLUMNS[i]}': {self.lut_[i]:g} deg, but its coefficients A_deg..E_deg give "
                f"{implied[i]:g} deg at {LUT_HEADINGS_DEG[i]:g} deg{hint}; expected the table of its coefficients, "
                f"lut = -(A + B sin z + C cos z + D sin 2z + E cos 2z)"
            )

    @classmethod
    def from_table(cls, table: pd.DataFrame | pd.Series) -> HeadingDeviationFit:
        """Rebuild a fitted estimator (coefficients, se, status, table, dates) from a row of to_table()."""
        row = table.iloc[0] if isinstance(table, pd.DataFrame) else table
        missing = [c for c in TABLE_COLUMNS if c not in row.index]
        if missing:
            raise ValueError(f"table: missing column '{missing[0]}' (expected the deviation.csv columns)")
        if row["status"] not in STATUSES:
            raise ValueError(f"table: column 'status' is {row['status']!r}, expected one of {', '.join(STATUSES)}")

        def num(c: str) -> float:
            try:
                return float(row[c])
            except (TypeError, ValueError):
                raise ValueError(
                    f"table: aircraft {row['aircraft']!r}, column '{c}': expected a number, got {row[c]!r}"
                ) from None

        self = cls(heading=_table_frame(row))
        self.aircraft_ = str(row["aircraft"])
        self.status_, self.reason_ = str(row["status"]), ("" if pd.isna(row["reason"]) else str(row["reason"]))
        n_used = num("n_used")
        self.n_used_ = int(n_used) if np.isfinite(n_used) else 0
        self.coef_ = {t: num(f"{t}_deg") for t in TERM_NAMES}
        self.se_ = {t: num(f"{t}_se_deg") for t in TERM_NAMES}
        self.lut_ = np.array([num(c) for c in LUT_COLUMNS])
        if self.status_ != "refused" and not np.isfinite(self.lut_).all():
            i = int(np.flatnonzero(~np.isfinite(self.lut_))[0])
            got = "empty" if np.isnan(self.lut_[i]) else f"{self.lut_[i]:g}"
            raise ValueError(
                f"table: aircraft {self.aircraft_!r} ({self.status_}), column '{LUT_COLUMNS[i]}': {got}; a table "
                f"that is not refused needs all eight corrections"
            )
        big = np.flatnonzero(np.abs(self.lut_) > _MAX_TABLE_CORRECTION_DEG)
        if len(big):  # no heading error the method takes as a measurement is this large
            c = LUT_COLUMNS[int(big[0])]
            raise ValueError(
                f"table: aircraft {self.aircraft_!r}, column '{c}': {self.lut_[big[0]]:g} deg; a "
                f"correction beyond +-{_MAX_TABLE_CORRECTION_DEG:g} deg exceeds any heading error the "
                f"method accepts (larger ones are gross errors): expected degrees"
            )
        if self.status_ != "refused":
            self._check_entries_against_coefficients()
        self.valid_from_, self.valid_to_ = str(row["valid_from"]), str(row["valid_to"])
        # the fit's first and last report (UTC), when the table says them
        self.data_from_, self.data_to_ = (
            (str(row[c]) if c in row.index and isinstance(row[c], str) else "") for c in ("data_from", "data_to")
        )
        self.heading_frame_ = self.heading
        self.terms_ = tuple(t for t in TERM_NAMES if np.isfinite(self.se_[t]))
        self._k = len(self.terms_)
        return self


HEADING_FRAMES = ("true", "magnetic")


def _table_frame(row: pd.Series) -> str:
    """The heading frame of a deviation-table row, read strictly: the column's `true` or
    `magnetic` as `to_table` writes them (a CSV reader may hand `true` over as the boolean
    True); a table without the column was fitted on true heading. Anything else (another
    word, a space around it, an empty cell) is a ValueError naming the aircraft and the
    column: taken for magnetic it would turn every heading by the declination."""
    if "heading_frame" not in row.index:
        return "true"
    value = row["heading_frame"]
    if isinstance(value, (bool, np.bool_)) and bool(value):
        return "true"
    if isinstance(value, str) and value in HEADING_FRAMES:
        return value
    if isinstance(value, (bool, np.bool_)):
        shown = repr(str(bool(value)).lower())
    elif value is None or value is pd.NA or (isinstance(value, float) and math.isnan(value)):
        shown = "an empty cell"
    else:
        shown = repr(value.item() if isinstance(value, np.generic) else value)
    raise ValueError(
        f"table: aircraft {row.get('aircraft')!r}, column 'heading_frame': {shown}; expected "
        f"{' or '.join(map(repr, HEADING_FRAMES))} (the heading the table is indexed by)"
    )


class FleetHeadingFit:
    """One HeadingDeviationFit per aircraft; exports/imports the deviation.csv table.
    Aircraft with any report whose `heading_input` is "true" get the offset-only fit."""

    def __init__(self, **params):
        self.params = params
        HeadingDeviationFit(**params)._check_params()

    def fit(self, obs: pd.DataFrame, source: str = "observation table") -> FleetHeadingFit:
        """Validate, compute heading errors for the whole table at once, fit each aircraft."""
        rows = obs if "error_deg" in obs.columns else heading_errors(obs, self.params.get("gates"), source)
        self.errors_ = rows
        self.fits_ = {}
        arrays = _used_arrays(rows, self.params.get("heading", "true"))
        ac = pd.Categorical(rows["aircraft"])
        codes = ac.codes
        t, g = rows["time_s"].to_numpy(), arrays["g"]
        dc, dg, dt_ = np.diff(codes), np.diff(g), np.diff(t)
        if np.all(
            (dc > 0) | ((dc == 0) & ((dg > 0) | ((dg == 0) & (dt_ >= 0))))
        ):  # heading_errors output: in order already
            order = np.arange(len(codes))
        else:
            order = np.lexsort((t, g, codes))
        starts = cluster_starts(codes[order])
        ends = np.r_[starts[1:], len(order)]
        true_input = rows["true_heading_input"].to_numpy()
        for s, e in zip(starts, ends, strict=False):
            sel = order[s:e]
            p = dict(self.params)
            p["offset_only"] = bool(p.get("offset_only", False) or true_input[sel].any())
            name = str(ac.categories[codes[sel[0]]])
            self.fits_[name] = HeadingDeviationFit(**p)._fit_arrays(name, arrays, sel)
        return self

    def to_table(self) -> pd.DataFrame:
        """The deviation.csv table: one row per aircraft."""
        return pd.concat([f.to_table() for f in self.fits_.values()], ignore_index=True)

    @classmethod
    def from_table(cls, table: pd.DataFrame) -> FleetHeadingFit:
        """Reload learned state stored with to_table()."""
        self = cls()
        self.fits_ = {str(r["aircraft"]): HeadingDeviationFit.from_table(r) for _, r in table.iterrows()}
        return self

    def correct(self, aircraft, heading_deg) -> np.ndarray:
        """Corrected headings (deg, [0, 360)); `aircraft` one name or an array aligned with
        heading_deg. Aircraft without a fit (or refused) are left uncorrected."""
        h = np.asarray(heading_deg, dtype=float)
        return (h + self.correction(aircraft, h)) % 360.0

    def correction(self, aircraft, heading_deg) -> np.ndarray:
        """The lookup-table corrections to add (deg) at each measured heading; 0 for aircraft
        without a fit (or refused)."""
        h = np.asarray(heading_deg, dtype=float)
        names = list(self.fits_)
        luts = np.vstack([np.nan_to_num(np.asarray(f.lut_, dtype=float)) for f in self.fits_.values()] + [np.zeros(8)])
        idx: np.ndarray
        if np.ndim(aircraft) == 0:
            idx = np.full(h.size, names.index(aircraft) if aircraft in names else -1)
        else:
            cat = pd.Categorical(aircraft)  # cheap when it already is one
            idx = pd.Index(names).get_indexer(cat.categories.astype(str))[cat.codes]
            idx[cat.codes < 0] = -1
        idx = np.where(idx < 0, len(names), idx).reshape(h.shape)  # no fit -> the zero row
        return lut_correction(luts, h, table=idx)
