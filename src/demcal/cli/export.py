"""``demcal export``: write a calibrated campaign's material card."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from demcal.cli._util import add_command
from demcal.errors import ConfigError

FORMAT_NAMES = ("json", "liggghts", "edem")


def register(subparsers) -> None:
    parser = add_command(
        subparsers, "export", run,
        help="write the calibrated material card: JSON, a LIGGGHTS snippet or EDEM's tables",
        description="Write the material card of a calibrated campaign: the full parameter set of "
                    "each condition with the lab record, the campaign's hash and the verification "
                    "figures, as JSON, as a block for a LIGGGHTS 3.8 input script, or as the "
                    "material and interaction tables of EDEM Creator. Each format names the contact "
                    "and rolling models the values assume in that code and says when they do not "
                    "carry over. Run `demcal calibrate CAMPAIGN` first.")
    parser.add_argument("campaign", type=Path, help="campaign file (TOML)")
    parser.add_argument("--format", default="json", metavar="FORMAT",
                        help="json (default), liggghts or edem")
    parser.add_argument("--condition", action="append", metavar="NAME",
                        help="export this condition only (repeat for several; default: every "
                             "calibrated condition)")
    parser.add_argument("-o", "--out", dest="output", type=Path, metavar="FILE",
                        help="write to FILE (default: standard output); an existing FILE is replaced whole "
                             "only when it is a material card demcal wrote, and never when it is one of the "
                             "campaign's inputs (its file, lab file, photos, store, runs, calibration)")
    parser.add_argument("--force", action="store_true",
                        help="replace an existing FILE that is not a card demcal wrote (never an input)")
    parser.add_argument("--allow-outside", action="store_true",
                        help="accept campaign paths (workdir, lab, photos, tables) outside the campaign "
                             "file's folder")


def run(args: argparse.Namespace) -> int:
    """Write the card, then say each of its warnings on stderr (exit status 0 all the same)."""
    from demcal.export import formatter
    from demcal.export.text import or_list

    if args.format not in FORMAT_NAMES:
        raise ConfigError(f"unknown export format '{args.format}'; choose {or_list(FORMAT_NAMES)}.")
    card = material_card(args.campaign, args.format, args.condition, allow_outside=args.allow_outside,
                         output=args.output, force=args.force)
    text = formatter(args.format)(card)
    if args.output is None:
        print(text, end="", flush=True)
    else:
        from demcal._files import write_atomic

        if args.output.parent != Path("") and not args.output.parent.is_dir():
            args.output.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(args.output, text)
        print(f"{args.format} card: {args.output}", flush=True)
    for warning in card["warnings"]:
        print(f"demcal: warning: {warning}", file=sys.stderr)
    return 0


def export(campaign_path: Path, format: str = "json", conditions: list[str] | None = None, *,
           allow_outside: bool = False, output: Path | None = None, force: bool = False) -> str:
    """The material card of the campaign file ``campaign_path`` in ``format``
    (:func:`material_card`, formatted)."""
    from demcal.export import formatter

    return formatter(format)(material_card(campaign_path, format, conditions, allow_outside=allow_outside,
                                           output=output, force=force))


def material_card(campaign_path: Path, format: str = "json", conditions: list[str] | None = None, *,
                  allow_outside: bool = False, output: Path | None = None, force: bool = False) -> dict:
    """The material card of the campaign file ``campaign_path``, its warnings for ``format``.

    ``output``, where the card will be written, is checked first
    (:func:`demcal._files.check_output` against the campaign's inputs); a calibration
    whose campaign hash is not the campaign file's any more is refused."""
    from demcal._files import check_output
    from demcal.campaign.chain import read_calibration
    from demcal.campaign.config import load_campaign
    from demcal.campaign.files import campaign_inputs
    from demcal.export.card import build_card

    campaign = load_campaign(campaign_path, allow_outside=allow_outside)
    if output is not None:
        check_output(output, "card", inputs=campaign_inputs(campaign), force=force, option="--out")
    calibration, path, digest = read_calibration(campaign)
    profile = calibration.get("profile")
    if isinstance(profile, str) and profile != campaign.profile:
        campaign = campaign.with_profile(profile)  # the profile the values were calibrated at
    _refuse_stale(campaign, calibration, path)
    return build_card(campaign, calibration, conditions, {"path": str(path), "sha256": digest},
                      code=None if format == "json" else format)


def _refuse_stale(campaign, calibration: dict, path: Path) -> None:
    """One sentence when calibration.json was calibrated from another campaign than the
    file says now (:func:`demcal.campaign.digest.calibrated_from`); a calibration.json
    without a hash is left to the card's warnings."""
    from demcal.campaign.digest import calibrated_from

    if calibrated_from(campaign, calibration) is False:
        raise ConfigError(f"{campaign.path} changed since {path} was written (factors, targets, settings or the "
                          "values it takes from another campaign differ), so its values are not this campaign's "
                          f"calibration; run `demcal calibrate {campaign.path}` again, then export.")
