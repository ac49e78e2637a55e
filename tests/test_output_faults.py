"""Output places that refuse writes (issue 51): a read-only file system, a folder without
permission, a full disk or a quota, and a device given as the output (/dev/full). Every
command checks its output folder or file with a probe write before any work
(aerotruth.errors.output_folder / output_file) and every write goes through
aerotruth.files, whose OSErrors are one line naming the path and the system's reason:
exit status 2, one stderr line, no traceback, nothing flown or computed, nothing written.

The faults are injected at the one I/O layer (CI runs as root, which chmod does not stop):
creating a file or a folder under the output place raises EROFS or EACCES (os.open with
O_CREAT, os.mkdir: what the probe and the atomic writers call), or flushing data to the disk
raises ENOSPC or EDQUOT (os.fsync, which the probe and every atomic write call), as a
full disk does on ext4, where the data blocks are only allocated then."""

from __future__ import annotations

import errno
import hashlib
import os
import stat
import sys
from pathlib import Path

import pytest

from aerotruth.app.cli import main
from aerotruth.errors import OutputError, output_file, output_folder
from aerotruth.files import atomic_write, atomic_write_text, make_folder

sys.path.insert(0, str(Path(__file__).parent))

REASONS = {
    errno.EROFS: "Read-only file system (EROFS)",
    errno.EACCES: "Permission denied (EACCES)",
    errno.ENOSPC: "No space left on device (ENOSPC)",
    errno.EDQUOT: "Disk quota exceeded (EDQUOT)",
}
AT_CREATE = (errno.EROFS, errno.EACCES)  # met when making a file or folder
AT_FLUSH = (errno.ENOSPC, errno.EDQUOT)  # met when the data reach the disk


def _under(path, where: Path) -> bool:
    try:
        p = Path(os.fsdecode(path))
    except TypeError:
        return False
    p = (p if p.is_absolute() else Path.cwd() / p).resolve()
    return p == where or where in p.parents


@pytest.fixture
def disk(monkeypatch):
    """`disk(code, where)`: from now on the file system under `where` refuses writes with
    errno `code` (at creation for EROFS/EACCES, at the flush for ENOSPC/EDQUOT)."""

    def refuse(code: int, where: Path) -> None:
        where = Path(where).resolve()
        real_open, real_mkdir = os.open, os.mkdir

        def fail(path=None):
            raise OSError(code, os.strerror(code), *([os.fspath(path)] if path is not None else []))

        if code in AT_CREATE:

            def opener(path, flags, mode=0o777, *a, **k):
                if flags & os.O_CREAT and _under(path, where):
                    fail(path)
                return real_open(path, flags, mode, *a, **k)

            def mkdir(path, mode=0o777, *a, **k):
                if _under(path, where):
                    fail(path)
                return real_mkdir(path, mode, *a, **k)

            monkeypatch.setattr(os, "open", opener)
            monkeypatch.setattr(os, "mkdir", mkdir)
        else:

            def fsync(fd):
                fail()

            monkeypatch.setattr(os, "fsync", fsync)

    return refuse


def _never(what: str):
    def called(*a, **k):
        raise AssertionError(f"{what} was called before the output was checked")

    return called


def refused(capsys, argv: list[str], path: Path | str, code: int) -> str:
    """The command exits 2 with one stderr line naming `path` and the reason of `code`."""
    capsys.readouterr()
    assert main([str(a) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err, err
    assert str(path) in err and os.strerror(code) in err, err
    return err


def listing(folder: Path) -> dict[str, str]:
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest() if p.is_file() else "dir"
        for p in sorted(folder.rglob("*"))
    }


# ---- the one I/O layer itself


@pytest.mark.parametrize("code", list(REASONS))
def test_the_probe_names_the_folder_and_the_reason_and_leaves_nothing(tmp_path, disk, code):
    disk(code, tmp_path)
    with pytest.raises(OutputError) as e:
        output_folder(tmp_path / "new" / "deeper", "--out")
    assert str(e.value) == f"--out: cannot write {tmp_path}: {REASONS[code]}"
    assert list(tmp_path.iterdir()) == []


@pytest.mark.parametrize("code", list(REASONS))
def test_an_atomic_write_that_fails_leaves_the_old_file_and_no_temporary(tmp_path, disk, code):
    target = tmp_path / "table.csv"
    target.write_text("old\n")
    disk(code, tmp_path)
    with pytest.raises(OutputError) as e:
        atomic_write_text(target, "new\n")
    assert str(e.value) == f"cannot write {target}: {REASONS[code]}"
    assert target.read_text() == "old\n" and sorted(p.name for p in tmp_path.iterdir()) == ["table.csv"]


def test_an_oserror_inside_the_writer_is_one_line_naming_the_final_file(tmp_path):
    def writer(tmp: Path) -> None:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(tmp))  # as pyarrow / matplotlib raise it

    with pytest.raises(OutputError, match=r"^cannot write .*out\.parquet: No space left on device \(ENOSPC\)$"):
        atomic_write(tmp_path / "out.parquet", writer)
    assert list(tmp_path.iterdir()) == []


