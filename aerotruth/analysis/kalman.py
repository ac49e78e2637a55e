"""A linear Kalman filter with Rauch-Tung-Striebel smoothing for error-state models.

Continuous model x' = F x + G w, E[w w'] = Qc delta(t); discretised exactly for a step dt
by the Van Loan method (Van Loan 1978, IEEE TAC 23(3): the matrix exponential of
[[-F, G Qc G'], [0, F']] dt gives Phi = expm(F dt) and Qd). Measurements z_k = H x_k + v_k,
E[v v'] = R. Filter: Gelb (1974) Table 4.2-1; smoother: Rauch, Tung & Striebel (1965),

    x_s[k] = x_f[k] + C_k (x_s[k+1] - x_p[k+1]),  C_k = P_f[k] Phi' P_p[k+1]^-1,
    P_s[k] = P_f[k] + C_k (P_s[k+1] - P_p[k+1]) C_k'.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.linalg import expm


def discretize(F: np.ndarray, G: np.ndarray, Qc: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    """(Phi, Qd) of the continuous model over dt (Van Loan)."""
    n = F.shape[0]
    M = np.zeros((2 * n, 2 * n))
    M[:n, :n] = -F
    M[:n, n:] = G @ Qc @ G.T
    M[n:, n:] = F.T
    E = expm(M * dt)
    phi = E[n:, n:].T
    qd = phi @ E[:n, n:]
    return phi, 0.5 * (qd + qd.T)


@dataclass
class Measurement:
    """Measurements at epoch k: z (m,), H (m, n), R (m, m)."""

    z: np.ndarray
    H: np.ndarray
    R: np.ndarray


def kalman_rts(
    t: np.ndarray,
    F: np.ndarray,
    G: np.ndarray,
    Qc: np.ndarray,
    x0: np.ndarray,
    P0: np.ndarray,
    measurements: dict[int, Measurement],
    smooth: bool = True,
) -> tuple[np.ndarray, np.ndarray]:
    """Filtered (smooth=False) or smoothed state means (K, n) and covariances (K, n, n) at the epochs t.

    The smoother's gains C_k need only the filter's covariances, so they are solved for all
    epochs at once after the forward pass (one batched LAPACK call, the same routine per
    matrix); the backward pass then runs on products alone."""
    K, n = len(t), len(x0)
    xf, Pf = np.zeros((K, n)), np.zeros((K, n, n))
    xp, Pp = np.zeros((K, n)), np.zeros((K, n, n))
    phis = np.zeros((K, n, n))
    eye = np.eye(n)
    cache: dict[float, tuple[np.ndarray, np.ndarray]] = {}
    x, P = np.asarray(x0, float), np.asarray(P0, float)
    for k in range(K):
        if k > 0:
            dt = round(float(t[k] - t[k - 1]), 9)
            if dt not in cache:
                cache[dt] = discretize(F, G, Qc, dt)
            phi, qd = cache[dt]
            phis[k] = phi
            x, P = phi @ x, phi @ P @ phi.T + qd
        xp[k], Pp[k] = x, P
        m = measurements.get(k)
        if m is not None:
            S = m.H @ P @ m.H.T + m.R
            Kg = np.linalg.solve(S.T, (P @ m.H.T).T).T
            x = x + Kg @ (m.z - m.H @ x)
            I_KH = eye - Kg @ m.H
            P = I_KH @ P @ I_KH.T + Kg @ m.R @ Kg.T  # Joseph form
        xf[k], Pf[k] = x, P
    if not smooth:
        return xf, Pf
    # C_k = P_f[k] Phi_{k+1}' P_p[k+1]^-1 for every k at once: C_k' = solve(P_p[k+1]', Phi_{k+1} P_f[k]')
    C = np.linalg.solve(Pp[1:].transpose(0, 2, 1), phis[1:] @ Pf[:-1].transpose(0, 2, 1)).transpose(0, 2, 1)
    xs, Ps = xf.copy(), Pf.copy()
    for k in range(K - 2, -1, -1):
        c = C[k]
        xs[k] += c @ (xs[k + 1] - xp[k + 1])
        Ps[k] += c @ (Ps[k + 1] - Pp[k + 1]) @ c.T
    return xs, Ps
