"""The model of `aerotruth diagnose` on an observation table and its effects library: the
columns of each term on the stacked (transverse, along) channels, the (generalised) least
squares fit with clustered Wald tests, the change-point scan and the quantization check. See
aerotruth.analysis.diagnose.wind for the method."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np
import pandas as pd
from pydantic import Field, ValidationError, field_validator
from scipy import sparse, stats

from aerotruth.analysis.diagnose.wind_data import N_FOLDS, WindData, heading_components
from aerotruth.analysis.diagnose.wind_field import FieldKernel, other_aircraft_field
from aerotruth.analysis.diagnose.wind_weights import Weights
from aerotruth.analysis.least_squares import live_columns, ols
from aerotruth.analysis.wind.heading_correction import heading_spread
from aerotruth.errors import ConfigError
from aerotruth.schema import Section
from aerotruth.units import DEG, G0, KT

MIN_COVERAGE = 0.1  # smaller eigenvalue of the (sin, cos) covariance: the heading-correction criterion
MIN_FLIGHTS = 4
QUANT_STEPS = (1e-4, 2e-4, 2.5e-4, 5e-4, 1e-3, 2e-3, 2.5e-3, 5e-3, 0.01, 0.02, 0.025, 0.05, 0.1, 0.2, 0.25, 0.5, 1.0)
FOLDS = tuple(range(N_FOLDS))  # the held-out folds (wind_data.N_FOLDS)
# model_of_sensors' free terms: (channel, covariate)
SENSOR_DYNAMICS = (
    ("transverse", "roll_deg"),
    ("transverse", "turn_deg_s"),
    ("transverse", "phase_ascent"),
    ("transverse", "phase_descent"),
    ("transverse", "accel_error"),
    ("both", "wind_rate"),
    ("along", "phase_ascent"),
    ("along", "phase_descent"),
)
TWO_CHANNEL = ("wind_rate",)  # covariates that are vectors: one term in both channels (channel "both")
QUANT_SHARE = 0.99  # share of coordinates that must lie on a grid for the data to be quantized on it


class WindModelSpec(Section):
    """What `aerotruth diagnose` assumes about the wind sensors behind an observation table
    (campaign YAML `diagnose: {wind: ...}`; the extended model it writes sets these)."""

    deviation_terms: int = Field(
        default=3, description="3: A, B, C (wind paper eq. 2 as the method fits it); 5: + D, E (soft iron)"
    )
    deviation_heading: Literal["auto", "magnetic", "true"] = Field(
        default="auto",
        description="the heading the deviation's harmonics are of: magnetic (the flux valve's own: the "
        "reported true heading less the IGRF declination; wind paper section 4: eq. 2 assumes magnetic "
        "heading), true (the method's approximation, the curve shifted by the declination), or auto: "
        "the one the base model fits better (the smaller transverse residual; indistinguishable where "
        "the declination hardly changes across the network)",
    )
    field_scaling: float = Field(default=0.0, ge=-3, le=3, description="gamma of B, C ~ (H0/H)^gamma (hard iron: 1)")
    tas_bias: bool = Field(
        default=False,
        description="each aircraft has its own constant TAS bias, fitted (the "
        "campaign's air_data.tas_bias_sigma_kt > 0): a free along-channel offset per aircraft",
    )
    tas_scale: dict[str, float] = Field(
        default_factory=dict, description="per aircraft TAS scale factor (0.01 = reads 1 % high)"
    )
    tas_along_path: bool = Field(
        default=False,
        description="the reported TAS is the airspeed along the air path (3-D), "
        "which eq. 1 takes as horizontal: in climb and descent the along residual is "
        "TAS (1 - cos gamma), gamma from the reports' altitude rate",
    )
    declination_age_yr: float = Field(default=0.0, ge=-50, le=50, description="age of the receivers' declination model")
    reference_bias_kt: dict[str, float] = Field(
        default_factory=dict, description="per reference model, bias along its wind (kt)"
    )
    reference_scale: dict[str, float] = Field(
        default_factory=dict, description="per reference model, scale error of its wind: reference = truth x (1 + s)"
    )
    recalibrations: dict[str, list[float]] = Field(
        default_factory=dict, description="per aircraft, UTC epoch seconds after which its offset A is new"
    )
    offset_drifts: list[str] = Field(
        default_factory=list, description="aircraft whose offset A changes linearly with time (rate fitted)"
    )
    lat_lon_step_deg: float = Field(default=0.01, gt=0, description="quantization of reported lat/lon")
    signatures: list[dict[str, Any]] = Field(
        default_factory=list,
        description="linear terms found by screening: {channel, covariate, slope} (an effect outside the library)",
    )
    free_terms: list[dict[str, str]] = Field(
        default_factory=list,
        description="fleet-wide linear terms the sensors are "
        "known to have, size fitted: {channel, covariate} (e.g. a pendulous valve's "
        "turning error: transverse, turn_deg_s)",
    )

    @field_validator("free_terms")
    @classmethod
    def _free_terms(cls, v: list[dict[str, str]]) -> list[dict[str, str]]:
        for i, t in enumerate(v):
            if set(t) != {"channel", "covariate"} or t["channel"] not in ("transverse", "along", "both"):
                raise ValueError(f"item {i}: expected {{channel: transverse|along|both, covariate: NAME}}, got {t}")
            if (t["channel"] == "both") != (t["covariate"] in TWO_CHANNEL):
                raise ValueError(f"item {i}: channel 'both' is for the vector covariates {list(TWO_CHANNEL)}, got {t}")
        return v


def wind_model_from_campaign(campaign) -> WindModelSpec:
    """The campaign's `diagnose.wind` section, else what the campaign's wind-report sensors
    put into reports (`model_of_sensors`), else the wind paper's model (A, B, C; 0.01 deg)."""
    raw = (getattr(campaign, "diagnose", None) or {}).get("wind") if campaign is not None else None
    if raw is not None:
        try:
            return WindModelSpec.model_validate(raw)
        except ValidationError as e:
            err = e.errors()[0]
            where = ".".join(str(p) for p in err["loc"])
            raise ConfigError(f"diagnose.wind.{where}: {err['msg']}") from None
    for name in ("wind_reports", "heading_correction"):
        if campaign is not None and name in campaign.studies:
            sensors = getattr(campaign.studies[name], "sensors", None)
            if sensors is not None and hasattr(sensors, "reports"):
                fleets = getattr(campaign.studies[name], "fleets", None) or [f.name for f in campaign.fleets]
                days = campaign.days([p.name for p in campaign.periods]) if campaign.periods else []
                return model_of_sensors(sensors, fleets, days)
    return WindModelSpec()


