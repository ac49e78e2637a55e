"""`aerotruth diagnose` on an observation table (aircraft wind reports with reference-model
winds, docs/data-formats.md): where the reports disagree with the simulation's model of the
wind sensors, which effect explains it, by how much, and what the extension gains on
flights it was not fitted on.

The data (wind paper section 5.1, `aerotruth.analysis.wind.heading_errors`): for every gated
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
times (a new offset A after each), aircraft whose offset drifts (a free rate of A in time),
the lat/lon quantization of the reports. The
harmonics are fitted for an aircraft only where its headings identify them (the
heading-correction method's coverage criterion); otherwise its offset A alone, said in
`model_fit`.

Effects library (each a departure from that model, its parameters linear given the
rest; `field_scaling` by Gauss-Newton on gamma):

    soft_iron          per aircraft D, E (2z): soft iron induced by the horizontal field
    field_scaling      gamma: hard-iron B, C grow as 1/H (magnetic latitude)
    tas_scale          per aircraft k: along residual = k TAS
    stale_declination  age a (years): transverse = a (-dD/dt)(lat, lon), D the IGRF declination;
                       one-sided towards an older table where the spec states a current one
                       (a receiver cannot carry a model newer than its data)
    reference_bias     per reference model b (kt along its wind): t = b w.n, a = b w.u; each
                       reference's b tested alone, Bonferroni over the references (where
                       there is a field, on the references' differences: wind_pairs)
                       (also as a scale s of its wind, error = s W, and which form fits better;
                       where a scale does, the error in the chosen forms is tested and held
                       out too: evidence["forms_chosen"])
    recalibration      per aircraft a step of A at an unknown time (CUSUM of its weather blocks' means)
    offset_drift       per aircraft A changing linearly in time (trend of its weather-block means)
    quantization       the reports' lat/lon grid is coarser (or finer) than the model's

The fit. Generalised least squares with a working covariance per (flight, reference) series
and channel (wind_weights): the reference error's correlation along the flight
(Ornstein-Uhlenbeck plus a white part, read off the ordinary fit of the model as given)
and each row's ground-track rounding variance (the data's position step over the span of
the two reports its ground velocity is taken over), so that a report that repeats its
neighbour's error, or whose ground track is short, counts for what it adds. Residuals,
held-out gains and every figure reported stay in the original units. It is the tests'
unit's covariance, used where the units are flights; where they are weather blocks (the
reference error a field the flights share) or the residual shows no correlation along
flights, the fit is the ordinary one (baseline "weights").

Evidence. Reference-model errors are one field over the region, correlated for hours, so
the flights of all aircraft in the same hours share them (on aerotruth's own simulated
reports, clustering on flights gave false reference biases): the tests' independent units
are 6-h weather blocks (wind_data.weather_blocks; each flight whole in the block of its
mid-time), unless the differences between two reference models at the same reports show
no error shared between flights (wind_data.reference_sharing, a sign-flip test; they carry
no aircraft error): then flights, which have the degrees of freedom the blocks pool
(wind_data.dependence_units; said in the report with the test's p). On those units: a Wald
test with the leave-one-unit-out (jackknife) covariance, F(q, G - 1); per-aircraft
parameters are tested aircraft by aircraft and the p-values combined by summing their
chi-square equivalents (Fisher-type). Where the units are weather blocks and the residual
shows the reference error as a field the aircraft share (wind_field), each aircraft's own
deviation terms (soft iron, field scaling: OWN_TERMS) are tested on the table less that
error as the other aircraft's rows saw it, which holds none of this aircraft's deviation;
a term the fleet shares is in those rows too and is tested on the table as it is; a
reference's bias, with two or more reference models, on the references' differences at the
same reports, where nothing of the aircraft is left (wind_pairs).
Changes in time are tested by permuting the units (exact for any number of them): an
aircraft's change-point (sup |CUSUM| of its units' mean offsets) and drift (their slope),
Bonferroni over aircraft, and the fleet's change-point and trend. Family-wise:
ALPHA_LIBRARY over the library's candidates of a round and ALPHA_SCREEN over the screening
tests, each Bonferroni-split (nominal 2 % in all), and divided by the round's number:
every round looks at the data again, so the r-th finding is named at 1/r of the first
one's level (on null data nearly every diagnosis ends in the first round, whose level is
unchanged; without it each later round's look would add up to the full 2 % of wrong
causes).

Gain. The tests' unit k in time (a flight or a weather block) goes to fold k mod N_FOLDS
(five folds, each spread over the whole period); each fold is predicted by parameters
learned on the other four and the residual RMS (kt) of the effect's channel measured on
it; an effect enters only if it lowers that held-out RMS (MIN_REL_GAIN). A scanned effect
(SCANNED: a recalibration, an offset drift) is held out with the aircraft and step times
its scan selects on all units, only its sizes learned out of fold.

Causes compete, not queue. Each round fits every candidate explanation on the current
model: the library's effects and the screening's signatures (effects outside the
library, below) together. A candidate term is fitted by partialling the current model out
of its columns (wind_model.Basis: Frisch-Waugh-Lovell, exactly the full fit). Of the
significant candidates with a held-out gain, the one with the largest held-out gain of
both channels leads (a library effect keeps the lead over a signature unless the
signature beats it and explains it away: `_lead`). Every other significant candidate is
then judged against the lead, and so is every candidate the data support at a nominal 5 %
(ALPHA_RIVAL: whether two explanations can be told apart does not hang on the second
reaching the level that names a cause): *separate* when still significant with the lead in the
model (it competes again in the next round; a rival only supported at ALPHA_RIVAL is left
apart only where the lead is itself still supported beside it: a lead that holds nothing
beside its rival is a partial copy of it, as a ramp fitted to a mid-period step is),
*beaten* when the lead predicts the held-out
units better (held_out_contest: the difference of the two explanations' held-out squared
residuals summed per unit, t two-sided at ALPHA_BEATS: the lead was chosen as the better
one on the same units), else *confusable*: the
finding then names both ("stale declination or a pitch-coupled term: these data cannot
tell"), never one of them alone, with what would tell them apart. Rounds repeat until no
candidate is left. A signature whose proxy models an attitude the table does not carry
(the pitch term: flight-path angle and angle of attack from the climb rate, altitude and
TAS) leaves what the proxy misses along those inputs; a later term in them is said as
confusable with the entered term's shape (PROXY_INPUTS), never as a second cause alone.

Screening (effects outside the library): each channel against heading harmonics (3z in
the transverse channel, z..3z along), roll, flight phase, turn rate, pressure altitude,
TAS, latitude, time, the pitch attitude (flight-path angle, q_250/q and q_cruise/q: the
angle of attack's shape at one weight and at one cruise lift coefficient), the local
solar hour (a diurnal term) and a pendulous flux valve's acceleration error (tan I
(dTAS/dt)/g sin z_mag: a speed change tilts the valve, which then reads part of the
vertical field); a least-squares periodogram of the flight-mean residuals; a
fleet-wide change-point. Each covariate's noise is independent of the residual's: the
turn rate comes from the report's neighbours' headings, never its own (whose error is in
the transverse residual: an own-heading rate made white heading noise look like a turning
error, errors in variables), the climb rates from altitudes (which do not enter the
residual), the TAS rate from the neighbours' TAS. A
signature that enters is reported by its text ("transverse residual ~
pressure_altitude_ft, 0.05 deg per 1000 ft") and becomes a linear term of the model.

A fleet-wide change in time (the fleet's step, its trend) named as a signature is often a
few aircraft's: three aircraft recalibrated on one day step the fleet's mean by a quarter
of their step. Each aircraft's weather-block offsets minus the median of the other
aircraft's in the same block (wind_model.fleet_contrasts: a change the whole fleet shares
cancels, and so does the reference error the block's flights share) are tested for a step
at the fleet's change time and for a slope (blocks permuted, Bonferroni over aircraft at
0.05); the aircraft that carry it are named with the signature as confusable
(recalibration or offset drift of those aircraft).
"""

from __future__ import annotations

import datetime as dt
import math
from collections.abc import Callable
from dataclasses import replace
from typing import Any, NotRequired, TypedDict

import numpy as np

from aerotruth.analysis.diagnose.wind_data import (  # noqa: F401  (prepare re-exported)
    N_FOLDS,
    WindData,
    prepare,
    unit_words,
    units_reason,
)
from aerotruth.analysis.diagnose.wind_field import fit_field_kernel
from aerotruth.analysis.diagnose.wind_model import (  # noqa: F401  (WindModelSpec, wind_model_from_campaign re-exported)
    CANDIDATES,
    CHANNEL,
    FOLDS,
    FORMS,
    MIN_COVERAGE,
    Basis,
    Block,
    Fit,
    State,
    WindModelSpec,
    base_held_out,
    block_p,
    build_blocks,
    carried_by,
    channel_rows,
    choose_deviation_heading,
    covariate,
    current_blocks,
    cusum_permutation,
    cusum_split,
    declination_identifiable,
    fit_with,
    fold_fits,
    group_means,
    held_out,
    held_out_contest,
    held_out_resid,
    initial_state,
    known_offsets,
    quantization_candidate,
    reference_bias_column,
    reference_scale_column,
    rms_of_kt,
    selected_aircraft,
    signature_column,
    slope_permutation,
    solve,
    split_time,
    stack_channels,
    standard_errors,
    term_center,
    wind_model_from_campaign,
)
from aerotruth.analysis.diagnose.wind_pairs import reference_difference_test
from aerotruth.analysis.diagnose.wind_weights import working_weights
from aerotruth.analysis.least_squares import clustered_se
from aerotruth.analysis.wind.heading_correction import heading_spread
from aerotruth.units import DEG, KT

