"""The first round of `diagnose` on chosen datasets of the confusion matrix: each candidate's
p-value and held-out gain, against the library's level at this code and at multiples of it.

What it is for: a null dataset's finding (or an effect's miss) is read against the level
it was named (or missed) at, e.g. whether a finding would stand at another ALPHA_LIBRARY
(validation/diagnose_confusion_plan.md, "The library's level at 3 %").

    python validation/diagnose_first_round.py --generator simulated --effect null --seeds 70023,70084
    python validation/diagnose_first_round.py --seeds 70000-70009 --below 0.01

One line per dataset: the findings, then each candidate whose p is under `--below`, with
its p, p over the library's level (a screening signature, `unexplained:`, has its own level)
and the held-out RMS drop (kt; negative: it predicts worse; nan: not computed, p above its level).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import diagnose_confusion as dc  # noqa: E402
from seed_runs import parse_seeds  # noqa: E402


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--generator", choices=("independent", "simulated"), default="independent")
    ap.add_argument("--effect", default="null", choices=dc.EFFECTS)
    ap.add_argument("--seeds", required=True, help="e.g. 70000-70009,70023")
    ap.add_argument("--below", type=float, default=0.01, help="list candidates with p under this (default 0.01)")
    ap.add_argument("--campaign", default="campaigns/mesaba_2009.yaml")
    ap.add_argument("--aircraft", type=int, default=12)
    ap.add_argument("--days", type=int, default=10)
    a = ap.parse_args()
    seeds = parse_seeds(a.seeds)

    from aerotruth.analysis.diagnose.wind import _library_level, diagnose_wind, prepare

    size = dc.sizes_of(a.generator)[a.effect]
    cfg = dc.sim_config(a.campaign, a.aircraft, a.days) if a.generator == "simulated" else None
    level = _library_level(1)
    print(f"# library level (first round): {level:.3g}")
    for s in seeds:
        obs, spec = dc.make_dataset(a.generator, a.effect, size, s, cfg)
        d = prepare(obs)
        findings, baseline, _, _ = diagnose_wind(d, spec)
        first = baseline["rounds"][0] if baseline["rounds"] else {}
        low = [
            f"{k} p {v['p']:.2g}"
            + ("" if k.startswith("unexplained:") else f" ({v['p'] / level:.2g} x level)")
            + f" held-out {v['held_out_before_kt'] - v['held_out_after_kt']:+.4f} kt"
            for k, v in sorted(first.items(), key=lambda kv: kv[1]["p"])
            if v["p"] < a.below
        ]
        names = ", ".join(f.effect for f in findings) or "none"
        print(f"{a.generator} {a.effect} {s} units={d.unit}: findings {names}; " + ("; ".join(low) or "-"), flush=True)


if __name__ == "__main__":
    main()
