"""Raw Mode-S / ADS-B frames (a hex message and its reception time per row) decoded into the
state table of aerotruth.measured.traffic: one row per BDS 6,0 reply with the aircraft's
position, ground velocity, pressure altitude and true airspeed around it.

The decoding is pyModeS's (version 3 or later, https://github.com/junzis/pyModeS). pyModeS is
licensed under the GNU GPL v3, so it is an optional extra of aerotruth (MIT): `pip install
"aerotruth[modes]"`. aerotruth imports and works without it; only reading raw frames needs it
(a file of frames read without it is one DataError saying so). pyModeS is imported here only,
inside the functions that decode.

Input: a table (CSV, JSON lines or Parquet) with a hex message column (MESSAGE_COLUMNS, any
case: rawmsg, msg, message, hex, frame; 14 or 28 hex digits, AVR's `*...;` accepted), a
reception time (TIME_COLUMNS: timestamp, ts, time, mintime; epoch s or ms, or ISO-8601) and
optionally the receiver's icao24. Rows whose message is not a frame are counted and left out;
frames repeated within DUPLICATE_S (one reply heard twice, or two receivers merged) count once.

What is decoded, through one `pyModeS.PipeDecoder` fed in time order (DF 0, 4, 5 and 16
carry nothing the wind method uses: counted, not decoded):

* DF17/18 extended squitter with a valid CRC (one with a parity error is counted and left out
  before decoding, where it could pair its CPR with a good frame): airborne positions (CPR: global decoding from
  an even/odd pair at most PAIR_WINDOW_S apart, then local decoding against the aircraft's
  last accepted position, at most LOCAL_WINDOW_S old; each frame is then resolved locally
  against the position the decoder gave it, so that every frame carries its own position and
  not its pair partner's), barometric altitude (type codes 9-18; the GNSS height of 20-22 is
  not a pressure altitude), airborne velocity (ground speed and track; the airspeed-heading
  subtype where an aircraft sends it) and operational status (the heading reference: HRD
  of ADS-B versions 1 and 2; version 0 sends magnetic headings);
* DF20/21 Comm-B: pyModeS infers the register (BDS 4,0 / 5,0 / 6,0 by their status bits and
  ranges, 5,0 against 6,0 scored with the aircraft's recent state) and decodes BDS 5,0 (roll,
  true track, ground speed, track rate, TAS) and BDS 6,0 (magnetic heading, IAS, Mach,
  barometric and inertial vertical rate). Their address is overlaid on the parity (AP): the
  CRC remainder is the address, and a reply is kept only when that address is one the file
  also has in plain text, from a CRC-valid DF17/18 or a DF11 whose parity is clean (its
  remainder holds no more than the interrogator code); the others are counted as rejected.
  pyModeS's own cross-checks reject a Comm-B reply whose DF20 altitude or BDS 5,0 / 6,0 values
  disagree with the aircraft's ADS-B (counted too).

The state table (time alignment): one row per accepted BDS 6,0 reply, at its time, with

* TAS, roll (and ground speed and true track, used below) from the aircraft's BDS 5,0 reply
  nearest in time, at most COMM_B_PAIR_S away on either side (a radar's beam dwell asks for
  both registers within a fraction of a second; their instants differ, so in a turn the
  heading and the TAS's track differ by the turn rate times that offset);
* position and ground speed and track from the latest ADS-B position and velocity at or
  before the reply, at most STATE_AGE_S old (ADS-B sends each twice a second); without an
  ADS-B velocity, the paired BDS 5,0's ground speed and true track;
* pressure altitude: a DF20 reply's own altitude, else the latest barometric altitude (ADS-B
  position or DF20 reply) at most STATE_AGE_S old;
* vertical rate: the reply's barometric vertical rate, else its inertial one, else the latest
  ADS-B vertical rate at most STATE_AGE_S old.

An aircraft sending the airspeed-heading velocity subtype with a TAS adds one row per such
message (heading magnetic or true as its operational status says; without one, left out),
with the nearest BDS 5,0's ground speed and track. The ground speed of the ground-velocity
subtype is taken exact: pyModeS truncates it to the knot below (a mean 0.5 kt short, which a
wind triangle would take as a head wind); the integer east and north components are the one
pair that gives both the decoded track and that truncated speed.

Rows missing a value the wind method needs stay in the table as NaN; the traffic reader
counts and leaves them out. The counts of every step are in the table's attrs["frames"].
"""

