"""Design-Expert style presentation of the statistics tables, for the CLI and the report.

The fitting code keeps machine names (``sum_sq``, ``pred_r2``, terms ``A*C``, ``B^2``),
which ``--json`` and the report's CSV/JSON files keep too; what people read goes
through this one module: headers as Design-Expert prints them (Sum of Squares, df,
Mean Square, F-value, p-value; Std. Dev., R², ...), terms as ``AC``, ``B²`` and
numbers as :func:`format_number` writes them.
"""

from __future__ import annotations

import math
import re

import numpy as np
import pandas as pd

#: Machine column name -> Design-Expert header.
HEADERS = {
    "sum_sq": "Sum of Squares", "df": "df", "mean_sq": "Mean Square", "F": "F-value",
    "p": "p-value", "significance": "", "std_dev": "Std. Dev.", "mean": "Mean",
    "cv_percent": "C.V. %", "r2": "R²", "adj_r2": "Adjusted R²", "pred_r2": "Predicted R²",
    "press": "PRESS", "adeq_precision": "Adeq Precision", "note": "",
    "estimate": "Coefficient Estimate", "std_error": "Standard Error",
    "ci_low": "95% CI Low", "ci_high": "95% CI High", "vif": "VIF",
    "source": "Source", "term": "Term", "model": "Model",
}
#: Headers whose values are p-values.
P_COLUMNS = ("p", "p-value", "p_value", "prob > f")
_SUPERSCRIPT = str.maketrans("0123456789", "⁰¹²³⁴⁵⁶⁷⁸⁹")
_TERM_INDEXES = ("source", "term")


def format_number(v, digits: int = 4, column: str = "") -> str:
    """A number as Design-Expert prints it.

    p-values (``column`` one of :data:`P_COLUMNS`) as ``< 0.0001`` or 4 decimals;
    integers as integers; other numbers to ``digits`` significant digits in fixed
    notation (whole numbers of more digits keep all of them: 44902, not 4.490e+04),
    scientific only below 1e-4 or from 1e9 on; NaN and None as blank.
    """
    if v is None or isinstance(v, str):
        return "" if v is None else v
    if isinstance(v, (bool, np.bool_)):
        return str(bool(v))
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    try:
        x = float(v)
    except (TypeError, ValueError):
        return str(v)
    if not math.isfinite(x):
        return "" if math.isnan(x) else ("∞" if x > 0 else "−∞")
    if column.lower() in P_COLUMNS:
        return "< 0.0001" if x < 1e-4 else f"{x:.4f}"
    if x == 0:
        return "0"
    if abs(x) < 1e-4 or abs(x) >= 1e9:
        return f"{x:.{max(digits - 1, 1)}e}"
    if x.is_integer():
        return str(int(x))
    decimals = max(digits - 1 - math.floor(math.log10(abs(x))), 0)
    text = f"{x:.{decimals}f}"
    return "0" if float(text) == 0 else text


def term_label(name: str) -> str:
    """``A*C`` -> ``AC``, ``B^2`` -> ``B²``; factor names longer than a letter are
    joined with ``·``; other labels (Model, Residual, Intercept) unchanged."""
    name = str(name)
    if "*" not in name and "^" not in name:
        return name
    parts = name.split("*")
    bases = [re.sub(r"\^\d+$", "", p) for p in parts]
    out = [re.sub(r"\^(\d+)$", lambda m: m.group(1).translate(_SUPERSCRIPT), p) for p in parts]
    return ("" if all(len(b) == 1 for b in bases) else "·").join(out)


def display_table(df: pd.DataFrame) -> pd.DataFrame:
    """``df`` with Design-Expert headers and term labels; values untouched.

    ``F`` becomes "F-value" only beside another statistic's column: a factor named F (or
    any one-letter factor) in a design table keeps its name.
    """
    stats = any(str(c) in HEADERS and len(str(c)) > 1 for c in df.columns)
    out = df.rename(columns=lambda c: HEADERS.get(str(c), c) if stats or len(str(c)) > 1 else c)
    name = str(df.index.name or "")
    if name.lower() in _TERM_INDEXES:
        out.index = [term_label(i) for i in df.index]
    out.index.name = HEADERS.get(name, name) if name else None
    return out


def format_cells(df: pd.DataFrame, digits: int = 4) -> list[list[str]]:
    """Every cell of ``df`` (already :func:`display_table`'d) as text, row by row."""
    return [[format_number(v, digits, str(c)) for c, v in zip(df.columns, row)]
            for row in df.itertuples(index=False)]


def format_table(df: pd.DataFrame, digits: int = 4) -> str:
    """``df`` as an aligned text table: header (index name first), a rule, the rows;
    the label column left-aligned, numbers right-aligned."""
    shown = display_table(df)
    head = [str(shown.index.name or "")] + [str(c) for c in shown.columns]
    body = [[str(i)] + cells for i, cells in zip(shown.index, format_cells(shown, digits))]
    widths = [max(len(r[k]) for r in [head] + body) for k in range(len(head))]

    def line(cells):
        return "  ".join(c.ljust(w) if k == 0 else c.rjust(w)
                         for k, (c, w) in enumerate(zip(cells, widths))).rstrip()

    return "\n".join([line(head), "  ".join("-" * w for w in widths if w)] + [line(r) for r in body])


def format_p(p: float) -> str:
    """A p-value in running text: ``p < 0.0001`` or ``p = 0.0137``."""
    txt = format_number(p, column="p")
    return f"p {txt}" if txt.startswith("<") else f"p = {txt}"
