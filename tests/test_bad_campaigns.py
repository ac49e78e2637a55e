"""Bad campaign files and bad `run --out`, `fly --date`, `--seed` values (issue 51): each is one
line naming the file, field or option and what was expected, exit status 2, no traceback,
no hang, and nothing written.

The hangs (an alias bomb, deep nesting) run the command in a subprocess with a timeout, so
that a hang, even inside compiled code, fails the test instead of stalling the suite; the
other cases run `main()` in-process under pytest-timeout."""

from __future__ import annotations

import datetime as dt
import json
import subprocess
import sys
from pathlib import Path

import pytest
from tiny_campaign import TINY_CAMPAIGN

from aerotruth.app.cli import main
from aerotruth.dates import FIRST_DATE, LAST_DATE, MODEL_DATE_SPAN, MODEL_EPOCH_S, check_model_date
from aerotruth.errors import UserError
from aerotruth.sim.campaign_loader import MAX_DEPTH, load_campaign, parse_campaign
from aerotruth.sim.store import RUN_FOLDER_NAMES, check_out_folder, is_run_folder

pytestmark = pytest.mark.timeout(60)

ROOT = Path(__file__).resolve().parents[1]
HANG_S = 20  # a command that takes longer on a bad file hangs on it

# one wind-climatology task (no JSBSim): a run takes a second or two
GOOD = TINY_CAMPAIGN

# ~400 bytes: 9 levels of 9 aliases each, 9^9 (387 million) strings once expanded
LAUGHS = "".join(
    f"{chr(ord('a') + i)}: &{chr(ord('a') + i)} ["
    + ", ".join([f"*{chr(ord('a') + i - 1)}" if i else '"lol"'] * 9)
    + "]\n"
    for i in range(9)
)
ALIAS_BOMB = GOOD.replace("studies:\n", LAUGHS + "studies:\n")
# merge keys (<<) that double a mapping at every level
MERGE_BOMB = (
    GOOD + "m0: &m0 {k: 1}\n" + "".join(f"m{i}: &m{i} {{<<: [*m{i - 1}, *m{i - 1}], z{i}: 1}}\n" for i in range(1, 40))
)


def subprocess_cli(args: list[str], cwd: Path) -> tuple[int, str, str]:
    """`aerotruth ARGS` in a fresh interpreter; a hang fails the test."""
    try:
        p = subprocess.run(
            [sys.executable, "-m", "aerotruth", *args], cwd=cwd, capture_output=True, text=True, timeout=HANG_S
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"`aerotruth {' '.join(args)}` hung (over {HANG_S} s)")
    return p.returncode, p.stdout, p.stderr


def inprocess_cli(args: list[str], capsys) -> tuple[int, str, str]:
    capsys.readouterr()
    try:
        rc = main(args)
    except SystemExit as e:  # argparse
        rc = int(e.code or 0)
    out, err = capsys.readouterr()
    return rc, out, err


def assert_one_line(rc: int, err: str, *names: str) -> str:
    """Exit 2 and exactly one stderr line, no traceback, naming each of `names`."""
    assert rc == 2, err
    assert "Traceback" not in err
    assert err.endswith("\n") and err.count("\n") == 1, err
    for name in names:
        assert name in err, (name, err)
    return err.strip()


def write(tmp_path: Path, name: str, text: str) -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def tree(folder: Path) -> dict[str, bytes]:
    """Every file under `folder` with its bytes (hidden ones included)."""
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


# ----------------------------------------------------------------------------- hangs


@pytest.mark.parametrize("text", [ALIAS_BOMB, MERGE_BOMB], ids=["aliases", "merge-keys"])
@pytest.mark.parametrize(
    "command", ["validate", "run", pytest.param("diagnose", marks=pytest.mark.slow)]
)  # diagnose imports its methods first: over 5 s on a busy machine
def test_an_alias_bomb_is_one_line_not_a_hang(tmp_path, command, text):
    assert len(ALIAS_BOMB) - len(GOOD) < 800
    bomb = write(tmp_path, "bomb.yaml", text)
    out = tmp_path / "out"
    args = {
        "validate": ["validate", str(bomb)],
        "run": ["run", str(bomb), "--out", str(out), "--quiet"],
        "diagnose": [
            "diagnose",
            str(write(tmp_path, "obs.csv", "aircraft,time\n")),
            "--model",
            str(bomb),
            "--out",
            str(out),
        ],
    }[command]
    rc, stdout, err = subprocess_cli(args, tmp_path)
    line = assert_one_line(rc, err, str(bomb), "100,000 values", "aliases")
    assert line.startswith(f"aerotruth {command}: {bomb}: ")
    assert stdout == "" and not out.exists()


