"""``demcal analyze``: fit a response surface to a run table and print its ANOVA."""

from __future__ import annotations

import json
import sys
from typing import TYPE_CHECKING

from demcal.cli._util import add_json, add_model_options, add_runs_command, read_runs_from_args
from demcal.errors import ConfigError, DataError

if TYPE_CHECKING:
    import pandas as pd

    from demcal.rsm.fit import ResponseSurface


def register(subparsers) -> None:
    p = add_runs_command(
        subparsers, "analyze", run,
        help="fit a response surface: ANOVA, fit statistics, equations",
        description="Fit a polynomial response surface in coded factors and print the "
        "Design-Expert style ANOVA (partial sums of squares, lack of fit), fit statistics, "
        "coefficients and the equations in coded and actual units.",
    )
    p.add_argument("--response", required=True, help="response column")
    add_model_options(
        p, factors_help="factor columns, comma separated (default: every numeric column except "
        "the response, run and std_order)",
        factor_help="actual low/high levels of a factor (for the actual-units equation)",
        reduce_help="backward elimination at this significance level, keeping hierarchy")
    add_json(p)


def check_reduce(alpha: float | None) -> None:
    """Refuse a ``--reduce`` significance level outside (0, 1)."""
    if alpha is not None and not 0 < alpha < 1:
        raise ConfigError(f"--reduce takes a significance level between 0 and 1, not {alpha}.")


def fit_from_args(args) -> tuple[ResponseSurface, list[str]]:
    """Read, fit and (optionally) reduce as ``demcal analyze`` does; returns model and notes."""
    from demcal.rsm.fit import fit_response_surface
    from demcal.rsm.reduce import backward_elimination
    from demcal.rsm.tables import format_p, term_label

    check_reduce(args.reduce)  # before the run table is read
    runs = read_runs_from_args(args, [args.response])
    model = fit_response_surface(runs.coded, runs.responses[args.response], runs.factors,
                                 args.model, args.response)
    notes = list(model.notes)
    if args.reduce is not None:
        red = backward_elimination(model, args.reduce)
        model = red.model
        if red.removed:
            notes.append("backward elimination removed " + ", ".join(
                f"{term_label(t)} ({format_p(p)})" for t, p in red.removed) + ".")
        notes.extend(n for n in model.notes if n not in notes)
    return model, notes


def _statistics(f) -> list[str]:
    """The fit statistics as two aligned label/value columns (Design-Expert's layout)."""
    from demcal.rsm.tables import format_number

    rows = [("Std. Dev.", f.std_dev, "R²", f.r2), ("Mean", f.mean, "Adjusted R²", f.adj_r2),
            ("C.V. %", f.cv_percent, "Predicted R²", f.pred_r2),
            ("PRESS", f.press, "Adeq Precision", f.adeq_precision)]
    return [f"  {a:<10}{format_number(x):>10}    {b:<15}{format_number(y):>10}" for a, x, b, y in rows]


def run(args) -> int:
    from demcal.rsm.summary import fit_summary
    from demcal.rsm.tables import format_table
    from demcal.rsm.terms import display_name

    model, notes = fit_from_args(args)
    for n in notes:
        print(f"demcal: note: {n}", file=sys.stderr)
    if args.json:
        print(json.dumps(model.to_dict(), indent=1))
        return 0
    reduced = args.reduce is not None
    kind = (f"{args.model} model reduced by backward elimination (alpha = {args.reduce:g})" if reduced
            else f"{model.order} model")
    out = [f"Response {model.response}: {kind}, {model.n} runs, factors "
           + ", ".join(f.describe() for f in model.factors), "", "ANOVA (partial sums of squares)",
           format_table(model.display_anova()), "", "Fit statistics"]
    out += _statistics(model.fit)
    out += ["", "Coefficients (coded)", format_table(model.coefficient_table), "",
            "Equation in coded factors", "  " + model.equation("coded"), "",
            "Equation in actual factors", "  " + model.equation("actual")]
    try:
        s = fit_summary(model.x, model.y, model.factors)
        out += ["", "Fit summary: sequential model sums of squares", format_table(s.sequential)]
        if not s.lack_of_fit.empty:
            out += ["", "Lack-of-fit tests", format_table(s.lack_of_fit)]
        out += ["", "Model summary statistics", format_table(s.model_stats)]
        if reduced:  # the summary compares whole orders; the model above is neither of them
            out.append(f"Fit summary's suggested order: {s.suggested or 'none significant'} (the model "
                       f"above is the reduced {args.model} model, terms "
                       + ", ".join(display_name(t, model.names) for t in model.terms if any(t))
                       + ")")
        else:
            out.append(f"Suggested model: {s.suggested or 'none significant'}")
    except DataError as exc:  # too few runs for the summary; the fit above stands on its own
        print(f"demcal: note: fit summary left out: {exc}", file=sys.stderr)
    print("\n".join(out))
    return 0
