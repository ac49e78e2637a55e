"""INS position drift over an approach from the FITS paper's simplified NED error model
(eq. 4, after Titterton & Weston) with the INS grades of its Table II.

    x_N'' = beta_N - g (-phi_E),   -phi_E' = x_N' / R - eps_E                 # FITS paper eq. 4
    x_E'' = beta_E - g phi_N,        phi_N' = x_E' / R + eps_N
    x_D'' = beta_D,                  phi_D' = eps_D

beta: accelerometer error (bias + white), eps: gyro error (bias + white), phi: tilt,
g = G0 = 9.80665 m/s^2, R = EARTH_RADIUS_M = 6,371,008.8 m (aerotruth.units, IUGG mean
radius). Each horizontal channel is x'' = a + g phi, phi' = -x'/R + e (with a = beta_N, e
= eps_E for north; a = beta_E, e = -eps_N for east, phi = -phi_N), whose exact solution
with the Schuler frequency w = sqrt(g / R) is

    x(t) = x0 + v0 sin(wt)/w + g phi0 (1 - cos wt)/w^2
           + int a(s) sin(w(t - s))/w ds + int g e(s) (1 - cos w(t - s))/w^2 ds,

so a constant accelerometer bias gives beta (1 - cos wt)/w^2 ~ beta t^2/2 and a constant
gyro bias g eps (t - sin(wt)/w)/w^2 ~ g eps t^3/6 (the paper's eq. 12). The vertical
channel is the double integral of beta_D. The convolutions are evaluated with cumulative
sums of the inputs times cos(ws), sin(ws) (rectangle rule on the sample grid), so a whole
track costs a few array passes. The azimuth error phi_D does not enter eq. 4's positions
(no velocity coupling in the simplified model); it is not modelled.

Grades (Table II, one-sided PSDs; white input of one-sided PSD S has the two-sided
density S/2, docs/conventions.md): tactical 500 ug, 1 deg/h, 2500 ug^2/Hz, 1e-6 (deg/s)^2/Hz;
automotive 30,000 ug, 100 deg/h, 5000 ug^2/Hz, 1e-4 (deg/s)^2/Hz. Biases are drawn per
approach with these 1-sigma values per axis. Alignment: an automotive gyro cannot
gyrocompass, so initial attitude comes from a transfer alignment to the aircraft's
attitude reference with a stated tilt error (initial_tilt_sigma_urad, default 500 urad
= 0.03 deg); initial position and velocity errors are stated likewise.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pydantic import Field

from aerotruth.schema import Section
from aerotruth.units import EARTH_RADIUS_M, G0

MICRO_G = 1e-6 * G0
DEG_PER_H = math.radians(1.0) / 3600.0


class InertialGrade(Section):
    """Accelerometer and gyro error figures of one INS grade (FITS paper Table II)."""

    accel_bias_ug: float = Field(ge=0, description="accelerometer bias, 1 sigma per axis (ug)")
    gyro_bias_deg_h: float = Field(ge=0, description="gyro bias, 1 sigma per axis (deg/h)")
    accel_white_ug2_hz: float = Field(ge=0, description="accelerometer white noise, one-sided PSD (ug^2/Hz)")
    gyro_white_deg2_s2_hz: float = Field(ge=0, description="gyro white noise, one-sided PSD ((deg/s)^2/Hz)")


INS_GRADES = {  # FITS paper Table II; navigation grade: docs/conventions.md (the table lacks it)
    "tactical": InertialGrade(
        accel_bias_ug=500.0, gyro_bias_deg_h=1.0, accel_white_ug2_hz=2500.0, gyro_white_deg2_s2_hz=1e-6
    ),
    "automotive": InertialGrade(
        accel_bias_ug=30000.0, gyro_bias_deg_h=100.0, accel_white_ug2_hz=5000.0, gyro_white_deg2_s2_hz=1e-4
    ),
    # ~25 ug and <= 0.01 deg/h (docs/conventions.md, INS grades: the AFIS class); noise: 10 ug/sqrt(Hz) and an
    # angle random walk of 0.002 deg/sqrt(h) ((0.002/60)^2 (deg/s)^2/Hz), typical figures
    # for a ring-laser-gyro navigator (Groves, 2nd ed., Table 4.1 class values) - stated
    # estimates, not a product's data sheet
    "navigation": InertialGrade(
        accel_bias_ug=25.0, gyro_bias_deg_h=0.01, accel_white_ug2_hz=100.0, gyro_white_deg2_s2_hz=(0.002 / 60.0) ** 2
    ),
}


class InertialErrorSpec(Section):
    """INS grade and the initial errors of its alignment."""

    grade: str = Field(
        default="tactical",
        description="tactical or automotive (FITS paper Table II), or navigation (docs/conventions.md)",
    )
    initial_position_sigma_m: float = Field(default=0.0, ge=0, description="per axis, 1 sigma")
    initial_velocity_sigma_mps: float = Field(default=0.05, ge=0, description="per axis, 1 sigma")
    initial_tilt_sigma_urad: float = Field(default=500.0, ge=0, description="transfer-alignment tilt per axis, 1 sigma")

    def grade_figures(self) -> InertialGrade:
        """The Table II figures of `grade`."""
        if self.grade not in INS_GRADES:
            raise ValueError(f"grade: expected one of {', '.join(INS_GRADES)}, got {self.grade!r}")
        return INS_GRADES[self.grade]


def ins_error_ned(
    t_s,
    accel_bias,
    gyro_bias,
    accel_noise=None,
    gyro_noise=None,
    x0=(0.0, 0.0, 0.0),
    v0=(0.0, 0.0, 0.0),
    tilt0=(0.0, 0.0),
) -> np.ndarray:
    """Position error (n, 3) NED of eq. 4 from constant accelerometer and gyro biases (3,)
    (m/s^2, rad/s; solved in closed form), optional white-noise samples (n, 3) (each row
    holds over the step that follows it; summed by the rectangle rule), the initial
    position and velocity errors and the tilts (phi_N, phi_E)."""
    t = np.asarray(t_s, dtype=float) - float(t_s[0])
    n = len(t)
    b_a, b_g = np.asarray(accel_bias, float), np.asarray(gyro_bias, float)
    a = np.zeros((n, 3)) if accel_noise is None else np.asarray(accel_noise, float)
    e = np.zeros((n, 3)) if gyro_noise is None else np.asarray(gyro_noise, float)
    if b_a.shape != (3,) or b_g.shape != (3,) or a.shape != (n, 3) or e.shape != (n, 3):
        raise ValueError(f"accel_bias, gyro_bias: expected shape (3,); accel_noise, gyro_noise: ({n}, 3)")
    dt = np.diff(t, append=t[-1])  # the last row starts no step
    w = math.sqrt(G0 / EARTH_RADIUS_M)
    c, s = np.cos(w * t)[:, None], np.sin(w * t)[:, None]
    tc = t[:, None]

    def before(u):  # sum over the steps that ended by each t_k
        return np.vstack([np.zeros((1, u.shape[1])), np.cumsum(u * dt[:, None], axis=0)[:-1]])

    # horizontal channels as x'' = a + g phi, phi' = -x'/R + e:  north (a_N, eps_E), east (a_E, -eps_N)
    def gyro_pair(u):
        return u[..., [1, 0]] * np.array([1.0, -1.0])

    ah, eh = a[:, :2], gyro_pair(e)
    bh, gh = b_a[:2], gyro_pair(b_g)
    phi0 = np.array([tilt0[1], -tilt0[0]])
    x0, v0 = np.asarray(x0, float), np.asarray(v0, float)
    horiz = (
        x0[:2]
        + v0[:2] * s / w
        + (G0 * phi0 + bh) * (1.0 - c) / w**2  # eq. 4, solved: tilt and accel bias
        + G0 * gh * (tc - s / w) / w**2  # gyro bias
        + (s * before(ah * c) - c * before(ah * s)) / w  # int a(s) sin(w(t - s))/w ds
        + G0 * (before(eh) - c * before(eh * c) - s * before(eh * s)) / w**2
    )  # int g e (1 - cos w(t - s))/w^2 ds
    # vertical: x_D'' = beta_D  ->  x = x0 + v0 t + beta t^2/2 + int (t - s) noise(s) ds
    ad = a[:, 2:3]
    vert = x0[2] + v0[2] * tc + 0.5 * b_a[2] * tc**2 + tc * before(ad) - before(ad * tc)
    return np.column_stack([horiz, vert[:, 0]])


@dataclass(frozen=True)
class InertialErrors:
    """One drawn INS error realization: the sensor errors (biases per axis, white-noise
    samples on the epochs, each held over the step that follows it), the alignment errors,
    and the NED position error of eq. 4 on the epochs `t_s`. The same draw drives the
    strapdown path (aerotruth.sensors.ins), with the biases in body axes there."""

    t_s: np.ndarray
    accel_bias_mps2: np.ndarray  # (3,)
    gyro_bias_radps: np.ndarray  # (3,)
    error_ned_m: np.ndarray  # (n, 3)
    accel_white_mps2: np.ndarray | None = None  # (n, 3)
    gyro_white_radps: np.ndarray | None = None  # (n, 3)
    position0_m: np.ndarray | None = None  # (3,) NED
    velocity0_mps: np.ndarray | None = None  # (3,) NED
    tilt0_rad: np.ndarray | None = None  # (2,) phi_N, phi_E

    @classmethod
    def draw(cls, spec: InertialErrorSpec, rng: np.random.Generator, t_s) -> InertialErrors:
        """Biases, white noise on the sample grid and initial errors, propagated by eq. 4."""
        gr = spec.grade_figures()
        t = np.asarray(t_s, dtype=float)
        if t.ndim != 1 or len(t) < 2 or not np.all(np.diff(t) > 0):
            raise ValueError("t_s: expected at least 2 increasing times")
        dt = np.diff(t, append=t[-1] + (t[-1] - t[-2]))
        b_a = gr.accel_bias_ug * MICRO_G * rng.standard_normal(3)
        b_g = gr.gyro_bias_deg_h * DEG_PER_H * rng.standard_normal(3)
        # white: two-sided density S/2, averaged over each step -> variance S / (2 dt)
        w_a = np.sqrt(gr.accel_white_ug2_hz / (2 * dt))[:, None] * MICRO_G * rng.standard_normal((len(t), 3))
        w_g = (
            np.sqrt(gr.gyro_white_deg2_s2_hz / (2 * dt))[:, None] * math.radians(1.0) * rng.standard_normal((len(t), 3))
        )
        x0 = spec.initial_position_sigma_m * rng.standard_normal(3)
        v0 = spec.initial_velocity_sigma_mps * rng.standard_normal(3)
        tilt0 = spec.initial_tilt_sigma_urad * 1e-6 * rng.standard_normal(2)
        err = ins_error_ned(t, b_a, b_g, w_a, w_g, x0=x0, v0=v0, tilt0=tilt0)
        return cls(t, b_a, b_g, err, w_a, w_g, x0, v0, tilt0)

    def apply(self, truth_xyz, t_s, runway_course_deg: float) -> np.ndarray:
        """INS positions in the runway frame (x along the course, y left, z up) for true
        positions (n, 3) at the drawn epochs; the NED error is rotated by the true course."""
        t = np.asarray(t_s, dtype=float)
        if t.shape != self.t_s.shape or not np.allclose(t, self.t_s, rtol=0, atol=1e-9):
            raise ValueError("t_s: expected the epochs these errors were drawn at")
        p = np.asarray(truth_xyz, dtype=float)
        if p.shape != self.error_ned_m.shape:
            raise ValueError(f"truth_xyz: expected shape {self.error_ned_m.shape}, got {p.shape}")
        c, s = math.cos(math.radians(runway_course_deg)), math.sin(math.radians(runway_course_deg))
        n, e, d = self.error_ned_m.T
        return p + np.column_stack([n * c + e * s, n * s - e * c, -d])