from __future__ import annotations

import math
import re
from typing import Any

import numpy as np
import pandas as pd

from aerotruth.errors import DataError
from aerotruth.measured.kinds import epoch_seconds

MESSAGE_COLUMNS = ("rawmsg", "msg", "message", "hex", "frame", "raw")
TIME_COLUMNS = ("timestamp", "ts", "time", "mintime", "time_s")
ICAO_COLUMNS = ("icao24", "icao", "address")
INSTALL = "install aerotruth[modes] (pyModeS, GPL-3) to decode raw frames"

PAIR_WINDOW_S = 10.0  # even/odd CPR frames of one global decoding
LOCAL_WINDOW_S = 30.0  # age of the last accepted position a single CPR frame is decoded against
DUPLICATE_S = 1.0  # the same frame again within this time counts once
COMM_B_PAIR_S = 5.0  # BDS 5,0 reply nearest a BDS 6,0 reply, on either side
STATE_AGE_S = 3.0  # age of the latest ADS-B position, velocity, altitude taken for a sample
DECODED_DFS = (11, 17, 18, 20, 21)  # the formats that carry what the wind method needs

_HEX = re.compile(r"^[0-9A-Fa-f]+$")
# (pyModeS result key, column of the decoded table)
_FIELDS = (
    ("icao", "icao"),
    ("df", "df"),
    ("bds", "bds"),
    ("crc_valid", "crc_valid"),
    ("typecode", "typecode"),
    ("latitude", "latitude"),
    ("longitude", "longitude"),
    ("cpr_format", "cpr_format"),
    ("cpr_lat", "cpr_lat"),
    ("cpr_lon", "cpr_lon"),
    ("altitude", "altitude"),
    ("subtype", "subtype"),
    ("groundspeed", "groundspeed"),
    ("track", "track"),
    ("vertical_rate", "vertical_rate"),
    ("heading", "adsb_heading"),
    ("airspeed", "airspeed"),
    ("airspeed_type", "airspeed_type"),
    ("hrd", "hrd"),
    ("version", "version"),
    ("roll", "roll"),
    ("true_track", "true_track"),
    ("track_rate", "track_rate"),
    ("true_airspeed", "tas"),
    ("magnetic_heading", "heading"),
    ("indicated_airspeed", "ias"),
    ("mach", "mach"),
    ("baro_vertical_rate", "vrate_baro"),
    ("inertial_vertical_rate", "vrate_inertial"),
    ("altitude_mismatch", "altitude_mismatch"),
    ("velocity_mismatch", "velocity_mismatch"),
)
_FLAGS = ("icao", "df", "bds", "crc_valid", "airspeed_type", "altitude_mismatch", "velocity_mismatch")
# BDS 5,0's ground speed shares a name with ADS-B's: kept apart in the decoded table
_COMM_B_GS = "gs50"


def _pick(columns, names) -> str | None:
    lower = {str(c).strip().lower(): c for c in columns}
    return next((lower[n] for n in names if n in lower), None)


def _clean_messages(values: pd.Series) -> pd.Series:
    """Messages as upper-case hex text, AVR's `*` and `;` and blanks taken off."""
    return values.astype("string").str.strip().str.strip("*;@").str.upper()


def frame_columns(df: pd.DataFrame) -> tuple[str, str, str | None] | None:
    """(message, time, icao24-or-None) columns when the table holds raw frames, else None: a
    message column whose first values are 14 or 28 hex digits, and a time column."""
    msg, time = _pick(df.columns, MESSAGE_COLUMNS), _pick(df.columns, TIME_COLUMNS)
    if msg is None or time is None:
        return None
    head = _clean_messages(df[msg].dropna().head(50))
    if len(head) == 0 or not head.str.len().isin((14, 28)).mean() > 0.5:
        return None
    return msg, time, _pick(df.columns, ICAO_COLUMNS)


