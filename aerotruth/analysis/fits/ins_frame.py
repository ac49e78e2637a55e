"""Whether an approach log's INS columns are in the runway frame (x along the course, y
left, z up), from the aircraft's motion: an axis of the other sign or two axes swapped
cannot be seen in the INS positions alone (a cheap INS drifts by kilometres over an
approach), but drift is smooth - a cubic in time holds its bias, velocity, tilt,
accelerometer and gyro terms over an approach - and the aircraft's motion is not (wander,
level-offs, speed changes). Beyond a cubic per approach (and a step at each flagged WAAS
epoch, where the WAAS bias jumps) the INS must follow the WAAS axis by axis. The frame it
is in is the orthogonal matrix Q nearest its loadings on the WAAS's motion (INS = Q r): an
axis of the other sign or two swapped (a signed permutation), or axes turned about the
vertical (a north-east frame, or a frame turned with a magnetic course for the true one).

Used by `aerotruth diagnose` (the `ins_frame` finding) and `aerotruth fits` (a log whose
INS is in another frame is refused)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.linalg import polar

MIN_MOTION_M = 1.0  # an axis moving less beyond the drift cubic is hidden by the WAAS noise (~0.5 m)
MIN_EPOCHS = 60  # WAAS epochs an approach needs to enter the fit
MIN_APPROACHES = 3  # the standard errors are clustered by approach
MIN_GAIN_M = 0.1  # a frame that moves WAAS - INS beyond the drift by less is not worth saying (as diagnose's offsets)
PERMUTATION_TOL = math.sin(math.radians(2.0))  # within 2 deg of a signed permutation: said as one
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
    clustered by approach. An INS logging Q x the runway-frame position (Q orthogonal: an
    axis flipped, two swapped, axes turned) gives F = Q, each column shrunk by the WAAS
    noise w (m^2 / (m^2 + w^2), ~0.85 at m = 1 m of motion). `aps`:
    approach_log.ApproachInputs (t_w, waas, ins_w, flags)."""
    xs, ys, grps = [], [], []
    for i, ap in enumerate(aps):
        ok = _usable(ap)
        if ok.sum() < MIN_EPOCHS:
            continue
        xs.append(beyond_drift(ap.t_w[ok], ap.flags[ok], ap.waas[ok]))
        ys.append(beyond_drift(ap.t_w[ok], ap.flags[ok], ap.ins_w[ok]))
        grps.append(np.full(ok.sum(), i))
    if len(xs) < MIN_APPROACHES:
        return None
    x, y, grp = np.vstack(xs), np.vstack(ys), np.concatenate(grps)
    xtx_inv = np.linalg.inv(x.T @ x)
    f = (xtx_inv @ x.T @ y).T
    r = y - x @ f.T
    groups = np.unique(grp)
    scores = np.array([x[grp == g].T @ r[grp == g] for g in groups])  # (group, WAAS axis, INS axis)
    c = len(groups) / (len(groups) - 1)
    se = np.array([np.sqrt(np.diag(xtx_inv @ (scores[:, :, i].T @ scores[:, :, i]) @ xtx_inv * c)) for i in range(3)])
    return f, se, np.sqrt(np.mean(x**2, axis=0))


def orientation(f: np.ndarray, motion_m: np.ndarray) -> np.ndarray:
    """The orthogonal Q nearest F on the tested columns (motion >= MIN_MOTION_M), each
    weighted by its motion's power, with a slight pull to the identity (1e-3 of the weakest
    tested column's weight) where they do not decide: Q maximises tr(Q' (F W + lambda I)),
    the polar factor of that matrix (orthogonal Procrustes). Untested columns only complete
    the tested ones."""
    m = np.asarray(motion_m, float)
    w = np.where(m >= MIN_MOTION_M, m**2, 0.0)
    return polar(f * w + 1e-3 * w[w > 0].min() * np.eye(3))[0]


