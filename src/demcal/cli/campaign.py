"""``demcal run | calibrate | report | demo``: campaigns from the command line."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from demcal.cli._util import add_command


def register(subparsers) -> None:
    for name, func, help, description, retry_help in (
        ("run", _run, "simulate every design point of a campaign (resumable, parallel)",
         "Simulate every design point of a campaign file. Finished runs are kept in the "
         "campaign's store and skipped when run again; failed runs are retried only with "
         "--retry-failed.", "run failed points again"),
        ("calibrate", _calibrate, "close the loop: fit, solve, move the box, verify at the production profile",
         "Fit the response model to the design results and, for each condition's lab target, "
         "move the design box along the path of steepest ascent when the target lies outside it, "
         "solve, and simulate the chosen parameters at the production profile until the mean lies "
         "inside the lab's spread with a 95 % interval narrower than the lab sd (or the budget is "
         "spent); resumable like run.",
         "run failed verification runs again"),
    ):
        parser = add_command(subparsers, name, func, help, description)
        _common(parser)
        _execution(parser)
        parser.add_argument("--retry-failed", action="store_true", help=retry_help)
        if name == "calibrate":
            parser.add_argument("--production", metavar="PROFILE",
                                help="verify at this profile (default: the file's [calibration] production, "
                                     "else the design's profile); designs run at --profile")

    report = add_command(
        subparsers, "report", _report,
        help="write the campaign's HTML report and its tables (CSV, JSON)",
        description="Write one self-contained HTML report with every table and figure, plus CSV "
                    "and JSON of each table, into the campaign's work folder.")
    _common(report, profile_help="report the runs of this bench profile: tiny, quick, paper or a test's own "
                                 "(the incline's medium) "
                                 "(default: the campaign file's [experiment] profile, quick if it names "
                                 "none); nothing is run")
    report.add_argument("--out", type=Path, help="report folder (default: WORKDIR/report)")

    demo = add_command(
        subparsers, "demo", _demo,
        help="run the paper's two example campaigns end to end and print the report path",
        description="Copy the residual-film-soil example campaigns into OUT, run them, calibrate "
                    "them and write the report.")
    demo.add_argument("--out", type=Path, default=Path("demo-output"), help="output folder (default: demo-output)")
    demo.add_argument("--profile", default="quick", help="bench profile: tiny, quick (default) or paper")
    _execution(demo, scheduler=False)


def _common(parser: argparse.ArgumentParser,
            profile_help: str = "bench profile: tiny, quick, paper or a test's own (the incline's medium) "
                                "(default: the campaign file's "
                                "[experiment] profile, quick if it names none)") -> None:
    parser.add_argument("campaign", type=Path, help="campaign file (TOML)")
    parser.add_argument("--profile", help=profile_help)
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--allow-outside", action="store_true",
                        help="accept a workdir, lab file, photos or reference_table outside the campaign "
                             "file's folder (refused by default)")


def _execution(parser: argparse.ArgumentParser, scheduler: bool = True) -> None:
    parser.add_argument("--workers", type=int, metavar="N",
                        help="worker processes, 0 for one per core (default: the file's [executor] workers, "
                             "else one per core)")
    if scheduler:
        parser.add_argument("--scheduler", metavar="ADDRESS",
                            help="run on the Dask cluster of this scheduler, e.g. tcp://host:8786 "
                                 "(default: the file's [executor] scheduler); its workers need a shared "
                                 "file system that holds the campaign folder at the same path, and "
                                 "--workers is ignored (the cluster's worker threads count)")


def _load(args, simulate: bool):
    """The campaign file of ``args``; the plugins it names are imported only by commands
    that run simulations (``simulate``), never by ``report``."""
    from demcal.campaign.config import load_campaign

    scheduler = getattr(args, "scheduler", None)
    if scheduler is not None:  # before anything is read or set up
        from demcal.campaign.executors import check_scheduler_address

        check_scheduler_address(scheduler)
    campaign = load_campaign(args.campaign, import_plugins=simulate, allow_outside=args.allow_outside)
    if args.profile:
        campaign = campaign.with_profile(args.profile)
    return campaign


def _run(args) -> int:
    from demcal.campaign.runner import run_campaign

    campaign = _load(args, simulate=True)
    summary = run_campaign(campaign, workers=args.workers, scheduler=args.scheduler,
                           retry_failed=args.retry_failed, progress=not args.quiet)
    for label, error in summary.failures[:10]:
        print(f"  {label}: {error}", file=sys.stderr)
    print(summary.sentence(campaign.name))
    print(f"Results: {campaign.store_path}")
    # Runs still in another runner's hands are that runner's to finish.
    return 1 if summary.failed or summary.done + summary.elsewhere < summary.total else 0


def _calibrate(args) -> int:
    from demcal.campaign.calibrate import calibrate, describe

    campaign = _load(args, simulate=True)
    if args.production:  # one sentence if it does not exist or does not suit the campaign
        campaign = campaign.with_production(args.production)
    calibration = calibrate(campaign, workers=args.workers, scheduler=args.scheduler, progress=not args.quiet,
                            retry_failed=args.retry_failed)
    print(describe(calibration))
    return 0


def _report(args) -> int:
    from demcal.report.campaign_report import write_report

    campaign = _load(args, simulate=False)
    campaign, replayed = _as_calibrated(campaign, profile_given=args.profile is not None)
    path = write_report(campaign, out=args.out)
    print(f"Report: {path}" + (f" (replayed with the options calibrate ran with: {replayed})" if replayed else ""))
    return 0


def _as_calibrated(campaign, profile_given: bool):
    """The campaign with the design and production profiles its calibration.json records
    (:func:`demcal.campaign.digest.as_calibrated`), so that the report shows what
    ``calibrate`` said, unless ``--profile`` asks for another design profile or the
    campaign file changed since; and the words that say so ("" when nothing changed)."""
    from demcal.campaign.chain import read_calibration
    from demcal.campaign.digest import as_calibrated, calibrated_from
    from demcal.errors import DataError

    try:
        saved, _, _ = read_calibration(campaign)
    except DataError:  # none yet, or unreadable: the report says so itself
        return campaign, ""
    if calibrated_from(campaign, saved) is False or (profile_given and saved.get("profile") != campaign.profile):
        return campaign, ""
    replayed = as_calibrated(campaign, saved)
    said = [f"designs at {replayed.profile}"] if replayed.profile != campaign.profile else []
    if replayed.calibration.production != campaign.calibration.production:
        said.append(f"verification at {replayed.calibration.production}")
    return replayed, ", ".join(said)


def _demo(args) -> int:
    from demcal.cli.demo import run_demo

    path = run_demo(args.out, profile=args.profile, workers=args.workers)
    print(f"Report: {path}")
    return 0