# the library's family-wise level (first round): 1 %, with the screening's 1 % a nominal 2 %.
# At 3 % aerotruth's own sensors' null carried 8 findings in 100 datasets (reference bias
# and TAS scale at one to three times the 1 % level: validation/diagnose_confusion_plan.md,
# "The library's level at 3 %"), above the 5 % null budget; at 1 %, 5 of 100.
ALPHA_LIBRARY = 0.01
ALPHA_SCREEN = 0.01
MAX_ROUNDS = 10
MAX_SCREENED = 3  # screening signatures entered at most (each a term outside the library)
MIN_BLOCKS = 20  # fewest weather blocks (independent clusters) for any test: CR1 with fewer over-rejects
# an effect must also predict: the held-out RMS must drop (relative gain > MIN_REL_GAIN). A
# floor in relative RMS (0.2 % was tried) is not a size that matters: the same heading error
# is a larger share of a residual whose reference winds are better, and at the confusion
# plan's sizes it rejected effects significant at p 2e-5 to 6e-4 whose held-out gains were
# 0.05-0.2 % (4-kt reference errors). What an effect is worth is its size, reported with it.
MIN_REL_GAIN = 0.0


def held_out_words(d: WindData) -> str:
    return (
        f"{unit_words(d)} in {N_FOLDS} folds (the k-th in time in fold k mod {N_FOLDS}); each fold predicted by "
        "what the others learned"
    )


# candidates tested by a scan of each aircraft's series of mean offsets (p-values Bonferroni over aircraft),
# not by the Wald test of their fitted columns (chosen by the scan, those would over-reject)
SCANNED = {
    "recalibration": "sup |CUSUM| of the aircraft's means over its {units}, permuted, Bonferroni over aircraft",
    "offset_drift": "slope in time of the aircraft's means over its {units}, permuted, Bonferroni over aircraft",
}

# terms each aircraft has on its own (its deviation's twice-round part, its once-round part's
# growth where the magnetic field is weak): where the data show a reference error field the
# aircraft share (wind_field), tested on the table less that field as the other aircraft saw
# it, as the recalibration and drift scans are (the other aircraft's rows carry their own
# terms of the kind too; on shared routes a little of them is in the field subtracted). A
# term the fleet shares (a reference's bias, a stale declination, a TAS scale) is in the
# other aircraft's rows too, and is tested on the table as it is.
OWN_TERMS = {"soft_iron", "field_scaling"}
OWN_TEST = "cluster-robust Wald on {units}, against the reference error as the other aircraft saw it"


def _wald_words(st: State, eff: str) -> str:
    if eff == "reference_bias" and st.reference_pairs is not None:
        return st.reference_pairs["test"]
    return OWN_TEST if st.field is not None and eff in OWN_TERMS else "cluster-robust Wald on {units}"


CAUSES = {
    "soft_iron": "the heading error goes twice round with the heading (2z): soft iron magnetised by the horizontal "
    "field",
    "field_scaling": "the once-round deviation grows where the horizontal field is weak (~1/H): permanent (hard-iron) "
    "magnetism",
    "tas_scale": "the true airspeed reads off by a constant factor: air-data calibration (static source, temperature "
    "probe)",
    "stale_declination": "the receiver converts magnetic to true heading with an old declination model: the error "
    "follows the field's secular change across the network",
    "reference_bias": "a reference model's wind is biased along the wind (too strong or too weak): the reference, not "
    "the aircraft",
    "recalibration": "an aircraft's heading offset changed at one time: a recalibration, a swung compass or a replaced "
    "valve",
    "offset_drift": "an aircraft's heading offset changes steadily with time: a deviation that is not stationary (wind "
    "paper section 8), e.g. slowly changing airframe magnetism or a degrading compass system",
    "quantization": "the reports' latitude and longitude are rounded to a coarser grid than the model's: noisier "
    "ground tracks",
}


def cause(eff: str, params: dict) -> str:
    """The finding's cause in words, its direction from the fitted parameters where the
    effect can go either way against the model (field scaling, the reports' grid) or take
    two forms (a reference's offset along its wind or scale of it)."""
    if eff == "field_scaling":
        g, g0 = params["gamma"]["value"], params["gamma"]["model"]
        if g < g0:
            return (
                f"the once-round deviation depends on the horizontal field less than the model says (gamma {g:.2f} "
                f"against the model's {g0:g}; 1: hard iron, ~1/H; 0: the same at every field): part of it is not "
                "magnetic, e.g. an error of the heading system's synchro or resolver transmission"
            )
        return CAUSES[eff] + f" (gamma {g:.2f} against the model's {g0:g})"
    if eff == "reference_bias":
        name, x = max(params["bias_kt"].items(), key=lambda kv: abs(kv[1]["value"]))
        if x["form"] == "scale":
            return (
                f"a reference model's wind is too {'strong' if x['scale']['value'] > 0 else 'weak'} in proportion to "
                f"its speed ({name}: {100 * x['scale']['value']:+.1f} %, a scale fits its rows better than an offset "
                "along the wind): the reference, not the aircraft"
            )
    if eff == "quantization" and params["lat_lon_step_deg"]["value"] < params["lat_lon_step_deg"]["model"]:
        return (
            "the reports' latitude and longitude are rounded to a finer grid than the model's: the model's ground "
            "tracks are noisier than the data's"
        )
    return CAUSES[eff]


# ----------------------------------------------------------------------------- the loop


def _iso(t: float) -> str:
    return (dt.datetime(1970, 1, 1) + dt.timedelta(seconds=float(t))).isoformat(timespec="minutes") + "Z"


def _parameters(eff: str, d: WindData, fit: Fit, dgamma: float, st: State) -> dict:
    parts = fit.coef(eff)
    r2d = 1 / DEG
    per: dict[str, dict[str, Any]]  # per aircraft (per reference model): the effect's numbers and words
    if eff == "soft_iron":
        per = {
            d.names[b.aircraft]: {
                "D_deg": float(be[0] * r2d),
                "E_deg": float(be[1] * r2d),
                "D_se_deg": float(standard_errors(v)[0] * r2d),
                "E_se_deg": float(standard_errors(v)[1] * r2d),
            }
            for b, be, v in parts
        }
        a2 = np.mean([x["D_deg"] ** 2 + x["E_deg"] ** 2 for x in per.values()])
        s2 = np.mean([x["D_se_deg"] ** 2 + x["E_se_deg"] ** 2 for x in per.values()])
        amp = math.sqrt(max(float(a2 - s2), 0.0))
        return {
            "amplitude_deg": {
                "value": amp,
                "se": math.sqrt(s2 / max(len(per), 1)),
                "meaning": "RMS over aircraft of the 2z amplitude sqrt(D^2 + E^2), noise-debiased",
            },
            "aircraft": per,
        }
    if eff == "field_scaling":
        se = float(standard_errors(parts[0][2])[0])
        return {
            "gamma": {
                "value": st.gamma + dgamma,
                "se": se,
                "model": st.gamma,
                "meaning": "B, C ~ (H0/H)^gamma, H0 the median horizontal field of the reports",
            },
            "H_ratio_range": [float(1 / d.h_ratio.max()), float(1 / d.h_ratio.min())],
        }
    if eff == "tas_scale" and parts and parts[0][0].aircraft < 0:  # one scale for the fleet
        k, se = float(parts[0][1][0]), float(standard_errors(parts[0][2])[0])
        return {
            "k_median": {"value": k, "se": se, "meaning": "TAS reads (1 + k) x true, one k for the fleet"},
            "form": "fleet",
            "aircraft": {
                d.names[i]: {"k": k, "se": se}
                for i in range(len(d.names))
                if np.any(parts[0][0].cols[d.n :][d.aircraft == i])
            },
        }
    if eff == "tas_scale":
        per = {d.names[b.aircraft]: {"k": float(be[0]), "se": float(standard_errors(v)[0])} for b, be, v in parts}
        ks = np.array([x["k"] for x in per.values()])
        ses = np.array([x["se"] for x in per.values()])
        return {
            "k_median": {
                "value": float(np.median(ks)),
                "se": float(1.2533 * np.sqrt(np.mean(ses**2) / len(ks))),
                "meaning": "TAS reads (1 + k) x true",
            },
            "aircraft": per,
        }
    if eff == "stale_declination":
        be, v = parts[0][1], parts[0][2]
        return {
            "age_yr": {
                "value": float(be[0]) + st.spec.declination_age_yr,
                "se": float(standard_errors(v)[0]),
                "meaning": "the receivers' declination model is this many years older than the data",
            },
            "identifiable_share": declination_identifiable(d),
        }
    if eff == "reference_bias":
        per = {}
        for b, be, v in parts:
            per[b.label] = {
                "value": float(be[0]),
                "se": float(standard_errors(v)[0]),
                **_bias_or_scale(d, fit, d.sources.index(b.label), float(be[0])),
            }
        return {
            "bias_kt": per,
            "meaning": "reference wind = truth + b along the wind; or truth x (1 + s), `form` the "
            "one of the two that fits the model's rows better",
        }
    if eff == "offset_drift":
        per = {}
        for b, be, v in parts:
            t = d.time_s[d.aircraft == b.aircraft]
            days = float((t.max() - t.min()) / 86400.0)
            rate, se = float(be[0] * r2d), float(standard_errors(v)[0] * r2d)
            per[d.names[b.aircraft]] = {
                "rate_deg_per_day": rate,
                "se_deg_per_day": se,
                "days": days,
                "change_deg": rate * days,
                "from_utc": _iso(float(t.min())),
                "to_utc": _iso(float(t.max())),
            }
        return {"aircraft": per, "meaning": "offset A = A_mid + rate x (t - middle of the aircraft's data)"}
    if eff == "recalibration":
        return {
            "steps": {
                d.names[b.aircraft]: {
                    "time_utc": _iso(float(b.label.split("@")[1])),
                    "time_s": float(b.label.split("@")[1]),
                    "step_deg": float(be[0] * r2d),
                    "se_deg": float(standard_errors(v)[0] * r2d),
                }
                for b, be, v in parts
            }
        }
    raise KeyError(eff)


