"""`aerotruth diagnose MEASURED --model CAMPAIGN.yaml --out DIR`: the files of a diagnosis.

The analysis (aerotruth.analysis.diagnose: Mode-S data, observation tables, approach logs)
returns findings; this module writes them: DIR/diagnosis.json (the contract in
docs/data-formats.md: a ranked `findings` list, each with effect, cause, parameters,
evidence and gain), DIR/report.md and its figures, and DIR/extended_model.yaml (the
campaign with the findings in its model) where the kind of data has one.
"""

from __future__ import annotations

import json
import math
from dataclasses import asdict
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pandas as pd

from aerotruth.analysis.diagnose.fits import (
    FitsModel,
    checked_approaches,
    mean_periodogram,
)
from aerotruth.analysis.diagnose.modes import Diagnosis, Finding
from aerotruth.analysis.diagnose.wind_model import WindModelSpec
from aerotruth.errors import DataError, UserError, output_folder
from aerotruth.files import atomic_write_text
from aerotruth.units import KT


def diagnose_main(
    measured_path: str,
    model_path: str,
    out_dir: str,
    aircraft_type: str | None = None,
    engine_type: str | None = None,
) -> int:
    """The command: recognise the measured data, diagnose them against the campaign's model,
    write DIR's files and print one line of what was found. `aircraft_type` (an ICAO type
    designator) and `engine_type` name the aircraft of Mode-S data (aerotruth.measured.modes)."""
    args = SimpleNamespace(measured=measured_path, model=model_path, out=out_dir)
    from aerotruth.analysis.diagnose.modes import diagnose_track
    from aerotruth.measured.kinds import load_measured
    from aerotruth.measured.modes import track_from_measured
    from aerotruth.sim.campaign_loader import load_campaign

    for flag, given in (("--aircraft-type", aircraft_type), ("--engine-type", engine_type)):
        if given is not None and not given.strip():  # an empty value would be taken for none given
            raise UserError(f"{flag}: empty; expected an ICAO type designator (e.g. A310) or jet / turboprop")
    output_folder(args.out)
    model = load_campaign(args.model) if args.model else None  # the simulation the data are compared with
    measured = _traffic_as_reports(args.measured, load_measured)
    if (aircraft_type or engine_type) and measured.kind not in ("modes_track", "modes_raw"):
        flag = "--aircraft-type" if aircraft_type else "--engine-type"
        raise UserError(
            f"{flag}: only Mode-S data are diagnosed with an aircraft type; {args.measured} is "
            f"{'an' if measured.kind[0] in 'aeiou' else 'a'} {measured.kind.replace('_', ' ')}"
        )
    if measured.kind == "approach_log":
        from aerotruth.analysis.diagnose.fits import diagnose_log
        from aerotruth.measured.approach_log import read_approach_log

        df = read_approach_log(args.measured)
        fm = FitsModel.from_campaign(model) if model is not None else FitsModel()
        findings, baseline = diagnose_log(Path(args.measured), df, fm)
        write_log_diagnosis(args.measured, df, findings, baseline, fm, Path(args.out))
        names = ", ".join(f.effect for f in findings) or "none"
        print(
            f"{args.measured}: approach log, {baseline['approaches']} approaches; "
            f"findings: {names} -> {Path(args.out) / 'diagnosis.json'}"
        )
        return 0
    if measured.kind == "observation_table":
        return _diagnose_observations(args, model, measured)
    track, excluded = track_from_measured(measured, aircraft_type=aircraft_type, engine_type=engine_type)
    findings, baseline = diagnose_track(track)
    for f in findings:
        if f.effect == "heading_offset" and measured.kind in (
            "modes_track",
            "modes_raw",
        ):  # BDS 6,0 heading is magnetic
            import datetime as dt

            from aerotruth.analysis.diagnose.modes import variation_table_epoch

            df = measured.df
            when = dt.datetime.fromtimestamp(float(track["time_s"].iloc[0]), tz=dt.UTC).replace(tzinfo=None)
            f.evidence["variation_table"] = variation_table_epoch(
                f.parameters["A_deg"]["value"],
                track,
                float(df["latitude"].median()),
                float(df["longitude"].median()),
                float(df["altitude"].median()) * 0.3048,
                when,
            )
    diag = Diagnosis(str(args.measured), measured.kind, len(track), excluded, findings, baseline)
    out = Path(args.out)
    write_diagnosis(diag, track, out)
    from aerotruth.sim.studies.modes_diagnose import extended_campaign

    extended = extended_campaign(model, findings) if findings and model is not None else None
    if extended is not None:  # the simulation with the found effects: run it to see them reproduced
        atomic_write_text(out / "extended_model.yaml", extended.to_yaml())
    names = ", ".join(f.effect for f in findings) or "none"
    print(f"{args.measured}: {measured.kind}, {len(track)} samples; findings: {names} -> {out / 'diagnosis.json'}")
    return 0


