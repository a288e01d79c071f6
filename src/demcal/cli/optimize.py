"""``demcal optimize``: solve response surfaces for targets by desirability."""

from __future__ import annotations

import json
import math
import sys
from typing import TYPE_CHECKING

from demcal.cli._util import add_json, add_model_options, add_runs_command, read_runs_from_args
from demcal.errors import ConfigError

if TYPE_CHECKING:
    from demcal.optimize.desirability import Goal


def register(subparsers) -> None:
    p = add_runs_command(
        subparsers, "optimize", run,
        help="find factor settings that give target responses (desirability)",
        description="Fit a response surface per response and maximise the Derringer-Suich "
        "desirability inside the design box from many starts. Prints the distinct "
        "solutions and the range of every factor over the solution set (D >= threshold).",
    )
    p.add_argument("--response", action="append", default=[], help="response column (repeatable)")
    p.add_argument("--target", action="append", type=float, default=[],
                   help="target value, paired in order with --response")
    p.add_argument("--goal", action="append", default=[], metavar="RESP=KIND[:...]",
                   help="goal such as y=max, y=min, y=range:10:20, y=target:31.07:importance=5")
    add_model_options(
        p, factors_help="factor columns, comma separated (default: all numeric columns except "
        "responses, run and std_order)",
        factor_help="actual low/high levels of a factor, for actual-unit answers",
        reduce_help="reduce each model by backward elimination first")
    p.add_argument("--starts", type=int, default=30,
                   help="random starting points, 1 to 10,000 (default: %(default)s)")
    p.add_argument("--seed", type=int, default=0,
                   help="seed of the starting points (default: %(default)s)")
    p.add_argument("--threshold", type=float, default=0.99,
                   help="desirability that defines the solution set (default: %(default)s)")
    p.add_argument("--max-solutions", type=int, default=None, help="print at most this many")
    p.add_argument("--plot", help="write the solution-set plot to this PNG or SVG file (an existing file is "
                                  "replaced only when it is a figure demcal wrote)")
    p.add_argument("--force", action="store_true", help="replace an existing --plot file that demcal did not write")
    add_json(p)


def goals_from_args(args) -> list[Goal]:
    from demcal.optimize.desirability import Goal, parse_goal

    goals = [parse_goal(s) for s in args.goal]
    given = {g.response for g in goals}
    plain = [r for r in args.response if r not in given]
    if len(args.target) > len(plain):
        raise ConfigError(f"{len(args.target)} --target values but only {len(plain)} --response "
                          "columns without a --goal to pair them with.")
    for r, t in zip(plain, args.target):
        if not math.isfinite(t):
            raise ConfigError(f"--target of {r!r} must be a finite number, got {t}.")
        goals.append(Goal(r, "target", t))
    missing = plain[len(args.target):]
    if missing:
        raise ConfigError(f"say what response {missing[0]!r} should do: add --target VALUE or "
                          f"--goal {missing[0]}=max.")
    if not goals:
        raise ConfigError("give a response and a goal, e.g. --response angle --target 31.07.")
    return goals


def run(args) -> int:
    from demcal.cli.rsm import check_reduce
    from demcal.optimize.search import check_search

    check_search(args.starts, args.threshold, ("--starts", "--threshold"))
    if args.max_solutions is not None and args.max_solutions < 1:
        raise ConfigError(f"--max-solutions must be at least 1 (the best solution), got {args.max_solutions}.")
    check_reduce(args.reduce)
    if args.plot:  # before anything is read or computed
        from demcal._files import check_output

        check_output(args.plot, "figure", inputs=[args.runs_csv], force=args.force, option="--plot",
                     of="this command")
    from demcal.optimize.search import optimize
    from demcal.rsm.fit import fit_response_surface
    from demcal.rsm.reduce import backward_elimination

    goals = goals_from_args(args)
    responses = [g.response for g in goals]
    runs = read_runs_from_args(args, responses)
    models = {}
    for r in responses:
        m = fit_response_surface(runs.coded, runs.responses[r], runs.factors, args.model, r)
        if args.reduce is not None:
            m = backward_elimination(m, args.reduce).model
        for n in m.notes:
            print(f"demcal: note: {r}: {n}", file=sys.stderr)
        models[r] = m
    result = optimize(models, goals, n_starts=args.starts, seed=args.seed, threshold=args.threshold)
    if args.plot:
        from demcal.report.figures import solution_set_figure, save_figure
        save_figure(solution_set_figure(result), args.plot)
    if args.json:
        print(json.dumps(result.to_dict(args.max_solutions), indent=1))
        return 0
    lines = ["Goals: " + "; ".join(g.describe() for g in result.goals)]
    for g in result.goals:
        lo, hi = result.reachable[g.response]
        lines.append(f"  {g.response} reaches {lo:.4g} .. {hi:.4g} inside the design box")
    sol = result.solutions if args.max_solutions is None else result.solutions.head(args.max_solutions)
    lines += ["", f"Solutions ({len(result.solutions)} distinct, best first)",
              sol.to_string(float_format=lambda v: f"{v:.5g}")]
    if result.factor_ranges:
        lines += ["", f"Solution set (desirability >= {result.threshold:g}): factor ranges"]
        for f in result.factors:
            lo, hi = result.factor_ranges[f.name]
            lines.append(f"  {f.name}: {lo:.4g} .. {hi:.4g}   (design {f.low:g} .. {f.high:g})")
    else:
        lines += ["", f"No setting reaches desirability {result.threshold:g}; the best is "
                  f"{result.solutions['desirability'].iloc[0]:.3g}."]
    print("\n".join(lines))
    return 0
