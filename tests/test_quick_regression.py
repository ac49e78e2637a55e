"""campaigns/quick.yaml regressed against its committed baseline: a change that moves any
quick metric fails CI until the baseline is rewritten on purpose
(`aerotruth regress runs/quick campaigns/quick.baseline.json --write --rel-tol 1e-6 --abs-tol 1e-9`)."""

from pathlib import Path

from aerotruth.cli import main

ROOT = Path(__file__).resolve().parents[1]


def test_quick_campaign_matches_its_baseline(tmp_path, capsys):
    out = tmp_path / "quick"
    assert main(["run", str(ROOT / "campaigns" / "quick.yaml"), "--out", str(out), "--quiet", "--no-report"]) == 0
    code = main(["regress", str(out), str(ROOT / "campaigns" / "quick.baseline.json")])
    assert code == 0, capsys.readouterr().out
