"""Writing files so that a reader never sees half of one: write a temporary file in the
same folder, flush it to disk, rename it over the final name (os.replace is atomic on
POSIX). A process killed at any moment leaves the old file, the new one, or nothing, plus
at worst a `*.tmp` that readers ignore and `remove_stale_temporaries` deletes.

Every failure of the system while writing (a read-only file system, no permission, a full
disk, a quota: any OSError) is one `aerotruth.errors.OutputError` naming the final path
and the system's reason (`writing`), the temporary removed and the old file left as it was.
A final name that is a folder, a device, a pipe or a socket (/dev/full, /dev/null) is
refused, never replaced by the rename. Output places are checked before any work with
`aerotruth.errors.output_folder` / `output_file` (a probe write)."""

from __future__ import annotations

import os
import re
import uuid
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from aerotruth.errors import OutputError, cannot_write

TMP_SUFFIX = ".tmp"


def _temporary_for(path: Path) -> Path:
    # pid and a random part: several processes may write the same final name at once
    return path.with_name(f"{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}{TMP_SUFFIX}")


@contextmanager
def writing(path: str | Path, option: str | None = None) -> Iterator[None]:
    """Any OSError raised inside becomes one OutputError naming `path` (and `option`) and
    the system's reason: the single wording of every write failure."""
    try:
        yield
    except OutputError:
        raise
    except OSError as e:
        raise cannot_write(path, e, option) from None


def _refuse_non_file(path: Path) -> None:
    """A final name that exists as anything but a regular file is not replaced."""
    try:
        exists, regular = path.exists(), path.is_file()
    except OSError as e:
        raise cannot_write(path, e) from None
    if exists and not regular:
        what = "a folder" if path.is_dir() else "not a regular file (a device, pipe or socket)"
        raise OutputError(f"cannot write {path}: it is {what}; expected a file name")


def atomic_write(path: str | Path, write: Callable[[Path], object]) -> None:
    """Call `write(tmp_path)` and rename the result over `path`; the temporary is removed
    if `write` fails. Whatever `write` returns is ignored. The temporary is created here
    (exclusively) before `write` fills it, so the folder's refusal is met at once. An
    OSError on the way is one OutputError naming `path` (`writing`)."""
    path = Path(path)
    _refuse_non_file(path)
    tmp = _temporary_for(path)
    try:
        with writing(path):
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
            write(tmp)
            fd = os.open(tmp, os.O_RDWR)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
            os.replace(tmp, path)
    finally:
        try:
            tmp.unlink(missing_ok=True)
        except OSError:
            pass  # the folder refuses the removal too; the `.tmp` is ignored by readers


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write `data` to `path` atomically."""
    atomic_write(path, lambda tmp: tmp.write_bytes(data))


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write UTF-8 `text` to `path` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def make_folder(path: str | Path, option: str | None = None) -> Path:
    """`path` made as a folder with its parents (nothing if it exists); an OSError is one
    OutputError naming it."""
    path = Path(path)
    with writing(path, option):
        path.mkdir(parents=True, exist_ok=True)
    return path


# the name _temporary_for gives: <final name>.<pid>.<8 hex>.tmp
_TEMPORARY = re.compile(r"^.+\.\d+\.[0-9a-f]{8}" + re.escape(TMP_SUFFIX) + "$")


def remove_stale_temporaries(folder: str | Path, recursive: bool = False) -> int:
    """Delete the temporaries (atomic_write's names) left in `folder` (and its subfolders
    with `recursive`) by killed writers; returns how many. Only for a folder no live writer
    uses (a run's, under its lock)."""
    n = 0
    pattern = f"**/*{TMP_SUFFIX}" if recursive else f"*{TMP_SUFFIX}"
    for stale in Path(folder).glob(pattern):
        if _TEMPORARY.match(stale.name) and stale.is_file():
            stale.unlink(missing_ok=True)
            n += 1
    return n
