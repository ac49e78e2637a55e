"""A user's CSV table read as written: the one reader behind `heading fit`, `fits` and
`diagnose` (docs/data-formats.md).

Two things a plain `pandas.read_csv` gets wrong on such files:

* label columns (`TEXT_COLUMNS`: aircraft, flight, reference-model and avionics labels)
  are read as text, never as numbers or booleans: a tail "0511" keeps its zero, and a
  `heading_input` column that says `true` on every row (an all-true-heading fleet, the
  wind paper's Chautauqua jets) stays the word, not the boolean pandas would make of it;
* the field separator is the header's: `,` unless the header line has none and has `;`
  (spreadsheets in locales with a decimal comma write those) or a tab;
* in a `;`- or tab-separated file a comma cannot separate fields, so a column whose every
  value is a plain number, some written with a decimal comma (`61,2`, `-149,9`, `1,5e-3`),
  is read as those numbers. Anything else (grouped thousands `1.234,5`, a mix of points
  and commas in one column) is left as text for the caller's number check to name:
  not guessed;
* a file whose last line has fewer fields than its header and the line before it was cut
  short (a copy or a download that stopped): pandas would pad that row with empty cells,
  the row would be skipped and the rest of the file lost without a word. It is refused
  (`CutShort`). A cut inside the last field cannot be told from a shorter value.
"""

from __future__ import annotations

import csv
import gzip
import io
import re
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.errors import DataError

TEXT_COLUMNS = ("aircraft", "flight", "ref_source", "heading_input", "phase", "fleet", "stage")
SEPARATORS = (",", ";", "\t")
_DECIMAL_COMMA = re.compile(r"[+-]?(\d+(,\d*)?|,\d+)([eE][+-]?\d+)?")


class CutShort(pd.errors.ParserError):
    """A CSV file whose last line has fewer fields than its header: cut short."""


def csv_separator(header_line: str) -> str:
    """The field separator of a CSV file from its header line: the first of `,` `;` tab
    that occurs in it (`,` when none does: a one-column file)."""
    for sep in SEPARATORS:
        if sep in header_line:
            return sep
    return ","


def read_csv_table(source: str | Path | bytes) -> pd.DataFrame:
    """A CSV table (a path or the file's bytes, plain or gzip-compressed: recognised by its
    magic bytes, whatever the name) with `TEXT_COLUMNS` read as text and the separator
    taken from the header. pandas' errors pass through (the callers name the file). (Not as
    pandas' "category" dtype: measured with pandas 3.1, it turns the categories "0511" and
    " 0511" into the number 511.)"""
    compression = "gzip" if _is_gzip(source) else None
    sep = csv_separator(_first_line(source, compression).decode("utf-8", errors="replace"))
    columns = pd.read_csv(_readable(source), sep=sep, nrows=0, compression=compression).columns
    last, before = _last_lines_fields(source, compression, sep)
    if last < min(before, len(columns)):
        raise CutShort(
            f"its last line has {last} of the header's {len(columns)} fields: the file is cut short "
            "(an interrupted copy or download?)"
        )
    dtype = {c: str for c in TEXT_COLUMNS if c in columns}
    df = pd.read_csv(_readable(source), sep=sep, dtype=dtype, low_memory=False, compression=compression)
    return df if sep == "," else _decimal_commas(df)


def numeric_column(df: pd.DataFrame, col: str, where: str) -> pd.Series:
    """Column `col` as float64, empty cells NaN; DataError naming `where`, the column and the
    first data row (1-based) whose text is not a number."""
    num = pd.to_numeric(df[col], errors="coerce")
    bad = num.isna() & df[col].notna()
    if bad.any():
        raise DataError(
            f"{where}: column {col!r} data row {int(np.flatnonzero(bad)[0]) + 1}: "
            f"expected a number, got {df[col][bad].iloc[0]!r}"
        )
    return num.astype(float)


