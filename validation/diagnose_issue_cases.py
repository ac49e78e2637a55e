"""`aerotruth diagnose` on observation tables from a second independent generator
(tests/straight_obs_generator.py: straight constant-course legs, white 0.3-deg heading
noise, white 2.2-m/s reference errors; no aerotruth code): what it finds per case and seed.

Cases (each seed flies the same flights with the same noise in every case):

* null: nothing hidden, model WindModelSpec(deviation_terms=3) (= `aerotruth diagnose`
  without --model: the wind paper's A, B, C);
* soft_iron: D, E of 1 deg on every aircraft (random phase), same model;
* pitch: heading error 0.4 deg per deg of pitch (flight-path angle + angle of attack),
  same model;
* null_quick_model: nothing hidden, the model `aerotruth diagnose --model
  campaigns/quick.yaml` uses (wind_model_from_campaign of that campaign).

The diagnosis runs in-process as the CLI does it (prepare, diagnose_wind). One line per
(case, seed): the findings in order (`unexplained:` ones with their signature), the gated
reports and the wall time; then the wall time per case.

    python validation/diagnose_issue_cases.py [--seeds 0-2] [--cases null,soft_iron,...]
"""

from __future__ import annotations

import os

for _v in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS"):
    os.environ.setdefault(_v, "1")  # one thread: a modest load

import argparse  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "tests"))
import straight_obs_generator as gen  # noqa: E402

CASES = {
    "null": {},
    "soft_iron": {"soft_iron_deg": 1.0},
    "pitch": {"pitch_deg_per_deg": 0.4},
    "null_quick_model": {},
}


def seeds_of(text: str) -> list[int]:
    """'0-4' -> [0, 1, 2, 3, 4]; '0,3,7' -> [0, 3, 7]; mixed: '0-2,5'."""
    out: list[int] = []
    for part in text.split(","):
        part = part.strip()
        if "-" in part:
            a, b = part.split("-", 1)
            out.extend(range(int(a), int(b) + 1))
        elif part:
            out.append(int(part))
    return out


def spec_of(case: str):
    from aerotruth.analysis.diagnose.wind import WindModelSpec

    if case == "null_quick_model":
        from aerotruth.analysis.diagnose.wind_model import wind_model_from_campaign
        from aerotruth.sim.campaign_loader import load_campaign

        return wind_model_from_campaign(load_campaign(ROOT / "campaigns" / "quick.yaml"))
    return WindModelSpec(deviation_terms=3)


def describe(f) -> str:
    """A finding (aerotruth.analysis.diagnose.modes.Finding) in a few words."""
    if f.effect.startswith("unexplained:"):
        return f"{f.effect} [{f.parameters.get('signature')}]"
    return f.effect


def run(case: str, seed: int) -> tuple[str, float]:
    from aerotruth.analysis.diagnose.wind import diagnose_wind, prepare

    t0 = time.perf_counter()
    df = gen.generate(seed, **CASES[case])
    data = prepare(df, f"{case}/seed{seed}")
    findings, baseline, _st, _plots = diagnose_wind(data, spec_of(case))
    wall = time.perf_counter() - t0
    names = "; ".join(describe(f) for f in findings) or "none"
    extra = " (not tested)" if "not_tested" in baseline else ""
    line = (
        f"{case} seed {seed}: findings: {names}{extra} | {data.table['reports']} reports, {len(df)} rows, "
        f"{data.n} gated rows | {wall:.1f} s"
    )
    return line, wall


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--seeds", default="0-2", help="seeds, e.g. 0-4 or 0,3 (default 0-2)")
    ap.add_argument("--cases", default=",".join(CASES), help=f"comma-separated, of {', '.join(CASES)}")
    args = ap.parse_args(argv)
    cases = [c.strip() for c in args.cases.split(",") if c.strip()]
    unknown = [c for c in cases if c not in CASES]
    if unknown:
        ap.error(f"unknown case {unknown[0]!r}; expected one of {', '.join(CASES)}")
    seeds = seeds_of(args.seeds)
    walls: dict[str, list[float]] = {}
    for case in cases:
        for seed in seeds:
            line, wall = run(case, seed)
            walls.setdefault(case, []).append(wall)
            print(line, flush=True)
    for case, w in walls.items():
        print(f"wall time {case}: {sum(w):.1f} s over {len(w)} seeds ({sum(w) / len(w):.1f} s each)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
