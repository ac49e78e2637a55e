"""`aerotruth diagnose` on an observation table (aircraft wind reports with reference-model
winds, docs/data-formats.md): where the reports disagree with the simulation's model of the
wind sensors, which effect explains it, by how much, and what the extension gains on
flights it was not fitted on.

The data (wind paper section 5.1, `heading_correction.heading_errors`): for every gated
report and reference model, the air-vector difference V_A - V_A' = V_W,REF - V_W,TAM
(eqs. 3, 4; the ground track cancels), split at the measured heading z into

    transverse  t = (V_A - V_A') . n,  n = (cos z, -sin z)   (= TAS sin d, d = psi - psi')
    along       a = (V_A - V_A') . u,  u = (sin z,  cos z)   (= |V_A| - |V_A'| to first order)

both in m/s, with the reference-model error as their noise (the same per component).

The model (`WindModel`): each aircraft's heading deviation d(z) = A + s(H) (B sin z + C cos z)
[+ D sin 2z + E cos 2z] (wind paper eq. 2) in the transverse channel, s(H) = (H0/H)^gamma
the hard-iron scaling with the horizontal field (gamma = 0 in the wind paper's model), plus
what the model states as known: a TAS scale (along: k TAS), a receiver declination epoch
(transverse: the table's error), reference-model biases along the wind, recalibration
times (a new offset A after each), the lat/lon quantization of the reports. The
harmonics are fitted for an aircraft only where its headings identify them (the
heading-correction method's coverage criterion); otherwise its offset A alone, said in
`model_fit`.

Effects library (each a departure from that model, its parameters linear given the
rest; `field_scaling` by Gauss-Newton on gamma):

    soft_iron          per aircraft D, E (2z): soft iron induced by the horizontal field
    field_scaling      gamma: hard-iron B, C grow as 1/H (magnetic latitude)
    tas_scale          per aircraft k: along residual = k TAS
    stale_declination  age a (years): transverse = a (-dD/dt)(lat, lon), D the IGRF declination
    reference_bias     per reference model b (kt along its wind): t = b w.n, a = b w.u
    recalibration      per aircraft a step of A at an unknown time (CUSUM of flight means)
    quantization       the reports' lat/lon grid is coarser (or finer) than the model's

Evidence. Reference-model errors are correlated along a flight, so every test is on
flight clusters: a cluster-robust (CR1) Wald test, F(q, G - 1); per-aircraft parameters
are tested aircraft by aircraft and the p-values combined by summing their chi-square
equivalents (Fisher-type). The change-point uses the sup of the CUSUM of flight means
(long-run variance, Bartlett lag 2) against the Kolmogorov distribution, Bonferroni over
aircraft. Family-wise: ALPHA_LIBRARY over the library's candidates of a round and
ALPHA_SCREEN over the screening tests, each Bonferroni-split (nominal 2 % in all).

Gain. Flights alternate between two folds (per aircraft, in time order); parameters are
learned on one fold and the residual RMS (kt) of the effect's channel measured on the
other, both ways; an effect enters only if it lowers that held-out RMS. The round's
entering effect is the significant candidate with the largest relative held-out gain;
rounds repeat until none is left (forward selection).

Screening (effects outside the library, on the final residuals): each channel against
heading harmonics (3z in the transverse channel, z..3z along), roll, flight phase, turn
rate (course change between adjacent reports), pressure altitude, TAS, latitude and time;
a Lomb-Scargle periodogram of the flight-mean residuals; a fleet-wide change-point. A
significant one with a held-out gain is reported by its signature ("transverse residual
~ pressure_altitude_ft, 0.05 deg per 1000 ft") and enters the model as a linear term.
"""

from __future__ import annotations

import datetime as dt
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd
from pydantic import Field, ValidationError
from scipy import stats

from aerotruth.analysis.heading_correction import GateSpec, heading_errors, heading_spread, validate_observations
from aerotruth.config import Section
from aerotruth.errors import ConfigError, DataError
from aerotruth.units import DEG, FT, KT

ALPHA_LIBRARY = 0.01
ALPHA_SCREEN = 0.01
MIN_COVERAGE = 0.1  # smaller eigenvalue of the (sin, cos) covariance: the heading-correction criterion
MIN_FLIGHTS = 4
MAX_ROUNDS = 8
QUANT_STEPS = (1e-4, 2e-4, 2.5e-4, 5e-4, 1e-3, 2e-3, 2.5e-3, 5e-3, 0.01, 0.02, 0.025, 0.05, 0.1, 0.2, 0.25, 0.5, 1.0)
QUANT_SHARE = 0.99  # share of coordinates that must lie on a grid for the data to be quantized on it
DECL_SPAN_YR = 5.0  # secular variation of the declination averaged over the 5 years before the data

CAUSES = {
    "soft_iron": "the heading error goes twice round with the heading (2z): soft iron magnetised by the horizontal field",
    "field_scaling": "the once-round deviation grows where the horizontal field is weak (~1/H): permanent (hard-iron) magnetism",
    "tas_scale": "the true airspeed reads off by a constant factor: air-data calibration (static source, temperature probe)",
    "stale_declination": "the receiver converts magnetic to true heading with an old declination model: the error follows "
                         "the field's secular change across the network",
    "reference_bias": "a reference model's wind is biased along the wind (too strong or too weak): the reference, not the aircraft",
    "recalibration": "an aircraft's heading offset changed at one time: a recalibration, a swung compass or a replaced valve",
    "quantization": "the reports' latitude and longitude are rounded to a coarser grid than the model's: noisier ground tracks",
}


class WindModelSpec(Section):
    """What `aerotruth diagnose` assumes about the wind sensors behind an observation table
    (campaign YAML `diagnose: {wind: ...}`; the extended model it writes sets these)."""

    deviation_terms: int = Field(default=3, description="3: A, B, C (wind paper eq. 2 as the method fits it); 5: + D, E (soft iron)")
    field_scaling: float = Field(default=0.0, ge=-3, le=3, description="gamma of B, C ~ (H0/H)^gamma (hard iron: 1)")
    tas_scale: dict[str, float] = Field(default_factory=dict, description="per aircraft TAS scale factor (0.01 = reads 1 % high)")
    declination_age_yr: float = Field(default=0.0, ge=-50, le=50, description="age of the receivers' declination model")
    reference_bias_kt: dict[str, float] = Field(default_factory=dict, description="per reference model, bias along its wind (kt)")
    recalibrations: dict[str, list[float]] = Field(default_factory=dict, description="per aircraft, UTC epoch seconds after "
                                                   "which its offset A is new")
    lat_lon_step_deg: float = Field(default=0.01, gt=0, description="quantization of reported lat/lon")
    signatures: list[dict[str, Any]] = Field(default_factory=list, description="linear terms found by screening: "
                                             "{channel, covariate, slope} (an effect outside the library)")


def wind_model_from_campaign(campaign) -> WindModelSpec:
    """The campaign's `diagnose.wind` section, else the wind paper's model with the lat/lon
    quantization of the campaign's wind-report sensors (0.01 deg by default)."""
    raw = (getattr(campaign, "diagnose", None) or {}).get("wind") if campaign is not None else None
    if raw is not None:
        try:
            return WindModelSpec.model_validate(raw)
        except ValidationError as e:
            err = e.errors()[0]
            where = ".".join(str(p) for p in err["loc"])
            raise ConfigError(f"diagnose.wind.{where}: {err['msg']}") from None
    step = 0.01
    for name in ("wind_reports", "heading_correction"):
        if campaign is not None and name in campaign.studies:
            sensors = getattr(campaign.studies[name], "sensors", None)
            if sensors is not None and hasattr(sensors, "reports"):
                step = float(sensors.reports.lat_lon_step_deg)
                break
    return WindModelSpec(lat_lon_step_deg=step)


# ----------------------------------------------------------------------------- data


