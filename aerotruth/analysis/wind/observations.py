"""The observation table (docs/data-formats.md) as the wind paper's method reads it:
aircraft wind reports with the reference-model winds at each, one row per (report, model),
checked and normalised once (`validate_observations`); every failure is one DataError
naming the table, the column and the data row."""

from __future__ import annotations

import datetime as dt
import math
from typing import Any

import numpy as np
import pandas as pd
from numba import njit

from aerotruth.contracts import OBSERVATION_OPTIONAL_NUMERIC, OBSERVATION_REQUIRED
from aerotruth.dates import MODEL_DATE_SPAN, MODEL_EPOCH_S
from aerotruth.errors import DataError

REQUIRED_COLUMNS = OBSERVATION_REQUIRED
OPTIONAL_NUMERIC = OBSERVATION_OPTIONAL_NUMERIC


def _numeric(df: pd.DataFrame, col: str, source: str) -> np.ndarray:
    s = df[col]
    if s.dtype.kind == "b" or (s.dtype == object and s.map(lambda v: isinstance(v, bool)).any()):
        raise DataError(f"{source}: column '{col}' holds true/false, expected numbers")
    if s.dtype.kind in "iuf":
        return s.to_numpy(dtype=float)
    num = pd.to_numeric(s, errors="coerce")
    bad = num.isna() & s.notna() & (s.astype(str).str.strip() != "")
    if bad.any():
        i = int(np.flatnonzero(bad.to_numpy())[0])
        raise DataError(f"{source}: column '{col}', data row {i + 1}: {s.iloc[i]!r} is not a number")
    return num.to_numpy(dtype=float)


def _times(df: pd.DataFrame, source: str) -> np.ndarray:
    """UTC epoch seconds from epoch numbers or ISO-8601 text, checked to lie in the dates
    aerotruth models (aerotruth.dates: the span of the magnetic field model every true
    heading and declination comes from)."""
    t = _parse_times(df, source)
    lo, hi = MODEL_EPOCH_S
    bad = (t < lo) | (t >= hi)  # NaN (empty cells) passes
    if bad.any():
        i = int(np.flatnonzero(bad)[0])
        v = df["time"].iloc[i]
        v = v.item() if isinstance(v, np.generic) else v
        hint = " (milliseconds?)" if lo <= t[i] / 1000.0 < hi else ""
        raise DataError(
            f"{source}: column 'time', data row {i + 1}: {v!r} is not a time from {MODEL_DATE_SPAN} in UTC "
            f"epoch seconds{hint} (the dates aerotruth models: the span of the magnetic field model)"
        )
    return t


def _parse_times(df: pd.DataFrame, source: str) -> np.ndarray:
    s = df["time"]
    if s.dtype.kind == "b" or (s.dtype == object and s.map(lambda v: isinstance(v, bool)).any()):
        raise DataError(f"{source}: column 'time' holds true/false, expected UTC epoch seconds or ISO-8601 times")
    if s.dtype.kind in "iuf":
        return s.to_numpy(dtype=float)
    if s.dtype.kind == "M":
        ts = pd.to_datetime(s, utc=True)
    else:
        num = pd.to_numeric(s, errors="coerce")
        if num.notna().sum() == s.notna().sum():
            return num.to_numpy(dtype=float)
        ts = pd.to_datetime(s.where(num.isna()), utc=True, errors="coerce", format="ISO8601")
        bad = ts.isna() & num.isna() & s.notna()
        if bad.any():
            i = int(np.flatnonzero(bad.to_numpy())[0])
            raise DataError(
                f"{source}: column 'time', data row {i + 1}: {s.iloc[i]!r} is neither UTC epoch seconds nor ISO-8601"
            )
        iso = ((ts - pd.Timestamp("1970-01-01", tz="UTC")) / pd.Timedelta(1, "s")).to_numpy(dtype=float)
        return np.where(num.notna().to_numpy(), num.to_numpy(dtype=float), iso)
    return ((ts - pd.Timestamp("1970-01-01", tz="UTC")) / pd.Timedelta(1, "s")).to_numpy(dtype=float)


