"""``demcal export``: write a calibrated campaign's material card."""

from __future__ import annotations

import argparse
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
                        help="write to FILE, replacing it whole (default: standard output)")
    parser.add_argument("--allow-outside", action="store_true",
                        help="accept campaign paths (workdir, lab, photos, tables) outside the campaign "
                             "file's folder")


def run(args: argparse.Namespace) -> int:
    from demcal.export.text import or_list

    if args.format not in FORMAT_NAMES:
        raise ConfigError(f"unknown export format '{args.format}'; choose {or_list(FORMAT_NAMES)}.")
    if args.output is not None and args.output.is_dir():
        raise ConfigError(f"--out {args.output} is a folder; give a file path.")
    text = export(args.campaign, args.format, args.condition, allow_outside=args.allow_outside)
    if args.output is None:
        print(text, end="")
    else:
        from demcal._files import write_atomic

        if args.output.parent != Path("") and not args.output.parent.is_dir():
            args.output.parent.mkdir(parents=True, exist_ok=True)
        write_atomic(args.output, text)
        print(f"{args.format} card: {args.output}")
    return 0


def export(campaign_path: Path, format: str = "json", conditions: list[str] | None = None, *,
           allow_outside: bool = False) -> str:
    """The material card of the campaign file ``campaign_path`` in ``format``."""
    from demcal.campaign.chain import read_calibration
    from demcal.campaign.config import load_campaign
    from demcal.export import formatter
    from demcal.export.card import build_card

    campaign = load_campaign(campaign_path, allow_outside=allow_outside)
    calibration, path, digest = read_calibration(campaign)
    profile = calibration.get("profile")
    if isinstance(profile, str) and profile != campaign.profile:
        campaign = campaign.with_profile(profile)  # the profile the values were calibrated at
    card = build_card(campaign, calibration, conditions, {"path": str(path), "sha256": digest})
    return formatter(format)(card)
