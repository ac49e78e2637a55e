"""Reading an approach log (CSV or Parquet; docs/data-formats.md, "Approach log") and its
runway geometry: a sidecar `<log>.runway.json` (or `<log stem>.runway.json`) or the Parquet
metadata key `runway` (one object for the whole log, or {"approaches": {id: object}} per
approach); without either, a 3,000 m runway with a standard installation
(aerotruth.analysis.fits.approach_log.DEFAULT_RUNWAY) is assumed and said."""

from __future__ import annotations

import difflib
import json
import math
from pathlib import Path

import numpy as np
import pandas as pd

from aerotruth.analysis.fits.approach_log import (
    DEFAULT_RUNWAY,
    DGPS,
    NUMERIC,
    OPTIONAL_NUMERIC,
    REQUIRED,
    RUNWAY_RANGES,
    approach_inputs,
    check_approach,
    event_codes,
)
from aerotruth.analysis.fits.filter import FitsSpec
from aerotruth.analysis.fits.ins_frame import beyond_drift
from aerotruth.errors import DataError
from aerotruth.measured.tables import numeric_column, read_csv_table

_RA_ARM = FitsSpec.model_fields["ra_lever_arm_m"].metadata  # its bounds, declared once
# per-row lever arms: the RA's as FitsSpec.ra_lever_arm_m (the same quantity, --ra-lever-arm);
# the TVPS camera's lateral offset within half the span of the largest airframe
LEVER_ARM_RANGES = {
    "ra_lever_arm_m": (
        next(m.ge for m in _RA_ARM if getattr(m, "ge", None) is not None),
        next(m.le for m in _RA_ARM if getattr(m, "le", None) is not None),
        "height of the reference point above the RA antenna, within an airframe's height",
    ),
    "tvps_lever_arm_m": (-40.0, 40.0, "y of the reference point minus the TVPS camera's, within half a wing span"),
}
# What a number of a length or time column can be (check_values): a runway-frame position
# within 1,000 km of the threshold (an INS drifts by kilometres, never by this), a radar
# altimeter's height within the range of any (2,500-5,000 ft), a TVPS camera's cross-track
# position within 1 km of the centreline (it sees the runway), a time in seconds (epoch
# seconds are 2e9); empty cells pass (the rules of each column say where they may be).
VALUE_LIMITS = {
    "time_s": (-1e10, 1e10, "s", "a time in seconds"),
    **{
        c: (-1e6, 1e6, "m", "a runway-frame position within 1,000 km of the threshold")
        for c in ("waas_x_m", "waas_y_m", "waas_z_m", "ins_x_m", "ins_y_m", "ins_z_m", *DGPS)
    },
    "ra_m": (-math.inf, 3000.0, "m", "a radar-altimeter height of at most 3,000 m (a radar altimeter's range)"),
    "tvps_y_m": (-1000.0, 1000.0, "m", "a TVPS cross-track position within 1 km of the centreline"),
}
# Units from the physics (check_physics): a length reading against the WAAS (or DGPS)
# position of the same instants. Reference errors taken as a bias per approach: WAAS 1.5 m
# (its bias is 1-2 m 95 %, plus the 12-s cyclic noise), DGPS 0.5 m (a survey offset of a few
# decimetres); each reading's own noise 0.5 m (TVPS 0.3 m, RA 0.15 m).
UNIT_FACTORS = {"feet": 1 / 0.3048, "inches": 1 / 0.0254, "centimetres": 100.0, "millimetres": 1000.0}
WAAS_SIGMA_M, DGPS_SIGMA_M, READING_SIGMA_M = 1.5, 0.5, 0.5
MIN_READINGS = 5  # rows with a reading and a reference an approach needs to count
# INS axis signs (ins_axis_signs): the WAAS epochs an approach needs (two 12-s cycles), the
# blocks of the standard error (one cycle), the INS's least motion beyond its drift
MIN_SIGN_EPOCHS, SIGN_BLOCK_S, MIN_SIGN_MOTION_M = 24, 12.0, 0.1
# an INS axis's unit is judged only where its motion beyond a drift follows the WAAS's
# (correlation at least this): along the course both are noise (the cubic takes the motion)
MIN_UNIT_CORRELATION = 0.9