_RANGES = {
    "lat": (-90.0, 90.0),
    "lon": (-180.0, 360.0),
    "wind_speed_kt": (0.0, 500.0),
    "ref_wind_speed_kt": (0.0, 500.0),
    "wind_dir_deg": (-180.0, 360.0),
    "ref_wind_dir_deg": (-180.0, 360.0),
    "pressure_altitude_ft": (-2000.0, 70000.0),
    "tas_kt": (0.0, 1000.0),
    "heading_deg": (-180.0, 360.0),
    "heading_mag_deg": (-180.0, 360.0),
    "declination_deg": (-180.0, 180.0),
    "roll_deg": (-180.0, 180.0),
}
# directions read either way round: [0, 360] or signed [-180, 180] (ARINC 429 carries
# heading and wind angle as signed binary, labels 314, 320 and 322), kept as [0, 360]
DIRECTIONS = ("wind_dir_deg", "ref_wind_dir_deg", "heading_deg", "heading_mag_deg")
WIND_DIRECTIONS = DIRECTIONS[:2]


@njit(cache=True, nogil=True)
def _outside(v: np.ndarray, lo: float, hi: float, keep: np.ndarray, required: bool) -> int:
    """The first row of v outside [lo, hi] (NaN is not: an empty cell), -1 if none; with
    `required`, rows whose v is not finite are cleared in `keep`."""
    for i in range(len(v)):
        x = v[i]
        if x < lo or x > hi:
            return i
        if required and not math.isfinite(x):
            keep[i] = False
    return -1


# a wind direction column in radians: at least this many values, all within [0, 2 pi] and
# spanning more than 0.2 (in degrees: every wind from within 6.3 deg east of north, none
# from west of it). Headings are checked against the wind triangle (heading_errors).
_RADIANS_MIN_VALUES = 200


def _check_degrees(v: np.ndarray, col: str, source: str) -> None:
    """DataError when a wind direction column reads as radians (comment above)."""
    fin = v[np.isfinite(v)]
    if len(fin) < _RADIANS_MIN_VALUES:
        return
    lo, hi = float(fin.min()), float(fin.max())
    if 0.0 <= lo and hi <= 2 * math.pi and hi - lo > 0.2:
        raise DataError(
            f"{source}: column '{col}': all {len(fin)} values lie within [{lo:.3g}, {hi:.3g}]: in radians? "
            "expected degrees"
        )


def _labels(values: pd.Series, fill: str | None = None, lower: bool = False, sort: bool = False) -> pd.Categorical:
    """Text labels as a Categorical: stripped (and lower-cased if `lower`); empty or missing
    -> `fill` (None: missing). Categories in the order the labels first appear, or sorted
    (`sort`: the reference models and flights, whose order enters the numbers, e.g. a
    consistency test's contrast, and must not follow the order of the rows)."""
    codes, uniques = pd.factorize(values, use_na_sentinel=True)
    names = np.array([(str(u).strip().lower() if lower else str(u).strip()) for u in uniques] + [""], dtype=object)
    names[names == ""] = fill if fill is not None else np.nan
    ucodes, cats = pd.factorize(pd.Series(names, dtype=object), use_na_sentinel=True, sort=sort)
    return pd.Categorical.from_codes(ucodes[codes], categories=pd.Index(cats, dtype=object))  # codes -1 -> last -> fill


