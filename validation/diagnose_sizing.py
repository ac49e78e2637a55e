"""The sizes of the confusion matrix's effects on a generator, by the rule of
validation/diagnose_confusion_plan.md ("Sizes on aerotruth's own sensors"): per effect the
plan's starting size first; while the effect is named first in fewer than 5 of 10
datasets, the size times 2 (then 4, 8, 16); where one step goes from below 5 to above 8,
the geometric mean of the two (to three significant digits) is tried as well. The size
chosen is the first tried with 5-8 of 10, else the one closest to 6.5 of 10 (the smaller
on a tie). quantization's grid is 0.02, 0.03, 0.05 deg; soft iron and pitch are fixed by
the issue and not sized.

Runs validation/diagnose_confusion.py one grid step at a time (every undecided effect's
next size in one call, 10 datasets each, seeds from 70000) into RESULTS, which resumes
like the confusion matrix's (its rows.csv), until every effect is decided; then prints
`sizing.EFFECT: SIZE (k of 10; tried SIZE:k ...)` lines.

    python validation/diagnose_sizing.py RESULTS --generator simulated --diagnose-code CHECKOUT \
        [--workers 2] [--fly] [--effects a,b,...] [--summary-only]
"""

from __future__ import annotations

import argparse
import math
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "validation"))
from diagnose_confusion import SIZES, read_rows  # noqa: E402

N_DATASETS = 10
FIXED = ("null", "soft_iron", "pitch")  # not sized: null has no size, the other two are the issue's
GRIDS = {"quantization": (0.02, 0.03, 0.05)}  # a grid cannot be finer than the model's 0.01 deg
DOUBLINGS = 4  # start x 1, 2, 4, 8, 16
# where the rule starts on aerotruth's sensors when not at the independent size: field scaling at the
# sensors' gamma (1: their hard iron scales as 1/H) less the wind paper's model's (0)
SIM_STARTS = {"field_scaling": 1.0}


def _key(size: float) -> str:
    return f"{size:g}"


def step(effect: str, start: float, counts: dict[str, int]) -> tuple[str, float]:
    """("try", size) for the next size the rule needs, or ("chosen", size).

    counts: named first (of 10) by size, keyed as rows.csv writes sizes (f"{size:g}")."""
    grid = GRIDS.get(effect)
    seq = list(grid) if grid else [start * 2**k for k in range(DOUBLINGS + 1)]
    tried: list[float] = []
    for s in seq:
        if _key(s) not in counts:
            return ("try", s)
        tried.append(s)
        if counts[_key(s)] >= 5:
            break
    if grid is None and len(tried) >= 2 and counts[_key(tried[-2])] < 5 and counts[_key(tried[-1])] > 8:
        gm = float(f"{math.sqrt(tried[-2] * tried[-1]):.3g}")
        if _key(gm) not in counts:
            return ("try", gm)
        tried.append(gm)
    for s in tried:
        if 5 <= counts[_key(s)] <= 8:
            return ("chosen", s)
    return ("chosen", min(tried, key=lambda s: (abs(counts[_key(s)] - 6.5), s)))


def counts_of(rows_path: Path, generator: str) -> dict[str, dict[str, int]]:
    """Named first by effect and size over the first N_DATASETS seeds that have a row
    (only effects/sizes with all N_DATASETS rows are counted)."""
    got: dict[tuple[str, str], list[int]] = {}
    for r in read_rows(rows_path):
        if r["generator"] == generator and r["status"] == "ok" and 70_000 <= int(r["seed"]) < 70_000 + N_DATASETS:
            got.setdefault((r["effect"], r["size"]), []).append(int(r["named_first"]))
    out: dict[str, dict[str, int]] = {}
    for (eff, size), v in got.items():
        if len(v) == N_DATASETS:
            out.setdefault(eff, {})[size] = sum(v)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("results")
    ap.add_argument("--generator", choices=("independent", "simulated"), default="simulated")
    ap.add_argument("--effects", default=",".join(e for e in SIZES if e not in FIXED))
    ap.add_argument("--diagnose-code", default=None, metavar="CHECKOUT")
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--fly", action="store_true")
    ap.add_argument("--summary-only", action="store_true")
    a = ap.parse_args()
    effects = [e.strip() for e in a.effects.split(",") if e.strip()]
    bad = [e for e in effects if e not in SIZES or e in FIXED]
    if bad:
        ap.error(f"--effects: {bad} are not sized; sized: {', '.join(e for e in SIZES if e not in FIXED)}")
    starts = {**SIZES, **(SIM_STARTS if a.generator == "simulated" else {})}
    rows_path = Path(a.results) / "rows.csv"
    while True:
        counts = counts_of(rows_path, a.generator)
        todo = {}
        for e in effects:
            what, size = step(e, starts[e], counts.get(e, {}))
            if what == "try":
                todo[e] = size
        if not todo or a.summary_only:
            break
        cmd = [
            sys.executable,
            str(ROOT / "validation" / "diagnose_confusion.py"),
            a.results,
            "--generator",
            a.generator,
            "--datasets",
            str(N_DATASETS),
            "--effects",
            ",".join(todo),
            "--workers",
            str(a.workers),
            "--no-cli-timing",
            *[f"--size={e}={_key(s)}" for e, s in todo.items()],
            *(["--diagnose-code", a.diagnose_code] if a.diagnose_code else []),
            *(["--fly"] if a.fly else []),
        ]
        print("sizing.step: " + " ".join(f"{e}={_key(s)}" for e, s in todo.items()), flush=True)
        rc = subprocess.call(cmd, stdout=subprocess.DEVNULL)
        if rc != 0:
            sys.exit(f"sizing: {' '.join(cmd)} exited with {rc}")
    counts = counts_of(rows_path, a.generator)
    for e in effects:
        c = counts.get(e, {})
        what, size = step(e, starts[e], c)
        tried = " ".join(f"{s}:{k}" for s, k in c.items())
        if what == "chosen":
            print(f"sizing.{e}: {_key(size)} ({c[_key(size)]} of {N_DATASETS}; tried {tried})")
        else:
            print(f"sizing.{e}: undecided, next {_key(size)} (tried {tried or 'none'})")


if __name__ == "__main__":
    main()