@dataclass
class WindData:
    """The gated (report, reference) rows with everything the model and the effects need."""

    aircraft: np.ndarray  # int codes
    names: list[str]
    source: np.ndarray  # int codes
    sources: list[str]
    flight: np.ndarray  # global flight id
    time_s: np.ndarray
    z: np.ndarray  # measured heading, rad (true)
    tas: np.ndarray  # m/s
    trans: np.ndarray  # m/s
    along: np.ndarray  # m/s
    wref_e: np.ndarray  # unit vector of the reported (aircraft) wind: the direction of a reference bias (0 where calm)
    wref_n: np.ndarray
    lat: np.ndarray
    lon: np.ndarray
    alt_ft: np.ndarray
    h_ratio: np.ndarray  # H0 / H
    sv_deg_yr: np.ndarray  # declination change per year (IGRF, 5 years before the data)
    roll: np.ndarray | None
    phase: np.ndarray | None
    turn_deg_s: np.ndarray
    fold: np.ndarray  # 0/1, alternating flights per aircraft
    report_lat: np.ndarray  # every report (not only gated), for the quantization
    report_lon: np.ndarray
    jitter: dict  # ground-track jitter of the reports (segment velocity differences)

    @property
    def n(self) -> int:
        return len(self.trans)


def _field_covariates(lat, lon, alt_ft, when: dt.datetime) -> tuple[np.ndarray, np.ndarray]:
    from aerotruth.sensors.magnetics import GeomagneticField

    f = GeomagneticField.covering(lat, lon, when, margin_deg=1.0, step_deg=0.5, h_m=(-1000.0, 16000.0))
    h_m = np.clip(np.asarray(alt_ft) * FT, -900.0, 15900.0)
    now = f.at(lat, lon, h_m)
    before = f.for_date(when - dt.timedelta(days=365.25 * DECL_SPAN_YR)).at(lat, lon, h_m)
    H = now.horizontal_nT
    sv = np.degrees(((now.declination_rad - before.declination_rad + np.pi) % (2 * np.pi)) - np.pi) / DECL_SPAN_YR
    return np.median(H) / H, sv


def _jitter(df: pd.DataFrame) -> dict:
    """Differences of adjacent segment velocities (m/s, per component) at every interior
    report of level flight, with c = 1/dt2^2 + (1/dt1 + 1/dt2)^2 + 1/dt1^2 (the factor of
    a position-noise variance) and the report's radii per degree (for the grid's metres)."""
    first = np.flatnonzero(np.r_[True, (df["aircraft"].cat.codes.to_numpy()[1:] != df["aircraft"].cat.codes.to_numpy()[:-1])
                                 | (np.diff(df["time_s"].to_numpy()) != 0)])
    ac = df["aircraft"].cat.codes.to_numpy()[first]
    t = df["time_s"].to_numpy()[first]
    lat, lon = df["lat"].to_numpy()[first], df["lon"].to_numpy()[first]
    alt = df["pressure_altitude_ft"].to_numpy()[first]
    m_lat = 111_132.0 - 559.8 * np.cos(2 * lat * DEG)
    m_lon = 111_320.0 * np.cos(lat * DEG)
    e, n = lon * m_lon, lat * m_lat
    ok = (ac[2:] == ac[:-2]) & (np.diff(t)[:-1] > 0) & (np.diff(t)[1:] > 0) & (np.diff(t)[:-1] <= 600) & (np.diff(t)[1:] <= 600)
    ok &= (np.abs(alt[2:] - alt[:-2]) < 100.0)  # level: the true velocity changes little
    dt1, dt2 = np.diff(t)[:-1], np.diff(t)[1:]
    with np.errstate(divide="ignore", invalid="ignore"):
        v1 = np.column_stack([(e[1:-1] - e[:-2]) / dt1, (n[1:-1] - n[:-2]) / dt1])
        v2 = np.column_stack([(e[2:] - e[1:-1]) / dt2, (n[2:] - n[1:-1]) / dt2])
        c = 1 / dt2**2 + (1 / dt1 + 1 / dt2) ** 2 + 1 / dt1**2
    dv = (v2 - v1)[ok]
    speed = np.hypot(*v1[ok].T)
    ok2 = np.all(np.isfinite(dv), axis=1) & (speed > 30.0) & (np.hypot(*dv.T) < 0.3 * speed)  # turns are not jitter
    return {"dv": dv[ok2], "c": c[ok][ok2], "m_lat": m_lat[1:-1][ok][ok2], "m_lon": m_lon[1:-1][ok][ok2],
            "aircraft": ac[1:-1][ok][ok2]}


def prepare(obs: pd.DataFrame, source: str = "observation table", gates: GateSpec | None = None) -> WindData:
    """Observation table -> WindData (gated rows of the wind paper's section 5.1)."""
    df = validate_observations(obs, source)
    rows = heading_errors(df, gates, source)
    used = (rows["gate"] == "used").to_numpy()
    if used.sum() < 20:
        counts = rows["gate"].value_counts().to_dict()
        raise DataError(f"{source}: only {int(used.sum())} report rows pass the ground-track gates (need 20); "
                        f"gates: {counts}")
    r = rows[used]
    z = r["heading_deg"].to_numpy() * DEG
    dv_e, dv_n = -r["dw_e"].to_numpy(), -r["dw_n"].to_numpy()
    trans = dv_e * np.cos(z) - dv_n * np.sin(z)
    along = dv_e * np.sin(z) + dv_n * np.cos(z)
    from aerotruth.analysis.heading_correction import towards_from_report

    # the direction "along the wind": the aircraft's reported wind, not the reference's (the
    # reference's own error would tilt its direction towards itself: a bias of ~sigma^2/|W|)
    we, wn = towards_from_report(df["wind_speed_kt"].to_numpy()[used], df["wind_dir_deg"].to_numpy()[used])
    sp = np.hypot(we, wn)
    with np.errstate(invalid="ignore", divide="ignore"):
        ue, un = np.where(sp > 0, we / sp, 0.0), np.where(sp > 0, wn / sp, 0.0)
    lat, lon = df["lat"].to_numpy()[used], df["lon"].to_numpy()[used]
    alt = df["pressure_altitude_ft"].to_numpy()[used]
    t = r["time_s"].to_numpy()
    when = dt.datetime(1970, 1, 1) + dt.timedelta(seconds=float(np.median(t)))
    h_ratio, sv = _field_covariates(lat, lon, alt, when)
    ac_cat = r["aircraft"].astype("category")
    names = [str(c) for c in ac_cat.cat.categories]
    ac = ac_cat.cat.codes.to_numpy()
    src_cat = r["ref_source"].astype("category")
    flight = r["flight"].to_numpy()
    # folds: each aircraft's flights alternate in time order
    fold = np.zeros(len(r), dtype=np.int8)
    for i in range(len(names)):
        sel = ac == i
        fl = flight[sel]
        uniq = np.unique(fl)
        fold[sel] = (np.searchsorted(uniq, fl) % 2).astype(np.int8)
    # turn rate: heading change between a flight's adjacent reports
    rep = r["report"].to_numpy()
    zr = pd.Series(z).groupby(rep).first()
    tr = pd.Series(t).groupby(rep).first()
    fr = pd.Series(flight).groupby(rep).first()
    dz = np.r_[np.nan, np.degrees((np.diff(zr.to_numpy()) + np.pi) % (2 * np.pi) - np.pi)]
    dtr = np.r_[np.nan, np.diff(tr.to_numpy())]
    same = np.r_[False, fr.to_numpy()[1:] == fr.to_numpy()[:-1]]
    with np.errstate(invalid="ignore", divide="ignore"):
        turn_rep = np.where(same & (dtr > 0), dz / dtr, 0.0)
    turn = pd.Series(turn_rep, index=zr.index).reindex(rep).to_numpy()
    roll = df["roll_deg"].to_numpy()[used] if "roll_deg" in df.columns else None
    # flight phase from the altitude change between a flight's adjacent reports
    ar = pd.Series(alt).groupby(rep).first().to_numpy()
    da = np.r_[np.nan, np.diff(ar)]
    with np.errstate(invalid="ignore", divide="ignore"):
        rate = np.where(same & (dtr > 0), da / dtr * 60.0, 0.0)
    ph_rep = np.where(rate > 300.0, "ascent", np.where(rate < -300.0, "descent", "level"))
    phase = pd.Series(ph_rep, index=zr.index).reindex(rep).to_numpy()
    first = np.flatnonzero(np.r_[True, (df["aircraft"].cat.codes.to_numpy()[1:] != df["aircraft"].cat.codes.to_numpy()[:-1])
                                 | (np.diff(df["time_s"].to_numpy()) != 0)])
    return WindData(aircraft=ac, names=names, source=src_cat.cat.codes.to_numpy(), sources=[str(c) for c in src_cat.cat.categories],
                    flight=flight, time_s=t, z=z, tas=r["tas_ms"].to_numpy(), trans=trans, along=along, wref_e=ue, wref_n=un,
                    lat=lat, lon=lon, alt_ft=alt, h_ratio=h_ratio, sv_deg_yr=sv, roll=roll, phase=phase, turn_deg_s=turn,
                    fold=fold, report_lat=df["lat"].to_numpy()[first], report_lon=df["lon"].to_numpy()[first],
                    jitter=_jitter(df))