def runway_geometry(path: Path) -> tuple[dict, str]:
    """({approach: geometry} or {None: geometry for all}, where it came from) of the log at
    `path` (module docstring): `<log>.runway.json` (or `<stem>.runway.json`) beside it, else
    the Parquet metadata key `runway`; a file may hold one geometry or
    {"approaches": {approach: geometry}}."""
    raw, src = None, ""
    for side in (path.with_name(path.name + ".runway.json"), path.with_suffix(".runway.json")):
        if side.is_dir():
            raise DataError(f"{side}: is a folder, expected the log's runway geometry (a JSON file)")
        if side.is_file():
            try:
                raw, src = json.loads(side.read_bytes().decode("utf-8")), str(side)
            except json.JSONDecodeError as exc:
                raise DataError(f"{side}: not JSON ({exc.msg} at line {exc.lineno})") from None
            except UnicodeDecodeError as exc:
                raise DataError(
                    f"{side}: not UTF-8 text (byte {exc.object[exc.start]:#04x} at offset {exc.start})"
                ) from None
            except RecursionError:
                raise DataError(f"{side}: nested too deep to be a runway geometry") from None
            except ValueError as exc:  # a number beyond int()'s 4,300 digits
                raise DataError(f"{side}: not a runway geometry ({str(exc).split(':')[0]})") from None
            break
    if raw is None and path.suffix.lower() in (".parquet", ".pq"):
        import pyarrow.parquet as pq

        meta = pq.read_schema(path).metadata or {}
        if b"runway" in meta:
            src = f"{path} (metadata key 'runway')"
            try:
                raw = json.loads(meta[b"runway"])
            except (json.JSONDecodeError, UnicodeDecodeError) as exc:
                raise DataError(f"{src}: not JSON ({getattr(exc, 'msg', exc)})") from None
            except (ValueError, RecursionError) as exc:  # a number beyond int()'s 4,300 digits, deep nesting
                raise DataError(
                    f"{src}: not a runway geometry ({str(exc).split(':')[0] or 'nested too deep'})"
                ) from None
    if raw is None:
        return {None: dict(DEFAULT_RUNWAY)}, "assumed (no runway geometry in the log)"
    if not isinstance(raw, dict):
        raise DataError(f"{src}: expected a JSON object with the runway geometry")
    items = raw["approaches"].items() if isinstance(raw.get("approaches"), dict) else [(None, raw)]
    out = {}
    for a, geo in items:
        where = src if a is None else f"{src}: approach {a!r}"
        if not isinstance(geo, dict):
            raise DataError(f"{where}: expected a JSON object with the runway geometry")
        for k in sorted(set(geo) - set(DEFAULT_RUNWAY)):  # other keys describe (airport, runway_frame, ...);
            near = difflib.get_close_matches(k, DEFAULT_RUNWAY, n=1, cutoff=0.8)  # a misspelt one would
            if near:  # silently leave its default in place
                raise DataError(f"{where}: unknown key {k!r}; did you mean {near[0]!r}?")
        g = dict(DEFAULT_RUNWAY)
        for k in DEFAULT_RUNWAY:
            if k in geo:
                try:
                    if isinstance(geo[k], bool):  # JSON true is not 1 m or 1 deg
                        raise TypeError
                    g[k] = float(geo[k])
                except (TypeError, ValueError, OverflowError):
                    raise DataError(f"{where}: key {k!r}: expected a number, got {geo[k]!r}"[:300]) from None
        for k, (lo, hi) in RUNWAY_RANGES.items():
            if not lo <= g[k] <= hi:
                raise DataError(f"{where}: key {k!r}: {g[k]:g} outside [{lo:g}, {hi:g}]")
        out[a] = g
    return out, src


