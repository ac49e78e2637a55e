"""The column contracts of the tables aerotruth reads and writes (docs/data-formats.md), in
one place: the readers check them, the writers follow them, `diagnose` recognises a file
by them. Names carry their units (`_kt`, `_ft`, `_m`, `_deg`, `_s`)."""

from __future__ import annotations

# TruthTrack (one flight or approach; aerotruth.truth.track): the recorded columns, then the
# leg and phase tags; runway-frame flights add x_m, y_m, z_m and the IMU columns
TRUTH_TRACK = (
    "time_s",
    "lat_deg",
    "lon_deg",
    "h_ellipsoid_m",
    "pressure_altitude_m",
    "vn_mps",
    "ve_mps",
    "vd_mps",
    "roll_rad",
    "pitch_rad",
    "heading_rad",
    "tas_mps",
    "cas_mps",
    "alpha_rad",
    "beta_rad",
    "p_radps",
    "q_radps",
    "r_radps",
    "wind_u_mps",
    "wind_v_mps",
    "wind_w_mps",
    "static_pressure_pa",
    "temperature_k",
    "leg_index",
    "phase",
)

# Observation table (the wind paper): one row per aircraft report and reference model
OBSERVATION_REQUIRED = (
    "aircraft",
    "time",
    "lat",
    "lon",
    "pressure_altitude_ft",
    "wind_speed_kt",
    "wind_dir_deg",
    "ref_wind_speed_kt",
    "ref_wind_dir_deg",
)
OBSERVATION_OPTIONAL_NUMERIC = ("tas_kt", "heading_deg", "heading_mag_deg", "declination_deg", "roll_deg")
# what the wind metrics need of it (no altitude: they score winds, not reports' levels)
OBSERVATION_WIND = tuple(c for c in OBSERVATION_REQUIRED if c != "pressure_altitude_ft")

# Approach log (the FITS paper): one row per epoch in the runway frame
APPROACH_LOG_REQUIRED = (
    "approach",
    "time_s",
    "waas_x_m",
    "waas_y_m",
    "waas_z_m",
    "ins_x_m",
    "ins_y_m",
    "ins_z_m",
    "ra_m",
    "tvps_y_m",
    "event",
    "sv_change",
    "iono_update",
)
APPROACH_LOG_DGPS = ("dgps_x_m", "dgps_y_m", "dgps_z_m")
APPROACH_LOG_OPTIONAL_NUMERIC = ("ra_lever_arm_m", "tvps_lever_arm_m")
# the order aerotruth writes (DGPS beside the other positions), and what identifies the kind
APPROACH_LOG_WRITTEN = APPROACH_LOG_REQUIRED[:8] + APPROACH_LOG_DGPS + APPROACH_LOG_REQUIRED[8:]
APPROACH_LOG_KEY = APPROACH_LOG_REQUIRED[:5]


def missing(columns, required: tuple[str, ...]) -> list[str]:
    """The names of `required` not among `columns`, in contract order."""
    have = set(columns)
    return [c for c in required if c not in have]
