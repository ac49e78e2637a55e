"""Reading the deviation tables that `aerotruth heading fit` writes (deviation.csv or
deviation_mag.csv) back as a fleet of fitted aircraft, for `heading apply`."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

from aerotruth.analysis.wind.heading_correction import FleetHeadingFit
from aerotruth.errors import DataError
from aerotruth.measured.tables import read_csv_table


def read_tables(path: str | Path) -> FleetHeadingFit:
    """The deviation tables of `aerotruth heading fit` (deviation.csv or deviation_mag.csv);
    DataError naming the file on anything else."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"{path}: no such file (expected the deviation.csv of `aerotruth heading fit`)")
    try:
        table = read_csv_table(path) if path.suffix.lower() != ".parquet" else pd.read_parquet(path)
    except Exception as e:  # noqa: BLE001 - pandas/pyarrow's many error types: one line naming the file
        raise DataError(f"{path}: not a readable table ({str(e).splitlines()[0]})") from None
    if len(table) == 0:
        raise DataError(f"{path}: no rows")
    twice = table["aircraft"][table["aircraft"].duplicated()] if "aircraft" in table.columns else []
    if len(twice):
        raise DataError(f"{path}: aircraft {twice.iloc[0]!r} has two tables")
    try:
        fleet = FleetHeadingFit.from_table(table)
    except (ValueError, KeyError, TypeError) as e:
        raise DataError(f"{path}: {e}") from None
    frames = {f.heading for f in fleet.fits_.values()}
    if len(frames) > 1:
        raise DataError(f"{path}: column 'heading_frame' mixes {sorted(frames)}; expected one frame per file")
    return fleet