def read_approach_log(path: str | Path) -> pd.DataFrame:
    """The log as a DataFrame with its columns checked (names, numbers)."""
    p = Path(path)
    if not p.is_file():
        raise DataError(
            f"{p}: {'is a folder' if p.is_dir() else 'no such file'} (expected an approach log, CSV or Parquet)"
        )
    try:
        df = pd.read_parquet(p) if p.suffix.lower() in (".parquet", ".pq") else read_csv_table(p)
    except Exception as exc:  # noqa: BLE001 - any reader failure is one line about the file
        raise DataError(
            f"{p}: cannot be read as CSV/Parquet ({type(exc).__name__}: {str(exc).splitlines()[0]})"
        ) from None
    missing = [c for c in REQUIRED if c not in df.columns]
    if missing:
        raise DataError(f"{p}: missing column {missing[0]!r} (an approach log needs {', '.join(REQUIRED)})")
    if any(c in df.columns for c in DGPS) and not all(c in df.columns for c in DGPS):
        raise DataError(f"{p}: DGPS columns must come together ({', '.join(DGPS)})")
    if len(df) == 0:
        raise DataError(f"{p}: no rows")
    df["event"] = event_codes(df["event"], str(p))
    for c in NUMERIC + OPTIONAL_NUMERIC:
        if c != "event" and c in df.columns:
            df[c] = numeric_column(df, c, str(p))
    if df["time_s"].isna().any():
        raise DataError(
            f"{p}: column 'time_s' data row {int(np.flatnonzero(df['time_s'].isna())[0]) + 1}: missing time"
        )
    for c in ("sv_change", "iono_update"):
        v = df[c].fillna(0.0)
        if not v.isin([0.0, 1.0]).all():
            raise DataError(f"{p}: column {c!r}: expected 0/1 flags, got {float(v[~v.isin([0.0, 1.0])].iloc[0]):g}")
        df[c] = v
    check_values(df, p)
    check_lever_arms(df, p)  # before the contract: its RA-WAAS height check adds the lever arm
    for a, g in df.groupby("approach", sort=False):
        check_approach(p, a, g)
    check_physics(df, p)
    return df


def check_values(df: pd.DataFrame, p) -> None:
    """Every time and length within what it can be (VALUE_LIMITS): an infinite or huge
    value would overflow the filter's sums or move the fix by as much. Empty cells pass."""
    for c, (lo, hi, unit, what) in VALUE_LIMITS.items():
        i, v = _first_outside(df, c, lo, hi)
        if i is not None:
            raise DataError(f"{p}: column {c!r} data row {i + 1}: {v:g} {unit}; expected {what}")


def _first_outside(df: pd.DataFrame, c: str, lo: float, hi: float) -> tuple[int | None, float]:
    """(row, value) of column c's first infinite value or value outside [lo, hi], (None, nan)
    when none is or the column is absent; empty cells pass."""
    if c not in df.columns:
        return None, float("nan")
    v = df[c].to_numpy(dtype=float)
    with np.errstate(invalid="ignore"):
        bad = np.flatnonzero(np.isinf(v) | (v < lo) | (v > hi))
    return (int(bad[0]), float(v[bad[0]])) if len(bad) else (None, float("nan"))


def check_lever_arms(df: pd.DataFrame, p) -> None:
    """The lever-arm columns within an airframe (LEVER_ARM_RANGES): a non-finite or huge
    value would move the threshold fix by as much, and the RA-WAAS check would blame the
    radar altimeter's units. Empty cells pass (the row's RA or TVPS reading is not used)."""
    for c, (lo, hi, what) in LEVER_ARM_RANGES.items():
        i, v = _first_outside(df, c, lo, hi)
        if i is not None:
            raise DataError(
                f"{p}: column {c!r} data row {i + 1}: {v:g} m; expected {lo:g} to {hi:g} m ({what}) or empty"
            )


