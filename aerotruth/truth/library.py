"""The on-disk truth library: flown legs cached as TruthTrack Parquet files, keyed by a
digest of everything that determines them (leg plan, seed, aircraft and its XML,
autopilot XML, atmosphere spec, turbulence, aerotruth and JSBSim versions). A leg that
diverged is remembered too (reason and seed), so it is reported, not re-flown silently.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
from datetime import datetime, timezone
from pathlib import Path

import jsbsim

import aerotruth
from aerotruth.truth.airframes import SYSTEMS_DIR, Airframe, aircraft_root, airframe
from aerotruth.truth.flight import FlightDiverged, fly_leg, seed_repr
from aerotruth.truth.track import TruthTrack


def _file_digest(paths) -> str:
    h = hashlib.sha256()
    for p in sorted(Path(x) for x in paths):
        h.update(p.name.encode())
        h.update(p.read_bytes())
    return h.hexdigest()[:16]


def _plan_identity(plan) -> dict:
    return {
        "origin": plan.origin.icao, "destination": plan.destination.icao,
        "departure_runway": plan.departure_runway.ident, "arrival_runway": plan.arrival_runway.ident,
        "departure_utc": plan.departure_utc.astimezone(timezone.utc).isoformat(),
        "cruise_pressure_altitude_m": round(float(plan.cruise_pressure_altitude_m), 3),
        "waypoints": [(w.name, round(float(w.lat), 9), round(float(w.lon), 9)) for w in plan.waypoints],
        "initial_height_m": round(float(plan.initial_height_m), 3),
        "arrival_height_m": round(float(plan.arrival_height_m), 3),
    }


def truth_key(plan, *, seed, aircraft: str | Airframe | None = None, turbulence: bool = False,
              atmosphere_spec=None) -> str:
    """Stable digest (hashlib, not hash()) of all inputs that determine a leg's truth."""
    af = aircraft if isinstance(aircraft, Airframe) else airframe(aircraft)
    model_dir = aircraft_root(af) / af.model
    ident = {
        "plan": _plan_identity(plan),
        "seed": seed_repr(seed),
        "aircraft": dataclasses.asdict(af),
        "aircraft_xml": _file_digest(model_dir.glob("*.xml")),
        "systems_xml": _file_digest(SYSTEMS_DIR.glob("*.xml")),
        "turbulence": bool(turbulence),
        "atmosphere_spec": repr(atmosphere_spec),
        "aerotruth": aerotruth.__version__,
        "jsbsim": jsbsim.__version__,
    }
    return hashlib.sha256(json.dumps(ident, sort_keys=True, default=str).encode()).hexdigest()[:24]


class TruthLibrary:
    """Folder of cached truth legs. `get` returns the cached TruthTrack or flies it."""

    def __init__(self, root: str | Path):
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)

    def get(self, plan, *, seed, aircraft: str | Airframe | None = None, turbulence: bool = False) -> TruthTrack:
        key = truth_key(plan, seed=seed, aircraft=aircraft, turbulence=turbulence)
        path = self.root / f"{key}.parquet"
        failed = self.root / f"{key}.diverged.json"
        if path.exists():
            return TruthTrack.read_parquet(path)
        if failed.exists():
            info = json.loads(failed.read_text())
            raise FlightDiverged(info["reason"], info["seed"], info.get("time_s"))
        try:
            track = fly_leg(plan, seed=seed, aircraft=aircraft, turbulence=turbulence)
        except FlightDiverged as e:
            tmp = failed.with_name(failed.name + f".{os.getpid()}.tmp")
            tmp.write_text(json.dumps({"reason": e.reason, "seed": e.seed, "time_s": e.time_s}))
            os.replace(tmp, failed)
            raise
        track.meta["truth_key"] = key
        track.to_parquet(path)
        return track


def parse_departure(text: str) -> datetime:
    """`YYYY-MM-DD` (departure 13:00 UTC, a morning departure in the US Central zone) or an
    ISO-8601 date-time (UTC unless it carries an offset)."""
    try:
        if len(text) == 10:
            d = datetime.strptime(text, "%Y-%m-%d")
            return d.replace(hour=13, tzinfo=timezone.utc)
        d = datetime.fromisoformat(text)
    except ValueError:
        raise ValueError(f"--date: expected YYYY-MM-DD or an ISO-8601 date-time, got {text!r}") from None
    return d if d.tzinfo is not None else d.replace(tzinfo=timezone.utc)
