"""`diagnose` on approach logs with nothing hidden (false findings) and its detection power
against effect size, on logs from the independent test generator
(tests/approach_log_generator.py: WAAS bias, jumps with flags, 12 s cycle, Gauss-Markov and
white noise; tactical INS; RA, TVPS, DGPS; 12 approaches per dataset).

Prints `label: value` lines: `null_datasets`, `null_findings` (by effect), and the share of
datasets whose first finding is the hidden effect, per size, for the DGPS reference offset,
the INS bias scale, the WAAS time-tag latency and the TVPS scale; writes the power figure to
--out. The null datasets' approaches cross the threshold laterally scattered (`--threshold-y-sd`,
default 3 m: crossings scatter by metres, coupled or flown by hand; on the centreline every
time, a TVPS scale cannot be told from an offset and is not tested).

    python validation/diagnose_fits_null.py [--datasets 100] [--out runs/diagnose_fits_power.png]
        [--threshold-y-sd 3.0]
"""

from __future__ import annotations

import argparse
import sys
from collections import Counter
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
import approach_log_generator as gen  # noqa: E402

from aerotruth.analysis.diagnose.fits import FitsModel, diagnose_log  # noqa: E402

POWER = {
    "dgps_offset": ("DGPS offset per axis (m)", [0.02, 0.05, 0.1, 0.2, 0.3], lambda v: {"dgps_offset": (0.0, v, v)}),
    "ins_bias": ("INS bias scale (x grade)", [1.0, 1.5, 2.0, 2.5, 3.0], lambda v: {"ins_bias_scale": v}),
    "waas_latency": ("WAAS time-tag latency (s)", [0.01, 0.02, 0.05, 0.1, 0.2], lambda v: {"waas_latency_s": v}),
    "tvps_scale": (
        "TVPS scale k (threshold y sd 3 m)",
        [0.99, 0.98, 0.97, 0.95, 0.9],
        lambda v: {"tvps_scale": v, "threshold_y_sd_m": 3.0},
    ),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--datasets", type=int, default=100)
    ap.add_argument("--power-datasets", type=int, default=20)
    ap.add_argument("--out", default="runs/diagnose_fits_power.png")
    ap.add_argument(
        "--threshold-y-sd",
        type=float,
        default=3.0,
        help="sd (m) of where the null datasets' approaches cross the threshold laterally (0: on the centreline)",
    )
    args = ap.parse_args()
    found = Counter()
    for s in range(args.datasets):
        log, _ = gen.make_log(12, seed=10_000 + s, jumps_per_s=0.0, threshold_y_sd_m=args.threshold_y_sd)
        for f in diagnose_log("null", log, FitsModel())[0]:
            found[f.effect] += 1
    print(f"null_datasets: {args.datasets}")
    print(f"null_findings: {sum(found.values())}")
    for k, v in sorted(found.items()):
        print(f"null_findings.{k}: {v}")
    curves = {}
    for effect, (label, sizes, kw) in POWER.items():
        shares = []
        for v in sizes:
            hit = 0
            for s in range(args.power_datasets):
                log, _ = gen.make_log(12, seed=20_000 + s, jumps_per_s=0.0, **kw(v))
                f = diagnose_log("p", log, FitsModel())[0]
                hit += bool(f) and f[0].effect == effect
            shares.append(hit / args.power_datasets)
            print(f"power.{effect}.{v:g}: {shares[-1]:.2f}")
        curves[effect] = (label, sizes, shares)
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(curves), figsize=(4.5 * len(curves), 3.5))
    for ax, (effect, (label, sizes, shares)) in zip(axes, curves.items(), strict=False):
        ax.plot(sizes, shares, "o-")
        ax.set(xlabel=label, ylabel="share found first", ylim=(-0.02, 1.02), title=effect)
        ax.grid(alpha=0.3)
    fig.tight_layout()
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=120)
    print(f"figure: {out}")


if __name__ == "__main__":
    main()
