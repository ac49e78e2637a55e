"""`aerotruth fits LOG --out DIR`: the WAAS-aided FITS (aerotruth.analysis.fits.filter) on an
approach log (docs/data-formats.md, "Approach log").

Reads CSV or Parquet, checks it (one error naming the file, approach and column), runs
the FITS per approach and writes into DIR:

* trajectory.csv: approach, time_s, x_m, y_m, z_m (runway frame, eq. 19) at every WAAS epoch;
* trajectory_8hz.csv: the same on the paper's 8 Hz grid (carried by the INS between epochs);
* cyclic_noise.csv: approach, time_s, n_x_m, n_y_m, n_z_m (the estimated cyclic noise);
* bias.csv: approach, bias_x_m, bias_y_m, bias_z_m (eq. 18), jumps (flagged epochs compensated);
* where the log holds DGPS (dgps_x_m, dgps_y_m, dgps_z_m): errors.csv (FITS minus DGPS at
  the WAAS epochs, angular errors and requirement verdicts from aerotruth.analysis.fits.ils_metrics)
  and requirement.png (cross-track and vertical errors against the 0.015/0.05 deg lines).

The log is checked against its contract first (aerotruth.analysis.fits.approach_log:
rows, times, gaps, WAAS epochs, units from the physics, events), and a log of 3 or more
approaches whose INS columns are not in the runway frame (an axis of the other sign, two
swapped, the horizontal axes turned: aerotruth.analysis.fits.ins_frame, from the aircraft's
motion beyond a drift) is refused naming the columns; fewer approaches are not checked (a
single approach can mislead). The runway geometry for the angular errors is read by
aerotruth.measured.approach_log (a sidecar `<log>.runway.json` or the Parquet metadata key
`runway`; without either, a standard installation on a 3,000 m runway, said in the output).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.fits.approach_log import (
    DGPS,
    approach_inputs,
    check_approach,
    fits_of,
    geometry_of,
    retagged,
    split_events,
)
from aerotruth.analysis.fits.filter import FitsSpec
from aerotruth.analysis.fits.ils_metrics import (
    FLOOR_HORIZONTAL_M,
    FLOOR_VERTICAL_M,
    REQUIREMENTS,
    approach_errors,
    approach_verdict,
    required_error_m,
)
from aerotruth.analysis.fits.ins_frame import frame_error
from aerotruth.errors import DataError, output_folder
from aerotruth.files import atomic_write, atomic_write_text, make_folder
from aerotruth.measured.approach_log import read_approach_log, runway_geometry
from aerotruth.units import NM

SUMMARY_FROM_NM = 10.0  # the command line's summary: from the threshold out to this distance


def _requirement_figure(errors: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    d_nm = errors["distance_to_threshold_m"] / NM
    for ax, col, rng_col, floor, label in (
        (axes[0], "cross_m", "range_loc_m", FLOOR_HORIZONTAL_M, "cross-track"),
        (axes[1], "vertical_m", "range_gp_m", FLOOR_VERTICAL_M, "vertical"),
    ):
        for a, e in errors.groupby("approach"):
            ax.plot(d_nm[e.index], e[col], lw=0.8, label=f"approach {a}" if errors["approach"].nunique() <= 8 else None)
        order = np.argsort(d_nm.to_numpy())
        for name, alpha in REQUIREMENTS.items():
            req = required_error_m(errors[rng_col].to_numpy()[order], alpha, floor)
            ls = "--" if name == "desired" else "-"
            ax.plot(d_nm.to_numpy()[order], req, "k", ls=ls, lw=1, label=f"{alpha} deg ({name})")
            ax.plot(d_nm.to_numpy()[order], -req, "k", ls=ls, lw=1)
        lim = max(1.0, 3.0 * float(np.nanpercentile(np.abs(errors[col]), 99)))
        ax.set(ylabel=f"{label} error (m)", title=f"WAAS-aided FITS minus DGPS, {label}", ylim=(-lim, lim))
        ax.legend(fontsize=7, loc="upper right")
    axes[1].set_xlabel("distance to threshold (NM)")
    fig.tight_layout()
    fig.savefig(path, format="png", dpi=120)
    plt.close(fig)


def fits_main(log_path: str, out_dir: str, spec: FitsSpec | None = None) -> int:
    """Run the FITS on every approach of the log at `log_path`; write the files listed in
    the module docstring into `out_dir`. Bad input raises DataError (a ValueError) with one
    line naming the file, approach and column."""
    spec = spec or FitsSpec()
    p, out = Path(log_path), output_folder(out_dir)  # the output checked before the work
    df = read_approach_log(p)
    has_dgps = all(c in df.columns for c in DGPS) and np.isfinite(df[list(DGPS)].to_numpy()).any()
    geoms, geom_src = runway_geometry(p)
    missing = [a for a in df["approach"].unique() if geometry_of(geoms, a) is None]
    if missing:  # a file of per-approach geometries: every approach of the log needs its own
        a = missing[0].item() if isinstance(missing[0], np.generic) else missing[0]
        raise DataError(
            f"{geom_src}: no runway geometry for approach {a!r} (it has "
            f"{', '.join(map(str, geoms))}); give every approach one, or one for the whole log"
        )
    approaches = []
    for a, g in df.groupby("approach", sort=False):
        check_approach(p, a, g)
        approaches.append((a, g, retagged(approach_inputs(g), spec.waas_latency_s)))
    fe = frame_error([inputs for _, _, inputs in approaches])  # needs 3 approaches: a single one can mislead
    if fe is not None:
        raise DataError(
            f"{p}: columns ins_x_m/ins_y_m/ins_z_m: {'; '.join(fe.said())} (beyond a drift the INS follows "
            f"the aircraft's motion as the WAAS sees it with loadings {fe.loads()}, over {len(approaches)} "
            "approaches); expected the runway frame, x along the course, y left, z up"
        )
    traj, grid, noise, bias, errs = [], [], [], [], []
    for a, g, inputs in approaches:
        try:
            r = fits_of(inputs, spec)
        except ValueError as exc:
            raise DataError(f"{p}: approach {a!r}: {exc}") from None
        nl = r.noiseless
        g, _ = split_events(g)
        traj.append(
            pd.DataFrame(
                {"approach": a, "time_s": nl.t_s, "x_m": r.xyz_m[:, 0], "y_m": r.xyz_m[:, 1], "z_m": r.xyz_m[:, 2]}
            )
        )
        tg, pg = r.on_grid(g["time_s"].to_numpy(), g[["ins_x_m", "ins_y_m", "ins_z_m"]].to_numpy(), spec.grid_rate_hz)
        grid.append(pd.DataFrame({"approach": a, "time_s": tg, "x_m": pg[:, 0], "y_m": pg[:, 1], "z_m": pg[:, 2]}))
        noise.append(
            pd.DataFrame(
                {
                    "approach": a,
                    "time_s": nl.t_s,
                    "n_x_m": nl.n_hat[:, 0],
                    "n_y_m": nl.n_hat[:, 1],
                    "n_z_m": nl.n_hat[:, 2],
                }
            )
        )
        bias.append(
            {
                "approach": a,
                "bias_x_m": r.bias_m[0],
                "bias_y_m": r.bias_m[1],
                "bias_z_m": r.bias_m[2],
                "jumps": len(nl.jump_idx),
            }
        )
        if has_dgps:
            d = inputs.dgps_w  # at the (re-tagged) WAAS epochs
            ok = np.isfinite(d).all(axis=1)
            if ok.any():
                geom = geometry_of(geoms, a)
                e = approach_errors(
                    d[ok, 0], r.xyz_m[ok], d[ok], loc_x_m=geom["loc_x_m"], gp_x_m=geom["gp_x_m"], gp_y_m=geom["gp_y_m"]
                )
                e.insert(0, "time_s", nl.t_s[ok])
                e.insert(0, "approach", a)
                errs.append(e)
    make_folder(out, "--out")
    atomic_write_text(out / "trajectory.csv", pd.concat(traj, ignore_index=True).to_csv(index=False))
    atomic_write_text(out / "trajectory_8hz.csv", pd.concat(grid, ignore_index=True).to_csv(index=False))
    atomic_write_text(out / "cyclic_noise.csv", pd.concat(noise, ignore_index=True).to_csv(index=False))
    atomic_write_text(out / "bias.csv", pd.DataFrame(bias).to_csv(index=False))
    epochs = sum(len(t) for t in traj)
    jumps = sum(b["jumps"] for b in bias)
    print(
        f"{p}: {len(traj)} approaches, {epochs} WAAS epochs, {jumps} flagged bias jumps compensated -> "
        f"{out / 'trajectory.csv'}"
    )
    if errs:
        errors = pd.concat(errs, ignore_index=True)
        atomic_write_text(out / "errors.csv", errors.to_csv(index=False))
        print(f"runway geometry for the angular errors: {geom_src}")
        verdicts = [approach_verdict(e, SUMMARY_FROM_NM) for e in errs]  # errs: one frame per approach
        met = {
            f"{axis}_{name}": sum(v[f"{axis}_meets_{name}"] for v in verdicts)
            for axis in ("cross", "vertical")
            for name in REQUIREMENTS
        }
        d = errors["distance_to_threshold_m"].to_numpy()
        inside = errors[(d >= 0.0) & (d <= SUMMARY_FROM_NM * NM)]
        print(
            f"FITS - DGPS, threshold to {SUMMARY_FROM_NM:g} nm: "
            f"cross-track RMS {np.sqrt(np.mean(inside['cross_m'] ** 2)):.2f} m, "
            f"vertical RMS {np.sqrt(np.mean(inside['vertical_m'] ** 2)):.2f} m; approaches meeting "
            + ", ".join(
                f"{name} ({REQUIREMENTS[name]:g} deg) cross {met['cross_' + name]}/{len(verdicts)} vertical "
                f"{met['vertical_' + name]}/{len(verdicts)}"
                for name in REQUIREMENTS
            )
            + f" -> {out / 'errors.csv'}"
        )
        atomic_write(out / "requirement.png", lambda tmp: _requirement_figure(errors, tmp))
    return 0
