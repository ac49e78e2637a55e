"""Tasks: the independent units a campaign expands into, and their random streams.

A task is named by its *identity* (study name plus a few key/value pairs such as fleet,
aircraft and date). Its random stream is `SeedSequence(campaign_seed, spawn_key=k)` with
`k` four 32-bit words of the sha256 digest of the canonical JSON of the identity
(DESIGN.md, "Random streams"): results depend neither on the order of the task list nor
on which worker runs it, and never on Python's per-process salted `hash()`.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

IdentityValue = str | int


@dataclass(frozen=True)
class Task:
    """One unit of work: `study` and `identity` name it, `params` carries what `run` needs
    (picklable; not part of the identity, so it never changes the random stream)."""

    study: str
    identity: tuple[tuple[str, IdentityValue], ...]
    params: dict[str, Any] = field(default_factory=dict, compare=False, hash=False)

    def __post_init__(self) -> None:
        for k, v in self.identity:
            if not isinstance(k, str) or not isinstance(v, (str, int)) or isinstance(v, bool):
                raise ValueError(f"task identity of {self.study}: expected str keys and str/int values, got {k!r}: {v!r}")

    @property
    def identity_json(self) -> str:
        """Canonical JSON of study + identity: the input of the digest."""
        return json.dumps({"study": self.study, **dict(self.identity)}, sort_keys=True, separators=(",", ":"))

    @property
    def digest(self) -> bytes:
        """sha256 of the canonical identity."""
        return hashlib.sha256(self.identity_json.encode("utf-8")).digest()

    @property
    def id(self) -> str:
        """File-safe, human-readable, unique name: `study--value--value--<8 hex digest>`."""
        parts = [self.study] + [_safe(str(v)) for _, v in self.identity]
        return "--".join(parts + [self.digest.hex()[:8]])

    def spawn_key(self) -> tuple[int, int, int, int]:
        """Four 32-bit words of the identity digest."""
        d = self.digest
        return tuple(int.from_bytes(d[4 * i : 4 * i + 4], "little") for i in range(4))  # type: ignore[return-value]

    def seed_sequence(self, campaign_seed: int) -> np.random.SeedSequence:
        """The task's SeedSequence: SeedSequence(campaign_seed, spawn_key=digest words)."""
        return np.random.SeedSequence(campaign_seed, spawn_key=self.spawn_key())

    def rng(self, campaign_seed: int) -> np.random.Generator:
        """The task's random generator (PCG64 on its SeedSequence)."""
        return np.random.Generator(np.random.PCG64(self.seed_sequence(campaign_seed)))


def _safe(s: str) -> str:
    """Keep letters, digits, '.', '_' and '-'; anything else becomes '_'."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", s)[:40] or "_"


def keyed_seed_sequence(campaign_seed: int, *key: IdentityValue) -> np.random.SeedSequence:
    """A SeedSequence for a shared draw named by `key` (e.g. ("weather", "2009-08-15"): the
    same day's weather for every task of a campaign), derived like a task's stream."""
    text = json.dumps(list(key), separators=(",", ":"))
    d = hashlib.sha256(text.encode("utf-8")).digest()
    return np.random.SeedSequence(campaign_seed, spawn_key=tuple(int.from_bytes(d[4 * i : 4 * i + 4], "little") for i in range(4)))


def keyed_seed(campaign_seed: int, *key: IdentityValue) -> int:
    """An int seed (63 bits, usable on a command line such as `aerotruth fly --seed`) for a
    shared draw named by `key`."""
    return int(keyed_seed_sequence(campaign_seed, *key).generate_state(1, np.uint64)[0]) >> 1


def weather_seed(campaign_seed: int, day: dt.date) -> int:
    """Seed of the day's truth atmosphere: every task and study of a campaign that touches
    this date sees the same weather realization (per region)."""
    return keyed_seed(campaign_seed, "weather", day.isoformat())
