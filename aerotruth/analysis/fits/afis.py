"""The AFIS baseline truth system (FITS paper section II): a navigation-grade INS coupled
with the barometric altimeter flies the approach free-inertially; over the runway the
radar altimeter (height), the TVPS (cross-track) and the pilot's event button at both
runway ends (along-track) measure its position; a Kalman filter on the INS error states
estimates them, and a Rauch-Tung-Striebel smoother carries the estimate back along the
approach in reverse time ("the final position is estimated by filtering the measurements
from the INS with the determined biases on the runway in reverse time").

Error model, per axis of the (locally level) runway frame, short-term (docs/conventions.md grades;
errors are INS-indicated minus true):

    horizontal (x along, y cross):   dp' = dv
                                     dv' = -g psi + b_a + w_a
                                     psi' = dv / R + b_g + w_g     (Schuler loop, omega^2 = g / R)
                                     b_a' = 0, b_g' = 0            (random constants)
    vertical (z):                    dh' = dvz
                                     dvz' = (2 g / R) dh + b_az + w_a   (the unstable vertical channel)
                                     b_az' = 0
                                     e_b' = -e_b / tau_b + w_b      (barometric altitude error, Gauss-Markov)

White-noise densities are one-sided PSDs S; the continuous model takes S / 2 (two-sided).
Measurements: baro every epoch, z_ins - z_baro = dh - e_b (+ white); radar altimeter
z_ins - h_RA = dh (sigma_RA); TVPS y_ins - y_TVPS = dy (sigma_TVPS); event at each runway
end, x_ins - x_end = dx (sigma = ground speed x the spread of the pilot's reaction; the
mean reaction is removed). The horizontal axes are independent of each other and of the
vertical in this model (level flight, small tilts), so three small filters run.
"""

from __future__ import annotations

import math

import numpy as np
from pydantic import Field

from aerotruth.analysis.kalman import Measurement, kalman_rts
from aerotruth.schema import Section
from aerotruth.sensors.air_data import BaroTemperature
from aerotruth.units import EARTH_RADIUS_M, G0

MICRO_G = 1e-6 * G0
DEG_PER_H = math.radians(1.0) / 3600.0


class AfisSpec(Section):
    """Navigation-grade INS, barometer and initial uncertainty (docs/conventions.md: ~25 ug, <= 0.01 deg/h)."""

    accel_bias_ug: float = Field(default=25.0, ge=0, description="accelerometer bias, 1 sigma")
    gyro_bias_deg_h: float = Field(default=0.01, ge=0, description="gyro bias, 1 sigma")
    accel_white_ug2_hz: float = Field(
        default=25.0, ge=0, description="accelerometer white noise, one-sided PSD (5 ug/sqrt(Hz))"
    )
    gyro_white_deg2_s2_hz: float = Field(
        default=1e-10, ge=0, description="gyro white noise, one-sided PSD ((deg/s)^2/Hz)"
    )
    initial_position_m: float = Field(default=30.0, gt=0, description="1 sigma at the start of the approach, per axis")
    initial_velocity_mps: float = Field(default=0.1, gt=0)
    initial_tilt_urad: float = Field(default=25.0, gt=0, description="levelling error ~ accel bias / g")
    baro_sigma_m: float = Field(default=3.0, gt=0, description="barometric altitude error (Gauss-Markov), 1 sigma")
    baro_tau_s: float = Field(default=600.0, gt=0)
    baro_white_m: float = Field(default=0.3, gt=0, description="baro reading noise per epoch")
    baro_temperature: BaroTemperature = Field(
        default="oat_corrected",
        description="the barometer's error from the truth atmosphere, referred to the threshold: "
        "uncorrected, corrected with the outside air temperature (the compensation assumed of an "
        "AFIS: the FITS paper does not say), or none (aerotruth.sensors.air_data.barometric_height_error)",
    )
    ra_sigma_m: float = Field(default=0.30 / 1.96, gt=0)
    tvps_sigma_m: float = Field(default=0.60 / 1.96, gt=0)
    event_sigma_s: float = Field(default=0.05, ge=0, description="spread of the pilot's reaction")


