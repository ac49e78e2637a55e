"""The campaign subcommands of `aerotruth` (run, validate, figures, report, regress).
Expected problems (bad YAML, wrong run directory, bad baseline, failed task) are
aerotruth.errors.UserError subclasses, printed by the command line as one line."""

from __future__ import annotations

import argparse
import signal
import sys

from aerotruth.sim.campaign_file import ConfigError
from aerotruth.sim.campaign_loader import load_campaign

PAUSED_EXIT = 3  # `aerotruth run --stop-after`: stopped at its time limit, the same command goes on


def _terminate(signum: int, frame: object) -> None:
    raise SystemExit(128 + signum)


def _err(msg: str) -> None:
    print(msg, file=sys.stderr)


def run_cli(args: argparse.Namespace) -> int:
    """aerotruth run CAMPAIGN.yaml [--size NAME] [--out DIR] [--force] [--workers N] [--executor local|dask]
    [--scheduler ADDR]

    Everything the user gave is checked before anything is written: the campaign, the
    executor, and the run folder (sim.store.check_out_folder: a non-empty folder that is not
    a run folder is refused; --force writes beside its files when none has a run's name)."""
    from aerotruth.sim.campaign import RunPaused, default_run_dir, run_campaign
    from aerotruth.sim.executors import resolve
    from aerotruth.sim.store import check_out_folder

    campaign = load_campaign(args.campaign, size=args.size)
    ex = campaign.executor
    # SIGTERM (e.g. a batch system's kill) unwinds like Ctrl-C: the executor stops its
    # workers instead of leaving them orphaned; finished tasks stay stored for a resume.
    choice = resolve(
        ex.kind, ex.workers, ex.scheduler, kind=args.executor, workers=args.workers, scheduler=args.scheduler
    )
    where = "--out" if args.out is not None else "outputs.dir" if campaign.outputs.dir else "run folder"
    out = check_out_folder(
        args.out if args.out is not None else default_run_dir(campaign),
        force=getattr(args, "force", False),
        option=where,
    )
    previous = signal.signal(signal.SIGTERM, _terminate)
    stop_after = getattr(args, "stop_after", None)
    try:
        summary = run_campaign(
            campaign,
            choice,
            out=out,
            progress=not args.quiet,
            log=_err,
            stop_after_s=None if stop_after is None else stop_after * 3600.0,
        )
    except ConfigError as e:
        raise ConfigError(f"{args.campaign}: {e}") from None
    except RunPaused as e:
        _err(f"{campaign.name}: {e} (--stop-after {stop_after:g})")
        return PAUSED_EXIT
    finally:
        signal.signal(signal.SIGTERM, previous)
    _err(
        f"{campaign.name}: {summary.n_tasks} tasks ({summary.reused} reused, {summary.ran} run, "
        f"{summary.legs_flown} legs flown) in {summary.seconds:.1f} s"
    )
    outputs = campaign.outputs
    if outputs.report and not args.no_report:
        from aerotruth.app.report import write_report

        _err(f"report: {write_report(summary.run_dir)}")
    elif outputs.figures and not args.no_report:
        from aerotruth.app.figures import make_figures

        make_figures(summary.run_dir)
    print(summary.run_dir / "metrics.json")
    return 0


def validate_cli(args: argparse.Namespace) -> int:
    """aerotruth validate CAMPAIGN.yaml: check the schema and expand the tasks."""
    from aerotruth.sim.campaign import expand

    campaign = load_campaign(args.campaign, size=args.size)
    try:
        tasks = expand(campaign)
    except ConfigError as e:
        raise ConfigError(f"{args.campaign}: {e}") from None
    counts = ", ".join(f"{s} {sum(t.study == s for t in tasks)}" for s in campaign.studies)
    print(
        f"{args.campaign}: ok, campaign {campaign.name}, {len(tasks)} tasks ({counts}), "
        f"config hash {campaign.config_hash()[:12]}"
    )
    return 0


def figures_cli(args: argparse.Namespace) -> int:
    """aerotruth figures RUN_DIR"""
    from aerotruth.app.figures import make_figures

    figs = make_figures(args.run_dir)
    for _study, items in figs.items():
        for f in items:
            print(f"{args.run_dir}/figures/{f.stem}.png")
    return 0


def report_cli(args: argparse.Namespace) -> int:
    """aerotruth report RUN_DIR"""
    from aerotruth.app.report import write_report

    print(write_report(args.run_dir))
    return 0


def regress_cli(args: argparse.Namespace) -> int:
    """aerotruth regress RUN_DIR BASELINE.json: exit 1 and a table when a metric moved."""
    from aerotruth.app.regress import format_checks, regress, write_baseline

    if args.write:
        n = write_baseline(args.run_dir, args.baseline, abs_tol=args.abs_tol, rel_tol=args.rel_tol)
        print(f"wrote {args.baseline}: {n} metrics (abs {args.abs_tol}, rel {args.rel_tol})")
        return 0
    checks = regress(args.run_dir, args.baseline)
    bad = [c for c in checks if not c.ok]
    if bad or args.all:
        print(format_checks(checks, only_failures=not args.all))
    print(
        f"{len(checks) - len(bad)} of {len(checks)} metrics within tolerance" + (f", {len(bad)} moved" if bad else "")
    )
    return 1 if bad else 0
