"""The second half of the fuzz corpus of tests/test_fuzz.py: its cases of `diagnose`, the campaign and
run-folder commands (run, validate, figures, report, regress), the truth flights (fly,
fly-approach) and the traffic reader (reports). The corpus, its seeds and its assertions are
all in tests/test_fuzz.py; this file only runs these cases, so that pytest-xdist (`--dist
loadfile`: one process per file) runs the two halves on two processes."""

from __future__ import annotations

from pathlib import Path

import pytest
import test_fuzz as corpus


@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> corpus.Seeds:
    return corpus.Seeds(tmp_path_factory.mktemp("fuzz-seeds") / "seeds")


@pytest.mark.timeout(600)
def test_every_seed_is_accepted(seeds: corpus.Seeds):
    corpus.unmutated_outputs(seeds, second_file=True)


@pytest.mark.parametrize("c", corpus.params(second_file=True))
def test_fuzz(c: corpus.Case, seeds: corpus.Seeds, tmp_path: Path, capsys, monkeypatch):
    corpus.run_case(c, seeds, tmp_path, capsys, monkeypatch)