def model_of_sensors(sensors, fleets: list[str], days: list | None = None) -> WindModelSpec:
    """The diagnose model of a campaign's wind sensors (aerotruth.sim.wind_observations.
    WindSensors; `fleets` the fleet names they serve, `days` the campaign's dates): what its
    simulated reports carry, so that diagnosing them finds nothing.

    * hard iron in a flux valve: B, C scale as H0/H (field_scaling 1; magnetics module);
    * soft iron (soft_iron_sigma > 0): the 2z terms D, E of eq. 2 (deviation_terms 5);
    * a TAS bias spread over airframes (tas_bias_sigma_kt > 0 or a mean bias): one fitted
      along-channel offset per aircraft (tas_bias);
    * the TAS is the truth's 3-D airspeed, the air vector of eq. 1 horizontal: in climbs
      and descents the along residual is TAS (1 - cos gamma) (tas_along_path; truth
      legs: TAS - horizontal airspeed 0.5-1.0 kt in climbs, 0.00 kt level);
    * a declination table of a fixed epoch: its age at the middle of the campaign's dates;
    * the reported lat/lon step;
    * what the sensors do in manoeuvres, fleet-wide terms of free size (SENSOR_DYNAMICS):
      a report is the mean over a trailing window (10 s) while the truth turns under it,
      a pendulous valve tilts with the kinematic acceleration of turns and speed changes
      and then reads part of the vertical field (turning and acceleration errors, ~Z/H),
      and the slaved gyro carries that on; so the transverse residual has roll and
      turn-rate terms and climb and descent offsets. Measured on simulated Mesaba days
      against the truth heading at the report time (12 aircraft, 2 seeds): -0.55 deg per
      deg of roll, -0.44 deg per deg/s of turn between reports, +0.24 deg climbing, +0.14
      deg descending (with each other in one regression).
    * the same valve tilted by speed changes (accel_error, the acceleration error
      -tan(I) (a/g) sin z_mag, a fleet-wide term of free size): in climbs and descents the
      TAS changes by ~0.07 m/s^2 rms. Measured against the truth heading (the report
      rows of one simulated Mesaba null, |roll| < 2 deg, per-aircraft A, B, C and the
      phase offsets fitted): -41.7 deg per unit of tan(I) a/g sin z_mag (an unslaved valve
      -57.3: the slaved gyro passes ~0.73 of it), 28 % of the residual sum of squares;
      without the term, what it leaves looked like a declination table 1.2-1.6 years
      younger than the stated one (a stale declination at z -3 to -5 with perfect
      reference winds, -1.9 on average with the analyses').
    * a report's wind is the mean over its trailing window, stamped at the window's end
      (aerotruth.sensors.tamdar): against a reference at the stamp it lags by half the
      window, W_REF - W_TAM = (W / 2) dW/dt in both channels (wind_rate, seconds, free):
      6.1 +- 0.6 s fitted where the window is 10 s (perfect reference winds, one null);
    * along-channel climb and descent offsets (free): with perfect reference winds the
      along residual is -0.29 kt climbing and -0.04 kt descending against level, what
      TAS (1 - cos gamma) from the reports' pressure-altitude rate leaves of the 3-D
      airspeed. Not in the model: a fleet TAS scale of -0.31 +- 0.01 % that the
      simulated reports carry against the truth wind (found with perfect references at
      p 1e-65; its cause is not yet known; a free fleet scale would hide the library's
      TAS scale).
    Per-airframe draws (hard iron, mounting, soft iron) are free parameters, not known
    values: the model states which terms exist, the fit finds their size."""
    specs = [sensors.of(f) for f in fleets] or [sensors.of("")]
    hard = any(
        max(
            s.heading.poor_hard_iron_sigma_nT * (s.heading.poor_fraction > 0),
            s.heading.healthy_hard_iron_sigma_nT * (s.heading.poor_fraction < 1),
        )
        > 0
        for s in specs
    )
    soft = any(s.heading.soft_iron_sigma > 0 for s in specs)
    tas_bias = any(s.air_data.tas_bias_sigma_kt > 0 or s.air_data.tas_bias_kt != 0 for s in specs)
    epochs = {s.heading.declination_epoch for s in specs} - {"truth"}
    age = 0.0
    if epochs and days:
        mid = days[len(days) // 2]
        age = float(np.mean([(mid - e).days / 365.25 for e in epochs]))
    return WindModelSpec(
        deviation_terms=5 if soft else 3,
        field_scaling=1.0 if hard else 0.0,
        tas_bias=tas_bias,
        tas_along_path=True,
        declination_age_yr=age,
        lat_lon_step_deg=float(sensors.reports.lat_lon_step_deg),
        free_terms=[{"channel": ch, "covariate": c} for ch, c in SENSOR_DYNAMICS],
    )


# ----------------------------------------------------------------------------- model


@dataclass
class Block:
    """Columns of one term of the model: `aircraft` -1 for fleet-wide terms."""

    effect: str
    label: str
    cols: np.ndarray  # (2n, q)
    aircraft: int = -1
    p: float | None = None  # a scanned candidate's p-value (Bonferroni over aircraft), else None
    # +1 (-1): the physics allows this one-column term only a positive (negative) coefficient,
    # so its test is one-sided in that direction (block_p); 0: either sign, two-sided
    sign: int = 0


@dataclass
class State:
    """The current model: the spec's known terms plus the effects entered so far (free)."""

    spec: WindModelSpec
    entered: list[str] = field(default_factory=list)
    gamma: float = 0.0  # field scaling exponent in the design (spec value, then fitted)
    steps: dict[int, list[float]] = field(default_factory=dict)  # aircraft -> step times (free new A after each)
    drifts: set[int] = field(default_factory=set)  # aircraft whose A drifts linearly in time (free rate)
    signatures: list[dict] = field(default_factory=list)  # screening terms entered (free)
    # the reference error field the fleet shares (wind_field), read off the model as given:
    # the per-aircraft scans measure an aircraft against the other aircraft's view of it
    field: FieldKernel | None = None
    weights: Weights | None = None  # the fit's working covariance (wind_weights), None: ordinary least squares
    # the references' biases tested on their differences at the same reports where there is a
    # field (wind_pairs.reference_difference_test; no term of the model enters them)
    reference_pairs: dict | None = None


def stack_channels(trans: np.ndarray | None, along: np.ndarray | None, n: int) -> np.ndarray:
    out = np.zeros(2 * n)
    if trans is not None:
        out[:n] = trans
    if along is not None:
        out[n:] = along
    return out


def tas_column(d: WindData, i: int) -> np.ndarray:
    """Along channel of aircraft i: TAS (coefficient: its TAS scale factor)."""
    return stack_channels(None, (d.aircraft == i) * d.tas, d.n)


def drift_column(d: WindData, i: int) -> np.ndarray:
    """Transverse of aircraft i: TAS x (t - t_mid) in days, t_mid the middle of its data
    (coefficient: the drift of its offset A, rad per day)."""
    sel = d.aircraft == i
    t = d.time_s[sel]
    mid = 0.5 * (t.min() + t.max()) if len(t) else 0.0
    return stack_channels(sel * d.tas * (d.time_s - mid) / 86400.0, None, d.n)


def flight_path_column(d: WindData) -> np.ndarray:
    """Along channel: TAS (1 - cos gamma), sin gamma = climb rate / TAS (the reports'
    pressure-altitude rate; m/s): what a 3-D TAS adds to a horizontal air vector."""
    sin_g = np.clip(d.climb_fpm * 0.3048 / 60.0 / np.maximum(d.tas, 1.0), -1.0, 1.0)
    return stack_channels(None, d.tas * (1.0 - np.sqrt(1.0 - sin_g**2)), d.n)


def declination_column(d: WindData) -> np.ndarray:
    """Transverse: TAS x (-dD/dt) (coefficient: the declination model's age in years)."""
    return stack_channels(d.tas * (-d.sv_deg_yr) * DEG, None, d.n)


def reference_bias_column(d: WindData, m: int) -> np.ndarray:
    """Reference m's rows: the unit wind vector on n and u, in kt (coefficient: bias, kt)."""
    s = d.source == m
    tr, al = heading_components(d.wref_e, d.wref_n, d.z)
    return stack_channels(s * tr, s * al, d.n) * KT


def reference_scale_column(d: WindData, m: int) -> np.ndarray:
    """Reference m's rows: its wind (speed x the unit vector) on n and u, m/s (coefficient:
    the scale s of its wind error, s W)."""
    return reference_bias_column(d, m) / KT * np.r_[d.wref_speed, d.wref_speed]


def wind_rate_column(d: WindData) -> np.ndarray:
    """Both channels: the wind's rate between the report's neighbours on n and u (m/s per s;
    coefficient: seconds). A report whose wind is the mean over a trailing window of W
    seconds but stamped at the window's end carries W(t) - (W / 2) dW/dt: against a
    reference at its stamp, V_A - V_A' = W_REF - W_TAM gains +(W / 2) dW/dt (TAMDAR's
    10-s window: 5 s; a wind older or younger than its time stamp in general)."""
    return stack_channels(*heading_components(d.wind_rate_e, d.wind_rate_n, d.z), d.n)


def signature_column(d: WindData, sig: dict) -> np.ndarray:
    """A screening term: deg per unit of the covariate (transverse), kt per unit (along);
    a vector covariate in both channels (TWO_CHANNEL): its own unit (wind_rate: s)."""
    if sig["channel"] == "both":
        if sig["covariate"] != "wind_rate":
            raise ConfigError(f"diagnose.wind.signatures: {sig['covariate']!r} is not a two-channel covariate")
        return wind_rate_column(d)
    x = covariate(d, sig["covariate"]) - float(sig.get("center", 0.0))
    return (
        stack_channels(d.tas * x * DEG, None, d.n)
        if sig["channel"] == "transverse"
        else stack_channels(None, x * KT, d.n)
    )


def known_offsets(d: WindData, spec: WindModelSpec) -> np.ndarray:
    """What the spec states as known (subtracted from the data): TAS scales, the declination
    table's age, reference biases along the wind and scales of it, stated signature terms."""
    out = np.zeros(2 * d.n)
    for i, name in enumerate(d.names):
        out += spec.tas_scale.get(name, 0.0) * tas_column(d, i)
    out += spec.declination_age_yr * declination_column(d)
    if spec.tas_along_path:
        out += flight_path_column(d)
    for m, src in enumerate(d.sources):
        out += spec.reference_bias_kt.get(src, 0.0) * reference_bias_column(d, m)
        out += spec.reference_scale.get(src, 0.0) * reference_scale_column(d, m)
    for sig in spec.signatures:
        out += float(sig["slope"]) * signature_column(d, sig)
    return out


def _coverage_ok(z: np.ndarray, harmonic: int) -> bool:
    return len(z) >= 3 and heading_spread(np.degrees(z), np.ones(len(z)), harmonic) >= MIN_COVERAGE


def deviation_z(d: WindData, spec: WindModelSpec) -> np.ndarray:
    """The heading (rad) the deviation's harmonics are of (WindModelSpec.deviation_heading;
    "auto" is decided by choose_deviation_heading before any fit, magnetic until then)."""
    return d.z if spec.deviation_heading == "true" else d.z_mag


def initial_state(d: WindData, spec: WindModelSpec) -> State:
    """The model as the spec states it, before any effect enters: its recalibration times
    and drifting offsets mapped to the data's aircraft."""
    steps = {d.names.index(a): list(ts) for a, ts in spec.recalibrations.items() if a in d.names}
    drifts = {d.names.index(a) for a in spec.offset_drifts if a in d.names}
    return State(spec, [], spec.field_scaling, steps, drifts, [])


def choose_deviation_heading(d: WindData, spec: WindModelSpec, y: np.ndarray, clusters: np.ndarray) -> dict:
    """For deviation_heading "auto": the base model fitted with its harmonics of the magnetic
    and of the true heading (the same number of parameters), the one with the smaller
    transverse residual sum of squares chosen. Returns {"chosen", "transverse_rms_kt":
    {magnetic, true}}; the spec's own choice where it is not "auto"."""
    rms = {}
    for h in ("magnetic", "true"):
        st = initial_state(d, spec.model_copy(update={"deviation_heading": h}))
        fit = solve(current_blocks(d, st), y, clusters, with_cov=False)
        rms[h] = float(np.sqrt(np.mean(fit.resid[: d.n] ** 2)) / KT)
    chosen = spec.deviation_heading if spec.deviation_heading != "auto" else min(rms, key=lambda h: rms[h])
    return {"chosen": chosen, "transverse_rms_kt": rms, "asked": spec.deviation_heading}


def base_blocks(d: WindData, st: State) -> list[Block]:
    """The deviation model per aircraft (A; B, C where identified; D, E when in the model),
    its harmonics of the deviation heading (deviation_z)."""
    n, out = d.n, []
    z = deviation_z(d, st.spec)
    s = d.h_ratio**st.gamma
    for i in range(len(d.names)):
        sel = d.aircraft == i
        one = sel.astype(float) * d.tas
        times = sorted(st.steps.get(i, []))
        edges = [-np.inf, *times, np.inf]
        cols = [
            stack_channels(one * ((d.time_s >= lo) & (d.time_s < hi)), None, n)
            for lo, hi in zip(edges[:-1], edges[1:], strict=False)
        ]
        out.append(Block("base", "A", np.column_stack(cols), i))
        if i in st.drifts:
            out.append(Block("base", "drift", drift_column(d, i)[:, None], i))
        if st.spec.tas_bias:
            out.append(Block("base", "T", stack_channels(None, sel.astype(float), n)[:, None], i))
        zi = z[sel]
        if _coverage_ok(zi, 1):
            out.append(
                Block(
                    "base",
                    "BC",
                    np.column_stack(
                        [stack_channels(one * s * np.sin(z), None, n), stack_channels(one * s * np.cos(z), None, n)]
                    ),
                    i,
                )
            )
        if (st.spec.deviation_terms == 5 or "soft_iron" in st.entered) and _coverage_ok(zi, 2):
            out.append(
                Block(
                    "soft_iron" if "soft_iron" in st.entered else "base",
                    "DE",
                    np.column_stack(
                        [stack_channels(one * np.sin(2 * z), None, n), stack_channels(one * np.cos(2 * z), None, n)]
                    ),
                    i,
                )
            )
    return out


def covariate(d: WindData, name: str) -> np.ndarray:
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
    if name in TWO_CHANNEL:
        raise ConfigError(f"diagnose.wind.signatures: {name!r} is a vector in both channels (channel: both)")
    if name == "accel_error":
        # a pendulous flux valve's acceleration error: a forward acceleration a tilts it aft by
        # atan(a / g) and it reads that much of the vertical field, an apparent turn towards
        # north of -tan(I) (a / g) sin(z_mag) rad (aerotruth.sensors.magnetics; the textbook
        # "accelerate north" error, larger where the dip is steep); a slaved gyro passes the
        # part that lasts longer than its slaving time. Unit: tan(I) a/g sin(z_mag); an
        # unslaved valve's coefficient is -57.3 deg per unit
        return d.tan_dip * d.tas_rate / G0 * np.sin(d.z_mag)
    if name == "flight_path_angle_deg":
        return d.fpa_deg
    if name == "inverse_dynamic_pressure":
        return d.inv_q
    if name == "inverse_dynamic_pressure_cruise":
        return d.inv_q_cruise
    if name in ("local_hour_sin", "local_hour_cos"):
        arg = 2 * np.pi * d.local_hour / 24.0
        return np.sin(arg) if name.endswith("sin") else np.cos(arg)
    if name.startswith("sin") or name.startswith("cos"):
        k = int(name[3])
        return np.sin(k * d.z_mag) if name.startswith("sin") else np.cos(k * d.z_mag)  # a compass term: magnetic
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
    return Block("signature", f"{sig['channel']}:{sig['covariate']}", signature_column(d, sig)[:, None])


def fixed_effect_blocks(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    """Blocks of the entered library effects other than soft iron (in base_blocks)."""
    out = []
    for eff in st.entered:
        if eff in ("soft_iron", "recalibration", "offset_drift", "field_scaling", "quantization"):
            continue
        out.extend(CANDIDATES[eff](d, st, fit))
    out.extend(signature_block(d, s) for s in st.signatures)
    out.extend(free_term_block(d, t) for t in st.spec.free_terms)
    return out


def term_center(d: WindData, channel: str, name: str) -> float:
    """What a linear term is centred on: its covariate's mean (the per-aircraft offsets keep
    the mean); none for a constant and for a two-channel vector (its mean is not an offset)."""
    return 0.0 if name == "const" or channel == "both" else float(np.mean(covariate(d, name)))


def free_term_block(d: WindData, term: dict) -> Block:
    """A free fleet-wide term of the spec (centred: term_center)."""
    sig = {**term, "center": term_center(d, term["channel"], term["covariate"])}
    return Block("base", f"free:{term['channel']}:{term['covariate']}", signature_column(d, sig)[:, None])


# ----------------------------------------------------------------------------- least squares


@dataclass
class Fit:
    blocks: list[Block]
    beta: np.ndarray
    cov: np.ndarray
    resid: np.ndarray
    slices: list[slice]
    clusters: np.ndarray
    # field_of's result per field kernel: the tests of one fit that read the field (each
    # aircraft's scans and its own terms, OWN_TERMS) share one kriging
    _field: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def field_of(self, d: WindData, kernel: FieldKernel) -> np.ndarray:
        """(2n,) each row's reference error field as the other aircraft's rows saw it, from
        this fit's residual (wind_field.other_aircraft_field)."""
        if kernel not in self._field:
            self._field[kernel] = other_aircraft_field(d, self.resid, kernel)
        return self._field[kernel]

    def transverse_less_field(self, d: WindData, kernel: FieldKernel | None) -> np.ndarray:
        """(n,) the transverse residual, less each row's reference error field as the other
        aircraft's rows saw it where there is a `kernel`."""
        if kernel is None:
            return self.resid[: d.n]
        return self.resid[: d.n] - self.field_of(d, kernel)[: d.n]

    def coef(self, effect: str, aircraft: int | None = None) -> list[tuple[Block, np.ndarray, np.ndarray]]:
        return [
            (b, self.beta[s], self.cov[s, s])
            for b, s in zip(self.blocks, self.slices, strict=False)
            if b.effect == effect and (aircraft is None or b.aircraft == aircraft)
        ]


class Basis:
    """The current model's design decomposed once a round, so that each candidate term is
    fitted by partialling the model out of its columns (Frisch-Waugh-Lovell): for added
    columns C, C~ = C - X0 (X0'X0)^-1 X0'C on the fitted rows, gamma = (C~'C~)^-1 C~'e0 with
    e0 the current model's residual; the coefficient, the residual (e0 - C~ gamma on every
    row) and the cluster-robust covariance of gamma (scores C~_g' e_g) are exactly those of
    the full fit [X0 C] (tests/test_diagnose_wind.py checks it), at the cost of the added
    columns only. Parts: None (all rows) and k = 0 .. N_FOLDS - 1 (trained on every fold but
    k, predicting fold k)."""

    def __init__(self, d: WindData, st: State, y: np.ndarray, clusters: np.ndarray):
        self.d, self.y, self.clusters = d, y, clusters
        self.weights = st.weights
        self.blocks = current_blocks(d, st)
        self.X0 = np.column_stack([b.cols for b in self.blocks])
        self.X0w, self.yw = self._whiten(self.X0), self._whiten(y)
        self.slices, k = [], 0
        for b in self.blocks:
            self.slices.append(slice(k, k + b.cols.shape[1]))
            k += b.cols.shape[1]
        self.parts = {p: self._part(None if p is None else train_rows(d, p)) for p in (None, *FOLDS)}

    def _whiten(self, x: np.ndarray) -> np.ndarray:
        return x if self.weights is None else self.weights.whiten(x)

    def _part(self, rows: np.ndarray | None) -> dict:
        Xr = self.X0w if rows is None else self.X0w[rows]
        yr = self.yw if rows is None else self.yw[rows]
        beta, xtx = ols(Xr, yr)
        live = live_columns(xtx)
        return {
            "rows": rows,
            "beta": beta,
            "live": live,
            "inv": np.linalg.pinv(xtx[np.ix_(live, live)]),
            "Xr": Xr[:, live],
            "resid": self.y - self.X0 @ beta,  # original units
            "resid_w": self.yw - self.X0w @ beta,  # whitened (the same as resid without weights)
        }

    def base_fit(self, part: int | None = None) -> Fit:
        """The current model's own fit (no covariance)."""
        p = self.parts[part]
        cov = np.full((self.X0.shape[1], self.X0.shape[1]), np.nan)
        return Fit(self.blocks, p["beta"], cov, p["resid"], self.slices, self.clusters)

    def fit(self, blocks: list[Block], part: int | None = None, with_cov: bool = True) -> Fit:
        p = self.parts[part]
        rows = p["rows"]
        C = np.column_stack([b.cols for b in blocks])
        Cw = self._whiten(C)
        Cr = Cw if rows is None else Cw[rows]
        Pi = p["inv"] @ (p["Xr"].T @ Cr)
        Ct = C - self.X0[:, p["live"]] @ Pi  # original units: what the residual loses
        Ctw = Cw - self.X0w[:, p["live"]] @ Pi if self.weights is not None else Ct
        Ctr = Ctw if rows is None else Ctw[rows]
        # a column the model already spans (nothing left after partialling): coefficient 0
        keep = np.sum(Ctr**2, axis=0) > 1e-18 * np.maximum(np.sum(Cr**2, axis=0), 1e-300)
        Ctr_k = Ctr[:, keep]
        e0r = p["resid_w"] if rows is None else p["resid_w"][rows]
        gamma = np.zeros(C.shape[1])
        xtx = Ctr_k.T @ Ctr_k
        if keep.any():
            gamma[keep], _ = ols(Ctr_k, e0r)
        resid = p["resid"] - Ct[:, keep] @ gamma[keep]
        cov = np.full((C.shape[1], C.shape[1]), np.nan)
        if with_cov and keep.any():
            g = self.clusters if rows is None else self.clusters[rows]
            idx = np.flatnonzero(keep)
            cov[np.ix_(idx, idx)] = cluster_jackknife(Ctr_k, e0r, g, xtx)
        slices, k = [], 0
        for b in blocks:
            slices.append(slice(k, k + b.cols.shape[1]))
            k += b.cols.shape[1]
        return Fit(blocks, gamma, cov, resid, slices, self.clusters)


def cluster_jackknife(X: np.ndarray, y: np.ndarray, g: np.ndarray, xtx: np.ndarray) -> np.ndarray:
    """Leave-one-cluster-out (CR3) covariance (G-1)/G sum_g (b_(-g) - b_bar)(b_(-g) - b_bar)'
    of the least-squares coefficients of y on X, each b_(-g) from X'X and X'y less cluster
    g's share. The candidate tests use it instead of CR1: with ~30 weather blocks and a
    regressor that varies from block to block (a time trend), CR1's F(1, G-1) test rejected
    3.4 times too often at 4e-4 (1.35e-3 of 20,000 simulated nulls), the jackknife 1.75
    times (7e-4). In the partialled fit the model's own terms stay at their full-data
    values (their refit without the cluster is second order)."""
    order = np.argsort(g, kind="stable")
    gs = g[order]
    cuts = np.flatnonzero(np.diff(gs)) + 1
    Xo, yo = X[order], y[order]
    xty = X.T @ y
    bs = []
    for a, b in zip(np.r_[0, cuts], np.r_[cuts, len(gs)], strict=True):
        Xg = Xo[a:b]
        A = xtx - Xg.T @ Xg
        r = xty - Xg.T @ yo[a:b]
        try:
            bs.append(np.linalg.solve(A, r))
        except np.linalg.LinAlgError:
            bs.append(np.linalg.lstsq(A, r, rcond=None)[0])
    B = np.array(bs)
    G = len(B)
    dev = B - B.mean(axis=0)
    return (G - 1) / max(G, 1) * dev.T @ dev


def cluster_robust(X: np.ndarray, resid: np.ndarray, g: np.ndarray, xtx: np.ndarray) -> np.ndarray:
    """CR1 covariance (X'X)^-1 (G/(G-1) sum_g s_g s_g') (X'X)^-1, s_g = X_g' e_g."""
    bread = np.linalg.pinv(xtx)
    uniq, inv = np.unique(g, return_inverse=True)
    G = len(uniq)
    members = sparse.csr_matrix((np.ones(len(inv)), (inv, np.arange(len(inv)))), shape=(G, len(inv)))
    scores = members @ (X * resid[:, None])
    meat = scores.T @ scores * (G / max(G - 1, 1))
    return bread @ meat @ bread


def solve(
    blocks: list[Block],
    y: np.ndarray,
    clusters: np.ndarray,
    rows: np.ndarray | None = None,
    with_cov: bool = True,
    weights: Weights | None = None,
) -> Fit:
    """Least squares on the stacked channels (rows: a mask of the 2n rows), generalised with
    the working covariance `weights` (wind_weights; None: ordinary), CR1 covariance on the
    clusters of the whitened rows; the residual in the original units."""
    X = np.column_stack([b.cols for b in blocks])
    slices, k = [], 0
    for b in blocks:
        slices.append(slice(k, k + b.cols.shape[1]))
        k += b.cols.shape[1]
    Xw, yw = (X, y) if weights is None else (weights.whiten(X), weights.whiten(y))
    Xr, yr = (Xw, yw) if rows is None else (Xw[rows], yw[rows])
    beta, xtx = ols(Xr, yr)  # columns zero on every used row (an aircraft left out): coefficient 0
    live = live_columns(xtx)
    resid = y - X @ beta
    cov = np.full((X.shape[1], X.shape[1]), np.nan)
    if with_cov:
        idx = np.flatnonzero(live)
        g = clusters if rows is None else clusters[rows]
        rw = resid if weights is None else yw - Xw @ beta  # the whitened residual
        rr = rw if rows is None else rw[rows]
        cov[np.ix_(idx, idx)] = cluster_robust(Xr[:, idx], rr, g, xtx[np.ix_(idx, idx)])
    return Fit(blocks, beta, cov, resid, slices, clusters)


def wald_p(beta: np.ndarray, cov: np.ndarray, df_den: int) -> float:
    ok = np.isfinite(np.diag(cov)) & (np.diag(cov) > 0)
    if not ok.any() or df_den < 1:
        return 1.0
    b, v = beta[ok], cov[np.ix_(ok, ok)]
    w = float(b @ np.linalg.pinv(v) @ b)
    # degrees of freedom: the covariance's rank (two nearly collinear columns, e.g. the pitch
    # signature's q_250/q and q_cruise/q where the flights' cruise q hardly varies, test one)
    q = max(int(np.linalg.matrix_rank(v, hermitian=True)), 1)
    return float(stats.f.sf(w / q, q, df_den))


def signed_p(beta: float, var: float, df_den: int, sign: int) -> float:
    """One-sided p of a single coefficient whose alternative is sign x beta > 0: the t test's
    upper tail, t = sign beta / sqrt(var) on df_den degrees of freedom (half the two-sided
    F(1, df_den) p in the allowed direction, one less that half in the other)."""
    if not (np.isfinite(var) and var > 0) or df_den < 1:
        return 1.0
    return float(stats.t.sf(sign * beta / math.sqrt(var), df_den))


# effects whose fleet-wide blocks are separate causes, one each: a reference model's bias is
# that model's (the other reference's term beside it is a second, independent question), so
# each block is tested alone and the smallest p taken times their number (Bonferroni), as
# per-aircraft scans are; a joint Wald test spends a degree of freedom on each unbiased one
SEPARATE_BLOCKS = {"reference_bias"}


def block_p(fit: Fit, effect: str, d: WindData) -> float:
    """p-value of `effect`'s blocks = 0: fleet-wide blocks by one Wald test on all flights
    (each block alone for SEPARATE_BLOCKS, Bonferroni over them; one column whose sign the
    physics fixes, Block.sign, one-sided), per-aircraft blocks aircraft by aircraft (their
    flights) combined by chi-square sums."""
    parts = fit.coef(effect)
    if not parts:
        return 1.0
    G = len(np.unique(fit.clusters))
    fleet = [(b, be, v) for b, be, v in parts if b.aircraft < 0]
    per = [(b, be, v) for b, be, v in parts if b.aircraft >= 0]
    ps = []
    if fleet and effect in SEPARATE_BLOCKS:
        ps.append(min(1.0, min(wald_p(be, v, G - 1) for _, be, v in fleet) * len(fleet)))
    elif len(fleet) == 1 and fleet[0][0].sign and fleet[0][1].size == 1:  # one signed column
        b, be, v = fleet[0]
        ps.append(signed_p(float(be[0]), float(v[0, 0]), G - 1, b.sign))
    elif fleet:
        be = np.concatenate([x[1] for x in fleet])
        sl = [s for b, s in zip(fit.blocks, fit.slices, strict=False) if b.effect == effect and b.aircraft < 0]
        idx = np.concatenate([np.arange(s.start, s.stop) for s in sl])
        ps.append(wald_p(be, fit.cov[np.ix_(idx, idx)], G - 1))
    if per:
        chi, dof = 0.0, 0
        for b, be, v in per:
            g_i = len(np.unique(d.cluster[d.aircraft == b.aircraft]))
            p = wald_p(be, v, g_i - 1)
            q = be.size
            chi += float(stats.chi2.isf(max(p, 1e-300), q))
            dof += q
        ps.append(float(stats.chi2.sf(chi, dof)))
    return float(min(1.0, min(ps) * len(ps)))


def rows_of_fold(d: WindData, fold: int) -> np.ndarray:
    """The 2n rows (both channels) of held-out fold `fold`."""
    f = d.fold == fold
    return np.r_[f, f]


def train_rows(d: WindData, fold: int) -> np.ndarray:
    """The rows a fit that predicts fold `fold` learns on: every other fold."""
    f = d.fold != fold
    return np.r_[f, f]


def channel_rows(n: int, channel: str) -> np.ndarray:
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
    z = deviation_z(d, st.spec)
    for i in range(len(d.names)):
        sel = d.aircraft == i
        if _enough(d, i) and _coverage_ok(z[sel], 2):
            one = sel * d.tas
            out.append(
                Block(
                    "soft_iron",
                    "DE",
                    np.column_stack(
                        [stack_channels(one * np.sin(2 * z), None, n), stack_channels(one * np.cos(2 * z), None, n)]
                    ),
                    i,
                )
            )
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
    return [Block("field_scaling", "gamma", stack_channels(col, None, d.n)[:, None])]


def cand_tas_scale(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    return [Block("tas_scale", "k", tas_column(d, i)[:, None], i) for i in range(len(d.names)) if _enough(d, i)]


def cand_tas_scale_fleet(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    """One TAS scale shared by the fleet (a type's air-data calibration, a temperature
    probe's recovery factor): one parameter where the per-aircraft form has one per
    aircraft, so a common error is found with far fewer reports."""
    cols = [tas_column(d, i) for i in range(len(d.names)) if _enough(d, i)]
    return [Block("tas_scale", "k_fleet", np.sum(cols, axis=0)[:, None])] if cols else []


def declination_identifiable(d: WindData) -> float:
    """Share of the declination-age regressor's variance left after per-aircraft offsets."""
    x = d.tas * (-d.sv_deg_yr)
    means = pd.Series(x).groupby(d.aircraft).transform("mean").to_numpy()
    tot = float(np.sum((x - x.mean()) ** 2))
    return float(np.sum((x - means) ** 2) / tot) if tot > 0 else 0.0


def cand_stale_declination(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    if declination_identifiable(d) < 0.01:
        return []
    # a receiver's declination model cannot be newer than the data it converts: the true age
    # is >= 0, so the departure from the stated age a0 is >= -a0. Where the spec states a
    # current model (a0 <= 0) only an older one is a cause, and the test is one-sided towards
    # it; a table "years newer than the data" is no receiver's and no cause to name. With
    # a0 > 0 both directions are possible (two-sided).
    older = 1 if st.spec.declination_age_yr <= 0 else 0
    return [Block("stale_declination", "age", declination_column(d)[:, None], sign=older)]


def cand_reference_bias(d: WindData, st: State, fit: Fit | None) -> list[Block]:
    return [Block("reference_bias", src, reference_bias_column(d, m)[:, None]) for m, src in enumerate(d.sources)]


def _cusum(x: np.ndarray) -> tuple[np.ndarray, int, float]:
    """(deviations from the mean, the index after which the mean changes, sup |CUSUM|)."""
    e = x - x.mean()
    s = np.cumsum(e)[:-1]
    k = int(np.argmax(np.abs(s)))
    return e, k, float(abs(s[k]))


# permutations of a per-aircraft scan (recalibration_scan, drift_scan): 1,999, then 39,999
# while p < 0.02, then 399,999 while p < 0.002 (the fleet-wide tests stop at 39,999). A
# per-aircraft scan is compared with the library's level (~9e-4) after Bonferroni over ~12
# aircraft, i.e. ~7.5e-5 an aircraft: at 39,999 that is 3 expected exceedances, and the
# decision near the level was the Monte Carlo's noise more than the data's (a recalibrated
# aircraft's scan at 1.25e-4 against its drift's 5e-5, the floor, on aerotruth's own reports)
PERMUTATION_STAGES = (1999, 39999, 399999)
PERMUTATION_GO_ON = (0.02, 0.002)  # p after stage k below this: the next stage
PERMUTATION_CHUNK = 40000  # permutations drawn at once (memory: chunk x units)


def permutation_p(x: np.ndarray, stat, stages: tuple[int, ...] = PERMUTATION_STAGES[:2], seed: int = 20261128) -> float:
    """p-value of stat(x) (larger = more extreme) by permuting the units of x: exact when
    the units are exchangeable under the null, whatever their number and distribution.
    `stat` maps an (m, n) array of permuted series to m statistics. Deterministic (a fixed
    stream); the permutations grow from one stage to the next while p is small
    (PERMUTATION_GO_ON), so p resolves down to 1 / (stages[-1] + 1)."""
    x = np.asarray(x, dtype=float)
    n = len(x)
    observed = float(stat(x[None, :])[0])
    tol = 1e-12 * max(abs(observed), 1.0)
    rng = np.random.default_rng(seed)
    hits = total = 0
    p = 1.0
    for k, m in enumerate(stages):
        while total < m:
            c = min(m - total, PERMUTATION_CHUNK)
            perm = np.argsort(rng.random((c, n)), axis=1)
            hits += int(np.sum(stat(x[perm]) >= observed - tol))
            total += c
        p = (1 + hits) / (1 + total)
        if k >= len(PERMUTATION_GO_ON) or not p < PERMUTATION_GO_ON[k]:
            break
    return float(p)


def _sup_cusum(xs: np.ndarray) -> np.ndarray:
    e = xs - xs.mean(axis=1, keepdims=True)
    return np.abs(np.cumsum(e, axis=1)[:, :-1]).max(axis=1)


def cusum_permutation(x: np.ndarray, stages: tuple[int, ...] = PERMUTATION_STAGES[:2]) -> tuple[float, int]:
    """p-value of the sup |CUSUM| of a series of exchangeable units (weather blocks' sums or
    means) by permuting the units (permutation_p), and the index after which the mean
    changes. Exact under no change for any number of units; the asymptotic Kolmogorov p
    (Brownian bridge), with a long-run variance from a few dozen means, rejects far too
    often in the tail (1.4 % of 20,000 pure-noise series at 4e-4; 38 times the level at
    1e-4 for 40 independent normal means, tests/test_diagnose_competing.py)."""
    x = np.asarray(x, dtype=float)
    if len(x) < 6:
        return 1.0, 0
    _, k, _ = _cusum(x)
    return permutation_p(x, _sup_cusum, stages), k


def cusum_split(x: np.ndarray) -> int:
    """The index after which the mean of a series changes most (sup |CUSUM|)."""
    return _cusum(np.asarray(x, dtype=float))[1]


def split_time(t0: np.ndarray, t1: np.ndarray, k: int) -> float:
    """The time of a change after group k of groups spanning [t0, t1] in time order: midway
    between the end of group k and the start of group k + 1."""
    return float(0.5 * (t1[k] + t0[k + 1]))


def slope_permutation(t: np.ndarray, x: np.ndarray, stages: tuple[int, ...] = PERMUTATION_STAGES[:2]) -> float:
    """Two-sided p-value of the least-squares slope of x on t by permuting x's units
    (permutation_p; the statistic |sum (t - mean t) x|). Exact for exchangeable units; the
    slope's t test with a Bartlett long-run variance from a few dozen points rejected 27
    times the level at 1e-4 (the variance estimate is itself noisy, and t(n - 2) does not
    carry that)."""
    t = np.asarray(t, dtype=float)
    if len(t) < 6 or np.ptp(t) <= 0:
        return 1.0
    tc = t - t.mean()
    return permutation_p(x, lambda xs: np.abs(xs @ tc), stages)


def group_means(
    d: WindData, resid_trans: np.ndarray, groups: np.ndarray, sel: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Mean transverse residual (as a heading angle, rad), first and last time of each group
    (flights: d.flight; weather blocks: d.cluster) of the rows in `sel`, in time order."""
    s = np.ones(d.n, dtype=bool) if sel is None else sel
    uniq, inv = np.unique(groups[s], return_inverse=True)
    t = d.time_s[s]
    m = np.bincount(inv, resid_trans[s] / d.tas[s], len(uniq)) / np.bincount(inv, minlength=len(uniq))
    t0 = np.full(len(uniq), np.inf)
    t1 = np.full(len(uniq), -np.inf)
    np.minimum.at(t0, inv, t)
    np.maximum.at(t1, inv, t)
    order = np.argsort(t0, kind="stable")
    return m[order], t0[order], t1[order]


def _means_by_aircraft(
    d: WindData, fit: Fit, rows: np.ndarray | None, groups: np.ndarray, field: FieldKernel | None = None
):
    """(aircraft, mean offsets of its rows in each group, the groups' first and last times)
    of each aircraft with at least 2 MIN_FLIGHTS flights among `rows`, in time order (the
    scans' series; groups: d.flight or d.cluster). With the reference error's `field`, each
    row's residual less that field as the other aircraft's rows saw it (wind_field: a
    recalibrated aircraft against its neighbours in space and time, not the block's mean)."""
    r = np.ones(d.n, dtype=bool) if rows is None else rows[: d.n]
    res = fit.transverse_less_field(d, field)
    for i in range(len(d.names)):
        sel = (d.aircraft == i) & r
        if len(np.unique(d.flight[sel])) >= 2 * MIN_FLIGHTS:
            yield (i, *group_means(d, res, groups, sel))


def recalibration_scan(
    d: WindData, fit: Fit, rows: np.ndarray | None = None, field: FieldKernel | None = None
) -> dict[int, tuple[float, float]]:
    """Per aircraft: (p-value, time of the change) of a change in its mean offset: the sup
    |CUSUM| of its mean offsets over the tests' units (d.cluster: weather blocks, or
    flights where no reference error is shared between them), by permuting the units
    (cusum_permutation); against the other aircraft's view of the reference error `field`
    where the data show one (_means_by_aircraft). The asymptotic
    Kolmogorov p of the flight means' CUSUM that this replaces rejected 38 times its level
    at 1e-4 (40 independent means) and named a recalibration in noise once a held-out floor
    no longer hid it."""
    out = {}
    for i, m, t0, t1 in _means_by_aircraft(d, fit, rows, d.cluster, field):
        p, k = cusum_permutation(m, PERMUTATION_STAGES)
        out[i] = (p, split_time(t0, t1, k))
    return out


def selected_aircraft(p_values: dict[int, float]) -> dict[int, float]:
    """The scanned aircraft whose p-value, Bonferroni over the aircraft scanned, is below
    0.05: their adjusted p-values."""
    n_ac = max(len(p_values), 1)
    return {i: p * n_ac for i, p in p_values.items() if p * n_ac < 0.05}


def cand_recalibration(d: WindData, st: State, fit: Fit | None, rows: np.ndarray | None = None) -> list[Block]:
    if fit is None:
        return []
    scan = recalibration_scan(d, fit, rows, st.field)
    out = []
    for i, q in selected_aircraft({i: p for i, (p, _) in scan.items()}).items():
        t = scan[i][1]
        col = (d.aircraft == i) * d.tas * (d.time_s >= t)
        out.append(Block("recalibration", f"step@{t:.0f}", stack_channels(col, None, d.n)[:, None], i, p=q))
    return out


def drift_scan(
    d: WindData, fit: Fit, rows: np.ndarray | None = None, field: FieldKernel | None = None
) -> dict[int, float]:
    """Per aircraft: p-value of a linear trend of its mean offset over the tests' units it
    flew in (d.cluster: 6-h weather blocks, whose flights share the reference models'
    error, or flights where they share none; each unit's middle as its time), against the
    other aircraft's view of the reference error `field` where the data show one."""
    return {
        i: slope_permutation(0.5 * (t0 + t1) / 86400.0, m, PERMUTATION_STAGES)
        for i, m, t0, t1 in _means_by_aircraft(d, fit, rows, d.cluster, field)
    }


def fleet_contrasts(d: WindData, fit: Fit) -> dict[int, tuple[np.ndarray, np.ndarray]]:
    """Per aircraft: (mid-times (s), its mean offset (rad) in each weather block it flew
    minus the median of the other aircraft's mean offsets in the same block), over the blocks
    another aircraft also flew, in time order. A change the whole fleet shares (a reference
    model's upgrade, a fleet-wide step or trend) and the reference error every aircraft in a
    block shares cancel; what one aircraft does on its own is left."""
    g = pd.DataFrame({"ac": d.aircraft, "blk": d.block, "off": fit.resid[: d.n] / d.tas, "t": d.time_s}).groupby(
        ["blk", "ac"]
    )
    m = g["off"].mean().unstack()  # block x aircraft
    mid = (0.5 * (g["t"].min() + g["t"].max())).unstack()
    out = {}
    for i in m.columns:
        rest = m.drop(columns=i).median(axis=1)  # the median: the few aircraft that carry a change move it least
        ok = m[i].notna() & rest.notna()
        if ok.sum() >= 6:
            u = m.loc[ok, i] - rest[ok]
            t = mid.loc[ok, i].to_numpy()
            o = np.argsort(t, kind="stable")
            out[int(i)] = (t[o], u.to_numpy()[o])
    return out


def carried_by(d: WindData, fit: Fit, step_at_s: float) -> dict[str, dict[int, float]]:
    """Which aircraft carry a fleet-wide change in time, from their contrasts with the rest
    of the fleet (fleet_contrasts), per aircraft p-values by permuting its blocks (exact
    for exchangeable blocks): 'recalibration', a step at `step_at_s` (the fleet's change
    time, so a test of one split, not a scan); 'offset_drift', a slope in time. A change
    shared evenly leaves no aircraft's contrast changed; a fleet step or trend made by a
    few aircraft (their recalibration at one time, two drifting compasses) shows in theirs.
    Unadjusted p-values (the caller adjusts over aircraft)."""
    out: dict[str, dict[int, float]] = {"recalibration": {}, "offset_drift": {}}
    for i, (t, u) in fleet_contrasts(d, fit).items():
        out["offset_drift"][i] = slope_permutation(t / 86400.0, u)
        after = (t > step_at_s).astype(float)
        if 2 <= after.sum() <= len(t) - 2:
            out["recalibration"][i] = slope_permutation(after, u)  # |sum (after - mean) u|: one split
    return out


def cand_offset_drift(d: WindData, st: State, fit: Fit | None, rows: np.ndarray | None = None) -> list[Block]:
    """Per aircraft whose mean offset trends over its weather blocks (Bonferroni over
    aircraft): a free rate of its offset A (the recalibration's ramp counterpart)."""
    if fit is None:
        return []
    return [
        Block("offset_drift", "rate", drift_column(d, i)[:, None], i, p=q)
        for i, q in selected_aircraft(drift_scan(d, fit, rows, st.field)).items()
        if i not in st.drifts
    ]


# a library effect tested in more than one form: each form's p-value, the smallest times the
# number of forms (Bonferroni), and the form with it is the candidate's
FORMS: dict[str, tuple[Callable[..., list[Block]], ...]] = {"tas_scale": (cand_tas_scale, cand_tas_scale_fleet)}

# (d, st, fit) -> blocks; recalibration and offset_drift take the training rows too
CANDIDATES: dict[str, Callable[..., list[Block]]] = {
    "soft_iron": cand_soft_iron,
    "field_scaling": cand_field_scaling,
    "tas_scale": cand_tas_scale,
    "stale_declination": cand_stale_declination,
    "reference_bias": cand_reference_bias,
    "recalibration": cand_recalibration,
    "offset_drift": cand_offset_drift,
}
CHANNEL = {
    "soft_iron": "transverse",
    "field_scaling": "transverse",
    "tas_scale": "along",
    "stale_declination": "transverse",
    "reference_bias": "both",
    "recalibration": "transverse",
    "offset_drift": "transverse",
}


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
    return {
        "step": step,
        "log10_p": log10_p,
        "share_on_model_grid": share_model,
        "gain": {
            "metric": "ground-track jitter: |predicted - measured| RMS of segment-velocity differences (kt)",
            "measured_kt": meas,
            "predicted_before_kt": pred0,
            "predicted_after_kt": pred1,
            "before": abs(pred0 - meas),
            "after": abs(pred1 - meas),
            "held_out_before": before / 2,
            "held_out_after": after / 2,
        },
        "relative_gain": (before - after) / max(meas_all, 1e-9),
    }


# ----------------------------------------------------------------------------- fitting a candidate


def current_blocks(d: WindData, st: State) -> list[Block]:
    return base_blocks(d, st) + fixed_effect_blocks(d, st, None)


def build_blocks(eff: str, d: WindData, st: State, fit: Fit, rows: np.ndarray | None) -> list[Block]:
    if eff in ("recalibration", "offset_drift"):  # scans of mean offsets: on the training rows only
        return CANDIDATES[eff](d, st, fit, rows)
    return CANDIDATES[eff](d, st, fit)


def fit_with(
    d: WindData,
    st: State,
    y,
    clusters,
    eff: str,
    blocks: list[Block],
    rows=None,
    with_cov=True,
    basis: Basis | None = None,
    part: int | None = None,
) -> tuple[Fit, float]:
    """The current model plus `blocks`; for field_scaling, Gauss-Newton on gamma (returns
    the total change of gamma; 0 otherwise). With the round's `basis` (the current model
    decomposed once) a term other than the field scaling is fitted by partialling out:
    `part` None for all rows, k for the fit that predicts fold k (`rows` then unused)."""
    if basis is not None and eff != "field_scaling":
        return basis.fit(blocks, part, with_cov), 0.0
    if basis is not None:
        rows = None if part is None else train_rows(d, part)
    cur = current_blocks(d, st)
    fit = solve(cur + blocks, y, clusters, rows, with_cov, st.weights)
    if eff != "field_scaling":
        return fit, 0.0
    first = fit
    total = float(fit.coef("field_scaling")[0][1][0])
    for _ in range(3):
        st2 = replace(st, entered=list(st.entered), gamma=st.gamma + total)
        f0 = solve(current_blocks(d, st2), y, clusters, rows, False, st.weights)
        b2 = cand_field_scaling(d, st2, f0)
        if not b2:
            break
        f2 = solve(current_blocks(d, st2) + b2, y, clusters, rows, False, st.weights)
        step = float(f2.coef("field_scaling")[0][1][0])
        total += step
        fit = f2
        if abs(step) < 1e-3:
            break
    # the test of gamma = the model's is the first linearisation's (coefficient and its
    # covariance); the estimate and the residuals are the converged Gauss-Newton's
    beta = first.beta.copy()
    k = next(s for b, s in zip(first.blocks, first.slices, strict=False) if b.effect == "field_scaling")
    beta[k] = total
    return Fit(first.blocks, beta, first.cov, fit.resid, first.slices, first.clusters), total


def fold_fits(d: WindData, st: State, y, clusters) -> list[Fit]:
    """The current model fitted on each fold's training flights (fold k is held out from fit k)."""
    return [solve(current_blocks(d, st), y, clusters, train_rows(d, k), False, st.weights) for k in FOLDS]


def held_out_resid(
    d: WindData,
    st: State,
    y,
    clusters,
    eff: str,
    build=None,
    base: list[Fit] | None = None,
    basis: Basis | None = None,
) -> np.ndarray | None:
    """Residual of every row (2n, both channels) as predicted from the other folds: fold k's
    rows from the current model plus the effect learned on every fold but k (`build`: (blocks,
    channel) of a term given as columns; None: the effect's own candidate built on the
    training fold). None when the effect has no term to fit."""
    if basis is not None:
        base = [basis.base_fit(k) for k in FOLDS]
    base = base or fold_fits(d, st, y, clusters)
    out = np.empty(2 * d.n)
    for k in FOLDS:
        train, test = train_rows(d, k), rows_of_fold(d, k)
        blocks = build_blocks(eff, d, st, base[k], train) if build is None else build[0]
        if not blocks:
            return None
        f1, _ = fit_with(d, st, y, clusters, eff, blocks, train, False, basis, k)
        out[test] = f1.resid[test]
    return out


def base_held_out(d: WindData, base: list[Fit]) -> np.ndarray:
    """The current model's held-out residual per row (fold k's rows from fit k)."""
    out = np.empty(2 * d.n)
    for k in FOLDS:
        test = rows_of_fold(d, k)
        out[test] = base[k].resid[test]
    return out


def held_out(
    d: WindData, st: State, y, clusters, eff: str, build=None, base: list[Fit] | None = None
) -> tuple[float, float]:
    """RMS (kt) of the effect's channel on held-out flights, without and with the effect
    (parameters learned on the other folds). `base`: fold_fits of the current
    model, when the caller has them."""
    base = base or fold_fits(d, st, y, clusters)
    r1 = held_out_resid(d, st, y, clusters, eff, build, base)
    if r1 is None:
        return math.nan, math.nan
    ch = channel_rows(d.n, CHANNEL.get(eff, "transverse") if build is None else build[1])
    r0 = base_held_out(d, base)
    return math.sqrt(np.mean(r0[ch] ** 2)) / KT, math.sqrt(np.mean(r1[ch] ** 2)) / KT


def held_out_contest(r_x: np.ndarray, r_y: np.ndarray, clusters: np.ndarray) -> tuple[float, float]:
    """Whether explanation x predicts held-out rows better than explanation y: the
    difference of their held-out squared residuals summed per unit, D_b = SS_y,b - SS_x,b
    (`clusters`: the tests' independent units, weather blocks or flights), its mean over
    the G units against its standard error, Student's t with G - 1 degrees of freedom
    (a Diebold-Mariano comparison of two forecasts on clusters). Returns (t, one-sided p
    that x is no better than y)."""
    uniq, inv = np.unique(clusters, return_inverse=True)
    dss = np.bincount(inv, weights=r_y**2 - r_x**2, minlength=len(uniq))
    G = len(uniq)
    if G < 3:
        return 0.0, 1.0
    sd = float(np.std(dss, ddof=1))
    if sd <= 0:
        return 0.0, 1.0
    t = float(np.mean(dss)) / (sd / math.sqrt(G))
    return t, float(stats.t.sf(t, G - 1))


def rms_of_kt(resid: np.ndarray, n: int, channel: str) -> float:
    return float(math.sqrt(np.mean(resid[channel_rows(n, channel)] ** 2)) / KT)


def standard_errors(v: np.ndarray) -> np.ndarray:
    return np.sqrt(np.clip(np.diag(np.atleast_2d(v)), 0, None))
