"""TruthTrack: one flight (or approach) as a table of truth samples at a fixed rate, with
metadata, stored as Parquet. The contract is documented in docs/data-formats.md.

Columns (SI, angles in rad, positions WGS-84 geodetic with ellipsoidal height):
time_s, lat_deg, lon_deg, h_ellipsoid_m, pressure_altitude_m, vn_mps, ve_mps, vd_mps,
roll_rad, pitch_rad, heading_rad (true), tas_mps, cas_mps, alpha_rad, beta_rad,
p_radps, q_radps, r_radps, wind_u_mps, wind_v_mps, wind_w_mps (air motion towards
east/north/up, turbulence included), static_pressure_pa, temperature_k, leg_index, phase.
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from scipy.spatial.transform import Rotation

from aerotruth.contracts import TRUTH_TRACK
from aerotruth.units import KT, NM

COLUMNS = TRUTH_TRACK
PHASES = ("climb", "cruise", "descent", "approach")
# Stored as float64: time (50 Hz samples over hours need < 1 ms) and position (float32
# degrees are ~1 m coarse; float32 heights ~1 mm at 10 km, kept double with them; an
# approach's runway-frame x, y, z likewise). Every
# other column is stored as float32: its relative precision of 6e-8 is far below any
# sensor error modelled (0.01 kt, 1e-5 deg of attitude, 0.01 Pa).
FLOAT64_COLUMNS = ("time_s", "lat_deg", "lon_deg", "h_ellipsoid_m", "x_m", "y_m", "z_m")
_META_KEY = b"aerotruth"


def body_to_ned(df: pd.DataFrame) -> Rotation:
    """Attitude of each sample as a rotation body -> NED: R = Rz(psi) Ry(theta) Rx(phi)
    (intrinsic z-y'-x'' Euler angles, aerospace convention)."""
    return Rotation.from_euler("ZYX", df[["heading_rad", "pitch_rad", "roll_rad"]].to_numpy(dtype=float))


def air_velocity_ned(df: pd.DataFrame) -> np.ndarray:
    """Velocity of the aircraft relative to the air in NED (m/s), from TAS, alpha, beta and
    the attitude: v_body = V (cos a cos b, sin b, sin a cos b), v_ned = R_body->NED v_body."""
    v = df["tas_mps"].to_numpy(dtype=float)
    a, b = df["alpha_rad"].to_numpy(dtype=float), df["beta_rad"].to_numpy(dtype=float)
    vb = np.stack([v * np.cos(a) * np.cos(b), v * np.sin(b), v * np.sin(a) * np.cos(b)], axis=-1)
    return body_to_ned(df).apply(vb)


@dataclass
class TruthTrack:
    """A truth trajectory: `df` holds the samples, `meta` the flight's identity and targets
    (aircraft, route, seed, JSBSim version, config hash, waypoints, runways)."""

    df: pd.DataFrame
    meta: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        missing = [c for c in COLUMNS if c not in self.df.columns]
        if missing:
            raise ValueError(f"TruthTrack: missing columns {missing}")

    def __len__(self) -> int:
        return len(self.df)

    # --- storage -----------------------------------------------------------------
    def compact_frame(self) -> pd.DataFrame:
        """The samples as stored: float64 for FLOAT64_COLUMNS, float32 for other floats."""
        df = self.df.copy()
        for c in df.columns:
            if c not in FLOAT64_COLUMNS and df[c].dtype == np.float64:
                df[c] = df[c].astype(np.float32)
        return df

    def to_parquet(self, path: str | Path) -> None:
        """Write atomically (temp file + rename) in the compact storage form, with the
        metadata in the Parquet schema."""
        from aerotruth.files import atomic_write

        table = pa.Table.from_pandas(self.compact_frame(), preserve_index=False)
        schema_meta = dict(table.schema.metadata or {})
        schema_meta[_META_KEY] = json.dumps(self.meta, sort_keys=True).encode()
        table = table.replace_schema_metadata(schema_meta)
        floats = [c for c in table.column_names if pa.types.is_floating(table.schema.field(c).type)]
        # byte-stream-split + zstd without dictionaries: 2.0 MB per flight-hour at 10 Hz
        # (4.7 MB with pyarrow's defaults, whose dictionaries blow up on unique floats)
        atomic_write(
            path,
            lambda tmp: pq.write_table(
                table,
                tmp,
                compression="zstd",
                use_byte_stream_split=floats,
                use_dictionary=[c for c in table.column_names if c not in floats],
            ),
        )

    @classmethod
    def read_parquet(cls, path: str | Path) -> TruthTrack:
        table = pq.read_table(path)
        raw = (table.schema.metadata or {}).get(_META_KEY)
        if raw is None:
            raise ValueError(f"{path}: not a TruthTrack (no aerotruth metadata in the Parquet schema)")
        return cls(table.to_pandas(), json.loads(raw))

    # --- derived quantities --------------------------------------------------------
    def ground_velocity_ne(self) -> np.ndarray:
        return self.df[["vn_mps", "ve_mps"]].to_numpy()

    def wind_triangle_residual_mps(self) -> np.ndarray:
        """|V_G - V_A - V_W| in the horizontal at every sample (wind paper eq. 1 must close)."""
        va = air_velocity_ned(self.df)
        vg = self.ground_velocity_ne()
        wind = self.df[["wind_v_mps", "wind_u_mps"]].to_numpy()
        return np.hypot(*(vg - va[:, :2] - wind).T)

    def phase_mask(self, phase: str) -> np.ndarray:
        if phase not in PHASES:
            raise ValueError(f"phase: expected one of {PHASES}, got {phase!r}")
        return (self.df["phase"] == phase).to_numpy()

    def summary(self) -> dict[str, float]:
        """Leg metrics: cruise TAS error, cruise cross-track (from the route's legs, through
        its fly-by turns), arrival centreline offset, wind-triangle closure, duration and
        flown distance."""
        from aerotruth.truth.guidance import GreatCircleLeg

        df = self.df
        out: dict[str, float] = {
            "duration_s": float(df["time_s"].iloc[-1] - df["time_s"].iloc[0]),
            "wind_triangle_residual_max_kt": float(self.wind_triangle_residual_mps().max() / KT),
        }
        gs = np.asarray(np.hypot(df["vn_mps"], df["ve_mps"]))  # the Series' values, as .to_numpy() gave
        out["distance_nm"] = float(np.sum(gs[1:] * np.diff(df["time_s"].to_numpy())) / NM)
        cruise = self.phase_mask("cruise")
        target = self.meta.get("cruise_tas_kt")
        if cruise.any() and target is not None:
            out["cruise_tas_error_max_kt"] = float(np.max(np.abs(df["tas_mps"].to_numpy()[cruise] / KT - target)))
            legs = [GreatCircleLeg(**leg) for leg in self.meta["legs"]]
            xt = np.zeros(int(cruise.sum()))
            idx = df["leg_index"].to_numpy()[cruise]
            lat, lon = df["lat_deg"].to_numpy()[cruise], df["lon_deg"].to_numpy()[cruise]
            for i in np.unique(idx):
                sel = idx == i
                xt[sel] = np.abs(legs[int(i)].cross_track_m(lat[sel], lon[sel]))
                if i > 0:
                    # the route as flown through its fly-by turns: a turn starts on the
                    # previous leg's line, R tan(dpsi / 2) before the waypoint, where the
                    # guidance already steers by the next leg (for a 10-deg dogleg at 5 deg
                    # of bank and 250 kt, 290 m from that leg's line), so the distance is
                    # to the nearer of the two
                    prev = np.abs(legs[int(i) - 1].cross_track_m(lat[sel], lon[sel]))
                    xt[sel] = np.minimum(xt[sel], prev)
            out["cruise_xtrack_max_nm"] = float(np.max(xt) / NM)
        else:
            out["cruise_tas_error_max_kt"] = float("nan")
            out["cruise_xtrack_max_nm"] = float("nan")
        rwy = self.meta.get("arrival_runway")
        if rwy is not None:
            centre = GreatCircleLeg(
                "centreline", rwy["far_lat"], rwy["far_lon"], rwy["threshold_lat"], rwy["threshold_lon"]
            )
            out["arrival_centreline_offset_nm"] = float(
                abs(centre.cross_track_m(df["lat_deg"].iloc[-1], df["lon_deg"].iloc[-1])) / NM
            )
        return out