# ----------------------------------------------------------------------------- model


@dataclass
class Block:
    """Columns of one term of the model: `aircraft` -1 for fleet-wide terms."""

    effect: str
    label: str
    cols: np.ndarray  # (2n, q)
    aircraft: int = -1


@dataclass
class State:
    """The current model: the spec's known terms plus the effects entered so far (free)."""

    spec: WindModelSpec
    entered: list[str] = field(default_factory=list)
    gamma: float = 0.0  # field scaling exponent in the design (spec value, then fitted)
    steps: dict[int, list[float]] = field(default_factory=dict)  # aircraft -> step times (free new A after each)
    signatures: list[dict] = field(default_factory=list)  # screening terms entered (free)


def _stack(trans: np.ndarray | None, along: np.ndarray | None, n: int) -> np.ndarray:
    out = np.zeros(2 * n)
    if trans is not None:
        out[:n] = trans
    if along is not None:
        out[n:] = along
    return out


def known_offsets(d: WindData, spec: WindModelSpec) -> np.ndarray:
    """What the spec states as known (subtracted from the data): TAS scales, the declination
    table's age, reference biases along the wind, stated signature terms."""
    n = d.n
    tr, al = np.zeros(n), np.zeros(n)
    for i, name in enumerate(d.names):
        k = spec.tas_scale.get(name, 0.0)
        if k:
            al[d.aircraft == i] += k * d.tas[d.aircraft == i]
    if spec.declination_age_yr:
        tr += d.tas * spec.declination_age_yr * (-d.sv_deg_yr) * DEG
    for m, src in enumerate(d.sources):
        b = spec.reference_bias_kt.get(src, 0.0) * KT
        if b:
            s = d.source == m
            tr[s] += b * (d.wref_e[s] * np.cos(d.z[s]) - d.wref_n[s] * np.sin(d.z[s]))
            al[s] += b * (d.wref_e[s] * np.sin(d.z[s]) + d.wref_n[s] * np.cos(d.z[s]))
    for sig in spec.signatures:
        x = _covariate(d, sig["covariate"]) - float(sig.get("center", 0.0))
        if sig["channel"] == "transverse":
            tr += d.tas * float(sig["slope"]) * x * DEG
        else:
            al += float(sig["slope"]) * KT * x
    return _stack(tr, al, d.n)


def _coverage_ok(z: np.ndarray, harmonic: int) -> bool:
    return len(z) >= 3 and heading_spread(np.degrees(z), np.ones(len(z)), harmonic) >= MIN_COVERAGE


def base_blocks(d: WindData, st: State) -> list[Block]:
    """The deviation model per aircraft (A; B, C where identified; D, E when in the model)."""
    n, out = d.n, []
    s = d.h_ratio ** st.gamma
    for i in range(len(d.names)):
        sel = d.aircraft == i
        one = sel.astype(float) * d.tas
        times = sorted(st.steps.get(i, []))
        edges = [-np.inf, *times, np.inf]
        cols = [_stack(one * ((d.time_s >= lo) & (d.time_s < hi)), None, n) for lo, hi in zip(edges[:-1], edges[1:])]
        out.append(Block("base", "A", np.column_stack(cols), i))
        zi = d.z[sel]
        if _coverage_ok(zi, 1):
            out.append(Block("base", "BC", np.column_stack([_stack(one * s * np.sin(d.z), None, n),
                                                            _stack(one * s * np.cos(d.z), None, n)]), i))
        if (st.spec.deviation_terms == 5 or "soft_iron" in st.entered) and _coverage_ok(zi, 2):
            out.append(Block("soft_iron" if "soft_iron" in st.entered else "base", "DE",
                             np.column_stack([_stack(one * np.sin(2 * d.z), None, n), _stack(one * np.cos(2 * d.z), None, n)]), i))
    return out


def _covariate(d: WindData, name: str) -> np.ndarray:
    if name == "const":
        return np.ones(d.n)
    if name == "pressure_altitude_ft":
        return d.alt_ft / 1000.0
    if name == "tas_kt":
        return d.tas / KT
    if name == "lat":
        return d.lat
    if name == "time_days":
        return (d.time_s - d.time_s.min()) / 86400.0
    if name == "roll_deg":
        return d.roll if d.roll is not None else np.zeros(d.n)
    if name == "turn_deg_s":
        return d.turn_deg_s
    if name.startswith("sin") or name.startswith("cos"):
        k = int(name[3])
        return np.sin(k * d.z) if name.startswith("sin") else np.cos(k * d.z)
    if name.startswith("phase_"):
        return (d.phase == name[6:]).astype(float)
    if name.startswith("period_"):
        p_s, trig = float(name.split("_")[1]), name.split("_")[2]
        arg = 2 * np.pi * d.time_s / p_s
        return np.sin(arg) if trig == "sin" else np.cos(arg)
    if name.startswith("fleet_step_"):
        return (d.time_s >= float(name[11:])).astype(float)
    raise ConfigError(f"diagnose.wind.signatures: unknown covariate {name!r}")


def signature_block(d: WindData, sig: dict) -> Block:
    x = _covariate(d, sig["covariate"]) - float(sig.get("center", 0.0))
    col = _stack(d.tas * x * DEG, None, d.n) if sig["channel"] == "transverse" else _stack(None, x * KT, d.n)
    return Block("signature", f"{sig['channel']}:{sig['covariate']}", col[:, None])


