"""User-facing errors: problems in what the user gave (a campaign file, a data file, a
command-line value, a run directory, an output place the system will not let us write).
The command line prints each as one line and exits with status 2; no traceback. Every layer
raises these; only `aerotruth.app.cli` prints them.

Output places are checked here before any work (`output_folder`, `output_file`): a probe
file is created in the folder the output goes to, written, flushed to the disk and deleted,
so that a read-only, full or over-quota disk, or a folder without permission, is one line
naming the path and the system's reason before anything is flown, read or computed (root
ignores permission bits: only a real write tells). `aerotruth.files` writes every output
and turns an OSError while writing into the same one line (`cannot_write`)."""

from __future__ import annotations

import errno as _errno
import os
import uuid
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


class OutputError(UserError):
    """An output file or folder that cannot be written (read-only file system, no
    permission, disk full, quota exceeded, ...): `[option: ]cannot write PATH: reason (ENAME)`."""


PROBE_PREFIX = ".aerotruth-probe."
PROBE_BYTES = 4096  # one block: a full disk refuses it (an empty file needs no block)


def os_reason(e: OSError) -> str:
    """The system's reason for `e` in words with its errno name, e.g. 'No space left on
    device (ENOSPC)'; its text when it has no errno."""
    code = e.errno if isinstance(e.errno, int) else None
    if code is None:
        return str(e) or type(e).__name__
    name = _errno.errorcode.get(code)
    words = e.strerror or os.strerror(code)
    return f"{words} ({name})" if name else words


def cannot_write(path: str | Path, e: OSError, option: str | None = None) -> OutputError:
    """The one-line error for an OSError `e` met while writing `path`."""
    return OutputError(f"{option + ': ' if option else ''}cannot write {path}: {os_reason(e)}")


def check_writable(folder: str | Path, option: str | None = None) -> None:
    """Create a probe file in the existing `folder`, write PROBE_BYTES, flush them to the
    disk and delete the file: an OutputError naming the folder and the system's reason when
    any step fails. Nothing is left behind (the probe's name ends in `.tmp`, which readers
    ignore and `aerotruth.files.remove_stale_temporaries` deletes, should a kill interrupt it)."""
    folder = Path(folder)
    probe = folder / f"{PROBE_PREFIX}{os.getpid()}.{uuid.uuid4().hex[:8]}.tmp"
    try:
        fd = os.open(probe, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600)
        try:
            os.write(fd, b"\0" * PROBE_BYTES)
            os.fsync(fd)
        finally:
            os.close(fd)
        os.unlink(probe)
    except OSError as e:
        try:
            os.unlink(probe)
        except OSError:
            pass
        raise cannot_write(folder, e, option) from None


def _nearest_existing(path: Path) -> Path:
    """`path` or its nearest ancestor that exists (the folder a new output is made in)."""
    p = path if path.is_absolute() else Path.cwd() / path
    while not p.exists() and p != p.parent:
        p = p.parent
    return p


def output_folder(path: str | Path, option: str = "--out") -> Path:
    """An output folder path checked before any work (made later if missing): a file in its
    place, or a file where one of its parent folders should be, is one UserError naming it;
    the folder (or, when it does not exist yet, the nearest existing folder it will be made
    in) must take a probe write (check_writable), else one OutputError naming it."""
    out = Path(path)
    if out.exists() and not out.is_dir():
        raise UserError(f"{option}: {out} exists and is not a folder (expected a folder for the outputs)")
    base = _nearest_existing(out)
    if not base.is_dir():
        raise UserError(f"{option}: cannot make {out}: {base} is a file, not a folder")
    check_writable(base, option)
    return out


def output_file(path: str | Path, option: str = "--out") -> Path:
    """An output file path checked before any work: not a folder, not a device, pipe or
    socket (such as /dev/full, which a rename would replace), in an existing folder that
    takes a probe write (check_writable). One UserError naming `option` otherwise."""
    out = Path(path)
    if out.is_dir():
        raise UserError(f"{option}: {out} is a folder, expected a file name (e.g. {out / 'output'})")
    if out.exists() and not out.is_file():
        raise UserError(f"{option}: {out} is not a regular file (a device, pipe or socket); expected a file name")
    if not out.parent.is_dir():
        what = "is a file, not a folder" if out.parent.exists() else "does not exist"
        raise UserError(f"{option}: folder {out.parent} {what}")
    check_writable(out.parent, option)
    return out
