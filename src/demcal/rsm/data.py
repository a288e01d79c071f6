"""Reading runs (factor settings and responses) from a table and coding the factors."""

from __future__ import annotations

import csv
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from demcal.doe.factors import Factor
from demcal.doe.io import (comment_lines, infer_factor_names, numeric_column, read_csv_text,
                           read_factor_comments, read_table)
from demcal.errors import ConfigError, DataError

_TOL = 1e-9
#: Largest coded level read as an axial point (rotatable CCD alpha of 8 factors).
_MAX_CODED = 4.0
#: The first comment line of a file written by ``demcal design -o``.
_DESIGN_LINE = re.compile(r"^#\s*demcal design:.*?(?P<coded>\(coded levels\))?\s*$")
#: Columns of a campaign's run table that are never factors: the store's bookkeeping
#: (besides :data:`demcal.doe.io.BOOKKEEPING_COLUMNS`).
RUN_BOOKKEEPING = ("seed", "replicate", "status", "wall_s", "key", "artifacts_dir", "condition")
#: Suffix of the actual-level copy of a coded factor column in the report's design
#: table (``tables/<campaign>_design_results.csv``: ``A``, ``A actual``, ...).
ACTUAL_SUFFIX = " actual"


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


def _code_with_levels(name: str, values: np.ndarray, factor: Factor, source: str,
                      coded: bool | None) -> np.ndarray:
    """Coded levels of a column whose actual low/high levels are known.

    A table that says what it holds (``coded``) is taken at its word. Otherwise values
    inside the levels are actual; values outside them are read as actual levels if they
    code to within +-:data:`_MAX_CODED` (axial points) and as coded levels if they lie
    within +-:data:`_MAX_CODED` and reach -1 or +1; a column that reads both ways with
    different results, or neither way, is refused rather than guessed.
    """
    if coded is True:
        return values.copy()
    as_actual = factor.to_coded(values)
    if coded is False:
        return as_actual
    lo, hi = float(values.min()), float(values.max())
    span = factor.high - factor.low
    if lo >= factor.low - _TOL * span and hi <= factor.high + _TOL * span:
        return as_actual
    actual_ok = bool(np.all(np.abs(as_actual) <= _MAX_CODED + _TOL))
    coded_ok = max(-lo, hi) <= _MAX_CODED + _TOL and (lo <= -1 + _TOL or hi >= 1 - _TOL)
    levels = f"{name}={factor.low:g}:{factor.high:g}"
    if actual_ok and coded_ok and not np.allclose(as_actual, values, rtol=0, atol=1e-9):
        raise DataError(
            f"column {name!r} of {source} runs from {lo:g} to {hi:g}, which reads both as "
            f"coded levels and as actual levels outside {levels} (coded "
            f"{as_actual.min():.3g} to {as_actual.max():.3g}); give levels that contain the "
            f"actual values, or read a file written by 'demcal design -o', whose comment "
            f"lines say which it holds."
        )
    if coded_ok:
        return values.copy()
    if actual_ok:
        return as_actual
    raise DataError(
        f"column {name!r} of {source} runs from {lo:g} to {hi:g}, which is neither coded "
        f"(-1..+1) nor near the levels {factor.low:g}..{factor.high:g} given for it; check "
        f"--factor {levels}."
    )


def _code_column(name: str, values: np.ndarray, factor: Factor | None, source: str,
                 coded: bool | None = None) -> tuple[Factor, np.ndarray]:
    """Decide whether a column holds coded or actual levels and return coded ones.

    ``coded`` is what the table says it holds (True: coded, False: actual, None: it does
    not say). With a factor given, see :func:`_code_with_levels`. Without one: a table
    that says it is coded, or values spanning exactly -1..+1, are coded; a column with
    two levels, or three evenly spaced ones (factorial, Box-Behnken, face-centred CCD),
    is coded so that its lowest level is -1 and its highest +1 (Design-Expert's coding).
    Any other column (a circumscribed or inscribed CCD has five levels per factor) does
    not show which of its levels are the low and high ones, so it is refused with a
    request for ``--factor NAME=LOW:HIGH`` instead of being guessed.
    """
    if factor is not None:
        return factor, _code_with_levels(name, values, factor, source, coded)
    lo, hi = float(values.min()), float(values.max())
    if hi == lo:
        raise DataError(f"column {name!r} of {source} has the same value in every run, so it "
                        "cannot be a factor; leave it out with --factors.")
    if coded is True or (abs(lo + 1) < _TOL and abs(hi - 1) < _TOL):
        return Factor(name), values.copy()
    rel = np.unique(np.round((values - lo) / (hi - lo), 6))
    if len(rel) == 2 or (len(rel) == 3 and abs(rel[1] - 0.5) < 1e-6):
        f = Factor(name, lo, hi)
        return f, f.to_coded(values)
    raise DataError(
        f"column {name!r} of {source} has {len(rel)} different levels from {lo:g} to {hi:g}, "
        f"so its low and high levels (coded -1 and +1) cannot be told from the data; give "
        f"them with --factor {name}=LOW:HIGH (or --factor {name}=-1:1 if the column is "
        f"already coded)."
    )


