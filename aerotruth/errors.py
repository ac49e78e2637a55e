"""User-facing errors: problems in what the user gave (a campaign file, a data file, a
command-line value, a run directory). The command line prints each as one line and exits
with status 2; no traceback. Every layer raises these; only `aerotruth.app.cli` prints them."""

from __future__ import annotations

from pathlib import Path


class UserError(ValueError):
    """An error in the user's input, already worded as one line naming the field or file
    and what was expected."""


class ConfigError(UserError):
    """A campaign file problem: `path: what was expected (line N)`."""


class RunDirError(UserError):
    """A run directory that cannot be used as asked (another run in progress, incomplete run, ...)."""


class DataError(UserError):
    """A measured-data file (observation table, approach log, ...) that cannot be read as
    what it should be; the message names the file and the column."""


def output_folder(path: str | Path, option: str = "--out") -> Path:
    """An output folder path checked before any work (made later if missing): a file in its
    place is one UserError naming it."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise UserError(f"{option}: {out} exists and is not a folder (expected a folder for the outputs)")
    return out
