"""Pieces shared by the sub-command modules of :mod:`demcal.cli`.

A module listed in :data:`demcal.cli.COMMAND_MODULES` imports only this module,
``argparse`` and :mod:`demcal.errors` at its top, so that ``demcal --help`` and the
light commands start in a fraction of a second; numpy, scipy, pandas and the rest are
imported inside the function that runs a command.
"""

from __future__ import annotations

import argparse


def add_command(subparsers, name: str, func, help: str, description: str,
                **kwargs) -> argparse.ArgumentParser:
    """A sub-command parser that runs ``func(args) -> int``."""
    parser = subparsers.add_parser(name, help=help, description=description, **kwargs)
    parser.set_defaults(func=func)
    return parser


def add_json(parser: argparse.ArgumentParser, help: str = "print one JSON object") -> None:
    parser.add_argument("--json", action="store_true", help=help)


def add_runs_command(subparsers, name: str, func, help: str,
                     description: str) -> argparse.ArgumentParser:
    """A sub-command that reads a runs CSV (its first argument, ``runs_csv``)."""
    parser = add_command(subparsers, name, func, help, description)
    parser.add_argument("runs_csv", help="CSV with one row per run")
    return parser


def add_model_options(parser: argparse.ArgumentParser, factors_help: str, factor_help: str,
                      reduce_help: str) -> None:
    """``--factors``, ``--factor``, ``--model`` and ``--reduce`` of the commands that
    fit response surfaces to a runs CSV (``analyze``, ``optimize``)."""
    parser.add_argument("--factors", help=factors_help)
    parser.add_argument("--factor", action="append", default=[], metavar="NAME=LOW:HIGH",
                        help=factor_help)
    parser.add_argument("--model", default="quadratic",
                        help="linear, 2fi, quadratic or cubic (default: %(default)s)")
    parser.add_argument("--reduce", type=float, default=None, metavar="ALPHA", help=reduce_help)


def read_runs_from_args(args, responses: list[str]):
    """The runs CSV ``args.runs_csv`` coded with the ``--factor`` levels, restricted to
    the ``--factors`` columns where that option exists and is given; a response with
    the same value in every run is refused."""
    from demcal.doe.factors import parse_factor
    from demcal.rsm.data import read_runs

    from demcal.errors import DataError

    factors = getattr(args, "factors", None)
    names = [s.strip() for s in factors.split(",") if s.strip()] if factors else None
    levels = {f.name: f for f in (parse_factor(s) for s in args.factor)}
    runs = read_runs(args.runs_csv, responses, names, levels)
    for name in responses:  # nothing to fit: one sentence rather than NaN statistics or a division by zero
        y = runs.responses[name]
        if y.size and y.min() == y.max():
            raise DataError(f"response {name!r} of {args.runs_csv} has the same value ({y[0]:g}) in all "
                            f"{y.size} runs, so there is no surface to fit; check that column.")
    return runs