def runs_from_frame(
    df: pd.DataFrame,
    responses,
    factor_names=None,
    levels: dict | None = None,
    source: str = "the table",
    coded: bool | None = None,
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
    coded : bool, optional
        What the table says its factor columns hold: True for coded levels, False for
        actual ones (a file written by ``demcal design -o``), None when it does not say.
    """
    responses = list(responses)
    levels = dict(levels or {})
    ys = {r: numeric_column(df, r, source) for r in responses}
    if factor_names is None:
        factor_names = [c for c in infer_factor_names(df, responses)
                        if str(c).lower() not in RUN_BOOKKEEPING and not str(c).endswith(ACTUAL_SUFFIX)]
        if not factor_names:
            raise DataError(f"{source} has no numeric factor columns besides the response.")
    factor_names = list(factor_names)
    seen = set()
    for nm in factor_names:
        if nm in seen:
            raise ConfigError(f"factor {nm!r} is named twice in --factors; name each factor once.")
        seen.add(nm)
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
        f, c = _code_column(nm, numeric_column(df, nm, source), levels.get(nm), source, coded)
        factors.append(f)
        cols.append(c)
    return Runs(tuple(factors), np.column_stack(cols), ys, source)


def _declared_units(path, text: str | None = None) -> bool | None:
    """What a demcal design file says its levels are: True (coded), False (actual) or
    None (no ``# demcal design`` line)."""
    for line in comment_lines(path, text):
        m = _DESIGN_LINE.match(line)
        if m:
            return bool(m["coded"])
    return None


def _check_csv_shape(path: Path, text: str) -> None:
    """Refuse what pandas would quietly get wrong in the CSV ``text`` of ``path``: a
    column named twice in the header (pandas renames the second ``A.1``), a row with
    more fields than the header (pandas shifts the first such row into an index,
    reporting an empty cell) and a row with fewer (pandas fills it with empty cells)."""
    lines = []
    for lineno, line in enumerate(text.splitlines(), 1):
        if '"' not in line:
            line = line.split("#", 1)[0]
        if line.strip():
            lines.append((lineno, line))
    if not lines:
        return
    rows = csv.reader((ln for _, ln in lines), skipinitialspace=True)
    try:
        header = [h.strip() for h in next(rows)]
        seen = set()
        for h in header:
            if h and h in seen:
                raise DataError(f"the header of {path} names column {h!r} twice; give every "
                                "column its own name.")
            seen.add(h)
        for i, row in enumerate(rows, 1):
            if len(row) != len(header):
                lineno = lines[min(i, len(lines) - 1)][0]
                raise DataError(
                    f"row {i} of {path} (line {lineno} of the file) has {len(row)} field"
                    f"{'s' if len(row) != 1 else ''}, but the header has {len(header)}; give every row "
                    "one field per column."
                )
    except csv.Error:
        return  # read_table reports it


def read_table_checked(path, text: str | None = None):
    """:func:`demcal.doe.io.read_table` after the checks it leaves out: a column named
    twice, a row with more or fewer fields than the header."""
    path = Path(path)
    text = read_csv_text(path) if text is None else text
    _check_csv_shape(path, text)
    return read_table(path, text)


def _tidy(v: float) -> float:
    """``v`` to 12 significant digits: 0.1 - 0.1 read back from a CSV is 0, not 2.8e-17."""
    v = float(f"{float(v):.12g}")
    return 0.0 if abs(v) < 1e-12 else v


def paired_levels(df: pd.DataFrame, source: str = "the table") -> dict:
    """Factors of a table that holds each factor twice, coded (``A``) and actual
    (``A actual``), as the campaign report's design table does; ``{}`` for any other.

    The low and high levels are the actual values at coded -1 and +1, read from the
    straight line through the pairs; pairs off that line are refused.
    """
    out = {}
    for c in df.columns:
        actual = f"{c}{ACTUAL_SUFFIX}"
        if actual not in df.columns:
            continue
        x = numeric_column(df, c, source)
        a = numeric_column(df, actual, source)
        if x.max() == x.min():
            raise DataError(f"column {c!r} of {source} has the same value in every run, so it "
                            "cannot be a factor; leave it out with --factors.")
        slope, centre = np.polyfit(x, a, 1)
        if slope <= 0 or not np.allclose(centre + slope * x, a, rtol=1e-6, atol=1e-9 * max(abs(slope), 1e-300)):
            raise DataError(f"columns {c!r} and {actual!r} of {source} are not coded and actual "
                            f"levels of one factor (not on one straight line); give the factors "
                            f"with --factors and --factor {c}=LOW:HIGH.")
        out[c] = Factor(c, _tidy(centre - slope), _tidy(centre + slope))
    return out


def read_runs(path, responses, factor_names=None, levels: dict | None = None) -> Runs:
    """Read runs from a CSV; factor levels come from ``levels``, the file's comments or,
    in the campaign report's design table, the actual-level copies of the coded factor
    columns (``A`` and ``A actual``; see :func:`paired_levels`)."""
    text = read_csv_text(path)
    df = read_table_checked(path, text)
    found = read_factor_comments(path, text)
    merged = {k: v for k, v in found.items() if k in df.columns}
    declared = _declared_units(path, text)
    if not merged and declared is None:
        paired = paired_levels(df, str(path))
        if paired and (factor_names is None or set(factor_names) <= set(paired)):
            merged, declared = paired, True
    if factor_names is None and merged:
        factor_names = [c for c in df.columns if c in merged]
    merged.update(levels or {})
    return runs_from_frame(df, responses, factor_names, merged, str(path), declared)
