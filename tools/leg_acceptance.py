"""Prints the leg acceptance figures for MSP->DLH and ANC->DLG
(cruise TAS error, cruise cross-track, arrival offset from the extended centreline,
wind-triangle closure) for each aircraft, in the day's truth atmosphere.

    python tools/leg_acceptance.py [--aircraft saab340 737] [--seed 1] [--turbulence]
"""

from __future__ import annotations

import argparse
from datetime import UTC, datetime

from aerotruth.truth.days import plan_in_weather
from aerotruth.truth.flight import fly_leg


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--aircraft", nargs="+", default=["saab340", "737"])
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--turbulence", action="store_true")
    args = ap.parse_args()
    dep = datetime(2009, 8, 15, 13, 0, tzinfo=UTC)
    for ac in args.aircraft:
        for a, b in (("KMSP", "KDLH"), ("PANC", "PADL")):
            plan = plan_in_weather(a, b, dep, weather_seed=args.seed)
            s = fly_leg(plan, seed=args.seed, aircraft=ac, turbulence=args.turbulence).summary()
            tag = f"{ac}_{a}_{b}"
            for key in (
                "cruise_tas_error_max_kt",
                "cruise_xtrack_max_nm",
                "arrival_centreline_offset_nm",
                "wind_triangle_residual_max_kt",
                "duration_s",
            ):
                print(f"{tag}_{key}: {s[key]:.4f}")


if __name__ == "__main__":
    main()