def _bias_or_scale(d: WindData, fit: Fit, m: int, bias_kt: float) -> dict:
    """Reference m's error along its wind as an offset b (kt, the library's form) or as a
    scale s of its wind (error = s W): each fitted alone to that model's rows of the
    residual with the fitted bias term (`bias_kt`) put back, the one with the smaller
    residual sum of squares is `form` (both have one parameter); s with its weather-block
    clustered se."""
    col = reference_bias_column(d, m)
    rows = col != 0
    r0 = (fit.resid + col * bias_kt)[rows]  # m/s

    def fitted(x: np.ndarray) -> tuple[float, np.ndarray, float]:
        sxx = float(x @ x)
        c = float(x @ r0) / sxx
        return c, r0 - c * x, sxx

    _, e_off, _ = fitted(col[rows])
    s, e, sxx = fitted(x := reference_scale_column(d, m)[rows])
    se, _ = clustered_se(x * e, fit.clusters[rows], sxx)
    ratio = float(e @ e) / float(e_off @ e_off)
    return {
        "scale": {"value": s, "se": se, "meaning": "reference wind = truth x (1 + s)"},
        "form": "scale" if ratio < 1 else "offset",
        "rss_scale_over_offset": ratio,
    }


def _forms_chosen(d: WindData, st: State, y: np.ndarray, clusters: np.ndarray, base: list[Fit], per: dict) -> dict:
    """The reference error tested and held out as the extended model carries it: each
    reference in the form (`per[src]["form"]`) that fits its rows (the library's candidate,
    whose test and gain the finding reports, is the offset along the wind)."""
    blocks = [
        Block(
            "reference_bias",
            src,
            (reference_scale_column if per[src]["form"] == "scale" else reference_bias_column)(d, m)[:, None],
        )
        for m, src in enumerate(d.sources)
        if src in per
    ]
    fit, _ = fit_with(d, st, y, clusters, "reference_bias", blocks)
    b_ho, a_ho = held_out(d, st, y, clusters, "reference_bias", (blocks, CHANNEL["reference_bias"]), base)
    return {
        "forms": {src: x["form"] for src, x in per.items()},
        "p_value": block_p(fit, "reference_bias", d),
        "held_out_before": b_ho,
        "held_out_after": a_ho,
        "test": f"on the table (each model's rows), cluster-robust Wald on {unit_words(d)}; held out as the "
        "finding's gain",
    }


def _size(eff: str, params: dict) -> float:
    """One number for the effect's size (what the tests compare)."""
    return {
        "soft_iron": lambda p: p["amplitude_deg"]["value"],
        "field_scaling": lambda p: p["gamma"]["value"],
        "tas_scale": lambda p: p["k_median"]["value"],
        "stale_declination": lambda p: p["age_yr"]["value"],
        "reference_bias": lambda p: max((x["value"] for x in p["bias_kt"].values()), key=abs),
        "recalibration": lambda p: max((x["step_deg"] for x in p["steps"].values()), key=abs),
        "offset_drift": lambda p: max((x["rate_deg_per_day"] for x in p["aircraft"].values()), key=abs),
        "quantization": lambda p: p["lat_lon_step_deg"]["value"],
    }[eff](params)


def _plot_data(d: WindData, fit0: Fit, fit1: Fit, eff: str, channel: str) -> dict:
    """Added-variable view: the residual without the effect and with it, against the
    effect's fitted term (deg transverse, kt along); a per-aircraft effect on some of the
    fleet shows those aircraft's rows (the others' term is 0 and would fill the view)."""
    term = np.zeros(2 * d.n)
    concerned = set()
    for b, s in zip(fit1.blocks, fit1.slices, strict=False):
        if b.effect in (eff, "screen"):
            term += b.cols @ fit1.beta[s]
            concerned.add(b.aircraft)
    m = channel_rows(d.n, "transverse" if channel == "both" else channel)
    if -1 not in concerned and len(concerned) < len(d.names):
        m &= np.tile(np.isin(d.aircraft, list(concerned)), 2)
    scale = np.r_[d.tas, np.full(d.n, KT)][m]
    unit = "deg" if channel != "along" else "kt"
    conv = (1 / DEG) if unit == "deg" else 1.0
    return {
        "x": term[m] / scale * conv,
        "before": fit0.resid[m] / scale * conv,
        "after": fit1.resid[m] / scale * conv,
        "unit": unit,
        "channel": "transverse" if channel == "both" else channel,
    }


# a finding is named alone only where it predicts held-out units better than each rival at this
# level, two-sided: the lead is the candidate with the larger held-out gain on the same units,
# so a one-sided test in the direction the data chose has twice its size for rivals that are
# equally good (an offset drift led a recalibration by a held-out gain and "beat" it at
# one-sided p 0.046 where the step was the truth, seed 70001 with flights as units)
ALPHA_BEATS = 0.05


def _beats(p_not_beaten: float) -> bool:
    """Whether the lead beats a rival: the contest's one-sided p below half of ALPHA_BEATS."""
    return p_not_beaten < ALPHA_BEATS / 2


# a rival is any candidate the data support at this nominal level (with a held-out gain), not
# only those significant at the family-wise level that lets a cause be named: whether two
# explanations can be told apart does not depend on the second reaching that level. With
# the family-wise level only, a TAS-linear heading error (the independent generator's
# airspeed effect, TAS and altitude correlated 0.8 over the flights) was named as an
# altitude term alone where TAS fell short of the level (p 1.3e-3, seed 70010)
ALPHA_RIVAL = 0.05


class _Cand(TypedDict):
    """A candidate explanation of a round: a library effect, a screening signature or the
    reports' grid (`kind`)."""

    effect: str  # library name, or "unexplained:<key>"
    kind: str  # "library", "screen", "quantization"
    p: float
    level: float
    held_out: tuple[float, float]  # RMS (kt) of its channel, held out, before and after
    rel: float  # relative held-out gain on its channel
    gain_all: float  # relative held-out gain of the squared residuals of both channels (the common yardstick)
    channel: str
    fit: NotRequired[Fit]
    blocks: NotRequired[list[Block]]
    resid_ho: NotRequired[np.ndarray]
    dgamma: NotRequired[float]
    sigs: NotRequired[list[dict]]
    key: NotRequired[str]
    q: NotRequired[dict[str, Any]]
    # how the candidate is tested when it is a rival (_rivals): its test's own basis (OWN_TERMS:
    # the table less the field), or a p that no term of the aircraft's model changes (a
    # reference's bias on the references' differences)
    test_basis: NotRequired[Any]
    p_given_any: NotRequired[float]


def _gains(d, r0: np.ndarray, r1: np.ndarray, ss0: float, channel: str) -> tuple[tuple[float, float], float, float]:
    """A candidate's held-out RMS (kt) of its channel before and after, its relative gain
    there, and the relative gain of both channels' squared residuals (_Cand's held_out,
    rel and gain_all)."""
    m = channel_rows(d.n, channel)
    b_ho, a_ho = math.sqrt(np.mean(r0[m] ** 2)) / KT, math.sqrt(np.mean(r1[m] ** 2)) / KT
    rel = (b_ho - a_ho) / b_ho if b_ho > 0 else 0.0
    return (b_ho, a_ho), rel, (ss0 - float(np.sum(r1**2))) / ss0 if ss0 > 0 else 0.0


