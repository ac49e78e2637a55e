"""Figures of the FITS study, after the FITS paper's: the WAAS error of one approach
(Fig. 5) and its spectrum with the 12 s peak (Fig. 6), the filter's frequency response
(Figs. 11/12), true against estimated cyclic noise and the residual (Figs. 13/14),
cross-track and vertical errors against the 0.015/0.05 deg requirement lines per INS
(Figs. 15-20), and the per-approach residual of each INS (section VI)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.sim.studies import Figure, Summary

NM = 1852.0


def _first(ep: pd.DataFrame) -> pd.DataFrame:
    a = ep["approach"].iloc[0]
    first_ins = ep["ins"].iloc[0]
    return ep[(ep["approach"] == a) & (ep["ins"] == first_ins)]


def draw(rows: pd.DataFrame, summary: Summary, out_dir: Path) -> list[Figure]:
    import matplotlib.pyplot as plt

    from aerotruth.analysis.fits.filter import frequency_response
    from aerotruth.analysis.fits.ils_metrics import (
        FLOOR_HORIZONTAL_M,
        FLOOR_VERTICAL_M,
        REQUIREMENTS,
        required_error_m,
    )

    figs: list[Figure] = []
    ep = rows[rows["kind"] == "epoch"] if len(rows) else rows
    if ep.empty:
        return figs
    one = _first(ep)
    t = one["time_s"].to_numpy(float) - float(one["time_s"].iloc[0])
    # Fig. 5: WAAS error of one approach
    fig, ax = plt.subplots(figsize=(8, 3.6))
    for a, name in zip("xyz", ("along-track", "cross-track", "vertical"), strict=False):
        ax.plot(t, one[f"waas_err_{a}_m"], lw=0.9, label=name)
    ax.set(xlabel="time (s)", ylabel="WAAS error (m)", title=f"WAAS position error, {one['approach'].iloc[0]}")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    out_dir.save(fig, "fits_waas_error")
    figs.append(
        Figure("fits_waas_error", "WAAS error of one approach: bias, 12 s cyclic noise, slow noise (FITS paper Fig. 5)")
    )
    # Fig. 6: averaged periodogram of the WAAS error (bias and slow trend removed per approach)
    from scipy.signal import periodogram

    first_ins = ep["ins"].iloc[0]
    spec, f = {}, None
    for a in "yz":
        acc = []
        for _, g in ep[ep["ins"] == first_ins].groupby("approach"):
            x = g[f"waas_err_{a}_m"].to_numpy(float)
            x = x - np.polyval(np.polyfit(np.arange(len(x)), x, 2), np.arange(len(x)))
            n = 256
            if len(x) >= n:
                f, p = periodogram(x[:n], fs=1.0)
                acc.append(p)
        if acc:
            spec[a] = np.mean(acc, axis=0)
    if spec:
        fig, ax = plt.subplots(figsize=(7, 3.6))
        for a, p in spec.items():
            ax.semilogy(f[1:], p[1:], label={"y": "cross-track", "z": "vertical"}[a])
        ax.axvline(1 / 12.0, color="0.5", ls=":", label="1/12 Hz")
        ax.set(
            xlabel="frequency (Hz)", ylabel="PSD (m$^2$/Hz)", title="Spectrum of the WAAS error (mean over approaches)"
        )
        ax.legend(fontsize=8)
        ax.grid(alpha=0.3)
        out_dir.save(fig, "fits_waas_spectrum")
        figs.append(
            Figure(
                "fits_waas_spectrum",
                "Spectrum of the WAAS error, detrended, averaged over approaches: the 12 s peak of the fast "
                "corrections (FITS paper Fig. 6)",
            )
        )
    # Figs. 11/12: frequency response of the low pass and of the high-pass cascade
    fr, lp, hp = frequency_response(12)
    fig, ax = plt.subplots(figsize=(7, 3.4))
    ax.plot(fr, lp, label="triangular low pass h (eq. 7)")
    ax.plot(fr, hp, label="high pass (delta - h)^2 (eqs. 8-11)")
    ax.axvline(1 / 12.0, color="0.5", ls=":", label="1/12 Hz")
    ax.set(xlabel="frequency (Hz)", ylabel="gain", title="Filter frequency response, T = 12 epochs at 1 Hz")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    out_dir.save(fig, "fits_frequency_response")
    figs.append(
        Figure(
            "fits_frequency_response",
            "Zero-phase frequency response: the high pass removes drifts up to cubic and passes every harmonic of "
            "the 12 s cycle (FITS paper Figs. 11/12)",
        )
    )
    # Figs. 13/14: true and estimated cyclic noise, residual
    fig, axes = plt.subplots(2, 2, figsize=(10, 5.5), sharex=True)
    for j, (a, name) in enumerate((("y", "cross-track"), ("z", "vertical"))):
        axes[0, j].plot(t, one[f"n_true_{a}_m"], lw=1.0, label="true N")
        axes[0, j].plot(t, one[f"n_hat_{a}_m"], lw=0.8, ls="--", label="estimated")
        axes[0, j].set(title=f"{name} cyclic noise", ylabel="m")
        axes[0, j].legend(fontsize=7)
        axes[1, j].plot(t, one[f"resid_{a}_m"], lw=0.9, color="C3")
        axes[1, j].axhspan(-0.1, 0.1, color="0.9")
        axes[1, j].set(xlabel="time (s)", ylabel="residual (m)")
        for ax in axes[:, j]:
            ax.grid(alpha=0.3)
    fig.suptitle(f"{one['approach'].iloc[0]}, INS {one['ins'].iloc[0]}")
    fig.tight_layout()
    out_dir.save(fig, "fits_cyclic_noise")
    figs.append(
        Figure(
            "fits_cyclic_noise",
            "True and estimated cyclic noise and the residual of one approach, the 0.1 m band shaded "
            "(FITS paper Figs. 13/14)",
        )
    )
    # Figs. 15-20: errors against the requirement, per INS
    variants = list(dict.fromkeys(ep["ins"]))
    fig, axes = plt.subplots(2, len(variants), figsize=(4.5 * len(variants), 6.5), squeeze=False, sharex=True)
    for j, v in enumerate(variants):
        e = ep[(ep["ins"] == v) & (ep["distance_to_threshold_m"] >= 0) & (ep["distance_to_threshold_m"] <= 10 * NM)]
        for i, (col, rcol, floor, name) in enumerate(
            (
                ("cross_m", "range_loc_m", FLOOR_HORIZONTAL_M, "cross-track"),
                ("vertical_m", "range_gp_m", FLOOR_VERTICAL_M, "vertical"),
            )
        ):
            ax = axes[i, j]
            for _, g in e.groupby("approach"):
                ax.plot(g["distance_to_threshold_m"] / NM, g[col], lw=0.5, alpha=0.5)
            if len(e):
                g0 = e[e["approach"] == e["approach"].iloc[0]].sort_values("distance_to_threshold_m")
                for req, alpha in REQUIREMENTS.items():
                    r = required_error_m(g0[rcol].to_numpy(float), alpha, floor)
                    ls = "--" if req == "desired" else "-"
                    ax.plot(g0["distance_to_threshold_m"] / NM, r, "k", ls=ls, lw=1, label=f"{alpha} deg")
                    ax.plot(g0["distance_to_threshold_m"] / NM, -r, "k", ls=ls, lw=1)
                lim = max(1.0, 1.5 * float(np.percentile(np.abs(e[col]), 99)))
                ax.set_ylim(-lim, lim)
            ax.set(title=f"{v}: {name}", ylabel="error (m)")
            ax.grid(alpha=0.3)
            if i == 1:
                ax.set_xlabel("distance to threshold (nm)")
            if i == 0 and j == 0:
                ax.legend(fontsize=7)
    fig.tight_layout()
    out_dir.save(fig, "fits_requirement")
    figs.append(
        Figure(
            "fits_requirement",
            "FITS minus truth, cross-track and vertical, against the 0.015 deg (dashed) and 0.05 deg lines with "
            "the 2 ft/1 ft floors, per INS (FITS paper Figs. 15-20)",
        )
    )
    # Figs. 3/4: the WAAS alone against the requirement by distance
    alone = summary.tables.get("waas_alone_by_distance")
    if alone is not None and len(alone):
        from aerotruth.analysis.fits.ils_metrics import PAPER_WAAS_95_M

        mid = (alone["from_nm"] + alone["to_nm"]).to_numpy(float) / 2
        fig, axes = plt.subplots(1, 2, figsize=(10, 3.8), sharex=True)
        for ax, axis, name in ((axes[0], "vertical", "vertical"), (axes[1], "cross", "horizontal (cross-track)")):
            ax.plot(mid, alone[f"waas_{axis}_p95_m"], "k-", lw=1.4, label="simulated WAAS, 95 %")
            paper = PAPER_WAAS_95_M[axis]
            ax.axhline(paper, color="C3", lw=1.0, label=f"paper's assumption {paper:.2f} m")
            ax.plot(mid, alone[f"req_{axis}_minimum_m"], "C0-", lw=1.0, label="0.05 deg (minimum)")
            ax.plot(mid, alone[f"req_{axis}_desired_m"], "C0--", lw=1.0, label="0.015 deg (desired)")
            ax.set(xlabel="distance to threshold (NM)", ylabel="error (m)", title=f"WAAS alone, {name}", yscale="log")
            ax.grid(alpha=0.3, which="both")
        axes[0].legend(fontsize=7)
        fig.tight_layout()
        out_dir.save(fig, "fits_waas_alone")
        figs.append(
            Figure(
                "fits_waas_alone",
                "The WAAS alone against the ILS requirement by distance: the simulated WAAS's 95 % error and "
                "the paper's assumed 3 ft / 6 ft beside the 0.015 and 0.05 deg lines with their floors "
                "(FITS paper Figs. 3/4)",
            )
        )
    # section VI: per-approach residual RMS of each INS
    appr = rows[(rows["kind"] == "approach") & ~rows["diverged"].astype(bool)]
    if len(appr):
        fig, ax = plt.subplots(figsize=(1.6 + 1.4 * len(variants), 3.8))
        data = [appr.loc[appr["ins"] == v, "resid_rms_m"].to_numpy(float) for v in variants]
        ax.boxplot(data)
        ax.set_xticks(range(1, len(variants) + 1), variants)
        floor = summary.metrics.get("noise_floor_rms_m")
        if floor:
            ax.axhline(floor, color="C2", ls=":", label=f"analytic floor {floor:.3f} m")
            ax.legend(fontsize=8)
        ax.set(ylabel="RMS of N_hat - N per approach (m)", title="Cyclic-noise residual by INS (paired approaches)")
        ax.grid(alpha=0.3)
        out_dir.save(fig, "fits_ins_residual")
        figs.append(
            Figure(
                "fits_ins_residual",
                "Per-approach RMS of the cyclic-noise residual for each INS on the same approaches and WAAS noise, "
                "with the analytic floor of white + Gauss-Markov noise (FITS paper section VI)",
            )
        )
    return figs