def horizontal_model(spec: AfisSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(F, G, Qc, P0) of one horizontal axis: state [dp, dv, psi, b_a, b_g]."""
    F = np.zeros((5, 5))
    F[0, 1] = 1.0
    F[1, 2], F[1, 3] = -G0, 1.0
    F[2, 1], F[2, 4] = 1.0 / EARTH_RADIUS_M, 1.0
    G = np.zeros((5, 2))
    G[1, 0] = G[2, 1] = 1.0
    Qc = np.diag([spec.accel_white_ug2_hz * MICRO_G**2 / 2, spec.gyro_white_deg2_s2_hz * math.radians(1.0) ** 2 / 2])
    P0 = np.diag(
        np.square(
            [
                spec.initial_position_m,
                spec.initial_velocity_mps,
                spec.initial_tilt_urad * 1e-6,
                spec.accel_bias_ug * MICRO_G,
                spec.gyro_bias_deg_h * DEG_PER_H,
            ]
        )
    )
    return F, G, Qc, P0


def vertical_model(spec: AfisSpec) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(F, G, Qc, P0) of the vertical channel: state [dh, dvz, b_az, e_baro]."""
    F = np.zeros((4, 4))
    F[0, 1] = 1.0
    F[1, 0], F[1, 2] = 2 * G0 / EARTH_RADIUS_M, 1.0
    F[3, 3] = -1.0 / spec.baro_tau_s
    G = np.zeros((4, 2))
    G[1, 0] = G[3, 1] = 1.0
    Qc = np.diag([spec.accel_white_ug2_hz * MICRO_G**2 / 2, 2 * spec.baro_sigma_m**2 / spec.baro_tau_s])
    P0 = np.diag(
        np.square([spec.initial_position_m, spec.initial_velocity_mps, spec.accel_bias_ug * MICRO_G, spec.baro_sigma_m])
    )
    return F, G, Qc, P0


def afis_trajectory(
    t_s,
    ins_xyz,
    baro_z,
    ra_z,
    tvps_y,
    events,
    ground_speed_mps,
    runway_length_m: float,
    spec: AfisSpec,
    *,
    smooth: bool = True,
    event_times_s=None,
) -> tuple[np.ndarray, np.ndarray]:
    """AFIS estimate of the trajectory (n, 3) and its 1-sigma (n, 3) at the epochs t_s.

    ins_xyz: INS-indicated runway-frame positions; baro_z: barometric height in the runway
    frame (its datum set to the runway elevation); ra_z, tvps_y: radar-altimeter height and
    TVPS cross-track (NaN where not measuring); events: 0/1 marks at the threshold and the
    stop end (first and second mark). `event_times_s` (optional): the crossing times of the
    two ends as the pilot's marks give them (press time minus the mean reaction); each is
    then used at the epoch nearest to it, the INS carried by the ground speed to the mark."""
    t = np.asarray(t_s, float)
    ins = np.asarray(ins_xyz, float)
    n = len(t)
    if ins.shape != (n, 3):
        raise ValueError(f"ins_xyz: expected shape ({n}, 3), got {ins.shape}")
    if np.any(np.diff(t) <= 0):
        raise ValueError("t_s: expected strictly increasing times")
    est, sig = np.empty_like(ins), np.empty_like(ins)

    # along-track: the event marks at the two runway ends
    ends = (0.0, runway_length_m)
    meas_x = {}
    if event_times_s is None:
        marks = np.flatnonzero(np.asarray(events) > 0)[:2]
        shift = np.zeros(len(marks))
    else:
        te = np.asarray(event_times_s, float)[:2]
        marks = np.clip(np.searchsorted(t, te), 0, n - 1)
        marks = np.where((marks > 0) & (np.abs(t[marks - 1] - te) < np.abs(t[marks] - te)), marks - 1, marks)
        shift = (t[marks] - te) * np.asarray(ground_speed_mps, float)[marks]  # the aircraft moved on since the mark
    for k, end, dx in zip(marks, ends, shift, strict=False):
        r = (float(ground_speed_mps[k]) * spec.event_sigma_s) ** 2 + 0.25**2  # plus the surveyed end's own 0.25 m
        meas_x[int(k)] = Measurement(np.array([ins[k, 0] - (end + dx)]), np.array([[1.0, 0, 0, 0, 0]]), np.array([[r]]))
    # cross-track: TVPS
    tv = np.asarray(tvps_y, float)
    meas_y = {
        int(k): Measurement(
            np.array([ins[k, 1] - tv[k]]), np.array([[1.0, 0, 0, 0, 0]]), np.array([[spec.tvps_sigma_m**2]])
        )
        for k in np.flatnonzero(np.isfinite(tv))
    }
    F, G, Qc, P0 = horizontal_model(spec)
    for axis, meas in ((0, meas_x), (1, meas_y)):
        xs, Ps = kalman_rts(t, F, G, Qc, np.zeros(5), P0, meas, smooth=smooth)
        est[:, axis] = ins[:, axis] - xs[:, 0]
        sig[:, axis] = np.sqrt(Ps[:, 0, 0])
    # vertical: baro every epoch, radar altimeter over the runway
    ra = np.asarray(ra_z, float)
    bz = np.asarray(baro_z, float)
    meas_z = {}
    for k in range(n):
        if np.isfinite(ra[k]):
            meas_z[k] = Measurement(
                np.array([ins[k, 2] - bz[k], ins[k, 2] - ra[k]]),
                np.array([[1.0, 0, 0, -1.0], [1.0, 0, 0, 0]]),
                np.diag([spec.baro_white_m**2, spec.ra_sigma_m**2]),
            )
        elif np.isfinite(bz[k]):
            meas_z[k] = Measurement(
                np.array([ins[k, 2] - bz[k]]), np.array([[1.0, 0, 0, -1.0]]), np.array([[spec.baro_white_m**2]])
            )
    F, G, Qc, P0 = vertical_model(spec)
    xs, Ps = kalman_rts(t, F, G, Qc, np.zeros(4), P0, meas_z, smooth=smooth)
    est[:, 2] = ins[:, 2] - xs[:, 0]
    sig[:, 2] = np.sqrt(Ps[:, 0, 0])
    return est, sig
