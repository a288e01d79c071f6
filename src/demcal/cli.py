"""The ``demcal`` command line.

Each subsystem registers its own sub-commands: a module listed in
:data:`COMMAND_MODULES` exposes ``register(subparsers)``, which adds its parsers
and sets ``func`` on each (``func(args) -> int`` exit status). Errors of type
:class:`demcal.errors.DemcalError` are printed as one sentence, exit status 2.
"""

from __future__ import annotations

import argparse
import importlib
import sys

from demcal import __version__
from demcal.errors import DemcalError

#: Modules that contribute sub-commands, in the order they appear in ``--help``.
COMMAND_MODULES = (
    "demcal.doe.commands",  # design
    "demcal.rsm.commands",  # analyze
    "demcal.optimize.commands",  # optimize
    "demcal.measure.commands",  # measure repose|incline
    "demcal.bench.commands",  # bench NAME
    "demcal.campaign.commands",  # run, calibrate, report, demo
)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="demcal",
        description="Calibrate DEM contact parameters of granular materials from bench tests.",
    )
    parser.add_argument("--version", action="version", version=f"demcal {__version__}")
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name in COMMAND_MODULES:
        try:
            module = importlib.import_module(name)
        except ModuleNotFoundError as exc:  # a subsystem not built yet
            if exc.name and name.startswith(exc.name):
                continue
            raise
        module.register(subparsers)
    return parser


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    if not getattr(args, "func", None):
        parser.print_help()
        return 1
    try:
        return int(args.func(args) or 0)
    except DemcalError as exc:
        print(f"demcal: error: {exc}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("demcal: interrupted; finished results are kept.", file=sys.stderr)
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
