"""Whether an approach log's INS columns are in the runway frame (x along the course, y
left, z up), from the aircraft's motion: an axis of the other sign or two axes swapped
cannot be seen in the INS positions alone (a cheap INS drifts by kilometres over an
approach), but drift is smooth - a cubic in time holds its bias, velocity, tilt,
accelerometer and gyro terms over an approach - and the aircraft's motion is not (wander,
level-offs, speed changes). Beyond a cubic per approach (and a step at each flagged WAAS
epoch, where the WAAS bias jumps) the INS must follow the WAAS axis by axis.

Used by `aerotruth diagnose` (the `ins_frame` finding) and `aerotruth fits` (a log whose
INS is in another frame is refused)."""

from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass

import numpy as np

MIN_MOTION_M = 1.0  # an axis moving less beyond the drift cubic is hidden by the WAAS noise (~0.5 m)
MIN_EPOCHS = 60  # WAAS epochs an approach needs to enter the fit
MIN_APPROACHES = 3  # the standard errors are clustered by approach
AXES = "xyz"


def beyond_drift(t: np.ndarray, flags: np.ndarray, y: np.ndarray) -> np.ndarray:
    """y (n, k) less its least-squares fit by a cubic in time (an INS's drift) and a step at
    each flagged WAAS epoch (the WAAS bias jumps there)."""
    u = (t - t.mean()) / max(np.ptp(t), 1e-9)
    a = np.column_stack([u**0, u, u**2, u**3, *((t >= t[i]).astype(float) for i in np.flatnonzero(flags))])
    return y - a @ np.linalg.lstsq(a, y, rcond=None)[0]


def _usable(ap) -> np.ndarray:
    return np.isfinite(ap.waas).all(axis=1) & np.isfinite(ap.ins_w).all(axis=1)


def loadings(aps: list):
    """(F, its standard errors, motion RMS per axis) or None with fewer than MIN_APPROACHES
    usable approaches: F[i, j] the loading of the INS's axis i on the WAAS's axis j, both
    beyond the drift, least squares over the approaches' WAAS epochs, standard errors
    clustered by approach. An INS logging P x the runway-frame position (P a signed
    permutation) gives F = P, each column shrunk by the WAAS noise w (m^2 / (m^2 + w^2),
    ~0.85 at m = 1 m of motion). `aps`: fits_log.ApproachInputs (t_w, waas, ins_w, flags)."""
    xs, ys, grp = [], [], []
    for i, ap in enumerate(aps):
        ok = _usable(ap)
        if ok.sum() < MIN_EPOCHS:
            continue
        xs.append(beyond_drift(ap.t_w[ok], ap.flags[ok], ap.waas[ok]))
        ys.append(beyond_drift(ap.t_w[ok], ap.flags[ok], ap.ins_w[ok]))
        grp.append(np.full(ok.sum(), i))
    if len(xs) < MIN_APPROACHES:
        return None
    x, y, grp = np.vstack(xs), np.vstack(ys), np.concatenate(grp)
    xtx_inv = np.linalg.inv(x.T @ x)
    f = (xtx_inv @ x.T @ y).T
    r = y - x @ f.T
    groups = np.unique(grp)
    se = np.zeros((3, 3))
    for i in range(3):
        scores = np.array([x[grp == g].T @ r[grp == g, i] for g in groups])
        cov = xtx_inv @ (scores.T @ scores) @ xtx_inv * len(groups) / (len(groups) - 1)
        se[i] = np.sqrt(np.diag(cov))
    return f, se, np.sqrt(np.mean(x**2, axis=0))


def signed_permutation(f: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """The signed permutation matrix nearest F on the columns `cols` (the identity's where
    the columns do not decide)."""
    best, best_cost = np.eye(3), math.inf
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            p = np.zeros((3, 3))
            p[list(perm), range(3)] = signs
            cost = float(np.sum((f[:, cols] - p[:, cols]) ** 2)) + 1e-6 * float(np.sum((p - np.eye(3)) ** 2))
            if cost < best_cost:
                best, best_cost = p, cost
    return best


@dataclass(frozen=True)
class FrameError:
    """The INS logs P r (r the runway-frame position): F, its se, the motion per axis, the
    axes tested and the largest z of an entry that differs from the identity."""

    p: np.ndarray
    f: np.ndarray
    se: np.ndarray
    motion_m: np.ndarray
    cols: np.ndarray
    z: float

    def said(self) -> list[str]:
        out = []
        for i in range(3):
            j = int(np.flatnonzero(self.p[i])[0])
            if j == i and self.p[i, j] < 0:
                out.append(f"ins_{AXES[i]}_m has the opposite sign")
            elif j != i:
                out.append(f"ins_{AXES[i]}_m holds the runway frame's {'-' if self.p[i, j] < 0 else ''}{AXES[j]}")
        return out

    def loads(self) -> str:
        return ", ".join(f"ins_{AXES[i]} on waas_{AXES[j]} {self.f[i, j]:+.2f}" for j in self.cols for i in range(3)
                         if self.p[i, j] != 0)


def frame_error(aps: list) -> FrameError | None:
    """The frame the INS columns are in, when it is not the runway frame: the nearest signed
    permutation on the axes that move >= MIN_MOTION_M beyond the drift, each entry that
    differs from the identity more than 4 standard errors from it. None otherwise (or
    when nothing can be tested)."""
    got = loadings(aps)
    if got is None:
        return None
    f, se, motion = got
    cols = np.flatnonzero(motion >= MIN_MOTION_M)
    if not len(cols):
        return None
    p = signed_permutation(f, cols)
    z = np.abs(f - np.eye(3)) / np.maximum(se, 1e-12)
    differ = (np.abs(p - np.eye(3)) > 0)[:, cols]
    if not differ.any() or not (z[:, cols][differ] > 4.0).all():
        return None
    return FrameError(p, f, se, motion, cols, float(z[:, cols][differ].max()))


def in_frame(ap, p: np.ndarray):
    """The approach with its INS positions taken back to the runway frame (INS = P r)."""
    return dataclasses.replace(ap, ins_w=ap.ins_w @ p, ins_rows=ap.ins_rows @ p)


def beyond_drift_rms(aps: list) -> float:
    """RMS of WAAS - INS beyond the drift (what the FITS's filter takes for WAAS noise),
    cross-track and vertical."""
    sq, n = 0.0, 0
    for ap in aps:
        ok = _usable(ap)
        if ok.sum() >= MIN_EPOCHS:
            d = beyond_drift(ap.t_w[ok], ap.flags[ok], ap.waas[ok] - ap.ins_w[ok])[:, 1:]
            sq, n = sq + float(np.sum(d**2)), n + d.size
    return math.sqrt(sq / n) if n else float("nan")
