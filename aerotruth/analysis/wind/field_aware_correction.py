"""Magnetic-latitude-aware heading correction: the wind paper's stated future enhancement
(section 7: "the magnetic deviation curve will vary over magnetic latitude for a constant
hard iron effect").

The deviation of a flux valve (aerotruth.sensors.magnetics) separates by its
field dependence, z' the measured magnetic heading, H and Z the horizontal and vertical
field at the report:

    d = A + (B_h sin z' + C_h cos z') H0/H          permanent (hard) iron, ~ 1/H
          + (B_v sin z' + C_v cos z') (Z/H - Z0/H0)  soft iron induced by Z, ~ Z/H
          + D sin 2z' + E cos 2z'                    horizontal soft iron (not fitted here)

H0, Z0: the fleet's median field over the fit data; there the scale factors are 1 and 0,
so A, B_h, C_h are what the constant table's A, B, C would be at the median field. The
field comes from IGRF at each report
(its quantized lat/lon and pressure altitude taken as height: < 1 nT error at these
heights), so the method needs nothing beyond the observation table.

Identifiability: over one region H0/H and Z/H both grow northwards and are nearly
collinear; the vertical terms are fitted only when the correlation of the two scale
factors over the used reports is below `max_scale_correlation` (0.95), else the
hard-iron form alone (the paper's dominant cause) — `terms_` says which. The fit is the
same Huber M-estimate with flight-clustered (CR3) errors as the constant method
(aerotruth.analysis.wind.robust_fit), weights (TAS / median TAS)^2.

Correction (ground side; an onboard table would need the field model onboard): the
heading of each report is corrected by -d(z', H, Z) at its own field and the wind
recomputed (`corrected_wind_error`).
"""

from __future__ import annotations

import datetime as dt
from typing import NotRequired, TypedDict

import numpy as np
import pandas as pd

from aerotruth.analysis.wind.heading_errors import GateSpec, heading_errors
from aerotruth.analysis.wind.observations import validate_observations
from aerotruth.analysis.wind.robust_fit import robust_fit
from aerotruth.units import FT


class AircraftFieldFit(TypedDict):
    """One aircraft's entry of `FieldAwareDeviationFit.fits_`: refused ("beta" None) or
    fitted (then also the standard errors and the scale factors' correlation)."""

    status: str
    terms: str
    beta: np.ndarray | None
    se: NotRequired[np.ndarray]
    scale_correlation: NotRequired[float]


