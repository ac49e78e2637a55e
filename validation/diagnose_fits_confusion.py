"""The confusion matrix of `diagnose` on approach logs (validation/diagnose_fits_confusion_plan.md):
each effect the approach-log diagnosis has a test for, hidden in logs of the independent
generator (tests/approach_log_generator.py, no aerotruth code), sized, then counted.

Two steps, both printed as `label: value` lines:

* `--sizing`: per effect, named first of `--sizing-datasets` (seeds 20000 + k) at each size
  of its grid, and the size the plan's rule picks (the first with 50-80 % named first, else
  the one closest to 65 %);
* the matrix (default): null datasets, and each effect at its sized size and at its clear
  size (the test suite's), `--datasets` each (seeds 30000 + k): named first, named at all,
  a wrong cause named, and any finding on the null, with Wilson 95 % intervals.

A dataset is 12 approaches (`make_log(12, ...)`), no flagged jumps, crossings scattered 3 m
(sd) across the threshold; the model FitsModel() (the baro-coupling rows and their null:
a baro-coupled INS with a 30-s loop, FitsModel(vertical="baro", baro_loop_tau_s=30)).

    python validation/diagnose_fits_confusion.py --sizing [--sizing-datasets 20]
    python validation/diagnose_fits_confusion.py [--datasets 100] [--effects dgps_offset,...]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections import Counter
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))
sys.path.insert(0, str(ROOT / "tests"))
sys.path.insert(0, str(ROOT / "validation"))
import approach_log_generator as gen  # noqa: E402
from diagnose_confusion import _share  # noqa: E402

from aerotruth.analysis.diagnose.fits import FitsModel, diagnose_log  # noqa: E402

N_APPROACHES = 12
THRESHOLD_Y_SD_M = 3.0
BARO_MODEL = FitsModel(vertical="baro", baro_loop_tau_s=30.0)


def _rotated(deg: float) -> Callable[[pd.DataFrame], pd.DataFrame]:
    """INS x, y logged in axes turned by `deg` about the vertical."""

    def turn(log: pd.DataFrame) -> pd.DataFrame:
        th = np.radians(deg)
        x, y = log["ins_x_m"], log["ins_y_m"]
        return log.assign(ins_x_m=np.cos(th) * x - np.sin(th) * y, ins_y_m=np.sin(th) * x + np.cos(th) * y)

    return turn


# effect: (size's words, the sizing grid ascending in strength, the clear size (the test
# suite's), size -> (generator keywords, log mutation or None), baro model)
EFFECTS: dict[str, tuple[str, list[float], float, Callable[[float], tuple[dict, Callable | None]], bool]] = {
    "cyclic_period": ("the WAAS cycle's period less the model's 12 s (s)", [0.25, 0.5, 1.0, 2.0, 4.0], -6.0,
                      lambda v: ({"period_s": 12.0 + v}, None), False),
    "dgps_offset": ("DGPS station offset, cross-track and vertical (m)", [0.02, 0.05, 0.1, 0.2, 0.3], 0.3,
                    lambda v: ({"dgps_offset": (0.0, v, v)}, None), False),
    "waas_jump": ("an unflagged WAAS step 150 s into every approach (m)", [0.25, 0.5, 0.75, 1.0, 1.5], 1.5,
                  lambda v: ({"unflagged_jump": (150.0, np.full(3, v / np.sqrt(3)))}, None), False),
    "ins_bias": ("INS bias scale (x its grade)", [1.25, 1.5, 2.0, 2.5, 3.0], 3.0,
                 lambda v: ({"ins_bias_scale": v}, None), False),
    "waas_latency": ("WAAS time-tag latency (s)", [0.01, 0.02, 0.05, 0.1, 0.2], 0.15,
                     lambda v: ({"waas_latency_s": v}, None), False),
    "tvps_scale": ("TVPS scale: 1 less the scale", [0.01, 0.02, 0.03, 0.05, 0.1], 0.1,
                   lambda v: ({"tvps_scale": 1.0 - v}, None), False),
    "ins_frame": ("INS axes turned about the vertical (deg)", [0.5, 1.0, 2.0, 5.0, 16.0], 16.0,
                  lambda v: ({}, _rotated(v)), False),
    "baro_coupling": ("the baro loop's time constant less the model's 30 s (s)", [2.0, 5.0, 10.0, 15.0], 15.0,
                      lambda v: ({"baro_loop_tau_s": 30.0 - v}, None), True),
}  # fmt: skip


def diagnosed(seed: int, kw: dict, mutate: Callable | None, baro: bool) -> list[str]:
    """The effects of a dataset's findings, in their order."""
    extra = {"baro_loop_tau_s": 30.0} if baro and "baro_loop_tau_s" not in kw else {}
    log, _ = gen.make_log(N_APPROACHES, seed=seed, jumps_per_s=0.0, threshold_y_sd_m=THRESHOLD_Y_SD_M, **kw, **extra)
    if mutate is not None:
        log = mutate(log)
    return [f.effect for f in diagnose_log("log", log, BARO_MODEL if baro else FitsModel())[0]]


