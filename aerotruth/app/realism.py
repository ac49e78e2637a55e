"""`aerotruth realism`: the truth beside real flights, like with like.

The simulated side: route legs and ILS approaches flown by the truth (from the truth store,
flown once), each passed through the Mode-S sensor (aerotruth.sensors.modes: the registers'
sampling, holding and least significant bits, ADS-B reception) and decoded to a 1-s
trajectory as a receiver's would be. The real side: measured files as aerotruth reads them
(aerotruth.measured: Mode-S/ADS-B trajectories, raw Mode-S messages, recorder extracts,
multi-aircraft traffic). Both go through aerotruth.analysis.realism; every statistic is
printed as `label: value` lines (p5/p50/p95 of each side, Wasserstein-1 distance, KS
statistic) and, with --figures, drawn as the two distributions.
"""

from __future__ import annotations

import argparse
import datetime as dt
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth import seeds
from aerotruth.analysis import realism
from aerotruth.errors import DataError

# Routes of the three networks (upper Midwest, Alaska, east coast) and the approaches of the
# issue that asked for this study (a turn onto final at KBUF).
ROUTES = (
    ("KMSP", "KDLH"),
    ("KMSP", "KFAR"),
    ("KDCA", "KRDU"),
    ("PANC", "PAKN"),
    ("KDLH", "KMSP"),
    ("KRDU", "KDCA"),
    ("KMSP", "KGRB"),
    ("KIND", "KORD"),
)
APPROACHES = (
    ("KDLH", "27", 0.0, 0.0),
    ("KMSP", "30L", 0.0, 0.0),
    ("PANC", "07R", 0.0, 0.0),
    ("KBUF", "23", 2.0, 30.0),
    ("KRST", "31", 0.0, 0.0),
    ("KCMH", "28L", -1.5, 25.0),
)
DATES = (dt.date(2009, 8, 15), dt.date(2010, 1, 20), dt.date(2009, 10, 5), dt.date(2010, 4, 12))
STUDY_SEED = 48  # the study's own streams: ("realism", ...) children of it


@dataclass
class Side:
    """One side of the comparison: its trajectories' samples and what was left out."""

    samples: list[dict[str, np.ndarray]]
    notes: list[str]

    def pooled(self) -> dict[str, np.ndarray]:
        return realism.pooled(self.samples)


# source column -> trajectory column, per source: a decoded Mode-S track or measured state
# table (aerotruth.measured.kinds), and the canonical traffic table (aerotruth.measured.traffic)
MEASURED_COLUMNS = {
    "altitude": "altitude_ft",
    "groundspeed": "groundspeed_kt",
    "track": "track_deg",
    "latitude": "latitude",
    "longitude": "longitude",
    "roll": "roll_deg",
}
TRAFFIC_COLUMNS = {
    "pressure_altitude_ft": "altitude_ft",
    "gs_kt": "groundspeed_kt",
    "track_deg": "track_deg",
    "lat": "latitude",
    "lon": "longitude",
    "roll_deg": "roll_deg",
}


def _trajectory(t: np.ndarray, frame: pd.DataFrame, columns: dict[str, str]) -> pd.DataFrame:
    """The trajectory aerotruth.analysis.realism reads: times `t` and the frame's columns
    renamed by `columns` (the first three required, the others where present)."""
    out = pd.DataFrame({"time_s": t})
    for i, (src, dst) in enumerate(columns.items()):
        if i < 3 or src in frame:
            out[dst] = pd.to_numeric(frame[src], errors="coerce").to_numpy(float)
    out["track_deg"] %= 360.0
    return out


def measured_trajectory(track: pd.DataFrame) -> pd.DataFrame:
    """A decoded Mode-S track (aerotruth.sensors.modes.decoded_track's columns) or a
    measured state table (time_s, altitude, groundspeed, track, latitude, longitude, roll)
    as the trajectory aerotruth.analysis.realism reads."""
    t = track["time_s"].to_numpy(float) if "time_s" in track else track["timestamp"].to_numpy(float) / 1000.0
    return _trajectory(t, track, MEASURED_COLUMNS)


