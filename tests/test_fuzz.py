"""A fuzz corpus through every command (issue 51, part 6): mutated inputs built from valid
seeds, each run through `aerotruth.app.cli.main` in-process (two in a subprocess, where a
hang inside compiled code must fail the test instead of stalling the suite).

Every case asserts the project's rules for bad input:

* the exit status is 2, or the case says why 0 is right (`why`) and its output is checked
  (`check`): what the unmutated input gives, or the mutation named; `regress` may exit 1,
  its "a metric moved", where a damaged value is a moved metric;
* a refusal is exactly one stderr line, starting `aerotruth <command>` and naming the
  file, field or option (`names`: the option or its field spelling); a Python warning or a
  logged warning met on the way counts as a line (the real command prints them on stderr);
* no "Traceback" anywhere, and no exception out of `main`;
* each case under a timeout (pytest-timeout, 20 s; subprocess cases their own);
* nothing outside the case's output folder changes, and on a refusal nothing at all: every
  entry under the case's folder (its inputs, in/, and its outputs, out/; the command runs
  in it) is snapshotted (kind, size, mtime, digest) before and after, `AEROTRUTH_CACHE` and
  `NUMBA_CACHE_DIR` pointed at folders left out of it; no seed file changes either.

The seeds come from the suite's independent generators (tests/obs_generator.py,
tests/approach_log_generator.py, tests/traffic_generator.py, a Mode-S flight written here, a
small ERA5-like NetCDF), campaigns/quick.yaml and a one-task campaign, the deviation.csv of
`heading fit` on a generated table and a one-task finished run folder, each made once per
module when a case first asks for it. Mutation classes (MUTATIONS): truncation, units,
nonfinite (NaN, inf), huge (1e308, long digits, deep nesting), time (repeated, reversed),
types, encoding (latin-1, UTF-16, NUL, invalid UTF-8), yaml (aliases, merge keys, tags),
empty, header (header only), folder (a folder for a file and a file for a folder), missing,
range (options out of range).

What the project cannot tell, said by its case and not asserted: a pressure altitude in
metres (observation tables, traffic: plausible feet), a deviation table whose coefficients
and entries are all in radians (small corrections are plausible), a TVPS in feet on an
approach flown on the centreline (it reads about 0 in any unit), a CSV cut inside its last
field (a shorter number: not in the corpus, as no check could tell).

The cases of `diagnose`, `reports`, the campaign commands and the flights run from
tests/test_fuzz_campaigns.py (SECOND_FILE): pytest-xdist gives each file one process."""

from __future__ import annotations

import dataclasses
import gzip
import hashlib
import json
import logging
import math
import os
import shutil
import subprocess
import sys
import warnings
from collections.abc import Callable
from pathlib import Path

import approach_log_generator as alg
import numpy as np
import obs_generator as gen
import pandas as pd
import pytest
import traffic_generator as tgen
from tiny_campaign import TINY_CAMPAIGN

from aerotruth.app.cli import main

ROOT = Path(__file__).resolve().parents[1]
CASE_TIMEOUT_S = 20
pytestmark = pytest.mark.timeout(CASE_TIMEOUT_S)

# a one-task campaign (wind climatology, no JSBSim): a run takes a second or two
TINY = TINY_CAMPAIGN.replace("name: tiny1", "name: fuzz", 1)
TRUTHS = [gen.AircraftTruth("N401XJ", A=2.0, B=-3.0, C=1.5), gen.AircraftTruth("N402XJ", A=-1.0, B=1.0, C=2.5)]
KT = 1852.0 / 3600.0


# ---------------------------------------------------------------- seeds


class Seeds:
    """The valid inputs every case starts from, each group made when a case first asks for
    one of its files (`seeds / name`), once per module; and, made when first asked for, the
    outputs of the unmutated inputs that accepted mutations are held to."""

    def __init__(self, root: Path):
        self.root = root
        self.root.mkdir(parents=True, exist_ok=True)
        self.numba = root.parent / "numba-cache"
        self.numba.mkdir(exist_ok=True)
        self._refs: dict[str, Path] = {}
        self._made: set[str] = set()

    def __truediv__(self, name: str) -> Path:
        group = next(g for g, names in SEED_GROUPS.items() if name in names)
        if group not in self._made:
            SEED_MAKERS[group](self)
            self._made.add(group)
        return self.root / name

    def reference(self, name: str, argv: Callable[[Seeds, Path], list[str]]) -> Path:
        """The folder `ref` where `aerotruth ARGV` (argv(seeds, ref): it may write its inputs
        into ref/in) wrote its outputs into ref/out: what an unmutated input gives."""
        if name not in self._refs:
            ref = self.root.parent / "refs" / name
            (ref / "in").mkdir(parents=True)
            (ref / "out").mkdir()
            assert main([str(a) for a in argv(self, ref)]) == 0, name
            self._refs[name] = ref / "out"
        return self._refs[name]


def modes_flight(minutes: int = 40, seed: int = 0) -> pd.DataFrame:
    """One aircraft's decoded Mode-S trajectory at 1 Hz (`traffic` names): FL200 near Bordeaux,
    legs of 3-5 min joined by 1.5 deg/s turns, a steady wind; magnetic heading from a fixed
    2-deg declination (the diagnosis does not depend on it being IGRF's)."""
    rng = np.random.default_rng(seed)
    n = minutes * 60
    parts, h = [], float(rng.uniform(0, 360))
    while sum(map(len, parts)) < n:
        parts.append(np.full(int(rng.uniform(180, 300)), h))
        new = h + rng.uniform(60, 150) * rng.choice([-1, 1])
        parts.append(np.linspace(h, new, int(abs(new - h) / 1.5), endpoint=False))
        h = new
    psi = np.radians(np.concatenate(parts)[:n])
    t = np.arange(n, dtype=float)
    tas = 215.0
    vn, ve = tas * np.cos(psi) - 10.0, tas * np.sin(psi) - 14.0
    lat = 45.0 + np.cumsum(vn) / 111.2e3
    lon = -1.0 + np.cumsum(ve) / (111.2e3 * np.cos(np.radians(45.0)))
    return pd.DataFrame(
        {
            "timestamp": 1593072000.0 + t,
            "icao24": "3c6444",
            "latitude": lat,
            "longitude": lon,
            "altitude": 20000.0,
            "vertical_rate": 0.0,
            "heading": np.round((np.degrees(psi) - 2.0) % 360, 1),
            "TAS": np.round(tas / KT, 1),
            "track": np.degrees(np.arctan2(ve, vn)) % 360,
            "groundspeed": np.hypot(vn, ve) / KT,
        }
    )


def era5(path: Path) -> None:
    """A small ERA5-like analysis (NetCDF) over the traffic's box, hours and levels: a uniform westerly."""
    import xarray as xr

    times = pd.date_range("2024-06-01 11:00", periods=4, freq="h")
    levels = np.array([500.0, 450.0, 400.0, 350.0, 300.0, 250.0])
    lats, lons = np.arange(47.0, 42.99, -0.5), np.arange(-96.0, -89.99, 0.5)
    shape = (len(times), len(levels), len(lats), len(lons))
    dims = ("valid_time", "pressure_level", "latitude", "longitude")
    coords = {"valid_time": times, "pressure_level": levels, "latitude": lats, "longitude": lons}
    wind = {
        "u": (dims, np.full(shape, 20.0), {"units": "m s**-1"}),
        "v": (dims, np.full(shape, 3.0), {"units": "m s**-1"}),
    }
    xr.Dataset(wind, coords=coords).to_netcdf(path)


def _observations(s: Seeds) -> None:
    obs = gen.generate(TRUTHS, np.random.default_rng(5), flights=24, include_heading=True)
    obs.to_csv(s.root / "obs.csv", index=False)
    obs.to_parquet(s.root / "obs.parquet", index=False)
    (s.root / "obs.csv.gz").write_bytes(gzip.compress((s.root / "obs.csv").read_bytes(), mtime=0))
    late = obs["time"] >= obs["time"].quantile(0.5)
    obs[~late].to_csv(s.root / "fit.csv", index=False)
    obs[late].to_csv(s.root / "later.csv", index=False)


def _deviation(s: Seeds) -> None:
    """deviation.csv of `heading fit` on the first half of the generated reports."""
    assert main(["heading", "fit", str(s / "fit.csv"), "--out", str(s.root / "fitted"), "--bootstrap", "0"]) == 0
    shutil.copy(s.root / "fitted" / "deviation.csv", s.root / "deviation.csv")


def _approach_log(s: Seeds) -> None:
    log, _ = alg.make_log(1, seed=3)
    log.to_csv(s.root / "log.csv", index=False)
    log.to_parquet(s.root / "log.parquet", index=False)
    (s.root / "log.csv.gz").write_bytes(gzip.compress((s.root / "log.csv").read_bytes(), mtime=0))
    (s.root / "runway.json").write_text(json.dumps({"length_m": 2500.0, "glide_path_deg": 3.0, "tch_m": 15.0}))


def _traffic(s: Seeds) -> None:
    traffic, _ = tgen.make_traffic(n_aircraft=6, seed=1, minutes=30)
    traffic.to_csv(s.root / "traffic.csv", index=False)
    traffic.to_parquet(s.root / "traffic.parquet", index=False)
    traffic.to_json(s.root / "traffic.json", orient="records", date_format="iso")
    era5(s.root / "era5.nc")


def _campaigns(s: Seeds) -> None:
    (s.root / "quick.yaml").write_text((ROOT / "campaigns" / "quick.yaml").read_text())
    (s.root / "tiny.yaml").write_text(TINY)


def _finished_run(s: Seeds) -> None:
    """A finished one-task run of TINY (no figures, no report) and its baseline."""
    from aerotruth.sim.campaign import run_campaign
    from aerotruth.sim.campaign_loader import parse_campaign
    from aerotruth.sim.executors import ExecutorChoice

    quiet = {"progress": False, "log": lambda msg: None}
    run_campaign(parse_campaign(TINY), ExecutorChoice("local", workers=1), out=s.root / "run", **quiet)
    assert main(["regress", str(s.root / "run"), str(s.root / "baseline.json"), "--write"]) == 0


SEED_GROUPS = {
    "observations": ("obs.csv", "obs.parquet", "obs.csv.gz", "fit.csv", "later.csv"),
    "deviation": ("deviation.csv",),
    "approach log": ("log.csv", "log.parquet", "log.csv.gz", "runway.json"),
    "traffic": ("traffic.csv", "traffic.parquet", "traffic.json", "era5.nc"),
    "mode-s": ("modes.json",),
    "campaigns": ("quick.yaml", "tiny.yaml"),
    "run": ("run", "baseline.json"),
}
SEED_MAKERS: dict[str, Callable[[Seeds], None]] = {
    "observations": _observations,
    "deviation": _deviation,
    "approach log": _approach_log,
    "traffic": _traffic,
    "mode-s": lambda s: (s.root / "modes.json").write_text(modes_flight().to_json(orient="records")),
    "campaigns": _campaigns,
    "run": _finished_run,
}


@pytest.fixture(scope="module")
def seeds(tmp_path_factory) -> Seeds:
    return Seeds(tmp_path_factory.mktemp("fuzz-seeds") / "seeds")


# ---------------------------------------------------------------- mutations of files


def cut(p: Path, at: int | float) -> None:
    """Truncate `p` at byte `at` (a fraction of its size when a float < 1; from the end when negative)."""
    data = p.read_bytes()
    n = int(len(data) * at) if isinstance(at, float) else (len(data) + at if at < 0 else at)
    p.write_bytes(data[:n])


