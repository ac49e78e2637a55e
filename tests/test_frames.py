"""Raw Mode-S / ADS-B frames into the traffic frame (aerotruth.measured.frames, through
aerotruth.measured.traffic.read_traffic), decoded with pyModeS >= 3 (an optional extra: the
tests that decode skip without it).

Frames here are made by a small encoder of this file (bit fields per ICAO Doc 9871 / DO-260B,
the parity from pyModeS's public `util.crc`), independent of the decoder, or taken from the
textbook examples of "The 1090 MHz Riddle" (J. Sun) with their published values. The
acceptance test decodes the real capture ../shared/real-data/full_flight_short.jsonl.gz and
compares with the decoded fields the file carries (its docstring counts the disagreements)."""

from __future__ import annotations

import math
import sys

import numpy as np
import pandas as pd
import pytest
import traffic_generator as gen

from aerotruth.errors import DataError
from aerotruth.measured import frames
from aerotruth.measured.kinds import real_data_dir
from aerotruth.measured.traffic import canonical_traffic, read_traffic

REAL = real_data_dir() / "full_flight_short.jsonl.gz"
needs_real = pytest.mark.skipif(not REAL.is_file(), reason=f"real capture not found: {REAL}")


@pytest.fixture
def pms():
    return pytest.importorskip("pyModeS", minversion="3")


# ---- an encoder for fixtures (ICAO Doc 9871 / DO-260B bit layouts) ----


def _with_parity(n: int, address: int = 0) -> str:
    from pyModeS.util import crc

    return f"{n | (crc(f'{n:028X}') ^ address):028X}"


def es(icao: str, me: int) -> str:
    """DF17 extended squitter, capability 5, address in clear, parity 0."""
    return _with_parity((17 << 107) | (5 << 104) | (int(icao, 16) << 80) | (me << 24))


def comm_b(df: int, icao: str, alt_ft: float, mb: int) -> str:
    """DF20 (altitude in the header) or DF21 reply, the address overlaid on the parity."""
    n_alt = round((alt_ft + 1000) / 25)
    ac = ((n_alt >> 5) << 7) | ((n_alt >> 4 & 1) << 5) | (1 << 4) | (n_alt & 0xF)  # Q = 1, M = 0
    header = ac if df == 20 else 0  # DF21: its identity (squawk) field, 0000 here
    return _with_parity((df << 107) | (header << 80) | (mb << 24), int(icao, 16))


def _twos(value: float, lsb: float, width: int) -> int:
    """Sign bit and `width` magnitude bits (two's complement) of value / lsb."""
    return round(value / lsb) % (1 << (width + 1))


def position_me(lat: float, lon: float, alt_ft: float, odd: int) -> int:
    from pyModeS.position import cprNL

    n_alt = round((alt_ft + 1000) / 25)
    alt12 = ((n_alt >> 4) << 5) | (1 << 4) | (n_alt & 0xF)
    dlat = 360.0 / (60 - odd)
    yz = math.floor(2**17 * (lat % dlat) / dlat + 0.5)
    rlat = dlat * (yz / 2**17 + math.floor(lat / dlat))
    dlon = 360.0 / max(cprNL(rlat) - odd, 1)
    xz = math.floor(2**17 * (lon % dlon) / dlon + 0.5)
    return (11 << 51) | (alt12 << 36) | (odd << 34) | ((yz & 0x1FFFF) << 17) | (xz & 0x1FFFF)


def velocity_me(v_east: int, v_north: int, vr_fpm: float = 0.0) -> int:
    vr = round(abs(vr_fpm) / 64) + 1
    return (
        (19 << 51) | (1 << 48) | (int(v_east < 0) << 42) | ((abs(v_east) + 1) << 32) | (int(v_north < 0) << 31)
        | ((abs(v_north) + 1) << 21) | (1 << 20) | (int(vr_fpm < 0) << 19) | (vr << 10)
    )  # fmt: skip


def airspeed_me(heading: float, tas: int, vr_fpm: float = 0.0) -> int:
    vr = round(abs(vr_fpm) / 64) + 1
    raw = round(heading / 360.0 * 1024) % 1024
    return (19 << 51) | (3 << 48) | (1 << 42) | (raw << 32) | (1 << 31) | ((tas + 1) << 21) | (1 << 20) | (vr << 10)


