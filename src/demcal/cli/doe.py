"""``demcal design``: write a design table (CSV) with actual factor levels."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

from demcal._checks import and_list
from demcal.cli._util import add_command, read_runs_from_args
from demcal.doe.catalog import DESIGN_KINDS, DESIGN_NAMES, OPTION_NAMES, design_kind, kind_label, takers
from demcal.errors import ConfigError

if TYPE_CHECKING:
    from demcal.doe.design import Design

#: The design kinds as ``demcal design --help`` lists them; every spelling of
#: :data:`demcal.doe.catalog.DESIGN_NAMES` is accepted as well.
SHOWN_KINDS = ("box-behnken", "ccd", "factorial", "fractional", "plackett-burman", "steepest-ascent")

#: Every kind the command takes: the catalogue's spellings, and paths of steepest ascent
#: (which follow a fitted model, so they are not in the catalogue).
KINDS = (*DESIGN_KINDS, "steepest-ascent")

_BUILT = tuple(DESIGN_NAMES)
_PATH = ("steepest-ascent",)

#: Options that only some design kinds take: (attribute, option as typed, kinds by the
#: catalogue's names). An attribute named like an option of
#: :data:`demcal.doe.catalog.DESIGN_OPTIONS` is passed to
#: :func:`~demcal.doe.catalog.design_matrix` under that name. Their defaults are None
#: (False for flags), so that an option given to a design kind that does not use it is
#: refused instead of silently ignored.
KIND_OPTIONS = (
    ("runs_csv", "a runs CSV", _PATH),
    ("n_factors", "-k", _BUILT),
    ("center", "--center", takers("center")),
    ("seed", "--seed", _BUILT),
    ("variant", "--ccd-type (--variant)", takers("variant")),
    ("alpha", "--alpha", takers("alpha")),
    ("levels", "--levels", takers("levels")),
    ("fraction", "--fraction", takers("fraction")),
    ("generators", "--generators", takers("generators")),
    ("runs", "--runs", takers("runs")),
    ("response", "--response", _PATH),
    ("step", "--step", _PATH),
    ("steps", "--steps", _PATH),
    ("descent", "--descent", _PATH),
)


def register(subparsers) -> None:
    p = add_command(
        subparsers, "design", run,
        help="generate a design of experiments (Box-Behnken, CCD, factorial, ...)",
        description="Generate a design of experiments and write it as CSV (actual levels; "
        "standard run order, randomised with --seed; with -o FILE, factor levels in "
        "'# factor' comment lines).",
    )
    # no argparse choices: an unknown kind is refused by the catalogue, in one sentence
    others = [k for k in KINDS if k not in SHOWN_KINDS]
    p.add_argument("kind", metavar="{" + ",".join(SHOWN_KINDS) + "}",
                   help=f"design type (also spelled {', '.join(others)})")
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
    p.add_argument("--ccd-type", "--variant", dest="variant", default=None,
                   choices=["circumscribed", "inscribed", "face-centred"],
                   help="CCD type (default: circumscribed); a campaign's [design] variant")
    p.add_argument("--alpha", default=None,
                   help="CCD axial distance: rotatable (default), orthogonal or a number")
    p.add_argument("--levels", type=int, default=None, help="factorial: levels per factor (default: 2)")
    p.add_argument("--fraction", type=int, default=None,
                   help="fractional: p of 2^(k-p) (default: 1, or one per generator); "
                        "ccd: p of its factorial part (default: 0)")
    p.add_argument("--generators", default=None, help="fractional: e.g. D=ABC,E=ABD")
    p.add_argument("--runs", type=int, default=None, help="Plackett-Burman: 8, 12, 16, 20 or 24 runs")
    p.add_argument("--response", help="steepest-ascent: response column")
    p.add_argument("--step", type=float, default=None,
                   help="steepest-ascent: base step [coded], > 0 (default: 1)")
    p.add_argument("--steps", type=int, default=None,
                   help="steepest-ascent: number of steps, >= 1 (default: 5)")
    p.add_argument("--descent", action="store_true", help="steepest-ascent: go downhill")
    p.add_argument("-o", "--output", help="CSV file to write (default: standard output); an existing file "
                                          "is replaced only when it is a design demcal wrote")
    p.add_argument("--force", action="store_true", help="replace an existing -o file that demcal did not write")


def _kind_name(kind: str) -> str:
    """The catalogue's name of a design kind as typed (``steepest-ascent`` as it is)."""
    return kind if kind in _PATH else design_kind(kind, also=_PATH)


