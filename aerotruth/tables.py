"""A user's CSV table read as written: the one reader behind `heading fit`, `fits` and
`diagnose` (docs/data-formats.md).

Two things a plain `pandas.read_csv` gets wrong on such files:

* label columns (`TEXT_COLUMNS`: aircraft, flight, reference-model and avionics labels)
  are read as text, never as numbers or booleans: a tail "0511" keeps its zero, and a
  `heading_input` column that says `true` on every row (an all-true-heading fleet, the
  wind paper's Chautauqua jets) stays the word, not the boolean pandas would make of it;
* the field separator is the header's: `,` unless the header line has none and has `;`
  (spreadsheets in locales with a decimal comma write those) or a tab. Decimal commas
  themselves are not guessed: numbers must use a point, and a column that does not is
  reported by the caller's number check.
"""

from __future__ import annotations

import io
from pathlib import Path

import pandas as pd

TEXT_COLUMNS = ("aircraft", "flight", "ref_source", "heading_input", "phase", "fleet", "stage")
SEPARATORS = (",", ";", "\t")


def csv_separator(header_line: str) -> str:
    """The field separator of a CSV file from its header line: the first of `,` `;` tab
    that occurs in it (`,` when none does: a one-column file)."""
    for sep in SEPARATORS:
        if sep in header_line:
            return sep
    return ","


def read_csv_table(source: str | Path | bytes) -> pd.DataFrame:
    """A CSV table (a path or the file's bytes) with `TEXT_COLUMNS` read as text and the
    separator taken from the header. pandas' errors pass through (the callers name the
    file)."""
    sep = csv_separator(_first_line(source).decode("utf-8", errors="replace"))
    columns = pd.read_csv(_readable(source), sep=sep, nrows=0).columns
    dtype = {c: str for c in TEXT_COLUMNS if c in columns}
    return pd.read_csv(_readable(source), sep=sep, dtype=dtype, low_memory=False)


def _readable(source: str | Path | bytes):
    """What pandas reads: a path as it is (pandas streams the file: no copy in memory), bytes
    through a fresh buffer."""
    return source if isinstance(source, (str, Path)) else io.BytesIO(source)


def _first_line(source: str | Path | bytes) -> bytes:
    if isinstance(source, (str, Path)):
        with open(source, "rb") as f:
            return f.readline()
    return source.split(b"\n", 1)[0]
