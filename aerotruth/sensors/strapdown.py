"""Strapdown inertial navigation in the Earth-centred Earth-fixed frame, from velocity
and angle increments (dv, dtheta per IMU interval, body axes).

Mechanization (Titterton & Weston, Strapdown Inertial Navigation Technology, 2nd ed.,
section 3.5, the ECEF-frame equations; Groves, Principles of GNSS, Inertial and
Multisensor Integrated Navigation Systems, 2nd ed., section 5.2):

    C_eb' = C_eb (I + [w_ib x]) - [w_ie x] C_eb        attitude, body -> ECEF
    v_e'  = C_eb f_b - 2 w_ie x v_e + g_e(r)           Earth-relative velocity
    r_e'  = v_e

with g_e = gravitation - w_ie x (w_ie x r) the gravity of the rotating Earth. Each
interval: attitude by the exact rotation vector of dtheta and the Earth's rotation over
dt; the specific-force increment rotated by the attitude at the interval's start with
the first-order rotation correction dv + 1/2 dtheta x dv (Savage's velocity rotation
compensation); gravity and Coriolis at the interval's midpoint (one predictor pass);
position by the trapezoid of the velocities.

Gravitation: WGS-84 GM and the J2 zonal term (the model JSBSim flies,
simulation/gravity-model = 1), so the truth's own recording closes on itself.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.spatial.transform import Rotation

from aerotruth import geo
from aerotruth.ellipsoid import A_M

GM = 3.986004418e14  # m^3/s^2, WGS-84 (NIMA TR8350.2)
J2 = 1.08262982e-3  # as JSBSim's FGInertia
OMEGA_IE = 7.292115e-5  # rad/s, WGS-84 Earth rate


def gravitation_j2(r: np.ndarray) -> np.ndarray:
    """Gravitational acceleration (m/s^2, ECEF) of the J2 Earth at ECEF position r (m)."""
    r = np.asarray(r, float)
    rn = np.linalg.norm(r, axis=-1, keepdims=True)
    s2 = (r[..., 2:3] / rn) ** 2
    k = 1.5 * J2 * (A_M / rn) ** 2
    scale = np.concatenate([1.0 + k * (1.0 - 5.0 * s2)] * 2 + [1.0 + k * (3.0 - 5.0 * s2)], axis=-1)
    return -GM / rn**2 * scale * r / rn


def gravity_ecef(r: np.ndarray) -> np.ndarray:
    """Gravity of the rotating Earth: gravitation minus the centripetal term."""
    w = np.array([0.0, 0.0, OMEGA_IE])
    return gravitation_j2(r) - np.cross(w, np.cross(w, r))


@dataclass
class NavState:
    """Position r (ECEF m), Earth-relative velocity v (ECEF axes, m/s), attitude C_eb."""

    r: np.ndarray
    v: np.ndarray
    c_eb: np.ndarray

    @classmethod
    def from_geodetic(
        cls, lat_deg: float, lon_deg: float, h_m: float, v_ned: np.ndarray, roll: float, pitch: float, heading: float
    ) -> NavState:
        r = np.array(geo.ecef(lat_deg, lon_deg, h_m), float)
        c_en = geo.ecef_from_ned_matrix(lat_deg, lon_deg)
        c_nb = Rotation.from_euler("ZYX", [heading, pitch, roll]).as_matrix()
        return cls(r, c_en @ np.asarray(v_ned, float), c_en @ c_nb)

    def geodetic(self) -> tuple[float, float, float]:
        lat, lon, h = geo.geodetic_from_ecef(*self.r)
        return float(lat), float(lon), float(h)

    def euler(self) -> tuple[float, float, float]:
        """Roll, pitch, heading (rad) in the local geodetic NED frame at the position."""
        lat, lon, _ = self.geodetic()
        c_nb = geo.ecef_from_ned_matrix(lat, lon).T @ self.c_eb
        yaw, pitch, roll = Rotation.from_matrix(c_nb).as_euler("ZYX")
        return float(roll), float(pitch), float(yaw)


def propagate(state: NavState, dv: np.ndarray, dtheta: np.ndarray, dt: float) -> list[NavState]:
    """Integrate increments dv (n, 3) m/s and dtheta (n, 3) rad, each over dt, from
    `state`. Returns the n + 1 states (the first is `state`)."""
    r, v, c = propagate_arrays(state, dv, dtheta, dt)
    return [NavState(r[k], v[k], c[k]) for k in range(len(r))]


def _gravity_scalar(x: float, y: float, z: float) -> tuple[float, float, float]:
    """gravity_ecef for one point, in plain floats (the per-step cost of the loop)."""
    rn2 = x * x + y * y + z * z
    rn = rn2**0.5
    s2 = z * z / rn2
    k = 1.5 * J2 * A_M * A_M / rn2
    f = -GM / (rn2 * rn)
    a = f * (1.0 + k * (1.0 - 5.0 * s2))
    w2 = OMEGA_IE * OMEGA_IE
    return a * x + w2 * x, a * y + w2 * y, f * (1.0 + k * (3.0 - 5.0 * s2)) * z


def propagate_arrays(state: NavState, dv: np.ndarray, dtheta: np.ndarray, dt: float):
    """The mechanization of the module docstring; (r, v, C_eb) arrays of the n + 1 states.
    Attitude: C_k = E C_(k-1) B_k with E the Earth's turn over dt, so C_k = E^k C_0 B_1..B_k
    (the body product accumulated in order); velocity and position in plain floats."""
    dv, dtheta = np.array(dv, dtype=float), np.array(dtheta, dtype=float)
    if dv.shape != dtheta.shape or dv.ndim != 2 or dv.shape[1] != 3:
        raise ValueError(f"dv, dtheta: expected two (n, 3) arrays, got {dv.shape} and {dtheta.shape}")
    n = len(dv)
    w = np.array([0.0, 0.0, OMEGA_IE])
    earth = Rotation.from_rotvec(-w * dt).as_matrix()
    half = Rotation.from_rotvec(-w * dt / 2).as_matrix()
    body = Rotation.from_rotvec(dtheta).as_matrix()
    c = np.empty((n + 1, 3, 3))
    c[0] = state.c_eb
    for k in range(n):
        c[k + 1] = earth @ c[k] @ body[k]
    # specific-force increments in ECEF with the rotation compensation, all at once
    dv_rot = dv + 0.5 * np.cross(dtheta, dv)
    f_dv = np.einsum("ij,njk,nk->ni", half, c[:-1], dv_rot)
    r = np.empty((n + 1, 3))
    v = np.empty((n + 1, 3))
    r[0], v[0] = state.r, state.v
    rx, ry, rz = (float(a) for a in state.r)
    vx, vy, vz = (float(a) for a in state.v)
    om2 = 2.0 * OMEGA_IE
    for k, (fx, fy, fz) in enumerate(f_dv.tolist()):
        gx, gy, gz = _gravity_scalar(rx, ry, rz)
        # predictor (2 w x v = (-2 w vy, 2 w vx, 0))
        px = vx + fx + (gx + om2 * vy) * dt
        py = vy + fy + (gy - om2 * vx) * dt
        pz = vz + fz + gz * dt
        mx, my, mz = rx + 0.25 * (vx + px) * dt, ry + 0.25 * (vy + py) * dt, rz + 0.25 * (vz + pz) * dt
        ux, uy = 0.5 * (vx + px), 0.5 * (vy + py)
        gx, gy, gz = _gravity_scalar(mx, my, mz)
        nx = vx + fx + (gx + om2 * uy) * dt
        ny = vy + fy + (gy - om2 * ux) * dt
        nz = vz + fz + gz * dt
        rx, ry, rz = rx + 0.5 * (vx + nx) * dt, ry + 0.5 * (vy + ny) * dt, rz + 0.5 * (vz + nz) * dt
        vx, vy, vz = nx, ny, nz
        r[k + 1] = (rx, ry, rz)
        v[k + 1] = (vx, vy, vz)
    return r, v, c
