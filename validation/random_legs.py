"""Reliability sweep: N random legs over the three networks, each in its day's truth
atmosphere with JSBSim turbulence, flown in a process pool. Every leg ends either as
truth or as a counted, logged divergence with its seed; nothing fails silently.

Prints one line per divergence and `label: value` totals:

    python validation/random_legs.py [--legs 200] [--workers 2] [--aircraft NAME] [--seed 2009]
"""

from __future__ import annotations

import argparse
import multiprocessing as mp
import time
from concurrent.futures import ProcessPoolExecutor
from datetime import UTC, date, datetime, timedelta

import numpy as np

from aerotruth.truth.airports import networks


def draw_legs(n: int, seed: int) -> list[tuple[int, str, str, str, datetime]]:
    rng = np.random.default_rng(seed)
    nets = sorted(networks().items())
    legs = []
    for i in range(n):
        name, net = nets[int(rng.integers(len(nets)))]
        hub = net.hubs[int(rng.integers(len(net.hubs)))]
        spokes = net.spokes_by_hub[hub]
        spoke = spokes[int(rng.integers(len(spokes)))]
        a, b = (hub, spoke) if rng.random() < 0.5 else (spoke, hub)
        day = date(2009, 1, 1) + timedelta(days=int(rng.integers(0, 730)))
        dep = datetime(day.year, day.month, day.day, tzinfo=UTC) + timedelta(minutes=int(rng.integers(0, 1440)))
        legs.append((i, name, a, b, dep))
    return legs


def fly_one(job):
    from aerotruth.truth.days import plan_in_weather
    from aerotruth.truth.flight import FlightDiverged, fly_leg
    from aerotruth.truth.weather import NETWORK_REGION

    i, net, a, b, dep, aircraft, base_seed = job
    seed = base_seed + i
    try:
        plan = plan_in_weather(a, b, dep, weather_seed=seed)
        track = fly_leg(plan, seed=seed, aircraft=aircraft, turbulence=True, region=NETWORK_REGION[net])
    except FlightDiverged as e:
        return i, f"{a}-{b}", "diverged", {"reason": e.reason, "seed": e.seed, "time_s": e.time_s}
    except ValueError as e:  # a leg the planner refuses (e.g. too short for any profile)
        return i, f"{a}-{b}", "refused", {"reason": str(e), "seed": seed}
    return i, f"{a}-{b}", "ok", track.summary()


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--legs", type=int, default=200)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--aircraft", default=None)
    ap.add_argument("--seed", type=int, default=2009)
    args = ap.parse_args()
    jobs = [(*leg, args.aircraft, args.seed) for leg in draw_legs(args.legs, args.seed)]
    t0 = time.perf_counter()
    results = []
    with ProcessPoolExecutor(args.workers, mp_context=mp.get_context("spawn")) as pool:
        for r in pool.map(fly_one, jobs):
            results.append(r)
            if r[2] != "ok":
                print(f"{r[2]}: leg {r[0]} {r[1]} seed {r[3]['seed']}: {r[3]['reason']}", flush=True)
    ok = [r[3] for r in results if r[2] == "ok"]
    sim_s = sum(s["duration_s"] for s in ok)
    print(f"legs: {len(results)}")
    print(f"ok: {len(ok)}")
    print(f"diverged: {sum(r[2] == 'diverged' for r in results)}")
    print(f"refused: {sum(r[2] == 'refused' for r in results)}")
    if ok:
        for key in (
            "cruise_tas_error_max_kt",
            "cruise_xtrack_max_nm",
            "arrival_centreline_offset_nm",
            "wind_triangle_residual_max_kt",
        ):
            vals = np.array([s[key] for s in ok], dtype=float)
            vals = vals[np.isfinite(vals)]
            print(f"{key}_p95: {np.percentile(vals, 95):.3f}")
            print(f"{key}_max: {vals.max():.3f}")
    print(f"simulated_hours: {sim_s / 3600:.1f}")
    print(f"wall_s: {time.perf_counter() - t0:.1f}")


if __name__ == "__main__":
    main()
