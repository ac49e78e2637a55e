"""Truth-loop speed: the full loop (autopilot XML, 1 Hz guidance, truth-wind and
atmosphere updates, 10 Hz recording, divergence guard) against a bare `fdm.run()` loop
on the same aircraft in the same process.

Prints `label: value` lines. `ratio` = bare µs/step / truth µs/step at the route legs'
20 Hz step (the per-step share of the Python; the realtime factors are the measure);
`ratio_vs_unwrapped` compares with the aircraft XML without our autopilot system;
`realtime_factor` = simulated seconds per wall second of the truth loop;
`vs_737_step_ratio` = this aircraft's bare step cost over the shipped 737's (both without
the autopilot); `bare_120hz_realtime_factor`: the bare aircraft (no autopilot) stepped at
120 Hz, JSBSim's own default rate, over the leg's simulated time, and
`realtime_factor_vs_bare_120hz` the truth loop's realtime factor over it (target >= 1.5).
`approach_ratio` = bare µs/step / µs/step of an ILS approach (KDLH 27, AFIS profile, at its
100 Hz step, against the autopilot's bare loop at that step) with its 50 Hz inertial
recording, and `approach_turbulence_ratio` the same with its MIL-F-8785C gusts (50 Hz, in
Python); `approach_realtime_factor_vs_bare_120hz` is the approach's realtime factor over the
bare 120 Hz aircraft's. Rounds alternate bare and truth runs; the fastest of each is kept
(noise only slows), and times are this process's CPU time (time.process_time), so other work
on the machine does not count; `realtime_factor` uses the same CPU time.

    python benchmarks/truth_speed.py [--rounds 3] [--aircraft NAME] [--from KMSP --to KDLH]
"""

from __future__ import annotations

import argparse
import time
from datetime import UTC, datetime

from aerotruth.truth.airframes import airframe, new_fdm
from aerotruth.truth.approach import approach_spec, fly_approach
from aerotruth.truth.days import plan_in_weather
from aerotruth.truth.fdm import ILS_DT
from aerotruth.truth.flight import DT, fly_leg


def _cruise_ic(fdm) -> None:
    fdm["ic/h-sl-ft"] = 15000.0
    fdm["ic/vc-kts"] = 200.0
    fdm["ic/lat-geod-deg"] = 45.0
    fdm["ic/long-gc-deg"] = -93.0
    fdm.run_ic()
    fdm["propulsion/set-running"] = -1
    for i in (0, 1):
        fdm[f"fcs/throttle-cmd-norm[{i}]"] = 0.8


def _wrapped(af, dt: float):
    """The aircraft with the autopilot at step dt, holding 15,000 ft and 200 KIAS."""
    fdm = new_fdm(af, dt)
    _cruise_ic(fdm)
    fdm["ap/target/altitude-ft"] = 15000.0
    fdm["ap/target/ias-kt"] = 200.0
    fdm["ap/active"] = 1
    return fdm


BARE_REFERENCE_DT = 1.0 / 120.0  # s: JSBSim's default step, the reference for the truth's realtime factor
CHUNK = round(400.0 / DT)  # steps (400 s) between re-initialisations: the bare aircraft stays in cruise


def bare_us_per_step(fdm, steps: int) -> float:
    """Mean µs per fdm.run() over `steps`, in chunks restarted from the cruise state (an
    uncontrolled aircraft would otherwise wander into other regimes over a long run)."""
    run = fdm.run
    spent = 0.0
    done = 0
    while done < steps:
        n = min(CHUNK, steps - done)
        _cruise_ic(fdm)
        for _ in range(200):
            run()
        t = time.process_time()
        for _ in range(n):
            run()
        spent += time.process_time() - t
        done += n
    return spent / steps * 1e6


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--aircraft", default=None)
    ap.add_argument("--from", dest="origin", default="KMSP")
    ap.add_argument("--to", dest="destination", default="KDLH")
    args = ap.parse_args()
    af = airframe(args.aircraft)
    plan = plan_in_weather(args.origin, args.destination, datetime(2009, 8, 15, 13, 0, tzinfo=UTC), weather_seed=1)

    wrapped = _wrapped(af, DT)
    wrapped_ils = _wrapped(af, ILS_DT) if af.name == "saab340" else None
    plain = new_fdm(af, DT, autopilot=False)
    ref737 = new_fdm(airframe("737"), DT, autopilot=False)  # a shipped twin for scale
    plain120 = new_fdm(af, BARE_REFERENCE_DT, autopilot=False)

    bare, unwrapped, truth, rt, b737, rt120 = [], [], [], [], [], []
    # (approach spec, its us/step list, the bare loop's us/step over as many steps)
    approaches = [
        (approach_spec("KDLH", "27", datetime(2009, 8, 15, 15, 0, tzinfo=UTC), turbulence=turb), [], [])
        for turb in (False, True)
    ]
    for _ in range(args.rounds):
        if af.name == "saab340":
            for spec, cost, cost_bare in approaches:
                t = time.process_time()
                a = fly_approach(spec, seed=1, aircraft=af)
                wall = time.process_time() - t
                a_steps = round((float(a.df["time_s"].iloc[-1]) + 0.02) / ILS_DT)
                cost.append(wall / a_steps * 1e6)
                cost_bare.append(bare_us_per_step(wrapped_ils, a_steps))
        t = time.process_time()
        track = fly_leg(plan, seed=1, aircraft=af)
        wall = time.process_time() - t
        sim = float(track.df["time_s"].iloc[-1]) + 0.1
        steps = round(sim / DT)
        truth.append(wall / steps * 1e6)
        rt.append(sim / wall)
        bare.append(bare_us_per_step(wrapped, steps))
        unwrapped.append(bare_us_per_step(plain, steps))
        b737.append(bare_us_per_step(ref737, steps))
        rt120.append(1e6 / (bare_us_per_step(plain120, round(sim / BARE_REFERENCE_DT)) / BARE_REFERENCE_DT))

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
    print(f"shipped_737_us_per_step: {min(b737):.3f}")
    print(f"vs_737_step_ratio: {u / min(b737):.3f}")
    print(f"bare_120hz_realtime_factor: {max(rt120):.1f}")
    print(f"realtime_factor_vs_bare_120hz: {max(rt) / max(rt120):.3f}")
    if af.name == "saab340":
        for (_spec, cost, cost_bare), label in zip(approaches, ("approach", "approach_turbulence"), strict=False):
            print(f"{label}_us_per_step: {min(cost):.3f}")
            print(f"{label}_ratio: {min(cost_bare) / min(cost):.3f}")
            print(f"{label}_realtime_factor_vs_bare_120hz: {1e6 / (min(cost) / ILS_DT) / max(rt120):.3f}")


if __name__ == "__main__":
    main()
