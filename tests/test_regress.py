"""`aerotruth regress`: a metric outside |got - value| <= abs + rel*|value| fails with a
non-zero exit and a table naming it; inside, it passes."""

from __future__ import annotations

import json

import pytest

from aerotruth.app.cli import main
from aerotruth.app.regress import BaselineError, Check, load_baseline
from aerotruth.sim.store import RunStore


@pytest.fixture
def run_dir(tmp_path):
    d = tmp_path / "run"
    d.mkdir()
    RunStore(d).write_metrics({"metrics": {"w.speed": 10.0, "w.n": 4, "w.nan": float("nan")}})
    return d


def baseline(tmp_path, doc) -> str:
    p = tmp_path / "baseline.json"
    p.write_text(json.dumps(doc))
    return str(p)


def test_tolerance_rule_is_abs_plus_rel_times_baseline():
    assert Check("m", 10.0, 10.6, abs_tol=0.1, rel_tol=0.05).ok  # 0.6 <= 0.1 + 0.5
    assert not Check("m", 10.0, 10.61, abs_tol=0.1, rel_tol=0.05).ok
    assert Check("m", 10.0, 9.4, abs_tol=0.1, rel_tol=0.05).ok
    assert not Check("m", 10.0, 10.0 + 1e-12, abs_tol=0.0, rel_tol=0.0).ok
    assert Check("m", None, None, 0.0, 0.0).ok and not Check("m", None, 1.0, 1.0, 1.0).ok


def test_regress_passes_within_tolerance(tmp_path, run_dir, capsys):
    b = baseline(
        tmp_path, {"default": {"rel": 0.01}, "metrics": {"w.speed": 10.05, "w.n": {"value": 4}, "w.nan": None}}
    )
    assert main(["regress", str(run_dir), b]) == 0
    assert capsys.readouterr().out.strip() == "3 of 3 metrics within tolerance"


def test_regress_fails_when_a_metric_moved_and_names_it(tmp_path, run_dir, capsys):
    b = baseline(tmp_path, {"metrics": {"w.speed": {"value": 9.0, "abs": 0.5}, "w.n": 4}})
    assert main(["regress", str(run_dir), b]) == 1
    out = capsys.readouterr().out
    moved = [line for line in out.splitlines() if "MOVED" in line]
    assert len(moved) == 1 and moved[0].split()[:4] == ["w.speed", "9", "10", "1"]
    assert out.strip().endswith("1 of 2 metrics within tolerance, 1 moved")


def test_metric_missing_from_the_run_fails(tmp_path, run_dir, capsys):
    b = baseline(tmp_path, {"metrics": {"w.gone": 1.0}})
    assert main(["regress", str(run_dir), b]) == 1
    assert "missing" in capsys.readouterr().out


def test_written_baseline_passes_then_fails_after_an_edit(tmp_path, run_dir):
    b = str(tmp_path / "b.json")
    assert main(["regress", str(run_dir), b, "--write", "--rel-tol", "0.02"]) == 0
    assert main(["regress", str(run_dir), b]) == 0
    doc = json.loads(open(b).read())
    doc["metrics"]["w.speed"]["value"] = 10.3  # 0.3 > 0.02 * 10.3
    open(b, "w").write(json.dumps(doc))
    assert main(["regress", str(run_dir), b]) == 1


def test_bad_baseline_is_one_line_exit_2(tmp_path, run_dir, capsys):
    b = baseline(tmp_path, {"metrics": {"w.speed": {"value": 1.0, "abs": -1}}})
    assert main(["regress", str(run_dir), b]) == 2
    assert (
        capsys.readouterr().err.strip()
        == f"aerotruth regress: {b}: metrics.w.speed.abs: expected a non-negative number, got -1"
    )
    with pytest.raises(BaselineError, match="not valid JSON"):
        p = tmp_path / "broken.json"
        p.write_text("{")
        load_baseline(p)


def test_regress_on_an_unfinished_run_is_one_line(tmp_path, capsys):
    b = baseline(tmp_path, {"metrics": {}})
    assert main(["regress", str(tmp_path / "nothere"), b]) == 2
    assert "nothere: no such run directory" in capsys.readouterr().err
    assert main(["regress", str(tmp_path), b]) == 2  # a folder, but no run's
    assert "is not a run directory" in capsys.readouterr().err
    (tmp_path / "config.resolved.yaml").write_text("name: x\n")
    assert main(["regress", str(tmp_path), b]) == 2
    assert "has no metrics.json" in capsys.readouterr().err


def test_write_to_a_folder_or_a_missing_folder_is_one_line(tmp_path, run_dir, capsys):
    assert main(["regress", str(run_dir), str(tmp_path), "--write"]) == 2
    assert "is a folder, expected the baseline's file name" in capsys.readouterr().err
    assert main(["regress", str(run_dir), str(tmp_path / "no" / "b.json"), "--write"]) == 2
    assert "does not exist" in capsys.readouterr().err
    with pytest.raises(SystemExit) as e:
        main(["regress", str(run_dir), str(tmp_path / "b.json"), "--write", "--rel-tol", "-0.1"])
    assert e.value.code == 2 and "expected a non-negative number" in capsys.readouterr().err
    assert not (tmp_path / "b.json").exists()
