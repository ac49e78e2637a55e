"""The light-chop climatology of aerotruth.truth.turbulence (CHOP_SIGMA_W_QUANTILES), derived
from the real A320 recorder extract in ../shared/real-data (fuelflow_a320.json.gz, 1 Hz):

1. the vertical load factor above 10,000 ft in 120-s windows, less its 31-s moving mean
   (the manoeuvre and phugoid part), gives sigma_n per window;
2. the quasi-static gust load factor of the A320 in that window, K = rho V CL_alpha / (2 W/S)
   per m/s of vertical gust (Pratt's sharp-edged gust without alleviation; rho and TAS from
   the ISA at the recorded altitude and CAS, W the recorded weight, S = 122.6 m^2, CL_alpha
   from the DATCOM lift-curve slope of a swept wing, A = 9.5, half-chord sweep 22 deg, at the
   window's Mach number);
3. F, the share of the rms of a Dryden vertical gust (MIL-F-8785C, L_w = 1,750 ft) that the
   1-Hz samples, the 31-s high-pass and the 120-s window keep, at the window's TAS;
4. sigma_w = sigma_n / (K F) per window, after the recorder's quantization noise (LSB/sqrt 12,
   LSB 1/256 g) is removed in quadrature.

Prints `label: value` lines: the windows, the median K and F, and the quantiles of sigma_w
(m/s) that the module carries. With `--truth-days N`, the check of the chain: Mesaba
aircraft-days flown in turbulence, the SAAB 340's own load factor (from the truth's
vertical velocity, 1-Hz samples, the same windows) beside its quasi-static expectation
sigma_w x K x F (K from the SAAB model's CL_alpha 5.40/rad, 12,000 kg, S = 41.81 m^2).

    python validation/chop_climatology.py [--truth-days 3]
"""

from __future__ import annotations

import argparse
import datetime as dt
import gzip
import json
from pathlib import Path

import numpy as np
import pandas as pd
from scipy.ndimage import uniform_filter1d

from aerotruth.truth.isa import G0, ISA_P0_PA, ISA_R_AIR, isa_pressure_pa, isa_temperature_k
from aerotruth.truth.turbulence import CHOP_QUANTILE_PROBS
from aerotruth.units import FT, KT

REAL = Path(__file__).resolve().parents[1].parent / "shared" / "real-data" / "fuelflow_a320.json.gz"
G = G0
S_A320 = 122.6  # m^2
ASPECT = 9.5
SWEEP_HALF_CHORD_DEG = 22.0
L_W_M = 1750.0 * FT
WINDOW_S, HIGHPASS_S = 120, 31
LSB_G = 1.0 / 256.0


def lift_slope(mach: float) -> float:
    """DATCOM (Helmbold-Polhamus) lift-curve slope of a swept wing, per rad."""
    b2 = 1.0 - mach * mach
    t = np.tan(np.radians(SWEEP_HALF_CHORD_DEG))
    return 2 * np.pi * ASPECT / (2 + np.sqrt(4 + ASPECT**2 * b2 * (1 + t * t / b2)))


def kept_share(tas_mps: float) -> float:
    """F: rms share of a Dryden w gust kept by 1-Hz sampling, the 31-s moving-mean high-pass
    and a 120-s window (frequencies 1/120 .. 0.5 Hz, the high-pass's exact response)."""
    f = np.linspace(1.0 / WINDOW_S, 0.5, 4000)
    om = 2 * np.pi * f * L_W_M / tas_mps  # L Omega
    phi = (1 + 3 * om**2) / (1 + om**2) ** 2  # Dryden w shape (MIL-F-8785C)
    hp = 1.0 - np.abs(np.sinc(f * HIGHPASS_S))  # 1 - moving-mean response
    fa = np.linspace(0.0, 50.0, 200000)
    oa = 2 * np.pi * fa * L_W_M / tas_mps
    total = np.trapezoid((1 + 3 * oa**2) / (1 + oa**2) ** 2, fa)
    return float(np.sqrt(np.trapezoid(phi * hp**2, f) / total))


def tas_from_cas(cas_mps: float, h_m: float) -> tuple[float, float]:
    """(TAS m/s, Mach) from CAS at pressure altitude h (ISA, subsonic compressible)."""
    p0, a0 = ISA_P0_PA, 340.294
    p = float(isa_pressure_pa(h_m))
    qc = p0 * ((1 + 0.2 * (cas_mps / a0) ** 2) ** 3.5 - 1)
    mach = float(np.sqrt(5 * ((qc / p + 1) ** (2 / 7) - 1)))
    a = float(np.sqrt(1.4 * ISA_R_AIR * isa_temperature_k(h_m)))
    return mach * a, mach


