"""`aerotruth heading fit OBS --out DIR`: the wind paper's heading-deviation method on a
user's observation table (CSV or Parquet, docs/data-formats.md).

Writes
  DIR/deviation.csv      one row per aircraft, fit on true heading (the paper's choice):
                         aircraft, status, reason, n_used, A..E_deg, A..E_se_deg,
                         lut_000_deg .. lut_315_deg, valid_from, valid_to, then extras;
  DIR/deviation_mag.csv  the same columns fit on magnetic heading (the frame the onboard
                         table is indexed by), when the table has `heading_mag_deg` or
                         `declination_deg`;
  DIR/deviation_ci.csv   (and deviation_mag_ci.csv) cluster-resampling bootstrap-t intervals
                         of each aircraft's A..E and 8 table entries: aircraft, quantity,
                         estimate, lo, hi, boot_se, level, n_boot, method (`--bootstrap N`,
                         0: none; an aircraft with fewer than 10 clusters gets t intervals
                         on its cluster-robust standard errors, method "t, G-1 df");
  DIR/figures/<aircraft>.png  heading error vs measured heading with the fit and the
                         8-point table (wind paper Figs. 3 and 8);
  DIR/report.md          what was used and rejected, the fits, criteria, the in-sample
                         wind errors before/after (wind paper section 6 components).
"""

from __future__ import annotations

import hashlib
import math
import re
import sys
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.wind.fleet_checks import (
    bootstrap_table,
    magnetic_heading_warnings,
    require_used_reports,
)
from aerotruth.analysis.wind.heading_correction import (
    LUT_HEADINGS_DEG,
    STATUSES,
    FleetHeadingFit,
)
from aerotruth.analysis.wind.heading_errors import GATE_NAMES, data_gates, heading_errors
from aerotruth.analysis.wind.metrics import wind_errors_before_after
from aerotruth.app.reports import observations_or_traffic_hint
from aerotruth.errors import DataError, output_folder
from aerotruth.files import atomic_write, atomic_write_text
from aerotruth.markdown import to_markdown

MIN_REPORTS = 30  # usable reports an aircraft needs for a table
MIN_FLIGHTS = 5  # clusters an aircraft needs when they are whole flights (sparse reports)
MIN_BLOCKS = 2  # ... when they are time blocks (dense reports): the fewest a cluster-robust se takes
MAX_SINUSOID_SE_DEG = 1.0  # a sinusoid less determined than this is not uploaded: offset only
MAX_BOOTSTRAP = 100_000


MAX_FIGURE_STEM = 80  # characters of a figure's file name before ".png": far below any file system's limit


def _safe_name(aircraft: str) -> str:
    """The aircraft id as a file-name stem: letters, digits, `_`, `.`, `-`; anything else,
    and a leading dot (a hidden file), as `_`."""
    return re.sub(r"^\.", "_", re.sub(r"[^A-Za-z0-9_.-]", "_", aircraft)) or "aircraft"


def _shown(aircraft: str) -> str:
    """An aircraft id as markdown code: a backtick or a line break would end it."""
    return str(aircraft).replace("`", "'").replace("\n", " ").replace("\r", " ")


def _hashed(aircraft: str, clean: str, digits: int = 8) -> str:
    tag = hashlib.sha256(aircraft.encode("utf-8", "surrogatepass")).hexdigest()[:digits]
    return f"{clean[: MAX_FIGURE_STEM - digits - 1]}-{tag}"


def figure_stems(aircraft: list[str]) -> dict[str, str]:
    """A file-name stem for each aircraft's figure, unique (also where case is not told
    apart, as on macOS and Windows) and at most MAX_FIGURE_STEM characters: the id cleaned
    (`_safe_name`); where that is longer, or where several ids clean to one name (`N401/XJ`,
    `N401_XJ`), the cleaned id cut short plus 8 hex digits of the id's SHA-256 (an id that
    is its own clean name keeps it)."""
    clean = {a: _safe_name(a) for a in aircraft}
    groups: dict[str, list[str]] = {}
    for a, c in clean.items():
        groups.setdefault(c.casefold(), []).append(a)
    stems = {}
    for members in groups.values():
        plain = [a for a in members if clean[a] == a]
        for a in members:
            keep = len(clean[a]) <= MAX_FIGURE_STEM and (len(members) == 1 or plain == [a])
            stems[a] = clean[a] if keep else _hashed(a, clean[a])
    seen: dict[str, int] = {}
    for s in stems.values():
        seen[s.casefold()] = seen.get(s.casefold(), 0) + 1
    for a, s in stems.items():  # a hashed stem that meets another id's own name: a longer hash
        if seen[s.casefold()] > 1 and s != clean[a]:
            stems[a] = _hashed(a, clean[a], 24)
    return stems


