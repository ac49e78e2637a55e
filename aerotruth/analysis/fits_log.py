"""`aerotruth fits LOG --out DIR`: the WAAS-aided FITS (aerotruth.analysis.fits) on an
approach log (docs/data-formats.md, "Approach log").

Reads CSV or Parquet, checks it (one error naming the file, approach and column), runs
the FITS per approach and writes into DIR:

* trajectory.csv: approach, time_s, x_m, y_m, z_m (runway frame, eq. 19) at every WAAS epoch;
* trajectory_8hz.csv: the same on the paper's 8 Hz grid (carried by the INS between epochs);
* cyclic_noise.csv: approach, time_s, n_x_m, n_y_m, n_z_m (the estimated cyclic noise);
* bias.csv: approach, bias_x_m, bias_y_m, bias_z_m (eq. 18), jumps (flagged epochs compensated);
* where the log holds DGPS (dgps_x_m, dgps_y_m, dgps_z_m): errors.csv (FITS minus DGPS at
  the WAAS epochs, angular errors and requirement verdicts from aerotruth.analysis.ils_metrics)
  and requirement.png (cross-track and vertical errors against the 0.015/0.05 deg lines).

Handling of the log: rows are grouped by `approach` (any order of approaches); within one
approach time_s must increase strictly (unsorted or repeated times are an error, not
re-sorted); a gap (a row step or a WAAS-epoch step over 1.5 times the typical one) is an
error; WAAS columns are finite on WAAS epochs and NaN elsewhere (all three together); the
INS on every row; the first row with event = 1 is the threshold crossing (later marks,
e.g. at the far end, are ignored); a receiver flag on a row between WAAS epochs belongs to
the next epoch; missing RA or TVPS near the threshold is an error (the bias cannot be fixed).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.fits import FitsResult, FitsSpec, fits_approach
from aerotruth.analysis.ils_metrics import FLOOR_HORIZONTAL_M, FLOOR_VERTICAL_M, REQUIREMENTS, approach_errors, required_error_m
from aerotruth.errors import DataError
from aerotruth.files import atomic_write_bytes, atomic_write_text
from aerotruth.units import NM

REQUIRED = ("approach", "time_s", "waas_x_m", "waas_y_m", "waas_z_m", "ins_x_m", "ins_y_m", "ins_z_m",
            "ra_m", "tvps_y_m", "event", "sv_change", "iono_update")
DGPS = ("dgps_x_m", "dgps_y_m", "dgps_z_m")
NUMERIC = REQUIRED[1:] + DGPS
# Ground-antenna positions for the requirement figure (runway frame): a localizer 300 m
# beyond the stop end of a 3000 m runway, the glide-path mast 300 m in and 120 m aside.
LOCALIZER_X_M, GLIDE_PATH_X_M, GLIDE_PATH_Y_M = 3300.0, 300.0, -120.0


def read_approach_log(path: str | Path) -> pd.DataFrame:
    """The log as a DataFrame with its columns checked (names, numbers)."""
    p = Path(path)
    if not p.is_file():
        raise DataError(f"{p}: no such file (expected an approach log, CSV or Parquet)")
    try:
        df = pd.read_parquet(p) if p.suffix.lower() in (".parquet", ".pq") else pd.read_csv(p)
    except Exception as exc:  # noqa: BLE001 - any reader failure is one line about the file
        raise DataError(f"{p}: cannot be read as CSV/Parquet ({type(exc).__name__}: {str(exc).splitlines()[0]})") from None
    missing = [c for c in REQUIRED if c not in df.columns]
    if missing:
        raise DataError(f"{p}: missing column {missing[0]!r} (an approach log needs {', '.join(REQUIRED)})")
    if any(c in df.columns for c in DGPS) and not all(c in df.columns for c in DGPS):
        raise DataError(f"{p}: DGPS columns must come together ({', '.join(DGPS)})")
    for c in NUMERIC:
        if c in df.columns:
            num = pd.to_numeric(df[c], errors="coerce")
            bad = num.isna() & df[c].notna()
            if bad.any():
                raise DataError(f"{p}: column {c!r} row {int(np.flatnonzero(bad)[0])}: expected a number, got {df[c][bad].iloc[0]!r}")
            df[c] = num.astype(float)
    if df["time_s"].isna().any():
        raise DataError(f"{p}: column 'time_s' row {int(np.flatnonzero(df['time_s'].isna())[0])}: missing time")
    for c in ("event", "sv_change", "iono_update"):
        v = df[c].fillna(0.0)
        if not v.isin([0.0, 1.0]).all():
            raise DataError(f"{p}: column {c!r}: expected 0/1 flags, got {v[~v.isin([0.0, 1.0])].iloc[0]!r}")
        df[c] = v
    return df


def _check_approach(p: Path, a, g: pd.DataFrame) -> None:
    t = g["time_s"].to_numpy()
    where = f"{p}: approach {a!r}"
    dt = np.diff(t)
    if len(t) < 2 or (dt <= 0).any():
        i = int(np.flatnonzero(dt <= 0)[0]) + 1 if len(t) >= 2 else 0
        raise DataError(f"{where}: column 'time_s' must increase strictly (row {g.index[i]}: {t[i]!r} after {t[max(i - 1, 0)]!r})")
    step = float(np.median(dt))
    if (dt > 1.5 * step).any():
        i = int(np.argmax(dt > 1.5 * step))
        raise DataError(f"{where}: column 'time_s' has a gap of {dt[i]:g} s after t = {t[i]:g} s (rows every {step:g} s)")
    w = g[["waas_x_m", "waas_y_m", "waas_z_m"]].to_numpy()
    fin = np.isfinite(w)
    if (fin.any(axis=1) != fin.all(axis=1)).any():
        raise DataError(f"{where}: columns waas_x_m/waas_y_m/waas_z_m must be all finite or all NaN on a row")
    tw = t[fin[:, 0]]
    if len(tw) < 2:
        raise DataError(f"{where}: columns waas_*: fewer than 2 WAAS epochs")
    dtw = np.diff(tw)
    if (dtw > 1.5 * np.median(dtw)).any():
        i = int(np.argmax(dtw > 1.5 * np.median(dtw)))
        raise DataError(f"{where}: columns waas_*: a gap of {dtw[i]:g} s between WAAS epochs after t = {tw[i]:g} s")
    if np.median(dtw) > 1.0 + 1e-6:
        raise DataError(f"{where}: columns waas_*: WAAS epochs every {np.median(dtw):g} s; expected 1 Hz or faster")
    if not np.isfinite(g[["ins_x_m", "ins_y_m", "ins_z_m"]].to_numpy()).all():
        raise DataError(f"{where}: columns ins_*: the INS position must be finite on every row")
    if not (g["event"] > 0).any():
        raise DataError(f"{where}: column 'event': no threshold event mark (event = 1)")


def run_approach(g: pd.DataFrame, spec: FitsSpec) -> FitsResult:
    """The FITS on one approach's rows (already checked)."""
    t = g["time_s"].to_numpy()
    ins = g[["ins_x_m", "ins_y_m", "ins_z_m"]].to_numpy()
    waas = g[["waas_x_m", "waas_y_m", "waas_z_m"]].to_numpy()
    is_w = np.isfinite(waas[:, 0])
    tw = t[is_w]
    flag_rows = (g["sv_change"].to_numpy() > 0) | (g["iono_update"].to_numpy() > 0)
    flags = np.zeros(len(tw), np.int8)
    k = np.searchsorted(tw, t[flag_rows], side="left")  # a flag between epochs: the next epoch
    flags[k[k < len(tw)]] = 1
    t_event = float(t[np.argmax(g["event"].to_numpy() > 0)])
    return fits_approach(tw, waas[is_w], ins[is_w], flags, t, ins, g["ra_m"].to_numpy(), g["tvps_y_m"].to_numpy(),
                         t_event, float(np.median(np.diff(t))), spec)