@dataclass(frozen=True)
class FrameError:
    """The INS logs Q r (r the runway-frame position, Q orthogonal): F, its se, the motion
    per axis, the axes tested, the largest z of an entry Q moves, and what the frame costs
    (WAAS - INS beyond the drift, RMS, as logged and with the INS put back in the frame)."""

    q: np.ndarray
    f: np.ndarray
    se: np.ndarray
    motion_m: np.ndarray
    cols: np.ndarray
    z: float
    rms_m: float
    rms_in_frame_m: float

    def said(self) -> list[str]:
        out = self._frame()
        guessed = [j for j in range(3) if j not in self.cols and abs(self.q[j, j] - 1.0) > 0.02]
        if guessed:  # its column of Q only completes the tested ones (orthogonal): which sign, the data cannot say
            out.append(
                f"the runway frame's {'/'.join(AXES[j] for j in guessed)} moves too little beyond the drift to be "
                f"tested ({', '.join(f'{self.motion_m[j]:.2f} m' for j in guessed)}): its sign here is a guess"
            )
        return out

    def _frame(self) -> list[str]:
        q, p = self.q, np.round(self.q)
        if np.abs(q - p).max() < PERMUTATION_TOL and np.allclose(np.abs(p).sum(axis=0), 1.0):
            out = []
            for i in range(3):
                j = int(np.flatnonzero(p[i])[0])
                if j == i and p[i, j] < 0:
                    out.append(f"ins_{AXES[i]}_m has the opposite sign")
                elif j != i:
                    out.append(f"ins_{AXES[i]}_m holds the runway frame's {'-' if p[i, j] < 0 else ''}{AXES[j]}")
            return out
        out = []
        if abs(q[2, 2]) > 1.0 - PERMUTATION_TOL:  # vertical kept apart: the horizontal axes turned (and mirrored?)
            h = q[:2, :2]
            mirrored = np.linalg.det(h) < 0
            g = h @ np.diag([1.0, -1.0]) if mirrored else h  # a rotation
            deg = math.degrees(math.atan2(g[1, 0], g[0, 0]))
            out.append(
                f"ins_x_m/ins_y_m are the runway frame's x{', -y' if mirrored else ', y'} turned by {deg:+.1f} deg "
                "about the vertical (a north-east frame, or one turned by a magnetic course for the true one?)"
            )
            if q[2, 2] < 0:
                out.append("ins_z_m has the opposite sign")
            return out
        return ["INS = Q r with Q = " + np.array2string(q, precision=2, suppress_small=True).replace("\n", "")]

    def loads(self) -> str:
        return ", ".join(
            f"ins_{AXES[i]} on waas_{AXES[j]} {self.f[i, j]:+.2f}"
            for j in self.cols
            for i in range(3)
            if abs(self.q[i, j]) > 0.1
        )


def frame_error(aps: list) -> FrameError | None:
    """The frame the INS columns are in, when it is not the runway frame: Q (`orientation`)
    from the axes that move >= MIN_MOTION_M beyond the drift, said when an entry it moves
    (by > 0.02) is more than 4 standard errors from the identity's on a tested axis and
    putting the INS back in the frame lowers WAAS - INS beyond the drift by > MIN_GAIN_M.
    None otherwise (or when nothing can be tested)."""
    got = loadings(aps)
    if got is None:
        return None
    f, se, motion = got
    cols = np.flatnonzero(motion >= MIN_MOTION_M)
    if not len(cols):
        return None
    q = orientation(f, motion)
    z = np.abs(f - np.eye(3)) / np.maximum(se, 1e-12)
    moved = (np.abs(q - np.eye(3)) > 0.02)[:, cols]
    if not moved.any() or not (z[:, cols][moved] > 4.0).any():
        return None
    rms, rms_in = beyond_drift_rms(aps), beyond_drift_rms([in_frame(ap, q) for ap in aps])
    if not rms - rms_in > MIN_GAIN_M:
        return None
    return FrameError(q, f, se, motion, cols, float(z[:, cols][moved].max()), rms, rms_in)


def in_frame(ap, q: np.ndarray):
    """The approach with its INS positions taken back to the runway frame (INS = Q r, Q
    orthogonal: r = Q' INS)."""
    return dataclasses.replace(ap, ins_w=ap.ins_w @ q, ins_rows=ap.ins_rows @ q)


def beyond_drift_rms(aps: list) -> float:
    """RMS of WAAS - INS beyond the drift (what the FITS's filter takes for WAAS noise), over
    the three axes."""
    sq, n = 0.0, 0
    for ap in aps:
        ok = _usable(ap)
        if ok.sum() >= MIN_EPOCHS:
            d = beyond_drift(ap.t_w[ok], ap.flags[ok], ap.waas[ok] - ap.ins_w[ok])
            sq, n = sq + float(np.sum(d**2)), n + d.size
    return math.sqrt(sq / n) if n else float("nan")