def _figure(fit, rows: pd.DataFrame, col: str, path: Path, ci: pd.DataFrame | None = None) -> None:
    """Heading error vs measured heading with the fit and the 8-point table (wind paper Figs.
    3/8); with `ci` (the aircraft's rows of deviation_ci.csv) the table points carry their
    bootstrap intervals."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    used = rows["gate"].to_numpy() == "used"
    z, d = rows[col].to_numpy()[used], rows["error_deg"].to_numpy()[used]
    fig, ax = plt.subplots(figsize=(7.5, 4.2))
    if len(z) > 20000:  # keep the figure light: a random 20,000-report subsample
        pick = np.random.default_rng(0).choice(len(z), 20000, replace=False)
        z, d = z[pick], d[pick]
    ax.scatter(z, d, s=2, alpha=0.25, color="0.35", lw=0, label="reports (psi - psi')")
    if fit.status_ != "refused":
        zz = np.arange(0.0, 360.5, 1.0)
        ax.plot(zz, fit.deviation(zz), color="C3", lw=2, label=f"fit ({fit.status_}, terms {''.join(fit.terms_)})")
        ax.plot(
            np.r_[LUT_HEADINGS_DEG, 360.0],
            -np.r_[fit.lut_, fit.lut_[0]],
            "o--",
            color="C0",
            ms=5,
            label="8-point table (minus the correction)",
        )
        if ci is not None and len(ci):
            lut = ci.set_index("quantity").reindex([f"lut_{int(h):03d}_deg" for h in LUT_HEADINGS_DEG])
            est, lo_, hi_ = -lut["estimate"].to_numpy(), -lut["hi"].to_numpy(), -lut["lo"].to_numpy()
            ax.errorbar(
                LUT_HEADINGS_DEG,
                est,
                yerr=[est - lo_, hi_ - est],
                fmt="none",
                ecolor="C0",
                capsize=4,
                label=f"{ci['level'].iloc[0]:.0%} bootstrap intervals",
            )
    ax.axhline(0, color="k", lw=0.5)
    ax.set_xlim(0, 360)
    ax.set_xticks(np.arange(0, 361, 45))
    lo, hi = np.nanpercentile(d, [0.5, 99.5]) if len(d) else (-3.0, 3.0)
    ax.set_ylim(min(lo, -1.0) - 0.5, max(hi, 1.0) + 0.5)
    ax.set_xlabel(f"measured heading ({'magnetic' if 'mag' in col else 'true'}), deg")
    ax.set_ylabel("heading error psi - psi', deg")
    title = f"{fit.aircraft_}: {fit.n_used_} reports {fit.valid_from_} to {fit.valid_to_}"
    if fit.status_ == "refused":  # no curve to show: say why on the figure
        title += f"\nno fit: {fit.reason_.split(';')[0]}"
    ax.set_title(title, fontsize=10)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    atomic_write(path, lambda tmp: fig.savefig(tmp, format="png", dpi=120))
    plt.close(fig)


def _report(
    obs: pd.DataFrame,
    rows: pd.DataFrame,
    fleet: FleetHeadingFit,
    mag: FleetHeadingFit | None,
    src: str,
    ci: pd.DataFrame | None = None,
    warnings: list[str] = (),
    limits: str = "",
    figures: dict[str, str] | None = None,
) -> str:
    gates = rows.drop_duplicates("report")["gate"].value_counts().reindex(GATE_NAMES, fill_value=0)
    table = fleet.to_table()
    out = [
        f"# Heading deviation fit: {src}",
        "",
        f"{obs['aircraft'].nunique()} aircraft, {rows['report'].nunique()} reports, "
        f"{len(rows)} (report, reference) rows "
        f"from {', '.join(sorted(map(str, obs['ref_source'].unique())))}; "
        f"{obs.attrs.get('dropped_empty', 0)} rows with an empty required cell and "
        f"{obs.attrs.get('dropped_duplicates', 0)} duplicate rows skipped.",
        "",
        "## Reports through the three-report ground-track gates (wind paper 5.1)",
        "",
        *([f"Read off the data: {limits}.", ""] if limits else []),
        "| gate | reports |",
        "|---|---|",
        *[f"| {g} | {int(n)} |" for g, n in gates.items()],
        "",
        "## Fit on true heading (deviation.csv)",
        "",
        to_markdown(
            table[
                [
                    "aircraft",
                    "status",
                    "n_used",
                    "A_deg",
                    "B_deg",
                    "C_deg",
                    "D_deg",
                    "E_deg",
                    "A_se_deg",
                    "B_se_deg",
                    "C_se_deg",
                ]
            ]
        ),
        "",
        "Reasons:",
        "",
        *[f"* {r.aircraft}: {r.reason}" for r in table.itertuples()],
        "",
    ]
    if warnings:
        out += ["## Warnings", "", *[f"* {w}" for w in warnings], ""]
    if mag is not None:
        mt = mag.to_table()
        out += [
            "## Fit on magnetic heading (deviation_mag.csv; the onboard table's index)",
            "",
            to_markdown(
                mt[
                    [
                        "aircraft",
                        "status",
                        "n_used",
                        "A_deg",
                        "B_deg",
                        "C_deg",
                        "D_deg",
                        "E_deg",
                        "B_se_deg",
                        "C_se_deg",
                    ]
                ]
            ),
            "",
        ]
    if ci is not None and len(ci):
        lut = ci[ci["quantity"].str.startswith("lut_")]
        wide = lut.assign(
            cell=[
                f"{e:+.2f} [{lo:+.2f}, {hi:+.2f}]"
                for e, lo, hi in zip(lut["estimate"], lut["lo"], lut["hi"], strict=False)
            ]
        )
        wide = wide.pivot(index="aircraft", columns="quantity", values="cell").reset_index()
        out += [
            f"## Lookup tables with {ci['level'].iloc[0]:.0%} bootstrap intervals (deviation_ci.csv; "
            f"{int(ci['n_boot'].iloc[0])} cluster resamples; t intervals for aircraft with fewer than 10 clusters)",
            "",
            "Correction to add (deg) at each measured true heading. For an aircraft fitted on one axis the "
            "intervals hold the along-axis curve's uncertainty only: its perpendicular part is not measured "
            "(taken as zero).",
            "",
            to_markdown(wide),
            "",
        ]
    used = rows["gate"].to_numpy() == "used"
    ru = rows.loc[used]
    before, after = wind_errors_before_after(ru, fleet.correction(ru["aircraft"].array, ru["heading_deg"].to_numpy()))
    out += [
        "## Wind error against the references, used reports (in sample)",
        "",
        "| | RMS kt | longitudinal kt | transverse kt |",
        "|---|---|---|---|",
        f"| before | {before['rms_kt']:.2f} | {before['longitudinal_kt']:.2f} | {before['transverse_kt']:.2f} |",
        f"| after the lookup tables | {after['rms_kt']:.2f} | {after['longitudinal_kt']:.2f} "
        f"| {after['transverse_kt']:.2f} |",
        "",
        "In-sample: the tables were fitted on these reports; judge them on a later period (the paper's "
        "before/after with a control group): `aerotruth heading apply LATER_OBS --tables deviation.csv --out DIR`.",
        "",
    ]
    if figures:
        out += [
            "## Figures",
            "",
            "Heading error against the measured heading, the fit and the 8-point table, one file per aircraft "
            "(an id that is not a plain file name, or is long, or cleans to another's name, carries a short hash):",
            "",
            *[f"* `{_shown(a)}`: [{path}]({path})" for a, path in figures.items()],
            "",
        ]
    out += [
        "## Method and criteria",
        "",
        "* Heading error psi - psi' = angle(V_G - V_W,TAM) - angle(V_G - V_W,REF) (wind paper eqs. 3, 4) against "
        "the measured heading (the `heading_deg` column where given, else the angle of V_A).",
        "* Fit of d = A + B sin z + C cos z + D sin 2z + E cos 2z (eq. 2): Huber M-estimate (c = 1.345, MAD scale), "
        "weights TAS^2; standard errors clustered by flight or time block (leave-one-cluster-out, CR3).",
        "* Sinusoid fitted only when the smaller eigenvalue of the covariance of (sin z, cos z) is >= 0.1 "
        "(uniform headings 0.5); else offset only. D, E kept when the flight-clustered Wald test rejects "
        "D = E = 0 at 0.001.",
        "* Reference models: all (report, model) pairs pooled; each model alone for the consistency check "
        "(Wald test of equal curves, p < 0.01 flagged).",
        "* Lookup table: correction to add at 0, 45, ..., 315 deg = -d(z); applied by piecewise-linear "
        "interpolation round the circle. Aircraft with `heading_input` = true: offset only (wind paper 8.4).",
        "",
    ]
    return "\n".join(out)


def _digits(n: int) -> str:
    """An integer option's value in a message: a long one by its number of digits."""
    text = str(n)
    return text if len(text) <= 24 else f"an integer of {len(text.lstrip('-'))} digits"