def test_make_folder_names_the_folder(tmp_path, disk):
    disk(errno.EROFS, tmp_path)
    with pytest.raises(OutputError, match=r"--out: cannot write .*/figs: Read-only file system \(EROFS\)"):
        make_folder(tmp_path / "figs", "--out")


@pytest.mark.parametrize("device", ["/dev/full", "/dev/null"])
def test_a_device_is_never_replaced_by_the_rename(device):
    before = os.stat(device)
    for check in (lambda: output_file(device), lambda: output_folder(device), lambda: atomic_write_text(device, "x")):
        with pytest.raises(ValueError, match=device):
            check()
    after = os.stat(device)
    assert stat.S_ISCHR(after.st_mode) and (after.st_ino, after.st_rdev) == (before.st_ino, before.st_rdev)


def test_output_file_refuses_a_missing_folder_and_a_folder_in_place_of_the_file(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        output_file(tmp_path / "nope" / "x.parquet")
    with pytest.raises(ValueError, match="is a folder"):
        output_file(tmp_path)
    (tmp_path / "f").write_text("")
    with pytest.raises(ValueError, match="is a file, not a folder"):
        output_folder(tmp_path / "f" / "sub")


# ---- every command: checked before any work


@pytest.fixture
def inputs(tmp_path):
    """Input files in their own folder (never written)."""
    import approach_log_generator as gen

    d = tmp_path / "in"
    d.mkdir()
    log, _ = gen.make_log(1, seed=3)
    log.to_csv(d / "log.csv", index=False)
    (d / "obs.csv").write_text("aircraft,time\n")  # never read: the output is checked first
    (d / "tables.csv").write_text("aircraft\n")
    (d / "traffic.csv").write_text("icao24,timestamp\n")
    return d


FOLDER_COMMANDS = {
    # name: (argv with {out} and {in}, the function that would start the work)
    "fits": (["fits", "{in}/log.csv", "--out", "{out}"], "aerotruth.app.fits.read_approach_log"),
    "diagnose": (["diagnose", "{in}/log.csv", "--out", "{out}"], "aerotruth.measured.kinds.load_measured"),
    "heading fit": (
        ["heading", "fit", "{in}/obs.csv", "--out", "{out}"],
        "aerotruth.app.heading_fit.observations_or_traffic_hint",
    ),
    "heading apply": (
        ["heading", "apply", "{in}/obs.csv", "--tables", "{in}/tables.csv", "--out", "{out}"],
        "aerotruth.app.heading_apply.read_tables",
    ),
}


@pytest.mark.parametrize("code", list(REASONS))
@pytest.mark.parametrize("command", list(FOLDER_COMMANDS))
def test_a_folder_command_refuses_an_unwritable_output_before_reading_its_input(
    tmp_path, inputs, disk, monkeypatch, capsys, command, code
):
    argv, work = FOLDER_COMMANDS[command]
    monkeypatch.setattr(work, _never(work))
    where = tmp_path / "outputs"
    where.mkdir()
    disk(code, where)
    out = where / "result"
    refused(capsys, [a.format(out=out, **{"in": inputs}) for a in argv], where, code)
    assert list(where.iterdir()) == []


@pytest.mark.parametrize("command", list(FOLDER_COMMANDS))
def test_a_folder_command_refuses_a_device_as_its_output_folder(tmp_path, inputs, monkeypatch, capsys, command):
    argv, work = FOLDER_COMMANDS[command]
    monkeypatch.setattr(work, _never(work))
    capsys.readouterr()
    assert main([a.format(out="/dev/full", **{"in": inputs}) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "/dev/full" in err and "not a folder" in err
    assert stat.S_ISCHR(os.stat("/dev/full").st_mode)


def test_a_write_failing_half_way_is_one_line_and_leaves_no_temporary(tmp_path, monkeypatch, capsys):
    """The probe passes, the disk fills while the FITS writes its files."""
    import approach_log_generator as gen

    log, _ = gen.make_log(2, seed=4)
    log.to_csv(tmp_path / "log.csv", index=False)
    real, calls = os.fsync, []

    def fsync(fd):
        calls.append(fd)
        if len(calls) > 2:  # the probe and the first file pass
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(fd)

    monkeypatch.setattr(os, "fsync", fsync)
    out = tmp_path / "out"
    refused(capsys, ["fits", tmp_path / "log.csv", "--out", out], out / "trajectory_8hz.csv", errno.ENOSPC)
    assert sorted(p.name for p in out.iterdir()) == ["trajectory.csv"]  # complete files only, no *.tmp


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


@pytest.mark.parametrize("code", list(REASONS))
def test_run_refuses_an_unwritable_run_folder_before_running(tmp_path, disk, monkeypatch, capsys, code):
    campaign = tmp_path / "c.yaml"
    campaign.write_text(ONE_TASK)
    monkeypatch.setattr("aerotruth.sim.campaign.run_campaign", _never("run_campaign"))
    where = tmp_path / "runs"
    where.mkdir()
    disk(code, where)
    refused(capsys, ["run", campaign, "--out", where / "r", "--quiet"], where, code)
    assert list(where.iterdir()) == []


@pytest.mark.parametrize("code", [errno.EROFS, errno.ENOSPC])
def test_validate_writes_nothing_so_an_unwritable_disk_does_not_matter(tmp_path, disk, capsys, code):
    campaign = tmp_path / "c.yaml"
    campaign.write_text(ONE_TASK)
    disk(code, Path("/"))
    assert main(["validate", str(campaign)]) == 0
    assert "ok" in capsys.readouterr().out


# ---- file outputs: fly, fly-approach, reports, regress --write

FILE_COMMANDS = {
    "fly": (
        ["fly", "--from", "KMSP", "--to", "KDLH", "--date", "2009-08-15", "--out", "{out}"],
        "leg.parquet",
        "aerotruth.truth.flight.fly_leg",
    ),
    "fly-approach": (
        ["fly-approach", "--airport", "KDLH", "--runway", "27", "--date", "2009-08-15", "--out", "{out}"],
        "ils.parquet",
        "aerotruth.truth.approach.fly_approach",
    ),
    "reports": (["reports", "{in}/traffic.csv", "--out", "{out}"], "obs.parquet", "aerotruth.app.reports.read_traffic"),
}


@pytest.mark.parametrize("code", list(REASONS))
@pytest.mark.parametrize("command", [(c) for c in FILE_COMMANDS])
def test_a_file_command_refuses_an_unwritable_folder_before_any_flight(
    tmp_path, inputs, disk, monkeypatch, capsys, command, code
):
    argv, name, work = FILE_COMMANDS[command]
    monkeypatch.setattr(work, _never(work))
    where = tmp_path / "outputs"
    where.mkdir()
    disk(code, where)
    refused(capsys, [a.format(out=where / name, **{"in": inputs}) for a in argv], where, code)
    assert list(where.iterdir()) == []


@pytest.mark.parametrize("command", [(c) for c in FILE_COMMANDS])
def test_a_file_command_refuses_dev_full_before_any_flight(tmp_path, inputs, monkeypatch, capsys, command):
    argv, _, work = FILE_COMMANDS[command]
    monkeypatch.setattr(work, _never(work))
    before = os.stat("/dev/full")
    capsys.readouterr()
    assert main([a.format(out="/dev/full", **{"in": inputs}) for a in argv]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "/dev/full" in err and "Traceback" not in err, err
    after = os.stat("/dev/full")
    assert stat.S_ISCHR(after.st_mode) and after.st_rdev == before.st_rdev


# ---- a finished run: figures, report, regress --write


@pytest.fixture(scope="module")
def finished(tmp_path_factory) -> Path:
    from aerotruth.sim.campaign import run_campaign
    from aerotruth.sim.campaign_loader import parse_campaign
    from aerotruth.sim.executors import ExecutorChoice

    out = tmp_path_factory.mktemp("faults") / "run"
    run_campaign(parse_campaign(ONE_TASK), ExecutorChoice("local", workers=1), out=out, progress=False, log=print)
    return out


@pytest.fixture
def run_dir(finished, tmp_path) -> Path:
    import shutil

    return Path(shutil.copytree(finished, tmp_path / "run"))


@pytest.mark.parametrize("code", list(REASONS))
@pytest.mark.parametrize("command", [("figures"), ("report")])
def test_figures_and_report_refuse_an_unwritable_run_folder_and_write_nothing(run_dir, disk, capsys, command, code):
    before = listing(run_dir)
    disk(code, run_dir)
    refused(capsys, [command, run_dir], run_dir, code)
    assert listing(run_dir) == before


@pytest.mark.parametrize("code", list(REASONS))
def test_regress_write_refuses_an_unwritable_baseline_folder(run_dir, tmp_path, disk, capsys, code):
    where = tmp_path / "baselines"
    where.mkdir()
    disk(code, where)
    refused(capsys, ["regress", run_dir, where / "b.json", "--write"], where, code)
    assert list(where.iterdir()) == []


def test_regress_write_refuses_dev_full(run_dir, capsys):
    capsys.readouterr()
    assert main(["regress", str(run_dir), "/dev/full", "--write"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "/dev/full" in err and stat.S_ISCHR(os.stat("/dev/full").st_mode)


def test_regress_without_write_reads_only(run_dir, tmp_path, disk, capsys):
    assert main(["regress", str(run_dir), str(tmp_path / "b.json"), "--write"]) == 0
    disk(errno.EROFS, Path("/"))
    assert main(["regress", str(run_dir), str(tmp_path / "b.json")]) == 0
