"""Nothing lost, every fault survived (issue 51).

* A damaged run folder (a truncated metrics.json or tables/index.json, a damaged table or
  task table, no tables/) makes `report`, `figures` and `regress` say so in one line naming
  the file, exit 2, and write nothing; so does a baseline that compares nothing, is a
  folder or is not UTF-8.
* `aerotruth run` killed with SIGKILL at any moment leaves no process behind (its pool
  workers end with it, the fork server and resource tracker follow) and resumes to the
  bytes of an uninterrupted run.
* The truth store's eviction takes each flight's lock and never removes a flight, or a
  lock file, that another process holds.
"""

from __future__ import annotations

import hashlib
import json
import os
import random
import shutil
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from aerotruth.app.cli import main
from aerotruth.errors import UserError
from aerotruth.sim.campaign import run_campaign
from aerotruth.sim.campaign_loader import parse_campaign
from aerotruth.sim.executors import ExecutorChoice
from aerotruth.truth.store import TruthStore, locked

ONE_TASK = """\
name: faults
seed: 5
periods:
  - {name: p, dates: [2009-08-14]}
studies:
  wind_climatology:
    regions:
      - {name: midwest, network: mesaba}
    periods: [p]
    flight_levels: [100, 250]
    hours_utc: [0]
    points: 20
"""
QUIET = {"progress": False, "log": lambda msg: None}


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    """A finished one-task run (metrics, tables; no figures or report yet)."""
    out = tmp_path_factory.mktemp("faults") / "run"
    run_campaign(parse_campaign(ONE_TASK), ExecutorChoice("local", workers=1), out=out, **QUIET)
    return out


@pytest.fixture
def run_dir(finished, tmp_path) -> Path:
    """A copy of the finished run to damage."""
    return Path(shutil.copytree(finished, tmp_path / "run"))


def snapshot(folder: Path) -> dict[str, tuple[str, int, str]]:
    """Every entry under `folder`: kind, modification time and content digest."""
    out = {}
    for p in sorted(folder.rglob("*")):
        st = p.lstat()
        digest = hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else ""
        out[str(p.relative_to(folder))] = ("dir" if p.is_dir() else "file", st.st_mtime_ns, digest)
    return out


def refused(capsys, argv: list[str], folder: Path, names: Path) -> str:
    """Run the command: exit 2, one stderr line naming `names`, no traceback, `folder` untouched."""
    before = snapshot(folder)
    capsys.readouterr()
    assert main(argv) == 2
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1, captured.err
    assert lines[0].startswith(f"aerotruth {argv[0]}: {names}: "), lines[0]
    assert "Traceback" not in captured.err and captured.out == ""
    assert snapshot(folder) == before, "written before the refusal"
    return lines[0]


def truncate(path: Path, keep: float = 0.5) -> None:
    data = path.read_bytes()
    path.write_bytes(data[: int(len(data) * keep)])


def first_task(run: Path) -> Path:
    return sorted((run / "tasks").glob("*.parquet"))[0]


def first_table(run: Path) -> Path:
    return sorted((run / "tables").glob("*.parquet"))[0]


DAMAGES = {
    # name: (damage the copy, the file the line must name)
    "truncated metrics.json": (lambda r: truncate(r / "metrics.json"), lambda r: r / "metrics.json"),
    "truncated tables/index.json": (
        lambda r: truncate(r / "tables" / "index.json"),
        lambda r: r / "tables" / "index.json",
    ),
    "damaged table": (lambda r: truncate(first_table(r), 0.8), first_table),
    "no tables/": (lambda r: shutil.rmtree(r / "tables"), lambda r: r / "tables"),
    "damaged task table": (lambda r: truncate(first_task(r), 0.8), first_task),
    "missing task table": (lambda r: first_task(r).rename(r / "elsewhere.parquet"), lambda r: first_task_name(r)),
    "truncated manifest.json": (lambda r: truncate(r / "manifest.json"), lambda r: r / "manifest.json"),
}


