"""ILS approach truth: the 3-D runway frame, the coupled approach and its
configuration schedule, the 50 Hz inertial truth closing on itself through an
independent strapdown mechanization, and lever-arm positions against hand-worked cases."""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
from datetime import date

import numpy as np
import pandas as pd
import pytest

from aerotruth import geo
from aerotruth.sensors import strapdown as sd
from aerotruth.truth.approach import approach_metrics, approach_spec, find_runway, fly_approach, point_positions
from aerotruth.truth.runway import RunwayFrame
from aerotruth.truth.track import COLUMNS, TruthTrack
from aerotruth.truth.weather import UniformAtmosphere
from aerotruth.units import DEG, FT, KT, NM

DAY = date(2009, 8, 15)


@pytest.fixture(scope="module")
def calm_afis():
    return fly_approach(approach_spec("KDLH", "27", DAY), seed=1)


@pytest.fixture(scope="module")
def windy_go_around():
    # 15 kt from 40 deg right of the nose of runway 27 (course 272.3 -> wind from 312)
    frm = math.radians(312.0)
    atm = UniformAtmosphere(u_mps=-15 * KT * math.sin(frm), v_mps=-15 * KT * math.cos(frm))
    return fly_approach(approach_spec("KDLH", "27", DAY, profile="go-around", turbulence=True), seed=3, atmosphere=atm)


def test_runway_frame_matches_hand_worked_geometry():
    rw = find_runway("KDLH", "27")
    f = RunwayFrame.of(rw)
    # 10 km along the course at the threshold's height: the normal-section radius there is
    # close to the prime-vertical N = a / sqrt(1 - e^2 sin^2 lat) (course ~west); the point
    # lies (N + h) sin(s/N) ahead and (N + h)(1 - cos(s/N)) below the tangent plane
    s = 10000.0
    lat, lon, _ = geo.forward(rw.threshold_lat, rw.threshold_lon, rw.true_course_deg, s)
    x, y, z = f.from_geodetic(lat, lon, f.h0_m)
    n = 6378137.0 / math.sqrt(1 - 6.69437999014e-3 * math.sin(math.radians(rw.threshold_lat)) ** 2)
    assert float(x) == pytest.approx((n + f.h0_m) * math.sin(s / n), abs=0.01)
    assert float(z) == pytest.approx(-(n + f.h0_m) * (1 - math.cos(s / n)), abs=0.01)
    assert abs(float(y)) < 0.01
    # 1 km to the right of the landing direction is y = -1000 (y is positive to the left)
    lat, lon, _ = geo.forward(rw.threshold_lat, rw.threshold_lon, rw.true_course_deg + 90.0, 1000.0)
    assert float(f.from_geodetic(lat, lon, f.h0_m)[1]) == pytest.approx(-1000.0, abs=0.1)
    # the origin is the threshold at its ellipsoidal height (elevation + undulation)
    assert f.h0_m == pytest.approx(rw.elevation_m + rw.undulation_m)
    pts = np.array([[-20000.0, 35.0, 1100.0], [500.0, -12.0, 30.0]])
    back = np.column_stack(f.from_geodetic(*f.to_geodetic(*pts.T)))
    np.testing.assert_allclose(back, pts, atol=1e-6)


def test_lever_arm_positions_match_a_hand_worked_attitude():
    rw = find_runway("KDLH", "27")
    f = RunwayFrame.of(rw)
    theta, phi = 10.0 * DEG, 30.0 * DEG
    row = {c: 0.0 for c in COLUMNS if c != "phase"}
    row.update(
        lat_deg=f.lat0_deg,
        lon_deg=f.lon0_deg,
        h_ellipsoid_m=f.h0_m,
        heading_rad=math.radians(f.course_deg),
        x_m=0.0,
        y_m=0.0,
        z_m=0.0,
        cg_x_m=8.5,
        cg_y_m=0.0,
        cg_z_m=-0.2,
    )
    df = pd.DataFrame([dict(row, pitch_rad=theta, roll_rad=0.0), dict(row, pitch_rad=0.0, roll_rad=phi)])
    df["phase"] = "approach"
    meta = {
        "runway_frame": {"lat0_deg": f.lat0_deg, "lon0_deg": f.lon0_deg, "h0_m": f.h0_m, "course_deg": f.course_deg},
        "points_structural_m": {"nose_top": [6.5, 0.0, 0.8], "right": [8.5, 1.0, -0.2]},
    }
    p = point_positions(TruthTrack(df, meta))
    # 2 m ahead of and 1 m above the CG, nose up 10 deg: r = 2 x_b - 1 z_b with
    # x_b = (cos t, 0, sin t), z_b (down) = (sin t, 0, -cos t) in (x along, y left, z up)
    want = [2 * math.cos(theta) - math.sin(theta), 0.0, 2 * math.sin(theta) + math.cos(theta)]
    np.testing.assert_allclose(p["nose_top"][0], want, atol=1e-9)
    # 1 m along the right wing, rolled 30 deg right: y_b = (0, -cos phi, -sin phi)
    np.testing.assert_allclose(p["right"][1], [0.0, -math.cos(phi), -math.sin(phi)], atol=1e-9)