def heading_fit_main(
    obs_path: str,
    out_dir: str,
    n_boot: int = 200,
    seed: int = 0,
    min_reports: int = MIN_REPORTS,
    min_clusters: int | None = None,
    cluster_s: float | None = None,
    position_step_deg: float | None = None,
    max_sinusoid_se_deg: float = MAX_SINUSOID_SE_DEG,
) -> int:
    """Run the method on an observation table and write DIR/deviation.csv (and
    deviation_mag.csv), with `n_boot` > 0 the bootstrap intervals DIR/deviation_ci.csv (and
    deviation_mag_ci.csv), figures and report.md. The position resolution and the clustering
    unit are read off the table unless given (heading_errors.data_gates); `min_clusters`
    defaults to MIN_FLIGHTS when the clusters are whole flights, MIN_BLOCKS when they are time
    blocks. Returns 0; bad input raises DataError (a ValueError) with one line naming file and
    column or option."""
    if n_boot < 0 or n_boot == 1:
        raise DataError(f"--bootstrap: expected 0 (none) or at least 2 resamples, got {_digits(n_boot)}")
    if n_boot > MAX_BOOTSTRAP:
        raise DataError(f"--bootstrap: expected at most {MAX_BOOTSTRAP} resamples, got {_digits(n_boot)}")
    if not 0 <= seed < 2**63:
        raise DataError(f"--seed: expected a whole number from 0 to 2**63 - 1, got {_digits(seed)}")
    if min_reports < 1:
        raise DataError(f"--min-reports: expected a whole number >= 1, got {_digits(min_reports)}")
    if min_clusters is not None and min_clusters < 2:
        raise DataError(
            f"--min-clusters: expected a whole number >= 2 (standard errors need two), got {_digits(min_clusters)}"
        )
    for name, v in (("--cluster-s", cluster_s), ("--position-step-deg", position_step_deg)):
        if v is not None and not (math.isfinite(v) and 0 <= v <= 1e6):
            raise DataError(f"{name}: expected a number >= 0 and <= 1,000,000 (0: none), got {v:g}")
    if not (math.isfinite(max_sinusoid_se_deg) and max_sinusoid_se_deg > 0):
        raise DataError(f"--max-sinusoid-se-deg: expected a positive number of degrees, got {max_sinusoid_se_deg}")
    out = output_folder(out_dir)  # before the work
    obs = observations_or_traffic_hint(obs_path)
    dg = data_gates(obs, cluster_s=cluster_s, position_step_deg=position_step_deg)
    rows = heading_errors(obs, dg.gates)
    require_used_reports(rows, obs_path)
    if min_clusters is None:
        min_clusters = MIN_BLOCKS if dg.gates.cluster_s > 0 else MIN_FLIGHTS
    params = dict(min_reports=min_reports, min_clusters=min_clusters, max_sinusoid_se_deg=max_sinusoid_se_deg)
    fleet = FleetHeadingFit(heading="true", **params).fit(rows)
    mag = None
    if np.isfinite(rows["heading_mag_deg"].to_numpy()).any():
        mag = FleetHeadingFit(heading="magnetic", **params).fit(rows)
    (out / "figures").mkdir(parents=True, exist_ok=True)
    ci = None
    for fl, stem in ((fleet, "deviation"), (mag, "deviation_mag")):
        if fl is None:
            continue
        atomic_write_text(out / f"{stem}.csv", fl.to_table().to_csv(index=False))  # TABLE_COLUMNS first
        if n_boot:
            t = bootstrap_table(fl, n_boot, seed)
            atomic_write_text(out / f"{stem}_ci.csv", t.to_csv(index=False))
            ci = t if fl is fleet else ci
    ac = rows["aircraft"].to_numpy()
    stems = figure_stems([str(name) for name in fleet.fits_])
    figures = {name: f"figures/{stems[str(name)]}.png" for name in fleet.fits_}
    for name, fit in fleet.fits_.items():
        mine = ci[ci["aircraft"] == name] if ci is not None else None
        _figure(fit, rows.loc[ac == name], "heading_deg", out / figures[name], mine)
    warnings = magnetic_heading_warnings(obs, rows)
    limits = (
        f"{dg.describe()}; an aircraft is fitted with at least {min_reports} usable reports in {min_clusters} "
        f"clusters; its sinusoid is kept while its standard error is at most {max_sinusoid_se_deg:g} deg"
    )
    atomic_write_text(out / "report.md", _report(obs, rows, fleet, mag, str(obs_path), ci, warnings, limits, figures))
    status = pd.Series([f.status_ for f in fleet.fits_.values()]).value_counts()
    print(
        f"{obs_path}: {len(fleet.fits_)} aircraft: "
        + ", ".join(f"{int(status.get(k, 0))} {k}" for k in STATUSES)
        + f" -> {out / 'deviation.csv'}"
    )
    for w in warnings:
        print(f"aerotruth heading: warning: {obs_path}: {w}", file=sys.stderr)
    return 0