def _modes_trajectory(truth_df: pd.DataFrame, rng: np.random.Generator, every: int) -> pd.DataFrame:
    from aerotruth.sensors.modes import ModeSSensor, ModeSSpec, avionics_from_truth, decoded_track

    av = avionics_from_truth(truth_df.iloc[::every].reset_index(drop=True), 0.0)
    msgs = ModeSSensor(ModeSSpec()).apply(av, rng)
    return measured_trajectory(decoded_track(msgs, 0.0))


def simulated_side(n_legs: int, n_approaches: int, turbulence: bool, store_root: str | None = None) -> Side:
    """Route legs and approaches from the truth store (flown if missing), through Mode-S."""
    from aerotruth.truth.approach import PlannedApproach, approach_spec
    from aerotruth.truth.days import PlannedLeg, on_airway, plan_in_weather
    from aerotruth.truth.store import TruthStore
    from aerotruth.truth.weather import region_for_airport

    store = TruthStore(store_root)
    samples, notes = [], []
    root = seeds.named_sequence(STUDY_SEED, "realism")
    for i in range(n_legs):
        org, dst = ROUTES[i % len(ROUTES)]
        day = DATES[(i // len(ROUTES)) % len(DATES)]
        region = region_for_airport(org)
        weather_seed = seeds.int_seed(seeds.child(root, "weather", day.isoformat()))
        flight_seed = seeds.int_seed(seeds.child(root, "flight", i))
        dep = dt.datetime.combine(day, dt.time(14, 0), tzinfo=dt.UTC)
        plan = plan_in_weather(
            org,
            dst,
            dep,
            weather_seed=weather_seed,
            region=region,
            rng=seeds.generator(seeds.child(root, "plan", i)),
            flight_id=f"realism-{i}",
        )
        leg = PlannedLeg(on_airway(plan, flight_seed), region, weather_seed, flight_seed)
        out = store.leg(leg, turbulence=turbulence)
        if out.track is None:
            notes.append(f"leg {org}-{dst} {day}: diverged ({out.diverged})")
            continue
        traj = _modes_trajectory(out.track.df, seeds.generator(seeds.child(root, "modes", "leg", i)), 1)
        leg_samples = realism.profile_samples(traj, f"leg {org}-{dst}")
        # a route leg ends on final 2,000 ft above the runway, not at it: its last descent is
        # no approach (the approaches are flown for that)
        for k in realism.SAMPLE_KEYS:
            if k.startswith("approach_"):
                leg_samples[k] = np.empty(0)
        samples.append(leg_samples)
    for i in range(n_approaches):
        icao, rwy, offset, intercept = APPROACHES[i % len(APPROACHES)]
        day = DATES[(i // len(APPROACHES)) % len(DATES)]
        region = region_for_airport(icao)
        spec = approach_spec(icao, rwy, day, turbulence=turbulence, offset_nm=offset, intercept_deg=intercept)
        planned = PlannedApproach(
            spec,
            seeds.int_seed(seeds.child(root, "weather", day.isoformat())),
            seeds.int_seed(seeds.child(root, "approach", i)),
            region,
        )
        flown = store.approach(planned)
        if flown.track is None:
            notes.append(f"approach {icao} {rwy} {day}: diverged ({flown.diverged})")
            continue
        traj = _modes_trajectory(flown.track.df, seeds.generator(seeds.child(root, "modes", "approach", i)), 5)
        samples.append(realism.profile_samples(traj, f"approach {icao} {rwy}"))
    return Side(samples, notes)


def real_trajectories(path: Path) -> list[tuple[str, pd.DataFrame]]:
    """The trajectories of one measured file: (label, trajectory) per aircraft and flight.
    DataError naming the file for a file that holds no trajectory."""
    from aerotruth.measured.kinds import load_measured

    try:
        m = load_measured(path)
    except DataError as e:  # several aircraft, or a traffic format of its own: the traffic reader's
        try:
            return _traffic_trajectories(path)
        except DataError:
            raise e from None
    df = m.df
    if m.kind == "modes_raw":
        return [(path.name, _raw_trajectory(df, path))]
    if m.kind in ("modes_track", "adsb_track", "qar"):
        need = ("altitude", "groundspeed", "track")
        missing = [c for c in need if c not in df]
        if missing:
            raise DataError(f"{path}: a {m.kind} without {', '.join(missing)}: no flight profile to compare")
        return [(path.name, measured_trajectory(df))]
    raise DataError(
        f"{path}: a {m.kind} holds no trajectory (expected Mode-S/ADS-B tracks, messages or a recorder extract)"
    )


def _traffic_trajectories(path: Path) -> list[tuple[str, pd.DataFrame]]:
    from aerotruth.measured.traffic import read_traffic

    tr = read_traffic(path)  # the canonical traffic table (aerotruth.measured.traffic)
    keys = [k for k in ("aircraft", "flight") if k in tr]
    out = []
    for name, g in tr.groupby(keys, sort=True):
        if len(g) < 60:
            continue
        g = g.sort_values("time_s")
        traj = _trajectory(g["time_s"].to_numpy(float), g, TRAFFIC_COLUMNS)
        label = ":".join(str(v) for v in (name if isinstance(name, tuple) else (name,)))
        out.append((f"{path.name}:{label}", traj))
    if not out:
        raise DataError(f"{path}: no aircraft with 60 or more states: no flight profile to compare")
    return out


def _raw_trajectory(df: pd.DataFrame, path: Path) -> pd.DataFrame:
    """Raw decoded messages: positions and altitude from ADS-B airborne position (BDS 0,5),
    ground speed and track from airborne velocity (BDS 0,9) interpolated to the position
    times, roll from BDS 5,0 held at most 10 s."""
    bds = df["bds"].astype(str) if "bds" in df else pd.Series("", index=df.index)
    pos = df[(bds == "05")].dropna(subset=["latitude", "longitude", "altitude"]).sort_values("time_s")
    vel = df[(bds == "09")].dropna(subset=["groundspeed", "track"]).sort_values("time_s")
    if len(pos) < 10 or len(vel) < 10:
        raise DataError(
            f"{path}: too few ADS-B position ({len(pos)}) or velocity ({len(vel)}) messages for a trajectory"
        )
    t = pos["time_s"].to_numpy(float)
    vt = vel["time_s"].to_numpy(float)
    out = pd.DataFrame(
        {
            "time_s": t,
            "latitude": pos["latitude"].to_numpy(float),
            "longitude": pos["longitude"].to_numpy(float),
            "altitude_ft": pos["altitude"].to_numpy(float),
            "groundspeed_kt": np.interp(t, vt, vel["groundspeed"].to_numpy(float)),
            "track_deg": np.degrees(np.interp(t, vt, np.unwrap(np.radians(vel["track"].to_numpy(float))))) % 360.0,
        }
    )
    b50 = df[(bds == "50")].dropna(subset=["roll"]).sort_values("time_s") if "roll" in df else df.iloc[:0]
    if len(b50):
        rt = b50["time_s"].to_numpy(float)
        idx = np.clip(np.searchsorted(rt, t, side="right") - 1, 0, len(rt) - 1)
        roll = b50["roll"].to_numpy(float)[idx]
        out["roll_deg"] = np.where((t >= rt[idx]) & (t - rt[idx] <= 10.0), roll, np.nan)
    return out


def real_side(paths: list[Path]) -> Side:
    """Every trajectory of the files, its track checked against its positions: a track
    column that is not the track the positions fly (the calibration samples' track is
    stored in one byte: off by ~100 deg over half the compass) is replaced by the
    positions' track, and said."""
    samples, notes = [], []
    for p in paths:
        for label, measured in real_trajectories(p):
            traj, off = realism.with_position_track(measured)
            if traj is not measured:
                notes.append(f"{label}: track column {off:.0f} deg (median) from the positions' track; positions used")
            samples.append(realism.profile_samples(traj, label))
    return Side(samples, notes)


def default_real_files() -> list[Path]:
    """Every measured flight in the documented real-data folder (README excluded)."""
    from aerotruth.measured.kinds import real_data_dir

    root = real_data_dir()
    if not root.is_dir():
        return []
    return sorted(p for p in root.rglob("*.gz") if p.is_file())


def _fmt(x: float) -> str:
    return "nan" if not math.isfinite(x) else f"{x:.3f}"


def report_lines(sim: Side, real: Side) -> list[str]:
    """The `label: value` lines of the comparison."""
    s, r = sim.pooled(), real.pooled()
    lines = [f"sim_trajectories: {len(sim.samples)}", f"real_trajectories: {len(real.samples)}"]
    for k in realism.SAMPLE_KEYS:
        if k == "climb_fpm_altitude_ft":
            continue
        c = realism.compare(k, s[k], r[k])
        lines += [
            f"{k}.n_sim: {c.n_sim}",
            f"{k}.n_real: {c.n_real}",
            f"{k}.sim_p5_p50_p95: {' '.join(_fmt(v) for v in c.sim)}",
            f"{k}.real_p5_p50_p95: {' '.join(_fmt(v) for v in c.real)}",
            f"{k}.wasserstein: {_fmt(c.wasserstein)}",
            f"{k}.ks: {_fmt(c.ks)}",
        ]
    for name, side in (("sim", s), ("real", r)):
        slope = realism.climb_slope_fpm_per_kft(side["climb_fpm"], side["climb_fpm_altitude_ft"])
        lines.append(f"climb_slope_fpm_per_kft.{name}: {_fmt(slope)}")
    return lines


def draw(sim: Side, real: Side, out_dir: Path) -> list[Path]:
    """One figure: the empirical distribution functions of every statistic, simulated
    beside real."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    s, r = sim.pooled(), real.pooled()
    keys = [k for k in realism.SAMPLE_KEYS if k != "climb_fpm_altitude_ft"]
    ncol = 4
    nrow = math.ceil(len(keys) / ncol)
    fig, axes = plt.subplots(nrow, ncol, figsize=(4.0 * ncol, 3.0 * nrow))
    for ax, k in zip(axes.ravel(), keys, strict=False):
        for name, side, style in (("simulated", s, "-"), ("real", r, "--")):
            x = np.sort(side[k][np.isfinite(side[k])])
            if len(x):
                ax.step(x, np.arange(1, len(x) + 1) / len(x), style, where="post", label=f"{name} (n={len(x)})")
        ax.set_title(k, fontsize=9)
        ax.set_ylabel("share")
        ax.legend(fontsize=7)
    for ax in axes.ravel()[len(keys) :]:
        ax.set_visible(False)
    fig.suptitle("truth realism: simulated (through Mode-S) vs real")
    fig.tight_layout()
    out_dir.mkdir(parents=True, exist_ok=True)
    path = out_dir / "truth_realism.png"
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return [path]


def realism_cli(args: argparse.Namespace) -> int:
    paths = [Path(p) for p in args.real] if args.real else default_real_files()
    if not paths:
        from aerotruth.measured.kinds import real_data_dir

        raise DataError(
            f"no measured flights: give files, or put them in the real-data folder ({real_data_dir()}; "
            "$AEROTRUTH_REAL_DATA sets it)"
        )
    missing = [p for p in paths if not p.is_file()]
    if missing:
        raise DataError(f"{missing[0]}: no such file (expected a measured flight file)")
    real = real_side(paths)
    sim = simulated_side(args.legs, args.approaches, args.turbulence, args.store)
    for line in report_lines(sim, real):
        print(line)
    for n in real.notes + sim.notes:
        print(f"note: {n}")
    if args.figures:
        for p in draw(sim, real, Path(args.figures)):
            print(f"figure: {p}")
    return 0