def check_options(args) -> None:
    """Refuse options that the chosen design kind does not use, and bad counts."""
    import math

    kind = _kind_name(args.kind)
    for attr, option, kinds in KIND_OPTIONS:
        value = getattr(args, attr, None)
        if value is None or value is False or kind in kinds:
            continue
        if attr == "runs_csv":
            raise ConfigError(
                f"a runs CSV ({value}) is read only by steepest-ascent designs, not by a "
                f"{args.kind} design; remove it or choose steepest-ascent."
            )
        labels = [kind_label(k) if k in DESIGN_NAMES else k for k in kinds]
        raise ConfigError(
            f"{option} does not apply to a {args.kind} design; only {and_list(labels)} designs "
            f"take it, so remove it or choose one of those."
        )
    if args.n_factors is not None and args.n_factors < 1:
        raise ConfigError(f"-k must be at least 1 factor, not {args.n_factors}.")
    if args.center is not None and args.center < 0:
        raise ConfigError(f"--center must be 0 or more centre points, not {args.center}.")
    if args.seed is not None and args.seed < 0:
        raise ConfigError(f"--seed must be a whole number of 0 or more, not {args.seed}.")
    if args.levels is not None and args.levels < 2:
        raise ConfigError(f"--levels must be at least 2 levels per factor, not {args.levels}.")
    if args.fraction is not None and kind == "central-composite" and args.fraction < 0:
        raise ConfigError(f"--fraction (p of the 2^(k-p) factorial part) must be 0 or more, not {args.fraction}.")
    if args.fraction is not None and kind != "central-composite" and args.fraction < 1:
        raise ConfigError(f"--fraction (p of 2^(k-p)) must be at least 1, not {args.fraction}.")
    if args.generators is not None and args.fraction is not None:
        n = len([g for g in args.generators.split(",") if g.strip()])
        if n != args.fraction:
            raise ConfigError(
                f"--fraction {args.fraction} disagrees with the {n} generators of --generators "
                f"{args.generators}; drop --fraction or give {args.fraction} generators."
            )
    if args.alpha is not None and args.alpha not in ("rotatable", "orthogonal"):
        try:
            alpha = float(args.alpha)
        except ValueError:
            alpha = None
        if alpha is not None and not (math.isfinite(alpha) and alpha > 0):
            raise ConfigError(f"--alpha must be a positive number, rotatable or orthogonal, not {args.alpha}.")
    if args.step is not None and not (math.isfinite(args.step) and args.step > 0):
        raise ConfigError(
            f"--step must be > 0 coded units, not {args.step:g}; to go downhill add --descent "
            "instead of a negative step."
        )
    if args.steps is not None and args.steps < 1:
        raise ConfigError(f"--steps must be at least 1, not {args.steps}.")


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
    from demcal.doe.catalog import design_matrix
    from demcal.doe.design import Design

    check_options(args)
    if args.kind == "steepest-ascent":
        return _steepest(args)
    factors = _factors(args)
    coded = design_matrix(args.kind, factors, **{name: getattr(args, name) for name in OPTION_NAMES})
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
    path = steepest_ascent(b, 1.0 if args.step is None else args.step,
                           5 if args.steps is None else args.steps, descent=args.descent)
    return Design("steepest-ascent", runs.factors, path)


def run(args) -> int:
    from demcal.doe.io import write_design_csv

    if args.output:  # before anything is read or computed
        from demcal._files import check_output

        check_output(args.output, "design", inputs=[args.runs_csv] if getattr(args, "runs_csv", None) else [],
                     force=args.force, of="this command")
    design = build_design(args)
    if args.output:
        write_design_csv(design, args.output, coded=args.coded)
        print(f"wrote {design.coded.shape[0]} runs of a {design.kind} design in "
              f"{len(design.factors)} factors to {args.output}", file=sys.stderr)
    else:
        sys.stdout.write(design.to_frame(coded=args.coded).to_csv(index=False, float_format="%.10g"))
    return 0
