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

Alignment (stated: docs/conventions.md, INS grades): an automotive gyro cannot gyrocompass (its 100
deg/h bias is 7 times the Earth rate), so every grade is given a transfer alignment from
the aircraft's attitude reference with the tilt error `initial_tilt_sigma_urad` (default
500 urad = 0.03 deg per axis) and no azimuth error: heading comes from the aircraft's
heading reference, whose error does not enter eq. 4.

A time-tag error tau (the INS output stamped tau late, e.g. a latency not compensated)
makes the INS report at time t the position it had at t - tau.

Barometer-coupled vertical channel (`vertical: baro`, the AFIS's: FITS paper section II,
"the barometric altimeter is coupled with the INS so that INS measurements are stable in
vertical"): the classical third-order baro-inertial loop (Widnall & Sinha, "Optimizing
the gains of the baro-inertial vertical channel", J. Guidance and Control 3(2), 1980;
the same loop in Titterton & Weston, 2nd ed., on vertical-channel aiding), on the
height error d = h_INS - h_baro:

    h' = v - k1 d,   v' = a_meas - b_hat - k2 d,   b_hat' = k3 d,

with all three poles at -1/tau_b (k1 = 3/tau_b, k2 = 3/tau_b^2, k3 = 1/tau_b^3), tau_b =
`baro_loop_time_constant_s` (30 s default: a stated choice, the mid of the 10-100 s range
such loops use). Its error equations are integrated on the epochs with the
accelerometer's vertical error (bias + white, from the draw) and the barometric altitude
error: a Gauss-Markov part (`baro_gm_sigma_m` 1.0 m, `baro_gm_tau_s` 60 s: static-source
and position error changing with speed, configuration and gusts) plus white noise per
reading (`baro_white_sigma_m` 0.3 m, ~1 ft resolution of digital air data), readings at
`baro_rate_hz` (1 Hz) held between them. The structure of the barometer error (a
first-order Gauss-Markov process plus an uncorrelated part) is the stochastic model of
Sabatini & Genovese, "A stochastic approach to noise modeling for barometric altimeters",
Sensors 13, 15692 (2013); its magnitudes here are stated estimates for aircraft air
data, not a product's specification. The loop replaces eq. 4's free vertical
x_D'' = beta_D (the error-model path only).
"""

from __future__ import annotations

from typing import Literal

import numpy as np
from pydantic import Field
from scipy.spatial.transform import Rotation

from aerotruth.sensors import strapdown as sd
from aerotruth.sensors.air_data import BaroTemperature, baro_error_from_truth
from aerotruth.sensors.inertial_errors import InertialErrors, InertialErrorSpec

MECHANIZATIONS = ("error_model", "strapdown")


class InsSpec(InertialErrorSpec):
    """One INS of an inspection system: a grade, its alignment, a path, a time-tag error."""

    name: str = Field(default="", description="label in tables and figures (default: the grade)")
    mechanization: Literal["error_model", "strapdown"] = Field(
        default="error_model",
        description="error_model (FITS paper eq. 4) or strapdown (the recorded IMU truth integrated)",
    )
    time_tag_error_s: float = Field(
        default=0.0, description="INS output stamped this late (s); 0 for a correct time tag"
    )
    vertical: Literal["free", "inertial", "baro"] = Field(
        default="free",
        description="eq. 4's vertical (x_D'' = beta_D), the free-inertial channel with its gravity "
        "feedback (x_D'' = 2 g / R x_D + beta_D), or the baro-inertial loop",
    )
    baro_loop_time_constant_s: float = Field(
        default=30.0, gt=0, description="triple pole of the baro-inertial loop at -1/tau"
    )
    baro_gm_sigma_m: float = Field(
        default=1.0, ge=0, description="barometric altitude error, Gauss-Markov part, 1 sigma"
    )
    baro_gm_tau_s: float = Field(default=60.0, gt=0)
    baro_white_sigma_m: float = Field(default=0.3, ge=0, description="barometric altitude noise per reading")
    baro_rate_hz: float = Field(default=1.0, gt=0, description="barometric altitude readings per second (held between)")
    baro_temperature: BaroTemperature = Field(
        default="oat_corrected",
        description="the barometer's error from the truth atmosphere (temperature, pressure gradient), "
        "referred to the threshold: uncorrected, corrected with the outside air temperature (the "
        "compensation assumed of an AFIS), or none (aerotruth.sensors.air_data.barometric_height_error)",
    )

    @property
    def label(self) -> str:
        return self.name or self.grade


def _shifted(t: np.ndarray, values: np.ndarray, tau: float) -> np.ndarray:
    """values(t - tau) by linear interpolation per column (held at the ends)."""
    if tau == 0.0:
        return values
    return np.column_stack([np.interp(t - tau, t, values[:, i]) for i in range(values.shape[1])])


def ins_positions(
    track, spec: InsSpec, rng: np.random.Generator, point: str = "gnss", true_point_m: np.ndarray | None = None
) -> tuple[np.ndarray, InertialErrors]:
    """The INS position (n, 3), runway frame, of the airframe point `point` at every
    sample of the approach `track`, and the error draw behind it (`true_point_m`: that
    point's true positions, when the caller has them already)."""
    from aerotruth.truth.approach import point_positions

    df, meta = track.df, track.meta
    t = df["time_s"].to_numpy(float)
    draw = InertialErrors.draw(spec, rng, t)
    course = float(meta["runway_frame"]["course_deg"])
    if spec.mechanization == "error_model":
        p_true = (
            point_positions(track, {point: tuple(track.meta["points_structural_m"][point])})[point]
            if true_point_m is None
            else true_point_m
        )
        if spec.vertical in ("baro", "inertial"):
            up = (
                baro_inertial_error(
                    t, draw, spec, rng, baro_error_from_truth(df, None, p_true[:, 0], spec.baro_temperature)
                )
                if spec.vertical == "baro"
                else -inertial_vertical_error(t, draw)
            )
            draw = InertialErrors(
                draw.t_s,
                draw.accel_bias_mps2,
                draw.gyro_bias_radps,
                np.column_stack([draw.error_ned_m[:, :2], -up]),
                draw.accel_white_mps2,
                draw.gyro_white_radps,
                draw.position0_m,
                draw.velocity0_mps,
                draw.tilt0_rad,
            )
        p = draw.apply(p_true, t, course)
    else:
        if spec.vertical != "free":
            raise ValueError(f"vertical: {spec.vertical!r} is modelled on the error_model path only")
        p = strapdown_positions(track, draw, point)
    return _shifted(t, p, spec.time_tag_error_s), draw


def inertial_vertical_error(t: np.ndarray, draw: InertialErrors) -> np.ndarray:
    """Down error (m) of the unaided inertial vertical channel with the gravity gradient
    (Titterton & Weston, 2nd ed.: the vertical channel's instability; the AFIS filter's
    model, aerotruth.analysis.fits.afis): x'' = w_v^2 x + beta, w_v^2 = 2 g / R, solved as eq. 4's
    horizontal channels are (closed form for the bias and initial errors, cumulative sums
    of the white noise against cosh, sinh)."""
    from aerotruth.units import EARTH_RADIUS_M, G0

    # a drawn realization (InertialErrors.draw) carries the white noise and initial errors
    assert draw.accel_white_mps2 is not None and draw.position0_m is not None and draw.velocity0_mps is not None
    t = np.asarray(t, float) - float(t[0])
    w = np.sqrt(2.0 * G0 / EARTH_RADIUS_M)
    dt = np.diff(t, append=t[-1])
    ch, sh = np.cosh(w * t), np.sinh(w * t)
    a = draw.accel_white_mps2[:, 2]

    def before(u):
        return np.concatenate([[0.0], np.cumsum(u * dt)[:-1]])

    x0, v0, b = draw.position0_m[2], draw.velocity0_mps[2], draw.accel_bias_mps2[2]
    return (
        x0 * ch
        + v0 * sh / w
        + b * (ch - 1.0) / w**2
        + (sh * before(a * np.cosh(w * t)) - ch * before(a * np.sinh(w * t))) / w
    )


def baro_inertial_error(
    t: np.ndarray,
    draw: InertialErrors,
    spec: InsSpec,
    rng: np.random.Generator,
    atmosphere_error_m: np.ndarray | None = None,
) -> np.ndarray:
    """Height error (up, m) of the baro-inertial loop (module docstring) on the epochs t:
    accelerometer vertical error from the draw (up = -down), barometer error drawn here,
    plus `atmosphere_error_m` (on t; the truth atmosphere's,
    aerotruth.sensors.air_data.baro_error_from_truth) read at
    the barometer's readings."""
    from scipy.signal import lfilter

    # a drawn realization (InertialErrors.draw) carries the white noise and initial errors
    assert draw.accel_white_mps2 is not None and draw.position0_m is not None and draw.velocity0_mps is not None
    t = np.asarray(t, float)
    n = len(t)
    dt = np.diff(t, append=t[-1] + (t[-1] - t[-2]))
    beta_up = -(draw.accel_bias_mps2[2] + draw.accel_white_mps2[:, 2])
    # barometer: readings at baro_rate_hz, Gauss-Markov + white, held between readings
    t_b = np.arange(t[0], t[-1] + 1e-9, 1.0 / spec.baro_rate_hz)
    rho = np.exp(-1.0 / (spec.baro_rate_hz * spec.baro_gm_tau_s))
    u = spec.baro_gm_sigma_m * rng.standard_normal(len(t_b))
    u[1:] *= np.sqrt(1.0 - rho**2)
    e_b = lfilter([1.0], [1.0, -rho], u) + spec.baro_white_sigma_m * rng.standard_normal(len(t_b))
    if atmosphere_error_m is not None:
        e_b = e_b + np.interp(t_b, t, np.asarray(atmosphere_error_m, float))
    e_baro = e_b[np.clip(np.searchsorted(t_b, t + 1e-9, side="right") - 1, 0, len(t_b) - 1)]
    tau = spec.baro_loop_time_constant_s
    k1, k2, k3 = 3.0 / tau, 3.0 / tau**2, 1.0 / tau**3
    h = float(draw.position0_m[2] * -1.0)
    v = float(-draw.velocity0_mps[2])
    b = 0.0
    out = np.empty(n)
    for k in range(n):  # semi-implicit Euler; steps are << tau
        out[k] = h
        d = h - e_baro[k]
        v += (beta_up[k] - b - k2 * d) * dt[k]
        h += (v - k1 * d) * dt[k]
        b += k3 * d * dt[k]
    return out


def strapdown_positions(track, draw: InertialErrors, point: str = "gnss") -> np.ndarray:
    """The strapdown path (module docstring): runway-frame positions (n, 3) of `point`."""
    from aerotruth import geo
    from aerotruth.truth.approach import point_positions
    from aerotruth.truth.runway import RunwayFrame

    # a drawn realization (InertialErrors.draw) carries the white noise and initial errors
    assert draw.accel_white_mps2 is not None and draw.gyro_white_radps is not None and draw.tilt0_rad is not None
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