def report_field(df: pd.DataFrame) -> tuple[np.ndarray, np.ndarray]:
    """Horizontal and vertical (down) IGRF field (nT) at each validated report, one field
    grid per UTC day."""
    from aerotruth.sensors.magnetics import GeomagneticField

    h = np.full(len(df), np.nan)
    z = np.full(len(df), np.nan)
    days = (df["time_s"].to_numpy() // 86400).astype(np.int64)
    lat, lon = df["lat"].to_numpy(float), df["lon"].to_numpy(float)
    alt = np.clip(df["pressure_altitude_ft"].to_numpy(float) * FT, -500.0, 12500.0)
    for day in np.unique(days):
        sel = days == day
        when = dt.datetime(1970, 1, 1) + dt.timedelta(days=int(day))
        f = GeomagneticField.covering(lat[sel], lon[sel], when)
        c = f.at(lat[sel], lon[sel], alt[sel])
        h[sel], z[sel] = c.horizontal_nT, c.down_nT
    return h, z


class FieldAwareDeviationFit:
    """Per aircraft: the field-dependent deviation above, learned from reports."""

    def __init__(
        self,
        heading: str = "magnetic",
        robust: bool = True,
        gates: GateSpec | None = None,
        min_reports: int = 30,
        min_flights: int = 5,
        max_scale_correlation: float = 0.95,
    ):
        if heading not in ("true", "magnetic"):
            raise ValueError(f"heading: expected 'true' or 'magnetic', got {heading!r}")
        self.heading, self.robust, self.gates = heading, robust, gates
        self.min_reports, self.min_flights, self.max_scale_correlation = min_reports, min_flights, max_scale_correlation

    def _prepare(self, obs: pd.DataFrame, source: str | None = None) -> tuple[pd.DataFrame, np.ndarray, np.ndarray]:
        """Validated reports' heading errors (heading_errors rows) and the field at each."""
        df = validate_observations(obs, source or obs.attrs.get("source", "observation table"))
        rows = heading_errors(df, self.gates)
        h, z = report_field(df)
        return rows, h, z

    def _design(self, zdeg: np.ndarray, h: np.ndarray, zf: np.ndarray, terms: str) -> np.ndarray:
        r = np.radians(zdeg)
        s, c = np.sin(r), np.cos(r)
        rh = self.h0_ / h
        cols = [np.ones_like(r), s * rh, c * rh]
        if terms == "hard_and_vertical":
            rz = zf / h - self.z0_ / self.h0_
            cols += [s * rz, c * rz]
        return np.column_stack(cols)

    def fit(self, obs: pd.DataFrame) -> FieldAwareDeviationFit:
        """Learn every aircraft's coefficients (attributes: h0_, z0_, fits_ {aircraft: dict})."""
        rows, h, zf = self._prepare(obs)
        col = "heading_deg" if self.heading == "true" else "heading_mag_deg"
        zdeg = rows[col].to_numpy()
        used = (rows["gate"].cat.codes.to_numpy() == 0) & np.isfinite(zdeg) & np.isfinite(h)
        self.h0_ = float(np.median(h[used])) if used.any() else float("nan")
        self.z0_ = float(np.median(zf[used])) if used.any() else float("nan")
        self.fits_: dict[str, AircraftFieldFit] = {}
        tas = rows["tas_ms"].to_numpy()
        for ac in pd.unique(rows["aircraft"]):
            sel = used & (rows["aircraft"].to_numpy() == ac)
            idx = np.flatnonzero(sel)
            flights = rows["flight"].to_numpy()[idx]
            if idx.size < self.min_reports or len(np.unique(flights)) < self.min_flights:
                self.fits_[str(ac)] = {"status": "refused", "terms": "", "beta": None}
                continue
            order = idx[np.lexsort((rows["time_s"].to_numpy()[idx], flights))]
            rh, rz = self.h0_ / h[order], zf[order] / h[order]
            corr = abs(np.corrcoef(rh, rz)[0, 1]) if np.ptp(rh) > 0 and np.ptp(rz) > 0 else 1.0
            terms = "hard_and_vertical" if corr < self.max_scale_correlation else "hard"
            X = self._design(zdeg[order], h[order], zf[order], terms)
            w = (tas[order] / np.median(tas[order])) ** 2
            f = robust_fit(X, rows["error_deg"].to_numpy()[order], w, rows["flight"].to_numpy()[order], self.robust)
            self.fits_[str(ac)] = {
                "status": "fitted",
                "terms": terms,
                "beta": f.beta,
                "se": np.sqrt(np.diag(f.cov)),
                "scale_correlation": float(corr),
            }
        self.heading_col_ = col
        return self

    def deviation(self, aircraft: np.ndarray, zdeg: np.ndarray, h: np.ndarray, zf: np.ndarray) -> np.ndarray:
        """d (deg) of each report (0 for aircraft without a fit)."""
        out = np.zeros(len(zdeg))
        for ac, f in self.fits_.items():
            sel = (aircraft == ac) & np.isfinite(zdeg) & np.isfinite(h)
            if f["beta"] is None or not sel.any():
                continue
            out[sel] = self._design(zdeg[sel], h[sel], zf[sel], f["terms"]) @ f["beta"]
        return out

    def to_table(self) -> pd.DataFrame:
        """One row per aircraft: status, terms, A, B_h, C_h (B_v, C_v) with standard errors (deg)."""
        names = ("A", "B_h", "C_h", "B_v", "C_v")
        rows = []
        for ac, f in self.fits_.items():
            r = {"aircraft": ac, "status": f["status"], "terms": f["terms"], "H0_nT": self.h0_, "Z0_nT": self.z0_}
            beta = f["beta"]
            for i, n in enumerate(names):
                if beta is not None and i < len(beta):
                    r[f"{n}_deg"] = float(beta[i])
                    r[f"{n}_se_deg"] = float(f["se"][i])
                else:
                    r[f"{n}_deg"] = 0.0 if beta is not None else np.nan
                    r[f"{n}_se_deg"] = np.nan
            r["scale_correlation"] = f.get("scale_correlation", np.nan)
            rows.append(r)
        return pd.DataFrame(rows)


def compare_on(
    fit_obs: pd.DataFrame, test_obs: pd.DataFrame, heading: str = "magnetic", gates: GateSpec | None = None
) -> pd.DataFrame:
    """Constant 8-point tables (the paper's method) against the field-aware correction,
    both fitted on `fit_obs` and applied ground-side to the uncorrected reports of
    `test_obs`: per aircraft and overall, RMS vector difference (kt) uncorrected, with the
    constant table and with the field-aware correction, and the report count."""
    from aerotruth.analysis.wind.heading_correction import FleetHeadingFit
    from aerotruth.analysis.wind.metrics import corrected_wind_error
    from aerotruth.units import KT

    const = FleetHeadingFit(heading=heading, gates=gates).fit(fit_obs)
    aware = FieldAwareDeviationFit(heading=heading, gates=gates).fit(fit_obs)
    rows, h, zf = aware._prepare(test_obs, "test reports")
    zdeg = rows[aware.heading_col_].to_numpy()
    used = (rows["gate"].cat.codes.to_numpy() == 0) & np.isfinite(zdeg) & np.isfinite(h)
    ac = rows["aircraft"].astype(str).to_numpy()
    c_const = const.correction(ac, zdeg)  # the table's correction (0 without a fit)
    c_aware = -aware.deviation(ac, zdeg, h, zf)
    out = []
    for name, sel in [(a, used & (ac == a)) for a in sorted(set(ac[used]))] + [("all", used)]:
        r = {"aircraft": name, "n": int(sel.sum())}
        for label, c in (("uncorrected", np.zeros(len(rows))), ("constant_table", c_const), ("field_aware", c_aware)):
            e, n_ = corrected_wind_error(rows[sel], c[sel])
            r[f"{label}_rms_kt"] = float(np.sqrt(np.mean(e**2 + n_**2)) / KT)
        out.append(r)
    return pd.DataFrame(out)