def _traffic_as_reports(path: str, load_measured):
    """The measured file, recognised (aerotruth.measured.kinds); multi-aircraft traffic (a
    decoded state table, raw frames or a tracker export of two aircraft or more,
    aerotruth.measured.traffic) as the observation table `aerotruth reports --reference
    consensus` writes: each sample against the consensus of the other aircraft, so that the
    wind diagnosis finds per-aircraft and fleet effects."""
    from aerotruth.analysis.wind.consensus import observation_table, straight_samples
    from aerotruth.measured.kinds import Measured
    from aerotruth.measured.traffic import read_traffic

    try:
        measured = load_measured(path)
    except DataError as not_known:
        try:
            traffic = read_traffic(path)
        except DataError as e:
            # traffic that lacks what the wind needs: say what it lacks; not traffic at all: the kinds known
            raise (not_known if "not traffic aerotruth reads" in str(e) else e) from None
    else:
        several = measured.kind in ("modes_track", "modes_raw") and measured.df.get("icao24", pd.Series()).nunique() > 1
        if not several:
            return measured
        traffic = read_traffic(path)
    traffic = straight_samples(traffic)  # the wind paper's roll gate, as `aerotruth reports`
    if traffic["aircraft"].nunique() < 2:
        raise DataError(f"{path}: traffic of one aircraft: a consensus reference needs other aircraft around it")
    obs = observation_table(traffic)
    if len(obs) == 0:
        raise DataError(
            f"{path}: no sample has another aircraft within the consensus neighbourhood (see `aerotruth reports "
            "--radius-km --layer-ft --window-s` to make the table with other limits, then diagnose it)"
        )
    obs.attrs = {}
    return Measured("observation_table", obs, Path(path))


def _diagnose_observations(args: SimpleNamespace, model, measured) -> int:
    from aerotruth.analysis.diagnose.wind import (
        diagnose_wind,
        extended_spec,
        prepare,
        wind_model_from_campaign,
    )

    spec = wind_model_from_campaign(model)
    data = prepare(measured.df, str(args.measured))
    findings, baseline, state, plots = diagnose_wind(data, spec)
    ext = extended_spec(spec, findings, data, state)
    out = Path(args.out)
    write_wind_diagnosis(args.measured, findings, baseline, spec, ext, plots, out)
    if findings and model is not None:  # the campaign with the found effects: diagnose with it finds them no more
        extended = model.model_copy(update={"diagnose": {**model.diagnose, "wind": ext.model_dump(mode="json")}})
        atomic_write_text(out / "extended_model.yaml", extended.to_yaml())
    names = ", ".join(_group_name(f) for f in findings) or "none"
    if "not_tested" in baseline:
        names += f" (not tested: {baseline['weather_blocks']} six-hour weather blocks, too few; see report.md)"
    table = baseline["data"]
    skipped = table["rows_dropped_empty"] + table["rows_dropped_duplicate"]
    left = (
        f" ({table['rows_dropped_empty']} rows with an empty required cell, {table['rows_dropped_duplicate']} "
        f"repeated rows left out)"
        if skipped
        else ""
    )
    print(
        f"{args.measured}: observation table, {baseline['reports']} gated reports of {baseline['aircraft']} aircraft"
        f"{left}; findings: {names} -> {out / 'diagnosis.json'}"
    )
    return 0


