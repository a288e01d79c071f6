"""``demcal design``: write a design table (CSV) with actual factor levels."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from demcal._cliutil import add_command, read_runs_from_args
from demcal.errors import ConfigError

if TYPE_CHECKING:
    from demcal.doe.design import Design

KINDS = ("box-behnken", "ccd", "factorial", "fractional", "plackett-burman", "steepest-ascent")


def register(subparsers) -> None:
    p = add_command(
        subparsers, "design", run,
        help="generate a design of experiments (Box-Behnken, CCD, factorial, ...)",
        description="Generate a design of experiments and write it as CSV (actual levels, "
        "randomised run order, factor levels in '# factor' comment lines).",
    )
    p.add_argument("kind", choices=KINDS, help="design type")
    p.add_argument("runs_csv", nargs="?", help="steepest-ascent only: runs of a first-order design")
    p.add_argument("--factor", action="append", default=[], metavar="NAME=LOW:HIGH[units]",
                   help="a factor and its actual low/high levels (repeat per factor)")
    p.add_argument("-k", "--n-factors", type=int, help="number of factors when no --factor is given "
                   "(named A, B, C, ... in coded units)")
    p.add_argument("--center", type=int, default=None,
                   help="centre points (default: 5 for Box-Behnken, 6 for CCD, 0 otherwise)")
    p.add_argument("--seed", type=int, default=None,
                   help="randomise the run order with this seed (default: standard order)")
    p.add_argument("--coded", action="store_true", help="write coded levels instead of actual ones")
    p.add_argument("--ccd-type", default="circumscribed",
                   choices=["circumscribed", "inscribed", "face-centred"], help="CCD type")
    p.add_argument("--alpha", default="rotatable",
                   help="CCD axial distance: rotatable, orthogonal or a number")
    p.add_argument("--levels", type=int, default=2, help="factorial: levels per factor")
    p.add_argument("--fraction", type=int, default=None, help="fractional: p of 2^(k-p)")
    p.add_argument("--generators", default=None, help="fractional: e.g. D=ABC,E=ABD")
    p.add_argument("--runs", type=int, default=None, help="Plackett-Burman: 8, 12, 16, 20 or 24 runs")
    p.add_argument("--response", help="steepest-ascent: response column")
    p.add_argument("--step", type=float, default=1.0, help="steepest-ascent: base step [coded]")
    p.add_argument("--steps", type=int, default=5, help="steepest-ascent: number of steps")
    p.add_argument("--descent", action="store_true", help="steepest-ascent: go downhill")
    p.add_argument("-o", "--output", help="CSV file to write (default: standard output)")


def _factors(args):
    from demcal.doe.factors import coded_factors, default_names, parse_factor

    if args.factor:
        factors = [parse_factor(s) for s in args.factor]
        if args.n_factors and args.n_factors != len(factors):
            raise ConfigError(f"-k {args.n_factors} disagrees with the {len(factors)} --factor options.")
        return factors
    if not args.n_factors:
        raise ConfigError("name the factors with --factor NAME=LOW:HIGH (or give -k N for coded factors).")
    return coded_factors(default_names(args.n_factors))


def build_design(args) -> Design:
    """The :class:`Design` described by parsed ``demcal design`` arguments."""
    import numpy as np

    from demcal.doe.design import Design
    from demcal.doe.designs import (
        box_behnken, central_composite, fractional_factorial, full_factorial, plackett_burman,
    )

    if args.kind == "steepest-ascent":
        return _steepest(args)
    factors = _factors(args)
    k = len(factors)
    if args.kind == "box-behnken":
        coded = box_behnken(k, 5 if args.center is None else args.center)
    elif args.kind == "ccd":
        try:
            alpha = float(args.alpha)
        except ValueError:
            alpha = args.alpha
        coded = central_composite(k, args.ccd_type, alpha, 6 if args.center is None else args.center)
    elif args.kind == "factorial":
        coded = full_factorial([args.levels] * k)
        coded = np.vstack([coded, np.zeros((args.center or 0, k))])
    elif args.kind == "fractional":
        gens = args.generators.split(",") if args.generators else None
        coded = fractional_factorial(k, args.fraction, gens)
        coded = np.vstack([coded, np.zeros((args.center or 0, k))])
    else:  # plackett-burman
        coded = plackett_burman(k, args.runs)
        coded = np.vstack([coded, np.zeros((args.center or 0, k))])
    return Design(args.kind, tuple(factors), coded).randomized(args.seed)


def _steepest(args) -> Design:
    from demcal.doe.design import Design
    from demcal.doe.designs import steepest_ascent
    from demcal.rsm.fit import fit_response_surface

    if not args.runs_csv or not args.response:
        raise ConfigError("steepest-ascent needs the runs CSV of a first-order design and --response.")
    runs = read_runs_from_args(args, [args.response])
    model = fit_response_surface(runs.coded, runs.responses[args.response], runs.factors, "linear",
                                 args.response)
    b = model.coef[1:]
    path = steepest_ascent(b, args.step, args.steps, descent=args.descent)
    return Design("steepest-ascent", runs.factors, path)


def run(args) -> int:
    from demcal.doe.io import write_design_csv

    design = build_design(args)
    if args.output:
        write_design_csv(design, args.output, coded=args.coded)
        print(f"wrote {design.coded.shape[0]} runs of a {design.kind} design in "
              f"{len(design.factors)} factors to {args.output}", file=sys.stderr)
    else:
        sys.stdout.write(design.to_frame(coded=args.coded).to_csv(index=False, float_format="%.10g"))
    return 0