def first_task_name(run: Path) -> Path:
    manifest = json.loads((run / "manifest.json").read_text())
    return run / "tasks" / f"{sorted(manifest['tasks'])[0]}.parquet"


@pytest.mark.parametrize("command", ["report", "figures"])
@pytest.mark.parametrize("damage", list(DAMAGES))
def test_a_damaged_run_folder_is_one_line_naming_the_file_and_nothing_is_written(run_dir, capsys, command, damage):
    spoil, named = DAMAGES[damage]
    target = named(run_dir)
    spoil(run_dir)
    refused(capsys, [command, str(run_dir)], run_dir, target)


def test_the_damaged_table_line_says_what_is_wrong(run_dir, capsys):
    truncate(first_table(run_dir), 0.8)
    line = refused(capsys, ["report", str(run_dir)], run_dir, first_table(run_dir))
    assert "not a readable Parquet table" in line and "rerun `aerotruth run`" in line


def test_an_intact_copy_reports_and_draws_leaving_no_staging_folder(run_dir, capsys):
    assert main(["report", str(run_dir)]) == 0
    assert (run_dir / "report.md").read_text().count("![") == 2
    assert sorted(p.suffix for p in (run_dir / "figures").iterdir()) == [".pdf", ".pdf", ".png", ".png"]
    assert not list(run_dir.glob(".figures-*"))


def test_a_study_failing_half_way_through_its_figures_leaves_the_figures_as_they_were(run_dir, capsys, monkeypatch):
    from aerotruth.sim.studies.wind_climatology import STUDY

    drawn = type(STUDY).figures

    def half(self, rows, summary, learned, out_dir):
        drawn(self, rows, summary, learned, out_dir)  # every figure saved, then:
        raise UserError("studies.wind_climatology: figures failed half-way")

    monkeypatch.setattr(type(STUDY), "figures", half)
    before = snapshot(run_dir)
    assert main(["figures", str(run_dir)]) == 2
    assert "failed half-way" in capsys.readouterr().err
    assert snapshot(run_dir) == before


def test_regress_on_a_truncated_metrics_json_is_one_line(run_dir, tmp_path, capsys):
    baseline = tmp_path / "b.json"
    baseline.write_text(json.dumps({"metrics": {"wind_climatology.samples": 40}}))
    assert main(["regress", str(run_dir), str(baseline)]) == 0
    truncate(run_dir / "metrics.json")
    line = refused(capsys, ["regress", str(run_dir), str(baseline)], tmp_path, run_dir / "metrics.json")
    assert "not valid JSON" in line


