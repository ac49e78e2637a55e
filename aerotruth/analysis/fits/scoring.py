"""Scoring the WAAS-aided FITS against the truth it was simulated from (FITS paper
sections V-VI): the cyclic-noise residual, the position errors against the ILS
requirement, and the equivalence of two INS grades.

* Residual r = N_hat - N per axis at the WAAS epochs (N the WAAS cyclic noise drawn, N_hat
  the FITS estimate of eqs. 8-16). Epochs within 2T of either end of the record (where
  the filter runs on its edge model, aerotruth.analysis.fits.filter) are counted apart: `edge`.
* Position error e = z_true_hat (eq. 19) - truth of the reference point, seen from the
  localizer and glide-path antennas (aerotruth.analysis.fits.ils_metrics) from `from_nm` to the
  threshold.
* Bias error per segment: the flagged jumps cut an approach into segments; on each, the
  bias the FITS takes off (B_hat of eq. 18 plus the estimated steps of the jumps before it,
  `FitsResult.applied_bias_m`) minus the truth's bias there (the drawn bias plus the jumps
  before it). Comparing B_hat alone with the truth's bias at the threshold would set the
  bias of the segment before the first jump (which B_hat refers to) against the bias after
  every jump up to the threshold.
* Noise against the DGPS reference (FITS paper section V, Figs. 15/16: "the noise is still
  improved about 50 %" in the vertical): at the WAAS epochs with a DGPS reading, within the
  scored span (the threshold to `from_nm`), the difference X - DGPS of the raw WAAS and of
  the FITS output, detrended by a straight line in time on each segment between flagged
  jumps (the bias, its jumps and the slow Gauss-Markov drift are not noise); its RMS per
  axis, and the improvement 1 - RMS(FITS - DGPS) / RMS(WAAS - DGPS). The DGPS's own white
  noise is in both: it bounds the improvement a perfect filter could show.
* Equivalence (two one-sided tests, TOST; Schuirmann 1987): for paired approaches (same
  truth and WAAS noise, only the INS differs) d_i = RMS_i(a) - RMS_i(b) of the interior
  residual over the three axes; H0: |mean d| >= margin is rejected at level alpha when
  both one-sided t-tests reject, p = max(p_lower, p_upper). Equivalent means p < alpha.
* The equivalence margin from the requirement (`requirement_margins`): the requirement is
  tightest at its floor near the threshold (1 ft vertical, 2 ft horizontal;
  aerotruth.analysis.fits.ils_metrics). The residual adds to the FITS error, so a change d
  of its RMS changes the error's RMS by at most d and the error's 95 % bound (1.96 sigma)
  by at most 1.96 d. Two INS are equivalent when the 95 % error moves by at most a share s
  of the floor: margin = s x floor / 1.96 (s = 0.1: 15.6 mm vertical, 31.1 mm horizontal).
  The horizontal channel takes the cross-track floor (the along-track axis has no
  requirement); the channel of all three axes the vertical one, the tightest.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from scipy import stats

from aerotruth.analysis.fits.filter import FitsResult
from aerotruth.analysis.fits.ils_metrics import (
    FLOOR_HORIZONTAL_M,
    FLOOR_VERTICAL_M,
    approach_errors,
    approach_verdict,
)

AXES = ("x", "y", "z")
Z95 = 1.959963984540054  # two-sided 95 % point of the standard normal


def requirement_margins(share: float) -> dict[str, float]:
    """Equivalence margins (m) on the per-approach residual RMS of each channel (all,
    horizontal, vertical) such that the FITS error's 95 % bound moves by at most `share`
    of the requirement's floor (module docstring)."""
    if not 0 < share <= 1:
        raise ValueError(f"share: expected a fraction in (0, 1], got {share!r}")
    vertical = share * FLOOR_VERTICAL_M / Z95
    return {"all": vertical, "horizontal": share * FLOOR_HORIZONTAL_M / Z95, "vertical": vertical}


def _columns(df: pd.DataFrame, names) -> np.ndarray:
    """(n, len(names)) float array of the columns (one column at a time: a list index costs
    pandas ~1 ms of index lookup per call, the arithmetic here is less)."""
    return np.column_stack([df[c].to_numpy(dtype=float) for c in names])


def _truth_rows(truth: pd.DataFrame, t_s: np.ndarray) -> np.ndarray:
    """Indices of the truth's rows at the WAAS epochs t_s (every epoch must have one)."""
    tt = truth["time_s"].to_numpy(float)
    i = np.searchsorted(tt, t_s - 1e-6)
    if len(i) and (i.max() >= len(tt) or not np.allclose(tt[i], t_s, atol=1e-6)):
        raise ValueError("truth: expected a row at every WAAS epoch")
    return i


def waas_at_epochs(log: pd.DataFrame) -> np.ndarray:
    """The log's WAAS positions (k, 3) at its WAAS epochs, in time order."""
    w = _columns(log, ("waas_x_m", "waas_y_m", "waas_z_m"))
    return w[np.isfinite(w[:, 0])]


