"""Mode-S as a sensor (docs/conventions.md, "Mode-S as a sensor"): what a ground receiver gets of an
aircraft's state through enhanced-surveillance registers and ADS-B.

Registers and their least significant bits (ICAO Doc 9871, the BDS 5,0 and 6,0 and ADS-B
airborne messages as decoded by open Mode-S decoders):

    BDS 5,0  roll 45/256 deg, true track 90/512 deg, ground speed 2 kt, track-angle rate
             8/256 deg/s, TAS 2 kt
    BDS 6,0  magnetic heading 90/512 deg, IAS 1 kt, Mach 2.048/512, barometric altitude
             rate 32 ft/min, inertial vertical velocity 32 ft/min
    ADS-B velocity (TC 19)  east and north velocity 1 kt, vertical rate 64 ft/min
    ADS-B position (TC 11)  barometric altitude 25 ft (the CPR position is kept to 1e-5 deg)

Sampling. The transponder refreshes each register from the avionics every `refresh_s`
(random phase per flight) and holds it; a Comm-B register is read out only when a ground
radar interrogates (reply bursts, a renewal process with intervals d + Exp(tau): several
radars' scans superposed, the dead time d standing for the regularity of a scan); ADS-B
squitters go out every U(0.4, 0.6) s (DO-260B). Each reply reaches the receiver with
probability `reception`. So BDS 5,0 and 6,0 are sampled at different instants and held:
in a turn at rate r their track and heading disagree by r times the age difference.

Magnetic heading: true heading (from the IRS) minus the variation of the aircraft's own
table (`variation_deg`, computed by the caller for the table's epoch; a stale table is a
real error), or a flux-valve system's magnetic heading given directly.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd
from pydantic import Field

from aerotruth.schema import Section

LSB = {
    "roll_deg": 45 / 256,
    "track_deg": 90 / 512,
    "groundspeed_kt": 2.0,
    "track_rate_deg_s": 8 / 256,
    "tas_kt": 2.0,
    "heading_mag_deg": 90 / 512,
    "ias_kt": 1.0,
    "mach": 2.048 / 512,
    "vrate_baro_fpm": 32.0,
    "vrate_inertial_fpm": 32.0,
    "v_east_kt": 1.0,
    "v_north_kt": 1.0,
    "vertical_rate_fpm": 64.0,
    "altitude_ft": 25.0,
    "lat": 1e-5,
    "lon": 1e-5,
}
REGISTERS = {
    "BDS50": ("roll_deg", "track_deg", "groundspeed_kt", "track_rate_deg_s", "tas_kt"),
    "BDS60": ("heading_mag_deg", "ias_kt", "mach", "vrate_baro_fpm", "vrate_inertial_fpm"),
    "velocity": ("v_east_kt", "v_north_kt", "vertical_rate_fpm"),
    "position": ("lat", "lon", "altitude_ft"),
}
ANGLES = ("track_deg", "heading_mag_deg")  # wrap to [0, 360)


class ReplyProcess(Section):
    """Reply times of one register: Comm-B bursts d + Exp(tau), or ADS-B squitters U(lo, hi)."""

    kind: str = Field(default="interrogated", pattern="^(interrogated|squitter)$")
    dead_time_s: float = Field(default=0.17, ge=0, description="interrogated: shortest interval between bursts")
    mean_excess_s: float = Field(default=0.55, gt=0, description="interrogated: mean of the exponential part")
    squitter_s: tuple[float, float] = Field(
        default=(0.4, 0.6), description="squitter: broadcast interval range (DO-260B)"
    )
    reception: float = Field(default=0.9, gt=0, le=1, description="probability that a reply reaches the receiver")
    refresh_s: float = Field(
        default=0.1,
        gt=0,
        description="register refresh from the avionics: as the ARINC 429 "
        "words arrive, about every 0.1 s (Doc 9871 allows up to 1.3 s; the raw CDG flight rejects "
        "1 s: BDS 6,0 new payloads come at p25 0.43 s)",
    )

    def times(self, t0: float, t1: float, rng: np.random.Generator) -> np.ndarray:
        """Received reply times in [t0, t1): a renewal process started at a random phase."""
        if self.kind == "squitter" and not 0 < self.squitter_s[0] <= self.squitter_s[1]:
            raise ValueError(f"squitter_s: expected 0 < low <= high, got {self.squitter_s}")
        mean_gap = (
            self.dead_time_s + self.mean_excess_s if self.kind == "interrogated" else float(np.mean(self.squitter_s))
        )
        n = int((t1 - t0) / mean_gap) + 16
        chunks, last = [], t0 + rng.uniform(0, mean_gap)
        chunks.append(np.array([last]))
        while last < t1:
            if self.kind == "interrogated":
                gaps = self.dead_time_s + rng.exponential(self.mean_excess_s, n)
            else:
                gaps = rng.uniform(*self.squitter_s, n)
            ts = last + np.cumsum(gaps)
            chunks.append(ts)
            last = ts[-1]
        times = np.concatenate(chunks)
        times = times[times < t1]
        return times[rng.random(len(times)) < self.reception]


class ModeSSpec(Section):
    """The Mode-S sensor: reply processes per register. Defaults: the ground environment of
    the raw Paris-CDG flight in ../shared/real-data, fitted on its reply times alone by
    `fit_reply_process` (Comm-B bursts; ADS-B reception)."""

    bds50: ReplyProcess = ReplyProcess(dead_time_s=0.131, mean_excess_s=1.077, reception=1.0)
    bds60: ReplyProcess = ReplyProcess(dead_time_s=0.169, mean_excess_s=0.544, reception=1.0)
    velocity: ReplyProcess = ReplyProcess(kind="squitter", reception=0.77)
    position: ReplyProcess = ReplyProcess(kind="squitter", reception=0.77)
    noise: dict[str, float] = Field(
        default_factory=lambda: {"vertical_rate_fpm": 17.0},
        description="white noise of the avionics source per refresh, by field (1 sigma, field units); "
        "vertical rate: 17 ft/min from successive ADS-B reports of the CDG flight in level flight",
    )


@dataclass(frozen=True)
class ModeSSensor:
    """A Mode-S sensor of one flight."""

    spec: ModeSSpec

    def apply(self, avionics: pd.DataFrame, rng: np.random.Generator) -> pd.DataFrame:
        """Messages a receiver gets: one row per reply (time_s, register, that register's
        fields quantized to their LSBs, NaN for the other registers' fields), sorted by
        time. `avionics` holds time_s and the fields of LSB (what the aircraft's systems
        feed the transponder) at a rate well above the refresh."""
        t = avionics["time_s"].to_numpy(float)
        if np.any(np.diff(t) <= 0):
            raise ValueError("avionics.time_s: expected strictly increasing times")
        frames = []
        for name, fields in REGISTERS.items():
            missing = [f for f in fields if f not in avionics]
            if missing:
                raise ValueError(f"avionics: missing column {missing[0]!r} for register {name}")
            proc: ReplyProcess = getattr(self.spec, name.lower() if name.startswith("BDS") else name)
            replies = proc.times(t[0], t[-1], rng)
            # content = avionics value at the last refresh before the reply (held)
            phase = rng.uniform(0, proc.refresh_s)
            refreshed = t[0] + phase + np.floor((replies - t[0] - phase) / proc.refresh_s) * proc.refresh_s
            refreshed = np.maximum(refreshed, t[0])
            idx = np.clip(np.searchsorted(t, refreshed, side="right") - 1, 0, len(t) - 1)
            slot = np.round((refreshed - t[0] - phase) / proc.refresh_s).astype(np.int64)
            row = {"time_s": replies, "register": name, "sampled_at_s": t[idx]}
            for f in fields:
                v = avionics[f].to_numpy(float)[idx]
                sigma = self.spec.noise.get(f, 0.0)
                if sigma:  # one draw per refresh: replies from the same register content agree
                    v = v + sigma * rng.standard_normal(int(slot.max()) + 1 if len(slot) else 0)[slot]
                q = np.round(v / LSB[f]) * LSB[f]
                row[f] = np.mod(q, 360.0) if f in ANGLES else q
            frames.append(pd.DataFrame(row))
        return (
            pd.concat(frames, ignore_index=True)
            .sort_values(["time_s", "register"], kind="stable")
            .reset_index(drop=True)
        )


def unique_payload_intervals(messages: pd.DataFrame, register: str) -> np.ndarray:
    """Intervals between the first appearances of distinct payloads of a register (how
    often a receiver learns something new from it)."""
    fields = list(REGISTERS[register])
    m = messages[messages["register"] == register].sort_values("time_s")
    first = m.drop_duplicates(fields)["time_s"].to_numpy()
    return np.diff(first)


def held_track(messages: pd.DataFrame, rate_hz: float = 1.0) -> pd.DataFrame:
    """The messages as a regular track: every field held from its last reply (what a
    1-s resampling of Mode-S data gives, as in the A310 sample file)."""
    t0, t1 = messages["time_s"].min(), messages["time_s"].max()
    grid = np.arange(np.ceil(t0 * rate_hz), np.floor(t1 * rate_hz) + 1) / rate_hz
    out = pd.DataFrame({"time_s": grid})
    for name, fields in REGISTERS.items():
        m = messages[messages["register"] == name].sort_values("time_s")
        idx = np.searchsorted(m["time_s"].to_numpy(), grid, side="right") - 1
        ok = idx >= 0
        for f in fields:
            col = np.full(len(grid), np.nan)
            col[ok] = m[f].to_numpy()[idx[ok]]
            out[f] = col
    return out


BURST_GAP_S = 0.15  # replies closer than this belong to one interrogation burst (one radar dwell)


def fit_reply_process(times_s: np.ndarray, kind: str, refresh_s: float = 0.1) -> ReplyProcess:
    """A reply process from received reply times alone (not payloads). Interrogated:
    bursts are replies within BURST_GAP_S; the burst intervals' 25th and 50th percentiles
    give the shifted exponential d + Exp(tau) (p_q = d + tau ln(1 / (1 - q))). Squitter:
    the reception probability is the share of intervals of one broadcast period
    (0.38-0.62 s), which is p for independent losses."""
    t = np.sort(np.asarray(times_s, float))
    d = np.diff(t)
    if kind == "squitter":
        return ReplyProcess(kind="squitter", reception=float(np.mean((d >= 0.38) & (d <= 0.62))), refresh_s=refresh_s)
    bursts = np.diff(t[np.r_[True, d > BURST_GAP_S]])
    p25, p50 = np.percentile(bursts, [25, 50])
    tau = (p50 - p25) / (np.log(2.0) - np.log(4.0 / 3.0))
    return ReplyProcess(
        dead_time_s=float(max(p25 - tau * np.log(4.0 / 3.0), 0.0)),
        mean_excess_s=float(tau),
        reception=1.0,
        refresh_s=refresh_s,
    )


RAW_FIELDS = {  # avionics field <- (register selector (df set, bds), decoded column)
    "roll_deg": (("20", "21"), "50", "roll"),
    "track_deg": (("20", "21"), "50", "track"),
    "groundspeed_kt": (("20", "21"), "50", "groundspeed"),
    "track_rate_deg_s": (("20", "21"), "50", "track_rate"),
    "tas_kt": (("20", "21"), "50", "TAS"),
    "heading_mag_deg": (("20", "21"), "60", "heading"),
    "ias_kt": (("20", "21"), "60", "IAS"),
    "mach": (("20", "21"), "60", "Mach"),
    "vrate_baro_fpm": (("20", "21"), "60", "vrate_barometric"),
    "vrate_inertial_fpm": (("20", "21"), "60", "vrate_inertial"),
    "vertical_rate_fpm": (("17",), "09", "vertical_rate"),
    "altitude_ft": (("17",), "05", "altitude"),
    "lat": (("17",), "05", "latitude"),
    "lon": (("17",), "05", "longitude"),
}


def register_times(raw: pd.DataFrame, register: str) -> np.ndarray:
    """Reply times of a register in a raw decoded message log (DF20 and DF21 together for Comm-B)."""
    sel = {
        "BDS50": (("20", "21"), "50"),
        "BDS60": (("20", "21"), "60"),
        "velocity": (("17",), "09"),
        "position": (("17",), "05"),
    }[register]
    return raw.loc[raw["df"].astype(str).isin(sel[0]) & (raw["bds"] == sel[1]), "time_s"].sort_values().to_numpy()


def avionics_from_raw(raw: pd.DataFrame, dt: float = 0.05, hold: bool = False) -> pd.DataFrame:
    """The flight's own decoded values on a dt grid: the trajectory a Mode-S sensor is run
    on to simulate a real flight (there is no aircraft model to fly it). Linear in time
    between replies (angles unwrapped), or with `hold` each value held until the next
    reply. Measured on the CDG flight: linear gives new-payload intervals within 20 % of
    the real ones except the BDS 5,0 median (12-17 % short: interpolation makes
    intermediate values the aircraft never sent); hold gives intervals 30-90 % too long
    (the simulated replies miss most of the real changes). Velocity components come from
    ADS-B ground speed and track."""
    t = raw["time_s"].to_numpy(float)
    grid = np.arange(t.min(), t.max(), dt)
    out = pd.DataFrame({"time_s": grid})

    def series(dfs, bds, col):
        s = raw[raw["df"].astype(str).isin(dfs) & (raw["bds"] == bds)].dropna(subset=[col]).sort_values("time_s")
        return s["time_s"].to_numpy(float), s[col].to_numpy(float)

    for field, (dfs, bds, col) in RAW_FIELDS.items():
        ts, v = series(dfs, bds, col)
        if field in ANGLES:
            v = np.degrees(np.unwrap(np.radians(v)))
        out[field] = _resample(grid, ts, v, hold)
    ts, gs = series(("17",), "09", "groundspeed")
    _, trk = series(("17",), "09", "track")
    trk = np.unwrap(np.radians(trk))
    out["v_east_kt"] = _resample(grid, ts, gs * np.sin(trk), hold)
    out["v_north_kt"] = _resample(grid, ts, gs * np.cos(trk), hold)
    return out


def _resample(grid: np.ndarray, ts: np.ndarray, v: np.ndarray, hold: bool) -> np.ndarray:
    if not hold:
        return np.interp(grid, ts, v)
    return v[np.clip(np.searchsorted(ts, grid, side="right") - 1, 0, len(v) - 1)]


def avionics_from_truth(df: pd.DataFrame, variation_deg) -> pd.DataFrame:
    """What the aircraft's systems feed the transponder, from a TruthTrack's samples:
    the IRS's true heading turned magnetic with the aircraft's own variation table
    (`variation_deg`, east positive, per sample or one value: the table's epoch is the
    caller's choice), air data from the truth, GNSS/IRS velocities."""
    from aerotruth.units import FT, KT

    t = df["time_s"].to_numpy(float)
    vn, ve, vd = (df[c].to_numpy(float) for c in ("vn_mps", "ve_mps", "vd_mps"))
    track = np.degrees(np.arctan2(ve, vn))
    heading = np.degrees(df["heading_rad"].to_numpy(float))
    palt = df["pressure_altitude_m"].to_numpy(float)
    return pd.DataFrame(
        {
            "time_s": t,
            "roll_deg": np.degrees(df["roll_rad"].to_numpy(float)),
            "track_deg": track % 360,
            "groundspeed_kt": np.hypot(vn, ve) / KT,
            "track_rate_deg_s": np.gradient(np.degrees(np.unwrap(np.radians(track))), t),
            "tas_kt": df["tas_mps"].to_numpy(float) / KT,
            "heading_mag_deg": (heading - np.asarray(variation_deg, float)) % 360,
            "ias_kt": df["cas_mps"].to_numpy(float) / KT,
            # speed of sound sqrt(gamma R T), gamma 1.4, R 287.05287 J/(kg K) (ICAO Doc 7488)
            "mach": df["tas_mps"].to_numpy(float) / np.sqrt(1.4 * 287.05287 * df["temperature_k"].to_numpy(float)),
            "vrate_baro_fpm": np.gradient(palt, t) / FT * 60.0,
            "vrate_inertial_fpm": -vd / FT * 60.0,
            "v_east_kt": ve / KT,
            "v_north_kt": vn / KT,
            "vertical_rate_fpm": -vd / FT * 60.0,
            "altitude_ft": palt / FT,
            "lat": df["lat_deg"].to_numpy(float),
            "lon": df["lon_deg"].to_numpy(float),
        }
    )


def decoded_track(messages: pd.DataFrame, start_epoch_s: float, rate_hz: float = 1.0) -> pd.DataFrame:
    """The messages as a 1-s trajectory with the column names of decoded Mode-S data
    (`timestamp` in ms, heading magnetic from BDS 6,0, TAS from BDS 5,0, track and ground
    speed from ADS-B velocity), as the A310 sample file holds them: what `diagnose` and
    `aerotruth.measured.kinds` take as a Mode-S trajectory."""
    h = held_track(messages, rate_hz).dropna()
    return pd.DataFrame(
        {
            "timestamp": (start_epoch_s + h["time_s"]) * 1000.0,
            "latitude": h["lat"],
            "longitude": h["lon"],
            "altitude": h["altitude_ft"],
            "heading": h["heading_mag_deg"],
            "TAS": h["tas_kt"],
            "track": np.degrees(np.arctan2(h["v_east_kt"], h["v_north_kt"])) % 360,
            "groundspeed": np.hypot(h["v_east_kt"], h["v_north_kt"]),
            "vertical_rate": h["vertical_rate_fpm"],
            "roll": h["roll_deg"],
            "IAS": h["ias_kt"],
            "Mach": h["mach"],
        }
    ).reset_index(drop=True)
