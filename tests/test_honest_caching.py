"""A stored task result is reused only while the code and data it depends on are
unchanged: an edited truth-atmosphere constant reruns the tasks (and re-flies the legs)
that depend on it, an edited aircraft XML file re-flies the truth and leaves the wind
climatology alone — no version bump. Run on a copy of the package, in subprocesses."""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

import aerotruth

CAMPAIGN = """\
name: honest
seed: 5
fleets:
  - {name: f, aircraft: [N1]}
periods:
  - {name: d, dates: [2009-08-15]}
studies:
  truth:
    fleets: [f]
    periods: [d]
    legs: [{from: KMSP, to: KRST, departure_utc: "13:00"}]
  wind_climatology:
    regions: [{name: mw, network: mesaba}]
    periods: [d]
    flight_levels: [250]
    hours_utc: [12]
    points: 50
"""


def _run(tmp: Path) -> tuple[dict, str]:
    env = dict(os.environ, PYTHONPATH=str(tmp / "pkg"), AEROTRUTH_CACHE=str(tmp / "cache"))
    cmd = [
        sys.executable,
        "-m",
        "aerotruth.app.cli",
        "run",
        str(tmp / "c.yaml"),
        "--out",
        str(tmp / "run"),
        "--workers",
        "1",
        "--quiet",
        "--no-report",
    ]
    p = subprocess.run(cmd, env=env, capture_output=True, text=True, cwd=tmp)
    assert p.returncode == 0, p.stderr
    where = subprocess.run(
        [sys.executable, "-c", "import aerotruth; print(aerotruth.__file__)"],
        env=env,
        capture_output=True,
        text=True,
        cwd=tmp,
    ).stdout
    assert where.startswith(str(tmp / "pkg")), where  # the copy runs, not the installed tree
    metrics = json.loads((tmp / "run" / "metrics.json").read_text())["metrics"]
    return metrics, p.stderr


def _counts(stderr: str) -> tuple[int, int, int]:
    m = re.search(r"(\d+) reused, (\d+) run, (\d+) legs flown", stderr)
    return tuple(int(x) for x in m.groups())


@pytest.mark.slow
def test_edits_of_a_parameters_file_or_an_xml_file_rerun_what_depends_on_them(tmp_path):
    shutil.copytree(
        Path(aerotruth.__file__).parent, tmp_path / "pkg" / "aerotruth", ignore=shutil.ignore_patterns("__pycache__")
    )
    (tmp_path / "c.yaml").write_text(CAMPAIGN)
    first, err = _run(tmp_path)
    assert _counts(err) == (0, 2, 1)
    again, err = _run(tmp_path)
    assert _counts(err) == (2, 0, 0) and again == first

    # the truth atmosphere's parameters file (a data file the atmosphere module reads)
    atm = tmp_path / "pkg" / "aerotruth" / "truth" / "data" / "wind_field.yaml"
    text = atm.read_text()
    assert "jet_speed_summer_ms: 23.0\n" in text
    atm.write_text(text.replace("jet_speed_summer_ms: 23.0\n", "jet_speed_summer_ms: 45.0\n"))
    edited, err = _run(tmp_path)
    assert _counts(err) == (0, 2, 1)  # both studies stand on the atmosphere: both rerun, the leg re-flies
    assert edited["wind_climatology.FL250.speed_mean_mps"] > first["wind_climatology.FL250.speed_mean_mps"] + 2.0

    gains = tmp_path / "pkg" / "aerotruth" / "truth" / "aircraft" / "systems" / "gains_saab340.xml"
    gains.write_text(gains.read_text() + "<!-- edited -->\n")
    after_xml, err = _run(tmp_path)
    assert _counts(err) == (1, 1, 1)  # the truth re-flies; the wind climatology does not depend on aircraft XML
    assert after_xml["wind_climatology.FL250.speed_mean_mps"] == edited["wind_climatology.FL250.speed_mean_mps"]


def test_numba_version_and_processor_are_in_the_code_digest(monkeypatch):
    """The wind method's compiled loops use fastmath: a stored result is reused only on the
    same numba build and processor model."""
    from importlib import metadata

    from aerotruth import digests

    source = "module:aerotruth.sim.studies.wind_reports"
    digests.code_digest.cache_clear()
    base = digests.code_digest(source)
    real = metadata.version
    monkeypatch.setattr(digests.metadata, "version", lambda n: "0.0.1" if n == "numba" else real(n))
    digests.code_digest.cache_clear()
    other_numba = digests.code_digest(source)
    monkeypatch.setattr(digests.metadata, "version", real)
    monkeypatch.setattr(digests, "cpu_name", lambda: "Some Other CPU @ 2.0GHz")
    digests.code_digest.cache_clear()
    other_cpu = digests.code_digest(source)
    monkeypatch.undo()
    digests.code_digest.cache_clear()
    assert len({base, other_numba, other_cpu}) == 3
    assert digests.code_digest(source) == base