def write_diagnosis(diag: Diagnosis, track: pd.DataFrame, out_dir: Path, knot_s: float = 600.0) -> None:
    """DIR/diagnosis.json, DIR/report.md and DIR/figures/wind_along_flight.png."""
    out_dir.mkdir(parents=True, exist_ok=True)
    doc = asdict(diag)
    aircraft = track.attrs.get("aircraft") or {}
    regs = track.attrs.get("registers") or {}
    model = (
        "Model: the simulation's Mode-S sensor on this flight's own trajectory, ideal heading and airspeed; the air "
        "vector is the horizontal part of the TAS, TAS cos(flight-path angle), along the air track heading - alpha "
        "sin(roll), alpha from the lift equation of the aircraft type"
        + (f": {aircraft['chosen']}" if aircraft else "")
        + " (aerotruth.truth.aircraft_types; a different alpha moves the air track by (delta alpha) sin(roll), "
        "< 0.1 deg per deg of alpha at 5 deg of bank)."
    )
    doc["model"] = model
    doc["aircraft"] = aircraft
    doc["registers"] = regs
    atomic_write_text(out_dir / "diagnosis.json", json.dumps(doc, indent=2, sort_keys=False) + "\n")
    lines = [
        f"# Diagnosis of `{diag.measured}`",
        "",
        f"Kind: {diag.kind}; samples used: {diag.samples_used}.",
        "",
        "Excluded: " + "; ".join(f"{k}: {v}" for k, v in diag.samples_excluded.items()),
        "",
        model,
        "",
    ]
    if regs:
        lines += [
            "Registers (values of any resolution are used): "
            + "; ".join(
                f"{name} LSB {r['lsb']:.5g} {r['unit']} ({r['source']}), "
                f"{100 * r['share_on_grid']:.0f} % of the samples on its grid"
                if r["lsb"] is not None
                else f"{name}: no register grid found (finer values, or interpolated)"
                for name, r in regs.items()
            )
            + ".",
            "",
        ]
    lines += [
        f"Baseline (ideal sensor, smooth wind): residual {diag.baseline['rms_kt']:.2f} kt per component, "
        f"held out {diag.baseline['held_out_rms_kt']:.2f} kt.",
        "",
    ]
    free = diag.baseline.get("tas_scale_heading_free")
    if free:
        size = (
            f"{100 * free['k']:+.2f} ± {100 * free['se']:.2f} %; a heading-based TAS scale is a finding only where it "
            "agrees"
            if free["k"] is not None
            else free["outcome"]
        )
        lines += [f"TAS scale without the heading ({free['method']}): {size}.", ""]
    if not diag.findings:
        lines += ["**No finding**: no candidate effect improves the held-out fit with strong evidence.", ""]
    for i, f in enumerate(diag.findings, 1):
        ps = ", ".join(f"{k} = {v['value']:.4g} ± {v['se']:.2g}" for k, v in f.parameters.items())
        vt = f.evidence.get("variation_table")
        if vt is not None:
            ps += (
                f"; the aircraft's variation table must hold {vt['implied_table_variation_deg']:.1f} deg "
                "where IGRF gives "
                f"{vt['declination_now_deg']:.1f} deg today"
                + (
                    f", the declination there in {vt['igrf_epoch_with_that_variation']:.0f}"
                    if "igrf_epoch_with_that_variation" in vt
                    else ""
                )
            )
        lines += [
            f"## {i}. {f.effect}",
            "",
            f.cause,
            "",
            f"* parameters: {ps}",
            f"* ΔBIC {f.evidence['delta_bic']:.1f}, jackknife p = {f.evidence['p_value']:.2g} "
            f"(level {f.evidence['alpha']:.2g})",
            f"* residual {f.gain['before']:.2f} → {f.gain['after']:.2f} kt; held out {f.gain['held_out_before']:.2f} → "
            f"{f.gain['held_out_after']:.2f} kt",
        ]
        hf = f.evidence.get("heading_free")
        if hf is not None:
            lines.append(f"* without the heading: k = {hf['k']:.4g} ± {hf['se']:.2g} (agrees)")
        lines.append("")
    last = (diag.baseline.get("rounds") or [{}])[-1]
    if last:
        lines += [
            "Candidates after the last finding (what the data say of each):",
            "",
            "| effect | outcome | size | ΔBIC | jackknife p | held out (kt) |",
            "|---|---|---|---|---|---|",
        ]
        for eff, c in last.items():
            ses = c.get("se", {})
            size = ", ".join(
                f"{k} {v:.3g}" + (f" ± {ses[k]:.2g}" if k in ses else "") for k, v in c.get("values", {}).items()
            )
            ho = f"{c['held_out_before_kt']:.3f} → {c['held_out_after_kt']:.3f}" if "held_out_after_kt" in c else ""
            lines.append(
                f"| {eff} | {c['outcome']} | {size} | {c['delta_bic']:.1f} | {c['p_value']:.2g} | {ho} |"
                if "delta_bic" in c
                else f"| {eff} | {c['outcome']} | {size} | | | |"
            )
        lines.append("")
    _wind_along_flight_figure(diag, track, out_dir, knot_s)
    lines += [
        "![The derived wind along the flight, coloured by heading, before and after](figures/wind_along_flight.png)",
        "",
    ]
    atomic_write_text(out_dir / "report.md", "\n".join(lines))


