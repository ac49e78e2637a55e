"""validation/error_budget.py's table bounds on a hand-built case: a heading error that is
exactly a sinusoid of the magnetic heading is removed entirely by the full static table,
which then leaves only the reference model's error."""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
import error_budget  # noqa: E402


def _from_vector(e, n):
    """(east, north) wind towards -> (speed, direction it blows from, deg)."""
    return np.hypot(e, n), np.degrees(np.arctan2(-e, -n)) % 360


def test_a_sinusoidal_heading_error_is_removed_by_the_full_static_table():
    rng = np.random.default_rng(4)
    rows = []
    for ac, group in (("P1", "poor"), ("P2", "poor"), ("C1", "control")):
        for stage in ("before", "after"):
            n = 400
            true_hdg = rng.uniform(0, 360, n)
            declination = 15.0
            mag = (true_hdg - declination) % 360  # the measured magnetic heading differs only by dpsi below
            dpsi = 1.5 + 3.0 * np.sin(np.radians(mag)) if group == "poor" else np.full(n, 0.5)
            meas = true_hdg + dpsi
            tas = rng.uniform(180, 260, n)
            te, tn = rng.normal(0, 20, n), rng.normal(0, 20, n)  # truth wind, kt towards
            # reported wind: V_G - V_A(measured heading); V_G = truth wind + V_A(true heading)
            oe = te + tas * (np.sin(np.radians(true_hdg)) - np.sin(np.radians(meas)))
            on = tn + tas * (np.cos(np.radians(true_hdg)) - np.cos(np.radians(meas)))
            re_, rn = te + rng.normal(0, 4, n), tn + rng.normal(0, 4, n)
            ws, wd = _from_vector(oe, on)
            rs, rd = _from_vector(re_, rn)
            ts, td = _from_vector(te, tn)
            rows.append(
                pd.DataFrame(
                    {
                        "aircraft": ac,
                        "group": group,
                        "stage": stage,
                        "ref_source": "rr",
                        "roll_deg": 0.0,
                        "wind_speed_kt": ws,
                        "wind_dir_deg": wd,
                        "ref_wind_speed_kt": rs,
                        "ref_wind_dir_deg": rd,
                        "truth_wind_speed_kt": ts,
                        "truth_wind_dir_deg": td,
                        "tas_kt": tas,
                        "heading_deg": meas % 360,
                        "truth_heading_deg": true_hdg,
                        "heading_mag_deg": (mag + dpsi) % 360,
                        "ref_e": re_ - te,
                        "ref_n": rn - tn,
                    }
                )
            )
    obs = pd.concat(rows, ignore_index=True)
    out = error_budget.table_bounds(obs, error_budget.winds(obs))
    pa = (obs["group"] == "poor") & (obs["stage"] == "after")
    ref_only = float(np.sqrt((obs.loc[pa, "ref_e"] ** 2 + obs.loc[pa, "ref_n"] ** 2).mean()))
    assert out["bound.no_heading_error.poor_after_kt"] == pytest.approx(ref_only, rel=1e-6)
    # the error is exactly A + B sin(measured magnetic heading - dpsi): not exactly in the
    # fitted basis of the measured heading, but within a few hundredths of a degree
    assert out["bound.full_static_table.poor_after_kt"] == pytest.approx(ref_only, rel=0.01)
    assert out["bound.scored.poor_after_kt"] > 2 * ref_only  # ~3.4 deg rms at ~220 kt: ~13 kt
    for o in (0, 90, 180, 270):
        assert out[f"octant.poor.after.{o:03d}_full_deg"] < 0.1
        assert out[f"octant.poor.after.{o:03d}_table_deg"] > 1.0  # 1.5 + 3 sin: >= 1.5 deg rms at these four


def test_the_season_held_takes_the_after_periods_seasonal_rise_out(tmp_path):
    """Own error zero and a reference error of 10 kt towards the east times the seasonal
    factor s(doy) = 1 + 0.11 cos(2 pi (doy - 106) / 182.625) (the presets' law): before on day
    40 (s = 1 + 0.11 cos(-2.2707) = 0.92915), after on day 116 (s = 1 + 0.11 cos(0.34405) =
    1.10355), worked by hand. Scored, the control's change is 10 x (1.10355 - 0.92915) =
    1.744 kt; held at the before period's factor, 0; every held after cell is 9.2915 kt,
    all of it along the east for a northbound aircraft (transverse), none longitudinal."""
    rows = []
    for group in ("poor", "control"):
        for stage, day in (("before", "2010-02-09"), ("after", "2010-04-26")):
            n = 50
            s = {"before": 0.92915, "after": 1.10355}[stage]
            te, tn = np.full(n, 20.0), np.full(n, 5.0)
            ws, wd = _from_vector(te, tn)
            rs, rd = _from_vector(te + 10.0 * s, tn)
            rows.append(
                pd.DataFrame(
                    {
                        "group": group,
                        "stage": stage,
                        "time": pd.Timestamp(f"{day}T12:00Z").timestamp() + np.arange(n),
                        "ref_source": "rr",
                        "wind_speed_kt": ws,
                        "wind_dir_deg": wd,
                        "ref_wind_speed_kt": rs,
                        "ref_wind_dir_deg": rd,
                        "truth_wind_speed_kt": ws,
                        "truth_wind_dir_deg": wd,
                        "heading_deg": 0.0,
                        "truth_heading_deg": 0.0,
                    }
                )
            )
    obs = pd.concat(rows, ignore_index=True)
    laws = {"rr": (0.11, 182.625, 106.0)}
    out = error_budget.season_held(obs, error_budget.winds(obs), laws)
    assert out["season.control.change_scored_kt"] == pytest.approx(1.744, abs=2e-3)
    assert out["season.control.change_held_kt"] == pytest.approx(0.0, abs=1e-3)  # 5-digit hand factors
    for g in ("poor", "control"):
        assert out[f"season_held.{g}.after.total_kt"] == pytest.approx(9.2915, abs=1e-3)
        assert out[f"season_held.{g}.after.longitudinal_kt"] == pytest.approx(0.0, abs=1e-6)
    cfg = {"studies": {"a": {"fleets": [{"references": [{"name": "rr", "seasonal_amplitude": 0.11,
            "seasonal_period_days": 182.625, "seasonal_peak_doy": 106.0}]}]}}}  # fmt: skip
    (tmp_path / "config.resolved.yaml").write_text(__import__("yaml").safe_dump(cfg))
    assert error_budget.seasonal_laws(tmp_path) == laws