@pytest.mark.parametrize(
    "kind, expected",
    [
        ("empty", "a baseline that compares nothing cannot fail"),
        ("folder", "is a folder, expected a baseline JSON file"),
        ("latin-1", "not UTF-8 text"),
        ("nan", "expected a finite number or null"),
        ("infinite tolerance", "expected a non-negative number"),
        ("repeated metric", "given twice"),
    ],
)
def test_a_baseline_that_cannot_be_a_gate_is_one_line(finished, tmp_path, capsys, kind, expected):
    b = tmp_path / "baseline.json"
    if kind == "empty":
        b.write_text('{"metrics": {}}')
    elif kind == "folder":
        b.mkdir()
    elif kind == "latin-1":
        b.write_bytes('{"comment": "Mesaba Airlines, Flugh\xe4fen", "metrics": {"x": 1}}'.encode("latin-1"))
    elif kind == "nan":
        b.write_text('{"metrics": {"wind_climatology.samples": NaN}}')
    elif kind == "infinite tolerance":
        b.write_text('{"default": {"abs": Infinity}, "metrics": {"wind_climatology.samples": 1}}')
    else:
        b.write_text('{"metrics": {"wind_climatology.samples": 40, "wind_climatology.samples": 41}}')
    before = snapshot(finished)
    capsys.readouterr()
    assert main(["regress", str(finished), str(b)]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "Traceback" not in err
    assert expected in err
    assert kind == "infinite tolerance" or err.startswith(f"aerotruth regress: {b}: ")
    assert snapshot(finished) == before


# -- the truth store's eviction ----------------------------------------------------------

HOLDER = """\
import fcntl, sys
f = open(sys.argv[1], "a")
fcntl.flock(f, fcntl.LOCK_EX)
print("held", flush=True)
sys.stdin.read()  # until the test closes our stdin
"""


def flights(root: Path, ages: dict[str, float]) -> dict[str, Path]:
    """Fake stored flights of 1000 bytes, used `age` seconds before 1e9."""
    out = {}
    for name, age in ages.items():
        p = root / "ab" / f"{name}.parquet"
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_bytes(b"x" * 1000)
        os.utime(p, (1e9 - age, 1e9 - age))
        out[name] = p
    return out


def test_eviction_keeps_a_flight_whose_lock_another_process_holds(tmp_path):
    files = flights(tmp_path, {"old": 300, "mid": 200, "new": 100})
    lock = files["old"].with_suffix(".lock")
    holder = subprocess.Popen(
        [sys.executable, "-c", HOLDER, str(lock)], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True
    )
    try:
        assert holder.stdout.readline().strip() == "held"
        # the least recently used flight is being read or flown elsewhere: kept, with its lock
        assert TruthStore(tmp_path).evict(1000) == (2, 2000)
        assert files["old"].exists() and lock.exists()
        assert not files["mid"].exists() and not files["new"].exists()
        assert not files["mid"].with_suffix(".lock").exists()
    finally:
        holder.stdin.close()
        holder.wait(timeout=10)
    assert TruthStore(tmp_path).evict(0) == (1, 1000)
    assert not files["old"].exists() and not lock.exists()


def test_a_lock_file_removed_while_another_waits_on_it_still_excludes(tmp_path):
    # evict removes a flight's lock file while it holds it; a process that was waiting on
    # that file must not believe it holds the key's lock while a third one locks the new file
    lock = tmp_path / "k.lock"
    got = threading.Event()
    release = threading.Event()

    def waiter():
        with locked(lock):
            got.set()
            release.wait(10)

    with locked(lock):
        t = threading.Thread(target=waiter)
        t.start()
        time.sleep(0.2)  # the waiter blocks on the file about to be removed
        lock.unlink()
    assert got.wait(10)
    try:
        with locked(lock, wait=False) as mine:
            assert not mine, "two holders of one key's lock"
        assert lock.exists()
    finally:
        release.set()
        t.join(10)
    with locked(lock, wait=False) as mine:
        assert mine


def test_a_flight_evicted_with_its_lock_file_is_flown_again_under_a_fresh_lock(tmp_path):
    import numpy as np
    import pandas as pd

    from aerotruth.truth.track import COLUMNS, TruthTrack

    def fly():
        flown.append(1)
        df = pd.DataFrame({c: np.linspace(0.0, 1.0, 5) for c in COLUMNS if c not in ("leg_index", "phase")})
        df["leg_index"] = np.zeros(5, dtype=np.int32)
        df["phase"] = pd.Categorical(["cruise"] * 5, categories=["climb", "cruise", "descent", "approach"])
        return TruthTrack(df, {"route": "X-Y", "seed": 4})

    store, flown, key = TruthStore(tmp_path), [], "k" + "0" * 31
    assert store._cached(key, "x", fly)[2] and store._cached(key, "x", fly)[2] is False
    size = store.size_bytes()
    assert store.evict(0) == (1, size)
    assert not store.files() and not list(tmp_path.glob("*/*.lock"))
    track, diverged, now = store._cached(key, "x", fly)
    assert now and track is not None and diverged is None and len(flown) == 2


def test_a_resumed_run_drops_the_temporaries_a_killed_one_left_in_any_of_its_folders(run_dir):
    """A run killed between writing a file's temporary and renaming it (CI seed 2712450051:
    tables/wind_climatology.wind_by_level.md.2250.cd53e410.tmp) leaves that temporary; the
    resumed run must end with the same files as an uninterrupted one, temporaries gone,
    whatever folder of the run they are in. A file of another name ending in .tmp is not
    one of the run's temporaries and stays."""
    before = {p.relative_to(run_dir) for p in run_dir.rglob("*") if p.is_file()}
    table = next((run_dir / "tables").iterdir()).name
    (run_dir / "figures" / "sub").mkdir(parents=True)
    planted = [
        run_dir / "tables" / f"{table}.2250.cd53e410.tmp",
        run_dir / "metrics.json.31.0123abcd.tmp",
        run_dir / "figures" / "sub" / "wind.png.7.deadbeef.tmp",
        run_dir / "tasks" / "t.parquet.12.89abcdef.tmp",
        run_dir / ".aerotruth-probe.55.00ff00ff.tmp",
    ]
    for p in planted:
        p.write_bytes(b"half")
    kept = run_dir / "tables" / "notes.tmp"  # not a temporary's name
    kept.write_bytes(b"mine")
    run_campaign(parse_campaign(ONE_TASK), ExecutorChoice("local", workers=1), out=run_dir, **QUIET)
    assert not any(p.exists() for p in planted), [str(p) for p in planted if p.exists()]
    assert kept.read_bytes() == b"mine"
    after = {p.relative_to(run_dir) for p in run_dir.rglob("*") if p.is_file()} - {kept.relative_to(run_dir)}
    assert after == before


# -- SIGKILL of `aerotruth run` ------------------------------------------------------------

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
KILLS = 5
GRACE_S = 5.0


def session_processes(sid: int) -> dict[int, str]:
    """Live (not zombie) processes of session `sid`: pid -> command line."""
    out = {}
    for d in Path("/proc").iterdir():
        if not d.name.isdigit():
            continue
        try:
            stat = (d / "stat").read_text()
            cmd = (d / "cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace")
        except OSError:
            continue
        fields = stat[stat.rindex(")") + 2 :].split()  # after "pid (comm) "
        state, session = fields[0], int(fields[3])
        if session == sid and state != "Z":
            out[int(d.name)] = cmd.strip()
    return out


def outlived(sid: int, since: float) -> tuple[dict[int, str], float]:
    """The processes of session `sid` still there GRACE_S after `since` (killed then, as
    this test started them), and when the last one went."""
    left = session_processes(sid)
    while left and time.monotonic() - since < GRACE_S:
        time.sleep(0.02)
        left = session_processes(sid)
    for pid in left:
        os.kill(pid, signal.SIGKILL)
    return left, time.monotonic() - since


def outputs(run: Path) -> dict[str, bytes]:
    files = [run / "metrics.json", *sorted((run / "tables").iterdir())]
    return {str(p.relative_to(run)): p.read_bytes() for p in files}


@pytest.mark.slow
@pytest.mark.skipif(not Path("/proc/self/stat").exists(), reason="reads the process table from /proc")
def test_sigkill_at_random_moments_leaves_no_process_and_resumes_to_identical_bytes(tmp_path):
    (tmp_path / "tiny.yaml").write_text(TINY)

    def cli(out: Path) -> subprocess.Popen:
        cmd = [sys.executable, "-m", "aerotruth.app.cli", "run", "tiny.yaml", "--workers", "2"]
        cmd += ["--out", str(out), "--no-report", "--quiet"]
        # its own session: every process it starts is found by session id after the kill
        return subprocess.Popen(
            cmd, cwd=tmp_path, start_new_session=True, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE
        )

    def until(proc: subprocess.Popen, ready, since: float, seconds: float) -> tuple[bool, float]:
        """Wait until `ready()`, then `seconds` more from then (or from `since` without a
        condition): whether the process still runs, and for how long it ran after `ready()`
        (or `since`) if it ended first (its work, when `ready` is the manifest)."""
        while ready is not None and not ready():
            if proc.poll() is not None:
                return False, 0.0
            time.sleep(0.002)
        start = since if ready is None else time.monotonic()
        while time.monotonic() - start < seconds:
            if proc.poll() is not None:
                return False, time.monotonic() - start
            time.sleep(0.002)
        return proc.poll() is None, time.monotonic() - start

    # the uninterrupted run, twice: the first fills the caches the killed runs will find
    # full (timed on it, the last quarter of the work would lie beyond the end of a warm
    # run); the second gives the bytes, its start-up (until the run folder's manifest is
    # written) and its work (executor, tasks, summary) timed
    warm = cli(tmp_path / "warm")
    assert warm.wait(300) == 0, warm.stderr.read().decode()
    warm.stderr.close()
    t0 = time.monotonic()
    ref = cli(tmp_path / "ref")
    assert until(ref, lambda: (tmp_path / "ref" / "manifest.json").exists(), t0, 0)[0] or ref.returncode == 0
    startup = time.monotonic() - t0
    assert ref.wait(300) == 0, ref.stderr.read().decode()
    ref.stderr.close()
    work = time.monotonic() - t0 - startup
    reference = outputs(tmp_path / "ref")
    assert outputs(tmp_path / "warm") == reference  # a cold and a warm run write the same bytes

    seed = int(os.environ.get("AEROTRUTH_KILL_SEED", time.time_ns() % 2**32))
    rng = random.Random(seed)
    report = []
    for i in range(KILLS):
        out = tmp_path / f"killed{i}"
        # the first moment in the start-up, one in each quarter of the work after it
        for _attempt in range(3):
            shutil.rmtree(out, ignore_errors=True)
            proc = cli(out)
            if i == 0:
                moment = rng.uniform(0, startup)
                hit, _ = until(proc, None, time.monotonic(), moment)
                what = f"{moment:.2f} s after the start"
            else:
                # within the first 90 % of each quarter: a killed run's work can be ~10 %
                # shorter than the timed one's, and a moment past its end kills nothing
                moment = work * (i - 1 + 0.9 * rng.random()) / (KILLS - 1)
                hit, ran = until(proc, lambda o=out: (o / "manifest.json").exists(), 0, moment)
                what = f"{moment:.2f} s into the run"
                if not hit and ran > 0:
                    # it finished first: this machine's work is as long as this run's was now,
                    # and the quarters are drawn again on it (a busy machine timed the first)
                    work = min(work, ran)
            if hit:
                break  # still running at the moment: kill it there
            proc.wait()
            proc.stderr.close()
        else:
            pytest.fail(f"seed {seed}: the run finished before every moment drawn in stratum {i}")
        os.kill(proc.pid, signal.SIGKILL)  # the main process only, as `kill -9 PID` does
        killed_at = time.monotonic()
        proc.wait()
        proc.stderr.close()
        at_death = snapshot(out) if out.exists() else {}
        left, gone_after = outlived(proc.pid, killed_at)
        assert not left, f"seed {seed}: kill {what} left {left}"
        # only the driver writes the run folder, under its lock: nothing changed after its death
        assert (snapshot(out) if out.exists() else {}) == at_death, f"seed {seed}: written after the kill"
        done = len(list((out / "tasks").glob("*.parquet"))) if (out / "tasks").exists() else 0
        report.append(f"kill {what}: {done} tasks stored, all processes gone in {gone_after:.2f} s")

        resumed = cli(out)
        assert resumed.wait(300) == 0, resumed.stderr.read().decode()
        resumed.stderr.close()
        assert outputs(out) == reference, f"seed {seed}: kill {what}"
        assert not outlived(resumed.pid, time.monotonic())[0]
    print(f"seed {seed}, uninterrupted run: start-up {startup:.2f} s, work {work:.2f} s;", "; ".join(report))
