"""Output paths are checked before any work: a file where a folder is expected (or a
folder where a file is) is one line and exit status 2, never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from aerotruth.app.cli import main

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize(
    "argv",
    [
        ["run", str(ROOT / "campaigns/quick.yaml"), "--out", "{file}"],
        ["fits", "{log}", "--out", "{file}"],
        ["diagnose", "{log}", "--model", str(ROOT / "campaigns/quick.yaml"), "--out", "{file}"],
        ["heading", "fit", "{obs}", "--out", "{file}"],
        ["heading", "apply", "{obs}", "--tables", "{obs}", "--out", "{file}"],
    ],
)
def test_a_file_given_as_the_output_folder_is_one_line(tmp_path, capsys, argv):
    file = tmp_path / "taken"
    file.write_text("not a folder")
    log, obs = tmp_path / "log.csv", tmp_path / "obs.csv"  # never read: the output is checked first
    log.write_text("approach,time_s\n")
    obs.write_text("aircraft,time\n")
    args = [a.format(file=file, log=log, obs=obs) for a in argv]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "taken" in err and "not a folder" in err and "Traceback" not in err and err.count("\n") == 1
    assert file.read_text() == "not a folder"
