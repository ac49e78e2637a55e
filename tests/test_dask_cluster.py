"""A real Dask cluster on loopback — a `dask scheduler` process and two `dask worker`
processes — runs the tiny campaign through `aerotruth run --scheduler ADDRESS`, with the
same metrics.json bytes as the local 1-worker run and tasks executed in both workers."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import pytest
from test_campaign_run import N_TASKS, QUIET, TINY

from aerotruth.app.cli import main
from aerotruth.sim.campaign import run_campaign
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.executors import ExecutorChoice

pytestmark = pytest.mark.slow  # every test here flies JSBSim or takes over 5 s


@pytest.fixture
def cluster(tmp_path):
    """Scheduler + two single-thread worker processes; yields the scheduler address."""
    sched_file = tmp_path / "scheduler.json"
    dask = [sys.executable, "-m", "dask"]
    procs = [
        subprocess.Popen(
            dask
            + [
                "scheduler",
                "--host",
                "127.0.0.1",
                "--port",
                "0",
                "--no-dashboard",
                "--scheduler-file",
                str(sched_file),
            ],
            stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL,
        )
    ]
    try:
        deadline = time.monotonic() + 60
        while not sched_file.exists():
            assert time.monotonic() < deadline and procs[0].poll() is None, "dask scheduler did not start"
            time.sleep(0.1)
        for name in ("w1", "w2"):
            procs.append(
                subprocess.Popen(
                    dask
                    + [
                        "worker",
                        "--scheduler-file",
                        str(sched_file),
                        "--nthreads",
                        "1",
                        "--nworkers",
                        "1",
                        "--no-dashboard",
                        "--name",
                        name,
                        "--host",
                        "127.0.0.1",
                    ],
                    stdout=subprocess.DEVNULL,
                    stderr=subprocess.DEVNULL,
                    cwd=tmp_path,
                )
            )
        from distributed import Client

        with Client(scheduler_file=str(sched_file), timeout="30s") as client:
            client.wait_for_workers(2, timeout=60)
            yield client.scheduler.address
    finally:
        for p in reversed(procs):  # only the processes this fixture started
            p.terminate()
        for p in procs:
            try:
                p.wait(timeout=20)
            except subprocess.TimeoutExpired:
                p.kill()
                p.wait()


def test_scheduler_and_two_worker_processes_run_the_campaign_identically(cluster, tmp_path, capsys):
    local = tmp_path / "local"
    run_campaign(parse_campaign(TINY), ExecutorChoice("local", workers=1), out=local, **QUIET)
    (tmp_path / "tiny.yaml").write_text(TINY)
    remote = tmp_path / "remote"
    assert (
        main(
            ["run", str(tmp_path / "tiny.yaml"), "--scheduler", cluster, "--out", str(remote), "--quiet", "--no-report"]
        )
        == 0
    )
    assert f"dask scheduler {cluster}" in capsys.readouterr().err
    assert (remote / "metrics.json").read_bytes() == (local / "metrics.json").read_bytes()
    assert json.loads((remote / "metrics.json").read_text())["tasks"] == {"wind_climatology": N_TASKS}

    from distributed import Client

    with Client(cluster) as client:
        executed = client.run(lambda dask_worker: dask_worker.state.executed_count)
        pids = client.run(os.getpid)
    assert len(executed) == 2 and sum(executed.values()) == N_TASKS and min(executed.values()) > 0
    assert len(set(pids.values())) == 2 and os.getpid() not in pids.values()