def check_physics(df: pd.DataFrame, p) -> None:
    """What the contract of each approach (check_approach) cannot see, read from the physics
    across the log's approaches (rows already checked): the TVPS's and the radar altimeter's
    units against the WAAS (or DGPS) position of the same instants (`reading_units`), and
    each INS axis's sign and unit against the aircraft's motion the WAAS sees beyond a drift
    (`ins_axis_signs`). One DataError naming the column and what it looks like."""
    aps = [(a, approach_inputs(g)) for a, g in df.groupby("approach", sort=False)]
    dgps = all(c in df.columns for c in DGPS)
    for column, axis, lever in (("tvps_y_m", 1, "tvps"), ("ra_m", 2, "ra")):
        pairs, refs = [], set()
        for _, ap in aps:
            reading = ap.tvps if lever == "tvps" else ap.ra
            lev = ap.tvps_lever if lever == "tvps" else ap.ra_lever
            reading = reading + (0.0 if lev is None else lev)  # the reference point's y or height
            ref_rows = ap.dgps_rows[:, axis] if dgps else np.full(len(ap.t_rows), np.nan)
            use_dgps = np.isfinite(reading) & np.isfinite(ref_rows)
            if dgps and use_dgps.sum() >= MIN_READINGS:
                pairs.append((reading[use_dgps], ref_rows[use_dgps], DGPS_SIGMA_M))
                refs.add(f"dgps_{'xyz'[axis]}_m")
                continue
            waas = np.full(len(ap.t_rows), np.nan)  # WAAS at its epochs among the rows
            waas[np.searchsorted(ap.t_rows, ap.t_w)] = ap.waas[:, axis]
            ok = np.isfinite(reading) & np.isfinite(waas)
            if ok.sum() >= MIN_READINGS:
                pairs.append((reading[ok], waas[ok], WAAS_SIGMA_M))
                refs.add(f"waas_{'xyz'[axis]}_m")
        scale = reading_units(pairs)
        if scale is not None:
            k, se, unit = scale
            ref = "/".join(sorted(refs))
            what = "cross-track position" if lever == "tvps" else "height over the runway"
            guess = f"in {unit} ({UNIT_FACTORS[unit]:.4g} times the metres)?" if unit else "a unit or a scale?"
            raise DataError(
                f"{p}: column {column!r}: it reads {k:.3g} +- {se:.2g} times the {what} of {ref} on the same rows "
                f"({len(pairs)} approach{'es' if len(pairs) > 1 else ''}): {guess} expected metres"
            )
    flipped = ins_axis_signs([ap for _, ap in aps])
    if flipped:
        raise DataError(
            f"{p}: columns ins_x_m/ins_y_m/ins_z_m: {'; '.join(flipped)}; expected the runway frame, x along the "
            "course, y left, z up"
        )


def reading_units(pairs: list[tuple[np.ndarray, np.ndarray, float]]) -> tuple[float, float, str] | None:
    """Whether a length reading is in other units than metres, from (reading, reference,
    reference error sd) per approach: the scale k of reading = k reference (least squares
    through the origin: both measure the same point from the runway's origin) and a
    conservative standard error (the reference's error taken as a bias shared by all of an
    approach's readings, READING_SIGMA_M of noise on each reading). (k, se, the unit of
    UNIT_FACTORS within a factor 1.5 of k or '') when k exceeds 1 by more than 0.5 and 4
    standard errors (feet read 3.28 times the metres), else None."""
    sxy = sum(float(np.sum(r * x)) for r, x, _ in pairs)
    sxx = sum(float(np.sum(x * x)) for _, x, _ in pairs)
    if not pairs or sxx <= 0:
        return None
    k = sxy / sxx
    bias = sum((s * float(np.sum(np.abs(x)))) ** 2 for _, x, s in pairs)
    se = math.sqrt(k * k * bias + (READING_SIGMA_M * max(1.0, abs(k))) ** 2 * sxx) / sxx
    if not k - 4.0 * se > 1.5:
        return None
    unit, factor = min(UNIT_FACTORS.items(), key=lambda u: abs(math.log(k / u[1])))
    return k, se, unit if abs(math.log(k / factor)) < math.log(1.5) else ""