def _library_level(look: int) -> float:
    """A library candidate's level in the round's look (module docstring: family-wise):
    ALPHA_LIBRARY over the candidates and the reports' grid, over the look."""
    return ALPHA_LIBRARY / (len(CANDIDATES) + 1) / look


def _library_candidates(d, st, y, clusters, fit0, basis, r0, look: int = 1) -> list[_Cand]:
    level = _library_level(look)
    ss0 = float(np.sum(r0**2))
    out: list[_Cand] = []
    # the round's model on the table less the field the other aircraft saw (OWN_TERMS' tests)
    own = (
        Basis(d, st, y - fit0.field_of(d, st.field), clusters)
        if st.field is not None and OWN_TERMS - set(st.entered)
        else None
    )
    for eff in CANDIDATES:
        if eff in st.entered:
            continue
        build = None
        test_basis, p_given_any = None, None
        if eff in FORMS:
            # p: the smallest form's, Bonferroni over the forms; the form: of those significant
            # at the library's level, the one that predicts held-out blocks best (a form with
            # a parameter per aircraft can be significant and still predict worse than one
            # for the fleet), else the one with the smallest p
            forms = [(blocks, basis.fit(blocks)) for f in FORMS[eff] if (blocks := f(d, st, fit0))]
            if not forms:
                continue
            ps = [min(1.0, block_p(f1, eff, d) * len(forms)) for _, f1 in forms]
            sig = [k for k, q in enumerate(ps) if q < level]
            if len(sig) > 1:
                ho = [held_out_resid(d, st, y, clusters, eff, (forms[k][0], CHANNEL[eff]), basis=basis) for k in sig]
                ss = [float(np.sum(r**2)) if r is not None else math.inf for r in ho]
                k = sig[int(np.argmin(ss))]
            else:
                k = int(np.argmin(ps))
            blocks, fit1 = forms[k]
            p, dg = min(ps), 0.0
            build = (blocks, CHANNEL[eff])
        else:
            blocks = build_blocks(eff, d, st, fit0, None)
            if not blocks:
                continue
            fit1, dg = fit_with(d, st, y, clusters, eff, blocks, basis=basis)
            if eff in SCANNED:
                scanned = [b.p for b in blocks if b.p is not None]
                assert len(scanned) == len(blocks)  # a scan's blocks each carry its p-value
                p = min(scanned)
                # held out with the aircraft and step times the scan selects on all units,
                # only the sizes learned out of fold: a step time that one fold's scan
                # misplaces would otherwise be judged by the misplacement (a ramp then
                # predicts that fold better than the step it stands for)
                build = (blocks, CHANNEL[eff])
            elif own is not None and eff in OWN_TERMS:  # the partialled fit on the table less the field
                p = block_p(own.fit(blocks), eff, d)
                test_basis = own
            elif eff == "reference_bias" and st.reference_pairs is not None:  # the references side by side
                p = st.reference_pairs["p"]
                p_given_any = p
            else:  # field scaling: the test of its first linearisation, the partialled fit's (jackknife)
                p = block_p(fit1 if eff != "field_scaling" else basis.fit(blocks), eff, d)
        r1 = held_out_resid(d, st, y, clusters, eff, build, basis=basis)
        if r1 is None:
            continue
        held, rel, gain_all = _gains(d, r0, r1, ss0, CHANNEL[eff])
        cand: _Cand = {
            "effect": eff,
            "kind": "library",
            "p": p,
            "level": level,
            "held_out": held,
            "rel": rel,
            "gain_all": gain_all,
            "channel": CHANNEL[eff],
            "fit": fit1,
            "blocks": blocks,
            "resid_ho": r1,
            "dgamma": dg,
        }
        if test_basis is not None:
            cand["test_basis"] = test_basis
        if p_given_any is not None:
            cand["p_given_any"] = p_given_any
        out.append(cand)
    q = _quantization(d, st, look)
    if q is not None:
        out.append(q)
    return out


def _quantization(d, st, look: int = 1) -> _Cand | None:
    """The reports' grid as a candidate (a test on the coordinates; no fit), None once it
    entered or where the grid is the model's."""
    q = None if "quantization" in st.entered else quantization_candidate(d, st.spec.lat_lon_step_deg)
    if q is None:
        return None
    return {
        "effect": "quantization",
        "kind": "quantization",
        "p": 10 ** max(q["log10_p"], -300),
        "level": _library_level(look),
        "held_out": (q["gain"]["held_out_before"], q["gain"]["held_out_after"]),
        "rel": q["relative_gain"],
        "gain_all": q["relative_gain"],
        "channel": "ground track",
        "q": q,
    }


def _screen_candidates(d, st, y, clusters, fit0, basis, r0, done: set[str], look: int = 1) -> list[_Cand]:
    """The screening signatures not yet entered (module docstring), each as a candidate."""
    all_tests = _screen_tests(d, st.spec)
    level = ALPHA_SCREEN / (len(all_tests) + 2) / look
    ss0 = float(np.sum(r0**2))

    def test_of(ch: str, covs: list[str]) -> Callable[..., float]:
        if covs == ["time_days"]:  # a trend in time: its blocks permuted
            return lambda f1: _trend_p(d, fit0, ch)
        return lambda f1: block_p(f1, "screen", d)

    tests: list[tuple[str, list[str], str, Callable[..., float]]] = [
        (ch, covs, f"{ch}:{'+'.join(covs)}", test_of(ch, covs))
        for ch, covs in all_tests
        if f"{ch}:{'+'.join(covs)}" not in done
    ]
    per = _periodic(d, fit0)
    if per is not None and "periodic" not in done:
        period, M = per
        tests.append(
            (
                "transverse",
                [f"period_{period:.0f}_sin", f"period_{period:.0f}_cos"],
                "periodic",
                lambda f1, M=M: min(1.0, M * block_p(f1, "screen", d)),
            )
        )
    bm, t0, t1 = group_means(d, fit0.resid[: d.n], d.cluster)
    p_cp, k = cusum_permutation(bm)
    if p_cp < level and len(bm) > 1 and "fleet_step" not in done:
        tests.append(("transverse", [f"fleet_step_{split_time(t0, t1, k):.0f}"], "fleet_step", lambda f1, p=p_cp: p))
    out: list[_Cand] = []
    for ch, covs, key, p_of in tests:
        blocks, sigs = _screen_blocks(d, ch, covs)
        fit1 = basis.fit(blocks)
        p = p_of(fit1)
        if not p < max(level, ALPHA_RIVAL):  # held out only where it could enter or rival (the cost of a round)
            out.append(
                {
                    "effect": f"unexplained:{key}",
                    "kind": "screen",
                    "p": p,
                    "level": level,
                    "held_out": (math.nan, math.nan),
                    "rel": 0.0,
                    "gain_all": 0.0,
                    "channel": ch,
                    "key": key,
                }
            )
            continue
        r1 = held_out_resid(d, st, y, clusters, "screen", (blocks, ch), basis=basis)
        assert r1 is not None  # the term's columns are given
        held, rel, gain_all = _gains(d, r0, r1, ss0, ch)
        out.append(
            {
                "effect": f"unexplained:{key}",
                "kind": "screen",
                "p": p,
                "level": level,
                "held_out": held,
                "rel": rel,
                "gain_all": gain_all,
                "channel": ch,
                "fit": fit1,
                "blocks": blocks,
                "resid_ho": r1,
                "sigs": sigs,
                "key": key,
            }
        )
    return out


def _trend_p(d: WindData, fit0: Fit, channel: str) -> float:
    """p-value of a fleet-wide trend in time of a channel's residual: the slope of its
    weather blocks' means (transverse as a heading angle) against the blocks' mid-times, by
    permuting the blocks (slope_permutation, exact). The Wald test of a time column on
    ~30 blocks with the jackknife covariance rejects ~1.75 times its level near 4e-4 (a
    regressor that changes only from block to block is its worst case), and a fleet trend
    of p 4e-4 came up after soft iron on the independent generator's data."""
    res = fit0.resid[: d.n] if channel == "transverse" else fit0.resid[d.n :] * d.tas  # along: m/s after / TAS
    m, t0, t1 = group_means(d, res, d.cluster)
    return slope_permutation(0.5 * (t0 + t1), m)


def _best_given_rival(d, basis, best: _Cand, c: _Cand) -> float:
    """The best explanation's p with rival c's terms in the model, in the best one's own
    test (its basis; a p that no term of the model changes stays as it is)."""
    if "p_given_any" in best:
        return best["p_given_any"]
    rb = [replace(b, effect="rival", p=None) for b in c["blocks"]]
    joint = best.get("test_basis", basis).fit(rb + best["blocks"])
    return block_p(joint, best["blocks"][0].effect, d)


