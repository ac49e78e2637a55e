"""The truth store: flown legs cached on disk as TruthTrack Parquet files and shared by
every study, run and campaign on the machine. A leg is flown only when missing.

Key: sha256 of everything that changes a flight — the leg plan (airports, runways,
waypoints, departure time, cruise level, heights), the flight seed, the aircraft (its
dataclass), turbulence, the atmosphere (date, weather seed, region), and a digest of
the truth code and data it runs on (aerotruth.truth modules, aircraft and autopilot XML,
airport table) with the JSBSim/NumPy/... versions (aerotruth.digests). Editing any of
them re-flies; changing a sensor never does.

Approaches (aerotruth.truth.approach.PlannedApproach) are stored the same way under
keys starting with "a": spec, seeds, region, aircraft and the same code digest.

Layout: ROOT/<key[:2]>/<key>.parquet, ROOT/<key[:2]>/<key>.diverged.json for a leg that
diverged (reason and seed: reported again, not re-flown silently), <key>.lock (held while
the leg is looked up or flown, so concurrent workers fly it once), ROOT/flown.log (one
line per leg flown: key, flight id, seconds; every process's, so a run counts its own
flights by `flown_here` of the instances it used). Storage is compact
(TruthTrack.to_parquet: float64 only for time and position, float32 for the rest, zstd).
A size cap is kept by `evict`, least recently used first (a read touches the file).

Locking: readers, writers and `evict` all take a key's lock (`locked`) before touching its
files. `evict` never waits for one and never removes a flight or a lock file another process
holds (that flight is in use); it removes a lock file only while holding it, and whoever
then obtains the lock of the removed file sees that it is no longer the key's lock file and
locks the new one, so two processes never hold one key's lock at once. flown.log is
appended under its own lock (flown.log.lock): an append is atomic between the processes of
one machine, not between NFS clients, which compute the end of the file themselves.

On a shared filesystem (workers on several machines, one store): the locks are flock(2)
locks on the lock files. Linux NFS clients (since 2.6.12) carry flock as a whole-file POSIX
lock through the server (NFSv4 state, NFSv3 lockd), so it holds between machines; a lock of
a machine that dies is freed when its lease or lockd state expires (NFSv4: ~90 s). Lustre
holds flock between clients only when mounted with `-o flock`; with `localflock` a lock
holds on one client only (two machines can fly one leg at once: the files stay whole, since
every write is a rename of a finished file, but the leg is flown twice and flown.log says
so), and with `noflock` flock fails: the store then stops with one line naming the lock file
(`StoreLockError`), never proceeding unlocked. Renames within one folder are atomic on both.
"""

from __future__ import annotations

import dataclasses
import fcntl
import hashlib
import json
import os
import socket
import time
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from datetime import UTC
from pathlib import Path

from aerotruth.digests import code_digest
from aerotruth.errors import UserError, os_reason
from aerotruth.files import atomic_write_text
from aerotruth.truth.airframes import airframe
from aerotruth.truth.approach import PlannedApproach, fly_approach
from aerotruth.truth.days import AircraftDay, PlannedLeg
from aerotruth.truth.flight import FlightDiverged, fly_leg
from aerotruth.truth.track import TruthTrack

TRUTH_CODE = "module:aerotruth.truth.store"  # this module reaches everything a flight runs on


def default_root() -> Path:
    """$AEROTRUTH_CACHE/truth, else $XDG_CACHE_HOME/aerotruth/truth, else ~/.cache/aerotruth/truth."""
    base = os.environ.get("AEROTRUTH_CACHE")
    if base:
        return Path(base) / "truth"
    xdg = os.environ.get("XDG_CACHE_HOME")
    return (Path(xdg) if xdg else Path.home() / ".cache") / "aerotruth" / "truth"


def plan_identity(plan) -> dict:
    """The parts of a LegPlan that determine its flight."""
    return {
        "flight_id": plan.flight_id,
        "origin": plan.origin.icao,
        "destination": plan.destination.icao,
        "departure_runway": plan.departure_runway.ident,
        "arrival_runway": plan.arrival_runway.ident,
        "departure_utc": plan.departure_utc.astimezone(UTC).isoformat(),
        "cruise_pressure_altitude_m": round(float(plan.cruise_pressure_altitude_m), 3),
        "waypoints": [(w.name, round(float(w.lat), 9), round(float(w.lon), 9)) for w in plan.waypoints],
        "initial_height_m": round(float(plan.initial_height_m), 3),
        "arrival_height_m": round(float(plan.arrival_height_m), 3),
    }


def truth_key(leg: PlannedLeg, aircraft_type: str | None, turbulence: bool) -> str:
    """Stable digest (hashlib) of all inputs that determine a leg's truth."""
    ident = {
        "plan": plan_identity(leg.plan),
        "flight_seed": int(leg.flight_seed),
        "atmosphere": {"weather_seed": int(leg.weather_seed), "region": leg.region},
        "aircraft": dataclasses.asdict(airframe(aircraft_type)),
        "turbulence": bool(turbulence),
        "code": code_digest(TRUTH_CODE),
    }
    return hashlib.sha256(json.dumps(ident, sort_keys=True, default=str).encode()).hexdigest()[:32]


