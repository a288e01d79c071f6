"""Reading runs (factor settings and responses) from a table and coding the factors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from demcal.doe.factors import Factor
from demcal.doe.io import infer_factor_names, numeric_column, read_factor_comments, read_table
from demcal.errors import DataError

_TOL = 1e-9


@dataclass(frozen=True)
class Runs:
    """Runs of an experiment, factors in coded units.

    Attributes
    ----------
    factors : tuple of Factor
    coded : numpy.ndarray
        ``(n, k)`` coded factor levels.
    responses : dict of str -> numpy.ndarray
    source : str
        Where the runs came from, for messages.
    """

    factors: tuple[Factor, ...]
    coded: np.ndarray
    responses: dict
    source: str = "the table"

    @property
    def names(self):
        return [f.name for f in self.factors]


def _code_column(name: str, values: np.ndarray, factor: Factor | None, source: str) -> tuple[Factor, np.ndarray]:
    """Decide whether a column holds coded or actual levels and return coded ones.

    With a factor given: values inside [low, high] are actual levels; otherwise values
    inside [-2, 2] (which covers CCD axial points) are taken as already coded. Without a
    factor: values spanning exactly -1..+1 are coded; other columns are coded so that
    their minimum is -1 and their maximum +1 (Design-Expert's coding of the design's
    low and high levels).
    """
    lo, hi = float(values.min()), float(values.max())
    if factor is not None:
        span = factor.high - factor.low
        if lo >= factor.low - _TOL * span and hi <= factor.high + _TOL * span:
            return factor, factor.to_coded(values)
        if lo >= -2.0 - _TOL and hi <= 2.0 + _TOL:
            return factor, values.copy()
        raise DataError(
            f"column {name!r} of {source} runs from {lo:g} to {hi:g}, which is neither coded "
            f"(-1..+1) nor inside the levels {factor.low:g}..{factor.high:g} given for it."
        )
    if hi == lo:
        raise DataError(f"column {name!r} of {source} has the same value in every run, so it "
                        "cannot be a factor; leave it out with --factors.")
    if abs(lo + 1) < _TOL and abs(hi - 1) < _TOL:
        return Factor(name), values.copy()
    f = Factor(name, lo, hi)
    return f, f.to_coded(values)


def runs_from_frame(
    df: pd.DataFrame,
    responses,
    factor_names=None,
    levels: dict | None = None,
    source: str = "the table",
) -> Runs:
    """Build :class:`Runs` from a DataFrame.

    Parameters
    ----------
    df : pandas.DataFrame
    responses : sequence of str
        Response column names.
    factor_names : sequence of str, optional
        Factor columns; by default every numeric column except the responses and the
        ``run`` / ``std_order`` columns.
    levels : dict of str -> Factor, optional
        Actual low/high levels of some factors (``--factor A=0.5:0.7``).
    source : str
        Name of the table for messages.
    """
    responses = list(responses)
    levels = dict(levels or {})
    ys = {r: numeric_column(df, r, source) for r in responses}
    if factor_names is None:
        factor_names = infer_factor_names(df, responses)
        if not factor_names:
            raise DataError(f"{source} has no numeric factor columns besides the response.")
    factor_names = list(factor_names)
    for nm in levels:
        if nm not in factor_names:
            raise DataError(
                f"levels were given for {nm!r}, which is not a factor column of {source} "
                f"(factors: {', '.join(factor_names)})."
            )
    factors, cols = [], []
    for nm in factor_names:
        if nm in responses:
            raise DataError(f"column {nm!r} cannot be both a factor and a response.")
        f, c = _code_column(nm, numeric_column(df, nm, source), levels.get(nm), source)
        factors.append(f)
        cols.append(c)
    return Runs(tuple(factors), np.column_stack(cols), ys, source)


def read_runs(path, responses, factor_names=None, levels: dict | None = None) -> Runs:
    """Read runs from a CSV; factor levels come from ``levels`` or the file's comments."""
    df = read_table(path)
    found = read_factor_comments(path)
    merged = {k: v for k, v in found.items() if k in df.columns}
    if factor_names is None and merged:
        factor_names = [c for c in df.columns if c in merged]
    merged.update(levels or {})
    return runs_from_frame(df, responses, factor_names, merged, str(path))
