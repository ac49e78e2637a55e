"""Truth-loop speed: the full loop (autopilot XML, 1 Hz guidance, truth-wind and
atmosphere updates, 10 Hz recording, divergence guard) against a bare `fdm.run()` loop
on the same aircraft in the same process.

Prints `label: value` lines. `ratio` = bare µs/step / truth µs/step (target >= 0.8);
`ratio_vs_unwrapped` compares with the aircraft XML without our autopilot system;
`realtime_factor` = simulated seconds per wall second of the truth loop. Rounds
alternate bare and truth runs; the fastest of each is kept (noise only slows).

    python benchmarks/truth_speed.py [--rounds 3] [--aircraft NAME] [--from KMSP --to KDLH]
"""

from __future__ import annotations

import argparse
import time
from datetime import datetime, timezone

from aerotruth.truth.airframes import airframe, new_fdm
from aerotruth.truth.flight import DT, fly_leg
from aerotruth.truth.weather import plan_in_weather


def _cruise_ic(fdm) -> None:
    fdm["ic/h-sl-ft"] = 15000.0
    fdm["ic/vc-kts"] = 220.0
    fdm["ic/lat-geod-deg"] = 45.0
    fdm["ic/long-gc-deg"] = -93.0
    fdm.run_ic()
    fdm["propulsion/set-running"] = -1


def bare_us_per_step(fdm, steps: int) -> float:
    run = fdm.run
    for _ in range(1000):
        run()
    t = time.perf_counter()
    for _ in range(steps):
        run()
    return (time.perf_counter() - t) / steps * 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--aircraft", default=None)
    ap.add_argument("--from", dest="origin", default="KMSP")
    ap.add_argument("--to", dest="destination", default="KDLH")
    args = ap.parse_args()
    af = airframe(args.aircraft)
    plan = plan_in_weather(args.origin, args.destination, datetime(2009, 8, 15, 13, 0, tzinfo=timezone.utc), seed=1)

    wrapped = new_fdm(af, DT)
    _cruise_ic(wrapped)
    wrapped["ap/active"] = 1
    plain = new_fdm(af, DT, autopilot=False)
    _cruise_ic(plain)

    bare, unwrapped, truth, rt = [], [], [], []
    for _ in range(args.rounds):
        t = time.perf_counter()
        track = fly_leg(plan, seed=1, aircraft=af)
        wall = time.perf_counter() - t
        sim = float(track.df["time_s"].iloc[-1]) + 0.1
        steps = round(sim / DT)
        truth.append(wall / steps * 1e6)
        rt.append(sim / wall)
        bare.append(bare_us_per_step(wrapped, steps))
        unwrapped.append(bare_us_per_step(plain, steps))

    b, u, tr = min(bare), min(unwrapped), min(truth)
    print(f"aircraft: {af.name}")
    print(f"leg: {plan.origin.icao}-{plan.destination.icao}")
    print(f"steps_per_leg: {steps}")
    print(f"bare_us_per_step: {b:.3f}")
    print(f"unwrapped_us_per_step: {u:.3f}")
    print(f"truth_us_per_step: {tr:.3f}")
    print(f"ratio: {b / tr:.3f}")
    print(f"ratio_vs_unwrapped: {u / tr:.3f}")
    print(f"realtime_factor: {max(rt):.1f}")


if __name__ == "__main__":
    main()