def _rivals(d, basis, best: _Cand, others: list[_Cand]) -> list[dict]:
    """What the round's best explanation is against each other explanation the data support.

    For each rival y (significant, or supported at ALPHA_RIVAL: *weak*; with a held-out
    gain): first whether y is a *separate* effect, still significant at its own level with
    the best one in the model (then it competes in a later round; a weak rival still
    supported at ALPHA_RIVAL is *apart*: another thing, too weak to name, and left out, but
    only where the best one is itself still supported at ALPHA_RIVAL beside y: a best one
    that holds nothing beside y is a partial copy of y, which holds what it explains and
    more, as a ramp fitted to an offset's step in the middle of the period is; then, as
    below, beaten or confusable); else y explains what the best one explains, and the best
    one is named alone only if it *beats* y: predicts the held-out units better
    (held_out_contest, two-sided at ALPHA_BEATS: _beats). A rival it does not beat is
    *confusable* with it: the finding names both."""
    out = []
    clusters2 = np.r_[d.cluster, d.cluster]
    for c in others:
        if "p_given_any" in c:  # no term of the model enters its test: given the best, the same
            p_sep = c["p_given_any"]
        else:  # in its own test's basis (OWN_TERMS: the table less the field)
            rb = [replace(b, effect="rival", p=None) for b in c["blocks"]]  # sign kept: the rival's own test
            joint = c.get("test_basis", basis).fit(best["blocks"] + rb)
            p_sep = block_p(joint, "rival", d)
        t, p_beat = held_out_contest(best["resid_ho"], c["resid_ho"], clusters2)
        weak = not c["p"] < c["level"]
        p_back = None
        if p_sep < (ALPHA_RIVAL if weak else c["level"]):
            verdict = "apart" if weak else "separate"
            if weak:  # apart only if the best one holds something of its own beside it
                p_back = _best_given_rival(d, basis, best, c)
                if not p_back < ALPHA_RIVAL:
                    verdict = "beaten" if _beats(p_beat) else "confusable"
        else:
            verdict = "beaten" if _beats(p_beat) else "confusable"
        out.append(
            {
                "effect": c["effect"],
                "verdict": verdict,
                "p_best_given_it": p_back,
                "p_given_best": p_sep,
                "held_out_t": t,
                "p_not_beaten": p_beat,
                "held_out_gain_all": c["gain_all"],
                "candidate": c,
            }
        )
    return out


def _lead(d, basis, ok: list[_Cand]) -> _Cand:
    """The round's finding among the significant candidates with a held-out gain. The
    reports' grid first where it is off (a test on the coordinates, independent of the wind
    residual). Otherwise the largest held-out gain of both channels, with one order between
    the kinds: a signature outside the library leads a library effect only where it beats
    the best library candidate on held-out blocks *and* explains it away (the library effect
    no longer significant with the signature in the model). A fleet-wide signature is often
    a coarse copy of a per-aircraft effect (a fleet time trend of two aircraft's drift, a
    fleet step of three aircraft's recalibration) that the data cannot yet resolve; the
    library's physical explanation keeps the lead unless the data reject it."""
    quant = [c for c in ok if c["kind"] == "quantization"]
    if quant:
        return quant[0]
    best = max(ok, key=lambda c: c["gain_all"])
    lib = [c for c in ok if c["kind"] == "library"]
    if best["kind"] != "screen" or not lib:
        return best
    best_lib = max(lib, key=lambda c: c["gain_all"])
    (r,) = _rivals(d, basis, best, [best_lib])
    return best if r["verdict"] == "beaten" else best_lib


def _screen_finding(d, st, fit0, c: _Cand, plots: dict) -> Any:
    from aerotruth.analysis.diagnose.modes import Finding

    ch, sigs, key, fit1 = c["channel"], c["sigs"], c["key"], c["fit"]
    beta = fit1.coef("screen")[0][1]
    cov = fit1.coef("screen")[0][2]
    for sg, b in zip(sigs, beta, strict=False):  # deg per unit (transverse), kt per unit (along)
        sg["slope"] = float(b)
    text = _signature_text(sigs, beta)
    params: dict[str, Any] = {
        "signature": text,
        "terms": [dict(sg, se=float(e)) for sg, e in zip(sigs, standard_errors(cov), strict=False)],
    }
    pitch = sigs[0]["covariate"] == "flight_path_angle_deg"  # its size: deg per deg of flight-path angle
    params["size"] = float(beta[0]) if len(beta) == 1 or pitch else float(math.hypot(*beta[:2]))
    evidence = {
        "test": f"cluster-robust Wald on {unit_words(d)} (screening)"
        if not key.startswith(("periodic", "fleet_step"))
        else (
            f"strongest period of the flight means' periodogram; cluster-robust Wald on {unit_words(d)} x M frequencies"
            if key == "periodic"
            else f"sup-CUSUM of the fleet's means over {unit_words(d)}"
        ),
        "p_value": c["p"],
        "alpha": c["level"],
    }
    gain = {
        "metric": f"RMS of the {ch} wind residual (kt)",
        "before": rms_of_kt(fit0.resid, d.n, ch),
        "after": rms_of_kt(fit1.resid, d.n, ch),
        "held_out_before": c["held_out"][0],
        "held_out_after": c["held_out"][1],
        "held_out": held_out_words(d),
    }
    plots[c["effect"]] = _plot_data(d, fit0, fit1, "screen", ch)
    return Finding(
        c["effect"], "not in the effects library; described by its signature: " + text, params, evidence, gain
    )


def _library_finding(d, st, fit0, c: _Cand, base, y, clusters, plots: dict) -> Any:
    from aerotruth.analysis.diagnose.modes import Finding

    eff = c["effect"]
    if eff == "quantization":
        qq = c["q"]
        params: dict[str, Any] = {
            "lat_lon_step_deg": {
                "value": qq["step"],
                "se": 0.0,
                "model": st.spec.lat_lon_step_deg,
                "meaning": "grid of the reported lat/lon",
            },
            "share_on_model_grid": qq["share_on_model_grid"],
        }
        evidence = {
            "test": "binomial: coordinates on the coarser grid vs the share the model's grid puts there",
            "log10_p": qq["log10_p"],
            "alpha": c["level"],
        }
        gain = qq["gain"]
    else:
        fit1 = c["fit"]
        params = _parameters(eff, d, fit1, c["dgamma"], st)
        ch = CHANNEL[eff]
        evidence = {
            "test": SCANNED.get(eff, _wald_words(st, eff)).format(units=unit_words(d)),
            "p_value": c["p"],
            "alpha": c["level"],
            "flights": int(len(np.unique(d.flight))),
            "rows": int(d.n),
        }
        if eff == "stale_declination":
            evidence["aliased_with_A"] = (
                f"{100 * (1 - declination_identifiable(d)):.0f} % of the regressor is a per-aircraft constant"
            )
        if eff == "reference_bias" and any(x["form"] == "scale" for x in params["bias_kt"].values()):
            evidence["forms_chosen"] = _forms_chosen(d, st, y, clusters, base, params["bias_kt"])
        if eff == "reference_bias" and st.reference_pairs is not None:
            # the contrast the test measured (attenuated by the measured wind's direction error;
            # the sizes above are the table's fit)
            evidence["contrast_kt"] = {src: v["b_kt"] for src, v in st.reference_pairs["per"].items()}
        gain = {
            "metric": f"RMS of the {ch} wind residual (kt)"
            if ch != "both"
            else "RMS of the wind residual vector components (kt)",
            "before": rms_of_kt(fit0.resid, d.n, ch),
            "after": rms_of_kt(fit1.resid, d.n, ch),
            "held_out_before": c["held_out"][0],
            "held_out_after": c["held_out"][1],
            "held_out": held_out_words(d),
        }
        plots[eff] = _plot_data(d, fit0, fit1, eff, ch)
    params["size"] = _size(eff, params)
    return Finding(eff, cause(eff, params), params, evidence, gain)


def _rival_words(d: WindData, r: dict) -> dict:
    """A confusable rival as the finding states it: its name, what it would mean, its numbers
    (and, for a per-aircraft effect, its aircraft and their step times)."""
    c = r["candidate"]
    out = {
        "effect": c["effect"],
        "p_value": c["p"],
        "held_out_before_kt": c["held_out"][0],
        "held_out_after_kt": c["held_out"][1],
        "p_given_the_finding": r["p_given_best"],
        "held_out_t": r["held_out_t"],
    }
    if c["kind"] == "screen":
        beta = c["fit"].coef("screen")[0][1]
        out["signature"] = _signature_text(c["sigs"], beta)
        out["covariates"] = [sg["covariate"] for sg in c["sigs"]]
        out["cause"] = "not in the effects library; described by its signature: " + out["signature"]
    else:
        out["cause"] = CAUSES.get(c["effect"], c["effect"])
        per = sorted({b.aircraft for b in c.get("blocks", []) if b.aircraft >= 0})
        if per and c["effect"] in SCANNED:
            out["aircraft"] = [d.names[i] for i in per]
            out["cause"] += f" ({', '.join(out['aircraft'])})"
        if c["effect"] == "recalibration":
            out["steps_utc"] = {
                d.names[b.aircraft]: _iso(float(b.label.split("@")[1])) for b in c["blocks"] if b.aircraft >= 0
            }
    return out