def validate_observations(obs: pd.DataFrame, source: str = "observation table") -> pd.DataFrame:
    """An observation table (docs/data-formats.md) checked and normalised: `time_s` in UTC
    epoch seconds, numbers as float, `aircraft` and `ref_source` (filled "ref") as
    categoricals, sorted by aircraft, time and reference; rows with an empty required cell
    are dropped (count in attrs["dropped_empty"]), repeated (aircraft, time, ref_source)
    rows too (attrs["dropped_duplicates"]). Raises DataError (a ValueError) naming `source`
    and the column on anything else."""
    if not isinstance(obs, pd.DataFrame):
        raise DataError(f"{source}: expected a pandas DataFrame, got {type(obs).__name__}")
    missing = [c for c in REQUIRED_COLUMNS if c not in obs.columns]
    if missing:
        raise DataError(
            f"{source}: missing column '{missing[0]}' (an observation table needs {', '.join(REQUIRED_COLUMNS)})"
        )
    if len(obs) == 0:
        raise DataError(f"{source}: no rows")
    # the columns: np.ndarray for numbers and times, pd.Categorical for labels
    out: dict[str, Any] = {"aircraft": _labels(obs["aircraft"]), "time_s": _times(obs, source)}
    for c in REQUIRED_COLUMNS[2:] + tuple(c for c in OPTIONAL_NUMERIC if c in obs.columns):
        out[c] = _numeric(obs, c, source)
    keep = np.ones(len(obs), dtype=bool)  # rows with every required number (NaN: an empty cell, dropped)
    for c in out:
        if c == "aircraft":
            continue
        lo, hi = _RANGES.get(c, (-np.inf, np.inf))
        i = _outside(out[c], lo, hi, keep, c == "time_s" or c in REQUIRED_COLUMNS)
        if i >= 0:
            raise DataError(f"{source}: column '{c}', data row {i + 1}: {out[c][i]:g} outside [{lo:g}, {hi:g}]")
        if c in DIRECTIONS:
            if c in WIND_DIRECTIONS:
                _check_degrees(out[c], c, source)
            if (out[c] < 0).any():
                out[c] = np.where(out[c] < 0, out[c] + 360.0, out[c])
    out["ref_source"] = (
        _labels(obs["ref_source"], "ref") if "ref_source" in obs.columns else pd.Categorical(np.full(len(obs), "ref"))
    )
    if "flight" in obs.columns:  # `phase` is not used by the method
        out["flight"] = _labels(obs["flight"], "")
    if "heading_input" in obs.columns:  # a word, in any case ("TRUE", "Magnetic")
        out["heading_input"] = _labels(obs["heading_input"], "", lower=True)
    if "heading_input" in out:
        vals = set(out["heading_input"].categories) - {"", "true", "magnetic"}
        if vals:
            raise DataError(f"{source}: column 'heading_input': {sorted(vals)[0]!r}, expected 'magnetic' or 'true'")
    ac_code = out["aircraft"].codes
    keep &= ac_code >= 0
    ref_code = out["ref_source"].codes
    order = _sort_order(ac_code, out["time_s"], ref_code)
    order = order[keep[order]]
    a, t, r = ac_code[order], out["time_s"][order], ref_code[order]
    dup = np.zeros(len(order), dtype=bool)
    dup[1:] = (a[1:] == a[:-1]) & (t[1:] == t[:-1]) & (r[1:] == r[:-1])
    if dup.any():
        _check_repeats(out, order, dup, source)
    order = order[~dup]
    if len(order) == 0:
        raise DataError(f"{source}: every row has an empty required cell")
    if len(order) == len(obs) and np.array_equal(order, np.arange(len(order))):  # already in order: no copies
        df = pd.DataFrame(out, copy=False)
    else:
        df = pd.DataFrame(
            {k: (v[order] if isinstance(v, np.ndarray) else v.take(order)) for k, v in out.items()}, copy=False
        )  # copy=False: no consolidation into one block (a copy of every column)
    _check_report_rows(df, source)
    df.attrs.update(source=source, dropped_empty=int((~keep).sum()), dropped_duplicates=int(dup.sum()))
    return df


def _check_repeats(out: dict[str, Any], order: np.ndarray, dup: np.ndarray, source: str) -> None:
    """Rows repeating an (aircraft, time, ref_source) must repeat it exactly (a file written
    twice, a merge that overlaps): they are dropped and counted. Two such rows that differ
    in any column are two different reports of one instant, and keeping either would be a
    guess: DataError naming the first pair (its data rows, aircraft, time, reference and
    the column). `order` the rows in (aircraft, time, ref_source) order, `dup[k]` whether
    row order[k] repeats order[k - 1]."""
    k = np.flatnonzero(dup)
    prev, cur = order[k - 1], order[k]
    differs = np.zeros(len(k), dtype=bool)
    first_col = np.full(len(k), "", dtype=object)
    for c, v in out.items():
        if c in ("aircraft", "time_s", "ref_source"):
            continue
        if isinstance(v, pd.Categorical):
            x, y = v.codes[prev], v.codes[cur]
            d = x != y
        else:
            x, y = v[prev], v[cur]
            d = (x != y) & ~(np.isnan(x) & np.isnan(y))
        first_col[d & ~differs] = c
        differs |= d
    if not differs.any():
        return
    j = int(np.flatnonzero(differs)[0])
    i0, i1, c = int(prev[j]), int(cur[j]), str(first_col[j])
    v = out[c]
    shown = (
        (repr(v[i0]), repr(v[i1]))
        if isinstance(v, pd.Categorical)
        else tuple("empty" if np.isnan(x) else f"{x:g}" for x in (v[i0], v[i1]))
    )
    when = dt.datetime.fromtimestamp(float(out["time_s"][i0]), tz=dt.UTC).isoformat().replace("+00:00", "Z")
    lo, hi = sorted((i0, i1))
    raise DataError(
        f"{source}: data rows {lo + 1} and {hi + 1} are one report (aircraft {out['aircraft'][i0]}, time {when}, "
        f"ref_source {out['ref_source'][i0]}) with different '{c}' ({shown[0]} vs {shown[1]}); expected one row "
        "per aircraft, time and reference model (exact repeats are dropped and counted)"
    )


