"""validation/prediction_uncertainty.py on run tables made by hand: cells linear in a
calibrated parameter with known slopes and seed spreads, so the parameter's standard
error, the predicted cells' calibration spread and the conditional prediction are known
by hand."""

import sys
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "validation"))
import prediction_uncertainty as pu  # noqa: E402

N = 16
FROZEN = 800.0


def _standardized(rng, sd):
    x = rng.standard_normal(N)
    return (x - x.mean()) / x.std(ddof=1) * sd


def _fleet(duplicate_before: bool):
    """Per seed, the cells at the frozen parameter and their slopes (kn per nT)."""
    rng = np.random.default_rng(5)
    poor_before = 16.0 + _standardized(rng, 2.0)  # sd 2 kn, slope 0.01 kn/nT: the parameter's sd is 2 / 0.01 = 200 nT
    control_before = 11.0 + _standardized(rng, 1.0)  # no slope: no information on the parameter
    cells = {
        ("poor", "before", "total"): (poor_before, 0.01, "calibrated"),
        ("control", "before", "total"): (control_before, 0.0, "calibrated"),
        # an exact linear function of the two before totals: its conditional value is known
        ("poor", "improvement", "total"): (
            7.0 + 0.8 * (poor_before - 16.0) - 0.5 * (control_before - 11.0),
            0.02,
            "predicted",
        ),
        ("poor", "after_adjusted", "total"): (9.0 + 0.1 * (poor_before - 16.0), 0.005, "predicted"),
    }
    if duplicate_before:  # a component that is the total over again: it adds no information
        cells[("poor", "before", "transverse")] = (poor_before - 1.0, 0.01, "calibrated")
    return cells


PAPER = {
    ("poor", "before", "total"): 16.4,
    ("control", "before", "total"): 11.6,
    ("poor", "improvement", "total"): 8.2,
    ("poor", "after_adjusted", "total"): 8.2,
    ("poor", "before", "transverse"): 15.6,
}


def _write(root: Path, tag: str, cells, value: float) -> list[str]:
    runs = []
    for s in range(N):
        rows = [
            {
                "group": g,
                "period": p,
                "component": c,
                "paper_kt": PAPER[(g, p, c)],
                "simulated_kt": float(v[s] + slope * (value - FROZEN)),
                "role": role,
                "source": "hand",
            }
            for (g, p, c), (v, slope, role) in cells.items()
        ]
        d = root / f"{tag}-{s}" / "tables"
        d.mkdir(parents=True)
        pd.DataFrame(rows).to_parquet(d / "heading_correction.versus_paper.parquet")
        runs.append(str(d.parent))
    return runs


def _run(monkeypatch, capsys, tmp_path, duplicate_before=False):
    cells = _fleet(duplicate_before)
    frozen = _write(tmp_path, "f", cells, FROZEN)
    lo, hi = _write(tmp_path, "lo", cells, 680.0), _write(tmp_path, "hi", cells, 920.0)
    monkeypatch.setattr(
        sys,
        "argv",
        [
            "x",
            *frozen,
            "--frozen",
            "hard_iron_nT=800",
            "--variant",
            "hard_iron_nT=680",
            *lo,
            "--variant",
            "hard_iron_nT=920",
            *hi,
        ],
    )
    pu.main()
    out = {}
    for line in capsys.readouterr().out.splitlines():
        label, _, rest = line.partition(": ")
        out[label] = rest.split()
    return out


def test_the_parameter_is_known_as_well_as_the_before_cells_pin_it(monkeypatch, capsys, tmp_path):
    out = _run(monkeypatch, capsys, tmp_path)
    assert float(out["sensitivity.poor.improvement.total.hard_iron_nT"][0]) == pytest.approx(0.02)
    assert float(out["calibration.hard_iron_nT"][2]) == pytest.approx(200.0, rel=1e-3)  # 2 kn / 0.01 kn per nT
    # sd_cal = |slope| x 200 nT: 0.02 -> 4.0 kn, 0.005 -> 1.0 kn; total_se = hypot(se, sd_cal)
    imp = out["prediction.poor.improvement.total"]
    assert float(imp[imp.index("sd_cal") + 1]) == pytest.approx(4.0, abs=0.01)
    se = float(imp[imp.index("se") + 1])
    assert float(imp[imp.index("total_se") + 1]) == pytest.approx(np.hypot(se, 4.0), abs=0.01)
    adj = out["prediction.poor.after_adjusted.total"]
    assert float(adj[adj.index("sd_cal") + 1]) == pytest.approx(1.0, abs=0.01)


def test_a_component_that_repeats_its_total_adds_no_information(monkeypatch, capsys, tmp_path):
    """Weighed as independent, two copies of one cell would halve the variance (141 nT);
    the sandwich with the seeds' covariance keeps 200 nT."""
    out = _run(monkeypatch, capsys, tmp_path, duplicate_before=True)
    assert float(out["calibration.hard_iron_nT"][2]) == pytest.approx(200.0, rel=1e-3)


def test_the_prediction_for_the_papers_own_draw_given_its_before_cells(monkeypatch, capsys, tmp_path):
    out = _run(monkeypatch, capsys, tmp_path)
    # by hand at the paper's before totals 16.4 / 11.6 (the seeds' means 16.0 / 11.0):
    # 7.0 + 0.8 x 0.4 - 0.5 x 0.6 = 7.02, exact (no scatter)
    got = out["conditional.poor.improvement.total"]
    assert float(got[0]) == pytest.approx(7.02, abs=1e-6)
    assert float(got[got.index("scatter") + 1]) == pytest.approx(0.0, abs=1e-6)
    assert float(out["conditional.poor.after_adjusted.total"][0]) == pytest.approx(9.04, abs=1e-6)


def test_a_variant_with_other_seeds_is_refused_by_name(monkeypatch, capsys, tmp_path):
    cells = _fleet(False)
    frozen = _write(tmp_path, "f", cells, FROZEN)
    lo = _write(tmp_path, "lo", cells, 680.0)[:-1]
    monkeypatch.setattr(
        sys, "argv", ["x", *frozen, "--frozen", "hard_iron_nT=800", "--variant", "hard_iron_nT=680", *lo]
    )
    with pytest.raises(SystemExit, match=r"--variant hard_iron_nT=680: expected 16 runs"):
        pu.main()