def _pymodes(source: str) -> Any:
    try:
        import pyModeS
    except ImportError:
        raise DataError(f"{source}: raw Mode-S frames: {INSTALL}") from None
    if not hasattr(pyModeS, "PipeDecoder"):
        version = getattr(pyModeS, "__version__", "< 3")
        raise DataError(f"{source}: raw Mode-S frames need pyModeS >= 3 (found {version}): {INSTALL}")
    import pyModeS.position
    import pyModeS.util

    return pyModeS


def exact_groundspeed(gs: np.ndarray, track_deg: np.ndarray) -> np.ndarray:
    """The ground speed of an ADS-B ground-velocity message (subtype 1) from pyModeS's
    truncated one (int of the exact speed) and its track: the speed of the integer east and
    north components (kt) that give both. Where none does (not subtype 1 data), `gs`."""
    gs = np.asarray(gs, float)
    trk = np.asarray(track_deg, float)
    s, c = np.sin(np.radians(trk)), np.cos(np.radians(trk))
    out = np.full(gs.shape, np.nan)
    with np.errstate(invalid="ignore"):
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                ve = np.round((gs + 0.5) * s) + dx
                vn = np.round((gs + 0.5) * c) + dy
                speed = np.hypot(ve, vn)
                angle = np.degrees(np.arctan2(ve, vn)) % 360.0
                same = (np.abs((angle - trk + 180.0) % 360.0 - 180.0) < 1e-9) & (np.floor(speed) == gs)
                out = np.where(same & np.isnan(out), speed, out)
    return np.where(np.isfinite(out), out, gs)