def _sort_order(ac: np.ndarray, t: np.ndarray, ref: np.ndarray) -> np.ndarray:
    """np.lexsort((ref, t, ac)) up to rows with a missing aircraft or time (dropped after):
    rows by aircraft, time, reference model. Tables often come so already: then the identity
    (checked, stopping at the first row out of order). Else a stable sort by time, then by
    aircraft (a radix sort of small integers), then each run of rows of one aircraft and time
    put in reference order: two sorts where lexsort makes three, and a table made of
    time-ordered blocks (one per aircraft or per model file) is sorted by time in one merge
    of its blocks (measured on the 1.1 M-row benchmark table with every report's rows to
    reorder: 71 ms against lexsort's 95)."""
    n = len(ac)
    if _ordered(ac, t, ref):
        return np.arange(n)
    o = np.argsort(t, kind="stable")  # NaN times last; their rows are dropped
    a = ac[o]
    if n and a.max() < 2**16 - 1:
        a = a.astype(np.uint16)  # missing aircraft (-1) last; their rows are dropped
    o = o[np.argsort(a, kind="stable")]
    _order_ties(ac, t, ref, o)
    return o


@njit(cache=True, nogil=True)
def _order_ties(ac: np.ndarray, t: np.ndarray, ref: np.ndarray, o: np.ndarray) -> None:
    """In place: within each run of o with one aircraft and time, the rows by reference
    (stable insertion sort: runs hold one row per reference model)."""
    for k in range(1, len(o)):
        j = o[k]
        m = k
        while m > 0:
            i = o[m - 1]
            if ac[i] != ac[j] or t[i] != t[j] or ref[i] <= ref[j]:
                break
            o[m] = i
            m -= 1
        o[m] = j


@njit(cache=True, nogil=True)
def _ordered(ac: np.ndarray, t: np.ndarray, ref: np.ndarray) -> bool:
    """Whether the rows are in (aircraft, time, reference) order (NaN times: not)."""
    for j in range(1, len(ac)):
        i = j - 1
        if ac[j] != ac[i]:
            if ac[j] < ac[i]:
                return False
            continue
        if t[j] > t[i]:
            continue
        if not (t[j] == t[i] and ref[j] >= ref[i]):
            return False
    return True


REPORT_OWN_COLUMNS = (
    "wind_speed_kt",
    "wind_dir_deg",
    "heading_deg",
    "tas_kt",
    "heading_mag_deg",
    "declination_deg",
    "lat",
    "lon",
    "roll_deg",
)


def _check_report_rows(df: pd.DataFrame, source: str) -> None:
    """The rows of one report (same aircraft and time, one per reference model) must agree
    on the aircraft's own values (REPORT_OWN_COLUMNS): `heading_errors` takes them once per
    report. `df` sorted by aircraft and time."""
    ac, t = df["aircraft"].cat.codes.to_numpy(), df["time_s"].to_numpy()
    same_rep = (ac[1:] == ac[:-1]) & (t[1:] == t[:-1])  # row i+1 repeats row i's report
    if not same_rep.any():
        return
    for c in REPORT_OWN_COLUMNS:
        if c not in df.columns:
            continue
        v = df[c].to_numpy()
        i = _first_disagreement(v, same_rep)
        if i >= 0:
            raise DataError(
                f"{source}: column '{c}': the rows of one report (aircraft {df['aircraft'].iloc[i]}, "
                f"time {t[i]:.3f}) differ ({v[i - 1]:g} vs {v[i]:g}); a report's own values must be "
                f"the same on each reference model's row"
            )


@njit(cache=True, nogil=True)
def _first_disagreement(v: np.ndarray, same_rep: np.ndarray) -> int:
    """The first row i whose value differs from row i - 1 of the same report (same_rep[i - 1];
    both empty is the same), -1 if none."""
    for k in range(len(same_rep)):
        if same_rep[k] and v[k + 1] != v[k] and not (math.isnan(v[k + 1]) and math.isnan(v[k])):
            return k + 1
    return -1
