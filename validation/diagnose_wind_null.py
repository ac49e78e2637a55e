"""Null control and detection power of `aerotruth diagnose` on observation tables.

Datasets come from the independent report generator (tests/obs_generator.py: 12 aircraft
x 40 flights, offset + once-round deviation, two reference models with 4-kt
Ornstein-Uhlenbeck errors), each with its own seed. With nothing hidden, every finding
is false: the family-wise level is nominally 2 % (1 % library, 1 % screening), so 100
datasets should give about 2 and must give <= 5. Power: the share of datasets where a
hidden effect of a given size is ranked first.

    python validation/diagnose_wind_null.py [--datasets 100] [--power 20] [--figure FILE]

Prints `label: value` lines.
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import obs_generator as gen  # noqa: E402

from aerotruth.analysis.diagnose.wind import WindModelSpec, diagnose_wind, prepare  # noqa: E402


def run(seed: int, tas_scale: float = 0.0, soft_deg: float = 0.0) -> list:
    rng = np.random.default_rng(seed)
    fleet = gen.fleet(12, rng, de_every=0, one_heading_last=False)
    if tas_scale or soft_deg:
        ph = rng.uniform(0, 2 * np.pi, len(fleet))
        fleet = [
            replace(a, tas_scale=tas_scale, D=soft_deg * np.cos(p), E=soft_deg * np.sin(p))
            for a, p in zip(fleet, ph, strict=False)
        ]
    obs = gen.generate(fleet, rng, flights=40)
    findings, _, _, _ = diagnose_wind(prepare(obs), WindModelSpec())
    return findings


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--datasets", type=int, default=100)
    ap.add_argument("--power", type=int, default=20, help="datasets per effect size")
    ap.add_argument("--figure", default=None)
    a = ap.parse_args()
    found = Counter()
    n_with = 0
    for s in range(a.datasets):
        f = run(10_000 + s)
        n_with += bool(f)
        found.update(x.effect for x in f)
    if a.datasets:
        print(f"null_datasets: {a.datasets}")
        print(f"null_findings: {sum(found.values())}")
        print(f"null_datasets_with_a_finding: {n_with}")
        for k, v in sorted(found.items()):
            print(f"null_finding_{k}: {v}")
    curves = {"tas_scale": [0.001, 0.002, 0.003, 0.005, 0.01], "soft_iron": [0.1, 0.15, 0.2, 0.3, 0.5]}
    power = {}
    for eff, sizes in curves.items() if a.power else ():
        for size in sizes:
            hits = 0
            for s in range(a.power):
                kw = {"tas_scale": size} if eff == "tas_scale" else {"soft_deg": size}
                f = run(20_000 + s, **kw)
                hits += bool(f) and f[0].effect == eff
            power[(eff, size)] = hits / a.power
            print(f"power_{eff}_{size:g}: {hits / a.power:.2f}")
    if a.figure and a.power:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt

        fig, axes = plt.subplots(1, 2, figsize=(9, 3.5))
        for ax, (eff, sizes), unit in zip(
            axes, curves.items(), ("TAS scale factor", "2z amplitude (deg)"), strict=False
        ):
            ax.plot(sizes, [power[(eff, x)] for x in sizes], "o-")
            ax.set_xscale("log")
            ax.set_ylim(-0.05, 1.05)
            ax.set_xlabel(unit)
            ax.set_ylabel("share found first")
            ax.set_title(f"{eff}: power, {a.power} datasets per size")
            ax.grid(alpha=0.3)
        if a.datasets:
            fig.suptitle(f"null: {sum(found.values())} findings in {a.datasets} datasets (nominal family-wise 2 %)")
        fig.savefig(a.figure, dpi=120, bbox_inches="tight")


if __name__ == "__main__":
    main()