def epoch_rows(result: FitsResult, truth: pd.DataFrame, geometry: dict, waas_xyz: np.ndarray, T: int) -> pd.DataFrame:
    """One row per WAAS epoch: truth, WAAS error, cyclic noise true and estimated, the
    residual, the FITS error and its angular view (ils_metrics columns)."""
    nl = result.noiseless
    i = _truth_rows(truth, nl.t_s)
    p_true = _columns(truth, ("x_m", "y_m", "z_m"))[i]
    n_true = _columns(truth, ("cyclic_x_m", "cyclic_y_m", "cyclic_z_m"))[i]
    errors = approach_errors(
        p_true[:, 0],
        result.xyz_m,
        p_true,
        loc_x_m=geometry["loc_x_m"],
        gp_x_m=geometry["gp_x_m"],
        gp_y_m=geometry["gp_y_m"],
    )
    k = np.arange(len(nl.t_s))
    more = {"edge": (k < 2 * T) | (k >= len(k) - 2 * T)}
    for j, a in enumerate(AXES):
        more[f"waas_err_{a}_m"] = waas_xyz[:, j] - p_true[:, j]
        more[f"n_true_{a}_m"] = n_true[:, j]
        more[f"n_hat_{a}_m"] = nl.n_hat[:, j]
        more[f"resid_{a}_m"] = nl.n_hat[:, j] - n_true[:, j]
    more["y_true_m"] = p_true[:, 1]
    more["z_true_m"] = p_true[:, 2]
    # one frame from the columns at once (inserting them one by one cost more than the arithmetic)
    return pd.DataFrame({"time_s": nl.t_s, **{c: errors[c].to_numpy() for c in errors.columns}, **more})


def segment_rows(result: FitsResult, truth: pd.DataFrame) -> pd.DataFrame:
    """One row per segment between flagged jumps: its first and last epoch time, epochs,
    the truth's bias there (`bias_true_{a}_m`: the mean over the segment's epochs of the
    truth's bias + jumps), the bias the FITS applied there (`bias_applied_{a}_m`), their
    difference (`bias_err_{a}_m`), and `threshold` for the segment holding the epoch nearest
    the threshold (x = 0), where the RA, TVPS and event mark fixed the bias."""
    nl = result.noiseless
    i = _truth_rows(truth, nl.t_s)
    b_true = _columns(truth, ("bias_x_m", "bias_y_m", "bias_z_m"))[i]
    b_applied = result.applied_bias_m()
    seg = nl.segment_index()
    thr = int(seg[int(np.argmin(np.abs(truth["x_m"].to_numpy(float)[i])))])
    rows = []
    for k in np.unique(seg):
        sel = seg == k
        row = {
            "segment": int(k),
            "t_start_s": float(nl.t_s[sel][0]),
            "t_end_s": float(nl.t_s[sel][-1]),
            "epochs": int(sel.sum()),
            "threshold": bool(k == thr),
        }
        for j, a in enumerate(AXES):
            bt, ba = float(b_true[sel, j].mean()), float(b_applied[sel, j].mean())
            row.update({f"bias_true_{a}_m": bt, f"bias_applied_{a}_m": ba, f"bias_err_{a}_m": ba - bt})
        rows.append(row)
    return pd.DataFrame(rows)


def noise_against_reference(t_s, est, ref, segment, keep) -> tuple[np.ndarray, int]:
    """RMS per axis (3,) of est - ref (n, 3) over the epochs `keep` (bool, n) after a straight
    line in time is removed on each `segment` (n,), and the epochs used (segments with
    fewer than 3 kept epochs left out)."""
    t = np.asarray(t_s, float)
    d = np.asarray(est, float) - np.asarray(ref, float)
    ok = np.asarray(keep, bool) & np.all(np.isfinite(d), axis=1)
    seg = np.asarray(segment)
    sq, n = np.zeros(3), 0
    for k in np.unique(seg[ok]):
        sel = ok & (seg == k)
        if sel.sum() < 3:
            continue
        tc = t[sel] - t[sel].mean()
        a = np.column_stack([np.ones_like(tc), tc])
        resid = d[sel] - a @ np.linalg.lstsq(a, d[sel], rcond=None)[0]
        sq += np.sum(resid**2, axis=0)
        n += int(sel.sum())
    return (np.sqrt(sq / n) if n else np.full(3, np.nan)), n