def status_me(version: int, hrd: int) -> int:
    """BDS 6,5 airborne operational status with the heading reference HRD (1 magnetic)."""
    return (31 << 51) | (version << 13) | (hrd << 2)


def bds50(roll: float, track: float, gs: float, tas: float, rate: float = 0.0) -> int:
    trk = track - 360.0 if track >= 180.0 else track
    return (
        (1 << 55) | (_twos(roll, 45 / 256, 9) << 45) | (1 << 44) | (_twos(trk, 90 / 512, 10) << 33)
        | (1 << 32) | (round(gs / 2) << 22) | (1 << 21) | (_twos(rate, 8 / 256, 9) << 11)
        | (1 << 10) | round(tas / 2)
    )  # fmt: skip


def bds60(heading: float, ias: float, mach: float, vr_baro: float, vr_inertial: float) -> int:
    hdg = heading - 360.0 if heading >= 180.0 else heading
    return (
        (1 << 55) | (_twos(hdg, 90 / 512, 10) << 44) | (1 << 43) | (round(ias) << 33)
        | (1 << 32) | (round(mach / (2.048 / 512)) << 22) | (1 << 21) | (_twos(vr_baro, 32, 9) << 11)
        | (1 << 10) | _twos(vr_inertial, 32, 9)
    )  # fmt: skip


def frames_table(rows: list[tuple[float, str]], **extra) -> pd.DataFrame:
    return pd.DataFrame({"timestamp": [t for t, _ in rows], "rawmsg": [m for _, m in rows], **extra})


# The 1090 MHz Riddle's examples with their published values
RIDDLE_EVEN = "8D40621D58C382D690C8AC2863A7"  # with the odd one below: 52.2572 N, 3.91937 E (even newer)
RIDDLE_ODD = "8D40621D58C386435CC412692AD6"  # its own position: 52.26578 N, 3.93891 E
RIDDLE_VELOCITY = "8D485020994409940838175B284F"  # 8 kt west, 159 kt south: 159.20 kt, 182.88 deg
RIDDLE_AIRSPEED = "8DA05F219B06B6AF189400CBC33F"  # subtype 3: heading 243.98 deg, TAS 375 kt, -2304 ft/min


def test_one_aircraft_hand_worked(pms):
    """The time alignment by hand: a position pair (even newer), a velocity, then a BDS 5,0 and
    a BDS 6,0 reply 0.3 s apart; the row is at the 6,0 reply with its heading, IAS, Mach and
    vertical rate, the 5,0's TAS and roll, the latest ADS-B position and velocity."""
    icao = "3C6DD2"
    lat, lon, alt = 50.0, 8.0, 35000.0
    rows = [
        (100.0, es(icao, position_me(lat, lon, alt, 1))),
        (101.0, es(icao, position_me(lat, lon, alt, 0))),
        (101.5, es(icao, velocity_me(-100, 400, -64))),
        (102.0, comm_b(20, icao, alt, bds50(-2.109375, 345.9375, 412, 450))),
        (102.3, comm_b(20, icao, alt, bds60(350.15625, 265, 0.78, -32, -64))),
    ]
    tr = read_frames_table(frames_table(rows))
    assert len(tr) == 1
    r = tr.iloc[0]
    assert r["aircraft"] == "3c6dd2" and r["time_s"] == 102.3
    assert r["lat"] == pytest.approx(lat, abs=360 / 60 / 2**17) and r["lon"] == pytest.approx(lon, abs=1e-4)
    assert r["pressure_altitude_ft"] == 35000.0
    assert r["gs_kt"] == pytest.approx(math.hypot(100, 400), abs=1e-9)  # exact, not pyModeS's int 412
    assert r["track_deg"] == pytest.approx(math.degrees(math.atan2(-100, 400)) % 360, abs=1e-9)
    assert r["heading_mag_deg"] == 350.15625 and r["tas_kt"] == 450.0 and r["roll_deg"] == -2.109375
    assert r["vertical_rate_fpm"] == -32.0  # the reply's barometric rate before ADS-B's