def _wind_along_flight_figure(diag: Diagnosis, track: pd.DataFrame, out_dir: Path, knot_s: float) -> None:
    """The derived wind along the flight, coloured by heading, with the ideal sensor and
    with the findings applied: a heading or airspeed error makes the wind jump when the
    aircraft turns; corrected, it runs on smoothly."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from aerotruth.analysis.wind.modes_wind import design

    effects = tuple(f.effect for f in diag.findings)
    t_min = (track["time_s"].to_numpy() - track["time_s"].iloc[0]) / 60.0
    psi = np.degrees(track["heading_rad"].to_numpy()) % 360
    n = len(track)
    fig, axes = plt.subplots(2, 2, figsize=(11, 6), sharex=True, sharey="row")
    for col, (effs, title) in enumerate(
        (((), "ideal sensor"), (effects, "with the findings" if effects else "no finding"))
    ):
        X, y, names = design(track, knot_s, effs)
        coef, *_ = np.linalg.lstsq(X, y, rcond=None)
        eff_cols = [i for i, nm in enumerate(names) if not nm.startswith("wind_")]
        wind = (y - (X[:, eff_cols] @ coef[eff_cols] if eff_cols else 0.0)) / KT  # V_G - corrected V_A
        for row, (part, label) in enumerate(((slice(0, n), "north"), (slice(n, 2 * n), "east"))):
            ax = axes[row, col]
            sc = ax.scatter(t_min, wind[part], c=psi, cmap="twilight", s=3, vmin=0, vmax=360)
            ax.set_ylabel(f"wind {label} (kt)") if col == 0 else None
            ax.grid(alpha=0.3)
        axes[0, col].set_title(title)
        axes[1, col].set_xlabel("minutes from the first sample used")
    fig.colorbar(sc, ax=axes, label="true heading (deg)")
    (out_dir / "figures").mkdir(exist_ok=True)
    fig.savefig(out_dir / "figures" / "wind_along_flight.png", dpi=130, bbox_inches="tight")
    plt.close(fig)


def _residual_figure(plot: dict, title: str, path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    x = plot["x"]
    lim = np.quantile(np.abs(plot["before"]), 0.98)
    if np.ptp(x) <= 1e-9 * max(1.0, float(np.max(np.abs(x)))):  # a constant term: x says nothing, the distribution does
        fig, ax = plt.subplots(figsize=(7, 4))
        bins = np.linspace(-lim, lim, 61)
        for key, lab, color in (("before", "model without the effect", "0.5"), ("after", "with the effect", "C3")):
            r = plot[key]
            ax.hist(r, bins=bins, histtype="step", color=color, label=f"{lab}: mean {np.mean(r):+.2f} {plot['unit']}")
            ax.axvline(np.mean(r), color=color, ls="--", lw=1)
        ax.set_xlabel(f"{plot['channel']} residual ({plot['unit']})")
        ax.set_ylabel("rows")
        ax.grid(alpha=0.3)
        ax.legend(loc="upper left", fontsize=8)
        title = title.replace("against the effect's term", "distribution (a constant term)")
    else:
        fig, axes = plt.subplots(1, 2, figsize=(10, 4), sharey=True)
        values = np.unique(x)
        if len(values) <= 10:  # a term of a few levels (flight phases): one bin per level
            idx, nb = np.searchsorted(values, x), len(values)
        else:  # 15 bins of equal counts
            edges = np.unique(np.quantile(x, np.linspace(0, 1, 16)))
            idx, nb = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, len(edges) - 2), len(edges) - 1
        full = [k for k in range(nb) if np.any(idx == k)]
        for ax, key, lab in ((axes[0], "before", "model without the effect"), (axes[1], "after", "with the effect")):
            r = plot[key]
            ax.scatter(x, r, s=2, alpha=0.15, color="0.5")
            if nb > 1:
                mids = np.array([np.mean(x[idx == k]) for k in full])
                means = np.array([np.mean(r[idx == k]) for k in full])
                ses = np.array([np.std(r[idx == k]) / math.sqrt(np.sum(idx == k)) for k in full])
                ax.errorbar(mids, means, ses, fmt="o-", color="C3", label="bin mean ± se")
            ax.set_ylim(-lim, lim)
            ax.axhline(0, color="k", lw=0.5)
            ax.set_title(lab)
            ax.set_xlabel(f"the effect's fitted term ({plot['unit']})")
            ax.grid(alpha=0.3)
        axes[0].set_ylabel(f"{plot['channel']} residual ({plot['unit']})")
        if axes[0].get_legend_handles_labels()[0]:
            axes[0].legend(loc="upper left")
    fig.suptitle(title)
    fig.savefig(path, dpi=120, bbox_inches="tight")
    plt.close(fig)


def _data_lines(table: dict) -> list[str]:
    """What was read and what was left out, for report.md."""
    if not table:
        return []
    gates = ", ".join(f"{k} {v}" for k, v in table["row_gates"].items())
    return [
        f"Read {table['rows_read']} rows: {table['rows_dropped_empty']} with an empty required cell and "
        f"{table['rows_dropped_duplicate']} repeating an (aircraft, time, reference) row left out; "
        f"{table['reports']} reports; rows by ground-track gate: {gates}.",
        "",
    ]


# per-item parameters of the library's effects, one phrase per aircraft (reference model)
_ITEMS = {
    "soft_iron": (
        "aircraft",
        lambda x: f"D {x['D_deg']:+.2f} ± {x['D_se_deg']:.2f}, E {x['E_deg']:+.2f} ± {x['E_se_deg']:.2f} deg",
    ),
    "tas_scale": ("aircraft", lambda x: f"k {x['k']:+.4f} ± {x['se']:.4f}"),
    "reference_bias": (
        "bias_kt",
        lambda x: (
            f"{x['value']:+.2f} ± {x['se']:.2f} kt along the wind, or a scale of its wind "
            f"{100 * x['scale']['value']:+.1f} ± {100 * x['scale']['se']:.1f} %; "
            f"the {x['form']} fits better"
        ),
    ),
    "recalibration": ("steps", lambda x: f"{x['step_deg']:+.2f} ± {x['se_deg']:.2f} deg at {x['time_utc']}"),
    "offset_drift": (
        "aircraft",
        lambda x: (
            f"{x['rate_deg_per_day']:+.3f} ± {x['se_deg_per_day']:.3f} deg/day "
            f"({x['change_deg']:+.2f} deg over {x['days']:.1f} days)"
        ),
    ),
}


def _fmt_params(effect: str, p: dict) -> str:
    """The finding's parameters in words: its summary values, then each aircraft's (or model's)."""
    parts = [
        f"{k} = {v['value']:.4g} ± {v['se']:.2g}" + (f" (model {v['model']:g})" if "model" in v else "")
        for k, v in p.items()
        if isinstance(v, dict) and "value" in v
    ]
    if effect in _ITEMS:
        key, phrase = _ITEMS[effect]
        parts += [f"{name}: {phrase(x)}" for name, x in p[key].items()]
    return "; ".join(parts) or (p.get("signature") or "")


def _group_name(f) -> str:
    """A finding's name, with the rivals the data cannot tell from it: "a or b (confusable)"."""
    alts = [r["effect"] for r in f.parameters.get("confusable_with", [])]
    return f.effect if not alts else f"{f.effect} or {' or '.join(alts)} (confusable)"


def _units_text(baseline: dict) -> str:
    """The tests' units and why (baseline["units"]; reports written before it: weather blocks)."""
    u = baseline.get("units")
    if u is None:
        return f"{baseline['weather_blocks']} six-hour weather blocks"
    what = "flights" if u["unit"] == "flight" else "six-hour weather blocks"
    return f"{u['count']} {what}: {u['why']}"


def _field_lines(field: dict | None) -> list[str]:
    """The reference models' error the aircraft share (baseline["reference_field"],
    wind_field), in one paragraph; none where the data show no such field."""
    if not field:
        return []

    def length(v: float, unit: str) -> str:
        return "any" if not math.isfinite(v) or v > 1e5 else f"{v:,.0f} {unit}"

    return [
        f"The reference models' error as the aircraft share it: {field['field_rms_ms']:.1f} m/s per component "
        f"({100 * field['share']:.0f} % of the residual's variance), correlated over "
        f"{length(field['horizontal_km'], 'km')}, "
        f"{length(field['vertical_m'], 'm')} of altitude and {length(field['time_min'], 'min')} (e-folding, from "
        f"{field['pairs']:,} pairs of rows of different aircraft); each aircraft's recalibration and drift scans, "
        "and the tests of its own soft iron and field scaling, measure it against that error as the other aircraft "
        "saw it.",
        "",
    ]


def _weights_text(baseline: dict) -> str:
    """The fit and its working covariance in one clause (baseline["weights"]; reports written
    before it: the ordinary fit)."""
    w = baseline.get("weights")
    if w is None or "form" in w:
        return "Fitted by ordinary least squares."
    parts = [
        f"{ch} {100 * w[ch]['correlated_share']:.0f} % over {w[ch]['tau_s'] / 60:.0f} min"
        for ch in ("transverse", "along")
        if w[ch]["correlated_share"] > 0
    ]
    return (
        "Fitted by generalised least squares: each report weighed for the error it shares with its "
        f"neighbours of the same flight and reference ({', '.join(parts)}) and for its ground track's "
        f"rounding (positions to {w['position_step_deg']:g} deg)."
    )


def write_wind_diagnosis(
    measured: str, findings: list, baseline: dict, spec: WindModelSpec, extended: WindModelSpec, plots: dict, out_dir
) -> None:
    """DIR/diagnosis.json, DIR/report.md, DIR/figures/<effect>.png."""
    import json
    from dataclasses import asdict
    from pathlib import Path

    from aerotruth.files import atomic_write_text

    out = Path(out_dir)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    doc = {
        "measured": str(measured),
        "kind": "observation_table",
        "model": spec.model_dump(mode="json"),
        "findings": [asdict(f) for f in findings],
        "baseline": baseline,
        "extended_model": extended.model_dump(mode="json"),
    }
    atomic_write_text(out / "diagnosis.json", json.dumps(doc, indent=2, default=float) + "\n")
    rr = baseline["residual_rms_kt"]
    lines = [
        f"# Diagnosis of `{measured}` (observation table)",
        "",
        f"{baseline['reports']} reports of {baseline['aircraft']} aircraft in {baseline['flights']} flights; "
        f"{baseline['rows']} (report, reference) rows pass the wind paper's ground-track gates.",
        "",
        *_data_lines(baseline.get("data") or {}),
        "Model: each aircraft's heading deviation A + B sin z + C cos z"
        + (" + D sin 2z + E cos 2z" if spec.deviation_terms == 5 else "")
        + f" (wind paper eq. 2), field scaling gamma = {spec.field_scaling:g}, "
        f"lat/lon grid {spec.lat_lon_step_deg:g} deg"
        + ("; a TAS bias per aircraft" if spec.tas_bias else "")
        + ("; TAS along the air path" if spec.tas_along_path else "")
        + f". Tests on {_units_text(baseline)}. {_weights_text(baseline)}",
        "",
        *_field_lines(baseline.get("reference_field")),
        f"Residual RMS (kt), transverse {rr['transverse_before']:.2f} → {rr['transverse_after']:.2f}, along "
        f"{rr['along_before']:.2f} → {rr['along_after']:.2f} (model → extended model).",
        "",
    ]
    if "not_tested" in baseline:
        lines += [f"**Not tested**: {baseline['not_tested']}", ""]
    elif not findings:
        lines += [
            "**No finding**: nothing in the effects library or the screening is significant at the family-wise "
            f"{100 * baseline['alpha']['family_wise']:.0f} % level with a held-out gain.",
            "",
        ]
    free = baseline.get("free_terms") or {}
    if free:
        lines += [
            "Terms the model has, fitted: "
            + "; ".join(
                f"{k} {v['slope']:+.3g} ± {v['se']:.2g} {v['unit']}"
                if np.isfinite(v["se"])
                else f"{k} (no reports to fit it)"
                for k, v in free.items()
            ),
            "",
        ]
    for i, f in enumerate(findings, 1):
        ev = f.evidence
        pv = f"p = {ev['p_value']:.2g}" if "p_value" in ev else f"log10 p = {ev['log10_p']:.0f}"
        g = f.gain
        lines += [
            f"## {i}. {_group_name(f)}",
            "",
            f.cause,
            "",
            f"* parameters: {_fmt_params(f.effect, f.parameters)}",
            f"* evidence: {ev['test']}, {pv} (level {ev['alpha']:.2g})",
            f"* gain: {g['metric']}: {g['before']:.3g} → {g['after']:.3g}; held out {g['held_out_before']:.3g} → "
            f"{g['held_out_after']:.3g}",
        ]
        for r in f.parameters.get("confusable_with", []):
            lines.append(
                f"* confusable: {r['effect']}" + (f" ({r['signature']})" if "signature" in r else "") + f": p = "
                f"{r['p_value']:.2g}, held out {r['held_out_before_kt']:.3g} → {r['held_out_after_kt']:.3g}; "
                f"with this finding in the model p = {r['p_given_the_finding']:.2g}; held-out contest t = "
                f"{r['held_out_t']:+.2f} (positive: this finding predicts better)"
            )
        beaten = [k for k, v in ev.get("rivals", {}).items() if v["verdict"] == "beaten"]
        if beaten:
            lines.append(
                "* beaten on held-out weather blocks (explained by this finding, and predicting worse): "
                + ", ".join(beaten)
            )
        if "forms_chosen" in ev:
            fc = ev["forms_chosen"]
            lines += [
                "* in the forms that fit each reference ("
                + ", ".join(f"{k}: {v}" for k, v in fc["forms"].items())
                + f"): p = {fc['p_value']:.2g}; held out {fc['held_out_before']:.3g} → {fc['held_out_after']:.3g}"
            ]
        lines += [""]
        if f.effect in plots:
            name = f.effect.replace(":", "_").replace("+", "_")
            _residual_figure(
                plots[f.effect], f"{f.effect}: residual against the effect's term", out / "figures" / f"{name}.png"
            )
            lines += [f"![{f.effect}](figures/{name}.png)", ""]
    for s in baseline["not_identifiable"]:
        lines += [f"* not identifiable: {s}"]
    fits = baseline["model_fit"]
    dh = baseline.get("deviation_heading")
    lines += ["", "## The model's fit per aircraft", ""]
    if dh:
        rms = dh["transverse_rms_kt"]
        how = "as the model states" if dh["asked"] != "auto" else "the one the data follow"
        lines += [
            f"The deviation's harmonics are of the {dh['chosen']} heading ({how}; transverse residual RMS "
            f"{rms['magnetic']:.3f} kt of the magnetic heading, {rms['true']:.3f} kt of the true heading).",
            "",
        ]
    lines += [
        "| aircraft | status | A (deg) | B (deg) | C (deg) | flights | reason |",
        "|---|---|---|---|---|---|---|",
    ]
    for a, r in fits.items():
        drift = (
            f" drifting {r['A_drift_deg_per_day']:+.3f} ± {r['A_drift_se_deg_per_day']:.3f} deg/day"
            if "A_drift_deg_per_day" in r
            else ""
        )
        lines.append(
            f"| {a} | {r['status']} | {r.get('A_deg', float('nan')):+.2f} ± {r.get('A_se_deg', float('nan')):.2f}"
            f"{drift} | {r.get('B_deg', float('nan')):+.2f} | {r.get('C_deg', float('nan')):+.2f} | {r['flights']} | "
            f"{r['reason']} |"
        )
    atomic_write_text(out / "report.md", "\n".join(lines) + "\n")


def write_log_diagnosis(
    path, df: pd.DataFrame, findings: list[Finding], baseline: dict, model: FitsModel, out_dir
) -> None:
    """DIR/diagnosis.json, DIR/report.md and DIR/figures/waas_periodogram.png."""
    import json
    from dataclasses import asdict
    from pathlib import Path

    from aerotruth.analysis.diagnose.modes import Diagnosis
    from aerotruth.files import atomic_write_text

    out = Path(out_dir)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    diag = Diagnosis(str(path), "approach_log", int(len(df)), {}, findings, {**baseline, "model": asdict(model)})
    atomic_write_text(out / "diagnosis.json", json.dumps(asdict(diag), indent=2, default=float) + "\n")
    lines = [
        f"# Diagnosis of `{path}`",
        "",
        f"Kind: approach log; {baseline['approaches']} approaches; DGPS truth: "
        f"{'yes' if baseline['dgps'] else 'no (only the INS frame and the cyclic period can be tested)'}.",
        "",
        f"Model: WAAS cyclic period {model.period_s:g} s, {model.grade} INS ({model.accel_bias_ug:g} ug), "
        "DGPS survey offset "
        f"{tuple(model.dgps_offset_m)} m.",
        "",
    ]
    if "fits_minus_dgps_rms_m" in baseline:
        lines += [
            f"Baseline: FITS minus DGPS, cross-track and vertical, RMS {baseline['fits_minus_dgps_rms_m']:.3f} m.",
            "",
        ]
    if not findings:
        lines += ["**No finding**: the log agrees with the model within the tests' thresholds.", ""]
    for i, f in enumerate(findings, 1):
        ps = ", ".join(f"{k} = {v['value']:.4g} ± {v['se']:.2g}" for k, v in f.parameters.items())
        g = f.gain
        lines += [
            f"## {i}. {f.effect}",
            "",
            f.cause,
            "",
            f"* parameters: {ps}",
            "* evidence: "
            + ", ".join(f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in f.evidence.items()),
            f"* {g.get('unit', '')}: {g.get('before', float('nan')):.4g} → {g.get('after', float('nan')):.4g}; "
            "held out "
            f"{g.get('held_out_before', float('nan')):.4g} → {g.get('held_out_after', float('nan')):.4g}"
            + (f" ({g['note']})" if "note" in g else ""),
            "",
        ]
    _periodogram_figure(df, path, model, out / "figures" / "waas_periodogram.png")
    lines += ["![Periodogram of WAAS - INS with the model's cyclic period](figures/waas_periodogram.png)", ""]
    atomic_write_text(out / "report.md", "\n".join(lines))


def _periodogram_figure(df: pd.DataFrame, path, model: FitsModel, png) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    grid, pm = mean_periodogram(checked_approaches(path, df))
    fig, ax = plt.subplots(figsize=(7, 3.6))
    if pm is not None:
        ax.semilogy(1.0 / grid, pm)
    ax.axvline(model.period_s, color="C3", ls="--", label=f"model period {model.period_s:g} s")
    ax.set(xlabel="period (s)", ylabel="power (m²/Hz)", title="WAAS - INS, detrended, mean periodogram", xlim=(2, 40))
    ax.legend()
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(png, dpi=120)
    plt.close(fig)
