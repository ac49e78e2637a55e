"""Task identities and random streams: named by a sha256 digest of the identity, so a
task's stream depends neither on list order, nor on the process, nor on its params."""

from __future__ import annotations

import hashlib
import os
import subprocess
import sys

import numpy as np
import pytest

from aerotruth.sim.tasks import Task, keyed_seed, keyed_seed_sequence

IDENT = (("region", "midwest"), ("date", "2009-08-15"))


def test_task_id_is_readable_and_ends_with_the_identity_digest():
    t = Task("wind_climatology", IDENT)
    canonical = b'{"date":"2009-08-15","region":"midwest","study":"wind_climatology"}'
    assert t.identity_json.encode() == canonical
    assert t.id == "wind_climatology--midwest--2009-08-15--" + hashlib.sha256(canonical).hexdigest()[:8]


def test_stream_is_seedsequence_of_campaign_seed_and_digest_words():
    t = Task("wind_climatology", IDENT)
    d = hashlib.sha256(t.identity_json.encode()).digest()
    words = tuple(int.from_bytes(d[i : i + 4], "little") for i in (0, 4, 8, 12))
    expected = np.random.Generator(np.random.PCG64(np.random.SeedSequence(42, spawn_key=words))).random(5)
    assert np.array_equal(t.rng(42).random(5), expected)


def test_stream_ignores_params_and_order_but_not_identity_or_seed():
    a = Task("wind_climatology", IDENT, params={"points": 3})
    b = Task("wind_climatology", IDENT, params={"points": 999})
    c = Task("wind_climatology", (("region", "midwest"), ("date", "2009-08-16")))
    assert a.rng(1).integers(2**62) == b.rng(1).integers(2**62)
    assert a.rng(1).integers(2**62) != c.rng(1).integers(2**62)
    assert a.rng(1).integers(2**62) != a.rng(2).integers(2**62)
    draws = {t.id: t.rng(7).random() for t in [a, c]}
    assert draws == {t.id: t.rng(7).random() for t in [c, a]}


def test_stream_is_the_same_in_another_process_with_another_hash_seed():
    code = (
        "from aerotruth.sim.tasks import Task;"
        "t = Task('wind_climatology', (('region', 'midwest'), ('date', '2009-08-15')));"
        "print(repr(t.rng(42).random()), t.id)"
    )
    outs = set()
    for hash_seed in ("1", "2"):
        env = dict(os.environ, PYTHONHASHSEED=hash_seed)
        outs.add(
            subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout
        )
    t = Task("wind_climatology", IDENT)
    assert outs == {f"{t.rng(42).random()!r} {t.id}\n"}


def test_keyed_seed_is_a_63_bit_int_shared_by_name():
    s = keyed_seed(42, "weather", "2009-08-15")
    assert 0 <= s < 2**63
    assert s == keyed_seed(42, "weather", "2009-08-15") != keyed_seed(42, "weather", "2009-08-16")
    assert keyed_seed_sequence(42, "weather", "2009-08-15").entropy == 42


def test_identity_values_must_be_str_or_int():
    with pytest.raises(ValueError, match="expected str keys and str/int values"):
        Task("x", (("date", 1.5),))
