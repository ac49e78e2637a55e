"""Random streams named by what they are for (docs/conventions.md, "Random streams").

A stream is `SeedSequence(campaign_seed, spawn_key=words)` where `words` are 32-bit words
of SHA-256 digests of names: a task's identity, then the consumer's name ("truth.plan",
"sensor.flux_valve", "method"). Appending words to a spawn key is exactly how NumPy
spawns child sequences, so a consumer's stream is a child of its task's stream and two
consumers never share numbers. hashlib, not Python's salted `hash()`: streams are the
same in every process, on every machine, whatever the order of the tasks.
"""

from __future__ import annotations

import hashlib
import json

import numpy as np

Name = str | int


def digest_words(text: str, n: int = 4) -> tuple[int, ...]:
    """The first `n` little-endian 32-bit words of sha256(text)."""
    d = hashlib.sha256(text.encode("utf-8")).digest()
    return tuple(int.from_bytes(d[4 * i : 4 * i + 4], "little") for i in range(n))


def name_words(*names: Name) -> tuple[int, ...]:
    """Spawn-key words of a name path such as ("truth", "N401XJ", "2009-08-15")."""
    return digest_words(json.dumps(list(names), separators=(",", ":")))


def seed_sequence(campaign_seed: int, key: tuple[int, ...]) -> np.random.SeedSequence:
    """SeedSequence(campaign_seed, spawn_key=key)."""
    return np.random.SeedSequence(campaign_seed, spawn_key=key)


def named_sequence(campaign_seed: int, *names: Name) -> np.random.SeedSequence:
    """The stream of a draw shared by name across tasks and studies, e.g.
    ("weather", "2009-08-15"): the same day's weather for every task of a campaign."""
    return seed_sequence(campaign_seed, name_words(*names))


def child(seq: np.random.SeedSequence, *names: Name) -> np.random.SeedSequence:
    """The child of `seq` named `names` (its spawn key extended by their words)."""
    return np.random.SeedSequence(seq.entropy, spawn_key=tuple(seq.spawn_key) + name_words(*names))


def named_child(seed: int | np.random.SeedSequence, *names: Name) -> np.random.SeedSequence:
    """The child named `names` of a flight's seed, an int or a SeedSequence (an int seed is
    SeedSequence(seed) first): a consumer's own stream inside one flight."""
    seq = seed if isinstance(seed, np.random.SeedSequence) else np.random.SeedSequence(seed)
    return child(seq, *names)


def generator(seq: np.random.SeedSequence) -> np.random.Generator:
    """PCG64 generator on `seq`."""
    return np.random.Generator(np.random.PCG64(seq))


def int_seed(seq: np.random.SeedSequence) -> int:
    """A 63-bit int from `seq`, usable on a command line (`aerotruth fly --seed`)."""
    return int(seq.generate_state(1, np.uint64)[0]) >> 1
