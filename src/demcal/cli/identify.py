"""``demcal identify``: whether a campaign's responses can pin its factors, before the design."""

from __future__ import annotations

import sys
from pathlib import Path

from demcal.cli._util import add_command, add_json


def register(subparsers) -> None:
    parser = add_command(
        subparsers, "identify", _identify,
        help="screen a campaign's factors cheaply: which parameters its responses can pin",
        description="Run a cheap two-level screen over the campaign's factors (Plackett-Burman by default) "
                    "at a cheap profile, each point with several seeds, through the campaign's store "
                    "(cached and resumable, as demcal run). Print per factor and response the main effect "
                    "(half the high-minus-low difference) with its standard error from the seed noise, its "
                    "t-ratio and whether it moves the response beyond that noise; the scaled sensitivity "
                    "matrix's singular values and condition number; the parameters no response can pin, "
                    "the combinations the responses cannot tell apart, and the benches declared to read "
                    "them. The whole result goes to identify.json in the campaign's work folder.")
    parser.add_argument("campaign", type=Path, help="campaign file (TOML)")
    parser.add_argument("--profile",
                        help="bench profile of the screen (default: tiny where the test has it, else the "
                             "campaign file's [experiment] profile)")
    parser.add_argument("--design", default="plackett-burman",
                        help="plackett-burman (default) or fractional-factorial (the smallest standard "
                             "two-level fraction with more points than factors)")
    parser.add_argument("--runs", type=int, metavar="N",
                        help="design points: 8, 12, 16, 20 or 24 for Plackett-Burman, a power of 2 for a "
                             "fraction (default: the smallest that fits)")
    parser.add_argument("--replicates", type=int, default=2, metavar="N",
                        help="seeds per point, 2 or more: their spread is the seed noise (default: %(default)s)")
    parser.add_argument("--condition", metavar="NAME",
                        help="screen with this condition's own fixed settings, where conditions fix settings "
                             "of their own (default: the first condition's)")
    add_json(parser, help="print the whole result as one JSON object (as identify.json holds it)")
    parser.add_argument("--quiet", action="store_true", help="no progress bar")
    parser.add_argument("--retry-failed", action="store_true", help="run failed screening runs again")
    parser.add_argument("--allow-outside", action="store_true",
                        help="accept a workdir or lab file outside the campaign file's folder (refused by default)")
    parser.add_argument("--workers", type=int, metavar="N",
                        help="worker processes, 0 for one per core (default: the file's [executor] workers, "
                             "else one per core)")
    parser.add_argument("--scheduler", metavar="ADDRESS",
                        help="run on the Dask cluster of this scheduler, e.g. tcp://host:8786 (default: the "
                             "file's [executor] scheduler)")


def _identify(args) -> int:
    import json

    from demcal.campaign.config import load_campaign
    from demcal.campaign.identify import describe, identify, to_dict

    if args.scheduler is not None:
        from demcal.campaign.executors import check_scheduler_address

        check_scheduler_address(args.scheduler)
    campaign = load_campaign(args.campaign, import_plugins=True, allow_outside=args.allow_outside)
    result = identify(campaign, profile=args.profile, design=args.design, runs=args.runs,
                      replicates=args.replicates, condition=args.condition, workers=args.workers,
                      scheduler=args.scheduler, retry_failed=args.retry_failed, progress=not args.quiet)
    if result.analysis is None:
        for label, error in result.summary.failures[:10]:
            print(f"  {label}: {error}", file=sys.stderr)
        print(result.summary.sentence(campaign.name), file=sys.stderr)
        print("demcal: the screen is not complete, so nothing is analysed yet; run it again "
              "(with --retry-failed for failed runs).", file=sys.stderr)
        return 1
    print(json.dumps(to_dict(result), indent=1) if args.json else describe(result))
    return 0