def _requirement_figure(errors: pd.DataFrame, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
    d_nm = errors["distance_to_threshold_m"] / NM
    for ax, col, rng_col, floor, label in ((axes[0], "cross_m", "range_loc_m", FLOOR_HORIZONTAL_M, "cross-track"),
                                           (axes[1], "vertical_m", "range_gp_m", FLOOR_VERTICAL_M, "vertical")):
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
    fig.savefig(path, dpi=120)
    plt.close(fig)


def fits_main(log_path: str, out_dir: str, spec: FitsSpec | None = None) -> int:
    """Run the FITS on every approach of the log at `log_path`; write the files listed in
    the module docstring into `out_dir`. Bad input raises DataError (a ValueError) with one
    line naming the file, approach and column."""
    spec = spec or FitsSpec()
    p = Path(log_path)
    df = read_approach_log(p)
    has_dgps = all(c in df.columns for c in DGPS) and np.isfinite(df[list(DGPS)].to_numpy()).any()
    traj, grid, noise, bias, errs = [], [], [], [], []
    for a, g in df.groupby("approach", sort=False):
        _check_approach(p, a, g)
        try:
            r = run_approach(g, spec)
        except ValueError as exc:
            raise DataError(f"{p}: approach {a!r}: {exc}") from None
        nl = r.noiseless
        traj.append(pd.DataFrame({"approach": a, "time_s": nl.t_s, "x_m": r.xyz_m[:, 0], "y_m": r.xyz_m[:, 1], "z_m": r.xyz_m[:, 2]}))
        tg, pg = r.on_grid(g["time_s"].to_numpy(), g[["ins_x_m", "ins_y_m", "ins_z_m"]].to_numpy(), spec.grid_rate_hz)
        grid.append(pd.DataFrame({"approach": a, "time_s": tg, "x_m": pg[:, 0], "y_m": pg[:, 1], "z_m": pg[:, 2]}))
        noise.append(pd.DataFrame({"approach": a, "time_s": nl.t_s, "n_x_m": nl.n_hat[:, 0], "n_y_m": nl.n_hat[:, 1], "n_z_m": nl.n_hat[:, 2]}))
        bias.append({"approach": a, "bias_x_m": r.bias_m[0], "bias_y_m": r.bias_m[1], "bias_z_m": r.bias_m[2], "jumps": len(nl.jump_idx)})
        if has_dgps:
            d = g.set_index("time_s").loc[nl.t_s, list(DGPS)].to_numpy()
            ok = np.isfinite(d).all(axis=1)
            if ok.any():
                e = approach_errors(d[ok, 0], r.xyz_m[ok], d[ok], loc_x_m=LOCALIZER_X_M, gp_x_m=GLIDE_PATH_X_M, gp_y_m=GLIDE_PATH_Y_M)
                e.insert(0, "time_s", nl.t_s[ok])
                e.insert(0, "approach", a)
                errs.append(e)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "trajectory.csv", pd.concat(traj, ignore_index=True).to_csv(index=False))
    atomic_write_text(out / "trajectory_8hz.csv", pd.concat(grid, ignore_index=True).to_csv(index=False))
    atomic_write_text(out / "cyclic_noise.csv", pd.concat(noise, ignore_index=True).to_csv(index=False))
    atomic_write_text(out / "bias.csv", pd.DataFrame(bias).to_csv(index=False))
    if errs:
        errors = pd.concat(errs, ignore_index=True)
        atomic_write_text(out / "errors.csv", errors.to_csv(index=False))
        tmp = out / "requirement.png.part.png"
        _requirement_figure(errors, tmp)
        atomic_write_bytes(out / "requirement.png", tmp.read_bytes())
        tmp.unlink()
    return 0