def read_parquet_table(path: str | Path) -> pd.DataFrame:
    """A Parquet table, its `TEXT_COLUMNS` stored as strings read as categoricals straight
    from the file's dictionary pages (no per-row strings made). pyarrow's errors pass
    through (the callers name the file)."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    labels = [
        f.name
        for f in pq.read_schema(path)
        if f.name in TEXT_COLUMNS and (pa.types.is_string(f.type) or pa.types.is_large_string(f.type))
    ]
    return pd.read_parquet(path, read_dictionary=labels)


def _decimal_commas(df: pd.DataFrame) -> pd.DataFrame:
    """Columns of a `;`/tab-separated table written with decimal commas, as numbers: a
    text column (not a label) whose every non-empty value is a number with at most one
    decimal comma and no point, at least one with the comma."""
    for name in df.columns:
        col = df[name]
        if name in TEXT_COLUMNS or not (col.dtype == object or pd.api.types.is_string_dtype(col)):
            continue
        text = col.str.strip()  # missing cells stay missing
        values = text[text.notna() & (text != "")]
        if values.empty or not values.str.contains(",", regex=False).any():
            continue
        if values.str.fullmatch(_DECIMAL_COMMA).all():
            df[name] = pd.to_numeric(text.where(text != "").str.replace(",", ".", regex=False), errors="raise")
    return df


def _readable(source: str | Path | bytes):
    """What pandas reads: a path as it is (pandas streams the file: no copy in memory), bytes
    through a fresh buffer."""
    return source if isinstance(source, (str, Path)) else io.BytesIO(source)


GZIP_MAGIC = b"\x1f\x8b"  # a gzip stream's first two bytes


def _is_gzip(source: str | Path | bytes) -> bool:
    if isinstance(source, (str, Path)):
        with open(source, "rb") as f:
            return f.read(2) == GZIP_MAGIC
    return source[:2] == GZIP_MAGIC


_BLOCK = 1 << 16  # the last line is looked for from the file's end, this much at a time


def _last_line(data: bytes) -> tuple[int, int]:
    """(start, end) of the last non-empty line of `data`; start is 0 when no line break
    precedes it (then it may begin before `data` does)."""
    end = len(data)
    while end > 0 and data[end - 1] in b"\r\n":
        end -= 1
    return data.rfind(b"\n", 0, end) + 1, end


def _last_lines_fields(source: str | Path | bytes, compression: str | None, sep: str) -> tuple[int, int]:
    """The numbers of fields of the file's last two non-empty lines (read back from its end,
    or through the gzip stream keeping its last two lines); a line that is not there has 0."""

    def two_lines(data: bytes) -> int:  # where the last two lines start (0: maybe before `data`)
        start, _ = _last_line(data)
        return _last_line(data[: max(start - 1, 0)])[0] if start > 0 else 0

    if compression == "gzip":
        tail = b""
        with gzip.open(_readable(source), "rb") as f:
            while block := f.read(1 << 20):
                tail += block
                tail = tail[two_lines(tail) :]  # the last two lines so far, and what follows them
    elif isinstance(source, (str, Path)):
        with open(source, "rb") as f:
            size = f.seek(0, io.SEEK_END)
            back = _BLOCK
            while True:
                f.seek(max(0, size - back))
                tail = f.read()
                if two_lines(tail) > 0 or back >= size:
                    break
                back *= 4
    else:
        tail = source
    out = []
    for _ in range(2):
        start, end = _last_line(tail)
        line = tail[start:end]
        text = line.decode("utf-8", errors="replace")
        out.append(len(next(csv.reader([text], delimiter=sep), [])) if line.strip() else 0)
        tail = tail[: max(start - 1, 0)] if start > 0 else b""
    return out[0], out[1]


def _first_line(source: str | Path | bytes, compression: str | None = None) -> bytes:
    if compression == "gzip":
        with gzip.open(_readable(source), "rb") as f:
            return f.readline()
    if isinstance(source, (str, Path)):
        with open(source, "rb") as f:
            return f.readline()
    return source.split(b"\n", 1)[0]
