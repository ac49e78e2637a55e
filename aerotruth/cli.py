"""The `aerotruth` command line. Each subcommand's work lives in its module; this file
only parses arguments and turns expected errors into one clear line (exit 2)."""

from __future__ import annotations

import argparse
import sys


class UserError(Exception):
    """An error in the user's input: printed as one line, no traceback."""


def _cmd_fly(args: argparse.Namespace) -> int:
    from aerotruth.truth.flight import fly_cli

    return fly_cli(args)


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="aerotruth", description=__doc__)
    sub = p.add_subparsers(dest="command", required=True)

    fly = sub.add_parser("fly", help="fly one leg with JSBSim and write its TruthTrack (Parquet)")
    fly.add_argument("--from", dest="origin", required=True, help="departure airport ICAO code")
    fly.add_argument("--to", dest="destination", required=True, help="arrival airport ICAO code")
    fly.add_argument("--date", required=True, help="UTC date YYYY-MM-DD (or ISO date-time of departure)")
    fly.add_argument("--seed", type=int, default=0, help="random seed (weather realization, schedule)")
    fly.add_argument("--aircraft", default=None, help="aircraft name (default: the project default)")
    fly.add_argument("--turbulence", action="store_true", help="switch on JSBSim turbulence")
    fly.add_argument("--out", required=True, help="output Parquet file")
    fly.set_defaults(func=_cmd_fly)
    return p


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except UserError as e:
        print(f"aerotruth {args.command}: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
