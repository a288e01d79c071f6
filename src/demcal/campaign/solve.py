"""The solve step the calibration and its closed loop share: fit a design's response
models, solve a condition's targets on them, and round the parameters found.

:func:`demcal.campaign.calibrate.calibrate` solves each condition on the campaign's design
(or on the box its loop ended in), and :mod:`demcal.campaign.loop` re-solves inside every
box it fits; both round a parameter the same way, as the store keys the runs.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd

from demcal._checks import significant
from demcal.campaign.config import Campaign, Condition

#: Significant digits of a calibrated parameter as it is simulated and reported.
PARAMETER_DIGITS = 3


def round_parameter(value: float, digits: int = PARAMETER_DIGITS) -> float:
    return significant(value, digits)


def fit_models(campaign: Campaign, table: pd.DataFrame):
    """Full and (if asked) reduced model of every response."""
    from demcal.rsm import backward_elimination, fit_response_surface

    factors = list(campaign.factors)
    names = campaign.factor_names
    full, models, removed, notes = {}, {}, {}, []
    for response in campaign.response_names:
        rows = table[table[response].notna()]
        missing = len(table) - len(rows)
        if missing:
            notes.append(f"{missing} of {len(table)} design runs of {response} have no result "
                         f"(failed or not run) and are left out of the fit.")
        x, y = rows[names].to_numpy(float), rows[response].to_numpy(float)
        model = fit_response_surface(x, y, factors, campaign.model_order, response)
        full[response] = model
        if campaign.reduce_alpha is not None:
            reduction = backward_elimination(model, campaign.reduce_alpha)
            models[response], removed[response] = reduction.model, reduction.removed
        else:
            models[response], removed[response] = model, ()
    return full, models, removed, notes


def _choose(solutions: pd.DataFrame, names: list[str], threshold: float) -> pd.Series:
    """The solution of the set nearest the design centre (coded), else the best one."""
    good = solutions[solutions["desirability"] >= threshold]
    if good.empty:
        return solutions.iloc[0]
    norms = np.linalg.norm(good[[f"coded:{n}" for n in names]].to_numpy(float), axis=1)
    return good.iloc[int(np.argmin(norms))]


def solve_condition(campaign: Campaign, models: dict, condition: Condition, seed: int = 0):
    """Solve one condition's targets; returns (chosen coded point, optimisation, notes)."""
    from demcal.optimize import Goal, optimize, reachable_range

    names = campaign.factor_names
    notes = []
    goals = []
    for target in condition.targets:
        model = models[target.response]
        lo, hi = reachable_range(model, seed=seed)
        if target.mean < lo or target.mean > hi:
            # Outside the box: aim at the nearest edge of what the box reaches.
            edge = lo if target.mean < lo else hi
            notes.append(
                f"the target {target.response} = {target.mean:g} lies outside what the model reaches inside "
                f"the design box ({lo:.2f} to {hi:.2f}); the parameters simulated are the box's nearest "
                f"point ({edge:.2f}), so the target cannot be met without wider factor levels")
            goals.append(Goal(target.response, "target", target=edge))
        else:
            goals.append(Goal(target.response, "target", target=target.mean))
    optimization = optimize({g.response: models[g.response] for g in goals}, goals, seed=seed)
    best = _choose(optimization.solutions, names, optimization.threshold)
    solutions = optimization.solutions
    solutions = pd.concat([solutions.loc[[best.name]], solutions.drop(index=best.name)]).reset_index(drop=True)
    return best, dataclasses.replace(optimization, solutions=solutions), notes
