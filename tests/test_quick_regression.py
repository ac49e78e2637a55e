"""campaigns/quick.yaml regressed against its committed baseline: a change that moves any
quick metric fails CI until the baseline is rewritten on purpose
(`aerotruth regress runs/quick campaigns/quick.baseline.json --write --rel-tol 1e-5 --abs-tol 1e-5`).

The tolerances: the run is bit-for-bit repeatable on one machine, but another CPU moves
the wind cells by up to ~8e-7 kn (likely the float32 trigonometry, whose SIMD paths differ by CPU; measured
26 Nov 2026 on an AMD EPYC against the baseline written on the previous machine: the poor
group's longitudinal improvement 0.4425306542 -> +8.2e-7). 1e-5 absolute plus 1e-5
relative holds that ten times over; the 0.02-deg quantization below moves 47 metrics, by
4.5e-4 kn (5e-5 of the value) to 130 % of it."""

from pathlib import Path

import pytest

from aerotruth.app.cli import main

pytestmark = pytest.mark.slow  # every test here flies JSBSim or takes over 5 s

ROOT = Path(__file__).resolve().parents[1]


def test_quick_campaign_matches_its_baseline(tmp_path, capsys):
    out = tmp_path / "quick"
    assert main(["run", str(ROOT / "campaigns" / "quick.yaml"), "--out", str(out), "--quiet", "--no-report"]) == 0
    code = main(["regress", str(out), str(ROOT / "campaigns" / "quick.baseline.json")])
    assert code == 0, capsys.readouterr().out
    # the poor aircraft's after period is also reported without its table (paired twin):
    # the same reports, and the table's own effect is the difference
    import numpy as np
    import pandas as pd

    g = pd.read_parquet(out / "tables" / "heading_correction.groups.parquet").set_index(["group", "period"])
    assert g.loc[("poor", "after_untreated"), "n"] == g.loc[("poor", "after"), "n"] > 0
    effect = g.loc[("poor", "after_untreated"), "rms_kt"] - g.loc[("poor", "after"), "rms_kt"]
    assert g.loc[("poor", "table_effect"), "rms_kt"] == effect
    # every cell is a ratio of the aircraft-day sums (the paper-scale redraw's input)
    from aerotruth.analysis.wind.paper_draw import cells_from_sums

    days = pd.read_parquet(out / "tables" / "heading_correction.aircraft_days.parquet")
    again = cells_from_sums(days).set_index(["group", "period"])
    for col in ("rms_kt", "longitudinal_rms_kt", "transverse_rms_kt"):
        assert np.allclose(again[col], g.loc[again.index, col], rtol=1e-9, atol=1e-9), col
    _unit_checks_on_simulated_reports(pd.read_parquet(out / "data" / "heading_correction.observations.parquet"))


def _unit_checks_on_simulated_reports(obs) -> None:
    """The wind-unit checks of the method (aerotruth.analysis.wind.heading_errors) on JSBSim's
    reports: tables in knots cut to a few flights are never refused (with the checks' plain
    ranges, without their clustered standard errors, 28-46 % of such cuts were), the whole
    table with its reference winds in m/s is."""
    import numpy as np
    import pytest

    from aerotruth.analysis.wind.heading_errors import heading_errors
    from aerotruth.errors import DataError

    keys = obs[["aircraft", "flight"]].drop_duplicates()
    rng = np.random.default_rng(5)
    for _ in range(16):
        pick = keys.sample(int(rng.integers(2, min(14, len(keys)))), random_state=int(rng.integers(1 << 30)))
        heading_errors(obs.merge(pick, on=["aircraft", "flight"]))
    with pytest.raises(DataError, match="'ref_wind_speed_kt'.*in m/s"):
        heading_errors(obs.assign(ref_wind_speed_kt=obs["ref_wind_speed_kt"] * 1852 / 3600))


def test_a_coarser_report_quantization_fails_the_regression(tmp_path, capsys):
    """The baseline's tolerances catch a deliberate sensor change: TAMDAR lat/lon reported
    on a 0.02-deg grid instead of 0.01 (the truth is reused from the store: nothing re-flies)."""
    import yaml

    spec = yaml.safe_load((ROOT / "campaigns" / "quick.yaml").read_text())
    for study in ("wind_reports", "heading_correction"):
        spec["studies"][study].setdefault("sensors", {})["reports"] = {"lat_lon_step_deg": 0.02}
    path = tmp_path / "quick.yaml"
    path.write_text(yaml.safe_dump(spec))
    out = tmp_path / "quick"
    assert main(["run", str(path), "--out", str(out), "--quiet", "--no-report"]) == 0
    capsys.readouterr()
    assert main(["regress", str(out), str(ROOT / "campaigns" / "quick.baseline.json")]) == 1
    moved = capsys.readouterr().out
    assert "wind_reports." in moved and "heading_correction." in moved, moved
