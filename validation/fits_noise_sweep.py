"""The cyclic-noise residual of the WAAS-aided FITS against the WAAS noise it cannot
remove: share of epochs with |N_hat - N| < 0.1 m (interior, first and last 2T apart) and
the RMS residual over the analytic floor, on a grid of Gauss-Markov and white-noise
levels (FITS paper Fig. 14 asks < 0.1 m; aerotruth.analysis.fits.filter.noise_floor_rms).

The aircraft's motion cancels in WAAS - INS (eq. 3), so each approach is its WAAS error
(aerotruth.sensors.waas, defaults except the two swept levels) and a tactical INS error
(eq. 4) on 450 one-second epochs. Prints `label: value` lines per grid cell and writes the
figure to --out (PNG).

    python validation/fits_noise_sweep.py [--n 40] [--out runs/fits_noise_sweep.png]

With `--model message_stream` the WAAS error is built from the fast corrections, the
satellite geometry and the receiver (aerotruth.sensors.waas_messages, a runway at 46.8 N),
its cyclic part being the fast-correction residual; the grid is then the master station's
fast-correction noise and the receiver's smoothed code noise (`ms_prc_<a>_rx_<b>.*` lines:
interior shares per axis and the removed share of the fast-correction residual).
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from aerotruth.analysis.fits.filter import FitsSpec, noise_floor_rms, waas_noiseless
from aerotruth.sensors.inertial_errors import InertialErrors, InertialErrorSpec
from aerotruth.sensors.waas import WaasSpec

GM_LEVELS = (0.0, 0.05, 0.1, 0.2, 0.4)
WHITE_LEVELS = (0.0, 0.03, 0.06, 0.12)


def cell(gm: float, white: float, n: int, rng: np.random.Generator) -> tuple[float, float, float]:
    spec = WaasSpec(gm_sigma_m=gm, white_sigma_m=white)
    t = np.arange(450.0)
    T = 12
    inner, edge, sq = [], [], []
    for _ in range(n):
        w = spec.draw(rng, 449.0)
        ins = InertialErrors.draw(InertialErrorSpec(grade="tactical"), rng, t).error_ned_m
        nl = waas_noiseless(t, w.error_m, ins, w.sv_change | w.iono_update, FitsSpec())
        r = nl.n_hat - w.cyclic_m
        inner.append(np.abs(r[2 * T : -2 * T]) < 0.1)
        edge.append(np.abs(np.r_[r[: 2 * T], r[-2 * T :]]) < 0.1)
        sq.append(r[2 * T : -2 * T] ** 2)
    floor = noise_floor_rms(T, white, gm, spec.gm_tau_s)
    rms = float(np.sqrt(np.mean(np.concatenate(sq))))
    return float(np.mean(inner)), float(np.mean(edge)), rms / floor if floor > 0 else float("nan")


PRC_LEVELS = (0.0, 0.05, 0.1, 0.2)
RX_LEVELS = (0.05, 0.1, 0.2)


def message_cell(prc: float, rx: float, n: int, rng: np.random.Generator) -> tuple[np.ndarray, float]:
    """Interior share |N_hat - N| < 0.1 m per axis and the removed share 1 - RMS(r)/RMS(N),
    N the fast-correction residual of the message-stream WAAS."""
    from aerotruth.sensors.waas_messages import WaasMessageSpec
    from aerotruth.truth.runway import RunwayFrame

    spec = WaasSpec(model="message_stream", messages=WaasMessageSpec(prc_noise_sigma_m=prc, receiver_noise_sigma_m=rx))
    frame = RunwayFrame(46.84, -92.19, 400.0, 270.0)
    t = np.arange(450.0)
    T = 12
    inner, r2, n2 = [], 0.0, 0.0
    for _ in range(n):
        w = spec.draw(rng, 449.0, frame=frame)
        ins = InertialErrors.draw(InertialErrorSpec(grade="tactical"), rng, t).error_ned_m
        nl = waas_noiseless(t, w.error_m, ins, w.sv_change | w.iono_update, FitsSpec())
        r = (nl.n_hat - w.cyclic_m)[2 * T : -2 * T]
        inner.append(np.abs(r) < 0.1)
        r2 += float(np.sum(r**2))
        n2 += float(np.sum(w.cyclic_m[2 * T : -2 * T] ** 2))
    return np.concatenate(inner).mean(axis=0), 1.0 - np.sqrt(r2 / n2)


def main_message_stream(n: int, seed: int) -> None:
    rng = np.random.default_rng(seed)
    for prc in PRC_LEVELS:
        for rx in RX_LEVELS:
            share, removed = message_cell(prc, rx, n, rng)
            for a, v in zip("xyz", share, strict=True):
                print(f"ms_prc_{prc:g}_rx_{rx:g}.share_inner.{a}: {v:.4f}")
            print(f"ms_prc_{prc:g}_rx_{rx:g}.removed_share: {removed:.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=40, help="approaches per grid cell")
    ap.add_argument("--out", default="runs/fits_noise_sweep.png")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--model", choices=("eq6", "message_stream"), default="eq6")
    args = ap.parse_args()
    if args.model == "message_stream":
        main_message_stream(args.n, args.seed)
        return
    rng = np.random.default_rng(args.seed)
    share = np.zeros((len(WHITE_LEVELS), len(GM_LEVELS)))
    for i, white in enumerate(WHITE_LEVELS):
        for j, gm in enumerate(GM_LEVELS):
            s_in, s_edge, ratio = cell(gm, white, args.n, rng)
            share[i, j] = s_in
            print(f"gm_{gm:g}_white_{white:g}.share_inner: {s_in:.4f}")
            print(f"gm_{gm:g}_white_{white:g}.share_edges: {s_edge:.4f}")
            print(f"gm_{gm:g}_white_{white:g}.rms_over_floor: {ratio:.3f}")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4))
    for i, white in enumerate(WHITE_LEVELS):
        ax.plot(GM_LEVELS, share[i], "o-", label=f"white {white:g} m")
    ax.axhline(0.9, color="k", ls=":", lw=1, label="90 %")
    ax.axvline(0.05, color="0.6", ls="--", lw=1, label="default GM 0.05 m")
    ax.set(
        xlabel="Gauss-Markov sigma (m), tau 100 s",
        ylabel="share of epochs |N_hat - N| < 0.1 m",
        title="Cyclic-noise residual vs the WAAS noise the filter passes",
        ylim=(0, 1.02),
    )
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=130, bbox_inches="tight")
    print(f"figure: {out}")


if __name__ == "__main__":
    main()
