"""tools/rra_wind_speed.py: Range Reference Atmosphere tables to wind-speed climatology
cells, against hand-worked numbers on a synthetic two-month table."""

from __future__ import annotations

import datetime as dt
import importlib.util
import math
import subprocess
import sys
from pathlib import Path

import pytest
from scipy.stats import norm

TOOL = Path(__file__).resolve().parents[1] / "tools" / "rra_wind_speed.py"
KT = 0.514444


def _tool():
    spec = importlib.util.spec_from_file_location("rra_wind_speed", TOOL)
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _write(folder: Path) -> None:
    """Site 'tst': January speeds 8 -> 12 m/s from 1 to 2 km, February 18 -> 22, sd 2,
    skewness 0; mean pressure 1000 / 900 / 800 hPa at 0 / 1 / 2 km."""
    t1 = ["  header", "   KM  M/S"]
    t2 = ["  header"]
    for month, base in (("January", 8.0), ("February", 18.0)):
        t1 += [f"                 {month}", "    Z    MEAN U ..."]
        t2 += [f"                 {month}"]
        for z, ws in ((0.0, 0.0), (1.0, base), (2.0, base + 4.0)):
            nobs = 0 if z == 0.0 else 900
            t1.append(f"  {z:.3f}  {ws:.2f}  2.00  0.0000  0.00  2.00  {ws:.2f}  2.00  0.00  {nobs}")
        for z, p in ((0.0, 1000.0), (1.0, 900.0), (2.0, 800.0)):
            t2.append(f"  {z:.3f} {p:.4f} 5.0 0.0 280.0 5.0 0.0 1200.0 20.0 0.0 900 900 900")
    (folder / "T1tst.txt").write_text("\n".join(t1) + "\n")
    (folder / "T2tst.txt").write_text("\n".join(t2) + "\n")


def test_level_height_and_the_two_month_mixture_match_the_hand_worked_figures(tmp_path):
    r = _tool()
    _write(tmp_path)
    t1, t2 = r.read_tables(tmp_path / "T1tst.txt"), r.read_tables(tmp_path / "T2tst.txt")
    # 843 hPa between 900 and 800 hPa, log-linear: z = 1 + ln(900/843) / ln(900/800) km
    z = 1 + math.log(900 / 843) / math.log(900 / 800)
    assert r.height_of_pressure(t2["january"], 843.0) == pytest.approx(z, abs=1e-9)
    assert r.wind_at(t1["january"], z)["mean_ws"] == pytest.approx(8.0 + 4.0 * (z - 1), abs=1e-9)
    # 15 January days and 15 February days: an equal mixture of N(m1, 2) and N(m1 + 10, 2);
    # its median is halfway, its 90th percentile x solves
    # 0.5 Phi((x - m1) / 2) + 0.5 Phi((x - m2) / 2) = 0.9, with Phi((x - m1) / 2) = 1 - 1e-11
    cell, _, months = r.period_cell(t1, t2, 843.0, dt.date(2010, 1, 17), dt.date(2010, 2, 15))
    m1 = 8.0 + 4.0 * (z - 1)
    m2 = m1 + 10.0
    assert [m for m, *_ in months] == ["january", "february"]
    assert cell["p50_speed_kt"] == pytest.approx((m1 + m2) / 2 / KT, rel=1e-6)
    assert cell["p90_speed_kt"] == pytest.approx((m2 + 2.0 * norm.ppf(0.8)) / KT, rel=1e-5)
    assert cell["mean_speed_kt"] == pytest.approx((m1 + m2) / 2 / KT, rel=1e-9)
    assert cell["sd_speed_kt"] == pytest.approx(math.sqrt(4.0 + 25.0) / KT, rel=1e-9)


def test_missing_tables_are_one_line(tmp_path):
    out = subprocess.run(
        [sys.executable, str(TOOL), str(tmp_path), "nowhere", "p=2010-01-01:2010-01-31"],
        capture_output=True,
        text=True,
    )
    assert out.returncode == 1 and out.stderr.startswith("rra_wind_speed: ") and "Traceback" not in out.stderr
