"""The `aerotruth` command line. Each subcommand's work lives in its module; this file
only parses arguments and prints user errors (aerotruth.errors.UserError) as one clear
line with exit status 2."""

from __future__ import annotations

import argparse
import math
import re
import sys
import typing
from pathlib import Path

import aerotruth
from aerotruth.errors import UserError


def _non_negative_int(text: str) -> int:
    try:
        if len(text.strip()) > 40:  # int() of a long text is slow, beyond 4,300 digits an error
            raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {len(text.strip())} characters")
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {text!r}") from None
    if value < 0:
        raise argparse.ArgumentTypeError(f"expected a non-negative integer, got {value}")
    return value


def _non_negative_float(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a non-negative number, got {text!r}") from None
    if not (math.isfinite(value) and value >= 0):
        raise argparse.ArgumentTypeError(f"expected a non-negative number, got {text}")
    return value


def spec_value(model, field: str, unit: str = ""):
    """An argparse type that takes a number as the pydantic `model`'s `field` does: its bounds
    are declared once, in the model, and a refusal states them and what the field is."""
    from pydantic import TypeAdapter, ValidationError

    info = model.model_fields[field]
    adapter = TypeAdapter(typing.Annotated[(info.annotation, *info.metadata)] if info.metadata else info.annotation)
    bounds = {
        k: getattr(m, k) for m in info.metadata for k in ("ge", "gt", "le", "lt") if getattr(m, k, None) is not None
    }
    lo = bounds.get("ge", bounds.get("gt"))
    hi = bounds.get("le", bounds.get("lt"))
    span = (
        f"{lo:g} to {hi:g}"
        if lo is not None and hi is not None
        else f"at least {lo:g}"
        if lo is not None
        else f"at most {hi:g}"
        if hi is not None
        else "a number"
    )
    what = re.sub(r"\s*\([^()]*\)$", "", (info.description or "").split(":")[0])
    what = f" ({what})" if what else ""
    expected = f"expected {span}{' ' + unit if unit else ''}{what}"

    def parse(text: str):
        try:
            number = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{expected}, got {text!r}") from None
        if not math.isfinite(number):
            raise argparse.ArgumentTypeError(f"{expected}, got {text!r}")
        try:
            return adapter.validate_python(number if info.annotation is float else text)
        except ValidationError:
            raise argparse.ArgumentTypeError(f"{expected}, got {text!r}") from None

    return parse


def _pass_height_ft(text: str) -> float:
    """An AFIS level-pass height: above the runway, below a pattern altitude."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a height in ft, got {text!r}") from None
    if not 20.0 <= value <= 1000.0:
        raise argparse.ArgumentTypeError(
            f"expected 20-1000 ft above the runway (AFIS passes fly 50-100 ft), got {value:g}"
        )
    return value


def _integer(text: str) -> int:
    """A whole number as typed (the bounds are the command's): at most 40 characters, as
    int() of a longer text is slow and beyond 4,300 digits an error; a longer one is said by
    its length, not echoed."""
    t = text.strip()
    try:
        if len(t) > 40:
            raise ValueError
        return int(t)
    except ValueError:
        shown = repr(t) if len(t) <= 40 else f"{len(t)} characters"
        raise argparse.ArgumentTypeError(f"expected a whole number, got {shown}") from None


def _positive_up_to(most: float, unit: str, beyond: str):
    """An argparse type: a number above 0 and at most `most` (`beyond`: why a larger one means nothing)."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            value = math.nan
        if not 0 < value <= most:
            raise argparse.ArgumentTypeError(
                f"expected a number above 0 and at most {most:,.0f} {unit} ({beyond}), got {text[:40]!r}"
            )
        return value

    return parse


# the consensus neighbourhood's largest extents: beyond them every sample is in every neighbourhood
RADIUS_KM_MAX = 20_015.0  # half the Earth's circumference
LAYER_FT_MAX = 72_000.0  # the span of the reports' pressure altitudes, -2,000 to 70,000 ft
WINDOW_S_MAX = 4_102_444_800.0  # the span of the dates aerotruth models, 1900-2029 (aerotruth.dates)


def _positive_int(text: str) -> int:
    value = _non_negative_int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a positive integer, got {value}")
    return value


def _output_file(value: str, option: str = "--out") -> Path:
    """Check an output file path before any work is done (a flight is never flown to be lost):
    a Parquet file name in an existing folder that takes a probe write (errors.output_file)."""
    from aerotruth.errors import output_file

    out = Path(value)
    if out.is_dir():
        raise UserError(f"{option}: {out} is a folder, expected a file name (e.g. {out / 'flight.parquet'})")
    if out.suffix and out.suffix.lower() not in (".parquet", ".pq"):
        raise UserError(
            f"{option}: the TruthTrack is written as Parquet: expected a .parquet file name, got '{out.name}'"
        )
    return output_file(out, option)


def _seed(text: str) -> int:
    """A seed: an integer from 0 to 2^63 - 1, the 63-bit seeds a campaign derives for its days
    and flights (the fly_command of a truth row)."""
    from aerotruth.sim.campaign_file import SEED_MAX

    expected = f"expected a seed from 0 to {SEED_MAX} (63 bits)"
    t = text.strip()
    if len(t) > 40:  # int() of a long text is slow, beyond 4,300 digits an error
        shown = f"{len(t)} digits" if t.isdigit() else f"{len(t)} characters"
        raise argparse.ArgumentTypeError(f"{expected}, got {shown}")
    try:
        value = int(t)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{expected}, got {t!r}") from None
    if not 0 <= value <= SEED_MAX:
        raise argparse.ArgumentTypeError(f"{expected}, got {value if len(t) <= 20 else f'{len(t)} digits'}")
    return value


def _one_line_errors(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    """`parser` with its usage errors (an option's bad value, a missing option) printed as one
    line, `aerotruth fly: argument --seed: expected ... (see aerotruth fly --help)`, exit 2."""

    def error(message: str) -> typing.NoReturn:
        parser.exit(2, f"{parser.prog}: {message} (see {parser.prog} --help)\n")

    parser.error = error  # type: ignore[method-assign]
    return parser


def _model_date(when, given: str, option: str = "--date"):
    """`when` (parsed from `given`) if its UTC day is one aerotruth models (aerotruth.dates),
    else a UserError naming `option`."""
    from aerotruth.dates import check_model_date

    check_model_date(when, option, given=repr(given))
    return when


def _cmd_fly(args: argparse.Namespace) -> int:
    from aerotruth.truth.airframes import DEFAULT_AIRCRAFT, airframe
    from aerotruth.truth.days import (
        day_atmosphere,
        on_airway,
        parse_departure,
        plan_in_weather,
    )
    from aerotruth.truth.flight import FlightDiverged, fly_leg
    from aerotruth.truth.routes import CRUISE_CEILING_FT
    from aerotruth.truth.weather import region_for_airport
    from aerotruth.units import NM

    out = _output_file(args.out)
    # certified ceilings of the flown types: the SAAB 340B's is the route planner's
    # (CRUISE_CEILING_FT, 25,000 ft); Boeing 737 classic/NG 41,000 ft
    ceiling_fl = {"saab340": int(CRUISE_CEILING_FT // 100), "737": 410}.get(args.aircraft or DEFAULT_AIRCRAFT)
    if args.cruise_fl is not None and ceiling_fl is not None and args.cruise_fl > ceiling_fl:
        raise UserError(
            f"--cruise-fl: FL{args.cruise_fl} is above the {args.aircraft or DEFAULT_AIRCRAFT}'s ceiling, "
            f"FL{ceiling_fl}"
        )
    origin, destination = args.origin.strip().upper(), args.destination.strip().upper()
    weather_seed = args.seed if args.weather_seed is None else args.weather_seed
    from aerotruth.truth.airports import airport

    for flag, code in (("--from", origin), ("--to", destination)):
        try:
            airport(code)
        except ValueError as e:
            raise UserError(f"{flag}: {e}") from None
    if origin == destination:
        raise UserError(f"--to: {destination} is the departure airport (--from); expected another airport")
    try:
        departure = _model_date(parse_departure(args.date), args.date)
        airframe(args.aircraft)
        region = args.region or region_for_airport(origin)
        plan = plan_in_weather(
            origin,
            destination,
            departure,
            weather_seed=weather_seed,
            region=region,
            cruise_flight_level=args.cruise_fl,
            flight_id=args.flight_id or "",
        )
        if not args.direct:
            plan = on_airway(plan, args.seed)
        atmosphere = day_atmosphere(plan.departure_utc.date(), weather_seed, region)
        track = fly_leg(plan, seed=args.seed, aircraft=args.aircraft, turbulence=args.turbulence, atmosphere=atmosphere)
    except (ValueError, FlightDiverged) as e:
        raise UserError(str(e)) from None
    track.to_parquet(out)
    if args.cruise_fl is not None and plan.cruise_flight_level != args.cruise_fl:
        print(
            f"--cruise-fl: FL{args.cruise_fl} does not fit this leg (climb, cruise and a 3 deg descent); flown at "
            f"FL{plan.cruise_flight_level}, the highest level of the direction's parity that does"
        )
    s = track.summary()
    print(
        f"{plan.origin.icao} rwy {plan.departure_runway.ident} -> {plan.destination.icao} rwy "
        f"{plan.arrival_runway.ident}, FL{plan.cruise_flight_level}, {plan.total_distance_m / NM:.0f} nm: "
        f"{len(track)} samples ({s['duration_s'] / 60:.1f} min) -> {out}"
    )
    print(
        f"cruise TAS error max {s['cruise_tas_error_max_kt']:.2f} kt, cruise cross-track max "
        f"{s['cruise_xtrack_max_nm']:.3f} nm, arrival off centreline {s['arrival_centreline_offset_nm']:.3f} nm"
    )
    return 0


def _cmd_fly_approach(args: argparse.Namespace) -> int:
    from aerotruth.seeds import child, named_sequence
    from aerotruth.truth.approach import (
        approach_metrics,
        approach_spec,
        find_runway,
        fly_approach,
    )
    from aerotruth.truth.days import day_atmosphere, parse_departure
    from aerotruth.truth.flight import FlightDiverged
    from aerotruth.truth.weather import region_for_airport

    out = _output_file(args.out)
    icao = args.airport.strip().upper()
    weather_seed = args.seed if args.weather_seed is None else args.weather_seed
    flight_seed = args.seed if args.flight_seed is None else args.flight_seed
    try:
        when = _model_date(parse_departure(args.date, default_hour=15), args.date)
        runway = find_runway(icao, args.runway)
        region = args.region or region_for_airport(icao)
        atmosphere = None if args.calm else day_atmosphere(when.date(), weather_seed, region)
        spec = approach_spec(
            icao,
            runway.ident,
            when,
            profile=args.profile,
            mass_kg=args.mass_kg,
            turbulence=args.turbulence,
            pass_height_ft=args.pass_height_ft,
            offset_nm=args.offset_nm,
            intercept_deg=args.intercept_deg,
        )
        seed = child(named_sequence(flight_seed, "approach", icao, runway.ident), "flight")
        track = fly_approach(spec, seed=seed, atmosphere=atmosphere)
    except (ValueError, FlightDiverged) as e:
        raise UserError(str(e)) from None
    track.to_parquet(out)
    m = approach_metrics(track)
    print(
        f"{icao} ILS {runway.ident} ({spec.profile}), {len(track)} samples at 50 Hz "
        f"({track.df['time_s'].iloc[-1] / 60:.1f} min) -> {out}"
    )
    print(
        f"at 1,000 ft: localizer {m['loc_dots_1000ft']:+.2f} dot, glide slope {m['gs_dots_1000ft']:+.2f} dot, "
        f"Vref{m['cas_minus_vref_kt_1000ft']:+.1f} kt, sink {m['sink_fpm_1000ft']:.0f} fpm; "
        f"threshold crossed at {m['height_over_threshold_ft']:.0f} ft, {m['cas_threshold_kt']:.0f} KCAS"
    )
    return 0


def _cmd_diagnose(args: argparse.Namespace) -> int:
    from aerotruth.app.diagnose import diagnose_main

    return diagnose_main(args.measured, args.model, args.out, args.aircraft_type, args.engine_type)


def _cmd_fits(args: argparse.Namespace) -> int:
    from aerotruth.analysis.fits.filter import FitsSpec
    from aerotruth.app.fits import fits_main

    spec = FitsSpec(
        ra_lever_arm_m=args.ra_lever_arm,
        waas_latency_s=args.waas_latency,
        cross_track_fix="none" if args.no_tvps_fix else "tvps",
    )
    try:
        return fits_main(args.log, args.out, spec)
    except ValueError as e:  # DataError and other bad-input errors: one line
        raise UserError(str(e)) from None


def _cmd_realism(args: argparse.Namespace) -> int:
    from aerotruth.app.realism import realism_cli

    try:
        return realism_cli(args)
    except ValueError as e:  # DataError and other bad-input errors: one line
        raise UserError(str(e)) from None


def _cmd_reports(args: argparse.Namespace) -> int:
    from aerotruth.app.reports import reports_main

    return reports_main(args.traffic, args.out, args.reference, args.radius_km, args.layer_ft, args.window_s)


def _cmd_heading_fit(args: argparse.Namespace) -> int:
    from aerotruth.app.heading_fit import heading_fit_main

    return heading_fit_main(
        args.obs,
        args.out,
        n_boot=args.bootstrap,
        seed=args.seed,
        min_reports=args.min_reports,
        min_clusters=args.min_clusters,
        cluster_s=args.cluster_s,
        position_step_deg=args.position_step_deg,
        max_sinusoid_se_deg=args.max_sinusoid_se_deg,
    )


def _cmd_heading_apply(args: argparse.Namespace) -> int:
    from aerotruth.app.heading_apply import heading_apply_main

    return heading_apply_main(args.obs, args.tables, args.out)


def _hours(text: str) -> float:
    """--stop-after: a number of hours, 0 or more and finite."""
    t = text.strip()
    shown = repr(t) if len(t) <= 40 else f"{len(t)} characters"
    try:
        value = float(t) if len(t) <= 40 else math.nan
    except ValueError:
        value = math.nan
    if not (math.isfinite(value) and value >= 0.0):
        raise argparse.ArgumentTypeError(f"expected a number of hours, 0 or more, got {shown}")
    return value


def _workers(text: str) -> int:
    """--workers: 1 to the most processes a campaign may ask for (campaign_file.MAX_WORKERS)."""
    from aerotruth.sim.campaign_file import MAX_WORKERS

    t = text.strip()
    shown = repr(t) if len(t) <= 40 else f"{len(t)} characters"
    try:
        value = int(t) if len(t) <= 40 else 0
    except ValueError:
        value = 0
    if not 1 <= value <= MAX_WORKERS:
        raise argparse.ArgumentTypeError(f"expected 1 to {MAX_WORKERS} worker processes, got {shown}")
    return value


def _add_campaign_commands(sub) -> None:
    """run / validate / figures / report / regress: implemented in aerotruth.app.campaign_commands."""

    def lazy(name: str):
        def call(args: argparse.Namespace) -> int:
            from aerotruth.app import campaign_commands as commands

            return getattr(commands, name)(args)

        return call

    run = sub.add_parser(
        "run",
        help="run a campaign (seeded Monte-Carlo) into a run directory",
        description="Run (or resume) a seeded Monte-Carlo campaign into its run directory (default "
        "runs/<name>; with --size NAME the campaign's `sizes: NAME:` overrides, into "
        "runs/<name>-NAME): one table per task, the learned states, metrics.json, the "
        "studies' tables and data exports, then the figures and RUN_DIR/report.md. Legs "
        "and approaches come from the truth store and are flown only when missing; a "
        "stored task result is reused only while the code, data and configuration it came "
        "from are unchanged. Every random draw comes from a stream named by its task, so "
        "the numbers do not depend on the executor or the number of workers. The run folder "
        "must be new, empty or a run folder (its manifest.json): a folder holding other "
        "files is refused unless --force, and even then a run never replaces a file it did "
        "not write. A campaign's `study_modules:` are code, imported (run) as the campaign is "
        "read: run only campaigns you trust.",
    )
    _one_line_errors(run)
    run.add_argument("campaign", help="campaign YAML file")
    run.add_argument(
        "--size", default=None, help="apply the campaign's `sizes: NAME:` overrides (e.g. reduced); runs/<name>-<size>"
    )
    run.add_argument(
        "--out",
        default=None,
        help="run directory (default runs/<campaign name>): a new or empty folder, or a run folder to resume",
    )
    run.add_argument(
        "--force",
        action="store_true",
        help="also run into a non-empty folder that is not a run folder, as long as none of the names a run "
        "writes (.lock, config.resolved.yaml, manifest.json, metrics.json, report.md, tasks/, learned/, "
        "failed/, tables/, data/, figures/) is taken there: a file aerotruth did not write is never replaced",
    )
    run.add_argument("--workers", type=_workers, default=None, help="worker processes (default: cores)")
    run.add_argument(
        "--executor", choices=["local", "dask"], default=None, help="executor (default: the YAML's, else local)"
    )
    run.add_argument("--scheduler", default=None, help="Dask scheduler address (implies --executor dask)")
    run.add_argument("--quiet", action="store_true", help="no progress bar")
    run.add_argument("--no-report", action="store_true", help="skip figures and report")
    run.add_argument(
        "--stop-after",
        type=_hours,
        default=None,
        metavar="HOURS",
        help="start no task after this many hours (at least one), store those in flight and exit with "
        "status 3: a run in parts, each at most HOURS plus its last tasks; the same command goes on "
        "from the stored tasks and flown legs",
    )
    run.set_defaults(func=lazy("run_cli"))

    val = sub.add_parser(
        "validate",
        help="check a campaign YAML and expand its tasks",
        description="Check a campaign file against the schema of every study it names (a problem is "
        "one line naming the YAML path and line), expand its tasks and print their count "
        "per study and the configuration hash. Nothing is run or flown, but a campaign's "
        "`study_modules:` are code and are imported (run) to check their sections: validate "
        "only campaigns you trust.",
    )
    _one_line_errors(val)
    val.add_argument("campaign", help="campaign YAML file")
    val.add_argument("--size", default=None, help="validate with the campaign's `sizes: NAME:` overrides applied")
    val.set_defaults(func=lazy("validate_cli"))

    fig = sub.add_parser(
        "figures",
        help="draw the figures of a run directory",
        description="Draw the figures of a finished run into RUN_DIR/figures (PNG and PDF): each "
        "study draws its own from its stored rows, tables and learned states; nothing is "
        "recomputed.",
    )
    fig.add_argument("run_dir", help="run directory written by `aerotruth run`")
    fig.set_defaults(func=lazy("figures_cli"))

    rep = sub.add_parser(
        "report",
        help="write RUN_DIR/report.md with figures and metric tables",
        description="Write RUN_DIR/report.md for a finished run: the campaign (seed, configuration "
        "hash, task counts, library versions), then per study its tables, its figures "
        "(drawn anew: PNG embedded, PDF linked) and all its metrics.",
    )
    rep.add_argument("run_dir", help="run directory written by `aerotruth run`")
    rep.set_defaults(func=lazy("report_cli"))

    reg = sub.add_parser(
        "regress",
        help="compare a run's metrics with a baseline (exit 1 if a metric moved)",
        description="Compare a run's metrics.json with a baseline JSON. A metric passes when |got - "
        "value| <= abs + rel |value| (its own tolerances, else the baseline's defaults); "
        "a baseline metric missing from the run fails. Exit status 1 and a table of the "
        "metrics that moved; --write makes the baseline from the run instead.",
    )
    reg.add_argument("run_dir", help="run directory written by `aerotruth run`")
    reg.add_argument("baseline", help="baseline JSON (metric values and tolerances)")
    reg.add_argument("--write", action="store_true", help="write the baseline from this run instead of checking")
    reg.add_argument(
        "--abs-tol", type=_non_negative_float, default=0.0, help="with --write: absolute tolerance per metric"
    )
    reg.add_argument(
        "--rel-tol", type=_non_negative_float, default=0.01, help="with --write: relative tolerance per metric"
    )
    reg.add_argument("--all", action="store_true", help="print every metric, not only those that moved")
    reg.set_defaults(func=lazy("regress_cli"))


def build_parser() -> argparse.ArgumentParser:
    from aerotruth.analysis.fits.filter import FitsSpec

    p = argparse.ArgumentParser(prog="aerotruth", description=__doc__.split("\n\n")[0])
    p.add_argument("--version", action="version", version=f"aerotruth {aerotruth.__version__}")
    sub = p.add_subparsers(dest="command", required=True)

    fly = sub.add_parser(
        "fly",
        help="fly one leg with JSBSim and write its TruthTrack (Parquet)",
        description="Fly one route leg with JSBSim (the SAAB 340B unless --aircraft) through the "
        "day's truth atmosphere and write its 10 Hz TruthTrack (Parquet, "
        "docs/data-formats.md): runways chosen into the day's surface wind, a straight "
        "climb-out, en-route fixes drawn from --seed (--direct leaves them out), cruise, "
        "and a descent to a point on final 2,000 ft above the runway. A campaign leg is "
        "re-flown bit for bit with the arguments in the fly_command column of its truth "
        "row (seeds, region, cruise level, flight id).",
    )
    _one_line_errors(fly)
    fly.add_argument("--from", dest="origin", required=True, help="departure airport ICAO code")
    fly.add_argument("--to", dest="destination", required=True, help="arrival airport ICAO code")
    fly.add_argument(
        "--date",
        required=True,
        help="UTC date YYYY-MM-DD (departure 13:00 UTC) or ISO date-time of departure, 1900-01-01 to 2029-12-31 "
        "(the span of IGRF-14, the magnetic field model)",
    )
    fly.add_argument(
        "--seed",
        type=_seed,
        default=0,
        help="flight seed, 0 to 2^63 - 1 (en-route fixes, turbulence); also the weather seed unless --weather-seed",
    )
    fly.add_argument(
        "--weather-seed",
        type=_seed,
        default=None,
        help="seed of the day's truth atmosphere (default: --seed)",
    )
    fly.add_argument("--region", default=None, help="truth-atmosphere region (default: that of the departure airport)")
    fly.add_argument(
        "--cruise-fl", type=_positive_int, default=None, help="cruise flight level (default: by distance and direction)"
    )
    fly.add_argument("--flight-id", default=None, help="flight id recorded in the track's metadata")
    fly.add_argument("--aircraft", default=None, help="aircraft type (default: the project default, saab340)")
    fly.add_argument(
        "--turbulence",
        action="store_true",
        help="a real flight's disturbances: MIL-F-8785C turbulence patches, light chop, steering wander",
    )
    fly.add_argument(
        "--direct", action="store_true", help="no en-route fixes: direct from the climb-out to the arrival fix"
    )
    fly.add_argument("--out", required=True, help="output Parquet file")
    fly.set_defaults(func=_cmd_fly)
    _add_campaign_commands(sub)

    fa = sub.add_parser(
        "fly-approach",
        help="fly one ILS approach with JSBSim and write its 50 Hz TruthTrack (Parquet)",
        description="Fly one coupled ILS approach with JSBSim's SAAB 340B from 14 nm out: gear and "
        "flaps 20 at glide-path capture, flaps 35 below 2,000 ft, Vref + 5 kt by 1,000 ft, "
        "then the AFIS level pass over the runway (--pass-height-ft) or a go-around at 200 "
        "ft (--profile go-around). Writes a 50 Hz TruthTrack with the runway-frame "
        "position and the IMU's velocity and angle increments (docs/data-formats.md). "
        "--offset-nm and --intercept-deg start it off the centreline for a turn onto "
        "final.",
    )
    _one_line_errors(fa)
    fa.add_argument("--airport", required=True, help="airport ICAO code (the embedded airport table)")
    fa.add_argument("--runway", required=True, help="runway end landed on, e.g. 27")
    fa.add_argument(
        "--date",
        required=True,
        help="UTC date YYYY-MM-DD (start 15:00 UTC) or ISO date-time of the start, 1900-01-01 to 2029-12-31 "
        "(the span of IGRF-14, the magnetic field model)",
    )
    fa.add_argument(
        "--seed", type=_seed, default=0, help="seed of the approach, 0 to 2^63 - 1 (weather and flight unless given)"
    )
    fa.add_argument(
        "--weather-seed",
        type=_seed,
        default=None,
        help="seed of the day's truth atmosphere (default: --seed)",
    )
    fa.add_argument(
        "--flight-seed",
        type=_seed,
        default=None,
        help="seed of the flight's own draws, e.g. turbulence (default: --seed)",
    )
    fa.add_argument("--region", default=None, help="truth-atmosphere region (default: that of the airport)")
    fa.add_argument(
        "--profile",
        choices=["afis", "go-around"],
        default="afis",
        help="after the glide path: the AFIS level pass over the runway, or a go-around at 200 ft",
    )
    fa.add_argument(
        "--pass-height-ft", type=_pass_height_ft, default=100.0, help="AFIS level-pass height above the runway (ft)"
    )
    fa.add_argument("--mass-kg", type=float, default=12000.0, help="landing mass (kg); Vref = 1.3 Vs scales with it")
    fa.add_argument(
        "--turbulence",
        action="store_true",
        help="MIL-F-8785C turbulence in patches, near the ground 0.1 x the wind at 20 ft",
    )
    fa.add_argument("--calm", action="store_true", help="ISA, no wind (instead of the day's truth atmosphere)")
    fa.add_argument(
        "--offset-nm", type=float, default=0.0, help="start this far left (+) or right (-) of the centreline (nm) ..."
    )
    fa.add_argument(
        "--intercept-deg", type=float, default=0.0, help="... on a heading this far off the course: a turn onto final"
    )
    fa.add_argument("--out", required=True, help="output Parquet file")
    fa.set_defaults(func=_cmd_fly_approach)

    dia = sub.add_parser(
        "diagnose",
        help="show where measured data disagree with the simulation's sensor model, and why",
        description="Recognise a measured file from its content and tell where it disagrees with the "
        "sensor model of the simulation (the campaign of --model), which effect explains "
        "it, by how much, and what the extended model gains on data it was not fitted on. "
        "Mode-S message logs and trajectories: heading offset, once-round heading "
        "deviation, TAS scale, heading/track timing and compass slaving lag, from the "
        "smoothness of the derived wind. Observation tables: the wind paper's deviation "
        "model per aircraft against soft iron, hard-iron scaling with the horizontal "
        "field, TAS scale, a stale declination model, a biased reference model, a "
        "recalibration, a drifting offset and coarser report rounding, tested on 6-h "
        "weather blocks. Approach logs: INS axes not in the runway frame, another WAAS "
        "cyclic period, a DGPS survey offset, unflagged WAAS jumps, late WAAS time tags, "
        "a TVPS sign or scale, a barometer loop's time constant and an INS beyond its "
        "grade. Writes DIR/diagnosis.json, DIR/report.md and figures, and for Mode-S data "
        "and observation tables with findings DIR/extended_model.yaml (the campaign with "
        "the findings in its model).",
    )
    dia.add_argument(
        "measured",
        help="measured data file (Mode-S JSON/JSONL, multi-aircraft traffic, observation table, approach log, ...)",
    )
    dia.add_argument(
        "--model",
        default=None,
        help="campaign YAML of the simulation the data are compared with (default: the sensor models' defaults, "
        "the wind paper's model for reports; then no extended_model.yaml is written)",
    )
    dia.add_argument("--out", required=True, help="output folder")
    dia.add_argument(
        "--aircraft-type",
        metavar="ICAO",
        help="Mode-S data: the aircraft's ICAO type designator (e.g. A310, B738, SF34), or jet / turboprop for a "
        "generic class; over a type the data name. Default: the data's type field, else a generic jet for a flight "
        "above Mach 0.65, else the simulation's SAAB 340B",
    )
    dia.add_argument(
        "--engine-type",
        metavar="ENGINES",
        help="Mode-S data: jet or turboprop (or an ICAO description such as L2J), the generic class for a type "
        "designator not listed",
    )
    dia.set_defaults(func=_cmd_diagnose)

    fits = sub.add_parser(
        "fits",
        help="the WAAS-aided FITS (FITS paper) on an approach log -> DIR/trajectory.csv",
        description="The WAAS-aided flight-inspection truth system (FITS paper) on an approach log "
        "(docs/data-formats.md). The log is checked first (units from the physics; with "
        "3 or more approaches, INS columns in the runway frame). Per approach it removes "
        "the 12-s cyclic WAAS noise through the INS (triangular zero-phase filter, eqs. "
        "7-17), compensates the WAAS bias jumps the receiver flags, fixes the bias at "
        "the threshold from radar altimeter and TVPS (eq. 18) and writes the trajectory "
        "(eq. 19) at the WAAS epochs and on an 8 Hz grid, the cyclic noise and the "
        "biases; with DGPS in the log, the errors against it and the requirement figure "
        "too.",
    )
    fits.add_argument("log", help="approach log (CSV, .csv.gz or Parquet, docs/data-formats.md)")
    fits.add_argument("--out", required=True, help="output folder")
    fits.add_argument(
        "--ra-lever-arm",
        type=spec_value(FitsSpec, "ra_lever_arm_m", "m"),
        default=0.0,
        help="height of the log's reference point above the radar-altimeter antenna (m)",
    )
    fits.add_argument(
        "--waas-latency",
        type=spec_value(FitsSpec, "waas_latency_s", "s"),
        default=0.0,
        help="seconds by which the log's WAAS positions are stamped late (what `aerotruth diagnose` "
        "finds as waas_latency); each epoch is put at its time minus this",
    )
    fits.add_argument(
        "--no-tvps-fix",
        action="store_true",
        help="leave the WAAS's cross-track bias (no TVPS fix at the threshold; the FITS paper's flight "
        "test): for logs whose TVPS readings are missing or not to be trusted",
    )
    fits.set_defaults(func=_cmd_fits)

    rea = sub.add_parser(
        "realism",
        help="the truth beside real flights: flight-profile statistics, simulated through Mode-S vs measured",
        description="Route legs and ILS approaches of the truth (from the truth store, flown if missing), "
        "passed through the Mode-S sensor and decoded to 1-s trajectories, beside measured flights "
        "(the files given, else every file of the real-data folder): climb and descent rates by "
        "altitude, roll and roll rate, cross-track wander on straight stretches, bank in turns, "
        "the approach path's straightness and angle. Prints `label: value` lines: p5/p50/p95 of "
        "each side, the Wasserstein-1 distance and the KS statistic (docs/commands.md).",
    )
    rea.add_argument("real", nargs="*", help="measured flight files (default: the real-data folder)")
    rea.add_argument("--legs", type=int, default=8, help="simulated route legs (default 8)")
    rea.add_argument("--approaches", type=int, default=12, help="simulated ILS approaches (default 12)")
    rea.add_argument("--turbulence", action="store_true", help="fly the simulated side in turbulence")
    rea.add_argument("--store", default=None, help="truth store folder (default: the user cache)")
    rea.add_argument("--figures", default=None, metavar="DIR", help="draw the distributions into DIR")
    rea.set_defaults(func=_cmd_realism)

    traffic = sub.add_parser(
        "reports",
        help="multi-aircraft Mode-S traffic (a decoded state table) -> an observation table with a consensus reference",
        description="Reads a decoded Mode-S / ADS-B state table of any number of aircraft (CSV, .csv.gz or Parquet; "
        "the traffic library's column names, or OpenSky's, matched case-insensitively), computes each sample's wind "
        "(ADS-B ground speed and track minus the BDS 5,0 TAS, horizontal, along the BDS 6,0 heading made true with "
        "the IGRF declination) and its reference: the consensus of the other aircraft within --radius-km, --layer-ft "
        "and --window-s, each with its own heading offset taken out. Writes the observation table that heading fit, "
        "heading apply and diagnose read (docs/data-formats.md).",
    )
    traffic.add_argument("traffic", help="decoded state table (CSV, .csv.gz or Parquet)")
    traffic.add_argument(
        "--reference",
        default="consensus",
        help="the reference winds: consensus (the other aircraft), or a gridded analysis file (NetCDF, or GRIB "
        "through cfgrib: u and v on time, pressure level, latitude and longitude, such as ERA5 pressure levels) "
        "interpolated to each report; its rows' ref_source is the file's stem",
    )
    traffic.add_argument("--out", required=True, help="observation table to write (.parquet, .csv or .csv.gz)")
    traffic.add_argument(
        "--radius-km",
        type=_positive_up_to(RADIUS_KM_MAX, "km", "half the Earth's circumference"),
        default=50.0,
        help="consensus radius (km, default 50)",
    )
    traffic.add_argument(
        "--layer-ft",
        type=_positive_up_to(LAYER_FT_MAX, "ft", "the span of pressure altitudes, -2,000 to 70,000 ft"),
        default=1000.0,
        help="consensus half-layer (ft, default 1000)",
    )
    traffic.add_argument(
        "--window-s",
        type=_positive_up_to(WINDOW_S_MAX, "s", "the span of the dates aerotruth models"),
        default=900.0,
        help="consensus half-window (s, default 900)",
    )
    traffic.set_defaults(func=_cmd_reports)

    heading = sub.add_parser(
        "heading",
        help="the wind paper's heading-deviation method on your own reports",
        description="The wind paper's heading-deviation method on your own aircraft reports: "
        "`fit` learns each aircraft's deviation and 8-point table from an observation "
        "table, `apply` corrects the reports of another period with those tables.",
    )
    hsub = heading.add_subparsers(dest="heading_command", required=True)
    hfit = hsub.add_parser(
        "fit",
        help="fit eq. 2 per aircraft from an observation table -> DIR/deviation.csv, figures, report",
        description="The wind paper's method on an observation table (aircraft wind reports with "
        "reference-model winds, docs/data-formats.md): ground tracks from three "
        "adjacent reports, the heading error against each reference model (eqs. 3-4), a "
        "robust flight-clustered fit of eq. 2 per aircraft (D, E only when a Wald test "
        "keeps them; the offset alone when the headings cannot identify the sinusoid) "
        "and its 8-point table. Writes DIR/deviation.csv (and deviation_mag.csv, fitted "
        "on magnetic heading, when the table has heading_mag_deg or declination_deg), "
        "flight-bootstrap intervals in deviation_ci.csv, a figure per aircraft and "
        "DIR/report.md.",
    )
    hfit.add_argument("obs", help="observation table (CSV, .csv.gz or Parquet, docs/data-formats.md)")
    hfit.add_argument("--out", required=True, help="output folder")
    hfit.add_argument(
        "--bootstrap",
        type=_integer,
        default=200,
        metavar="N",
        help="cluster (flight or time-block) resamples for the 95 %% intervals of A..E and the table entries "
        "(deviation_ci.csv; default 200, 0: none; ~20 s per million rows and heading frame at 200)",
    )
    hfit.add_argument("--seed", type=_integer, default=0, help="seed of the bootstrap's resampling (default 0)")
    hfit.add_argument(
        "--min-reports",
        type=_integer,
        default=30,
        metavar="N",
        help="usable reports an aircraft needs for a table (default 30)",
    )
    hfit.add_argument(
        "--min-clusters",
        type=_integer,
        default=None,
        metavar="N",
        help="clusters (flights or time blocks, see --cluster-s) an aircraft needs (default 5 flights, "
        "or 2 blocks for dense reports; at least 2)",
    )
    hfit.add_argument(
        "--cluster-s",
        type=float,
        default=None,
        metavar="S",
        help="cut each flight into time blocks of at most S seconds as the clusters of the standard errors "
        "and bootstrap, 0: whole flights (default: 300 where the median report interval is under 60 s, "
        "as in Mode-S traffic; else whole flights)",
    )
    hfit.add_argument(
        "--position-step-deg",
        type=float,
        default=None,
        metavar="DEG",
        help="the reports' lat/lon resolution for the ground-track gates (default: read off the values, "
        "e.g. 0.01 for TAMDAR, 0 for decoded Mode-S positions)",
    )
    hfit.add_argument(
        "--max-sinusoid-se-deg",
        type=float,
        default=1.0,
        metavar="DEG",
        help="a sinusoid whose standard error exceeds this is not uploaded: offset only (default 1.0)",
    )
    hfit.set_defaults(func=_cmd_heading_fit)
    happ = hsub.add_parser(
        "apply",
        help="apply the tables of `heading fit` to the reports of another period -> "
        "DIR/corrected.*, apply.csv (before/after per aircraft), figure, report",
        description="Apply the tables `aerotruth heading fit` learned to the reports of another "
        "period, as the onboard table would have corrected them (eq. 1 with the air "
        "vector turned by the table's correction; nothing is refitted). The reports "
        "must not be corrected onboard already. Writes DIR/corrected.csv (or .parquet, "
        "as the input) with each row's correction and corrected wind, DIR/apply.csv "
        "(per aircraft the wind error against the references before and after: RMS, "
        "longitudinal, transverse; in_sample where the reports' times overlap the fit's data), a "
        "before/after figure and DIR/report.md.",
    )
    happ.add_argument("obs", help="observation table (CSV, .csv.gz or Parquet, docs/data-formats.md)")
    happ.add_argument(
        "--tables", required=True, help="the deviation.csv (or deviation_mag.csv) of `aerotruth heading fit`"
    )
    happ.add_argument("--out", required=True, help="output folder")
    happ.set_defaults(func=_cmd_heading_apply)
    _every_parser_one_line(p)
    return p


def _every_parser_one_line(parser: argparse.ArgumentParser) -> None:
    """The command and each of its subcommands print usage errors as one line (_one_line_errors)."""
    _one_line_errors(parser)
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub in action.choices.values():
                _every_parser_one_line(sub)


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except UserError as e:  # one line, whatever the message quotes (a reader's multi-line text)
        print(f"aerotruth {args.command}: {' '.join(str(e).split())}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("interrupted", file=sys.stderr)
        return 130


if __name__ == "__main__":
    sys.exit(main())