def test_the_shipped_campaigns_stay_far_inside_the_bounds():
    for path in sorted((ROOT / "campaigns").glob("*.yaml")):
        load_campaign(path)  # raises on any bound


NESTED = {  # what is nested, the file's name, and where the message points
    "flow": ("flow.yaml", lambda: GOOD + "x: " + "[" * 100_000 + "]" * 100_000 + "\n", "x[0][0][0]..."),
    "block": (
        "block.yaml",
        lambda: GOOD + "x:\n" + "".join("  " * (i + 1) + f"k{i}:\n" for i in range(1000)),
        "x.k0.k1.k2...",
    ),
    "json": (
        "deep.json",
        lambda: '{"name": "j", "seed": 1, "x": ' + "[" * 50_000 + "]" * 50_000 + "}\n",
        "x[0][0][0]...",
    ),
}


@pytest.mark.parametrize("kind", list(NESTED))
def test_deep_nesting_is_one_line_not_a_recursion_error(tmp_path, kind):
    name, text, where = NESTED[kind]
    path = write(tmp_path, name, text())
    rc, _, err = subprocess_cli(["validate", str(path)], tmp_path)
    assert_one_line(rc, err, str(path), where, f"nested more than {MAX_DEPTH} levels")


@pytest.mark.parametrize(
    "text, words",
    [
        ("x: &a [1, *a]\n", ("x[1]", "alias *a", "contains it")),
        ("x: &a {y: *a}\n", ("x.y", "alias *a")),
        (
            "a: &a " + "[" * 30 + "1" + "]" * 30 + "\nb: " + "[" * 14 + "*a" + "]" * 14 + "\n",  # 30 + 14 levels
            ("through the alias *a",),
        ),
    ],
    ids=["recursive-list", "recursive-map", "deep-through-alias"],
)
def test_recursive_and_deep_aliases_are_one_line(tmp_path, capsys, text, words):
    path = write(tmp_path, "c.yaml", GOOD + text)
    rc, _, err = inprocess_cli(["validate", str(path)], capsys)
    assert_one_line(rc, err, str(path), *words)


@pytest.mark.parametrize(
    "text, words",
    [
        ("seed: !!binary aGVsbG8=", ("seed:", "!!binary", "line 2")),
        ("seed: !!python/object:os.system ls", ("seed:", "!!python/object:os.system")),
        ("seed: !!timestamp 2009-08-15", ("seed:", "!!timestamp")),
        ("seed: !!int 12abc", ("seed: expected an integer", "12abc")),
        ("seed: 3\nx: !!bool maybe", ("x: expected true or false",)),
    ],
)
def test_yaml_tags_a_campaign_cannot_mean_are_one_line(tmp_path, capsys, text, words):
    path = write(tmp_path, "c.yaml", GOOD.replace("seed: 3", text))
    rc, _, err = inprocess_cli(["validate", str(path)], capsys)
    assert_one_line(rc, err, str(path), *words)


def test_files_that_are_not_campaign_files_are_one_line(tmp_path, capsys):
    big = write(tmp_path, "big.yaml", "# " + "x" * (9 * 2**20) + "\n" + GOOD)
    rc, _, err = inprocess_cli(["validate", str(big)], capsys)
    assert_one_line(rc, err, str(big), "larger than 8 MiB")
    rc, _, err = inprocess_cli(["validate", "/dev/zero"], capsys)  # endless: never read to its end
    assert_one_line(rc, err, "/dev/zero", "not a regular file")
    latin = tmp_path / "latin.yaml"
    latin.write_bytes(GOOD.replace("tiny1", "caf\xe9").encode("latin-1"))
    rc, _, err = inprocess_cli(["validate", str(latin)], capsys)
    assert_one_line(rc, err, str(latin), "not a UTF-8 text file")


