"""The INS on approach truth: the strapdown path (recorded IMU truth + sensor errors,
integrated) against the FITS paper's NED error model (eq. 4) on the same error draw."""

from __future__ import annotations

import datetime as dt

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from aerotruth.sensors.inertial_errors import DEG_PER_H, MICRO_G, InertialErrors, ins_error_ned
from aerotruth.sensors.ins import InsSpec, ins_positions, strapdown_positions
from aerotruth.truth.approach import approach_spec, fly_approach, point_positions
from aerotruth.truth.track import TruthTrack
from aerotruth.units import NM

DAY = dt.date(2009, 8, 15)


@pytest.fixture(scope="module")
def calm():
    return fly_approach(approach_spec("KDLH", "27", DAY), seed=2)


def _draw(track, b_a_body, b_g_body, seconds):
    """A draw with given body-axis biases, no noise and perfect alignment, and the eq. 4
    error it predicts with the biases taken to NED at the mean attitude of the segment."""
    df = track.df
    t = df["time_s"].to_numpy(float)
    n = len(t)
    z3 = np.zeros(3)
    draw = InertialErrors(
        t,
        np.asarray(b_a_body, float),
        np.asarray(b_g_body, float),
        np.zeros((n, 3)),
        np.zeros((n, 3)),
        np.zeros((n, 3)),
        z3,
        z3,
        np.zeros(2),
    )
    seg = t <= seconds
    c_nb = (
        Rotation.from_euler("ZYX", np.column_stack([df["heading_rad"], df["pitch_rad"], df["roll_rad"]])[seg])
        .mean()
        .as_matrix()
    )
    model = ins_error_ned(t[seg], c_nb @ draw.accel_bias_mps2, -(c_nb @ draw.gyro_bias_radps))  # eq. 4 sign convention
    return draw, model, seg


def _to_rwy(ned, course_deg):
    c, s = np.cos(np.radians(course_deg)), np.sin(np.radians(course_deg))
    n, e, d = ned.T
    return np.column_stack([n * c + e * s, n * s - e * c, -d])


@pytest.mark.slow
@pytest.mark.parametrize("which", ["accelerometer", "gyro"])
def test_strapdown_and_the_eq4_error_model_agree_on_the_straight_segment(calm, which):
    """Before glide-path capture (straight and level, 150 s) the strapdown's position
    error equals eq. 4's within 3 % of the drift (measured: 1.2 % accelerometer, 2.3 %
    gyro; the gyro's few metres of vertical error are the tilt x horizontal specific force
    coupling eq. 4 leaves out)."""
    b_a = np.array([3000.0, -2000.0, 1500.0]) * MICRO_G if which == "accelerometer" else np.zeros(3)
    b_g = np.array([30.0, -50.0, 40.0]) * DEG_PER_H if which == "gyro" else np.zeros(3)
    draw, model, seg = _draw(calm, b_a, b_g, 150.0)
    clean, _, _ = _draw(calm, np.zeros(3), np.zeros(3), 150.0)
    course = calm.meta["runway_frame"]["course_deg"]
    sd_err = (
        strapdown_positions(calm, draw)[seg] - strapdown_positions(calm, clean)[seg]
    )  # the recording's own closure cancels
    md_err = _to_rwy(model, course)
    scale = np.abs(md_err).max(axis=0)
    dev = np.abs(sd_err - md_err).max(axis=0)
    print(
        f"\n{which}: eq. 4 error at 150 s {np.round(md_err[-1], 2)} m, strapdown {np.round(sd_err[-1], 2)} m, "
        f"max difference {np.round(dev, 3)} m"
    )
    assert dev.max() <= 0.03 * scale.max()
    assert scale.max() > 20.0  # a test of something: tens of metres of drift


