"""The campaign engine on a tiny wind-climatology campaign: identical metrics.json bytes
whatever the executor or worker count, resume after SIGKILL, no partial file read as a
result, one run directory per configuration, regression and the report."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from aerotruth.app.cli import main
from aerotruth.sim.campaign import TaskFailed, run_campaign
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.executors import ExecutorChoice

TINY = """\
name: tiny
seed: 11
periods:
  - name: p
    start: 2009-08-14
    end: 2009-08-17
studies:
  wind_climatology:
    regions:
      - {name: midwest, network: mesaba}
      - {name: box, lat_deg: [55, 60], lon_deg: [-160, -150]}
    periods: [p]
    flight_levels: [100, 250]
    hours_utc: [0, 12]
    points: 100
"""
N_TASKS = 8  # 2 regions x 4 days
LOCAL1 = ExecutorChoice("local", workers=1)
QUIET = {"progress": False, "log": lambda msg: None}


@pytest.fixture(scope="module")
def reference(tmp_path_factory) -> Path:
    """An uninterrupted 1-worker run of TINY (its metrics.json is the reference bytes)."""
    out = tmp_path_factory.mktemp("ref") / "run"
    s = run_campaign(parse_campaign(TINY), LOCAL1, out=out, **QUIET)
    assert (s.n_tasks, s.reused, s.ran) == (N_TASKS, 0, N_TASKS)
    return out


def metrics_bytes(run_dir: Path) -> bytes:
    return (run_dir / "metrics.json").read_bytes()


def test_metrics_hold_the_expected_keys_and_plausible_winds(reference):
    doc = json.loads(metrics_bytes(reference))
    m = doc["metrics"]
    assert doc["tasks"] == {"wind_climatology": N_TASKS}
    assert m["wind_climatology.samples"] == N_TASKS * 2 * 2 * 100
    for fl in ("FL100", "FL250"):
        mean, rms = m[f"wind_climatology.{fl}.speed_mean_mps"], m[f"wind_climatology.{fl}.speed_rms_mps"]
        assert 0 < mean <= rms <= m[f"wind_climatology.{fl}.speed_max_mps"]
    # the mean westerly grows with height towards the jet (truth atmosphere)
    assert m["wind_climatology.FL250.u_mean_mps"] > m["wind_climatology.FL100.u_mean_mps"] > 0


def test_two_local_workers_give_identical_metrics_bytes(reference, tmp_path):
    run_campaign(parse_campaign(TINY), ExecutorChoice("local", workers=2), out=tmp_path / "r2", **QUIET)
    assert metrics_bytes(tmp_path / "r2") == metrics_bytes(reference)


@pytest.mark.slow
def test_dask_localcluster_gives_identical_metrics_bytes(reference, tmp_path):
    run_campaign(parse_campaign(TINY), ExecutorChoice("dask", workers=2), out=tmp_path / "rd", **QUIET)
    assert metrics_bytes(tmp_path / "rd") == metrics_bytes(reference)


@pytest.mark.slow
def test_sigkill_midway_then_resume_gives_identical_metrics(reference, tmp_path):
    (tmp_path / "tiny.yaml").write_text(TINY)
    out = tmp_path / "killed"
    cmd = [
        sys.executable,
        "-m",
        "aerotruth.app.cli",
        "run",
        "tiny.yaml",
        "--workers",
        "1",
        "--out",
        str(out),
        "--no-report",
        "--quiet",
    ]
    proc = subprocess.Popen(
        cmd, cwd=tmp_path, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
    )
    deadline = time.monotonic() + 60
    while len(list((out / "tasks").glob("*.parquet"))) < 2:
        assert proc.poll() is None, proc.stderr.read().decode()
        assert time.monotonic() < deadline, "no task finished within 60 s"
        time.sleep(0.01)
    os.killpg(proc.pid, signal.SIGKILL)  # the driver and its pool workers (same session)
    proc.wait()
    proc.stderr.close()
    assert proc.returncode == -signal.SIGKILL
    done_before = sorted(p.name for p in (out / "tasks").glob("*.parquet"))
    assert 2 <= len(done_before) < N_TASKS and not (out / "metrics.json").exists()

    # a stray temporary with the name of a missing task must never be taken as its result
    manifest = json.loads((out / "manifest.json").read_text())
    missing = next(t for t in manifest["tasks"] if f"{t}.parquet" not in done_before)
    stray = out / "tasks" / f"{missing}.parquet.12345.deadbeef.tmp"
    stray.write_bytes(b"PAR1 not a parquet file")

    s = run_campaign(parse_campaign(TINY), LOCAL1, out=out, **QUIET)
    assert s.reused == len(done_before) and s.ran == N_TASKS - len(done_before)
    assert metrics_bytes(out) == metrics_bytes(reference)
    assert not stray.exists() and not list((out / "tasks").glob("*.tmp"))


def test_a_run_in_parts_at_its_time_limit_stores_each_part_and_ends_identical(reference, tmp_path):
    # a limit already past: each call starts exactly one task (progress is guaranteed), stores
    # it and pauses; the call that starts the last task finishes the run
    from aerotruth.sim.campaign import RunPaused

    out, parts = tmp_path / "parts", []
    while True:
        try:
            s = run_campaign(parse_campaign(TINY), LOCAL1, out=out, stop_after_s=0.0, **QUIET)
            break
        except RunPaused as e:
            parts.append(e.stored)
            assert not (out / "metrics.json").exists()
    assert parts == list(range(1, N_TASKS))
    assert (s.reused, s.ran) == (N_TASKS - 1, 1)
    assert metrics_bytes(out) == metrics_bytes(reference)
    # a limit not reached is no limit
    s = run_campaign(parse_campaign(TINY), LOCAL1, out=tmp_path / "whole", stop_after_s=3600.0, **QUIET)
    assert s.ran == N_TASKS and metrics_bytes(tmp_path / "whole") == metrics_bytes(reference)


def test_stop_after_on_the_command_line_exits_3_in_one_line_and_refuses_a_bad_value(tmp_path, capsys):
    (tmp_path / "tiny.yaml").write_text(TINY)
    args = ["run", str(tmp_path / "tiny.yaml"), "--out", str(tmp_path / "run"), "--workers", "1", "--quiet"]
    assert main([*args, "--stop-after", "0", "--no-report"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert "paused after" in err[-1] and "1 of 8 tasks stored" in err[-1] and "--stop-after 0" in err[-1]
    with pytest.raises(SystemExit) as e:
        main([*args, "--stop-after", "-1"])
    assert e.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "--stop-after" in err[0] and "expected a number of hours" in err[0]


def test_unreadable_result_file_is_recomputed_not_read(reference, tmp_path):
    out = tmp_path / "corrupt"
    run_campaign(parse_campaign(TINY), LOCAL1, out=out, **QUIET)
    victim = sorted((out / "tasks").glob("*.parquet"))[3]
    victim.write_bytes(victim.read_bytes()[:100])  # as if copied half-way by hand
    s = run_campaign(parse_campaign(TINY), LOCAL1, out=out, **QUIET)
    assert (s.reused, s.ran) == (N_TASKS - 1, 1)
    assert metrics_bytes(out) == metrics_bytes(reference)


def test_finished_run_is_reused_entirely(reference):
    s = run_campaign(parse_campaign(TINY), LOCAL1, out=reference, **QUIET)
    assert (s.reused, s.ran) == (N_TASKS, 0)


@pytest.mark.slow
def test_rerun_with_another_configuration_recomputes_what_it_changes(reference, tmp_path):
    out = tmp_path / "reconfigured"
    run_campaign(parse_campaign(TINY), LOCAL1, out=out, **QUIET)
    # another seed changes every task's stream: all rerun, and the result is a fresh run's
    s = run_campaign(parse_campaign(TINY.replace("seed: 11", "seed: 12")), LOCAL1, out=out, **QUIET)
    assert (s.reused, s.ran) == (0, N_TASKS)
    fresh = tmp_path / "fresh12"
    run_campaign(parse_campaign(TINY.replace("seed: 11", "seed: 12")), LOCAL1, out=fresh, **QUIET)
    assert metrics_bytes(out) == metrics_bytes(fresh) != metrics_bytes(reference)
    # one period day fewer: nothing reruns, the dropped day's tables leave the run directory
    s = run_campaign(
        parse_campaign(TINY.replace("seed: 11", "seed: 12").replace("end: 2009-08-17", "end: 2009-08-16")),
        LOCAL1,
        out=out,
        **QUIET,
    )
    assert (s.n_tasks, s.ran) == (N_TASKS - 2, 0)
    assert len(list((out / "tasks").glob("*.parquet"))) == N_TASKS - 2


def test_seed_changes_metrics_and_regress_catches_it_both_ways(reference, tmp_path, capsys):
    baseline = tmp_path / "baseline.json"
    assert main(["regress", str(reference), str(baseline), "--write", "--rel-tol", "1e-9"]) == 0
    assert main(["regress", str(reference), str(baseline)]) == 0
    moved = tmp_path / "seed12"
    run_campaign(parse_campaign(TINY.replace("seed: 11", "seed: 12")), LOCAL1, out=moved, **QUIET)
    capsys.readouterr()
    assert main(["regress", str(moved), str(baseline)]) == 1
    out = capsys.readouterr().out
    assert "wind_climatology.FL250.speed_mean_mps" in out and "MOVED" in out


def test_failed_task_stops_the_run_with_one_line_and_a_kept_traceback(tmp_path, capsys):
    # the truth atmosphere only models northern mid-latitudes: a polar box makes every task raise
    text = TINY.replace("lat_deg: [55, 60]", "lat_deg: [80, 86]")
    (tmp_path / "polar.yaml").write_text(text)
    out = tmp_path / "polar"
    assert main(["run", str(tmp_path / "polar.yaml"), "--workers", "1", "--out", str(out), "--quiet"]) == 2
    err = capsys.readouterr().err.strip().splitlines()[-1]
    assert err.startswith("aerotruth run: task wind_climatology--box--") and "ValueError" in err
    logs = list((out / "failed").glob("*.log"))
    assert len(logs) == 1 and "Traceback" in logs[0].read_text()
    with pytest.raises(TaskFailed):
        run_campaign(parse_campaign(text), LOCAL1, out=out, **QUIET)


def test_report_embeds_figures_and_the_metric_table(reference, capsys):
    assert main(["report", str(reference)]) == 0
    report = (reference / "report.md").read_text()
    assert "| FL250 |" in report
    images = [line.split("](")[1].rstrip(")") for line in report.splitlines() if line.startswith("![")]
    assert len(images) == 2
    for rel in images:
        png = reference / rel
        assert png.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert png.with_suffix(".pdf").read_bytes()[:5] == b"%PDF-"
    assert (reference / "tables" / "wind_climatology.wind_by_level.csv").exists()
    capsys.readouterr()
    assert main(["figures", str(reference)]) == 0
    assert capsys.readouterr().out.count(".png") == 2


def test_figures_of_an_unfinished_run_is_one_line(tmp_path, capsys):
    assert main(["figures", str(tmp_path)]) == 2
    assert (
        capsys.readouterr().err.strip()
        == f"aerotruth figures: {tmp_path} is not a run directory (no config.resolved.yaml)"
    )


def test_scheduler_with_local_executor_is_one_line(tmp_path, capsys):
    (tmp_path / "tiny.yaml").write_text(TINY)
    args = ["run", str(tmp_path / "tiny.yaml"), "--executor", "local", "--scheduler", "tcp://127.0.0.1:8786"]
    assert main(args) == 2
    assert capsys.readouterr().err.strip() == "aerotruth run: --scheduler needs --executor dask"