def read_frames_table(table: pd.DataFrame) -> pd.DataFrame:
    return canonical_traffic(frames.read_frames(table, "t.csv"), "t.csv")


def test_the_pairing_windows_by_hand(pms):
    """BDS 5,0 nearest within 5 s on either side; ADS-B position and velocity at most 3 s old,
    never from after the reply: 6,0 replies at 110 and 120, a 5,0 at 114.5 (4.5 s after the
    first reply: paired; 5.5 s before the second: not), positions at 107.5/108 (2 s before the
    first reply: taken) and none within 3 s before 120 (a position at 121 is after)."""
    icao = "4CA123"
    alt = 30000.0
    rows = [
        (107.5, es(icao, position_me(48.0, 2.0, alt, 1))),
        (108.0, es(icao, position_me(48.0, 2.0, alt, 0))),
        (108.0, es(icao, velocity_me(0, 300))),
        (110.0, comm_b(20, icao, alt, bds60(0.0, 250, 0.7, 0, 0))),
        (114.5, comm_b(20, icao, alt, bds50(0.0, 0.0, 300, 320))),
        (118.0, es(icao, velocity_me(0, 300))),
        (120.0, comm_b(21, icao, alt, bds60(0.0, 250, 0.7, 0, 0))),
        (121.0, es(icao, position_me(48.02, 2.0, alt, 1))),
    ]
    st = frames.read_frames(frames_table(rows), "t")
    assert st["timestamp"].tolist() == [110.0, 120.0]
    assert st["TAS"].iloc[0] == 320.0 and np.isnan(st["TAS"].iloc[1])
    assert st["latitude"].iloc[0] == pytest.approx(48.0, abs=1e-4) and np.isnan(st["latitude"].iloc[1])
    assert st["groundspeed"].iloc[1] == 300.0  # the velocity at 118, 2 s old
    assert np.isnan(st["altitude"].iloc[1])  # DF21 has none of its own, and the DF20 at 114.5 is 5.5 s old
    tr = canonical_traffic(st, "t")
    assert len(tr) == 1 and tr.attrs["rows_incomplete"] == 1


def test_riddle_examples_decode_to_their_published_values(pms):
    """Position pair (even frame newer) and the exact ground speed, from the book's values."""
    rows = [(1457996400.0, RIDDLE_ODD), (1457996402.0, RIDDLE_EVEN), (1457996403.0, RIDDLE_VELOCITY)]
    dec = frames.decode_frames(frames_table(rows), "t").set_index("row")
    assert dec.loc[1, "latitude"] == pytest.approx(52.2572021484375, abs=1e-9)
    assert dec.loc[1, "longitude"] == pytest.approx(3.91937255859375, abs=1e-9)
    # each frame its own position (the odd one's, as if it were the newer)
    assert dec.loc[0, "latitude"] == pytest.approx(52.26578017412606, abs=1e-6)
    assert dec.loc[0, "longitude"] == pytest.approx(3.938912527901786, abs=1e-6)
    assert dec.loc[2, "groundspeed"] == pytest.approx(math.sqrt(8**2 + 159**2), abs=1e-9)  # pyModeS: 159
    assert dec.loc[2, "track"] == pytest.approx(182.8803775528476, abs=1e-6)
    assert dec.loc[2, "vertical_rate"] == -832.0


def test_exact_groundspeed_recovers_the_integer_components():
    """pyModeS's int(sqrt(ve^2 + vn^2)) and the track give the components back: (3, 4) kt is
    5.0; (-9, -159) is 159.2545; a speed whose track no integer pair gives stays as it is."""
    gs = np.array([5.0, 159.0, 100.0])
    trk = np.array([math.degrees(math.atan2(3, 4)), math.degrees(math.atan2(-9, -159)) % 360, 33.3333])
    out = frames.exact_groundspeed(gs, trk)
    assert out[0] == pytest.approx(5.0) and out[1] == pytest.approx(159.25451328058573) and out[2] == 100.0


