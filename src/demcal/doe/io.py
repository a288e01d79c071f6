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

import io
import re
from pathlib import Path

import numpy as np
import pandas as pd

from demcal.doe.design import Design
from demcal.doe.factors import Factor
from demcal._files import write_atomic
from demcal._checks import MAX_CSV_BYTES, control_character, printable, read_limited
from demcal.errors import DataError

_FACTOR_LINE = re.compile(
    r"^#\s*factor\s+(?P<name>\S+):\s*low=(?P<low>\S+)\s+high=(?P<high>\S+)(?:\s+units=(?P<units>.*))?$"
)

#: Columns that are never factors when the factors are inferred from a table.
BOOKKEEPING_COLUMNS = ("run", "std_order", "std", "block")
#: Largest magnitude of a value in a run table: squares and sums of squares of the
#: responses, and products of the coded factors, stay far from overflowing a float
#: (about 1.8e308).
MAX_ABS_VALUE = 1e100


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
    return write_atomic(path, "\n".join(lines) + "\n" + body)


def comment_lines(path, text: str | None = None):
    """The ``#`` lines at the head of a CSV file (or of its ``text``, already read), stripped."""
    text = read_csv_text(path) if text is None else text
    for line in text.splitlines():
        if not line.startswith("#"):
            return
        yield line.strip()


def read_factor_comments(path, text: str | None = None) -> dict[str, Factor]:
    """Factors described in the comment lines of a demcal CSV (empty if none)."""
    found = {}
    for line in comment_lines(path, text):
        m = _FACTOR_LINE.match(line)
        if m:
            try:
                found[m["name"]] = Factor(
                    m["name"], float(m["low"]), float(m["high"]), (m["units"] or "").strip()
                )
            except ValueError:
                continue
    return found


def read_csv_text(path) -> str:
    """The text of a CSV file, read with the size limit :data:`demcal._checks.MAX_CSV_BYTES`
    (a leading byte-order mark dropped); a missing, binary or too large file is a
    :class:`DataError`."""
    path = Path(path)
    if path.is_dir():
        raise DataError(f"{path} is a folder; give the path of a CSV file with one row per run.")
    if not path.exists():
        raise DataError(f"cannot find the file {path}; check the path.")
    data = read_limited(path, MAX_CSV_BYTES, "CSV file", DataError)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise DataError(f"{path} is not a text CSV file (byte 0x{data[exc.start]:02x} at offset {exc.start} is "
                        "not UTF-8); give a CSV file saved as UTF-8 text.") from None
    text = text.removeprefix("\ufeff")
    found = control_character(text)
    if found is not None:
        raise DataError(f"{path} is not a text CSV file (line {found[0]} holds the control character "
                        f"{ascii(found[1])}); give a CSV file saved as text.")
    return text


def read_table(path, text: str | None = None) -> pd.DataFrame:
    """Read a CSV of runs (or its ``text``, already read by :func:`read_csv_text`); a
    missing, empty, binary, too large or unreadable file is a :class:`DataError`."""
    path = Path(path)
    text = read_csv_text(path) if text is None else text
    try:
        df = pd.read_csv(io.StringIO(text), comment="#", skipinitialspace=True)
    except pd.errors.EmptyDataError:
        raise DataError(f"{path} is empty; it needs a header row and one row per run.") from None
    except pd.errors.ParserError as exc:
        raise DataError(f"cannot read {path} as CSV ({printable(str(exc).splitlines()[0], 200)}).") from None
    df.columns = [str(c).strip() for c in df.columns]
    if df.empty:
        raise DataError(f"{path} has a header but no runs.")
    return df


def numeric_column(df: pd.DataFrame, name: str, source="the table") -> np.ndarray:
    """Column ``name`` as floats; missing, non-numeric or empty cells are a :class:`DataError`."""
    if name not in df.columns:
        raise DataError(
            f"{source} has no column {name!r}; its columns are "
            f"{printable(', '.join(map(str, df.columns)), 200)}."
        )
    col = pd.to_numeric(df[name], errors="coerce")
    bad = col.isna() & df[name].notna()
    if bad.any():
        row = int(np.flatnonzero(bad.to_numpy())[0])
        raise DataError(
            f"column {name!r} of {source} is not numeric (row {row + 1} holds "
            f"{printable(repr(df[name].iloc[row]), 60)})."
        )
    if col.isna().any():
        row = int(np.flatnonzero(col.isna().to_numpy())[0])
        raise DataError(f"column {name!r} of {source} has an empty cell in row {row + 1}.")
    values = col.to_numpy(dtype=float)
    large = ~(np.abs(values) <= MAX_ABS_VALUE)
    if large.any():
        row = int(np.flatnonzero(large)[0])
        what = "is not a finite number" if not np.isfinite(values[row]) else f"is beyond ±{MAX_ABS_VALUE:g}"
        raise DataError(
            f"column {name!r} of {source} holds {values[row]:g} in row {row + 1}, which {what}; give finite "
            f"values within ±{MAX_ABS_VALUE:g} (rescale the column, e.g. to other units)."
        )
    return values


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
    text = read_csv_text(path)
    df = read_table(path, text)
    factors = read_factor_comments(path, text)
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