@pytest.mark.slow
def test_calm_approach_is_stabilised_and_passes_level_over_the_runway(calm_afis):
    df, meta = calm_afis.df, calm_afis.meta
    assert np.allclose(np.diff(df["time_s"]), 0.02, atol=1e-9)  # 50 Hz
    m = approach_metrics(calm_afis)
    assert m["stabilised"] == 1.0
    assert abs(m["loc_dots_1000ft"]) < 0.2 and abs(m["gs_dots_1000ft"]) < 0.2
    assert -5.0 <= m["cas_minus_vref_kt_1000ft"] <= 10.0
    # the glide path crosses the threshold at 50 ft; the level-off to the 100 ft pass starts above it
    assert 60.0 < m["height_over_threshold_ft"] < 160.0
    over = (df["x_m"] > 300.0) & (df["x_m"] < meta["runway_length_m"])
    assert df.loc[over, "z_m"].between(90 * FT, 140 * FT).all()
    assert m["recorded_past_threshold_s"] >= 100.0
    # a coupled approach starts >= 11 nm out and is on the glide path by 11 nm
    ev = meta["events_s"]
    t11 = df["time_s"][df["x_m"] >= -11 * NM].iloc[0]
    assert df["x_m"].iloc[0] <= -11 * NM and ev["gs_capture_s"] < t11
    # configuration: gear down and flaps 35 before 1,000 ft; approach attitude nose-up-ish
    assert ev["flaps35_s"] < df["time_s"][(df["x_m"] < 0) & (df["z_m"] < 1000 * FT)].iloc[0]
    final = (df["x_m"] > -2 * NM) & (df["x_m"] < -0.5 * NM)
    assert df.loc[final, "pitch_rad"].between(-2 * DEG, 4 * DEG).all()
    # calm air: the roll-in of the localizer capture stays airline-like
    assert np.abs(df["roll_rad"]).max() < 5 * DEG


@pytest.mark.parametrize("turbulence", [False, True])
def test_the_steering_wander_is_stepped_every_tenth_of_a_second_of_flight(monkeypatch, turbulence):
    """fly_loop (calm; gusts updated at 50 Hz) steps the wander every
    STEER_DT_S = 0.1 s of flight: as many steps as tenths of a second flown (the last
    second's ten included), on the flight's own 'steering' stream."""
    import aerotruth.truth.approach as approach_mod
    from aerotruth import seeds
    from aerotruth.truth.steering import STEER_SIGMA_RAD, SteeringWander

    made = []

    class Counting(SteeringWander):
        def __init__(self, fdm, rng):
            super().__init__(fdm, rng)
            self.calls = 0
            self.e0 = self.e  # the stationary start, the stream's first draw
            made.append(self)

        def step(self):
            self.calls += 1
            super().step()

    monkeypatch.setattr(approach_mod, "SteeringWander", Counting)
    tr = fly_approach(approach_spec("KDLH", "27", DAY, turbulence=turbulence), seed=5)
    (w,) = made
    seconds = round((tr.df["time_s"].iloc[-1] - tr.df["time_s"].iloc[0]) + 0.02)  # 50 Hz rows of whole seconds
    assert w.calls == 10 * seconds
    assert w.e0 == STEER_SIGMA_RAD * seeds.generator(seeds.named_child(5, "steering")).standard_normal()