# what varies for an explanation: data where two of these vary independently tell them apart
VARIES_WITH = {
    "soft_iron": "the heading, twice round (2z)",
    "field_scaling": "the horizontal field (magnetic latitude) at the same heading",
    "tas_scale": "the true airspeed, in the along-heading channel",
    "stale_declination": "position across the network (the declination's secular change)",
    "reference_bias": "the wind speed and direction of one reference model",
    "recalibration": "time, as one step per aircraft",
    "offset_drift": "time, as a steady ramp per aircraft",
    "quantization": "the reports' position grid",
}


def _varies(effect: str, covs: list[str] | None = None) -> str:
    if effect in VARIES_WITH:
        return VARIES_WITH[effect]
    if covs and covs[0].startswith("fleet_step_"):
        return "time, as one step of the whole fleet"
    if covs == ["time_days"]:
        return "time, as a trend of the whole fleet"
    return "its covariates (" + ", ".join(covs or [effect.split(":", 1)[-1]]) + ")"


def _carriers(d: WindData, fit0: Fit, c: _Cand) -> list[dict]:
    """A fleet-wide change in time found as a signature (a step at one time, a trend) and
    the per-aircraft causes it may be made of: the aircraft whose contrasts with the rest
    of the fleet carry it (wind_model.carried_by: a step at the fleet's change time, a
    slope; Bonferroni over aircraft, below 0.05). Three aircraft recalibrated on one day
    step the fleet's mean by a quarter of their step, and two drifting compasses tilt the
    fleet's trend: the fleet's signature is then their coarse copy, and the finding says
    both, as confusable. A change every aircraft shares leaves no carrier."""
    key = c.get("key", "")
    if key == "fleet_step":
        step_at = float(c["sigs"][0]["covariate"].rsplit("_", 1)[1])
    elif key == "transverse:time_days":  # a trend may be a step: at the fleet's change time
        bm, t0, t1 = group_means(d, fit0.resid[: d.n], d.cluster)
        if len(bm) < 2:
            return []
        step_at = split_time(t0, t1, cusum_split(bm))
    else:
        return []
    ps_of = carried_by(d, fit0, step_at)
    chosen = {eff: selected_aircraft(ps) for eff, ps in ps_of.items()}
    by_bar = {eff for eff, sel in chosen.items() if sel}
    # a carrier found in one form is said in the other as well where its contrast supports
    # that too (ALPHA_RIVAL, unadjusted): one aircraft's step in the middle of the period and
    # its ramp are nearly the same series (correlation ~0.87), and which of the two the
    # Bonferroni bar selects is then the draw's, not the data's evidence
    for eff, other in (("recalibration", "offset_drift"), ("offset_drift", "recalibration")):
        if chosen[other] or not chosen[eff]:
            continue
        chosen[other] = {i: ps_of[other][i] for i in chosen[eff] if ps_of[other].get(i, 1.0) < ALPHA_RIVAL}
    out = []
    for eff, sel in chosen.items():
        if not sel:
            continue
        names = [d.names[i] for i in sorted(sel)]
        when = f" at {_iso(step_at)}" if eff == "recalibration" else ""
        out.append(
            {
                "effect": eff,
                "aircraft": names,
                "p_value": min(sel.values()),
                "test": "the aircraft's weather-block offsets minus the median of the rest of the fleet's, "
                + "blocks permuted "
                + ("(one split at the fleet's change time)" if eff == "recalibration" else "(slope in time)")
                + (
                    ", Bonferroni over aircraft"
                    if eff in by_bar
                    else f", unadjusted below {ALPHA_RIVAL:g} on the aircraft that carry the change in the other form"
                ),
                "cause": f"{CAUSES[eff]} ({', '.join(names)}{when}: the fleet's change is carried by "
                f"{'this aircraft' if len(names) == 1 else 'these aircraft'})",
            }
        )
    return out


# What a signature's proxy is made of, where the proxy is a model of an attitude the table
# does not carry: the pitch attitude's flight-path angle comes from the climb rate (whose
# sign is the flight phase) and its angle of attack from the dynamic pressure, a function of
# the pressure altitude and the TAS, known only in shape (alpha0 + (W/S) / (CL_alpha q); flaps,
# thrust, the weight's change along the flight and the air's temperature left out). What the
# proxy misses of the true pitch then lies along those inputs: a TAS or altitude term found
# after the pitch term is the pitch attitude's shape or a second effect, and no table without
# the pitch (or the angle of attack) can tell which. On aerotruth's simulated SAAB 340 (true
# JSBSim pitch, 0.4 deg/deg) 17 of 41 datasets named such a term after the pitch term; a
# shape per flight phase added to the pitch term made it stronger, not weaker.
PROXY_INPUTS = {
    ("transverse", "flight_path_angle_deg", "inverse_dynamic_pressure", "inverse_dynamic_pressure_cruise"): (
        {"tas_kt", "pressure_altitude_ft", "phase_ascent", "phase_descent"},
        "the pitch attitude's shape: the pitch term's proxy (flight-path angle between reports plus an angle of "
        "attack in 1/q) is built from the climb rate, the altitude and the TAS, and what it misses of the true pitch "
        "lies along them",
        "a measured pitch attitude or angle of attack",
    ),
}


def _shape_of_entered(st: State, best: _Cand) -> list[dict]:
    """The entered signatures whose proxy's misfit a screening finding may be
    (PROXY_INPUTS): its channel theirs, its covariates among their proxy's inputs. Said
    with the finding as confusable: the data cannot tell the two apart by construction."""
    if best["kind"] != "screen":
        return []
    covs = {sg["covariate"] for sg in best["sigs"]}
    out = []
    for (ch, *group), (inputs, words, tell) in PROXY_INPUTS.items():
        entered = [sg["covariate"] for sg in st.signatures if sg["channel"] == ch and sg["covariate"] in group]
        if best["channel"] != ch or group[0] not in entered or not covs <= inputs:
            continue
        out.append(
            {
                "effect": f"unexplained:{ch}:" + "+".join(entered),
                "covariates": entered,
                "cause": words,
                "test": "none: the finding's covariates are the entered term's proxy's inputs",
                "tell_apart": tell,
            }
        )
    return out


def _name_confusable(d: WindData, f, best: _Cand, rivals: list[dict], carriers: list[dict], shapes: list[dict]) -> None:
    """The finding names every rival the data cannot tell from it, the per-aircraft causes a
    fleet-wide signature may be made of (`carriers`, _carriers) and the entered terms whose
    proxy's leftovers it may be (`shapes`, _shape_of_entered), and what would tell them."""
    words = [_rival_words(d, r) for r in rivals]
    confusable = words + carriers + shapes
    if not confusable:
        return
    f.parameters["confusable_with"] = confusable
    lead_covs = [sg["covariate"] for sg in best.get("sigs", [])]
    alts = "; or ".join(x["cause"] for x in confusable)
    told = words + carriers
    tell = "; ".join(
        ([_varies(best["effect"], lead_covs)] if told else [])
        + [_varies(x["effect"], x.get("covariates")) for x in told]
        + [x["tell_apart"] for x in shapes]
    )
    why = []
    if words:
        why.append(f"each explains what the other does, and neither predicts held-out {unit_words(d)} better")
    if carriers:
        why.append(
            "the fleet's change is not shared evenly: the aircraft named carry it against the rest of the fleet, "
            "and whether it is theirs alone or the fleet's and theirs these data do not say"
        )
    if shapes:
        why.append("its covariates are what an entered term's proxy is made of")
    f.cause = f"{f.cause}; or {alts}. These data cannot tell them apart ({'; '.join(why)}); " + (
        f"data where these vary independently would: {tell}" if told else f"{tell} would"
    )


