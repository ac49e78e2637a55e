"""Reading the deviation tables that `aerotruth heading fit` writes (deviation.csv or
deviation_mag.csv) back as a fleet of fitted aircraft, for `heading apply`. Read strictly:
a value `heading apply` would take otherwise than the fit meant (a heading frame other
than `true` or `magnetic`, a date that is not one) is one DataError naming the file, the
aircraft and the column."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

import pandas as pd

from aerotruth.analysis.wind.heading_correction import FleetHeadingFit
from aerotruth.dates import MODEL_DATE_SPAN, check_model_date
from aerotruth.errors import DataError, UserError
from aerotruth.measured.tables import read_csv_table

DATE_COLUMNS = ("valid_from", "valid_to")  # UTC days of the data fitted, YYYY-MM-DD
TIME_COLUMNS = ("data_from", "data_to")  # UTC times of the first and last report fitted, ISO 8601 (optional)


def read_tables(path: str | Path) -> FleetHeadingFit:
    """The deviation tables of `aerotruth heading fit` (deviation.csv or deviation_mag.csv);
    DataError naming the file on anything else."""
    path = Path(path)
    if not path.is_file():
        what = "is a folder" if path.is_dir() else "no such file"
        raise DataError(f"{path}: {what} (expected the deviation.csv of `aerotruth heading fit`)")
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
    for fit in fleet.fits_.values():
        _check_dates(fit, path)
    return fleet


def _empty(text: str) -> bool:
    return text.strip().lower() in ("", "nan", "nat", "none")


def _check_dates(fit, path: Path) -> None:
    """The table's dates as `heading apply` uses them (in_sample): valid_from/valid_to UTC
    days YYYY-MM-DD in aerotruth's span, in order (empty only for a refused table, which
    corrects nothing); data_from/data_to, where given, ISO 8601 times in order."""
    where = f"{path}: aircraft {fit.aircraft_!r}"
    days = {}
    for c in DATE_COLUMNS:
        text = str(getattr(fit, c + "_"))
        if _empty(text):
            if fit.status_ != "refused":
                raise DataError(f"{where}, column {c!r}: empty; a {fit.status_} table needs its dates (YYYY-MM-DD)")
            setattr(fit, c + "_", "")
            continue
        try:
            day = dt.date.fromisoformat(text)
        except ValueError:
            raise DataError(f"{where}, column {c!r}: {text!r} is not a date; expected YYYY-MM-DD (UTC)") from None
        try:
            days[c] = check_model_date(day, f"{where}, column {c!r}")
        except UserError as e:
            raise DataError(str(e)) from None
    if len(days) == 2 and days["valid_from"] > days["valid_to"]:
        raise DataError(
            f"{where}, columns 'valid_from'/'valid_to': {days['valid_from']} is after {days['valid_to']}; "
            f"expected the first and the last day of the data fitted ({MODEL_DATE_SPAN})"
        )
    times = {}
    for c in TIME_COLUMNS:
        text = str(getattr(fit, c + "_", ""))
        if _empty(text):
            setattr(fit, c + "_", "")
            continue
        try:
            t = pd.Timestamp(text)
        except (ValueError, TypeError):
            t = pd.NaT
        if t is pd.NaT:
            raise DataError(f"{where}, column {c!r}: {text!r} is not a time; expected ISO 8601 UTC")
        times[c] = t.tz_localize("UTC") if t.tzinfo is None else t.tz_convert("UTC")
    if len(times) == 2 and times["data_from"] > times["data_to"]:
        raise DataError(
            f"{where}, columns 'data_from'/'data_to': {times['data_from']} is after {times['data_to']}; "
            "expected the first and the last report fitted"
        )
