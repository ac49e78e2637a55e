"""Tasks: the independent units a campaign expands into, and their random streams.

A task is named by its *identity* (study name, its stage when it has one, plus a few
key/value pairs such as fleet, aircraft and date). Its random stream is
`SeedSequence(campaign_seed, spawn_key=k)` with `k` four 32-bit words of the sha256
digest of the canonical JSON of the identity (docs/conventions.md, "Random streams"); each consumer
inside the task draws from its own named child of that stream (`TaskContext.rng`).
Results depend neither on the order of the task list nor on which worker runs it, and
never on Python's per-process salted `hash()`.

A task of a study that learns (fit on one stage, apply to another) names the learned
states it `needs`; the runner gives them to it once they are fitted.
"""

from __future__ import annotations

import datetime as dt
import hashlib
import json
import re
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from aerotruth import seeds

IdentityValue = str | int
MAIN_STAGE = "main"


@dataclass(frozen=True)
class Task:
    """One unit of work: `study`, `stage` and `identity` name it; `params` carries what
    `run` needs (picklable; not part of the identity, so it never changes the random
    stream); `needs` names learned states of the study the task applies; `source` says
    where workers import the study from (set by the runner)."""

    study: str
    identity: tuple[tuple[str, IdentityValue], ...]
    params: dict[str, Any] = field(default_factory=dict, compare=False, hash=False)
    stage: str = MAIN_STAGE
    needs: tuple[str, ...] = ()
    source: str = field(default="", compare=False, hash=False)

    def __post_init__(self) -> None:
        for k, v in self.identity:
            if not isinstance(k, str) or not isinstance(v, (str, int)) or isinstance(v, bool):
                raise ValueError(
                    f"task identity of {self.study}: expected str keys and str/int values, got {k!r}: {v!r}"
                )

    @property
    def identity_json(self) -> str:
        """Canonical JSON of study (+ stage) + identity: the input of the digest."""
        head: dict[str, Any] = {"study": self.study}
        if self.stage != MAIN_STAGE:
            head["stage"] = self.stage
        return json.dumps({**head, **dict(self.identity)}, sort_keys=True, separators=(",", ":"))

    @property
    def id(self) -> str:
        """File-safe, human-readable, unique name: `study--[stage--]value--...--<8 hex digest>`."""
        parts = (
            [self.study]
            + ([self.stage] if self.stage != MAIN_STAGE else [])
            + [_safe(str(v)) for _, v in self.identity]
        )
        return "--".join(parts + [self._digest_hex()[:8]])

    def _digest_hex(self) -> str:
        return hashlib.sha256(self.identity_json.encode("utf-8")).hexdigest()

    def spawn_key(self) -> tuple[int, ...]:
        """Four 32-bit words of the identity digest."""
        return seeds.digest_words(self.identity_json)

    def seed_sequence(self, campaign_seed: int) -> np.random.SeedSequence:
        """The task's SeedSequence: SeedSequence(campaign_seed, spawn_key=digest words)."""
        return seeds.seed_sequence(campaign_seed, self.spawn_key())

    def rng(self, campaign_seed: int, *name: IdentityValue) -> np.random.Generator:
        """The task's random generator, or that of its child stream `name` (PCG64)."""
        seq = self.seed_sequence(campaign_seed)
        return seeds.generator(seeds.child(seq, *name) if name else seq)


def _safe(s: str) -> str:
    """Keep letters, digits, '.', '_' and '-'; anything else becomes '_'."""
    return re.sub(r"[^A-Za-z0-9._-]", "_", s)[:40] or "_"


def keyed_seed_sequence(campaign_seed: int, *key: IdentityValue) -> np.random.SeedSequence:
    """A SeedSequence for a draw shared by name (e.g. ("weather", "2009-08-15"): the same
    day's weather for every task of a campaign)."""
    return seeds.named_sequence(campaign_seed, *key)


def keyed_seed(campaign_seed: int, *key: IdentityValue) -> int:
    """An int seed (63 bits, usable on a command line such as `aerotruth fly --seed`) for a
    draw shared by name."""
    return seeds.int_seed(keyed_seed_sequence(campaign_seed, *key))


def weather_seed(campaign_seed: int, day: dt.date) -> int:
    """Seed of the day's truth atmosphere: every task and study of a campaign that touches
    this date sees the same weather realization (per region)."""
    return keyed_seed(campaign_seed, "weather", day.isoformat())