class StoreLockError(UserError):
    """The filesystem of the truth store refuses file locks (module docstring)."""


@contextmanager
def locked(path: str | Path, *, wait: bool = True) -> Iterator[bool]:
    """Hold the lock file `path` (created if missing) while the `with` body runs: yields
    True once held, or at once False if `wait` is False and another process holds it. The
    OS releases it if the process dies. If the file was removed while this process waited
    (`TruthStore.evict` removes a flight's lock file while it holds it), the lock of the
    file now at `path` is taken instead."""
    fd = _acquire(Path(path), wait)
    try:
        yield fd is not None
    finally:
        if fd is not None:
            os.close(fd)


def _acquire(path: Path, wait: bool) -> int | None:
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_CLOEXEC, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX if wait else fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            return None
        except OSError as e:
            os.close(fd)
            raise StoreLockError(
                f"truth store: cannot lock {path}: {os_reason(e)}; the store's filesystem must support flock "
                "between its users (Lustre: mount with -o flock; NFS: NFSv4 or NFSv3 with lockd), or give each "
                "machine its own store (truth_store.path)"
            ) from None
        except BaseException:
            os.close(fd)
            raise
        try:
            now = os.stat(path)
        except FileNotFoundError:
            now = None
        held = os.fstat(fd)
        if now is not None and (now.st_dev, now.st_ino) == (held.st_dev, held.st_ino):
            return fd
        os.close(fd)  # removed while we waited: lock the key's current lock file


@dataclass
class LegOutcome:
    """A planned leg and what the store returned: its track, or why it diverged."""

    leg: PlannedLeg
    key: str
    track: TruthTrack | None
    diverged: FlightDiverged | None
    flown_now: bool


@dataclass
class ApproachOutcome:
    """A planned approach and what the store returned: its track, or why it diverged."""

    planned: PlannedApproach
    key: str
    track: TruthTrack | None
    diverged: FlightDiverged | None
    flown_now: bool


