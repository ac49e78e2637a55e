"""An INS on approach truth: the position it reports for a point of the airframe, by one
of two paths that share one error draw (aerotruth.sensors.inertial_errors):

* `error_model` — the FITS paper's simplified NED error model (eq. 4) added to the true
  position of the point: x_INS = x_true + C_rwy<-ned dx_NED. Cheap (array passes); the
  attitude error's effect on the lever arm is left out (tilt 0.03 deg x 5 m = 3 mm).
  Sign convention of eq. 4 (checked against the strapdown in tests/test_ins.py): its tilt
  phi and gyro error eps are corrections (computed -> true), so a body gyro bias b_g acts
  as eps = -C_nb b_g, and an accelerometer bias b_a as beta = C_nb b_a.
* `strapdown` — the recorded 50 Hz IMU truth (dv, dtheta at the IMU point, body axes)
  corrupted by the same draw (accelerometer and gyro biases taken in body axes, white
  noise per 20 ms increment: dv += (b_a + w_a) dt, dtheta += (b_g + w_g) dt) and
  integrated by aerotruth.sensors.strapdown (ECEF, J2 gravity) from the true state at
  the first sample plus the alignment errors (position and velocity per NED axis, tilt
  about north and east); the point's position is then the INS position of the IMU plus
  the lever arm turned by the INS attitude. This is what a real INS does; it keeps the
  couplings eq. 4 drops (specific force x attitude error in turns and decelerations,
  the heading error's lever-arm effect).

Alignment (stated, as DESIGN.md asks): an automotive gyro cannot gyrocompass (its 100
deg/h bias is 7 times the Earth rate), so every grade is given a transfer alignment from
the aircraft's attitude reference with the tilt error `initial_tilt_sigma_urad` (default
500 urad = 0.03 deg per axis) and no azimuth error: heading comes from the aircraft's
heading reference, whose error does not enter eq. 4.

A time-tag error tau (the INS output stamped tau late, e.g. a latency not compensated)
makes the INS report at time t the position it had at t - tau.
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field
from scipy.spatial.transform import Rotation

from aerotruth.sensors import strapdown as sd
from aerotruth.sensors.inertial_errors import InertialErrors, InertialErrorSpec

MECHANIZATIONS = ("error_model", "strapdown")


class InsSpec(InertialErrorSpec):
    """One INS of an inspection system: a grade, its alignment, a path, a time-tag error."""

    name: str = Field(default="", description="label in tables and figures (default: the grade)")
    mechanization: Literal["error_model", "strapdown"] = Field(
        default="error_model", description="error_model (FITS paper eq. 4) or strapdown (the recorded IMU truth integrated)")
    time_tag_error_s: float = Field(default=0.0, description="INS output stamped this late (s); 0 for a correct time tag")

    @property
    def label(self) -> str:
        return self.name or self.grade


def _shifted(t: np.ndarray, values: np.ndarray, tau: float) -> np.ndarray:
    """values(t - tau) by linear interpolation per column (held at the ends)."""
    if tau == 0.0:
        return values
    return np.column_stack([np.interp(t - tau, t, values[:, i]) for i in range(values.shape[1])])


def ins_positions(track, spec: InsSpec, rng: np.random.Generator, point: str = "gnss") -> tuple[np.ndarray, InertialErrors]:
    """The INS position (n, 3), runway frame, of the airframe point `point` at every
    50 Hz sample of the approach `track`, and the error draw behind it."""
    from aerotruth.truth.approach import point_positions

    df, meta = track.df, track.meta
    t = df["time_s"].to_numpy(float)
    draw = InertialErrors.draw(spec, rng, t)
    course = float(meta["runway_frame"]["course_deg"])
    if spec.mechanization == "error_model":
        p_true = point_positions(track)[point]
        p = draw.apply(p_true, t, course)
    else:
        p = strapdown_positions(track, draw, point)
    return _shifted(t, p, spec.time_tag_error_s), draw


def strapdown_positions(track, draw: InertialErrors, point: str = "gnss") -> np.ndarray:
    """The strapdown path (module docstring): runway-frame positions (n, 3) of `point`."""
    from aerotruth import geo
    from aerotruth.truth.approach import point_positions
    from aerotruth.truth.runway import RunwayFrame

    df, meta = track.df, track.meta
    frame = RunwayFrame(**meta["runway_frame"])
    t = df["time_s"].to_numpy(float)
    dt = float(np.median(np.diff(t)))
    pts = {k: np.asarray(v, float) for k, v in meta["points_structural_m"].items()}
    imu = point_positions(track, {"imu": tuple(pts["imu"])})["imu"]
    # the true state of the IMU at the first sample, plus the alignment errors (NED)
    r0 = df.iloc[0]
    lat, lon, h = (float(v) for v in frame.to_geodetic(*imu[0]))
    c_en = geo.ecef_from_ned_matrix(lat, lon)
    p0 = np.array(geo.ecef(lat, lon, h), float) + c_en @ draw.position0_m
    v_ned = np.array([r0.vn_mps, r0.ve_mps, r0.vd_mps], float) + draw.velocity0_mps
    c_nb = Rotation.from_euler("ZYX", [r0.heading_rad, r0.pitch_rad, r0.roll_rad]).as_matrix()
    # tilt (phi_N, phi_E) of eq. 4 is the angle from the computed to the true frame (its
    # x_N'' = beta_N + g phi_E), so the computed attitude is the true one turned by -phi
    tilt = Rotation.from_rotvec([-draw.tilt0_rad[0], -draw.tilt0_rad[1], 0.0]).as_matrix()
    state = sd.NavState(p0, c_en @ v_ned, c_en @ tilt @ c_nb)
    dv = df[["dv_x_mps", "dv_y_mps", "dv_z_mps"]].to_numpy(float)[1:]
    dth = df[["dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad"]].to_numpy(float)[1:]
    # sensor errors over the 20 ms ending at each sample (the draw's row k-1 holds over it)
    dv = dv + (draw.accel_bias_mps2 + draw.accel_white_mps2[:-1]) * dt
    dth = dth + (draw.gyro_bias_radps + draw.gyro_white_radps[:-1]) * dt
    r, _, c_eb = sd.propagate_arrays(state, dv, dth, dt)
    lat, lon, h = geo.geodetic_from_ecef(r[:, 0], r[:, 1], r[:, 2])
    x, y, z = frame.from_geodetic(lat, lon, h)
    # the point: lever arm from the IMU in body axes (structural x aft, z up -> body x fwd, z down)
    d = pts[point] - pts["imu"]
    r_b = np.array([-d[0], d[1], -d[2]])
    c_rb = np.einsum("ij,njk->nik", frame.rotation_from_ecef, c_eb)
    return np.column_stack([x, y, z]) + np.einsum("nij,j->ni", c_rb, r_b)