def cut_in_line(p: Path, line: int, field: int) -> None:
    """Truncate a CSV `p` in the middle of data line `line`'s `field`-th field (a partial last row)."""
    lines = p.read_bytes().split(b"\n")
    fields = lines[line].split(b",")
    keep = b",".join(fields[:field]) + b"," + fields[field][: max(1, len(fields[field]) // 2)]
    p.write_bytes(b"\n".join(lines[:line]) + b"\n" + keep)


def header_only(p: Path) -> None:
    p.write_bytes(p.read_bytes().split(b"\n", 1)[0] + b"\n")


def text_table(p: Path) -> pd.DataFrame:
    return pd.read_csv(p, dtype=str, keep_default_na=False)


def set_cell(p: Path, col: str, value: str, row: int = 100) -> None:
    """CSV `p` with one cell's text replaced (every other cell as written)."""
    df = text_table(p)
    df.loc[row, col] = value
    df.to_csv(p, index=False)


def scale(p: Path, cols: tuple[str, ...] | str, factor: float) -> None:
    """CSV or Parquet `p` with numeric columns multiplied by `factor` (a unit swap)."""
    cols = (cols,) if isinstance(cols, str) else cols
    parquet = p.suffix == ".parquet"
    df = pd.read_parquet(p) if parquet else pd.read_csv(p, dtype={c: str for c in ("aircraft", "event")})
    for c in cols:
        df[c] = df[c] * factor
    df.to_parquet(p, index=False) if parquet else df.to_csv(p, index=False)


def edit(p: Path, fn: Callable[[pd.DataFrame], pd.DataFrame]) -> None:
    """CSV `p` (as text) or Parquet through `fn`."""
    if p.suffix == ".parquet":
        fn(pd.read_parquet(p)).to_parquet(p, index=False)
    else:
        fn(text_table(p)).to_csv(p, index=False)


def drop_row(p: Path, row: int = 100) -> None:
    edit(p, lambda df: df.drop(index=row))


def replace_bytes(p: Path, old: bytes, new: bytes, count: int = 1) -> None:
    data = p.read_bytes()
    assert old in data, old
    p.write_bytes(data.replace(old, new, count))


def insert_bytes(p: Path, what: bytes, line: int = 50) -> None:
    """`what` put in the middle of line `line` of text file `p`."""
    lines = p.read_bytes().split(b"\n")
    s = lines[line]
    lines[line] = s[: len(s) // 2] + what + s[len(s) // 2 :]
    p.write_bytes(b"\n".join(lines))


def utf16(p: Path) -> None:
    p.write_bytes(p.read_text(encoding="utf-8").encode("utf-16"))  # with its BOM


def as_folder(p: Path) -> None:
    p.unlink() if p.exists() else None
    p.mkdir()
    (p / "inside.csv").write_text("a,b\n1,2\n")


def empty(p: Path) -> None:
    p.write_bytes(b"")


def reverse_rows(p: Path) -> None:
    edit(p, lambda df: df.iloc[::-1])


def repeat_rows(p: Path, start: int = 100, n: int = 20) -> None:
    edit(p, lambda df: pd.concat([df, df.iloc[start : start + n]]))


# ---------------------------------------------------------------- cases


@dataclasses.dataclass(frozen=True)
class Case:
    """One command on one mutated input. `build(seeds, case_dir)` writes the inputs under
    case_dir/in and returns the arguments (outputs under case_dir/out, an empty folder);
    `names`: text the refusal must hold (the file, field or option); `check(seeds, case_dir,
    stdout)` for an accepted case; `why`: why an accepted exit status is right."""

    command: str
    mutation: str
    name: str
    build: Callable[[Seeds, Path], list[str]]
    expect: tuple[int, ...] = (2,)
    names: str | Callable[[Path], str] | None = None
    check: Callable[[Seeds, Path, str], None] | None = None
    why: str = ""
    slow: bool = False
    subprocess: bool = False
    timeout: int = CASE_TIMEOUT_S

    @property
    def id(self) -> str:
        """command|mutation|name, in printable ASCII (a NUL or a lone surrogate shown as <xx>)."""
        name = "".join(ch if " " <= ch <= "~" and ch != "\\" else f"<{ord(ch):x}>" for ch in self.name)
        return f"{self.command}|{self.mutation}|{name}"


CASES: list[Case] = []
MUTATIONS = (
    "truncation",
    "units",
    "nonfinite",
    "huge",
    "time",
    "types",
    "encoding",
    "yaml",
    "empty",
    "header",
    "folder",
    "missing",
    "range",
)


def case(command: str, mutation: str, name: str, build, **kw) -> None:
    assert mutation in MUTATIONS, mutation
    CASES.append(Case(command, mutation, name, build, **kw))


def inp(d: Path, name: str) -> Path:
    return d / "in" / name


def copy(s: Seeds, d: Path, name: str, as_name: str | None = None) -> Path:
    src, dst = s / name, inp(d, as_name or name)
    if src.is_dir():
        shutil.copytree(src, dst)
    else:
        shutil.copy(src, dst)
    return dst


def same_files(got: Path, ref: Path, names: tuple[str, ...]) -> None:
    """Each of `names` identical in the two output folders (CSV compared as tables)."""
    for n in names:
        a, b = got / n, ref / n
        assert a.exists(), f"{n} not written"
        if n.endswith(".csv"):  # rows in any order (the output follows the input's order of aircraft)
            key = [
                c
                for c in ("aircraft", "approach", "time", "time_s", "ref_source", "quantity")
                if c in pd.read_csv(b, nrows=0).columns
            ]

            def rows(f: Path, key: list[str] = key) -> pd.DataFrame:
                return pd.read_csv(f).sort_values(key, kind="stable").reset_index(drop=True)

            pd.testing.assert_frame_equal(rows(a), rows(b), check_exact=False, rtol=1e-9)
        else:
            assert a.read_bytes() == b.read_bytes(), n


# ---------------------------------------------------------------- the harness


def snapshot(root: Path, skip: tuple[str, ...]) -> dict[str, tuple]:
    """Every entry under `root` but the top-level names in `skip`: kind, size, mtime, digest."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root)
        if rel.parts[0] in skip:
            continue
        st = p.lstat()
        if p.is_symlink():
            out[str(rel)] = ("link", os.readlink(p))
        elif p.is_dir():
            out[str(rel)] = ("dir",)
        else:
            out[str(rel)] = ("file", st.st_size, st.st_mtime_ns, hashlib.sha256(p.read_bytes()).hexdigest())
    return out


def stats(root: Path) -> dict[str, tuple[int, int]]:
    """Size and mtime of every file under `root` (the seeds: too many bytes to digest per case)."""
    return {str(p): (p.stat().st_size, p.stat().st_mtime_ns) for p in root.rglob("*") if p.is_file()}


class _Lines(logging.Handler):
    """Log records the real command would print on stderr (logging's last resort: WARNING and up)."""

    def __init__(self):
        super().__init__(logging.WARNING)
        self.records: list[logging.LogRecord] = []

    def emit(self, record):
        self.records.append(record)


def _python_default_warnings() -> None:
    """The warning filters of a plain `python` (what the installed command runs with)."""
    warnings.resetwarnings()
    warnings.simplefilter("default")
    for category in (DeprecationWarning, PendingDeprecationWarning, ImportWarning, ResourceWarning):
        warnings.filterwarnings("ignore", category=category)


def run_inprocess(argv: list[str], capsys) -> tuple[int, str, str, list[str]]:
    capsys.readouterr()
    handler = _Lines()
    logging.getLogger().addHandler(handler)
    try:
        with warnings.catch_warnings(record=True) as caught:
            _python_default_warnings()
            try:
                rc = main(argv)
            except SystemExit as e:  # argparse
                rc = e.code if isinstance(e.code, int) else 2
            except Exception as e:  # noqa: BLE001 - the command would print a traceback
                pytest.fail(f"a traceback: {type(e).__name__}: {e}"[:2000])
    finally:
        logging.getLogger().removeHandler(handler)
    out, err = capsys.readouterr()
    extra = [f"{w.category.__name__}: {w.message}" for w in caught]
    extra += [f"log {r.levelname}: {r.getMessage()}" for r in handler.records]
    return rc, out, err, extra


def run_subprocess(argv: list[str], d: Path, timeout: int) -> tuple[int, str, str, list[str]]:
    env = dict(os.environ, AEROTRUTH_CACHE=str(d / "cache"), NUMBA_CACHE_DIR=os.environ["NUMBA_CACHE_DIR"])
    try:
        p = subprocess.run(
            [sys.executable, "-m", "aerotruth", *argv], cwd=d, capture_output=True, text=True, timeout=timeout, env=env
        )
    except subprocess.TimeoutExpired:
        pytest.fail(f"`aerotruth {' '.join(argv)}` hung (over {timeout} s)")
    return p.returncode, p.stdout, p.stderr, []


# the commands whose cases tests/test_fuzz_campaigns.py runs: pytest-xdist gives each file one
# process (--dist loadfile), so the corpus is two files to run on two
SECOND_FILE = ("diagnose", "reports", "validate", "run", "figures", "report", "regress", "fly", "fly-approach")


def params(second_file: bool) -> list:
    """The cases of this file or of the second, as pytest parameters named command|mutation|name."""
    out = []
    for c in CASES:
        if (c.command in SECOND_FILE) != second_file:
            continue
        marks = [pytest.mark.timeout(c.timeout)] + ([pytest.mark.slow] if c.slow else [])
        out.append(pytest.param(c, id=c.id, marks=marks))
    return out


def unmutated_outputs(s: Seeds, second_file: bool) -> None:
    """Every seed accepted by its commands (the outputs accepted mutations are held to); made
    first, under a long timeout, as it may compile the wind method's loops (numba) and flies
    nothing."""
    if not second_file:
        fit_reference(s)
        s.reference("apply", apply_argv)
        fits_reference(s)
        return
    s.reference("diagnose-modes", lambda s, ref: ["diagnose", s / "modes.json", "--out", ref / "out" / "diag"])
    reports_reference(s)
    s.reference("validate-quick", lambda s, ref: ["validate", s / "quick.yaml"])
    for command in ("figures", "report"):

        def argv(s: Seeds, ref: Path, command: str = command) -> list[str]:
            shutil.copytree(s / "run", ref / "out" / "run")
            return [command, ref / "out" / "run"]

        s.reference(f"{command}-intact", argv)
    assert main(["regress", str(s / "run"), str(s / "baseline.json")]) == 0


@pytest.mark.timeout(600)
def test_every_seed_is_accepted(seeds: Seeds):
    unmutated_outputs(seeds, second_file=False)


def test_the_corpus_covers_every_command_and_mutation():
    by_command: dict[str, int] = {}
    for c in CASES:
        by_command[c.command] = by_command.get(c.command, 0) + 1
    assert len({c.id for c in CASES}) == len(CASES), "two cases of one name"
    assert len(CASES) >= 300, len(CASES)
    assert set(by_command) == set(COMMANDS), set(COMMANDS) ^ set(by_command)
    assert min(by_command.values()) >= 15, by_command
    assert {c.mutation for c in CASES} == set(MUTATIONS)


def run_case(c: Case, s: Seeds, d: Path, capsys, monkeypatch) -> tuple[int, str, str]:
    (d / "in").mkdir()
    (d / "out").mkdir()
    (d / "cache").mkdir()
    monkeypatch.chdir(d)
    monkeypatch.setenv("AEROTRUTH_CACHE", str(d / "cache"))
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(s.numba))
    argv = [str(a) for a in c.build(s, d)]
    before = snapshot(d, ("cache",))
    seeds_before = stats(s.root)
    if c.subprocess:
        rc, out, err, extra = run_subprocess(argv, d, c.timeout)
    else:
        rc, out, err, extra = run_inprocess(argv, capsys)
    if os.environ.get("FUZZ_SHOW"):  # a reviewer's listing: every case's outcome
        print(f"\n[{c.id}] exit {rc}: {err.strip()[:400]} {extra}", file=sys.__stderr__)
    shown = f"exit {rc}\nstdout: {out[-1500:]}\nstderr: {err[-3000:]}\nwarnings/logs: {extra}"
    assert "Traceback" not in out + err, shown
    assert rc in c.expect, shown
    if rc in (0, 1) and c.expect != (2,):
        assert c.why, "an accepted case says why it is right"
    if rc == 2:
        lines = err.strip("\n").split("\n")
        assert len(lines) == 1 and not extra, f"not one line: {shown}"
        assert lines[0].startswith(f"aerotruth {c.command.split()[0]}"), shown
        names = c.names(d) if callable(c.names) else c.names
        if names is not None:
            field = names.lstrip("-").replace("-", "_") if names.startswith("--") else names
            assert names in lines[0] or field in lines[0], f"the line does not name {names!r}: {lines[0]}"
    after = snapshot(d, ("cache",))
    assert stats(s.root) == seeds_before, "a seed input was changed"
    if rc == 0:
        outside = {k: v for k, v in after.items() if not k.startswith("out")}
        assert outside == {k: v for k, v in before.items() if not k.startswith("out")}, "changed outside out/"
        if c.check is not None:
            c.check(s, d, out)
    else:
        assert after == before, f"written or changed before the refusal: {set(after.items()) ^ set(before.items())}"
    return rc, out, err


COMMANDS = (
    "fly",
    "fly-approach",
    "run",
    "validate",
    "figures",
    "report",
    "regress",
    "diagnose",
    "fits",
    "reports",
    "heading fit",
    "heading apply",
)


# ---- observation tables: heading fit, heading apply, diagnose share the mutations

FIT_FILES = ("deviation.csv",)


def fit_argv(obs: str, *extra: str):
    """argv(seeds, folder) of `heading fit` on the seed `obs` (or folder/in/<obs> when there)."""

    def argv(s: Seeds, d: Path) -> list[str]:
        src = inp(d, obs) if inp(d, obs).exists() else s / obs
        return ["heading", "fit", src, "--out", d / "out", "--bootstrap", "0", *extra]

    return argv


def fit_reference(s: Seeds) -> Path:
    return s.reference("fit-obs", fit_argv("obs.csv"))


def fits_as_unmutated(s: Seeds, d: Path, stdout: str) -> None:
    same_files(d / "out", fit_reference(s), FIT_FILES)


def fits_as_without_row(row: int, obs: str = "obs.csv"):
    """The output of the table with that row left out."""

    def check(s: Seeds, d: Path, stdout: str) -> None:
        def argv(s: Seeds, ref: Path) -> list[str]:
            shutil.copy(s / obs, inp(ref, obs))
            drop_row(inp(ref, obs), row)
            return fit_argv(obs)(s, ref)

        same_files(d / "out", s.reference(f"fit-{obs}-without-{row}", argv), FIT_FILES)

    return check


def obs_case(command: str, mutation: str, name: str, mutate: Callable[[Path], None], seed="obs.csv", **kw):
    """A case of `command` ("heading fit", "diagnose") on the seed observation table mutated."""

    def build(s: Seeds, d: Path) -> list[str]:
        p = copy(s, d, seed)
        mutate(p)
        if command == "heading fit":
            return ["heading", "fit", p, "--out", d / "out", "--bootstrap", "0"]
        if command == "diagnose":
            return ["diagnose", p, "--out", d / "out" / "diag"]
        raise AssertionError(command)

    kw.setdefault("names", seed)
    case(command, mutation, name, build, **kw)


def heading_fit_option(mutation: str, option: str, value: str, expect=(2,), **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        argv = fit_argv("obs.csv")(s, d)
        if option == "--bootstrap":
            argv = argv[:-2]
        return [*argv, *opt(option, value)]

    kw.setdefault("names", option)
    case("heading fit", mutation, f"{option} {shown(value)}", build, expect=expect, **kw)


def opt(option: str, value: str) -> list[str]:
    """An option and its value as a user writes a negative one (argparse takes `-1e9` for an option)."""
    return [f"{option}={value}"] if value.startswith("-") else [option, value]


def shown(value: str) -> str:
    """A value as a case's name: a long one by its length."""
    return value if len(value) <= 20 else f"{value[:3]}... ({len(value)} characters)"


HF = "heading fit"
# truncation
obs_case(HF, "truncation", "csv cut in the header", lambda p: cut(p, 30))
obs_case(HF, "truncation", "csv cut after the header", lambda p: cut(p, len(p.read_bytes().split(b"\n")[0]) + 1))
obs_case(
    HF,
    "truncation",
    "csv cut in a row's wind speed",
    lambda p: cut_in_line(p, 2000, 5),
    names="obs.csv",
)
obs_case(HF, "truncation", "csv cut at 1 byte", lambda p: cut(p, 1))
obs_case(HF, "truncation", "parquet cut at half", lambda p: cut(p, 0.5), seed="obs.parquet")
obs_case(HF, "truncation", "parquet cut at 4 bytes", lambda p: cut(p, 4), seed="obs.parquet")
obs_case(HF, "truncation", "parquet footer cut", lambda p: cut(p, -6), seed="obs.parquet")
obs_case(HF, "truncation", "gzip cut at half", lambda p: cut(p, 0.5), seed="obs.csv.gz")
obs_case(HF, "truncation", "gzip cut before its trailer", lambda p: cut(p, -4), seed="obs.csv.gz")
obs_case(HF, "truncation", "gzip cut in its header", lambda p: cut(p, 5), seed="obs.csv.gz")


def _gzip_of_a_cut_csv(p: Path) -> None:
    text = gzip.decompress(p.read_bytes())
    p.write_bytes(gzip.compress(text[: text.index(b"\n", len(text) // 2) + 20], mtime=0))


obs_case(HF, "truncation", "gzip of a CSV cut in a row", _gzip_of_a_cut_csv, seed="obs.csv.gz", names="cut short")
# units
obs_case(HF, "units", "wind speed in m/s", lambda p: scale(p, "wind_speed_kt", KT), names="wind_speed_kt")
obs_case(
    HF, "units", "reference wind speed in m/s", lambda p: scale(p, "ref_wind_speed_kt", KT), names="ref_wind_speed_kt"
)
obs_case(
    HF, "units", "wind direction in radians", lambda p: scale(p, "wind_dir_deg", math.pi / 180), names="wind_dir_deg"
)
obs_case(HF, "units", "tas in m/s", lambda p: scale(p, "tas_kt", KT), names="tas_kt")
obs_case(HF, "units", "heading in radians", lambda p: scale(p, "heading_deg", math.pi / 180), names="heading_deg")
obs_case(HF, "units", "lat and lon in radians", lambda p: scale(p, ("lat", "lon"), math.pi / 180))
obs_case(HF, "units", "wind speed in km/h", lambda p: scale(p, "wind_speed_kt", 1.852), names="wind_speed_kt")
obs_case(
    HF,
    "units",
    "pressure altitude in metres",
    lambda p: scale(p, "pressure_altitude_ft", 0.3048),
    expect=(0, 2),
    why="heights of 0-6,700 in metres are plausible heights in feet, and the method uses the altitude only for "
    "its bands: the project cannot tell (not asserted)",
)
# nonfinite and huge values
for col, value in [
    ("wind_speed_kt", "inf"),
    ("wind_speed_kt", "-inf"),
    ("lat", "1e308"),
    ("lon", "-1e308"),
    ("time", "inf"),
    ("pressure_altitude_ft", "1e308"),
    ("tas_kt", "-inf"),
    ("ref_wind_dir_deg", "1e308"),
]:
    m = "huge" if "308" in value else "nonfinite"
    obs_case(HF, m, f"{col} {value}", lambda p, col=col, value=value: set_cell(p, col, value), names=col)
obs_case(
    HF,
    "nonfinite",
    "wind_speed_kt nan",
    lambda p: set_cell(p, "wind_speed_kt", "nan"),
    expect=(0, 2),
    check=fits_as_without_row(100),
    why="an empty required cell (NaN) skips its row, as documented: the fit of the table without it",
    slow=True,
)
obs_case(HF, "huge", "time of 400 digits", lambda p: set_cell(p, "time", "9" * 400), names="time")
# time
obs_case(
    HF,
    "time",
    "rows repeated",
    repeat_rows,
    expect=(0,),
    check=fits_as_unmutated,
    why="exact repeats of (aircraft, time, ref_source) rows are dropped (documented): the unmutated fit",
)
obs_case(
    HF,
    "time",
    "rows reversed",
    reverse_rows,
    expect=(0,),
    check=fits_as_unmutated,
    why="the order of the rows does not matter (documented): the unmutated fit",
    slow=True,
)
obs_case(
    HF, "time", "a report's time repeated with other values", lambda p: set_cell(p, "time", text_table(p)["time"][98])
)
obs_case(HF, "time", "times in milliseconds", lambda p: scale(p, "time", 1000.0), names="time")
obs_case(HF, "time", "times negated (1930, reversed)", lambda p: scale(p, "time", -1.0), names="obs.csv")
# types
obs_case(HF, "types", "a word in wind_speed_kt", lambda p: set_cell(p, "wind_speed_kt", "calm"), names="wind_speed_kt")
obs_case(HF, "types", "true in lat", lambda p: set_cell(p, "lat", "true"), names="lat")
obs_case(HF, "types", "a unit in the cell", lambda p: set_cell(p, "tas_kt", "280kt"), names="tas_kt")
obs_case(HF, "types", "a list in a cell", lambda p: set_cell(p, "lon", "[-93.2, -93.3]"), names="lon")
obs_case(
    HF,
    "types",
    "parquet numbers as strings",
    lambda p: edit(p, lambda df: df.assign(wind_speed_kt=df["wind_speed_kt"].map(repr))),
    seed="obs.parquet",
    expect=(0, 2),
    check=fits_as_unmutated,
    why="a Parquet column of number strings read as the numbers they spell: the unmutated fit",
    names="wind_speed_kt",
    slow=True,
)
obs_case(
    HF,
    "types",
    "parquet time as booleans",
    lambda p: edit(p, lambda df: df.assign(time=df["time"] > 0)),
    seed="obs.parquet",
    names="column 'time'",
)
obs_case(
    HF,
    "types",
    "parquet lat as bytes",
    lambda p: edit(p, lambda df: df.assign(lat=df["lat"].map(lambda v: repr(v).encode()))),
    seed="obs.parquet",
    expect=(0, 2),
    check=fits_as_unmutated,
    why="a Parquet column of the numbers' text (as bytes) read as those numbers: the unmutated fit",
    names="lat",
    slow=True,
)
obs_case(
    HF,
    "types",
    "parquet lat as booleans",
    lambda p: edit(p, lambda df: df.assign(lat=df["lat"] > 45.0)),
    seed="obs.parquet",
    names="'lat'",
)
# encodings
obs_case(HF, "encoding", "latin-1 aircraft label", lambda p: replace_bytes(p, b"N402XJ", "N402XÄ".encode("latin-1")))
obs_case(HF, "encoding", "utf-16 with BOM", utf16)
obs_case(HF, "encoding", "a NUL byte in a row", lambda p: insert_bytes(p, b"\x00"))
obs_case(HF, "encoding", "invalid utf-8 in a row", lambda p: insert_bytes(p, b"\xff\xfe\xfa"))
obs_case(HF, "encoding", "NUL bytes throughout", lambda p: p.write_bytes(p.read_bytes().replace(b",", b",\x00")))
# empty, header, folder, missing
obs_case(HF, "empty", "empty csv", empty)
obs_case(HF, "empty", "empty parquet file", empty, seed="obs.parquet")
obs_case(HF, "empty", "empty gzip", lambda p: p.write_bytes(gzip.compress(b"", mtime=0)), seed="obs.csv.gz")
obs_case(HF, "header", "header only", header_only)
obs_case(
    HF,
    "header",
    "parquet without rows",
    lambda p: edit(p, lambda df: df.iloc[:0]),
    seed="obs.parquet",
)
obs_case(
    HF,
    "header",
    "a required column missing",
    lambda p: edit(p, lambda df: df.drop(columns="wind_dir_deg")),
    names="wind_dir_deg",
)
obs_case(HF, "folder", "a folder for the table", as_folder)
obs_case(HF, "missing", "no such file", lambda p: p.unlink())


def _out_is_file(s: Seeds, d: Path) -> list[str]:
    (d / "out" / "taken").write_text("mine")
    return ["heading", "fit", s / "obs.csv", "--out", d / "out" / "taken", "--bootstrap", "0"]


case(HF, "folder", "--out is a file", _out_is_file, names="--out")


# options
def _every_aircraft_refused_for_its_clusters(s: Seeds, d: Path, stdout: str) -> None:
    dev = pd.read_csv(d / "out" / "deviation.csv")
    assert (dev["status"] == "refused").all() and dev["reason"].str.contains("cluster").all(), dev


heading_fit_option(
    "huge",
    "--min-clusters",
    "1000000000000",
    expect=(0, 2),
    check=_every_aircraft_refused_for_its_clusters,
    why="more clusters than any data: each aircraft's row refused, its reason naming the clusters (flagged)",
)
for option, values in {
    "--bootstrap": ["-1", "1e9", "nan", "1000000000", "9" * 5000, "9" * 4000],
    "--seed": ["-1", "nan", str(2**64), "9" * 400],
    "--min-reports": ["-1", "0", "1e9", "nan"],
    "--min-clusters": ["0", "1", "-5"],
    "--cluster-s": ["nan", "-1", "inf", "1e308"],
    "--position-step-deg": ["nan", "-1", "inf", "1e9"],
    "--max-sinusoid-se-deg": ["nan", "-1", "0", "inf"],
}.items():
    for v in values:
        m = "nonfinite" if v in ("nan", "inf") else "huge" if len(v) > 8 or "e9" in v or "308" in v else "range"
        heading_fit_option(m, option, v)


# ---- heading apply: the deviation table and the later reports

HA = "heading apply"
APPLY_FILES = ("apply.csv", "corrected.csv")


def apply_argv(s: Seeds, d: Path) -> list[str]:
    """`heading apply` on the case's later.csv and deviation.csv (copied from the seeds unless there)."""
    for name in ("later.csv", "deviation.csv"):
        if not inp(d, name).exists() and not inp(d, name).is_symlink() and not (d / "in" / f".{name}.gone").exists():
            copy(s, d, name)
    return ["heading", "apply", inp(d, "later.csv"), "--tables", inp(d, "deviation.csv"), "--out", d / "out" / "apply"]


def applies_as_unmutated(s: Seeds, d: Path, stdout: str) -> None:
    same_files(d / "out" / "apply", s.reference("apply", apply_argv) / "apply", APPLY_FILES)


def gone(p: Path) -> None:
    """`p` removed (and remembered as removed, so that no seed is copied in its place)."""
    p.unlink()
    (p.parent / f".{p.name}.gone").write_text("")


def table_case(mutation: str, name: str, mutate: Callable[[Path], None], **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        mutate(copy(s, d, "deviation.csv"))
        return apply_argv(s, d)

    kw.setdefault("names", "deviation.csv")
    case(HA, mutation, f"table: {name}", build, **kw)


def later_case(mutation: str, name: str, mutate: Callable[[Path], None], **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        mutate(copy(s, d, "later.csv"))
        return apply_argv(s, d)

    kw.setdefault("names", "later.csv")
    case(HA, mutation, f"reports: {name}", build, **kw)


def set_table(col: str, value: str, row: int = 1):
    return lambda p: set_cell(p, col, value, row)


LUTS = tuple(f"lut_{k:03d}_deg" for k in range(0, 360, 45))
table_case("truncation", "cut in the header", lambda p: cut(p, 30))
table_case("truncation", "cut after the header", lambda p: cut(p, len(p.read_bytes().split(b"\n")[0]) + 1))
table_case("truncation", "cut in the second aircraft's A_deg", lambda p: cut_in_line(p, 2, 4))
table_case("truncation", "cut at half", lambda p: cut(p, 0.5))
table_case("units", "table entries in radians", lambda p: scale(p, LUTS, math.pi / 180), names="lut_")
table_case(
    "units",
    "coefficients in radians, entries in degrees",
    lambda p: scale(p, ("A_deg", "B_deg", "C_deg", "D_deg", "E_deg"), math.pi / 180),
    names="N40",
)
table_case(
    "units",
    "everything in radians",
    lambda p: scale(p, ("A_deg", "B_deg", "C_deg", "D_deg", "E_deg", *LUTS), math.pi / 180),
    expect=(0, 2),
    why="a table of small corrections in radians is a plausible table in degrees: the project cannot tell "
    "(not asserted)",
)
table_case("nonfinite", "A_deg nan on a fitted row", set_table("A_deg", "nan"), names="A_deg")
table_case("nonfinite", "lut_000_deg inf", set_table("lut_000_deg", "inf"), names="lut_000_deg")
table_case("nonfinite", "lut_045_deg empty", set_table("lut_045_deg", ""), names="lut_045_deg")
table_case("huge", "lut_090_deg 1e308", set_table("lut_090_deg", "1e308"), names="lut_090_deg")
table_case("huge", "B_deg -1e308", set_table("B_deg", "-1e308"), names="B_deg")
table_case("time", "valid_from after valid_to", set_table("valid_from", "2009-09-30"), names="valid_from")
table_case("time", "valid_to not a day", set_table("valid_to", "2009-02-30"), names="valid_to")
table_case("time", "data_from not a time", set_table("data_from", "yesterday"), names="data_from")
table_case("types", "status a word", set_table("status", "maybe"), names="status")
table_case("types", "A_deg a word", set_table("A_deg", "two"), names="A_deg")
table_case("types", "heading_frame a number", set_table("heading_frame", "1"), names="heading_frame")
table_case("types", "a list in lut_180_deg", set_table("lut_180_deg", "[1, 2]"), names="lut_180_deg")
table_case("types", "an aircraft twice", lambda p: edit(p, lambda df: pd.concat([df, df.iloc[:1]])), names="N401XJ")
table_case("encoding", "latin-1", lambda p: replace_bytes(p, b"reference models", "référence".encode("latin-1")))
table_case("encoding", "utf-16 with BOM", utf16)
table_case("encoding", "a NUL byte", lambda p: insert_bytes(p, b"\x00", line=1))
table_case("encoding", "invalid utf-8", lambda p: insert_bytes(p, b"\xc3\x28", line=2))
table_case("empty", "empty", empty)
table_case("header", "header only", header_only)
table_case("folder", "a folder for the table", as_folder)
table_case("missing", "no such table", gone)
table_case("types", "another table as --tables", lambda p: p.write_bytes(b"aircraft,time,lat\nN1,1249086612,44\n"))
later_case("units", "wind speed in m/s", lambda p: scale(p, "wind_speed_kt", KT), names="wind_speed_kt")
later_case(
    "time",
    "rows reversed",
    reverse_rows,
    expect=(0,),
    check=applies_as_unmutated,
    why="the order of the rows does not matter: the unmutated outputs",
    slow=True,
)
later_case("empty", "empty", empty)
later_case("header", "header only", header_only)
later_case("folder", "a folder for the reports", as_folder)
later_case("missing", "no such reports file", gone)
later_case("truncation", "cut in a row", lambda p: cut_in_line(p, 500, 6))
later_case("encoding", "utf-16 with BOM", utf16)


def _apply_out_is_file(s: Seeds, d: Path) -> list[str]:
    (d / "out" / "taken").write_text("mine")
    return ["heading", "apply", s / "later.csv", "--tables", s / "deviation.csv", "--out", d / "out" / "taken"]


case(HA, "folder", "--out is a file", _apply_out_is_file, names="--out")


# ---- approach logs: fits (and diagnose)

FITS_FILES = ("trajectory.csv", "bias.csv")


def fits_reference(s: Seeds) -> Path:
    return s.reference("fits", lambda s, ref: ["fits", s / "log.csv", "--out", ref / "out"])


def fits_as_unmutated(s: Seeds, d: Path, stdout: str) -> None:
    same_files(d / "out" / "fits", fits_reference(s), FITS_FILES)


def log_case(command: str, mutation: str, name: str, mutate: Callable[[Path], None], seed="log.csv", **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        p = copy(s, d, seed)
        mutate(p)
        if command == "fits":
            return ["fits", p, "--out", d / "out" / "fits"]
        return ["diagnose", p, "--out", d / "out" / "diag"]

    kw.setdefault("names", seed)
    case(command, mutation, name, build, **kw)


WAAS = ("waas_x_m", "waas_y_m", "waas_z_m")
INS = ("ins_x_m", "ins_y_m", "ins_z_m")
DGPS_COLS = ("dgps_x_m", "dgps_y_m", "dgps_z_m")
FT_PER_M = 1 / 0.3048
log_case("fits", "truncation", "csv cut in the header", lambda p: cut(p, 40))
log_case("fits", "truncation", "csv cut in a row", lambda p: cut_in_line(p, 900, 5))
log_case("fits", "truncation", "csv cut after the header", lambda p: cut(p, len(p.read_bytes().split(b"\n")[0]) + 1))
log_case("fits", "truncation", "parquet cut at 90 %", lambda p: cut(p, 0.9), seed="log.parquet")
log_case("fits", "truncation", "gzip cut at 70 %", lambda p: cut(p, 0.7), seed="log.csv.gz")
log_case("fits", "units", "positions in feet", lambda p: scale(p, WAAS + INS + DGPS_COLS, FT_PER_M), names="waas")
log_case("fits", "units", "radar altimeter in feet", lambda p: scale(p, "ra_m", FT_PER_M), names="ra_m")
log_case(
    "fits",
    "units",
    "TVPS in feet",
    lambda p: scale(p, "tvps_y_m", FT_PER_M),
    names="tvps_y_m",
    expect=(0, 2),
    why="one approach flown on the centreline: the TVPS reads about 0 in any unit, and its unit shows only in "
    "the spread of the threshold crossings (documented: not seen by the log's checks); not asserted",
)
log_case("fits", "units", "time in milliseconds", lambda p: scale(p, "time_s", 1000.0))
log_case("fits", "units", "INS in feet", lambda p: scale(p, INS, FT_PER_M), names="ins")
log_case("fits", "units", "WAAS in feet", lambda p: scale(p, WAAS, FT_PER_M), names="waas")
log_case("fits", "nonfinite", "time_s nan", lambda p: set_cell(p, "time_s", "nan"), names="time_s")
log_case("fits", "nonfinite", "time_s inf", lambda p: set_cell(p, "time_s", "inf"), names="time_s")
log_case("fits", "nonfinite", "waas_x_m alone nan on an epoch", lambda p: set_cell(p, "waas_x_m", "nan"), names="waas")
log_case("fits", "nonfinite", "ins_x_m inf", lambda p: set_cell(p, "ins_x_m", "inf"), names="ins_x_m")
log_case("fits", "nonfinite", "ra_m -inf", lambda p: set_cell(p, "ra_m", "-inf", 1505), names="ra_m")
log_case("fits", "huge", "waas_z_m 1e308", lambda p: set_cell(p, "waas_z_m", "1e308"), names="waas")
log_case("fits", "huge", "ra_m 1e308", lambda p: set_cell(p, "ra_m", "1e308", 1505), names="ra_m")
log_case("fits", "huge", "time_s -1e308", lambda p: set_cell(p, "time_s", "-1e308"), names="time_s")
log_case("fits", "huge", "tvps_y_m -1e308", lambda p: set_cell(p, "tvps_y_m", "-1e308", 1505), names="tvps_y_m")
log_case("fits", "time", "a row repeated", lambda p: repeat_rows(p, 100, 1), names="time_s")
log_case("fits", "time", "rows reversed", reverse_rows, names="time_s")
log_case(
    "fits",
    "time",
    "two rows swapped",
    lambda p: edit(p, lambda df: df.iloc[[*range(100), 101, 100, *range(102, len(df))]]),
    names="time_s",
)
log_case("fits", "types", "a word in ins_x_m", lambda p: set_cell(p, "ins_x_m", "north"), names="ins_x_m")
log_case("fits", "types", "an unknown event", lambda p: set_cell(p, "event", "touchdown"), names="event")
log_case("fits", "types", "a flag of 2", lambda p: set_cell(p, "sv_change", "2"), names="sv_change")
log_case("fits", "types", "true in ra_m", lambda p: set_cell(p, "ra_m", "true", 1505), names="ra_m")
log_case(
    "fits",
    "types",
    "parquet time_s as strings",
    lambda p: edit(p, lambda df: df.assign(time_s=df["time_s"].map(repr))),
    seed="log.parquet",
    expect=(0, 2),
    check=fits_as_unmutated,
    why="a Parquet column of number strings read as those numbers: the unmutated FITS",
    names="time_s",
)
log_case("fits", "encoding", "latin-1 event", lambda p: replace_bytes(p, b",thr,", ",thr\xe9,".encode("latin-1")))
log_case("fits", "encoding", "utf-16 with BOM", utf16)
log_case("fits", "encoding", "a NUL byte", lambda p: insert_bytes(p, b"\x00", 300))
log_case("fits", "encoding", "invalid utf-8", lambda p: insert_bytes(p, b"\xff", 300))
log_case("fits", "empty", "empty", empty)
log_case("fits", "empty", "empty parquet", empty, seed="log.parquet")
log_case("fits", "header", "header only", header_only)
log_case(
    "fits", "header", "a required column missing", lambda p: edit(p, lambda df: df.drop(columns="ra_m")), names="ra_m"
)
log_case("fits", "folder", "a folder for the log", as_folder)
log_case("fits", "missing", "no such log", lambda p: p.unlink())


def runway_case(mutation: str, name: str, mutate: Callable[[Path], None], **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        log = copy(s, d, "log.csv")
        side = copy(s, d, "runway.json", "log.csv.runway.json")
        mutate(side)
        return ["fits", log, "--out", d / "out" / "fits"]

    kw.setdefault("names", "runway.json")
    case("fits", mutation, f"runway: {name}", build, **kw)


def runway_key(key: str, raw: str):
    def mutate(p: Path) -> None:
        doc = p.read_text()
        p.write_text(
            doc[:-1] + f', "{key}": {raw}}}'
            if key not in doc
            else doc.replace(f'"{key}": ', f'"{key}": {raw}, "_was": ')
        )

    return mutate


runway_case("truncation", "cut at half", lambda p: cut(p, 0.5))
runway_case("nonfinite", "glide path NaN", runway_key("glide_path_deg", "NaN"), names="glide_path_deg")
runway_case("huge", "length 1e308", runway_key("length_m", "1e308"), names="length_m")
runway_case("types", "glide path true", runway_key("glide_path_deg", "true"), names="glide_path_deg")
runway_case("types", "tch a list", runway_key("tch_m", "[15]"), names="tch_m")
runway_case("types", "not an object", lambda p: p.write_text("[2500, 3.0]"))
runway_case(
    "encoding", "latin-1", lambda p: p.write_bytes('{"airport": "Düsseldorf", "length_m": 2500}'.encode("latin-1"))
)
runway_case("encoding", "utf-16 with BOM", utf16)
runway_case("empty", "empty", empty)
runway_case("huge", "a number of 5,000 digits", runway_key("tch_m", "9" * 5000), names="runway.json")
runway_case("huge", "nested 100,000 deep", lambda p: p.write_text("[" * 100_000 + "]" * 100_000))
runway_case("folder", "a folder for the sidecar", as_folder)
runway_case("units", "length in feet", runway_key("length_m", "8202"), names="length_m")


def _runway_metadata(raw: bytes):
    def mutate(p: Path) -> None:
        import pyarrow.parquet as pq

        table = pq.read_table(p)
        pq.write_table(table.replace_schema_metadata({**(table.schema.metadata or {}), b"runway": raw}), p)

    return mutate


log_case(
    "fits",
    "huge",
    "parquet runway metadata nested 100,000 deep",
    _runway_metadata(b"[" * 100_000 + b"]" * 100_000),
    seed="log.parquet",
    names="runway",
)
log_case(
    "fits",
    "encoding",
    "parquet runway metadata in latin-1",
    _runway_metadata('{"airport": "D\xfcsseldorf"}'.encode("latin-1")),
    seed="log.parquet",
    names="runway",
)


def _epochs_one_second_later(s: Seeds, d: Path, stdout: str) -> None:
    got = pd.read_csv(d / "out" / "fits" / "trajectory.csv")["time_s"].to_numpy()
    ref = pd.read_csv(fits_reference(s) / "trajectory.csv")["time_s"].to_numpy()
    n = min(len(got), len(ref))
    assert n > 40 and np.allclose(got[:n], ref[:n] + 1.0) or np.allclose(got[-n:], ref[-n:] + 1.0)


case(
    "fits",
    "range",
    "--waas-latency -1",
    lambda s, d: ["fits", s / "log.csv", "--out", d / "out" / "fits", "--waas-latency", "-1"],
    expect=(0,),
    check=_epochs_one_second_later,
    why="a receiver stamping its fixes 1 s early is within the option's -2 to 2 s: each epoch is put 1 s later",
)
for option, values in {
    "--ra-lever-arm": ["nan", "inf", "-1e308", "1e9", "9" * 400],
    "--waas-latency": ["nan", "-3", "1e9", "-inf"],
}.items():
    for v in values:

        def build(s: Seeds, d: Path, option=option, v=v) -> list[str]:
            return ["fits", s / "log.csv", "--out", d / "out" / "fits", *opt(option, v)]

        m = "nonfinite" if "nan" in v or "inf" in v else "huge" if len(v) > 4 else "range"
        case("fits", m, f"{option} {shown(v)}", build, names=option)


def _fits_out_is_file(s: Seeds, d: Path) -> list[str]:
    (d / "out" / "taken").write_text("mine")
    return ["fits", s / "log.csv", "--out", d / "out" / "taken"]


case("fits", "folder", "--out is a file", _fits_out_is_file, names="--out")


# ---- diagnose: every kind of measured file, the model and the options

DG = "diagnose"
obs_case(DG, "truncation", "observations cut in a row", lambda p: cut_in_line(p, 2000, 5))
obs_case(DG, "units", "observations' wind speed in m/s", lambda p: scale(p, "wind_speed_kt", KT), names="wind_speed_kt")
obs_case(DG, "nonfinite", "observations' lat inf", lambda p: set_cell(p, "lat", "inf"), names="lat")
obs_case(DG, "encoding", "observations in utf-16", utf16)
obs_case(DG, "header", "observations header only", header_only)
log_case(DG, "units", "log positions in feet", lambda p: scale(p, WAAS + INS + DGPS_COLS, FT_PER_M), names="waas")
log_case(DG, "time", "log rows reversed", reverse_rows, names="time_s")
log_case(DG, "truncation", "log parquet cut", lambda p: cut(p, 0.6), seed="log.parquet")


def modes_case(mutation: str, name: str, mutate: Callable[[Path], None], seed="modes.json", **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        p = copy(s, d, seed)
        mutate(p)
        return ["diagnose", p, "--out", d / "out" / "diag"]

    kw.setdefault("names", seed)
    case(DG, mutation, f"mode-s: {name}", build, **kw)


def records(fn: Callable[[list[dict]], list[dict] | object]):
    def mutate(p: Path) -> None:
        doc = json.loads(p.read_text())
        p.write_text(json.dumps(fn(doc)))

    return mutate


def set_record(i: int, key: str, value):
    def fn(doc):
        doc[i][key] = value
        return doc

    return records(fn)


modes_case("truncation", "cut at half", lambda p: cut(p, 0.5))
modes_case("truncation", "cut at 10 bytes", lambda p: cut(p, 10))


def diagnoses_one_sample_fewer(s: Seeds, d: Path, stdout: str) -> None:
    ref = s.reference("diagnose-modes", lambda s, ref: ["diagnose", s / "modes.json", "--out", ref / "out" / "diag"])
    got, want = (json.loads((f / "diag" / "diagnosis.json").read_text()) for f in (d / "out", ref))
    assert got["samples_used"] == want["samples_used"] - 1
    assert [f["effect"] for f in got["findings"]] == [f["effect"] for f in want["findings"]]


modes_case(
    "nonfinite",
    "NaN heading",
    lambda p: replace_bytes(p, b'"heading":', b'"heading":NaN,"_h":'),
    expect=(0,),
    check=diagnoses_one_sample_fewer,
    why="NaN (JSON's null) is a missing value: that sample is left out and counted, the diagnosis stands",
)
modes_case("nonfinite", "Infinity TAS", lambda p: replace_bytes(p, b'"TAS":', b'"TAS":Infinity,"_t":'), names="TAS")
modes_case("huge", "latitude 1e308", set_record(100, "latitude", 1e308), names="latitude")
modes_case("huge", "timestamp -1e308", set_record(100, "timestamp", -1e308), names="timestamp")
modes_case("types", "a word in TAS", set_record(100, "TAS", "fast"), names="TAS")
modes_case("types", "a list in heading", set_record(100, "heading", [1, 2]), names="heading")
modes_case("types", "true in altitude", set_record(100, "altitude", True), names="altitude")
modes_case("types", "an object, not records", records(lambda doc: {"flight": doc}))


def diagnoses_as_unmutated(s: Seeds, d: Path, stdout: str) -> None:
    ref = s.reference("diagnose-modes", lambda s, ref: ["diagnose", s / "modes.json", "--out", ref / "out" / "diag"])
    got, want = (json.loads((f / "diag" / "diagnosis.json").read_text()) for f in (d / "out", ref))
    for doc in (got, want):
        doc.pop("measured")
    assert got == want


modes_case(
    "time",
    "records repeated",
    records(lambda doc: doc + doc[100:110]),
    expect=(0,),
    check=diagnoses_as_unmutated,
    why="an exact repeat of a record is the same sample: the unmutated diagnosis",
)
modes_case(
    "time",
    "a timestamp repeated with other values",
    records(lambda doc: doc + [dict(doc[100], heading=(doc[100]["heading"] + 90) % 360)]),
    names="heading",
)
modes_case("units", "TAS in m/s", records(lambda doc: [dict(r, TAS=r["TAS"] * KT) for r in doc]), names="TAS")
modes_case(
    "units",
    "heading in radians",
    records(lambda doc: [dict(r, heading=math.radians(r["heading"])) for r in doc]),
    names="heading",
)
modes_case("encoding", "utf-16 with BOM", utf16)
modes_case(
    "huge", "a number of 5,000 digits", lambda p: replace_bytes(p, b'"TAS":', b'"TAS":' + b"9" * 5000 + b',"_t":')
)
modes_case("huge", "nested 100,000 deep", lambda p: p.write_text("[" * 100_000 + "]" * 100_000))
modes_case("encoding", "a NUL byte", lambda p: insert_bytes(p, b"\x00", 0))
modes_case("empty", "empty", empty)
modes_case("empty", "an empty list", lambda p: p.write_text("[]"))
modes_case("folder", "a folder", as_folder)
modes_case("missing", "no such file", lambda p: p.unlink())


def diag_option(mutation: str, name: str, extra: Callable[[Seeds, Path], list[str]], measured="modes.json", **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        return ["diagnose", s / measured, "--out", d / "out" / "diag", *extra(s, d)]

    case(DG, mutation, name, build, **kw)


def _model(mutate: Callable[[Path], None]):
    def extra(s: Seeds, d: Path) -> list[str]:
        p = copy(s, d, "quick.yaml")
        mutate(p)
        return ["--model", p]

    return extra


diag_option("truncation", "--model cut at a third", _model(lambda p: cut(p, 0.33)), names="quick.yaml")
diag_option("missing", "--model missing", _model(lambda p: p.unlink()), names="quick.yaml")
diag_option("folder", "--model a folder", _model(as_folder), names="quick.yaml")
diag_option("empty", "--model empty", _model(empty), names="quick.yaml")
diag_option("range", "--aircraft-type unknown", lambda s, d: ["--aircraft-type", "ZZZZ"], names="--aircraft-type")
diag_option("range", "--aircraft-type empty", lambda s, d: ["--aircraft-type", ""], names="--aircraft-type")
diag_option("range", "--engine-type rocket", lambda s, d: ["--engine-type", "rocket"], names="--engine-type")
diag_option(
    "range",
    "--aircraft-type on an approach log",
    lambda s, d: ["--aircraft-type", "SF34"],
    measured="log.csv",
    names="--aircraft-type",
)


def _diag_out_is_file(s: Seeds, d: Path) -> list[str]:
    (d / "out" / "taken").write_text("mine")
    return ["diagnose", s / "modes.json", "--out", d / "out" / "taken"]


case(DG, "folder", "--out is a file", _diag_out_is_file, names="--out")


# ---- reports: traffic state tables, the gridded reference and the consensus options

RP = "reports"


def traffic_case(mutation: str, name: str, mutate: Callable[[Path], None], seed="traffic.csv", **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        p = copy(s, d, seed)
        mutate(p)
        return ["reports", p, "--out", d / "out" / "obs.parquet"]

    kw.setdefault("names", seed)
    case(RP, mutation, name, build, **kw)


def reports_reference(s: Seeds) -> Path:
    return s.reference("reports", lambda s, ref: ["reports", s / "traffic.csv", "--out", ref / "out" / "obs.parquet"])


def reports_as_unmutated(s: Seeds, d: Path, stdout: str) -> None:
    def table(p: Path) -> pd.DataFrame:
        df = pd.read_parquet(p)
        return df.sort_values(["aircraft", "time"], kind="stable").reset_index(drop=True)

    pd.testing.assert_frame_equal(table(d / "out" / "obs.parquet"), table(reports_reference(s) / "obs.parquet"))


traffic_case("truncation", "cut in a row", lambda p: cut_in_line(p, 3000, 4))
traffic_case("truncation", "cut in the header", lambda p: cut(p, 25))
traffic_case("truncation", "parquet cut", lambda p: cut(p, 0.5), seed="traffic.parquet")
traffic_case("units", "groundspeed in m/s", lambda p: scale(p, "groundspeed", KT), names="groundspeed")
traffic_case("units", "TAS in m/s", lambda p: scale(p, "TAS", KT), names="TAS")
traffic_case("units", "track in radians", lambda p: scale(p, "track", math.pi / 180), names="track")
traffic_case("units", "heading in radians", lambda p: scale(p, "heading", math.pi / 180), names="heading")
traffic_case(
    "units",
    "altitude in metres",
    lambda p: scale(p, "altitude", 0.3048),
    expect=(0, 2),
    why="FL200-FL300 in metres (6,000-9,000) is a plausible altitude in feet: the project cannot tell (not asserted)",
)
traffic_case("nonfinite", "latitude inf", lambda p: set_cell(p, "latitude", "inf"), names="latitude")
traffic_case("nonfinite", "TAS -inf", lambda p: set_cell(p, "TAS", "-inf"), names="TAS")
traffic_case("huge", "altitude 1e308", lambda p: set_cell(p, "altitude", "1e308"), names="altitude")
traffic_case("huge", "groundspeed -1e308", lambda p: set_cell(p, "groundspeed", "-1e308"), names="groundspeed")


def _one_row_incomplete(s: Seeds, d: Path, stdout: str) -> None:
    assert ", 1 incomplete," in stdout, stdout
    got = pd.read_parquet(d / "out" / "obs.parquet")
    want = pd.read_parquet(reports_reference(s) / "obs.parquet")
    assert abs(len(got) - len(want)) <= 1, (len(got), len(want))


traffic_case(
    "nonfinite",
    "heading nan",
    lambda p: set_cell(p, "heading", "nan"),
    expect=(0,),
    check=_one_row_incomplete,
    why="a row missing a needed value (NaN) is left out and counted (documented): the printed line says 1 "
    "incomplete and the table has at most that one report fewer",
)
traffic_case(
    "time",
    "rows reversed",
    reverse_rows,
    expect=(0,),
    check=reports_as_unmutated,
    why="the samples' order does not matter: the unmutated table",
    slow=True,
)
traffic_case(
    "time",
    "one timestamp repeated with other values",
    lambda p: set_cell(p, "timestamp", text_table(p)["timestamp"][98]),
    names="two samples",
)
traffic_case(
    "time",
    "timestamps in 1800",
    lambda p: edit(p, lambda df: df.assign(timestamp=df["timestamp"].str.replace("2024-", "1800-"))),
    names="timestamp",
)
traffic_case("types", "a word in TAS", lambda p: set_cell(p, "TAS", "fast"), names="TAS")
traffic_case("types", "true in latitude", lambda p: set_cell(p, "latitude", "true"), names="latitude")
traffic_case("encoding", "utf-16 with BOM", utf16)
traffic_case("encoding", "invalid utf-8", lambda p: insert_bytes(p, b"\xfe\xff", 20))
traffic_case("encoding", "a NUL byte", lambda p: insert_bytes(p, b"\x00", 20))
traffic_case("empty", "empty", empty)
traffic_case(
    "huge",
    "JSON records nested 100,000 deep",
    lambda p: p.write_text("[" * 100_000 + "]" * 100_000),
    seed="traffic.json",
)
traffic_case("truncation", "JSON records cut at half", lambda p: cut(p, 0.5), seed="traffic.json")
traffic_case("header", "header only", header_only)
traffic_case("folder", "a folder", as_folder)
traffic_case("missing", "no such file", lambda p: p.unlink())


def reports_option(mutation: str, name: str, extra: list[str], **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        return ["reports", s / "traffic.csv", "--out", d / "out" / "obs.parquet", *extra]

    case(RP, mutation, name, build, **kw)


for option in ("--radius-km", "--layer-ft", "--window-s"):
    for v in ("nan", "0", "-1", "1e308", "inf", "5e9"):
        m = "nonfinite" if v in ("nan", "inf") else "huge" if "308" in v else "range"
        reports_option(m, f"{option} {v}", opt(option, v), names=option)


def _reference(mutate: Callable[[Path], None]):
    def build(s: Seeds, d: Path) -> list[str]:
        p = inp(d, "era5.nc")
        p.write_bytes((s / "era5.nc").read_bytes())
        mutate(p)
        return ["reports", s / "traffic.csv", "--reference", p, "--out", d / "out" / "obs.parquet"]

    return build


case(RP, "truncation", "--reference NetCDF cut at half", _reference(lambda p: cut(p, 0.5)), names="era5.nc")
case(RP, "empty", "--reference empty", _reference(empty), names="era5.nc")
case(RP, "folder", "--reference a folder", _reference(as_folder), names="era5.nc")
case(RP, "missing", "--reference missing", _reference(lambda p: p.unlink()), names="era5.nc")
case(
    RP,
    "encoding",
    "--reference utf-16 text",
    _reference(lambda p: p.write_bytes("u,v\n1,2\n".encode("utf-16"))),
    names="era5.nc",
)


def _reports_out(name: str):
    def build(s: Seeds, d: Path) -> list[str]:
        (d / "out" / "taken.parquet").mkdir()
        return ["reports", s / "traffic.csv", "--out", d / "out" / name]

    return build


case(RP, "folder", "--out a folder", _reports_out("taken.parquet"), names="--out")
case(RP, "range", "--out a .txt name", _reports_out("obs.txt"), names="--out")


# ---- fly and fly-approach: every refusal before JSBSim flies (a case that flew would time out)

FLY = ["fly", "--from", "KMSP", "--to", "KDLH", "--date", "2009-08-15", "--seed", "1"]
APPROACH = ["fly-approach", "--airport", "KDLH", "--runway", "27", "--date", "2009-08-15", "--seed", "1"]


def with_option(argv: list[str], option: str, value: str) -> list[str]:
    """`argv` with `option` set to `value` (replaced where it is given)."""
    argv = list(argv)
    if option in argv:
        i = argv.index(option)
        return argv[:i] + opt(option, value) + argv[i + 2 :]
    return [*argv, *opt(option, value)]


def fly_case(command: str, mutation: str, option: str, value: str, **kw):
    base = FLY if command == "fly" else APPROACH

    def build(s: Seeds, d: Path) -> list[str]:
        return [*with_option(base, option, value), "--out", d / "out" / "track.parquet"]

    kw.setdefault("names", option)
    case(command, mutation, f"{option} '{shown(value)}'", build, **kw)


for option, values in {
    "--date": [
        ("range", "2009-13-45"),
        ("nonfinite", "nan"),
        ("range", "1899-12-31"),
        ("range", "2030-01-01"),
        ("empty", ""),
        ("huge", "9" * 400),
        ("range", "2009-08-15T25:00"),
        ("huge", "1e308"),
    ],
    "--seed": [("range", "-1"), ("nonfinite", "nan"), ("huge", str(2**63)), ("huge", "9" * 5000), ("huge", "1e9")],
    "--weather-seed": [("range", "-5")],
    "--cruise-fl": [
        ("range", "0"),
        ("range", "-1"),
        ("nonfinite", "nan"),
        ("huge", "1e9"),
        ("huge", "9" * 400),
        ("range", "999"),
    ],
    "--from": [("range", "ZZZZ"), ("empty", ""), ("encoding", "K\udcc3SP"), ("encoding", "KM\x00SP")],
    "--to": [("range", "KMSP")],
    "--aircraft": [("range", "concorde")],
    "--region": [("range", "mars")],
}.items():
    for m, v in values:
        fly_case("fly", m, option, v)


def _fly_out(name: str, make: Callable[[Path], None] | None = None, command: str = "fly"):
    def build(s: Seeds, d: Path) -> list[str]:
        out = d / "out" / name
        if make is not None:
            make(out)
        return [*(FLY if command == "fly" else APPROACH), "--out", out]

    return build


case("fly", "folder", "--out a folder", _fly_out("leg.parquet", lambda p: p.mkdir()), names="--out")
case("fly", "range", "--out a .csv name", _fly_out("leg.csv"), names="--out")
case("fly", "missing", "--out in a missing folder", _fly_out("no/such/leg.parquet"), names="--out")


def _flown_leg(s: Seeds, d: Path, stdout: str) -> None:
    from aerotruth.truth.track import TruthTrack

    t = TruthTrack.read_parquet(d / "out" / "track.parquet")
    assert t.meta["origin"] == "KMSP" and t.meta["destination"] == "KDLH" and len(t) > 1000


fly_case(
    "fly",
    "range",
    "--from",
    " kmsp ",
    expect=(0,),
    check=_flown_leg,
    why="an ICAO code in lower case with spaces is read as KMSP (the command strips and upper-cases it)",
    slow=True,
    timeout=600,
)

for option, values in {
    "--mass-kg": [
        ("nonfinite", "nan"),
        ("nonfinite", "inf"),
        ("range", "-1"),
        ("range", "0"),
        ("huge", "1e9"),
        ("huge", "1e308"),
    ],
    "--offset-nm": [("nonfinite", "nan"), ("huge", "1e308"), ("huge", "-1e9"), ("nonfinite", "inf")],
    "--intercept-deg": [("nonfinite", "nan"), ("huge", "1e9"), ("range", "180"), ("huge", "-1e308")],
    "--pass-height-ft": [("nonfinite", "nan"), ("nonfinite", "inf"), ("range", "0")],
    "--runway": [("range", "99"), ("empty", ""), ("encoding", "27\x00")],
    "--airport": [("range", "ZZZZ")],
    "--date": [("range", "2009-02-30")],
    "--flight-seed": [("range", "-1")],
    "--weather-seed": [("huge", "9" * 400)],
    "--profile": [("range", "land")],
}.items():
    for m, v in values:
        fly_case("fly-approach", m, option, v)
case(
    "fly-approach",
    "folder",
    "--out a folder",
    _fly_out("a.parquet", lambda p: p.mkdir(), "fly-approach"),
    names="--out",
)


def _flown_approach(s: Seeds, d: Path, stdout: str) -> None:
    from aerotruth.truth.track import TruthTrack

    t = TruthTrack.read_parquet(d / "out" / "track.parquet")
    assert t.meta["airport"] == "KDLH" and t.meta["runway"] == "27"


fly_case(
    "fly-approach",
    "range",
    "--runway",
    "27 ",
    expect=(0, 2),
    check=_flown_approach,
    why="a runway ident with a space around it is that runway (or refused naming it)",
    slow=True,
    timeout=600,
)


# ---- campaigns: run and validate

YAML_MUTATIONS: dict[str, tuple[str, Callable[[str], str | bytes]]] = {
    # name: (class, text -> mutated text or bytes)
    "cut at a third": ("truncation", lambda t: t[: len(t) // 3]),
    "cut at 10 bytes": ("truncation", lambda t: t[:10]),
    "cut in a key": ("truncation", lambda t: t[: t.index("flight_levels") + 6]),
    "a list for the seed": ("types", lambda t: t.replace("seed: 3", "seed: [3]")),
    "the seed as a string": ("types", lambda t: t.replace("seed: 3", 'seed: "3"')),
    "points as a word": ("types", lambda t: t.replace("points: 20", "points: many")),
    "a scalar for the flight levels": ("types", lambda t: t.replace("flight_levels: [100]", "flight_levels: 100")),
    "a boolean hour": ("types", lambda t: t.replace("hours_utc: [0]", "hours_utc: [true]")),
    "a mapping for the name": ("types", lambda t: t.replace("name: fuzz", "name: {a: 1}")),
    "points .nan": ("nonfinite", lambda t: t.replace("points: 20", "points: .nan")),
    "flight level .inf": ("nonfinite", lambda t: t.replace("flight_levels: [100]", "flight_levels: [.inf]")),
    "seed -.inf": ("nonfinite", lambda t: t.replace("seed: 3", "seed: -.inf")),
    "seed 1e308": ("huge", lambda t: t.replace("seed: 3", "seed: 1e308")),
    "seed of 400 digits": ("huge", lambda t: t.replace("seed: 3", "seed: " + "9" * 400)),
    "points 1000000000": ("huge", lambda t: t.replace("points: 20", "points: 1000000000")),
    "latitude 1e308": ("huge", lambda t: t.replace("lat_deg: [44, 46]", "lat_deg: [44, 1e308]")),
    "points 0": ("range", lambda t: t.replace("points: 20", "points: 0")),
    "points -1": ("range", lambda t: t.replace("points: 20", "points: -1")),
    "hour 25": ("range", lambda t: t.replace("hours_utc: [0]", "hours_utc: [25]")),
    "30 February": ("range", lambda t: t.replace("2009-08-15", "2009-02-30")),
    "a date in 1899": ("range", lambda t: t.replace("2009-08-15", "1899-08-15")),
    "latitudes beyond the pole": ("range", lambda t: t.replace("lat_deg: [44, 46]", "lat_deg: [95, 100]")),
    "a python tag": ("yaml", lambda t: t.replace("seed: 3", "seed: !!python/object/apply:os.getpid []")),
    "an alias inside its own anchor": ("yaml", lambda t: t.replace("periods: [p]", "periods: &a [p, *a]")),
    "a key given twice": ("yaml", lambda t: t.replace("seed: 3", "seed: 3\nseed: 4")),
    "an undefined alias": ("yaml", lambda t: t.replace("periods: [p]", "periods: *nowhere")),
    "a merge key of a list": ("yaml", lambda t: t.replace("points: 20", "points: 20\n    <<: [1, 2]")),
    "tabs for indentation": ("yaml", lambda t: t.replace("    periods: [p]", "\tperiods: [p]")),
    "latin-1 text": ("encoding", lambda t: (t + "description: Flughäfen\n").encode("latin-1")),
    "utf-16 with BOM": ("encoding", lambda t: t.encode("utf-16")),
    "a NUL byte": ("encoding", lambda t: t.replace("name: fuzz", "name: fu\x00zz").encode()),
    "invalid utf-8": ("encoding", lambda t: t.encode() + b"description: \xff\xfe\n"),
    "empty": ("empty", lambda t: b""),
    "comments only": ("empty", lambda t: "# a campaign\n# to come\n"),
    "only the name": ("header", lambda t: "name: fuzz\n"),
}
ALIAS_BOMB = "".join(
    f"{chr(97 + i)}: &{chr(97 + i)} [" + ", ".join([f"*{chr(96 + i)}" if i else '"lol"'] * 9) + "]\n" for i in range(9)
)
MERGE_BOMB = "m0: &m0 {k: 1}\n" + "".join(
    f"m{i}: &m{i} {{<<: [*m{i - 1}, *m{i - 1}], z{i}: 1}}\n" for i in range(1, 40)
)


def campaign_case(command: str, mutation: str, name: str, mutate: Callable[[str], str | bytes], seed="tiny.yaml", **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        p = inp(d, "campaign.yaml")
        out = mutate((s / seed).read_text())
        p.write_bytes(out.encode() if isinstance(out, str) else out)
        if command == "validate":
            return ["validate", p]
        return ["run", p, "--out", d / "out" / "run", "--workers", "1", "--quiet", "--no-report"]

    kw.setdefault("names", "campaign.yaml")
    case(command, mutation, name, build, **kw)


for name, (m, mutate) in YAML_MUTATIONS.items():
    campaign_case("validate", m, name, mutate)
campaign_case(
    "validate", "yaml", "an alias bomb", lambda t: t.replace("studies:\n", ALIAS_BOMB + "studies:\n"), subprocess=True
)
campaign_case("validate", "yaml", "a merge-key bomb", lambda t: t + MERGE_BOMB)
campaign_case(
    "validate",
    "huge",
    "a seed of 100,000 digits",
    lambda t: t.replace("seed: 3", "seed: " + "9" * 100_000),
)
campaign_case(
    "validate",
    "huge",
    "nesting 10,000 deep",
    lambda t: t + "deep: " + "[" * 10_000 + "]" * 10_000 + "\n",
    subprocess=True,
)


def _counted_as_its_own_campaign(s: Seeds, d: Path, stdout: str) -> None:
    from aerotruth.sim.campaign import expand
    from aerotruth.sim.campaign_loader import load_campaign

    tasks = expand(load_campaign(inp(d, "campaign.yaml")))
    assert f", {len(tasks)} tasks (" in stdout, stdout


for frac in (0.1, 0.25, 0.5, 0.75, 0.97):
    campaign_case(
        "validate",
        "truncation",
        f"quick.yaml cut at {frac:.0%}",
        lambda t, frac=frac: t[: int(len(t) * frac)],
        seed="quick.yaml",
        expect=(0, 2),
        check=_counted_as_its_own_campaign,
        why="YAML has no end marker: a campaign cut at a line's end can be a shorter valid campaign, which the "
        "project cannot tell from one written so; its counts are its own (not asserted beyond that)",
    )


def _validate_path(make: Callable[[Path], None]):
    def build(s: Seeds, d: Path) -> list[str]:
        p = inp(d, "campaign.yaml")
        make(p)
        return ["validate", p]

    return build


case("validate", "folder", "a folder for the campaign", _validate_path(lambda p: p.mkdir()), names="campaign.yaml")
case("validate", "missing", "no such campaign", _validate_path(lambda p: None), names="campaign.yaml")
case(
    "validate",
    "range",
    "--size unknown",
    lambda s, d: ["validate", s / "quick.yaml", "--size", "enormous"],
    names="enormous",
)


def _same_metrics_as_the_seed_run(s: Seeds, d: Path, stdout: str) -> None:
    assert (d / "out" / "run" / "metrics.json").read_bytes() == (s / "run" / "metrics.json").read_bytes()


for name in (
    "cut at a third",
    "points .nan",
    "seed 1e308",
    "points 1000000000",
    "a python tag",
    "latin-1 text",
    "empty",
    "30 February",
    "a key given twice",
    "a boolean hour",
):
    m, mutate = YAML_MUTATIONS[name]
    campaign_case("run", m, name, mutate)
campaign_case("run", "yaml", "an alias bomb", lambda t: t.replace("studies:\n", ALIAS_BOMB + "studies:\n"))
campaign_case(
    "run",
    "yaml",
    "anchors, aliases and merge keys",
    lambda t: t.replace(
        "regions:\n      - {name: box, lat_deg: [44, 46], lon_deg: [-94, -92]}",
        "regions:\n      - <<: {name: box, lat_deg: &lat [44, 46]}\n        lon_deg: [-94, -92]",
    ).replace("periods: [p]", "periods: &ps [p]"),
    expect=(0,),
    check=_same_metrics_as_the_seed_run,
    why="aliases and merge keys are plain YAML: the campaign they spell is the seed's, so are its metrics",
)


def run_option(mutation: str, name: str, extra: list[str] | Callable[[Seeds, Path], list[str]], names=None, **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        more = extra(s, d) if callable(extra) else extra
        argv = ["run", s / "tiny.yaml", "--quiet", "--no-report"]
        return argv + (more if "--out" in more else ["--out", d / "out" / "run", *more])

    case("run", mutation, name, build, names=names, **kw)


for v, m in (("0", "range"), ("-1", "range"), ("nan", "nonfinite"), ("1e9", "huge"), ("9" * 400, "huge")):
    run_option(m, f"--workers {shown(v)}", opt("--workers", v), names="--workers")
run_option("range", "--size unknown", ["--size", "enormous"], names="enormous")
run_option("range", "--executor bogus", ["--executor", "bogus"], names="--executor")


def _out_taken(s: Seeds, d: Path) -> list[str]:
    (d / "out" / "mine").mkdir()
    (d / "out" / "mine" / "notes.txt").write_text("my notes")
    return ["--out", d / "out" / "mine"]


def _out_file(s: Seeds, d: Path) -> list[str]:
    (d / "out" / "mine").write_text("a file")
    return ["--out", d / "out" / "mine"]


run_option("folder", "--out a folder of mine", _out_taken, names="--out")
run_option("folder", "--out a file", _out_file, names="--out")
case(
    "run", "folder", "a folder for the campaign", lambda s, d: ["run", d / "in", "--out", d / "out" / "run"], names="in"
)
case(
    "run",
    "missing",
    "no such campaign",
    lambda s, d: ["run", inp(d, "none.yaml"), "--out", d / "out" / "run"],
    names="none.yaml",
)


# ---- a finished run folder: figures, report, regress

RUN_DAMAGES: dict[str, tuple[str, str, Callable[[Path], None]]] = {
    # name: (class, the file the line names, damage the copy of the run folder)
    "metrics.json cut": ("truncation", "metrics.json", lambda r: cut(r / "metrics.json", 0.5)),
    "metrics.json empty": ("empty", "metrics.json", lambda r: empty(r / "metrics.json")),
    "metrics.json a folder": ("folder", "metrics.json", lambda r: as_folder(r / "metrics.json")),
    "metrics.json missing": ("missing", "metrics.json", lambda r: (r / "metrics.json").unlink()),
    "metrics.json utf-16": ("encoding", "metrics.json", lambda r: utf16(r / "metrics.json")),
    "metrics.json a NUL byte": ("encoding", "metrics.json", lambda r: insert_bytes(r / "metrics.json", b"\x00", 1)),
    "metrics.json a list": ("types", "metrics.json", lambda r: (r / "metrics.json").write_text("[1, 2]")),
    "metrics.json a string metric": (
        "types",
        "metrics.json",
        lambda r: _json_edit(r / "metrics.json", lambda doc: doc["metrics"].update({"wind_climatology.samples": "20"})),
    ),
    "manifest.json cut": ("truncation", "manifest.json", lambda r: cut(r / "manifest.json", 0.5)),
    "manifest.json empty": ("empty", "manifest.json", lambda r: empty(r / "manifest.json")),
    "manifest.json versions a list": (
        "types",
        "manifest.json",
        lambda r: _json_edit(r / "manifest.json", lambda doc: doc.update({"versions": ["numpy"]})),
    ),
    "metrics.json nested 100,000 deep": (
        "huge",
        "metrics.json",
        lambda r: (r / "metrics.json").write_text('{"metrics": ' + "[" * 100_000 + "]" * 100_000 + "}"),
    ),
    "metrics.json a metric of 400 digits": (
        "huge",
        "metrics.json",
        lambda r: _json_edit(
            r / "metrics.json", lambda doc: doc["metrics"].update({"wind_climatology.samples": 10**400})
        ),
    ),
    "tables/index.json nested 100,000 deep": (
        "huge",
        "index.json",
        lambda r: (r / "tables" / "index.json").write_text("[" * 100_000 + "]" * 100_000),
    ),
    "tables/index.json cut": ("truncation", "index.json", lambda r: cut(r / "tables" / "index.json", 0.5)),
    "tables/index.json a folder": ("folder", "index.json", lambda r: as_folder(r / "tables" / "index.json")),
    "a task table cut": ("truncation", "tasks", lambda r: cut(sorted((r / "tasks").glob("*.parquet"))[0], 0.7)),
    "a task table empty": ("empty", "tasks", lambda r: empty(sorted((r / "tasks").glob("*.parquet"))[0])),
    "config.resolved.yaml cut": ("truncation", "config.resolved.yaml", lambda r: cut(r / "config.resolved.yaml", 0.4)),
    "config.resolved.yaml latin-1": (
        "encoding",
        "config.resolved.yaml",
        lambda r: (r / "config.resolved.yaml").write_bytes(
            (r / "config.resolved.yaml").read_bytes() + "description: Flughäfen\n".encode("latin-1")
        ),
    ),
    "config.resolved.yaml an alias bomb": (
        "yaml",
        "config.resolved.yaml",
        lambda r: (r / "config.resolved.yaml").write_text((r / "config.resolved.yaml").read_text() + ALIAS_BOMB),
    ),
    "the run folder empty": ("empty", "run", lambda r: [shutil.rmtree(r), r.mkdir()]),
    "the run folder a file": ("folder", "run", lambda r: [shutil.rmtree(r), r.write_text("a file")]),
    "the run folder missing": ("missing", "run", lambda r: shutil.rmtree(r)),
}


def _json_edit(p: Path, fn: Callable[[dict], object]) -> None:
    doc = json.loads(p.read_text())
    fn(doc)
    p.write_text(json.dumps(doc))


def run_dir_case(command: str, name: str):
    m, names, damage = RUN_DAMAGES[name]

    def build(s: Seeds, d: Path) -> list[str]:
        r = d / "out" / "run"
        shutil.copytree(s / "run", r)
        damage(r)
        if command == "regress":
            return ["regress", r, copy(s, d, "baseline.json")]
        return [command, r]

    case(command, m, name, build, names=names)


for name in RUN_DAMAGES:
    run_dir_case("figures", name)
    run_dir_case("report", name)


def _as_the_intact_run(command: str):
    """The report (its text) or the figures (their names) of the intact run."""

    def check(s: Seeds, d: Path, stdout: str) -> None:
        def argv(s: Seeds, ref: Path) -> list[str]:
            shutil.copytree(s / "run", ref / "out" / "run")
            return [command, ref / "out" / "run"]

        ref = s.reference(f"{command}-intact", argv) / "run"
        got = d / "out" / "run"
        if command == "report":
            assert (got / "report.md").read_text() == (ref / "report.md").read_text()
        else:
            assert sorted(p.name for p in (got / "figures").iterdir()) == sorted(
                p.name for p in (ref / "figures").iterdir()
            )

    return check


def _tasks_a_string(r: Path) -> None:
    _json_edit(r / "manifest.json", lambda doc: doc.update({"tasks": "all"}))


for command in ("figures", "report"):

    def build(s: Seeds, d: Path, command: str = command) -> list[str]:
        r = d / "out" / "run"
        shutil.copytree(s / "run", r)
        _tasks_a_string(r)
        return [command, r]

    case(
        command,
        "types",
        "manifest.json tasks a string",
        build,
        expect=(0,),
        check=_as_the_intact_run(command),
        why="the manifest's task list is not what figures and reports are made of (the campaign's tasks are): "
        "the intact run's output",
    )
for name in (
    "metrics.json cut",
    "metrics.json a folder",
    "metrics.json utf-16",
    "metrics.json a string metric",
    "the run folder a file",
    "metrics.json nested 100,000 deep",
    "metrics.json a metric of 400 digits",
):
    run_dir_case("regress", name)


def metric_case(mutation: str, name: str, value: str, **kw):
    """The run's metrics.json with one metric's value replaced by `value` (JSON text)."""

    def build(s: Seeds, d: Path) -> list[str]:
        r = d / "out" / "run"
        shutil.copytree(s / "run", r)
        text = (r / "metrics.json").read_text()
        key = '"wind_climatology.samples": '
        i = text.index(key) + len(key)
        j = min(k for k in (text.find(",", i), text.find("}", i)) if k > 0)
        (r / "metrics.json").write_text(text[:i] + value + text[j:])
        return ["regress", r, copy(s, d, "baseline.json")]

    case("regress", mutation, f"metric {name}", build, **kw)


MOVED = "a damaged metric is a metric that moved: exit 1 and the table naming it"
metric_case("nonfinite", "NaN", "NaN", expect=(1, 2), why=MOVED, names="metrics.json")
metric_case("huge", "of 400 digits", "9" * 400, expect=(1, 2), why=MOVED, names="metrics.json")
metric_case("huge", "1e400", "1e400", expect=(1, 2), why=MOVED, names="metrics.json")
metric_case("types", "true", "true", expect=(1, 2), why=MOVED, names="metrics.json")


def baseline_case(mutation: str, name: str, mutate: Callable[[Path], None], **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        b = copy(s, d, "baseline.json")
        mutate(b)
        return ["regress", s / "run", b]

    kw.setdefault("names", "baseline.json")
    case("regress", mutation, f"baseline {name}", build, **kw)


def baseline_value(raw: str, key: str = "value"):
    def mutate(p: Path) -> None:
        text = p.read_text()
        i = text.index(f'"{key}": ', text.index('"wind_climatology.samples"')) + len(key) + 4
        j = min(k for k in (text.find(",", i), text.find("}", i), text.find("\n", i)) if k > 0)
        p.write_text(text[:i] + raw + text[j:])

    return mutate


baseline_case("truncation", "cut at half", lambda p: cut(p, 0.5))
baseline_case("nonfinite", "a NaN value", baseline_value("NaN"))
baseline_case("nonfinite", "an Infinity value", baseline_value("Infinity"))
baseline_case("huge", "a value of 1e400", baseline_value("1e400"))
baseline_case("huge", "a value of 400 digits", baseline_value("9" * 400))
baseline_case("huge", "a value of 1e308", baseline_value("1e308"), expect=(1,), why=MOVED)
baseline_case(
    "range", "a negative default tolerance", lambda p: _json_edit(p, lambda doc: doc["default"].update({"rel": -1e308}))
)
baseline_case("types", "a value as a string", baseline_value('"40"'))
baseline_case("types", "a value as a list", baseline_value("[40]"))
baseline_case("types", "a value true", baseline_value("true"))
baseline_case("encoding", "utf-16 with BOM", utf16)
baseline_case(
    "encoding",
    "latin-1",
    lambda p: p.write_bytes(p.read_bytes()[:-2] + ', "comment": "Flugh\xe4fen"}\n'.encode("latin-1")),
)
baseline_case("encoding", "a NUL byte", lambda p: insert_bytes(p, b"\x00", 1))
baseline_case("empty", "empty", empty)
baseline_case("header", "no metrics", lambda p: p.write_text('{"metrics": {}}'))
baseline_case("folder", "a folder", as_folder)
baseline_case("missing", "missing", lambda p: p.unlink())
baseline_case(
    "yaml", "nested 100,000 deep", lambda p: p.write_text('{"metrics": ' + "[" * 100_000 + "]" * 100_000 + "}")
)


def write_option(mutation: str, option: str, value: str, **kw):
    def build(s: Seeds, d: Path) -> list[str]:
        return ["regress", s / "run", d / "out" / "b.json", "--write", *opt(option, value)]

    case("regress", mutation, f"--write {option} {value}", build, names=option, **kw)


for option in ("--rel-tol", "--abs-tol"):
    for v, m in (("nan", "nonfinite"), ("-1", "range"), ("inf", "nonfinite"), ("-1e308", "huge")):
        write_option(m, option, v)
case(
    "regress",
    "folder",
    "--write onto a folder",
    lambda s, d: ["regress", s / "run", d / "out", "--write"],
    names="out",
)


# ================================================================ the corpus, run


@pytest.mark.parametrize("c", params(second_file=False))
def test_fuzz(c: Case, seeds: Seeds, tmp_path: Path, capsys, monkeypatch):
    run_case(c, seeds, tmp_path, capsys, monkeypatch)