def diagnose_wind(d: WindData, spec: WindModelSpec) -> tuple[list, dict, State, dict]:
    """Rounds of competing explanations (the library's effects and the screening's
    signatures together): the round's best by held-out gain is named, with every rival it
    does not beat named beside it as confusable. Returns (findings, baseline, the final
    state, plot data per finding)."""
    y = stack_channels(d.trans, d.along, d.n) - known_offsets(d, spec)
    clusters = np.r_[d.cluster, d.cluster]
    heading = choose_deviation_heading(d, spec, y, clusters)
    spec = spec.model_copy(update={"deviation_heading": heading["chosen"]})
    st = initial_state(d, spec)
    # the ordinary fit of the model as given: the tests' working covariance within a unit
    # (wind_weights; where the units are flights) and the reference error field the fleet
    # shares (wind_field; where they are weather blocks) are read off its residual
    r0 = solve(current_blocks(d, st), y, clusters, with_cov=False).resid
    st.weights = working_weights(d, r0)
    st.field = fit_field_kernel(d, r0)
    st.reference_pairs = reference_difference_test(d, y, st.field)
    fit_start = None  # the model before any effect: the first round's fit
    findings: list = []
    plots: dict = {}
    rounds: list[dict] = []
    done: set[str] = set()  # screening keys entered
    # (finding, its candidate, rivals, carriers, the entered terms whose shape it may be)
    pending: list[tuple[Any, _Cand, list[dict], list[dict], list[dict]]] = []
    n_units = len(np.unique(d.cluster))
    testable = n_units >= MIN_BLOCKS
    for _ in range(MAX_ROUNDS):
        fit_start = fit_start or solve(current_blocks(d, st), y, clusters, with_cov=False, weights=st.weights)
        if not testable:  # only the reports' grid, which needs no weather blocks (and no fit)
            c = _quantization(d, st, len(findings) + 1)
            if c is None or not (c["p"] < c["level"] and c["rel"] > MIN_REL_GAIN):
                break
            findings.append(_library_finding(d, st, fit_start, c, None, y, clusters, plots))
            st.entered.append("quantization")
            continue
        basis = Basis(d, st, y, clusters)
        fit0 = basis.base_fit()
        base = [basis.base_fit(k) for k in FOLDS]
        r0 = base_held_out(d, base)
        look = len(findings) + 1  # the round's look at the data (module docstring: levels)
        cands = _library_candidates(d, st, y, clusters, fit0, basis, r0, look)
        if len(done) < MAX_SCREENED:
            cands += _screen_candidates(d, st, y, clusters, fit0, basis, r0, done, look)
        rounds.append(
            {
                c["effect"]: {
                    "p": c["p"],
                    "held_out_before_kt": c["held_out"][0],
                    "held_out_after_kt": c["held_out"][1],
                }
                for c in cands
            }
        )
        ok = [c for c in cands if c["p"] < c["level"] and c["rel"] > MIN_REL_GAIN]
        if not ok:
            break
        best = _lead(d, basis, ok)
        rivals: list[dict] = []
        if best["kind"] != "quantization":
            others = [
                c
                for c in cands
                if c is not best
                and c["kind"] != "quantization"
                and c["p"] < max(c["level"], ALPHA_RIVAL)
                and c["rel"] > MIN_REL_GAIN
                and "resid_ho" in c
            ]
            rivals = _rivals(d, basis, best, others)
        if best["kind"] == "screen":
            f = _screen_finding(d, st, fit0, best, plots)
        else:
            f = _library_finding(d, st, fit0, best, base, y, clusters, plots)
        f.evidence["rivals"] = {
            r["effect"]: {
                "verdict": r["verdict"],
                "p_given_the_finding": r["p_given_best"],
                "held_out_t": r["held_out_t"],
                "p_not_beaten": r["p_not_beaten"],
            }
            for r in rivals
        }
        f.evidence["rivals_rule"] = (
            "a rival (significant, with a held-out gain) is separate when still significant with this finding in the "
            f"model (a weak one, supported at {ALPHA_RIVAL:g}, is left apart only where this finding is itself still "
            f"supported at {ALPHA_RIVAL:g} with the rival in the model); otherwise beaten when this finding predicts "
            f"held-out {unit_words(d)} better (two-sided p < "
            f"{ALPHA_BEATS:g}, Diebold-Mariano on the units' sums), else confusable; a separate rival that this "
            "finding did not beat and that never enters on its own is confusable after all"
        )
        shapes = _shape_of_entered(st, best)
        if shapes:
            f.evidence["shape_of_an_entered_term"] = [x["effect"] for x in shapes]
        pending.append((f, best, rivals, _carriers(d, fit0, best) if best["kind"] == "screen" else [], shapes))
        findings.append(f)
        if best["kind"] == "screen":
            st.signatures.extend(best["sigs"])
            done.add(best["key"])
            continue
        eff = best["effect"]
        st.entered.append(eff)
        params = f.parameters
        if eff == "field_scaling":
            st.gamma = params["gamma"]["value"]
        if eff == "recalibration":
            for a, s_ in params["steps"].items():
                st.steps.setdefault(d.names.index(a), []).append(s_["time_s"])
        if eff == "offset_drift":
            st.drifts.update(d.names.index(a) for a in params["aircraft"])
    named = {f.effect for f in findings}
    for f, best, rivals, carriers, shapes in pending:
        for r in rivals:  # "separate" promised a round of its own; without one it could not be told apart
            if r["verdict"] == "separate" and r["effect"] not in named and not _beats(r["p_not_beaten"]):
                r["verdict"] = "confusable"
                f.evidence["rivals"][r["effect"]]["verdict"] = "confusable (separate, but never entered on its own)"
        carriers = [x for x in carriers if x["effect"] not in named]  # a cause named on its own is not a copy
        _name_confusable(d, f, best, [r for r in rivals if r["verdict"] == "confusable"], carriers, shapes)
    fit_end = solve(current_blocks(d, st), y, clusters, weights=st.weights)
    assert fit_start is not None  # set in the first round (MAX_ROUNDS >= 1)
    free = {
        b.label[5:]: {
            "slope": float(be[0]),
            "se": float(standard_errors(v)[0]) if n_units >= 2 else float("nan"),  # one cluster: no se
            "unit": "deg per unit"
            if b.label.startswith("free:transverse")
            else ("s (both channels)" if b.label.startswith("free:both") else "kt per unit"),
        }
        for b, be, v in fit_end.coef("base", -1)
        if b.label.startswith("free:")
    }
    baseline: dict[str, Any] = {
        "rounds": rounds,
        "model_fit": model_fit(d, st, fit_end),
        "free_terms": free,
        "residual_rms_kt": {
            "transverse_before": rms_of_kt(fit_start.resid, d.n, "transverse"),
            "transverse_after": rms_of_kt(fit_end.resid, d.n, "transverse"),
            "along_before": rms_of_kt(fit_start.resid, d.n, "along"),
            "along_after": rms_of_kt(fit_end.resid, d.n, "along"),
        },
        "deviation_heading": heading,
        "weights": st.weights.params
        if st.weights is not None
        else {
            "form": "ordinary least squares: "
            + (
                "the residual is not correlated within a flight's series"
                if d.unit == "flight"
                else "the units are weather blocks (the reference error a field the flights share)"
            )
        },
        "alpha": {"library": ALPHA_LIBRARY, "screening": ALPHA_SCREEN, "family_wise": ALPHA_LIBRARY + ALPHA_SCREEN},
        "not_identifiable": (
            []
            if declination_identifiable(d) >= 0.01
            else [
                "stale_declination: aliased with the per-aircraft offset A (the declination change across "
                f"this network is {100 * declination_identifiable(d):.1f} % outside per-aircraft constants)"
            ]
        ),
        "reports": int(len(np.unique(np.c_[d.aircraft, d.time_s], axis=0))),
        "rows": int(d.n),
        "aircraft": len(d.names),
        "flights": int(len(np.unique(d.flight))),
        "weather_blocks": int(len(np.unique(d.block))),
        "units": {"unit": d.unit, "count": n_units, "why": units_reason(d), "sharing_test": d.sharing},
        "reference_field": None if st.field is None else st.field.params(),
        "reference_pairs": None
        if st.reference_pairs is None
        else {k: v for k, v in st.reference_pairs.items() if k != "test"},
        "data": d.table,
    }
    if not testable:
        baseline["not_tested"] = (
            f"the data span {n_units} independent 6-h weather blocks, fewer than {MIN_BLOCKS}: "
            "cluster-robust tests on so few clusters reject too often (aerotruth's own null "
            "reports on 15 blocks: 10 false findings in 100 datasets), so no effect is tested; the "
            "quantization check (no test statistic on clusters) still runs. More days of data "
            "are needed."
        )
    return findings, baseline, st, plots


def model_fit(d: WindData, st: State, fit: Fit) -> dict:
    """The current model's per-aircraft deviation: status, reason, A (B, C, D, E) +- se (deg)."""
    out = {}
    r2d = 1 / DEG
    for i, name in enumerate(d.names):
        sel = d.aircraft == i
        row: dict[str, Any] = {"n_rows": int(sel.sum()), "flights": int(len(np.unique(d.flight[sel])))}
        # a cluster-robust se needs two clusters (6-h weather blocks): from one it is ~0, not small
        one_cluster = len(np.unique(d.cluster[sel])) < 2
        for b, be, v in fit.coef("base", i) + fit.coef("soft_iron", i):
            se = standard_errors(v) if not one_cluster else np.full(len(be), np.nan)
            if b.label == "A":
                row["A_deg"] = float(be[-1] * r2d)
                row["A_se_deg"] = float(se[-1] * r2d)
            elif b.label == "T":
                row["tas_bias_kt"], row["tas_bias_se_kt"] = float(be[0] / KT), float(se[0] / KT)
            elif b.label == "drift":
                row["A_drift_deg_per_day"], row["A_drift_se_deg_per_day"] = float(be[0] * r2d), float(se[0] * r2d)
            else:
                for j, t in enumerate(b.label):
                    row[f"{t}_deg"], row[f"{t}_se_deg"] = float(be[j] * r2d), float(se[j] * r2d)
        spread = heading_spread(np.degrees(d.z[sel]), np.ones(sel.sum())) if sel.sum() >= 3 else 0.0
        if "B_deg" in row:
            row["status"], row["reason"] = "fitted", ""
        else:
            row["status"] = "offset_only"
            row["reason"] = (
                f"heading coverage cannot identify the sinusoid (spread {spread:.2f} < {MIN_COVERAGE}): "
                "offset A only; one heading cannot tell an offset from a sinusoid"
            )
        out[name] = row
    return out


# ----------------------------------------------------------------------------- screening

