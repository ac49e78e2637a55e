"""Writing files so that a reader never sees half of one: write a temporary file in the
same folder, flush it to disk, rename it over the final name (os.replace is atomic on
POSIX). A process killed at any moment leaves the old file, the new one, or nothing, plus
at worst a `*.tmp` that readers ignore and `remove_stale_temporaries` deletes."""

from __future__ import annotations

import os
import uuid
from collections.abc import Callable
from pathlib import Path

TMP_SUFFIX = ".tmp"


def _temporary_for(path: Path) -> Path:
    # pid and a random part: several processes may write the same final name at once
    return path.with_name(f"{path.name}.{os.getpid()}.{uuid.uuid4().hex[:8]}{TMP_SUFFIX}")


def atomic_write(path: str | Path, write: Callable[[Path], object]) -> None:
    """Call `write(tmp_path)` and rename the result over `path`; the temporary is removed
    if `write` fails. Whatever `write` returns is ignored."""
    path = Path(path)
    tmp = _temporary_for(path)
    try:
        write(tmp)
        with open(tmp, "rb+") as f:
            os.fsync(f.fileno())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def atomic_write_bytes(path: str | Path, data: bytes) -> None:
    """Write `data` to `path` atomically."""
    atomic_write(path, lambda tmp: tmp.write_bytes(data))


def atomic_write_text(path: str | Path, text: str) -> None:
    """Write UTF-8 `text` to `path` atomically."""
    atomic_write_bytes(path, text.encode("utf-8"))


def remove_stale_temporaries(folder: str | Path) -> int:
    """Delete `*.tmp` files left in `folder` by killed writers; returns how many."""
    n = 0
    for stale in Path(folder).glob(f"*{TMP_SUFFIX}"):
        stale.unlink(missing_ok=True)
        n += 1
    return n