def ins_axis_signs(aps: list) -> list[str]:
    """The INS axes logged with the opposite sign, from the aircraft's motion beyond a drift
    (aerotruth.analysis.fits.ins_frame.beyond_drift: a cubic per approach and a step at each
    flagged WAAS epoch) at the WAAS epochs: the WAAS's such motion regressed on the INS's,
    b = sum(w i) / sum(i^2) pooled over the approaches with MIN_SIGN_EPOCHS epochs, which is
    about 1 for an axis in the frame (the INS follows the motion) and -1 for an axis of the
    other sign; its standard error from the scores summed over 12-s blocks (the WAAS's
    cyclic noise). An axis is said when b <= -0.5 with b + 4 se < 0 and the INS moves at
    least MIN_SIGN_MOTION_M beyond its drift; an axis in another unit, when b > 0 is off 1
    by more than a factor 1.5 and 4 se where the two motions correlate (r >= MIN_UNIT_CORRELATION;
    feet: b = 0.305, the INS moving 3.28 times as far).
    Unlike ins_frame.frame_error this needs no 3 approaches and no metre of motion: a sign
    (or a unit) is one number, not a rotation."""
    ws, ins, ts = [], [], []
    for ap in aps:
        ok = np.isfinite(ap.waas).all(axis=1) & np.isfinite(ap.ins_w).all(axis=1)
        if ok.sum() < MIN_SIGN_EPOCHS:
            continue
        t = ap.t_w[ok]
        ws.append(beyond_drift(t, ap.flags[ok], ap.waas[ok]))
        ins.append(beyond_drift(t, ap.flags[ok], ap.ins_w[ok]))
        ts.append(t)
    if not ws:
        return []
    sxy = sum(np.sum(w * i, axis=0) for w, i in zip(ws, ins, strict=True))
    syy = sum(np.sum(i * i, axis=0) for i in ins)
    sww = sum(np.sum(w * w, axis=0) for w in ws)
    n = sum(len(t) for t in ts)
    with np.errstate(invalid="ignore", divide="ignore"):
        b = sxy / syy
    scores = []
    for w, i, t in zip(ws, ins, ts, strict=True):
        block = np.floor((t - t[0]) / SIGN_BLOCK_S).astype(int)
        e = i * (w - b * i)
        scores += [e[block == k].sum(axis=0) for k in np.unique(block)]
    s = np.array(scores)
    g = len(s)
    with np.errstate(invalid="ignore", divide="ignore"):
        se = np.sqrt((s**2).sum(axis=0) * g / max(g - 1, 1)) / syy
    motion = np.sqrt(syy / n)
    with np.errstate(invalid="ignore", divide="ignore"):
        r = sxy / np.sqrt(sww * syy)  # the INS's and the WAAS's motions beyond a drift, correlated
    out = []
    for j, name in enumerate("xyz"):
        if motion[j] >= MIN_SIGN_MOTION_M and b[j] <= -0.5 and b[j] + 4.0 * se[j] < 0.0:
            out.append(
                f"ins_{name}_m has the opposite sign (beyond a drift it moves against waas_{name}_m: "
                f"{b[j]:+.2f} +- {se[j]:.2f} m per m over {len(ws)} approach(es))"
            )
        elif r[j] >= MIN_UNIT_CORRELATION and b[j] > 0 and abs(math.log(b[j])) > math.log(1.5):
            if abs(b[j] - 1.0) > 4.0 * se[j]:  # the INS reads k = 1/b times the motion: another unit
                k = 1.0 / b[j]
                unit, factor = min(UNIT_FACTORS.items(), key=lambda u: abs(math.log(k / u[1])))
                guess = f"in {unit}?" if abs(math.log(k / factor)) < math.log(1.5) else "a unit or a scale?"
                out.append(
                    f"ins_{name}_m moves {k:.3g} times as far as waas_{name}_m beyond a drift "
                    f"({b[j]:.2f} +- {se[j]:.2f} m of WAAS per m over {len(ws)} approach(es)): {guess} expected metres"
                )
    return out