@pytest.mark.slow
def test_they_part_where_the_aircraft_manoeuvres(calm):
    """Over the whole approach (capture, flaps, deceleration, level-off) eq. 4 with fixed NED
    biases misses what the attitude changes do to body-axis biases: the difference grows."""
    b_a = np.array([3000.0, -2000.0, 1500.0]) * MICRO_G
    draw, _, _ = _draw(calm, b_a, np.zeros(3), 1e9)
    clean, _, _ = _draw(calm, np.zeros(3), np.zeros(3), 1e9)
    t = calm.df["time_s"].to_numpy(float)
    sd_err = strapdown_positions(calm, draw) - strapdown_positions(calm, clean)
    c_nb0 = (
        Rotation.from_euler("ZYX", calm.df[["heading_rad", "pitch_rad", "roll_rad"]].to_numpy()[:7500])
        .mean()
        .as_matrix()
    )
    md_err = _to_rwy(ins_error_ned(t, c_nb0 @ b_a, np.zeros(3)), calm.meta["runway_frame"]["course_deg"])
    rel = np.abs(sd_err[-1] - md_err[-1]) / np.abs(md_err[-1])
    print(f"\nwhole approach ({t[-1]:.0f} s): eq. 4 {np.round(md_err[-1], 1)} m, strapdown {np.round(sd_err[-1], 1)} m")
    assert rel.max() > 0.03


@pytest.mark.slow
def test_time_tag_error_delays_the_reported_position(calm):
    spec0 = InsSpec(grade="tactical", initial_velocity_sigma_mps=0.0, initial_tilt_sigma_urad=0.0)
    spec1 = spec0.model_copy(update={"time_tag_error_s": 0.5})
    p0, _ = ins_positions(calm, spec0, np.random.default_rng(3))
    p1, _ = ins_positions(calm, spec1, np.random.default_rng(3))
    df = calm.df
    far = (df["x_m"] < -8 * NM).to_numpy()
    gs = np.hypot(df["vn_mps"], df["ve_mps"]).to_numpy()
    # half a second late: the reported position lags by half a second of ground speed
    assert np.median((p0 - p1)[far, 0] / gs[far]) == pytest.approx(0.5, abs=0.01)


@pytest.mark.slow
def test_error_model_path_is_the_true_point_plus_the_rotated_eq4_error(calm):
    spec = InsSpec(grade="automotive")
    p, draw = ins_positions(calm, spec, np.random.default_rng(4))
    truth = point_positions(calm)["gnss"]
    assert np.allclose(p - truth, _to_rwy(draw.error_ned_m, calm.meta["runway_frame"]["course_deg"]))
    sub = TruthTrack(calm.df.iloc[::10].reset_index(drop=True), calm.meta)
    p_sub, _ = ins_positions(sub, spec, np.random.default_rng(4))
    assert p_sub.shape == (len(sub.df), 3)


def test_baro_inertial_loop_follows_the_barometer_through_its_third_order_transfer():
    """Closed-loop height error of the triple-pole loop: a barometer sinusoid passes with
    |H(jw)| = |k1 (jw)^2 + k2 jw + k3| / |jw + 1/tau|^3, and an accelerometer bias is
    learned (no steady height error)."""
    from aerotruth.sensors.ins import baro_inertial_error

    tau, dt_s = 30.0, 0.05
    t = np.arange(0.0, 1500.0, dt_s)
    n = len(t)
    z3 = np.zeros(3)
    spec = InsSpec(
        grade="navigation",
        vertical="baro",
        baro_loop_time_constant_s=tau,
        baro_gm_sigma_m=0.0,
        baro_white_sigma_m=0.0,
        baro_rate_hz=1.0 / dt_s,
    )
    bias = InertialErrors(
        t, np.array([0.0, 0.0, 2e-3]), z3, np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), z3, z3, np.zeros(2)
    )
    up = baro_inertial_error(t, bias, spec, np.random.default_rng(0))
    assert abs(up[-1]) < 1e-3 and np.abs(up).max() > 0.3  # drifted, then learned the bias
    # a barometer sinusoid: patch the draw's barometer by a generator that yields it
    k1, k2, k3 = 3 / tau, 3 / tau**2, 1 / tau**3
    for period in (12.0, 120.0):
        w = 2 * np.pi / period

        class Sine:
            def standard_normal(self, m, w=w):  # GM part off (sigma 0): the white part carries the sine
                return np.sin(w * np.arange(m) * dt_s)

        s2 = spec.model_copy(update={"baro_white_sigma_m": 1.0})
        clean = InertialErrors(t, z3, z3, np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), z3, z3, np.zeros(2))
        h = baro_inertial_error(t, clean, s2, Sine())
        tail = h[t > 10 * tau]
        gain = (tail.max() - tail.min()) / 2
        jw = 1j * w
        expect = abs(k1 * jw**2 + k2 * jw + k3) / abs(jw + 1 / tau) ** 3
        print(f"\nbaro loop tau {tau:g} s: |H| at {period:g} s = {gain:.3f} (analytic {expect:.3f})")
        assert gain == pytest.approx(expect, rel=0.03)