def dgps_noise(
    result: FitsResult, log: pd.DataFrame, ep: pd.DataFrame, from_nm: float, waas_xyz: np.ndarray | None = None
) -> dict:
    """Per approach: the noise of the raw WAAS and of the FITS against the log's DGPS
    (`noise_against_reference`, module docstring) per axis, `dgps_noise_waas_{a}_m`,
    `dgps_noise_fits_{a}_m`, the mean of FITS - DGPS (`dgps_bias_{a}_m`: the bias the
    paper's Figs. 15/16 show) and the epochs used, `dgps_epochs`. `waas_xyz`: the log's
    WAAS positions at its epochs when the caller has them (`waas_at_epochs`)."""
    nl = result.noiseless
    t = log["time_s"].to_numpy(float)
    dg = _columns(log, ("dgps_x_m", "dgps_y_m", "dgps_z_m"))
    has = np.isfinite(dg[:, 0])
    i = np.searchsorted(t[has], nl.t_s - 1e-6)
    i = np.clip(i, 0, max(int(has.sum()) - 1, 0))
    ref = np.full((len(nl.t_s), 3), np.nan)
    if has.any():
        match = np.abs(t[has][i] - nl.t_s) <= 1e-6
        ref[match] = dg[has][i[match]]
    d = ep["distance_to_threshold_m"].to_numpy(float)
    keep = (d >= 0) & (d <= from_nm * 1852.0)
    seg = nl.segment_index()
    waas = waas_at_epochs(log) if waas_xyz is None else waas_xyz
    n_w, n = noise_against_reference(nl.t_s, waas, ref, seg, keep)
    n_f, _ = noise_against_reference(nl.t_s, result.xyz_m, ref, seg, keep)
    out: dict = {"dgps_epochs": n}
    used = keep & np.all(np.isfinite(ref), axis=1)
    for j, a in enumerate(AXES):
        out[f"dgps_noise_waas_{a}_m"] = float(n_w[j])
        out[f"dgps_noise_fits_{a}_m"] = float(n_f[j])
        # the bias the flight test saw (Figs. 15/16): the mean of FITS - DGPS over the span
        out[f"dgps_bias_{a}_m"] = float(np.mean(result.xyz_m[used, j] - ref[used, j])) if used.any() else float("nan")
    return out


def approach_summary(ep: pd.DataFrame, bias_hat: np.ndarray, segments: pd.DataFrame, from_nm: float) -> dict:
    """Per approach: residual RMS and share < 0.1 m (interior and edges), the removed share
    1 - RMS(r)/RMS(N), B_hat (`bias_hat_{a}_m`), the bias error on the threshold's segment
    (`bias_err_{a}_m`, from `segments`: `segment_rows`), and the requirement verdicts."""
    is_edge = ep["edge"].to_numpy(bool)
    inner, edge = np.flatnonzero(~is_edge), np.flatnonzero(is_edge)
    out: dict = {"epochs": len(ep), "segments": len(segments)}
    at_thr = segments[segments["threshold"].to_numpy(bool)].iloc[0]
    r = ep[[f"resid_{a}_m" for a in AXES]].to_numpy()
    r_in = r[inner]
    for i, a in enumerate(AXES):
        out[f"resid_rms_{a}_m"] = float(np.sqrt(np.mean(r_in[:, i] ** 2)))
        out[f"resid_share_lt_0p1_{a}"] = float(np.mean(np.abs(r_in[:, i]) < 0.1))
        out[f"edge_resid_share_lt_0p1_{a}"] = float(np.mean(np.abs(r[edge, i]) < 0.1)) if len(edge) else float("nan")
        n_rms = float(np.sqrt(np.mean(ep[f"n_true_{a}_m"].to_numpy()[inner] ** 2)))
        out[f"removed_share_{a}"] = 1.0 - out[f"resid_rms_{a}_m"] / n_rms if n_rms > 0 else float("nan")
        out[f"bias_hat_{a}_m"] = float(bias_hat[i])
        out[f"bias_err_{a}_m"] = float(at_thr[f"bias_err_{a}_m"])
    out["resid_rms_m"] = float(np.sqrt(np.mean(r_in**2)))
    out.update({f"verdict_{k}": v for k, v in approach_verdict(ep, from_nm).items()})
    return out


def tost_paired(a: np.ndarray, b: np.ndarray, margin: float, alpha: float = 0.05) -> dict:
    """Two one-sided t-tests on the paired differences a - b against +-margin."""
    d = np.asarray(a, float) - np.asarray(b, float)
    d = d[np.isfinite(d)]
    n = len(d)
    if n < 3:
        return {
            "pairs": n,
            "mean_diff_m": float("nan"),
            "ci90_low_m": float("nan"),
            "ci90_high_m": float("nan"),
            "p_value": float("nan"),
            "equivalent": False,
        }
    m, se = float(d.mean()), float(d.std(ddof=1) / np.sqrt(n))
    if se == 0.0:
        p = 0.0 if abs(m) < margin else 1.0
    else:
        p_low = stats.t.sf((m + margin) / se, n - 1)  # H0: mean <= -margin
        p_high = stats.t.cdf((m - margin) / se, n - 1)  # H0: mean >= +margin
        p = float(max(p_low, p_high))
    q = stats.t.ppf(1 - alpha, n - 1) * se  # the (1 - 2 alpha) interval TOST is equivalent to
    return {
        "pairs": n,
        "mean_diff_m": m,
        "ci90_low_m": m - q,
        "ci90_high_m": m + q,
        "p_value": p,
        "equivalent": bool(p < alpha),
    }
