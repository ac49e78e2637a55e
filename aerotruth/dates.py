"""The dates aerotruth can model: one span for every command, campaign and reader.

The span is that of the Earth's magnetic field model, the narrowest of the date-dependent
models: IGRF-14 (through ppigrf) has coefficients from 1900-01-01 to 2030-01-01, and
aerotruth.sensors.magnetics refuses a year outside 1900-2029 (its `IGRF_YEARS`). Every
flight's flux valve, every wind report's true heading and every declination the methods
use comes from it, so a date outside the span cannot be simulated or corrected; and a
period of the year 1000 to 9999 is a typing error, not a campaign (3.3 million days).

`check_model_date(value, what)` is the one test (a campaign's dates, `--date` options, the
times of a measured file); `MODEL_EPOCH_S` is the same span in UTC epoch seconds for readers
of time columns. A refusal is a UserError (a ValueError, so that pydantic validators can
raise it too) naming `what` and the span.
"""

from __future__ import annotations

import datetime as _dt

from aerotruth.errors import UserError

FIRST_DATE = _dt.date(1900, 1, 1)
"""The first day aerotruth models (IGRF-14's first epoch)."""

LAST_DATE = _dt.date(2029, 12, 31)
"""The last day aerotruth models (IGRF-14's coefficients end on 2030-01-01)."""

MODEL_DATES = (FIRST_DATE, LAST_DATE)
"""(first, last) day, both included."""

MODEL_DATE_SPAN = f"{FIRST_DATE.isoformat()} to {LAST_DATE.isoformat()}"
"""The span as it is worded in messages and documentation."""

MODEL_DAYS = (LAST_DATE - FIRST_DATE).days + 1
"""The number of days in the span (47,482): no period or step of days can be longer."""

_EPOCH = _dt.datetime(1970, 1, 1, tzinfo=_dt.UTC)
MODEL_EPOCH_S = (
    (_dt.datetime.combine(FIRST_DATE, _dt.time(), _dt.UTC) - _EPOCH).total_seconds(),
    (_dt.datetime.combine(LAST_DATE + _dt.timedelta(days=1), _dt.time(), _dt.UTC) - _EPOCH).total_seconds(),
)
"""The span in UTC epoch seconds: [first day 00:00, the day after the last 00:00)."""

_REASON = "the span of IGRF-14, the magnetic field model"


def utc_date(value: _dt.date | _dt.datetime) -> _dt.date | None:
    """The UTC calendar day of a date or date-time (naive date-times are UTC); None when
    a date-time's offset takes it past the calendar's ends (year 1 or 9999), or for
    anything that is not a date."""
    if isinstance(value, _dt.datetime):
        if value.tzinfo is None or value.utcoffset() is None:
            return value.date()
        try:
            return value.astimezone(_dt.UTC).date()
        except OverflowError:
            return None
    return value if isinstance(value, _dt.date) else None


def check_model_date(value: _dt.date | _dt.datetime, what: str | None = None, given: str | None = None) -> _dt.date:
    """The UTC day of `value` if it lies in MODEL_DATES; otherwise a UserError worded as
    `<what>: expected a date from 1900-01-01 to 2029-12-31 (...), got <value>` (without the
    `<what>: ` prefix when `what` is None, as inside a pydantic validator, whose error
    names the field; `given`, the text the user wrote, is shown instead of `value`)."""
    day = utc_date(value)
    if day is not None and FIRST_DATE <= day <= LAST_DATE:
        return day
    shown = given if given is not None else value.isoformat() if isinstance(value, _dt.date) else repr(value)
    if isinstance(value, _dt.datetime) and day is not None and day != value.date():
        shown += f" (UTC {day.isoformat()})"
    text = f"expected a date from {MODEL_DATE_SPAN} ({_REASON}), got {shown}"
    raise UserError(f"{what}: {text}" if what else text)