def test_inertial_vertical_channel_grows_as_cosh_with_the_gravity_gradient():
    """x'' = (2 g / R) x + beta from rest: x = beta (cosh(w t) - 1) / w^2, against a fine
    numerical integration and, early on, eq. 4's beta t^2 / 2."""
    from aerotruth.sensors.inertial_errors import EARTH_RADIUS_M, G0
    from aerotruth.sensors.ins import inertial_vertical_error

    t = np.arange(0.0, 3600.0, 0.5)
    n = len(t)
    z3 = np.zeros(3)
    beta = 25 * MICRO_G
    draw = InertialErrors(
        t, np.array([0.0, 0.0, beta]), z3, np.zeros((n, 3)), np.zeros((n, 3)), np.zeros((n, 3)), z3, z3, np.zeros(2)
    )
    x = inertial_vertical_error(t, draw)
    w2 = 2 * G0 / EARTH_RADIUS_M
    xs, vs, out = 0.0, 0.0, []
    for _ in t:  # velocity Verlet at 0.5 s
        out.append(xs)
        a0 = w2 * xs + beta
        xs += vs * 0.5 + 0.5 * a0 * 0.25
        vs += 0.5 * (a0 + w2 * xs + beta) * 0.5
    assert np.allclose(x, out, rtol=1e-6, atol=1e-6)
    assert x[120] == pytest.approx(0.5 * beta * 60.0**2, rel=1e-3)  # early: eq. 4's free channel
    assert x[-1] > 5 * 0.5 * beta * 3600.0**2  # an hour on: the instability dominates (x13.6)


def test_barometric_height_error_is_the_hypsometric_thickness_ratio_in_a_warm_column():
    """An ISA + 15 K column with the ISA's sea-level pressure, written here from the
    hypsometric equation: T = t0 - L h, p = p0 (T / t0)^(g / (R L)) with t0 = 303.15 K.
    The ISA reaches the same pressure at H = h x 288.15 / t0 (equate the two power laws),
    so an altimeter referred to the field at 200 m errs by -(h - 200) x 15 / 303.15
    (-48.0 m at 1,170 m); the OAT ratio T / T_ISA(H) is t0 / 288.15 at every height, so
    the corrected reading is exact; "none" adds nothing."""
    from aerotruth.sensors.air_data import barometric_height_error

    g, r, lapse, t0 = 9.80665, 287.05287, 0.0065, 288.15 + 15.0
    h = np.array([200.0, 500.0, 800.0, 1170.0])
    temp = t0 - lapse * h
    p = 101325.0 * (temp / t0) ** (g / (r * lapse))
    e = barometric_height_error(p, temp, h, 0, "uncorrected")
    assert np.allclose(e, -(h - 200.0) * 15.0 / t0, atol=1e-6)
    assert e[-1] == pytest.approx(-48.0, abs=0.05)
    assert np.allclose(barometric_height_error(p, temp, h, 0, "oat_corrected"), 0.0, atol=1e-6)
    assert not barometric_height_error(p, temp, h, 0, "none").any()