class TruthStore:
    """A folder of cached truth legs (see the module docstring)."""

    def __init__(self, root: str | Path | None = None):
        self.root = Path(root) if root is not None else default_root()
        self.flown_here = 0  # legs and approaches this instance flew (diverged ones too)

    def _paths(self, key: str) -> tuple[Path, Path]:
        d = self.root / key[:2]
        return d / f"{key}.parquet", d / f"{key}.diverged.json"

    def leg(self, leg: PlannedLeg, *, aircraft_type: str | None = None, turbulence: bool = False) -> LegOutcome:
        """The leg's truth from the store, flown now if missing. Two workers asking for the
        same missing leg (e.g. two studies of one aircraft-day) fly it once: the second
        waits on the leg's lock file and then reads it."""
        key = truth_key(leg, aircraft_type, turbulence)
        track, diverged, now = self._cached(
            key,
            leg.plan.flight_id,
            lambda: fly_leg(
                leg.plan,
                seed=leg.flight_seed,
                aircraft=aircraft_type,
                turbulence=turbulence,
                atmosphere=leg.atmosphere(),
            ),
        )
        return LegOutcome(leg, key, track, diverged, now)

    def approach(self, planned: PlannedApproach, *, aircraft_type: str | None = None) -> ApproachOutcome:
        """An approach's 50 Hz truth from the store, flown now if missing (same locking,
        divergence record and compact storage as `leg`)."""
        ident = {
            "approach": planned.identity(),
            "aircraft": dataclasses.asdict(airframe(aircraft_type)),
            "code": code_digest(TRUTH_CODE),
        }
        key = "a" + hashlib.sha256(json.dumps(ident, sort_keys=True, default=str).encode()).hexdigest()[:31]
        label = (
            f"{planned.spec.airport}-{planned.spec.runway}-{planned.spec.start_utc:%Y%m%dT%H%M}-{planned.flight_seed}"
        )
        track, diverged, now = self._cached(
            key,
            label,
            lambda: fly_approach(
                planned.spec, seed=planned.flight_seed, aircraft=aircraft_type, atmosphere=planned.atmosphere()
            ),
        )
        return ApproachOutcome(planned, key, track, diverged, now)

    def mission(
        self, spec, *, weather_seed: int, flight_seed: int, region: str | None, aircraft_type: str | None = None
    ) -> tuple[str, TruthTrack | None, FlightDiverged | None]:
        """An inspection mission's 10 Hz truth (aerotruth.truth.mission), flown if missing:
        (key, track or None, divergence or None)."""
        from aerotruth.truth.days import day_atmosphere
        from aerotruth.truth.mission import fly_mission

        ident = {
            "mission": {
                "airport": spec.airport,
                "runway": spec.runway,
                "start_utc": spec.start_utc.isoformat(),
                "runs": [r.model_dump() for r in spec.runs],
                "mass_kg": spec.mass_kg,
                "turbulence": spec.turbulence,
                "ils": spec.ils.model_dump(),
                "points_m": {k: list(v) for k, v in sorted(spec.points_m.items())},
            },
            "weather_seed": int(weather_seed),
            "flight_seed": int(flight_seed),
            "region": region,
            "aircraft": dataclasses.asdict(airframe(aircraft_type)),
            "code": code_digest(TRUTH_CODE),
        }
        key = "m" + hashlib.sha256(json.dumps(ident, sort_keys=True, default=str).encode()).hexdigest()[:31]
        atm = None if region is None else day_atmosphere(spec.start_utc.date(), weather_seed, region)
        track, diverged, _ = self._cached(
            key,
            f"{spec.airport}-{spec.runway}-mission-{flight_seed}",
            lambda: fly_mission(spec, seed=flight_seed, aircraft=aircraft_type, atmosphere=atm),
        )
        return key, track, diverged

    def _cached(self, key: str, label: str, fly) -> tuple[TruthTrack | None, FlightDiverged | None, bool]:
        """(track, divergence, flown now) of `key`: read, or the recorded divergence, or
        `fly()` under the key's lock (released when the file closes, or by the OS if the
        process dies)."""
        path, failed = self._paths(key)
        path.parent.mkdir(parents=True, exist_ok=True)
        with locked(path.with_suffix(".lock")):
            if path.exists():
                os.utime(path)  # recently used: evicted last
                return TruthTrack.read_parquet(path), None, False
            if failed.exists():
                info = json.loads(failed.read_text())
                return None, FlightDiverged(info["reason"], info["seed"], info.get("time_s")), False
            t0 = time.monotonic()
            self.flown_here += 1
            try:
                track = fly()
            except FlightDiverged as e:
                atomic_write_text(failed, json.dumps({"reason": e.reason, "seed": e.seed, "time_s": e.time_s}))
                self._log_line(key, label, time.monotonic() - t0, "diverged")
                return None, e, True
            track.to_parquet(path)
            self._log_line(key, label, time.monotonic() - t0, "flown")
            # hand back exactly what a later read returns (compact storage), so results do
            # not depend on whether the flight was flown now or read from the store
            return TruthTrack.read_parquet(path), None, True

    def day(self, day: AircraftDay) -> list[LegOutcome]:
        """Every leg of an aircraft-day, in flying order."""
        return [self.leg(p, aircraft_type=day.aircraft_type, turbulence=day.turbulence) for p in day.plans()]

    def _log_line(self, key: str, flight_id: str, seconds: float, what: str) -> None:
        self.root.mkdir(parents=True, exist_ok=True)
        line = json.dumps(
            {
                "key": key,
                "flight_id": flight_id,
                "what": what,
                "seconds": round(seconds, 3),
                "host": socket.gethostname(),
                "pid": os.getpid(),
            }
        )
        # one writer at a time: O_APPEND keeps one machine's lines apart, not NFS clients'
        with locked(self.root / "flown.log.lock"), open(self.root / "flown.log", "a", encoding="utf-8") as f:
            f.write(line + "\n")

    def flown_count(self) -> int:
        """Legs flown into this store so far (lines of flown.log)."""
        log = self.root / "flown.log"
        return sum(1 for _ in open(log, encoding="utf-8")) if log.exists() else 0

    def files(self) -> list[Path]:
        """Stored flights (Parquet), any order."""
        return list(self.root.glob("*/*.parquet")) if self.root.exists() else []

    def size_bytes(self) -> int:
        """Bytes held by stored flights."""
        return sum(p.stat().st_size for p in self.files())

    def evict(self, max_bytes: int) -> tuple[int, int]:
        """Delete least recently used flights until at most `max_bytes` remain; returns
        (files removed, bytes freed). Each flight is removed under its key's lock, the one
        readers and writers take: a flight whose lock another process holds is in use and
        stays, with its lock file. One eviction at a time: while another process evicts
        from this store, returns (0, 0)."""
        if not self.root.is_dir():
            return 0, 0
        with locked(self.root / ".evict.lock", wait=False) as mine:
            if not mine:
                return 0, 0
            return self._evict(max_bytes)

    def _evict(self, max_bytes: int) -> tuple[int, int]:
        files = []
        for p in self.files():
            try:
                st = p.stat()
            except FileNotFoundError:  # removed since listed
                continue
            files.append((st.st_mtime_ns, st.st_size, p))
        files.sort(key=lambda x: (x[0], str(x[2])))
        total = sum(s for _, s, _ in files)
        removed = freed = 0
        for mtime, size, p in files:
            if total <= max_bytes:
                break
            with locked(p.with_suffix(".lock"), wait=False) as mine:
                if not mine:  # being read or written by another process
                    continue
                try:
                    used = p.stat().st_mtime_ns
                except FileNotFoundError:
                    total -= size
                    continue
                if used != mtime:  # read since listed: recently used now
                    continue
                p.unlink()
                p.with_suffix(".lock").unlink(missing_ok=True)  # held by us: see `locked`
            total -= size
            freed += size
            removed += 1
        return removed, freed