def test_airspeed_heading_subtype_by_its_heading_reference(pms):
    """The book's subtype-3 message (heading 243.98, TAS 375): magnetic when the aircraft's
    operational status says HRD = 1 (version 2), a true heading with HRD = 0 (the traffic reader
    turns it magnetic with IGRF), left out without an operational status."""
    icao = "A05F21"
    alt = 20000.0

    def rows(status):
        r = [
            (10.0, es(icao, position_me(40.0, -100.0, alt, 0))),
            (11.0, es(icao, position_me(40.0, -100.0, alt, 1))),
            (11.5, comm_b(20, icao, alt, bds50(0.0, 239.94140625, 350, 376))),
            (12.0, RIDDLE_AIRSPEED),
        ]
        return r + ([(5.0, es(icao, status))] if status is not None else [])

    mag = frames.read_frames(frames_table(rows(status_me(2, 1))), "t")
    assert mag["heading"].tolist() == [pytest.approx(243.984375)] and mag["TAS"].tolist() == [375.0]
    assert mag["groundspeed"].tolist() == [350.0] and mag["track"].tolist() == [239.94140625]  # from BDS 5,0
    true = frames.read_frames(frames_table(rows(status_me(2, 0))), "t")
    assert np.isnan(true["heading"].iloc[0]) and true["true_heading"].iloc[0] == pytest.approx(243.984375)
    with pytest.raises(DataError, match="without a BDS 6,0 reply"):
        frames.read_frames(frames_table(rows(None)), "t")


def test_comm_b_of_an_address_never_seen_in_clear_is_rejected_and_counted(pms):
    icao, other = "3C6DD2", "3C6DD3"
    rows = [
        (1.0, es(icao, position_me(50.0, 8.0, 35000, 0))),
        (2.0, es(icao, position_me(50.0, 8.0, 35000, 1))),
        (2.1, es(icao, velocity_me(0, 450))),
        (2.5, comm_b(20, icao, 35000, bds60(10.01953125, 260, 0.78, 0, 0))),
        (2.6, comm_b(20, icao, 35000, bds50(0.0, 0.0, 450, 460))),
        (3.0, comm_b(20, other, 35000, bds60(10.01953125, 260, 0.78, 0, 0))),
        (3.1, comm_b(21, other, 35000, bds50(0.0, 0.0, 450, 460))),
    ]
    st = frames.read_frames(frames_table(rows), "t")
    assert st["icao24"].unique().tolist() == ["3c6dd2"]
    assert st.attrs["frames"]["Comm-B rejected (address not seen in DF17/18/11)"] == 2


def test_names_case_forms_and_file_types(pms, tmp_path):
    """Column names any case (RawMsg, MINTIME, ICAO24), AVR's `*...;`, ms times, and the same
    frames as CSV, JSON lines and Parquet read alike through read_traffic."""
    icao = "3C6DD2"
    rows = [
        (1.0e3, es(icao, position_me(50.0, 8.0, 35000, 0))),
        (2.0e3, es(icao, position_me(50.0, 8.0, 35000, 1))),
        (2.1e3, es(icao, velocity_me(0, 450))),
        (2.5e3, comm_b(20, icao, 35000, bds60(10.01953125, 260, 0.78, 0, 0))),
        (2.6e3, comm_b(20, icao, 35000, bds50(0.0, 0.0, 450, 460))),
    ]
    t0 = 1.7e12  # ms
    table = pd.DataFrame(
        {"MINTIME": [t0 + t for t, _ in rows], "RawMsg": [f"*{m.lower()};" for _, m in rows], "ICAO24": icao.lower()}
    )
    table.to_csv(tmp_path / "f.csv", index=False)
    table.to_json(tmp_path / "f.jsonl", orient="records", lines=True)
    table.to_parquet(tmp_path / "f.parquet", index=False)
    got = [read_traffic(tmp_path / n) for n in ("f.csv", "f.jsonl", "f.parquet")]
    for tr in got:
        assert len(tr) == 1 and tr["time_s"].iloc[0] == pytest.approx(1.7e9 + 2.5)
        assert tr["heading_mag_deg"].iloc[0] == 10.01953125 and tr["tas_kt"].iloc[0] == 460.0
        assert "Comm-B replies: 2" in frames.frames_summary(tr.attrs["frames"])