def decode_frames(df: pd.DataFrame, source: str) -> pd.DataFrame:
    """Every frame of a raw-frames table decoded (module docstring): one row per message of
    the DECODED_DFS kept (column `row`: its row in `df`), with `time_s`, `icao`, `df`, `bds`
    ("5,0", ...), `accepted` (a Comm-B reply whose address is known, an ADS-B message with a
    valid CRC) and the decoded fields; the counts in attrs["frames"]."""
    cols = frame_columns(df)
    if cols is None:
        raise DataError(f"{source}: no column of hex Mode-S messages ({', '.join(MESSAGE_COLUMNS)}) with a time")
    msg_col, time_col, icao_col = cols
    pms = _pymodes(source)
    counts: dict[str, int] = {"rows": len(df)}
    msgs = _clean_messages(df[msg_col])
    good = msgs.notna() & msgs.str.len().isin((14, 28)) & msgs.str.match(_HEX).fillna(False).astype(bool)
    counts["not a frame"] = int((~good).sum())
    times = epoch_seconds(df[time_col], source, str(time_col)).to_numpy(float)
    good &= np.isfinite(times)
    table = pd.DataFrame({"row": np.arange(len(df)), "msg": msgs, "time_s": times})[good.to_numpy()]
    if icao_col is not None:
        table["given_icao"] = df[icao_col].astype("string").str.strip().str.upper().to_numpy()[good.to_numpy()]
    table = table.sort_values(["msg", "time_s"], kind="stable")
    same = (table["msg"].to_numpy()[1:] == table["msg"].to_numpy()[:-1]) & (
        np.diff(table["time_s"].to_numpy()) < DUPLICATE_S
    )
    table = table[~np.r_[False, same]]
    counts["repeated frames"] = int(same.sum())
    first = table["msg"].str[:2].map(lambda h: int(h, 16) >> 3)
    counts.update({f"DF{d}": int(n) for d, n in first.value_counts().sort_index().items()})
    table = table[first.isin(DECODED_DFS).to_numpy()].sort_values(["time_s", "row"], kind="stable")
    # extended squitters with a parity error never reach the decoder: it would pair their CPR
    es = table["msg"].str[:2].map(lambda h: int(h, 16) >> 3).isin((17, 18)).to_numpy()
    crc = pms.util.crc
    bad = np.zeros(len(table), bool)
    bad[es] = [crc(m) != 0 for m in table["msg"].to_numpy()[es]]
    counts["ADS-B parity errors"] = int(bad.sum())
    table = table[~bad]
    if len(table) == 0:
        raise DataError(f"{source}: column {msg_col!r}: no Mode-S frame of DF {', '.join(map(str, DECODED_DFS))}")

    pipe = pms.PipeDecoder(pair_window=PAIR_WINDOW_S, local_ref_window=LOCAL_WINDOW_S)
    decode = pipe.decode
    results = [decode(m, timestamp=t) for m, t in zip(table["msg"].tolist(), table["time_s"].tolist(), strict=True)]
    pipe.flush()

    n = len(results)
    out: dict[str, list] = {name: [None] * n for _, name in _FIELDS}
    out[_COMM_B_GS] = [None] * n
    names = dict(_FIELDS)
    names_commb = {**names, "groundspeed": _COMM_B_GS}
    for i, r in enumerate(results):
        for key, v in r.items():
            name = (names_commb if r.get("df") in (20, 21) else names).get(key)
            if name is not None:
                out[name][i] = v
    dec = pd.DataFrame(out, index=table.index)
    dec.insert(0, "time_s", table["time_s"].to_numpy())
    dec.insert(0, "row", table["row"].to_numpy())
    dec["icao"] = dec["icao"].astype("string").str.upper()
    dec["df"] = dec["df"].astype(int)
    numeric = [n for _, n in _FIELDS if n not in _FLAGS] + [_COMM_B_GS]
    for c in numeric:
        dec[c] = pd.to_numeric(dec[c], errors="coerce").astype(float)

    # addresses: plain text in CRC-valid DF17/18, or DF11 with a clean parity
    adsb = dec["df"].isin((17, 18)).to_numpy() & (dec["crc_valid"] == True).to_numpy()  # noqa: E712 - None is not True
    known = set(dec.loc[adsb, "icao"])
    df11 = dec["df"].to_numpy() == 11
    if df11.any():
        crc = np.array([pms.Message(m).crc for m in table["msg"].to_numpy()[df11]])
        known |= set(dec.loc[df11, "icao"].to_numpy()[crc < 0x80])
    commb = dec["df"].isin((20, 21)).to_numpy()
    seen = dec["icao"].isin(known).to_numpy()
    accepted = np.where(commb, seen, adsb)
    counts["Comm-B replies"] = int(commb.sum())
    counts["Comm-B rejected (address not seen in DF17/18/11)"] = int((commb & ~seen).sum())
    if icao_col is not None:
        given = table["given_icao"].to_numpy()
        differ = pd.notna(given) & (given != dec["icao"].to_numpy())
        differ &= commb | adsb
        counts["frames whose icao24 column differs from the frame's address"] = int(differ.sum())
        accepted &= ~differ
    flagged = (dec["altitude_mismatch"] == True).to_numpy() | (dec["velocity_mismatch"] == True).to_numpy()  # noqa: E712
    counts["rejected by pyModeS's cross-checks with the aircraft's ADS-B"] = int((accepted & flagged).sum())
    dec["accepted"] = accepted & ~flagged

    # every airborne position at its own frame: local decoding against the decoder's position
    pos = accepted & (dec["bds"] == "0,5").to_numpy() & dec["latitude"].notna().to_numpy()
    if pos.any():
        p = dec.loc[pos, ["cpr_format", "cpr_lat", "cpr_lon", "latitude", "longitude"]].to_numpy()
        with_ref = pms.position.airborne_position_with_ref
        own = [with_ref(int(f), int(a), int(b), la, lo) for f, a, b, la, lo in p]
        dec.loc[pos, ["latitude", "longitude"]] = np.array(own)
    velocity = accepted & (dec["bds"] == "0,9").to_numpy() & (dec["subtype"] == 1).to_numpy()
    dec.loc[velocity, "groundspeed"] = exact_groundspeed(
        dec.loc[velocity, "groundspeed"].to_numpy(), dec.loc[velocity, "track"].to_numpy()
    )
    dec.attrs["frames"] = counts
    return dec.reset_index(drop=True)