UNITS = {
    "pressure_altitude_ft": "1000 ft",
    "tas_kt": "kt",
    "lat": "deg latitude",
    "time_days": "day",
    "roll_deg": "deg roll",
    "turn_deg_s": "deg/s of turn",
    "accel_error": "unit of tan(dip) x (dTAS/dt)/g x sin(magnetic heading) (a flux valve's acceleration error)",
    "flight_path_angle_deg": "deg of flight-path angle",
    "inverse_dynamic_pressure": "unit of q_250/q (q_250: 250 kt at sea level)",
    "inverse_dynamic_pressure_cruise": "unit of q_cruise/q",
    "const": "(constant)",
}


def _screen_tests(d: WindData, spec: WindModelSpec | None = None) -> list[tuple[str, list[str]]]:
    """(channel, covariates) of every screening test; covariates the spec's free terms
    already carry in a channel are not tested again there."""
    common = ["pressure_altitude_ft", "lat", "time_days", "turn_deg_s"] + (["roll_deg"] if d.roll is not None else [])
    tests = [
        ("transverse", ["sin3", "cos3"]),
        ("transverse", ["phase_ascent", "phase_descent"]),
        ("transverse", ["tas_kt"]),
        # a pitch-coupled heading error: pitch = flight-path angle + angle of attack, the latter
        # alpha0 + (W/S) / (CL_alpha q) (lift = weight) with the flight's weight unknown: 1/q at
        # one weight, q_cruise/q at one cruise lift coefficient (wind_data.prepare)
        ("transverse", ["flight_path_angle_deg", "inverse_dynamic_pressure", "inverse_dynamic_pressure_cruise"]),
        # a diurnal error (temperature-driven: heating of the valve or the air-data probes)
        ("transverse", ["local_hour_sin", "local_hour_cos"]),
        # a pendulous valve tilted by speed changes (wind_model.covariate: accel_error)
        ("transverse", ["accel_error"]),
        # a wind older or younger than its time stamp (a trailing mean stamped at its end)
        ("both", ["wind_rate"]),
    ]
    tests += [("transverse", [c]) for c in common]
    tests += [
        ("along", ["const"]),
        ("along", ["sin1", "cos1"]),
        ("along", ["sin2", "cos2"]),
        ("along", ["sin3", "cos3"]),
        ("along", ["phase_ascent", "phase_descent"]),
    ]
    tests += [("along", [c]) for c in common]
    free = {(t["channel"], t["covariate"]) for t in spec.free_terms} if spec is not None else set()
    tests = [(ch, [c for c in covs if (ch, c) not in free]) for ch, covs in tests]
    return [(ch, covs) for ch, covs in tests if covs]


def _screen_blocks(d: WindData, channel: str, covs: list[str]) -> tuple[list[Block], list[dict]]:
    sigs = [{"channel": channel, "covariate": c, "center": term_center(d, channel, c)} for c in covs]
    return [
        Block("screen", f"{channel}:{'+'.join(covs)}", np.column_stack([signature_column(d, s) for s in sigs]))
    ], sigs


def _periodic(d: WindData, fit: Fit) -> tuple[float, int] | None:
    """(period s, M independent frequencies) of the strongest period in the flight-mean
    transverse residual (least-squares periodogram, periods 2 h .. span/2). Its evidence is
    not the white-noise p = M exp(-z): flight means share the weather's errors for hours
    (a 4-h "period" came up in 1 of 8 null datasets of aerotruth's own reports), so the
    term is tested like the others, by a Wald test on weather blocks, times M."""
    m, t0, t1 = group_means(d, fit.resid[: d.n], d.flight)
    t = 0.5 * (t0 + t1)
    span = t.max() - t.min()
    if len(m) < 20 or span < 4 * 7200.0:
        return None
    M = int(span / 7200.0)
    freqs = np.linspace(2.0 / span, 1 / 7200.0, 4 * M)
    e = m - m.mean()
    best = (0.0, 0.0)
    for f in freqs:
        X = np.column_stack([np.sin(2 * np.pi * f * t), np.cos(2 * np.pi * f * t)])
        b, *_ = np.linalg.lstsq(X, e, rcond=None)
        z = np.sum(e**2) - np.sum((e - X @ b) ** 2)
        if z > best[0]:
            best = (float(z), 1 / f)
    return best[1], M


def _signature_text(sig: list[dict], beta: np.ndarray) -> str:
    ch = sig[0]["channel"]
    unit = "deg" if ch == "transverse" else "kt"
    covs = [s["covariate"] for s in sig]
    if covs[0] == "wind_rate":
        return (
            f"the reported wind lags its time stamp by {beta[0]:+.1f} s (both channels follow the wind's change "
            "between neighbouring reports: a mean over a trailing window stamped at its end lags by half the window)"
        )
    if covs[0] in ("sin1", "sin2", "sin3"):
        k = covs[0][3]
        return f"{ch} residual varies as {k}z with the heading, amplitude {math.hypot(*beta[:2]):.2f} {unit}"
    if covs[0].startswith("phase_"):
        return (
            f"{ch} residual depends on the flight phase: ascent {beta[0]:+.2f} {unit}, "
            f"descent {beta[1]:+.2f} {unit} vs level"
        )
    if covs[0].startswith("period_"):
        return (
            f"{ch} residual is periodic, period {float(covs[0].split('_')[1]) / 3600:.1f} h, "
            f"amplitude {math.hypot(*beta[:2]):.2f} {unit}"
        )
    if covs[0] == "flight_path_angle_deg" or covs[0].startswith("inverse_dynamic_pressure"):
        parts = ", ".join(f"{b:+.3g} {unit} per {UNITS.get(c, c)}" for c, b in zip(covs, beta, strict=False))
        return (
            f"{ch} residual follows the pitch attitude: {parts} (the angle of attack's shape in q; its two "
            "columns are not told apart where the flights' cruise q hardly varies)"
        )
    if covs[0] == "local_hour_sin":
        peak = (math.degrees(math.atan2(beta[0], beta[1])) / 15.0) % 24.0
        return (
            f"{ch} residual varies with the local solar hour (a diurnal term), amplitude "
            f"{math.hypot(*beta[:2]):.2f} {unit}, largest at {peak:.1f} h"
        )
    if covs[0].startswith("fleet_step_"):
        return f"{ch} residual of the whole fleet steps by {beta[0]:+.2f} {unit} at {_iso(float(covs[0][11:]))}"
    if covs[0] == "const":
        return (
            f"{ch} residual has a constant offset {beta[0]:+.2f} {unit} "
            "(an airspeed or reference bias not in the library)"
        )
    return f"{ch} residual ~ {covs[0]}, {beta[0]:+.3g} {unit} per {UNITS.get(covs[0], covs[0])}"


# ----------------------------------------------------------------------------- outputs


def extended_spec(spec: WindModelSpec, findings: list, d: WindData, st: State) -> WindModelSpec:
    """The model with the findings in it (what a rerun of diagnose with it should not find again)."""
    up: dict[str, Any] = {"deviation_heading": st.spec.deviation_heading}  # "auto" as decided
    for f in findings:
        p = f.parameters
        if f.effect == "soft_iron":
            up["deviation_terms"] = 5
        elif f.effect == "field_scaling":
            up["field_scaling"] = float(np.clip(p["gamma"]["value"], -3, 3))
        elif f.effect == "tas_scale":
            up["tas_scale"] = {
                **spec.tas_scale,
                **{a: spec.tas_scale.get(a, 0.0) + v["k"] for a, v in p["aircraft"].items()},
            }
        elif f.effect == "stale_declination":
            up["declination_age_yr"] = float(p["age_yr"]["value"])
        elif f.effect == "reference_bias":  # each model in the form that fits it better
            forms = {s: v.get("form", "offset") for s, v in p["bias_kt"].items()}
            up["reference_bias_kt"] = {
                **spec.reference_bias_kt,
                **{
                    s: spec.reference_bias_kt.get(s, 0.0) + v["value"]
                    for s, v in p["bias_kt"].items()
                    if forms[s] == "offset"
                },
            }
            up["reference_scale"] = {
                **spec.reference_scale,
                **{
                    s: spec.reference_scale.get(s, 0.0) + v["scale"]["value"]
                    for s, v in p["bias_kt"].items()
                    if forms[s] == "scale"
                },
            }
        elif f.effect == "recalibration":
            rec = {a: list(ts) for a, ts in spec.recalibrations.items()}
            for a, s in p["steps"].items():
                rec.setdefault(a, []).append(s["time_s"])
            up["recalibrations"] = rec
        elif f.effect == "offset_drift":
            up["offset_drifts"] = sorted(set(spec.offset_drifts) | set(p["aircraft"]))
        elif f.effect == "quantization":
            up["lat_lon_step_deg"] = float(p["lat_lon_step_deg"]["value"])
        elif f.effect.startswith("unexplained:"):
            up.setdefault("signatures", list(spec.signatures))
            up["signatures"] += [{k: t[k] for k in ("channel", "covariate", "center", "slope")} for t in p["terms"]]
    return spec.model_copy(update=up)