def test_calm_final_weaves_as_an_airliners_coupled_final_does(calm_afis):
    """Roll on the straight final (6 to 1.5 nm) in calm air: the autopilot's steering
    wander (truth/steering.py, 0.65 deg of bank command, 5 s) gives |roll| of a few tenths
    of a degree, as the airliner recorders' coupled finals show (A320 and A310 files of the
    real-data folder through the realism study: |roll| p50 0.35 deg, p95 1.4 deg), not the
    noiseless loop's hundredths; the aircraft stays on the localizer (a few metres)."""
    df = calm_afis.df
    final = ((df["x_m"] > -6 * NM) & (df["x_m"] < -1.5 * NM)).to_numpy()
    roll = np.abs(df["roll_rad"].to_numpy()[final]) / DEG
    assert 0.15 < np.median(roll) < 0.8
    assert 0.6 < np.percentile(roll, 95) < 2.0
    y = df["y_m"].to_numpy()[final]
    assert np.sqrt(np.mean(y**2)) < 10.0
    # the wander is the flight's own named stream: another seed weaves otherwise
    other = fly_approach(approach_spec("KDLH", "27", DAY), seed=2)
    fo = ((other.df["x_m"] > -6 * NM) & (other.df["x_m"] < -1.5 * NM)).to_numpy()
    n = min(final.sum(), fo.sum())
    assert not np.allclose(df["roll_rad"].to_numpy()[final][:n], other.df["roll_rad"].to_numpy()[fo][:n], atol=1e-4)


@pytest.mark.slow
def test_inertial_truth_closes_through_an_independent_strapdown_mechanization(calm_afis, tmp_path):
    """A strapdown (aerotruth.sensors.strapdown, ECEF, J2 gravity) of the recorded dv,
    dtheta from the true state at 60 s reproduces the recorded position within 1 m and the
    attitude within 0.01 deg after 120 s; read back from Parquet (float32 increments)."""
    path = tmp_path / "a.parquet"
    calm_afis.to_parquet(path)
    df = TruthTrack.read_parquet(path).df
    j0, n = 3000, 6000
    r = df.iloc[j0]
    st = sd.NavState.from_geodetic(
        r.lat_deg,
        r.lon_deg,
        r.h_ellipsoid_m,
        np.array([r.vn_mps, r.ve_mps, r.vd_mps]),
        r.roll_rad,
        r.pitch_rad,
        r.heading_rad,
    )
    cols_v, cols_t = ["dv_x_mps", "dv_y_mps", "dv_z_mps"], ["dtheta_x_rad", "dtheta_y_rad", "dtheta_z_rad"]
    end = sd.propagate(
        st, df[cols_v].to_numpy(float)[j0 + 1 : j0 + 1 + n], df[cols_t].to_numpy(float)[j0 + 1 : j0 + 1 + n], 0.02
    )[-1]
    row = df.iloc[j0 + n]
    err = np.linalg.norm(end.r - np.array(geo.ecef(row.lat_deg, row.lon_deg, row.h_ellipsoid_m)))
    roll, pitch, yaw = end.euler()
    att = np.degrees(
        [roll - row.roll_rad, pitch - row.pitch_rad, (yaw - row.heading_rad + np.pi) % (2 * np.pi) - np.pi]
    )
    print(f"strapdown after 120 s: position {err:.3f} m, attitude {np.abs(att).max():.5f} deg")
    assert err < 1.0
    assert np.abs(att).max() < 0.01


@pytest.mark.slow
def test_the_imu_senses_gravity_and_the_earth_rate_in_steady_flight(calm_afis):
    """Independent physics: on the steady glide path the specific force is ~ -g along
    body z (so |dv| ~ g dt) and the gyros see the Earth's rotation plus the transport rate."""
    df = calm_afis.df
    sel = (df["x_m"] > -8 * NM) & (df["x_m"] < -6 * NM)
    f = df.loc[sel, ["dv_x_mps", "dv_y_mps", "dv_z_mps"]].to_numpy(float) / 0.02
    assert np.linalg.norm(f, axis=1).mean() == pytest.approx(9.80, abs=0.05)
    assert f[:, 2].mean() < -9.5