def pick_size(grid: list[float], shares: list[float]) -> float | tuple[float, float]:
    """The plan's rule on a grid's shares named first: the first size in 50-80 %; else, where
    one step goes from below 50 % to above 80 %, the pair to try their geometric mean
    between; else the size closest to 65 % (ties: the smaller)."""
    for v, s in zip(grid, shares, strict=True):
        if 0.5 <= s <= 0.8:
            return v
    for i in range(len(grid) - 1):
        if shares[i] < 0.5 and shares[i + 1] > 0.8:
            return (grid[i], grid[i + 1])
    return grid[int(np.argmin([abs(s - 0.65) for s in shares]))]


def sizing(effects: list[str], n: int) -> None:
    for e in effects:
        words, grid, _, hide, baro = EFFECTS[e]

        def share(v: float, e: str = e, hide=hide, baro: bool = baro) -> float:
            kw, mutate = hide(v)
            hit = sum((f := diagnosed(20_000 + s, kw, mutate, baro)) != [] and f[0] == e for s in range(n))
            print(f"sizing.{e}.{v:.4g}: {hit} of {n}", flush=True)
            return hit / n

        tried = {v: share(v) for v in grid}
        pick = pick_size(grid, list(tried.values()))
        if isinstance(pick, tuple):  # one step from below 50 % to above 80 %: their geometric mean
            mid = float(np.sqrt(pick[0] * pick[1]))
            tried[mid] = share(mid)
            order = sorted(tried)
            pick = pick_size(order, [tried[v] for v in order])
            if isinstance(pick, tuple):  # still no size in 50-80 %: the closest to 65 %
                pick = order[int(np.argmin([abs(tried[v] - 0.65) for v in order]))]
        print(f"sized.{e}: {pick:.4g}  # {words}", flush=True)


def matrix(effects: list[str], sizes: dict[str, float], n: int) -> None:
    rows = []
    for baro in sorted({EFFECTS[e][4] for e in effects}):
        label = "null_baro" if baro else "null"
        t0 = time.perf_counter()
        found = Counter()
        any_ = 0
        for s in range(n):
            f = diagnosed(30_000 + s, {}, None, baro)
            any_ += bool(f)
            found.update(f)
        print(f"{label}.null_any: {_share(any_, n)}")
        print(f"{label}.findings: {dict(found) or '-'}")
        print(f"{label}.wall_s_per_dataset: {(time.perf_counter() - t0) / n:.2f}", flush=True)
        rows.append((label, "-", "-", "-", f"{any_} of {n}", dict(found) or "-"))
    for e in effects:
        _, _, clear, hide, baro = EFFECTS[e]
        for which, v in (("sized", sizes[e]), ("clear", clear)):
            kw, mutate = hide(v)
            first = named = wrong = 0
            others = Counter()
            for s in range(n):
                f = diagnosed(30_000 + s, kw, mutate, baro)
                first += bool(f) and f[0] == e
                named += e in f
                bad = [x for x in f if x != e]
                wrong += bool(bad)
                others.update(bad)
            p = f"{e}.{which}.{v:g}"
            print(f"{p}.named_first: {_share(first, n)}")
            print(f"{p}.named_any: {_share(named, n)}")
            print(f"{p}.wrong_cause: {_share(wrong, n)}")
            print(f"{p}.wrong_findings: {dict(others) or '-'}", flush=True)
            rows.append((e, which, f"{v:g}", f"{first} of {n}", f"{wrong} of {n}", dict(others) or "-"))
    print("\n| hidden | size | value | named first | wrong cause (null: any finding) | wrong findings |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print("| " + " | ".join(str(x) for x in r) + " |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--sizing", action="store_true", help="measure each effect's grid and print the sized sizes")
    ap.add_argument("--sizing-datasets", type=int, default=20)
    ap.add_argument("--datasets", type=int, default=100)
    ap.add_argument("--effects", default=",".join(EFFECTS), help="comma-separated effects")
    ap.add_argument(
        "--size", action="append", default=[], help="EFFECT=VALUE: the sized size (the plan's; repeat per effect)"
    )
    a = ap.parse_args()
    effects = [e for e in a.effects.split(",") if e]
    unknown = [e for e in effects if e not in EFFECTS]
    if unknown:
        ap.error(f"--effects: {', '.join(unknown)} not among {', '.join(EFFECTS)}")
    if a.sizing:
        sizing(effects, a.sizing_datasets)
        return
    sizes = dict(SIZED)
    for s in a.size:
        k, _, v = s.partition("=")
        if k not in EFFECTS:
            ap.error(f"--size {s}: {k!r} is not among {', '.join(EFFECTS)}")
        try:
            sizes[k] = float(v)
        except ValueError:
            ap.error(f"--size {s}: expected EFFECT=NUMBER")
    missing = [e for e in effects if e not in sizes]
    if missing:
        ap.error(f"no sized size for {', '.join(missing)}: run --sizing and give --size EFFECT=VALUE")
    matrix(effects, sizes, a.datasets)


# the sizes the plan's rule picked (--sizing, the plan's record)
SIZED: dict[str, float] = {
    "cyclic_period": 1.414,
    "dgps_offset": 0.1,
    "waas_jump": 0.5,
    "ins_bias": 2.0,
    "waas_latency": 0.02,
    "tvps_scale": 0.03873,
    "ins_frame": 5.0,
    "baro_coupling": 10.0,
}

if __name__ == "__main__":
    main()