# ----------------------------------------------------------------------------- dates


def test_the_date_span_is_igrfs():
    from aerotruth.sensors.magnetics import IGRF_YEARS

    assert (FIRST_DATE.year, LAST_DATE.year + 1) == IGRF_YEARS
    assert MODEL_DATE_SPAN == "1900-01-01 to 2029-12-31"
    assert check_model_date(dt.date(1900, 1, 1)) == FIRST_DATE
    assert check_model_date(dt.datetime(2029, 12, 31, 23, 59)) == LAST_DATE
    assert dt.datetime.fromtimestamp(MODEL_EPOCH_S[0], dt.UTC).date() == FIRST_DATE
    assert dt.datetime.fromtimestamp(MODEL_EPOCH_S[1] - 1, dt.UTC).date() == LAST_DATE
    late = dt.datetime(2029, 12, 31, 23, tzinfo=dt.timezone(dt.timedelta(hours=-5)))  # 2030-01-01 in UTC
    for bad in (dt.date(1899, 12, 31), dt.date(2030, 1, 1), late, dt.datetime.max.replace(tzinfo=late.tzinfo)):
        with pytest.raises(UserError, match=r"^--date: expected a date from 1900-01-01 to 2029-12-31"):
            check_model_date(bad, "--date")


@pytest.mark.parametrize(
    "period, where, got",
    [
        ("{name: p, start: 1000-01-01, end: 9999-12-31}", "periods[0].start", "1000-01-01"),
        ("{name: p, start: 2009-01-01, end: 9999-12-31}", "periods[0].end", "9999-12-31"),
        ("{name: p, dates: [2009-08-15, 1800-06-01]}", "periods[0].dates[1]", "1800-06-01"),
        ("{name: p, dates: [9999-12-31]}", "periods[0].dates[0]", "9999-12-31"),
    ],
)
def test_dates_outside_what_the_models_cover_are_one_line(tmp_path, capsys, period, where, got):
    text = GOOD.replace("  - name: p\n    dates: [2009-08-15]\n", f"  - {period}\n")
    path = write(tmp_path, "c.yaml", text)
    for args in (["validate", str(path)], ["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]):
        rc, _, err = inprocess_cli(args, capsys)
        assert_one_line(rc, err, str(path), f"{where}: expected a date from {MODEL_DATE_SPAN}", got, "line 4")
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("command", ["fly", "fly-approach"])
@pytest.mark.parametrize("date", ["1800-01-01", "9999-12-31", "2029-12-31T23:00-05:00", "0001-01-01T00:00+05:00"])
def test_fly_dates_outside_what_the_models_cover_are_one_line(tmp_path, capsys, command, date):
    out = tmp_path / "leg.parquet"
    where = ["--from", "KMSP", "--to", "KDLH"] if command == "fly" else ["--airport", "KDLH", "--runway", "27"]
    rc, _, err = inprocess_cli([command, *where, "--date", date, "--out", str(out)], capsys)
    assert_one_line(rc, err, f"aerotruth {command}: --date: expected a date from {MODEL_DATE_SPAN}", repr(date))
    assert list(tmp_path.iterdir()) == []


# ----------------------------------------------------------------------------- sizes and seeds


@pytest.mark.parametrize(
    "old, new, words",
    [
        ("seed: 3", "seed: " + "7" * 5000, ("seed: expected an integer of at most 64 bits", "5000 digits", "line 2")),
        ("seed: 3", "seed: 9223372036854775808", ("seed: expected at most 9223372036854775807 (2^63 - 1",)),
        ("points: 20", "points: 1" + "0" * 30, ("points: expected an integer of at most 64 bits", "31 digits")),
        (
            "seed: 3",
            "seed: 3\nexecutor: {workers: 1000000000}",
            ("executor.workers: expected at most 1024 (the processes one machine can run)",),
        ),
        ("seed: 3", "seed: 3\ntruth_store: {max_gb: .inf}", ("truth_store.max_gb: expected a finite number",)),
        ("seed: 3", "seed: 3\ntruth_store: {max_gb: 1.0e+400}", ("truth_store.max_gb: expected a finite number",)),
        ("seed: 3", "seed: 3\ntruth_store: {max_gb: 'inf'}", ("truth_store.max_gb: expected a finite number",)),
        ("seed: 3", "seed: 3\ntruth_store: {max_gb: 1.0e+12}", ("truth_store.max_gb: expected a number <= 1000000",)),
        (
            "dates: [2009-08-15]",
            "{start: 2000-01-01, end: 2009-12-31, every_days: 100000000000}",
            ("periods[0].every_days: expected at most 47482 (the days from 1900 to 2029",),
        ),
        ("name: tiny1", "name: " + "a" * 300, ("name: expected at most 100 characters, got 300",)),
    ],
    ids=[
        "seed-5000-digits",
        "seed-64-bit",
        "int-100-bits",
        "workers",
        "inf",
        "overflow",
        "inf-text",
        "max-gb",
        "every-days",
        "name",
    ],
)
def test_sizes_beyond_what_a_campaign_can_mean_are_one_line(tmp_path, capsys, old, new, words):
    text = GOOD.replace(old, new)
    if "every_days" in new:
        text = GOOD.replace(
            "    dates: [2009-08-15]\n", "    start: 2000-01-01\n    end: 2009-12-31\n    every_days: 100000000000\n"
        )
    path = write(tmp_path, "c.yaml", text)
    for args in (["validate", str(path)], ["run", str(path), "--out", str(tmp_path / "out"), "--quiet"]):
        rc, _, err = inprocess_cli(args, capsys)
        line = assert_one_line(rc, err, str(path), *words)
        assert len(line) < 400
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize(
    "argv, option, got",
    [
        (
            ["fly", "--from", "KMSP", "--to", "KDLH", "--date", "2009-08-15", "--seed", "7" * 5000],
            "--seed",
            "5000 digits",
        ),
        (
            ["fly", "--from", "KMSP", "--to", "KDLH", "--date", "2009-08-15", "--weather-seed", "-1"],
            "--weather-seed",
            "-1",
        ),
        (["fly", "--from", "KMSP", "--to", "KDLH", "--date", "2009-08-15", "--seed", str(2**63)], "--seed", str(2**63)),
        (
            [
                "fly-approach",
                "--airport",
                "KDLH",
                "--runway",
                "27",
                "--date",
                "2009-08-15",
                "--flight-seed",
                "9" * 5000,
            ],
            "--flight-seed",
            "5000 digits",
        ),
        (
            ["fly-approach", "--airport", "KDLH", "--runway", "27", "--date", "2009-08-15", "--seed", "x"],
            "--seed",
            "'x'",
        ),
        (["run", "{campaign}", "--workers", "1000000000"], "--workers", "'1000000000'"),
        (["run", "{campaign}", "--workers", "9" * 5000], "--workers", "5000 characters"),
    ],
    ids=[
        "fly-seed",
        "fly-weather-seed",
        "fly-seed-64-bit",
        "approach-flight-seed",
        "approach-seed",
        "run-workers",
        "run-workers-digits",
    ],
)
def test_seed_and_worker_options_are_one_line(tmp_path, capsys, argv, option, got):
    campaign = write(tmp_path, "c.yaml", GOOD)
    out = tmp_path / "out.parquet" if argv[0] != "run" else tmp_path / "run"
    args = [a.format(campaign=campaign) for a in argv] + ["--out", str(out)]
    rc, _, err = inprocess_cli(args, capsys)
    line = assert_one_line(rc, err, f"aerotruth {argv[0]}: argument {option}: expected", got, "--help")
    assert len(line) < 300
    assert not out.exists()


# ----------------------------------------------------------------------------- run --out


@pytest.fixture
def campaign(tmp_path) -> Path:
    return write(tmp_path, "tiny1.yaml", GOOD)


@pytest.fixture
def users_folder(tmp_path) -> Path:
    folder = tmp_path / "mine"
    folder.mkdir()
    (folder / "report.md").write_text("# my own report\n")
    (folder / "metrics.json").write_text('{"mine": true}\n')
    (folder / "notes.txt").write_text("keep\n")
    return folder


@pytest.mark.parametrize("force", [False, True])
def test_run_out_into_a_users_folder_is_refused_and_nothing_replaced(campaign, users_folder, capsys, force):
    before = tree(users_folder)
    args = ["run", str(campaign), "--out", str(users_folder), "--quiet"] + (["--force"] if force else [])
    rc, out, err = inprocess_cli(args, capsys)
    if force:
        assert_one_line(rc, err, f"--out: {users_folder}", "metrics.json, report.md", "never replaced")
    else:
        assert_one_line(rc, err, f"--out: {users_folder} is not empty and is not an aerotruth run folder", "--force")
    assert out == ""
    assert tree(users_folder) == before  # byte-equal, and no .lock, manifest or tasks/ added


def test_run_into_the_default_folder_of_a_users_files_is_refused(tmp_path, campaign, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    (tmp_path / "runs" / "tiny1").mkdir(parents=True)
    (tmp_path / "runs" / "tiny1" / "report.md").write_text("mine\n")
    rc, _, err = inprocess_cli(["run", str(campaign), "--quiet"], capsys)
    assert_one_line(rc, err, "runs/tiny1 is not empty and is not an aerotruth run folder")
    assert [p.name for p in (tmp_path / "runs" / "tiny1").iterdir()] == ["report.md"]


def test_with_force_a_run_writes_beside_a_users_files_then_resumes(campaign, tmp_path, capsys):
    folder = tmp_path / "shared"
    folder.mkdir()
    (folder / "notes.txt").write_text("keep\n")
    args = ["run", str(campaign), "--out", str(folder), "--quiet", "--no-report", "--workers", "1"]
    rc, out, err = inprocess_cli(args, capsys)
    assert rc == 2 and "--force" in err  # refused without it
    rc, out, err = inprocess_cli([*args, "--force"], capsys)
    assert rc == 0, err
    assert (folder / "notes.txt").read_text() == "keep\n" and is_run_folder(folder)
    metrics = (folder / "metrics.json").read_bytes()
    # now a run folder: resumed without --force, every task reused
    rc, out, err = inprocess_cli(args, capsys)
    assert rc == 0, err
    assert "1 tasks (1 reused, 0 run" in err
    assert (folder / "metrics.json").read_bytes() == metrics and (folder / "notes.txt").read_text() == "keep\n"


def test_a_run_folder_is_resumed_and_an_empty_or_new_folder_used(campaign, tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    rc, _, err = inprocess_cli(
        ["run", str(campaign), "--out", str(empty), "--quiet", "--no-report", "--workers", "1"], capsys
    )
    assert rc == 0, err
    rc, _, err = inprocess_cli(["run", str(campaign), "--out", str(empty), "--quiet", "--workers", "1"], capsys)
    assert rc == 0 and "(1 reused, 0 run" in err
    assert (empty / "report.md").exists()
    assert check_out_folder(tmp_path / "new" / "deeper") == tmp_path / "new" / "deeper"
    assert not (tmp_path / "new").exists()


def test_run_folder_recognition(tmp_path):
    folder = tmp_path / "r"
    folder.mkdir()
    (folder / "manifest.json").write_text(
        json.dumps({"campaign": "x", "config_hash": "0", "tasks": [], "versions": {}})
    )
    assert is_run_folder(folder)
    (folder / "manifest.json").write_text('{"mine": 1}')
    assert not is_run_folder(folder)
    (folder / "manifest.json").write_text("not json")
    assert not is_run_folder(folder)
    stopped = tmp_path / "stopped"  # killed between taking its lock and writing its manifest
    (stopped / "tasks").mkdir(parents=True)
    (stopped / ".lock").write_text("")
    (stopped / "config.resolved.yaml.123.0123abcd.tmp").write_text("")
    assert is_run_folder(stopped)
    (stopped / "report.md").write_text("mine")
    assert not is_run_folder(stopped)
    with pytest.raises(UserError, match="exists and is not a folder"):
        check_out_folder(stopped / "report.md")
    assert set(RUN_FOLDER_NAMES) >= {".lock", "manifest.json", "metrics.json", "report.md", "tasks", "figures"}


def test_parse_campaign_text_bounds_need_no_file():
    with pytest.raises(UserError, match=r"^[a-i]\[\d\]: the file expands to more than 100,000 values"):
        parse_campaign(ALIAS_BOMB)
