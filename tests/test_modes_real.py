"""The Mode-S sensor against the raw Mode-S/ADS-B flight from Paris CDG: its reply
processes are fitted on reply *times* only, the sensor runs on the flight's own decoded
values, and the intervals between new payloads of each register — what a receiver learns
and when — must match the real log at p25, p50 and p90 within 20 %."""

import numpy as np
import pytest

from aerotruth.measured.kinds import load_measured, real_data_dir
from aerotruth.sensors.modes import (
    ModeSSensor,
    ModeSSpec,
    avionics_from_raw,
    fit_reply_process,
    register_times,
    unique_payload_intervals,
)

RAW = real_data_dir() / "full_flight_short.jsonl.gz"
pytestmark = pytest.mark.skipif(
    not RAW.exists(), reason=f"raw Mode-S flight not found at {RAW} (set AEROTRUTH_REAL_DATA)"
)


@pytest.fixture(scope="module")
def raw():
    df = load_measured(RAW).df
    df["payload"] = df["frame"].str[8:22]  # the 56-bit ME/MB field
    return df


def real_unique_intervals(raw, register):
    t = register_times(raw, register)
    sel = raw["time_s"].isin(t) & raw["bds"].isin(["50", "60", "05", "09"])
    m = raw[sel & raw["time_s"].between(t.min(), t.max())]
    m = m[m["bds"] == {"BDS50": "50", "BDS60": "60", "velocity": "09", "position": "05"}[register]].sort_values(
        "time_s"
    )
    return np.diff(m.drop_duplicates("payload")["time_s"].to_numpy())


def test_update_intervals_per_register_match_the_real_flight(raw):
    spec = ModeSSpec(
        **{
            name.lower() if name.startswith("BDS") else name: fit_reply_process(
                register_times(raw, name), "squitter" if name in ("velocity", "position") else "interrogated"
            )
            for name in ("BDS50", "BDS60", "velocity", "position")
        }
    )
    msgs = ModeSSensor(spec).apply(avionics_from_raw(raw), np.random.default_rng(11))
    rows = []
    for reg in ("BDS50", "BDS60", "velocity", "position"):
        sim = np.percentile(unique_payload_intervals(msgs, reg), [25, 50, 90])
        real = np.percentile(real_unique_intervals(raw, reg), [25, 50, 90])
        rows.append((reg, sim.round(2), real.round(2)))
        assert sim == pytest.approx(real, rel=0.20), rows[-1]
    print("\n".join(f"{r}: sim p25/50/90 {s} real {q}" for r, s, q in rows))


def test_fitted_environment_is_the_default_spec(raw):
    fitted = fit_reply_process(register_times(raw, "BDS60"), "interrogated")
    assert (round(fitted.dead_time_s, 3), round(fitted.mean_excess_s, 3)) == (
        ModeSSpec().bds60.dead_time_s,
        ModeSSpec().bds60.mean_excess_s,
    )
    assert (
        round(fit_reply_process(register_times(raw, "position"), "squitter").reception, 2)
        == ModeSSpec().position.reception
    )