@pytest.mark.slow
def test_windy_turbulent_go_around_climbs_away_and_cleans_up(windy_go_around):
    df, meta = windy_go_around.df, windy_go_around.meta
    m = approach_metrics(windy_go_around)
    assert m["stabilised"] == 1.0
    ev = meta["events_s"]
    assert {"gs_capture_s", "go_around_s", "gear_up_s", "threshold_s"} <= set(ev)
    ga = df["time_s"] >= ev["go_around_s"]
    assert df.loc[ga, "z_m"].min() > 150 * FT  # no sink below the decision height after it
    assert df["z_m"].iloc[-1] > 1000 * FT
    assert m["recorded_past_threshold_s"] >= 100.0
    # the crab angle into the crosswind from the right: heading right of the course
    final = (df["x_m"] > -4 * NM) & (df["x_m"] < -1 * NM)
    crab = np.degrees(
        np.angle(np.exp(1j * (df.loc[final, "heading_rad"] - math.radians(meta["runway_frame"]["course_deg"]))))
    )
    assert 2.0 < crab.mean() < 8.0


def test_bad_runway_and_profile_are_one_clear_error():
    with pytest.raises(ValueError, match="runway: KDLH has no runway '28'"):
        find_runway("KDLH", "28")
    with pytest.raises(ValueError, match="profile"):
        approach_spec("KDLH", "27", DAY, profile="touch-and-go")


@pytest.mark.parametrize("height, ok", [("-50", False), ("5", False), ("1500", False), ("abc", False), ("50", True)])
def test_pass_height_is_checked_by_the_argument_parser(height, ok, capsys):
    """A level pass below the runway (or at 5 ft) used to fly into the divergence guard."""
    from aerotruth.app.cli import _pass_height_ft

    if ok:
        assert _pass_height_ft(height) == float(height)
    else:
        with pytest.raises(argparse.ArgumentTypeError, match=r"expected (20-1000 ft above the runway|a height in ft)"):
            _pass_height_ft(height)


@pytest.mark.slow
def test_fly_approach_command_line(tmp_path):
    out = tmp_path / "a.parquet"
    cmd = [
        sys.executable,
        "-m",
        "aerotruth",
        "fly-approach",
        "--airport",
        "KDLH",
        "--runway",
        "27",
        "--date",
        "2009-08-15",
        "--seed",
        "1",
        "--out",
        str(out),
    ]
    r = subprocess.run(cmd, capture_output=True, text=True)
    assert r.returncode == 0, r.stderr
    t = TruthTrack.read_parquet(out)
    assert t.meta["airport"] == "KDLH" and t.meta["runway"] == "27" and t.meta["rate_hz"] == 50
    assert {"x_m", "y_m", "z_m", "dv_x_mps", "dtheta_z_rad", "cg_x_m"} <= set(t.df.columns)
    bad = subprocess.run(cmd[:7] + ["09L"] + cmd[8:], capture_output=True, text=True)
    assert bad.returncode == 2 and "no runway '09L'" in bad.stderr and "Traceback" not in bad.stderr


@pytest.mark.slow
def test_turn_onto_final_captures_the_localizer_by_10_nm_with_an_airline_roll():
    """From 1.5 nm right of the centreline on a 30 deg intercept: on the localizer (within
    30 m) by 10 nm, bank within the 25 deg limit (+3 deg overshoot), roll rate at 1 Hz
    under 5 deg/s, still stabilised at 1,000 ft."""
    tr = fly_approach(approach_spec("KDLH", "27", DAY, offset_nm=-1.5, intercept_deg=30.0), seed=4)
    df = tr.df
    assert df["y_m"].iloc[0] == pytest.approx(-1.5 * NM, abs=5.0)
    assert abs(df["y_m"][df["x_m"] >= -10 * NM].iloc[0]) < 30.0
    roll = np.degrees(df["roll_rad"].to_numpy())
    assert 10.0 < np.abs(roll).max() < 28.0
    assert np.abs(np.diff(roll[::50])).max() < 5.0
    assert approach_metrics(tr)["stabilised"] == 1.0
    with pytest.raises(ValueError, match="intercept_deg"):
        approach_spec("KDLH", "27", DAY, intercept_deg=60.0)


def test_dcm_body_to_ned_is_scipys_zyx_euler_rotation():
    from scipy.spatial.transform import Rotation

    from aerotruth.truth.approach import dcm_body_to_ned

    rng = np.random.default_rng(0)
    ang = rng.uniform(-1.5, 1.5, (50, 3))
    expect = Rotation.from_euler("ZYX", ang).as_matrix()
    assert np.allclose(dcm_body_to_ned(ang[:, 0], ang[:, 1], ang[:, 2]), expect, atol=1e-12)