def density(h_m: float) -> float:
    """ISA density (kg/m^3) at pressure altitude h."""
    return float(isa_pressure_pa(h_m)) / (ISA_R_AIR * float(isa_temperature_k(h_m)))


SAAB_CL_ALPHA, SAAB_MASS_KG, SAAB_S = 5.40, 12000.0, 41.81


def truth_check(days: int) -> None:
    """The SAAB's load factor in the chop against sigma_w x K x F, quantile by quantile."""
    from aerotruth.truth.days import AircraftDay
    from aerotruth.truth.flight import FlightDiverged, fly_leg
    from aerotruth.truth.turbulence import CHOP_QUANTILE_PROBS, CHOP_SIGMA_W_QUANTILES

    sig, kf = [], []
    for k in range(days):
        day = AircraftDay.for_campaign(
            2009, f"N40{k + 1}XJ", dt.date(2009, 8, 15) + dt.timedelta(days=k), network="mesaba", turbulence=True
        )
        for leg in day.plans():
            try:
                df = fly_leg(leg.plan, seed=leg.flight_seed, turbulence=True, atmosphere=leg.atmosphere()).df
            except FlightDiverged:
                continue
            n = (-np.gradient(df["vd_mps"].to_numpy(), 0.1) / G)[::10]  # load factor increment, 1 Hz
            h, tas = df["pressure_altitude_m"].to_numpy()[::10], df["tas_mps"].to_numpy()[::10]
            hp = n - uniform_filter1d(n, HIGHPASS_S)
            for i in range(0, len(n) - WINDOW_S, WINDOW_S):
                s = slice(i, i + WINDOW_S)
                if h[s].min() < 10000 * FT:
                    continue
                v = float(tas[s].mean())
                sig.append(float(hp[s].std()))
                kf.append(
                    density(float(h[s].mean())) * v * SAAB_CL_ALPHA / (2 * SAAB_MASS_KG * G / SAAB_S) * kept_share(v)
                )
    print(f"saab.windows: {len(sig)}")
    print(f"saab.gust_load_factor_x_kept_share: {np.median(kf):.4f}")
    for p, q in zip(CHOP_QUANTILE_PROBS[1:-1], CHOP_SIGMA_W_QUANTILES[1:-1], strict=False):
        print(f"saab.sigma_n_q{int(round(100 * p)):02d}_g: {np.quantile(sig, p):.4f}")
        print(f"expected.sigma_n_q{int(round(100 * p)):02d}_g: {q * np.median(kf):.4f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument(
        "--truth-days", type=int, default=0, help="also fly this many Mesaba aircraft-days and check the chain"
    )
    args = ap.parse_args()
    a = pd.DataFrame(json.load(gzip.open(REAL))).sort_values("timestamp")
    n = a["vertical_acceleration"].to_numpy(float)
    hp = n - uniform_filter1d(n, HIGHPASS_S)
    alt_ft, cas, w = (a[c].to_numpy(float) for c in ("altitude", "CAS", "weight"))
    sig_w, ks, fs = [], [], []
    for k in range(0, len(n) - WINDOW_S, WINDOW_S):
        s = slice(k, k + WINDOW_S)
        if alt_ft[s].min() < 10000 or not np.isfinite(hp[s]).all():
            continue
        h = float(np.mean(alt_ft[s])) * FT
        tas, mach = tas_from_cas(float(np.mean(cas[s])) * KT, h)
        kk = density(h) * tas * lift_slope(mach) / (2 * float(np.mean(w[s])) * G / S_A320)
        ff = kept_share(tas)
        sn = np.sqrt(max(np.var(hp[s]) - LSB_G**2 / 12, 0.0))
        sig_w.append(sn / (kk * ff))
        ks.append(kk)
        fs.append(ff)
    sig_w = np.array(sig_w)
    print(f"windows: {len(sig_w)}")
    print(f"a320.gust_load_factor_per_mps: {np.median(ks):.4f}")
    print(f"a320.kept_rms_share: {np.median(fs):.3f}")
    for p in CHOP_QUANTILE_PROBS:
        print(f"sigma_w_q{int(round(100 * p)):02d}_mps: {np.quantile(sig_w, p):.3f}")
    if args.truth_days:
        truth_check(args.truth_days)


if __name__ == "__main__":
    main()
