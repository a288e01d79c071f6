"""Design and run tables as CSV files.

A design file is an ordinary CSV whose first lines are comments describing the factors,
so that coded levels can be recovered without re-typing the levels::

    # demcal design: box-behnken
    # factor e: low=0.5 high=0.7 units=-
    run,std_order,e,mu
    1,7,0.6,0.3
    ...

Any CSV with a header row can be read back; the comment lines are optional.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import pandas as pd

from demcal.doe.design import Design
from demcal.doe.factors import Factor
from demcal.errors import DataError

_FACTOR_LINE = re.compile(
    r"^#\s*factor\s+(?P<name>\S+):\s*low=(?P<low>\S+)\s+high=(?P<high>\S+)(?:\s+units=(?P<units>.*))?$"
)

#: Columns that are never factors when the factors are inferred from a table.
BOOKKEEPING_COLUMNS = ("run", "std_order", "std", "block")


def write_design_csv(design: Design, path, coded: bool = False) -> Path:
    """Write ``design`` (in run order) to ``path`` with its factor comments; returns the path.

    The file is written to a temporary name and renamed, so a failure never leaves a
    half-written file.
    """
    path = Path(path)
    lines = [f"# demcal design: {design.kind}" + (" (coded levels)" if coded else "")]
    for f in design.factors:
        lines.append(f"# factor {f.name}: low={f.low!r} high={f.high!r} units={f.units}")
    body = design.to_frame(coded=coded).to_csv(index=False, float_format="%.10g")
    tmp = path.with_name(path.name + ".tmp")
    try:
        tmp.write_text("\n".join(lines) + "\n" + body)
        os.replace(tmp, path)
    except OSError as exc:
        raise DataError(f"cannot write {path}: {exc.strerror}.") from None
    return path


def comment_lines(path):
    """The ``#`` lines at the head of a CSV file, stripped."""
    with open(path, encoding="utf-8", errors="replace") as fh:
        for line in fh:
            if not line.startswith("#"):
                return
            yield line.strip()


def read_factor_comments(path) -> dict[str, Factor]:
    """Factors described in the comment lines of a demcal CSV (empty if none)."""
    found = {}
    for line in comment_lines(path):
        m = _FACTOR_LINE.match(line)
        if m:
            try:
                found[m["name"]] = Factor(
                    m["name"], float(m["low"]), float(m["high"]), (m["units"] or "").strip()
                )
            except ValueError:
                continue
    return found


def read_table(path) -> pd.DataFrame:
    """Read a CSV of runs; a missing, empty or unreadable file is a :class:`DataError`."""
    path = Path(path)
    if not path.is_file():
        raise DataError(f"cannot find the file {path}; check the path.")
    try:
        df = pd.read_csv(path, comment="#", skipinitialspace=True)
    except pd.errors.EmptyDataError:
        raise DataError(f"{path} is empty; it needs a header row and one row per run.") from None
    except (pd.errors.ParserError, UnicodeDecodeError) as exc:
        raise DataError(f"cannot read {path} as CSV ({str(exc).splitlines()[0]}).") from None
    df.columns = [str(c).strip() for c in df.columns]
    if df.empty:
        raise DataError(f"{path} has a header but no runs.")
    return df


def numeric_column(df: pd.DataFrame, name: str, source="the table") -> np.ndarray:
    """Column ``name`` as floats; missing, non-numeric or empty cells are a :class:`DataError`."""
    if name not in df.columns:
        raise DataError(
            f"{source} has no column {name!r}; its columns are {', '.join(map(str, df.columns))}."
        )
    col = pd.to_numeric(df[name], errors="coerce")
    bad = col.isna() & df[name].notna()
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise DataError(
            f"column {name!r} of {source} is not numeric (row {row + 1} holds {df[name].iloc[row]!r})."
        )
    if col.isna().any():
        row = int(np.flatnonzero(col.isna().to_numpy())[0])
        raise DataError(f"column {name!r} of {source} has an empty cell in row {row + 1}.")
    return col.to_numpy(dtype=float)


def infer_factor_names(df: pd.DataFrame, responses) -> list[str]:
    """Every numeric column except the responses and bookkeeping columns (run, std_order).

    A column with some numeric cells counts as numeric, so that a stray text cell in a
    factor column is reported by :func:`numeric_column` instead of silently dropping the
    factor; columns without any number (labels, notes) are skipped.
    """
    responses = set(responses)
    names = []
    for c in df.columns:
        if c in responses or c.lower() in BOOKKEEPING_COLUMNS:
            continue
        if pd.api.types.is_numeric_dtype(df[c]) or pd.to_numeric(df[c], errors="coerce").notna().any():
            names.append(c)
    return names


def read_design_csv(path) -> Design:
    """Read a design file written by :func:`write_design_csv` (actual levels)."""
    df = read_table(path)
    factors = read_factor_comments(path)
    if not factors:
        raise DataError(f"{path} has no '# factor' lines, so it is not a demcal design file.")
    coded = np.column_stack(
        [f.to_coded(numeric_column(df, f.name, str(path))) for f in factors.values()]
    )
    order = numeric_column(df, "run", str(path)).astype(int) if "run" in df.columns else None
    if "std_order" in df.columns:
        std = numeric_column(df, "std_order", str(path)).astype(int) - 1
        idx = np.argsort(std)
        coded = coded[idx]
        order = order[idx] if order is not None else None
    return Design("from-file", tuple(factors.values()), coded, order)