def _latest(t: np.ndarray, ts: np.ndarray, max_age: float) -> np.ndarray:
    """Index into sorted `ts` of the latest time at or before each `t`, at most `max_age`
    older; -1 where none."""
    i = np.searchsorted(ts, t, side="right") - 1
    ok = i >= 0
    ok[ok] = t[ok] - ts[i[ok]] <= max_age
    return np.where(ok, i, -1)


def _nearest(t: np.ndarray, ts: np.ndarray, max_dt: float) -> np.ndarray:
    """Index into sorted `ts` of the time nearest each `t`, at most `max_dt` away; -1 where none."""
    if len(ts) == 0:
        return np.full(len(t), -1)
    j = np.searchsorted(ts, t)
    lo, hi = np.clip(j - 1, 0, len(ts) - 1), np.clip(j, 0, len(ts) - 1)
    i = np.where(np.abs(ts[lo] - t) <= np.abs(ts[hi] - t), lo, hi)
    return np.where(np.abs(ts[i] - t) <= max_dt, i, -1)


def _take(values: np.ndarray, idx: np.ndarray) -> np.ndarray:
    out = np.full(len(idx), np.nan)
    ok = idx >= 0
    out[ok] = values[idx[ok]]
    return out


def states_from_frames(dec: pd.DataFrame) -> pd.DataFrame:
    """The state table (module docstring) of a decoded-frames table (decode_frames), in the
    `traffic` library's column names, one aircraft after another."""
    acc = dec[dec["accepted"]]
    rows = []
    counts = {"BDS 6,0 samples": 0, "BDS 6,0 samples without a BDS 5,0 within 5 s": 0, "airspeed-heading samples": 0}
    counts["airspeed-heading messages without the aircraft's heading reference (BDS 6,5)"] = 0
    for icao, a in acc.groupby("icao", sort=True):
        a = a.sort_values("time_s", kind="stable")
        bds = a["bds"].to_numpy()
        b60 = a[bds == "6,0"]
        b50 = a[(bds == "5,0")]
        pos = a[(bds == "0,5") & a["latitude"].notna().to_numpy()]
        vel = a[(bds == "0,9") & a["groundspeed"].notna().to_numpy()]
        air = a[(bds == "0,9") & a["airspeed"].notna().to_numpy() & (a["airspeed_type"] == "TAS").to_numpy()]
        air = air[air["adsb_heading"].notna()]
        alt_src = a[
            (((bds == "0,5") & (a["typecode"] <= 18).to_numpy()) | (a["df"] == 20).to_numpy())
            & a["altitude"].notna().to_numpy()
        ]
        vr_src = a[(bds == "0,9") & a["vertical_rate"].notna().to_numpy()]
        status = a[(bds == "6,5") & a["hrd"].notna().to_numpy()]
        # the heading reference: HRD of ADS-B version 1 and 2 (1 magnetic, 0 true); version 0 sends magnetic
        ref = math.nan if len(status) == 0 else (1.0 if status["version"].iloc[-1] == 0 else status["hrd"].iloc[-1])
        t50 = b50["time_s"].to_numpy()
        for kind, s in (("60", b60), ("air", air)):
            if len(s) == 0:
                continue
            t = s["time_s"].to_numpy()
            i50 = _nearest(t, t50, COMM_B_PAIR_S)
            ip = _latest(t, pos["time_s"].to_numpy(), STATE_AGE_S)
            iv = _latest(t, vel["time_s"].to_numpy(), STATE_AGE_S)
            ia = _latest(t, alt_src["time_s"].to_numpy(), STATE_AGE_S)
            ir = _latest(t, vr_src["time_s"].to_numpy(), STATE_AGE_S)
            gs = _take(vel["groundspeed"].to_numpy(), iv)
            trk = _take(vel["track"].to_numpy(), iv)
            gs = np.where(np.isfinite(gs), gs, _take(b50[_COMM_B_GS].to_numpy(), i50))
            trk = np.where(np.isfinite(trk), trk, _take(b50["true_track"].to_numpy(), i50))
            alt = _take(alt_src["altitude"].to_numpy(), ia)
            vr = _take(vr_src["vertical_rate"].to_numpy(), ir)
            st = {
                "icao24": str(icao).lower(),
                "timestamp": t,
                "latitude": _take(pos["latitude"].to_numpy(), ip),
                "longitude": _take(pos["longitude"].to_numpy(), ip),
                "groundspeed": gs,
                "track": trk,
                "roll": _take(b50["roll"].to_numpy(), i50),
                "track_rate": _take(b50["track_rate"].to_numpy(), i50),
            }
            if kind == "60":
                own_alt = np.where(s["df"].to_numpy() == 20, s["altitude"].to_numpy(), np.nan)
                vb, vi = s["vrate_baro"].to_numpy(), s["vrate_inertial"].to_numpy()
                st |= {
                    "altitude": np.where(np.isfinite(own_alt), own_alt, alt),
                    "heading": s["heading"].to_numpy(),
                    "true_heading": np.full(len(s), np.nan),
                    "TAS": _take(b50["tas"].to_numpy(), i50),
                    "IAS": s["ias"].to_numpy(),
                    "Mach": s["mach"].to_numpy(),
                    "vertical_rate": np.where(np.isfinite(vb), vb, np.where(np.isfinite(vi), vi, vr)),
                }
                counts["BDS 6,0 samples"] += len(s)
                counts["BDS 6,0 samples without a BDS 5,0 within 5 s"] += int((i50 < 0).sum())
            else:
                h = s["adsb_heading"].to_numpy()
                if not np.isfinite(ref):
                    counts["airspeed-heading messages without the aircraft's heading reference (BDS 6,5)"] += len(s)
                    continue
                st |= {
                    "altitude": alt,
                    "heading": h if ref == 1 else np.full(len(s), np.nan),
                    "true_heading": h if ref == 0 else np.full(len(s), np.nan),
                    "TAS": s["airspeed"].to_numpy(),
                    "IAS": np.full(len(s), np.nan),
                    "Mach": np.full(len(s), np.nan),
                    "vertical_rate": s["vertical_rate"].to_numpy(),
                }
                counts["airspeed-heading samples"] += len(s)
            rows.append(pd.DataFrame(st))
    columns = [
        "icao24", "timestamp", "latitude", "longitude", "altitude", "groundspeed", "track", "heading",
        "true_heading", "TAS", "IAS", "Mach", "roll", "track_rate", "vertical_rate",
    ]  # fmt: skip
    states = pd.concat(rows, ignore_index=True)[columns] if rows else pd.DataFrame(columns=columns)
    states = states.sort_values(["icao24", "timestamp"], kind="stable").reset_index(drop=True)
    states.attrs["frames"] = {**dec.attrs.get("frames", {}), **counts}
    return states


def read_frames(df: pd.DataFrame, source: str) -> pd.DataFrame:
    """A raw-frames table as the state table (module docstring); DataError naming `source` when
    it cannot be decoded or holds no BDS 6,0 reply of a known aircraft."""
    dec = decode_frames(df, source)
    states = states_from_frames(dec)
    if len(states) == 0:
        c = dec.attrs["frames"]
        raise DataError(
            f"{source}: raw Mode-S frames without a BDS 6,0 reply (magnetic heading) of an aircraft also seen in "
            f"ADS-B ({c.get('Comm-B replies', 0)} Comm-B replies, "
            f"{c.get('Comm-B rejected (address not seen in DF17/18/11)', 0)} of unknown address): "
            "the wind triangle needs the heading and the BDS 5,0 true airspeed"
        )
    return states


def frames_summary(counts: dict[str, int]) -> str:
    """The counts of attrs["frames"] in one line."""
    return "; ".join(f"{k}: {v}" for k, v in counts.items())