def fixed_effect_blocks(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    """Blocks of the entered library effects other than soft iron (in base_blocks)."""
    out = []
    for eff in st.entered:
        if eff in ("soft_iron", "recalibration", "field_scaling", "quantization"):
            continue
        out.extend(CANDIDATES[eff](d, st, fit))
    out.extend(signature_block(d, s) for s in st.signatures)
    return out


# ----------------------------------------------------------------------------- least squares


@dataclass
class Fit:
    blocks: list[Block]
    beta: np.ndarray
    cov: np.ndarray
    resid: np.ndarray
    slices: list[slice]
    clusters: np.ndarray

    def coef(self, effect: str, aircraft: int | None = None) -> list[tuple[Block, np.ndarray, np.ndarray]]:
        return [(b, self.beta[s], self.cov[s, s]) for b, s in zip(self.blocks, self.slices)
                if b.effect == effect and (aircraft is None or b.aircraft == aircraft)]


def solve(blocks: list[Block], y: np.ndarray, clusters: np.ndarray, rows: np.ndarray | None = None,
          with_cov: bool = True) -> Fit:
    """OLS on the stacked channels (rows: a mask of the 2n rows), CR1 covariance on flights."""
    X = np.column_stack([b.cols for b in blocks])
    slices, k = [], 0
    for b in blocks:
        slices.append(slice(k, k + b.cols.shape[1]))
        k += b.cols.shape[1]
    r = np.ones(len(y), dtype=bool) if rows is None else rows
    Xr, yr = X[r], y[r]
    live = np.any(Xr != 0, axis=0)
    beta = np.zeros(X.shape[1])
    sol, *_ = np.linalg.lstsq(Xr[:, live], yr, rcond=None)
    beta[live] = sol
    resid = y - X @ beta
    cov = np.full((X.shape[1], X.shape[1]), np.nan)
    if with_cov:
        Xl = Xr[:, live]
        bread = np.linalg.pinv(Xl.T @ Xl)
        g = clusters[r]
        uniq, inv = np.unique(g, return_inverse=True)
        scores = np.zeros((len(uniq), Xl.shape[1]))
        np.add.at(scores, inv, Xl * resid[r][:, None])
        G = len(uniq)
        meat = scores.T @ scores * (G / max(G - 1, 1))
        cl = bread @ meat @ bread
        idx = np.flatnonzero(live)
        cov[np.ix_(idx, idx)] = cl
    return Fit(blocks, beta, cov, resid, slices, clusters)


def _wald_p(beta: np.ndarray, cov: np.ndarray, df_den: int) -> float:
    ok = np.isfinite(np.diag(cov)) & (np.diag(cov) > 0)
    if not ok.any() or df_den < 1:
        return 1.0
    b, v = beta[ok], cov[np.ix_(ok, ok)]
    w = float(b @ np.linalg.pinv(v) @ b)
    q = int(ok.sum())
    return float(stats.f.sf(w / q, q, df_den))


def block_p(fit: Fit, effect: str, d: WindData) -> float:
    """p-value of `effect`'s blocks = 0: fleet-wide blocks by one Wald test on all flights,
    per-aircraft blocks aircraft by aircraft (their flights) combined by chi-square sums."""
    parts = fit.coef(effect)
    if not parts:
        return 1.0
    G = len(np.unique(fit.clusters))
    fleet = [(b, be, v) for b, be, v in parts if b.aircraft < 0]
    per = [(b, be, v) for b, be, v in parts if b.aircraft >= 0]
    ps = []
    if fleet:
        be = np.concatenate([x[1] for x in fleet])
        sl = [s for b, s in zip(fit.blocks, fit.slices) if b.effect == effect and b.aircraft < 0]
        idx = np.concatenate([np.arange(s.start, s.stop) for s in sl])
        ps.append(_wald_p(be, fit.cov[np.ix_(idx, idx)], G - 1))
    if per:
        chi, dof = 0.0, 0
        for b, be, v in per:
            g_i = len(np.unique(d.flight[d.aircraft == b.aircraft]))
            p = _wald_p(be, v, g_i - 1)
            q = be.size
            chi += float(stats.chi2.isf(max(p, 1e-300), q))
            dof += q
        ps.append(float(stats.chi2.sf(chi, dof)))
    return float(min(1.0, min(ps) * len(ps)))


def rows_of_fold(d: WindData, fold: int) -> np.ndarray:
    f = d.fold == fold
    return np.r_[f, f]


def _channel_rows(n: int, channel: str) -> np.ndarray:
    m = np.zeros(2 * n, dtype=bool)
    if channel in ("transverse", "both"):
        m[:n] = True
    if channel in ("along", "both"):
        m[n:] = True
    return m


# ----------------------------------------------------------------------------- effects library


def _enough(d: WindData, i: int) -> bool:
    return len(np.unique(d.flight[d.aircraft == i])) >= MIN_FLIGHTS


def cand_soft_iron(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    if st.spec.deviation_terms == 5:
        return []
    n, out = d.n, []
    for i in range(len(d.names)):
        sel = d.aircraft == i
        if _enough(d, i) and _coverage_ok(d.z[sel], 2):
            one = sel * d.tas
            out.append(Block("soft_iron", "DE", np.column_stack([_stack(one * np.sin(2 * d.z), None, n),
                                                                 _stack(one * np.cos(2 * d.z), None, n)]), i))
    return out


def cand_field_scaling(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    """d/dgamma of s(H)(B sin z + C cos z) = ln(H0/H) x that term, with the current B, C."""
    if fit is None:
        return []
    col = np.zeros(d.n)
    for b, be, _ in fit.coef("base"):
        if b.label == "BC":
            col += (b.cols[: d.n] @ be) * np.log(d.h_ratio)
    if not np.any(col):
        return []
    return [Block("field_scaling", "gamma", _stack(col, None, d.n)[:, None])]


def cand_tas_scale(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    return [Block("tas_scale", "k", _stack(None, (d.aircraft == i) * d.tas, d.n)[:, None], i)
            for i in range(len(d.names)) if _enough(d, i)]


def declination_identifiable(d: WindData) -> float:
    """Share of the declination-age regressor's variance left after per-aircraft offsets."""
    x = d.tas * (-d.sv_deg_yr)
    means = pd.Series(x).groupby(d.aircraft).transform("mean").to_numpy()
    tot = float(np.sum((x - x.mean()) ** 2))
    return float(np.sum((x - means) ** 2) / tot) if tot > 0 else 0.0


def cand_stale_declination(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    if declination_identifiable(d) < 0.01:
        return []
    return [Block("stale_declination", "age", _stack(d.tas * (-d.sv_deg_yr) * DEG, None, d.n)[:, None])]


def cand_reference_bias(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    out = []
    for m, src in enumerate(d.sources):
        s = d.source == m
        tr = s * (d.wref_e * np.cos(d.z) - d.wref_n * np.sin(d.z))
        al = s * (d.wref_e * np.sin(d.z) + d.wref_n * np.cos(d.z))
        out.append(Block("reference_bias", src, (_stack(tr, al, d.n) * KT)[:, None]))
    return out


def _kolmogorov_cusum(x: np.ndarray) -> tuple[float, int]:
    """p-value of the sup |CUSUM| of a series (Brownian-bridge limit, long-run variance with
    Bartlett weights to lag 2) and the index after which the mean changes."""
    n = len(x)
    if n < 6:
        return 1.0, 0
    e = x - x.mean()
    s = np.cumsum(e)[:-1]
    k = int(np.argmax(np.abs(s)))
    # the long-run variance from the residuals about the two segments' means (about the
    # overall mean, a real step would inflate it and hide itself)
    r = np.r_[x[: k + 1] - x[: k + 1].mean(), x[k + 1:] - x[k + 1:].mean()]
    lrv = np.mean(r**2) + 2 * sum((1 - j / 3) * np.mean(r[j:] * r[:-j]) for j in (1, 2))
    if lrv <= 0:
        return 1.0, 0
    stat = abs(s[k]) / math.sqrt(n * lrv)
    return float(stats.kstwobign.sf(stat)), k


def _flight_means(d: WindData, resid_trans: np.ndarray, sel: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Flight-mean transverse residual (as a heading angle, rad), start and end time of each flight in `sel`."""
    g = pd.DataFrame({"f": d.flight[sel], "r": resid_trans[sel] / d.tas[sel], "t": d.time_s[sel]}).groupby("f")
    agg = g.agg(r=("r", "mean"), t0=("t", "min"), t1=("t", "max")).sort_values("t0")
    return agg["r"].to_numpy(), agg["t0"].to_numpy(), agg["t1"].to_numpy()


def recalibration_scan(d: WindData, fit: Fit, rows: np.ndarray | None = None) -> dict[int, tuple[float, float]]:
    """Per aircraft: (p-value, time of the change) of a change in its flight-mean offset."""
    out = {}
    r = np.ones(d.n, dtype=bool) if rows is None else rows[: d.n]
    for i in range(len(d.names)):
        sel = (d.aircraft == i) & r
        if len(np.unique(d.flight[sel])) < 2 * MIN_FLIGHTS:
            continue
        m, t0, t1 = _flight_means(d, fit.resid[: d.n], sel)
        p, k = _kolmogorov_cusum(m)
        out[i] = (p, 0.5 * (t1[k] + t0[k + 1]))
    return out


def cand_recalibration(d: WindData, st: State, fit: Fit | None, rows: np.ndarray | None = None) -> list[Block]:
    if fit is None:
        return []
    scan = recalibration_scan(d, fit, rows)
    n_ac = max(len(scan), 1)
    out = []
    for i, (p, t) in scan.items():
        if p * n_ac < 0.05:
            col = (d.aircraft == i) * d.tas * (d.time_s >= t)
            b = Block("recalibration", f"step@{t:.0f}", _stack(col, None, d.n)[:, None], i)
            b.p = p * n_ac  # type: ignore[attr-defined]
            out.append(b)
    return out


CANDIDATES = {
    "soft_iron": cand_soft_iron,
    "field_scaling": cand_field_scaling,
    "tas_scale": cand_tas_scale,
    "stale_declination": cand_stale_declination,
    "reference_bias": cand_reference_bias,
    "recalibration": cand_recalibration,
}
CHANNEL = {"soft_iron": "transverse", "field_scaling": "transverse", "tas_scale": "along", "stale_declination": "transverse",
           "reference_bias": "both", "recalibration": "transverse"}


# ----------------------------------------------------------------------------- quantization


def grid_step(values: np.ndarray) -> float:
    """The coarsest grid in QUANT_STEPS holding >= QUANT_SHARE of the values (0: none)."""
    v = np.asarray(values, dtype=float)
    v = v[np.isfinite(v)]
    best = 0.0
    for q in QUANT_STEPS:
        x = v / q
        if np.mean(np.abs(x - np.round(x)) < 1e-6 * np.maximum(1.0, np.abs(x)) + 1e-7) >= QUANT_SHARE:
            best = q
    return best


def _jitter_rms_kt(j: dict, step: float, sel: np.ndarray) -> tuple[float, float]:
    """(measured, predicted) RMS per component of the segment-velocity differences (kt),
    predicted from position errors uniform on the grid: var = (step m)^2 / 12 c."""
    dv, c = j["dv"][sel], j["c"][sel]
    meas = math.sqrt(np.mean(dv**2)) / KT
    var_q = ((step * j["m_lat"][sel]) ** 2 + (step * j["m_lon"][sel]) ** 2) / 2 / 12.0
    pred = math.sqrt(np.mean(var_q * c)) / KT
    return meas, pred


def quantization_candidate(d: WindData, model_step: float) -> dict | None:
    coords = np.concatenate([d.report_lat, d.report_lon])
    step = grid_step(coords)
    if step == 0.0 or math.isclose(step, model_step, rel_tol=1e-9) or len(d.jitter["dv"]) < 10:
        return None
    coarse, fine = max(step, model_step), min(step, model_step)
    share_model = float(np.mean(np.abs(coords / model_step - np.round(coords / model_step)) < 1e-6))
    if step > model_step:  # all on the coarser grid, where the model puts only fine/coarse of them
        on = np.abs(coords / coarse - np.round(coords / coarse)) < 1e-6
        log10_p = float(stats.binom.logsf(int(on.sum()) - 1, len(coords), fine / coarse) / math.log(10))
    else:  # the data hold values off the model's grid
        log10_p = -math.inf if share_model < QUANT_SHARE else 0.0
    # held out by aircraft halves: the grid learned on one half, the jitter predicted on the other
    ac = d.jitter["aircraft"]
    half = (ac % 2).astype(bool)
    before = after = meas_all = 0.0
    for h in (False, True):
        sel = half == h
        if sel.sum() < 5:
            continue
        meas, pred0 = _jitter_rms_kt(d.jitter, model_step, sel)
        _, pred1 = _jitter_rms_kt(d.jitter, step, sel)
        before += abs(pred0 - meas)
        after += abs(pred1 - meas)
        meas_all += meas
    meas, pred0 = _jitter_rms_kt(d.jitter, model_step, np.ones(len(ac), dtype=bool))
    _, pred1 = _jitter_rms_kt(d.jitter, step, np.ones(len(ac), dtype=bool))
    return {"step": step, "log10_p": log10_p, "share_on_model_grid": share_model,
            "gain": {"metric": "ground-track jitter: |predicted - measured| RMS of segment-velocity differences (kt)",
                     "measured_kt": meas, "predicted_before_kt": pred0, "predicted_after_kt": pred1,
                     "before": abs(pred0 - meas), "after": abs(pred1 - meas), "held_out_before": before / 2,
                     "held_out_after": after / 2},
            "relative_gain": (before - after) / max(meas_all, 1e-9)}


# ----------------------------------------------------------------------------- the loop


def current_blocks(d: WindData, st: State) -> list[Block]:
    return base_blocks(d, st) + fixed_effect_blocks(d, st, None)


def _build(eff: str, d: WindData, st: State, fit: Fit, rows: np.ndarray | None) -> list[Block]:
    if eff == "recalibration":
        return cand_recalibration(d, st, fit, rows)
    return CANDIDATES[eff](d, st, fit)


def _fit_with(d: WindData, st: State, y, clusters, eff: str, blocks: list[Block], rows=None, with_cov=True) -> tuple[Fit, float]:
    """The current model plus `blocks`; for field_scaling, Gauss-Newton on gamma (returns
    the total change of gamma; 0 otherwise)."""
    cur = current_blocks(d, st)
    fit = solve(cur + blocks, y, clusters, rows, with_cov)
    if eff != "field_scaling":
        return fit, 0.0
    first = fit
    total = float(fit.coef("field_scaling")[0][1][0])
    for _ in range(3):
        st2 = State(st.spec, list(st.entered), st.gamma + total, st.steps, st.signatures)
        f0 = solve(current_blocks(d, st2), y, clusters, rows, False)
        b2 = cand_field_scaling(d, st2, f0)
        if not b2:
            break
        f2 = solve(current_blocks(d, st2) + b2, y, clusters, rows, False)
        step = float(f2.coef("field_scaling")[0][1][0])
        total += step
        fit = f2
        if abs(step) < 1e-3:
            break
    # the test of gamma = the model's is the first linearisation's (coefficient and its
    # covariance); the estimate and the residuals are the converged Gauss-Newton's
    beta = first.beta.copy()
    k = next(s for b, s in zip(first.blocks, first.slices) if b.effect == "field_scaling")
    beta[k] = total
    return Fit(first.blocks, beta, first.cov, fit.resid, first.slices, first.clusters), total


def held_out(d: WindData, st: State, y, clusters, eff: str, build=None) -> tuple[float, float]:
    """RMS (kt) of the effect's channel on held-out flights, without and with the effect
    (parameters learned on the other fold; both ways)."""
    ch = _channel_rows(d.n, CHANNEL.get(eff, "transverse") if build is None else build[1])
    ss0 = ss1 = 0.0
    cnt = 0
    for k in (0, 1):
        train, test = rows_of_fold(d, 1 - k), rows_of_fold(d, k)
        f0 = solve(current_blocks(d, st), y, clusters, train, False)
        blocks = _build(eff, d, st, f0, train) if build is None else build[0]
        if not blocks:
            return math.nan, math.nan
        f1, _ = _fit_with(d, st, y, clusters, eff, blocks, train, False)
        t = test & ch
        ss0 += float(np.sum(f0.resid[t] ** 2))
        ss1 += float(np.sum(f1.resid[t] ** 2))
        cnt += int(t.sum())
    return math.sqrt(ss0 / cnt) / KT, math.sqrt(ss1 / cnt) / KT


def _rms_kt(resid: np.ndarray, n: int, channel: str) -> float:
    return float(math.sqrt(np.mean(resid[_channel_rows(n, channel)] ** 2)) / KT)


def _se(v: np.ndarray) -> np.ndarray:
    return np.sqrt(np.clip(np.diag(np.atleast_2d(v)), 0, None))


def _iso(t: float) -> str:
    return (dt.datetime(1970, 1, 1) + dt.timedelta(seconds=float(t))).isoformat(timespec="minutes") + "Z"


def _parameters(eff: str, d: WindData, fit: Fit, dgamma: float, st: State) -> dict:
    parts = fit.coef(eff)
    r2d = 1 / DEG
    if eff == "soft_iron":
        per = {d.names[b.aircraft]: {"D_deg": float(be[0] * r2d), "E_deg": float(be[1] * r2d),
                                     "D_se_deg": float(_se(v)[0] * r2d), "E_se_deg": float(_se(v)[1] * r2d)} for b, be, v in parts}
        a2 = np.mean([x["D_deg"] ** 2 + x["E_deg"] ** 2 for x in per.values()])
        s2 = np.mean([x["D_se_deg"] ** 2 + x["E_se_deg"] ** 2 for x in per.values()])
        amp = math.sqrt(max(a2 - s2, 0.0))
        return {"amplitude_deg": {"value": amp, "se": math.sqrt(s2 / max(len(per), 1)),
                                  "meaning": "RMS over aircraft of the 2z amplitude sqrt(D^2 + E^2), noise-debiased"},
                "aircraft": per}
    if eff == "field_scaling":
        se = float(_se(parts[0][2])[0])
        return {"gamma": {"value": st.gamma + dgamma, "se": se, "model": st.gamma,
                          "meaning": "B, C ~ (H0/H)^gamma, H0 the median horizontal field of the reports"},
                "H_ratio_range": [float(1 / d.h_ratio.max()), float(1 / d.h_ratio.min())]}
    if eff == "tas_scale":
        per = {d.names[b.aircraft]: {"k": float(be[0]), "se": float(_se(v)[0])} for b, be, v in parts}
        ks = np.array([x["k"] for x in per.values()])
        ses = np.array([x["se"] for x in per.values()])
        return {"k_median": {"value": float(np.median(ks)), "se": float(1.2533 * np.sqrt(np.mean(ses**2) / len(ks))),
                             "meaning": "TAS reads (1 + k) x true"}, "aircraft": per}
    if eff == "stale_declination":
        be, v = parts[0][1], parts[0][2]
        return {"age_yr": {"value": float(be[0]) + st.spec.declination_age_yr, "se": float(_se(v)[0]),
                           "meaning": "the receivers' declination model is this many years older than the data"},
                "identifiable_share": declination_identifiable(d)}
    if eff == "reference_bias":
        return {"bias_kt": {b.label: {"value": float(be[0]), "se": float(_se(v)[0])} for b, be, v in parts},
                "meaning": "reference wind = truth + b along the wind"}
    if eff == "recalibration":
        return {"steps": {d.names[b.aircraft]: {"time_utc": _iso(float(b.label.split("@")[1])), "time_s": float(b.label.split("@")[1]),
                                                "step_deg": float(be[0] * r2d), "se_deg": float(_se(v)[0] * r2d)}
                          for b, be, v in parts}}
    raise KeyError(eff)


def _size(eff: str, params: dict) -> float:
    """One number for the effect's size (what the tests compare)."""
    return {"soft_iron": lambda p: p["amplitude_deg"]["value"], "field_scaling": lambda p: p["gamma"]["value"],
            "tas_scale": lambda p: p["k_median"]["value"], "stale_declination": lambda p: p["age_yr"]["value"],
            "reference_bias": lambda p: max((x["value"] for x in p["bias_kt"].values()), key=abs),
            "recalibration": lambda p: max((x["step_deg"] for x in p["steps"].values()), key=abs),
            "quantization": lambda p: p["lat_lon_step_deg"]["value"]}[eff](params)


def _plot_data(d: WindData, fit0: Fit, fit1: Fit, eff: str, channel: str) -> dict:
    """Added-variable view: the residual without the effect and with it, against the
    effect's fitted term (deg transverse, kt along)."""
    term = np.zeros(2 * d.n)
    for b, s in zip(fit1.blocks, fit1.slices):
        if b.effect in (eff, "screen"):
            term += b.cols @ fit1.beta[s]
    m = _channel_rows(d.n, "transverse" if channel == "both" else channel)
    scale = np.r_[d.tas, np.full(d.n, KT)][m]
    unit = "deg" if channel != "along" else "kt"
    conv = (1 / DEG) if unit == "deg" else 1.0
    return {"x": term[m] / scale * conv, "before": fit0.resid[m] / scale * conv + 0.0,
            "after": fit1.resid[m] / scale * conv, "unit": unit, "channel": "transverse" if channel == "both" else channel}


def diagnose_wind(d: WindData, spec: WindModelSpec) -> tuple[list, dict, State, dict]:
    """Forward selection over the library, then screening. Returns (findings, baseline, the
    final state, plot data per finding)."""
    from aerotruth.analysis.diagnose import Finding

    y = _stack(d.trans, d.along, d.n) - known_offsets(d, spec)
    clusters = np.r_[d.flight, d.flight]
    steps = {d.names.index(a): list(ts) for a, ts in spec.recalibrations.items() if a in d.names}
    st = State(spec, [], spec.field_scaling, steps, [])
    fit_start = solve(current_blocks(d, st), y, clusters)
    findings, plots, rejected, rounds = [], {}, [], []
    n_lib = len(CANDIDATES) + 1
    for _ in range(MAX_ROUNDS):
        fit0 = solve(current_blocks(d, st), y, clusters)
        cands = []
        for eff in CANDIDATES:
            if eff in st.entered:
                continue
            blocks = _build(eff, d, st, fit0, None)
            if not blocks:
                continue
            fit1, dg = _fit_with(d, st, y, clusters, eff, blocks)
            p = min(b.p for b in blocks) if eff == "recalibration" else block_p(fit1, eff, d)
            b_ho, a_ho = held_out(d, st, y, clusters, eff)
            cands.append({"effect": eff, "p": p, "held_out": (b_ho, a_ho), "fit": fit1, "dgamma": dg,
                          "rel": (b_ho - a_ho) / b_ho if b_ho > 0 else 0.0})
        q = None if "quantization" in st.entered else quantization_candidate(d, spec.lat_lon_step_deg)
        if q is not None:
            cands.append({"effect": "quantization", "p": 10 ** max(q["log10_p"], -300), "log10_p": q["log10_p"], "q": q,
                          "held_out": (q["gain"]["held_out_before"], q["gain"]["held_out_after"]), "rel": q["relative_gain"]})
        level = ALPHA_LIBRARY / n_lib
        ok = [c for c in cands if c["p"] < level and c["held_out"][1] < c["held_out"][0]]
        rounds.append({c["effect"]: {"p": c["p"], "held_out_before_kt": c["held_out"][0], "held_out_after_kt": c["held_out"][1]}
                       for c in cands})
        if not ok:
            break
        best = max(ok, key=lambda c: c["rel"])
        eff = best["effect"]
        if eff == "quantization":
            qq = best["q"]
            params = {"lat_lon_step_deg": {"value": qq["step"], "se": 0.0, "model": spec.lat_lon_step_deg,
                                           "meaning": "grid of the reported lat/lon"},
                      "share_on_model_grid": qq["share_on_model_grid"]}
            evidence = {"test": "binomial: coordinates on the coarser grid vs the share the model's grid puts there",
                        "log10_p": qq["log10_p"], "alpha": level}
            gain = qq["gain"]
        else:
            fit1 = best["fit"]
            params = _parameters(eff, d, fit1, best["dgamma"], st)
            ch = CHANNEL[eff]
            evidence = {"test": ("sup-CUSUM of flight means, Kolmogorov, Bonferroni over aircraft" if eff == "recalibration"
                                 else "cluster-robust Wald on flights"), "p_value": best["p"], "alpha": level,
                        "flights": int(len(np.unique(d.flight))), "rows": int(d.n)}
            if eff == "stale_declination":
                evidence["aliased_with_A"] = f"{100 * (1 - declination_identifiable(d)):.0f} % of the regressor is a per-aircraft constant"
            gain = {"metric": f"RMS of the {ch} wind residual (kt)" if ch != "both" else "RMS of the wind residual vector components (kt)",
                    "before": _rms_kt(fit0.resid, d.n, ch), "after": _rms_kt(fit1.resid, d.n, ch),
                    "held_out_before": best["held_out"][0], "held_out_after": best["held_out"][1],
                    "held_out": "flights alternate between two folds per aircraft; learned on one, measured on the other"}
            plots[eff] = _plot_data(d, fit0, fit1, eff, ch)
        params["size"] = _size(eff, params)
        findings.append(Finding(eff, CAUSES[eff], params, evidence, gain))
        st.entered.append(eff)
        if eff == "field_scaling":
            st.gamma = params["gamma"]["value"]
        if eff == "recalibration":
            for a, s in params["steps"].items():
                st.steps.setdefault(d.names.index(a), []).append(s["time_s"])
    findings.extend(screen(d, st, y, clusters, plots))
    fit_end = solve(current_blocks(d, st), y, clusters)
    baseline = {"rounds": rounds, "model_fit": model_fit(d, st, fit_end),
                "residual_rms_kt": {"transverse_before": _rms_kt(fit_start.resid, d.n, "transverse"),
                                    "transverse_after": _rms_kt(fit_end.resid, d.n, "transverse"),
                                    "along_before": _rms_kt(fit_start.resid, d.n, "along"),
                                    "along_after": _rms_kt(fit_end.resid, d.n, "along")},
                "alpha": {"library": ALPHA_LIBRARY, "screening": ALPHA_SCREEN, "family_wise": ALPHA_LIBRARY + ALPHA_SCREEN},
                "not_identifiable": ([] if declination_identifiable(d) >= 0.01 else
                                     ["stale_declination: aliased with the per-aircraft offset A (the declination change across "
                                      f"this network is {100 * declination_identifiable(d):.1f} % outside per-aircraft constants)"]),
                "reports": int(len(np.unique(np.c_[d.aircraft, d.time_s], axis=0))), "rows": int(d.n),
                "aircraft": len(d.names), "flights": int(len(np.unique(d.flight)))}
    return findings, baseline, st, plots


def model_fit(d: WindData, st: State, fit: Fit) -> dict:
    """The current model's per-aircraft deviation: status, reason, A (B, C, D, E) +- se (deg)."""
    out = {}
    r2d = 1 / DEG
    for i, name in enumerate(d.names):
        sel = d.aircraft == i
        row: dict[str, Any] = {"n_rows": int(sel.sum()), "flights": int(len(np.unique(d.flight[sel])))}
        for b, be, v in fit.coef("base", i) + fit.coef("soft_iron", i):
            se = _se(v)
            if b.label == "A":
                row["A_deg"] = float(be[-1] * r2d)
                row["A_se_deg"] = float(se[-1] * r2d)
            else:
                for j, t in enumerate(b.label):
                    row[f"{t}_deg"], row[f"{t}_se_deg"] = float(be[j] * r2d), float(se[j] * r2d)
        spread = heading_spread(np.degrees(d.z[sel]), np.ones(sel.sum())) if sel.sum() >= 3 else 0.0
        if "B_deg" in row:
            row["status"], row["reason"] = "fitted", ""
        else:
            row["status"] = "offset_only"
            row["reason"] = (f"heading coverage cannot identify the sinusoid (spread {spread:.2f} < {MIN_COVERAGE}): "
                             "offset A only; one heading cannot tell an offset from a sinusoid")
        out[name] = row
    return out


# ----------------------------------------------------------------------------- screening

UNITS = {"pressure_altitude_ft": "1000 ft", "tas_kt": "kt", "lat": "deg latitude", "time_days": "day", "roll_deg": "deg roll",
         "turn_deg_s": "deg/s of turn", "const": "(constant)"}


def _screen_tests(d: WindData) -> list[tuple[str, list[str]]]:
    common = ["pressure_altitude_ft", "lat", "time_days", "turn_deg_s"] + (["roll_deg"] if d.roll is not None else [])
    tests = [("transverse", ["sin3", "cos3"]), ("transverse", ["phase_ascent", "phase_descent"]), ("transverse", ["tas_kt"])]
    tests += [("transverse", [c]) for c in common]
    tests += [("along", ["const"]), ("along", ["sin1", "cos1"]), ("along", ["sin2", "cos2"]), ("along", ["sin3", "cos3"]),
              ("along", ["phase_ascent", "phase_descent"])]
    tests += [("along", [c]) for c in common]
    return tests


def _screen_blocks(d: WindData, channel: str, covs: list[str]) -> tuple[list[Block], list[dict]]:
    cols, sigs = [], []
    for c in covs:
        x = _covariate(d, c)
        center = 0.0 if c == "const" else float(np.mean(x))
        sigs.append({"channel": channel, "covariate": c, "center": center})
        cols.append(_stack(d.tas * (x - center) * DEG, None, d.n) if channel == "transverse" else _stack(None, (x - center) * KT, d.n))
    return [Block("screen", f"{channel}:{'+'.join(covs)}", np.column_stack(cols))], sigs


def _periodic(d: WindData, fit: Fit) -> tuple[float, float] | None:
    """(p-value, period s) of the strongest period in the flight-mean transverse residual
    (least-squares periodogram, periods 2 h .. span/2; p = M exp(-z), M independent frequencies)."""
    m, t0, t1 = _flight_means(d, fit.resid[: d.n], np.ones(d.n, dtype=bool))
    t = 0.5 * (t0 + t1)
    span = t.max() - t.min()
    if len(m) < 20 or span < 4 * 7200.0:
        return None
    M = int(span / 7200.0)
    freqs = np.linspace(2.0 / span, 1 / 7200.0, 4 * M)
    e = m - m.mean()
    var = float(np.var(e))
    best = (0.0, 0.0)
    for f in freqs:
        X = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)])
        b, *_ = np.linalg.lstsq(X, e, rcond=None)
        z = (np.sum(e**2) - np.sum((e - X @ b) ** 2)) / (2 * var)
        if z > best[0]:
            best = (float(z), 1 / f)
    return min(1.0, M * math.exp(-best[0])), best[1]


def _signature_text(sig: list[dict], beta: np.ndarray) -> str:
    ch = sig[0]["channel"]
    unit = "deg" if ch == "transverse" else "kt"
    covs = [s["covariate"] for s in sig]
    if covs[0] in ("sin1", "sin2", "sin3"):
        k = covs[0][3]
        return f"{ch} residual varies as {k}z with the heading, amplitude {math.hypot(*beta[:2]):.2f} {unit}"
    if covs[0].startswith("phase_"):
        return f"{ch} residual depends on the flight phase: ascent {beta[0]:+.2f} {unit}, descent {beta[1]:+.2f} {unit} vs level"
    if covs[0].startswith("period_"):
        return f"{ch} residual is periodic, period {float(covs[0].split('_')[1]) / 3600:.1f} h, amplitude {math.hypot(*beta[:2]):.2f} {unit}"
    if covs[0].startswith("fleet_step_"):
        return f"{ch} residual of the whole fleet steps by {beta[0]:+.2f} {unit} at {_iso(float(covs[0][11:]))}"
    if covs[0] == "const":
        return f"{ch} residual has a constant offset {beta[0]:+.2f} {unit} (an airspeed or reference bias not in the library)"
    return f"{ch} residual ~ {covs[0]}, {beta[0]:+.3g} {unit} per {UNITS.get(covs[0], covs[0])}"


def screen(d: WindData, st: State, y, clusters, plots: dict) -> list:
    """Effects outside the library, by their signature (module docstring)."""
    from aerotruth.analysis.diagnose import Finding

    out = []
    done: set[str] = set()
    for _ in range(3):
        fit0 = solve(current_blocks(d, st), y, clusters)
        tests = [(ch, covs) for ch, covs in _screen_tests(d) if f"{ch}:{'+'.join(covs)}" not in done]
        per = _periodic(d, fit0)
        m_tests = len(_screen_tests(d)) + 2
        level = ALPHA_SCREEN / m_tests
        cands = []
        extra = []
        if per is not None and per[0] < level and "periodic" not in done:
            extra.append(("transverse", [f"period_{per[1]:.0f}_sin", f"period_{per[1]:.0f}_cos"], per[0], "periodic"))
        fm, t0, t1 = _flight_means(d, fit0.resid[: d.n], np.ones(d.n, dtype=bool))
        p_cp, k = _kolmogorov_cusum(fm)
        if p_cp < level and len(fm) > 1 and "fleet_step" not in done:
            extra.append(("transverse", [f"fleet_step_{0.5 * (t1[k] + t0[k + 1]):.0f}"], p_cp, "fleet_step"))
        for ch, covs in tests:
            blocks, sigs = _screen_blocks(d, ch, covs)
            fit1 = solve(current_blocks(d, st) + blocks, y, clusters)
            p = block_p(fit1, "screen", d)
            cands.append((ch, covs, p, blocks, sigs, fit1, f"{ch}:{'+'.join(covs)}"))
        for ch, covs, p, key in extra:
            blocks, sigs = _screen_blocks(d, ch, covs)
            fit1 = solve(current_blocks(d, st) + blocks, y, clusters)
            cands.append((ch, covs, p, blocks, sigs, fit1, key))
        ok = []
        for c in cands:
            if c[2] < level:
                b_ho, a_ho = held_out(d, st, y, clusters, "screen", (c[3], c[0]))
                if a_ho < b_ho:
                    ok.append((c, b_ho, a_ho))
        if not ok:
            break
        (ch, covs, p, blocks, sigs, fit1, key), b_ho, a_ho = max(ok, key=lambda x: (x[1] - x[2]) / x[1])
        beta = fit1.coef("screen")[0][1]
        cov = fit1.coef("screen")[0][2]
        unit_scale = 1.0  # transverse coefficients are deg per unit, along kt per unit (the columns' scaling)
        for s, b in zip(sigs, beta):
            s["slope"] = float(b * unit_scale)
        text = _signature_text(sigs, beta)
        params = {"signature": text, "terms": [dict(s, se=float(e)) for s, e in zip(sigs, _se(cov))]}
        params["size"] = float(beta[0]) if len(beta) == 1 else float(math.hypot(*beta[:2]))
        evidence = {"test": "cluster-robust Wald on flights (screening)" if not key.startswith(("periodic", "fleet_step")) else
                    ("periodogram of flight means, p = M exp(-z)" if key == "periodic" else "sup-CUSUM of the fleet's flight means"),
                    "p_value": p, "alpha": level}
        gain = {"metric": f"RMS of the {ch} wind residual (kt)", "before": _rms_kt(fit0.resid, d.n, ch),
                "after": _rms_kt(fit1.resid, d.n, ch), "held_out_before": b_ho, "held_out_after": a_ho,
                "held_out": "flights alternate between two folds per aircraft; learned on one, measured on the other"}
        name = f"unexplained:{key}"
        out.append(Finding(name, "not in the effects library; described by its signature: " + text, params, evidence, gain))
        plots[name] = _plot_data(d, fit0, fit1, "screen", ch)
        st.signatures.extend(sigs)
        done.add(key)
    return out


# ----------------------------------------------------------------------------- outputs


def extended_spec(spec: WindModelSpec, findings: list, d: WindData, st: State) -> WindModelSpec:
    """The model with the findings in it (what a rerun of diagnose with it should not find again)."""
    up: dict[str, Any] = {}
    for f in findings:
        p = f.parameters
        if f.effect == "soft_iron":
            up["deviation_terms"] = 5
        elif f.effect == "field_scaling":
            up["field_scaling"] = float(np.clip(p["gamma"]["value"], -3, 3))
        elif f.effect == "tas_scale":
            up["tas_scale"] = {**spec.tas_scale, **{a: spec.tas_scale.get(a, 0.0) + v["k"] for a, v in p["aircraft"].items()}}
        elif f.effect == "stale_declination":
            up["declination_age_yr"] = float(p["age_yr"]["value"])
        elif f.effect == "reference_bias":
            up["reference_bias_kt"] = {**spec.reference_bias_kt, **{s: spec.reference_bias_kt.get(s, 0.0) + v["value"]
                                                                   for s, v in p["bias_kt"].items()}}
        elif f.effect == "recalibration":
            rec = {a: list(ts) for a, ts in spec.recalibrations.items()}
            for a, s in p["steps"].items():
                rec.setdefault(a, []).append(s["time_s"])
            up["recalibrations"] = rec
        elif f.effect == "quantization":
            up["lat_lon_step_deg"] = float(p["lat_lon_step_deg"]["value"])
        elif f.effect.startswith("unexplained:"):
            up.setdefault("signatures", list(spec.signatures))
            up["signatures"] += [{k: t[k] for k in ("channel", "covariate", "center", "slope")} for t in p["terms"]]
    return spec.model_copy(update=up)


def _figure(plot: dict, title: str, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = plot["x"]
    fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
    edges = np.unique(np.quantile(x, np.linspace(0, 1, 16)))
    for ax, key, lab in ((axes[0], "before", "model without the effect"), (axes[1], "after", "with the effect")):
        r = plot[key]
        ax.scatter(x, r, s=2, alpha=0.15, color="0.5")
        if len(edges) > 2:
            idx = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2)
            mids = np.array([np.mean(x[idx == k]) for k in range(len(edges) - 1) if np.any(idx == k)])
            means = np.array([np.mean(r[idx == k]) for k in range(len(edges) - 1) if np.any(idx == k)])
            ses = np.array([np.std(r[idx == k]) / math.sqrt(max(np.sum(idx == k), 1)) for k in range(len(edges) - 1)
                            if np.any(idx == k)])
            ax.errorbar(mids, means, ses, fmt="o-", color="C3", label="bin mean ± se")
        lim = np.quantile(np.abs(plot["before"]), 0.98)
        ax.set_ylim(-lim, lim)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_title(lab)
        ax.set_xlabel(f"the effect's fitted term ({plot['unit']})")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel(f"{plot['channel']} residual ({plot['unit']})")
    axes[0].legend(loc="upper left")
    fig.suptitle(title)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def _fmt_params(p: dict) -> str:
    parts = []
    for k, v in p.items():
        if isinstance(v, dict) and "value" in v:
            parts.append(f"{k} = {v['value']:.4g} ± {v['se']:.2g}")
    return ", ".join(parts) or (p.get("signature") or "")


def write_wind_diagnosis(measured: str, findings: list, baseline: dict, spec: WindModelSpec, extended: WindModelSpec,
                         plots: dict, out_dir) -> None:
    """DIR/diagnosis.json, DIR/report.md, DIR/figures/<effect>.png."""
    import json
    from dataclasses import asdict
    from pathlib import Path

    from aerotruth.files import atomic_write_text

    out = Path(out_dir)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    doc = {"measured": str(measured), "kind": "observation_table", "model": spec.model_dump(mode="json"),
           "findings": [asdict(f) for f in findings], "baseline": baseline,
           "extended_model": extended.model_dump(mode="json")}
    atomic_write_text(out / "diagnosis.json", json.dumps(doc, indent=2, default=float) + "\n")
    rr = baseline["residual_rms_kt"]
    lines = [f"# Diagnosis of `{measured}` (observation table)", "",
             f"{baseline['reports']} reports of {baseline['aircraft']} aircraft in {baseline['flights']} flights; "
             f"{baseline['rows']} (report, reference) rows pass the wind paper's ground-track gates.", "",
             "Model: each aircraft's heading deviation A + B sin z + C cos z" + (" + D sin 2z + E cos 2z" if spec.deviation_terms == 5 else "")
             + f" (wind paper eq. 2), field scaling gamma = {spec.field_scaling:g}, lat/lon grid {spec.lat_lon_step_deg:g} deg.", "",
             f"Residual RMS (kt), transverse {rr['transverse_before']:.2f} → {rr['transverse_after']:.2f}, along "
             f"{rr['along_before']:.2f} → {rr['along_after']:.2f} (model → extended model).", ""]
    if not findings:
        lines += ["**No finding**: nothing in the effects library or the screening is significant at the family-wise "
                  f"{100 * baseline['alpha']['family_wise']:.0f} % level with a held-out gain.", ""]
    for i, f in enumerate(findings, 1):
        ev = f.evidence
        pv = f"p = {ev['p_value']:.2g}" if "p_value" in ev else f"log10 p = {ev['log10_p']:.0f}"
        g = f.gain
        lines += [f"## {i}. {f.effect}", "", f.cause, "", f"* parameters: {_fmt_params(f.parameters)}",
                  f"* evidence: {ev['test']}, {pv} (level {ev['alpha']:.2g})",
                  f"* gain: {g['metric']}: {g['before']:.3g} → {g['after']:.3g}; held out {g['held_out_before']:.3g} → "
                  f"{g['held_out_after']:.3g}", ""]
        if f.effect in plots:
            name = f.effect.replace(":", "_").replace("+", "_")
            _figure(plots[f.effect], f"{f.effect}: residual against the effect's term", out / "figures" / f"{name}.png")
            lines += [f"![{f.effect}](figures/{name}.png)", ""]
    for s in baseline["not_identifiable"]:
        lines += [f"* not identifiable: {s}"]
    fits = baseline["model_fit"]
    lines += ["", "## The model's fit per aircraft", "", "| aircraft | status | A (deg) | B (deg) | C (deg) | flights | reason |",
              "|---|---|---|---|---|---|---|"]
    for a, r in fits.items():
        lines.append(f"| {a} | {r['status']} | {r.get('A_deg', float('nan')):+.2f} ± {r.get('A_se_deg', float('nan')):.2f} | "
                     f"{r.get('B_deg', float('nan')):+.2f} | {r.get('C_deg', float('nan')):+.2f} | {r['flights']} | {r['reason']} |")
    atomic_write_text(out / "report.md", "\n".join(lines) + "\n")