def test_without_pymodes_one_line_says_what_to_install(tmp_path, monkeypatch):
    pd.DataFrame({"timestamp": [1.0], "msg": ["8D40621D58C382D690C8AC2863A7"]}).to_csv(tmp_path / "f.csv", index=False)
    monkeypatch.setitem(sys.modules, "pyModeS", None)  # import fails as when not installed
    with pytest.raises(DataError) as e:
        read_traffic(tmp_path / "f.csv")
    said = str(e.value)
    assert (
        said
        == f"{tmp_path / 'f.csv'}: raw Mode-S frames: install aerotruth[modes] (pyModeS, GPL-3) to decode raw frames"
    )


def test_bad_times_are_one_line_naming_file_and_column(pms, tmp_path):
    pd.DataFrame({"ts": ["yesterday"], "hex": [RIDDLE_EVEN]}).to_csv(tmp_path / "f.csv", index=False)
    with pytest.raises(DataError, match=r"f\.csv: column 'ts': expected UTC epoch seconds or ISO-8601 times"):
        read_traffic(tmp_path / "f.csv")


def encode_traffic(df: pd.DataFrame, step_s: int = 2, comm_b_s: int = 4) -> pd.DataFrame:
    """The generator's state table as frames: every `step_s` an ADS-B position (even and odd in
    turn) and velocity (integer east and north components), every `comm_b_s` a BDS 5,0 reply and
    0.2 s later a BDS 6,0 one (heading as the table has it, IAS and Mach from an ISA-ish model)."""
    out = []
    for k, (_, a) in enumerate(df.groupby("icao24", sort=True)):
        a = a.reset_index(drop=True)
        t = (a["timestamp"] - pd.Timestamp("1970-01-01", tz="UTC")).dt.total_seconds().to_numpy()
        addr = f"{0x400000 + k:06X}"
        for i in range(0, len(a), step_s):
            r = a.iloc[i]
            trk = math.radians(r["track"])
            ve, vn = round(r["groundspeed"] * math.sin(trk)), round(r["groundspeed"] * math.cos(trk))
            out.append((t[i], es(addr, position_me(r["latitude"], r["longitude"], r["altitude"], (i // step_s) % 2))))
            out.append((t[i] + 0.05, es(addr, velocity_me(ve, vn))))
            if i % comm_b_s == 0:
                tas = r["TAS"]
                out.append((t[i] + 0.3, comm_b(20, addr, r["altitude"], bds50(0.0, r["track"], r["groundspeed"], tas))))
                mach, ias = tas / 589.0, tas * 0.61
                out.append((t[i] + 0.5, comm_b(20, addr, r["altitude"], bds60(r["heading"], ias, mach, 0, 0))))
    out.sort()
    return pd.DataFrame({"timestamp": [x for x, _ in out], "rawmsg": [m for _, m in out]})


@pytest.mark.slow
def test_frames_give_the_state_tables_winds(pms, tmp_path, capsys):
    """The generator's traffic (tests/traffic_generator.py) encoded as frames, decoded, and its
    per-sample winds against those of the state table itself at the same instants: equal to the
    ADS-B velocity's 1-kt components (< 1 kt); and `aerotruth reports` on the frames file."""
    from aerotruth.analysis.wind.consensus import sample_winds
    from aerotruth.app.cli import main

    df, _ = gen.make_traffic(8, seed=5, minutes=30, levels_ft=(30000.0,))
    enc = encode_traffic(df)
    enc.to_csv(tmp_path / "frames.csv", index=False)
    tr = read_traffic(tmp_path / "frames.csv")
    assert tr["aircraft"].nunique() == 8 and len(tr) >= 0.95 * len(df) / 4
    w = sample_winds(tr)
    tr = tr.assign(wind_u_kt=w["wind_u_kt"].to_numpy(), wind_v_kt=w["wind_v_kt"].to_numpy())
    ref = canonical_traffic(df, "gen")
    w = sample_winds(ref)
    ref = ref.assign(wind_u_kt=w["wind_u_kt"].to_numpy(), wind_v_kt=w["wind_v_kt"].to_numpy())
    ref["aircraft"] = ref.groupby("aircraft").ngroup().map(lambda k: f"{0x400000 + k:06x}")
    merged = pd.merge_asof(
        tr.sort_values("time_s"), ref.sort_values("time_s"), on="time_s", by="aircraft", suffixes=("", "_ref")
    )
    assert (merged["heading_mag_deg"] == merged["heading_mag_deg_ref"]).all()
    err = np.hypot(merged["wind_u_kt"] - merged["wind_u_kt_ref"], merged["wind_v_kt"] - merged["wind_v_kt_ref"])
    assert err.max() < 1.0
    argv = ["reports", str(tmp_path / "frames.csv"), "--reference", "consensus", "--out", str(tmp_path / "o.csv")]
    assert main(argv) == 0
    assert "reports of 8 aircraft" in capsys.readouterr().out


@needs_real
@pytest.mark.slow
def test_real_capture_matches_its_own_decoded_fields(pms):
    """Acceptance: the frames of full_flight_short.jsonl.gz (one Air France flight from CDG,
    57,793 messages; 13,762 repeats of a frame within 1 s count once, leaving 22,334 frames of
    DF 11/17/18/20/21) decoded here against the decoded fields the file carries, frame by frame
    where both have a value; equal within the register's LSB, except as counted below
    (pyModeS 3.6.1; the file's fields come from an older decoder).

    * ADS-B positions (6,069 frames), altitudes, ground speed, track and vertical rate (3,010):
      all equal (to 1e-9). Two steps make it so: each CPR frame is resolved against its own
      pyModeS position (PipeDecoder gives the older frame of a pair the newer one's position:
      4,361 frames up to 0.02 deg off), and the ground speed is taken exact (pyModeS truncates
      it to the knot below: 0.52 kt short on average here).
    * BDS 5,0 (2,155 frames both call 5,0): roll, true track, ground speed, TAS equal; track
      rate: 1,004 frames with sign and magnitude all ones, which pyModeS reads as -1 LSB
      (-0.03125 deg/s) and the file as "not available" (it is a fill value: -1 LSB comes 2.7
      times as often as +1 LSB; the wind method does not use the rate).
    * BDS 6,0 (4,732 frames): heading, IAS, Mach equal; vertical rate barometric 79 and
      inertial 144 frames differ by one LSB, 32 ft/min: the same all-ones pattern, -32 here
      and 0 in the file.
    * DF20 altitude (5,384 replies): one differs, a garbled reply saying 39,150 ft (Q-bit code,
      read right here; the file says 5,590) while the aircraft was level at 35,025 ft: pyModeS's
      altitude cross-check flags it and the reader rejects it.
    * Register inference (10,814 Comm-B frames): 484 differ. 462 the file leaves without a BDS
      and pyModeS calls 5,0 (both 5,0 and 6,0 fit their status bits; the aircraft's recent state
      decides): in the air they agree with the latest ADS-B velocity (all 454 within 4 kt and 3
      deg; the worst, 2.0 deg, in a turn at 23 deg of bank; 8 more are after the last airborne
      position, on the ground). 12 the file leaves without and pyModeS
      calls 6,0: all on the ground (no IAS or Mach, heading far from the last track). 9 the
      file calls 6,0 and pyModeS 5,0: 8 in the climb whose 5,0 reading matches the ADS-B ground
      speed and track while the file's 6,0 reading does not (heading 359 deg on a 208 deg
      track, IAS 157 kt at Mach 0.49 at 10,500 ft), 1 on the ground. 1 the file calls 5,0 and
      the reader rejects: on the landing roll, 8 s after the last ADS-B velocity, pyModeS's
      cross-check finds its 96 kt too far from that velocity's 140 kt."""
    raw = pd.read_json(REAL, lines=True, dtype=False)
    dec = frames.decode_frames(raw, str(REAL))
    f = raw.iloc[dec["row"].to_numpy()].reset_index(drop=True)
    d = dec.reset_index(drop=True)
    assert len(d) == 22334 and dec.attrs["frames"]["repeated frames"] == 13762
    fb = f["bds"].astype("string").fillna("-").to_numpy()
    mb = d["bds"].astype("string").str.replace(",", "").fillna("-").to_numpy()
    mb = np.where(d["accepted"], mb, "-")

    def differ(mask, mine, theirs, lsb, angle=False):
        a = d.loc[mask, mine].to_numpy(float)
        b = pd.to_numeric(f.loc[mask, theirs], errors="coerce").to_numpy(float)
        diff = np.abs((a - b + 180) % 360 - 180) if angle else np.abs(a - b)
        both = np.isfinite(a) & np.isfinite(b)
        return int(both.sum()), int((both & (diff > 1e-9)).sum()), float(np.max(diff[both], initial=0.0)), (a, b)

    pos = (d["df"] == 17).to_numpy() & (fb == "05") & (mb == "05")
    for c, lsb in (("latitude", 360 / 60 / 2**17), ("longitude", 360 / 39 / 2**17), ("altitude", 25)):
        n, bad, _, _ = differ(pos, c, c, lsb)
        assert (n, bad) == (6069, 0), c
    vel = (d["df"] == 17).to_numpy() & (fb == "09") & (mb == "09")
    for c, angle in (("groundspeed", False), ("track", True), ("vertical_rate", False)):
        assert differ(vel, c, c, 1, angle)[:2] == (3010, 0), c
    b5 = (fb == "50") & (mb == "50")
    fields50 = (
        ("roll", "roll", False),
        ("true_track", "track", True),
        ("gs50", "groundspeed", False),
        ("tas", "TAS", False),
    )
    for mine, theirs, angle in fields50:
        n, bad, _, _ = differ(b5, mine, theirs, 0, angle)
        assert n >= 2154 and bad == 0, mine
    _, _, _, (rate, file_rate) = differ(b5, "track_rate", "track_rate", 8 / 256)
    only_here = np.isfinite(rate) & np.isnan(file_rate)
    assert only_here.sum() == 1004 and (rate[only_here] == -0.03125).all()
    b6 = (fb == "60") & (mb == "60")
    for mine, theirs in (("heading", "heading"), ("ias", "IAS"), ("mach", "Mach")):
        assert differ(b6, mine, theirs, 0)[1] == 0, mine
    for mine, theirs, count in (("vrate_baro", "vrate_barometric", 79), ("vrate_inertial", "vrate_inertial", 144)):
        n, bad, worst, (a, b) = differ(b6, mine, theirs, 32)
        assert n == 4732 and bad == count and worst == 32.0
        off = np.isfinite(a) & np.isfinite(b) & (a != b)
        assert (a[off] == -32).all() and (b[off] == 0).all()
    n, bad, _, _ = differ((d["df"] == 20).to_numpy(), "altitude", "altitude", 25)
    assert (n, bad) == (5384, 1)
    odd = (d["df"] == 20).to_numpy() & (d["altitude"] == 39150).to_numpy()
    assert not d.loc[odd, "accepted"].any()

    commb = d["df"].isin((20, 21)).to_numpy()
    pairs = pd.Series(list(zip(fb[commb & (fb != mb)], mb[commb & (fb != mb)], strict=True))).value_counts()
    assert pairs.to_dict() == {("-", "50"): 462, ("-", "60"): 12, ("60", "50"): 9, ("50", "-"): 1}
    airborne_end = d.loc[(d["bds"] == "0,5") & d["latitude"].notna(), "time_s"].max()
    v = d[(d["bds"] == "0,9") & d["groundspeed"].notna()].sort_values("time_s")
    i = np.clip(np.searchsorted(v["time_s"].to_numpy(), d["time_s"].to_numpy()) - 1, 0, len(v) - 1)
    ok50 = (np.abs(d["gs50"].to_numpy() - v["groundspeed"].to_numpy()[i]) <= 4) & (
        np.abs((d["true_track"].to_numpy() - v["track"].to_numpy()[i] + 180) % 360 - 180) <= 3
    )
    air = d["time_s"].to_numpy() <= airborne_end
    for (was, now), count_air in ((("-", "50"), 454), (("60", "50"), 8)):
        sel = commb & (fb == was) & (mb == now)
        assert (sel & air).sum() == count_air and (sel & air & ok50).sum() == count_air
    assert not ((fb == "-") & (mb == "60") & air).any()
