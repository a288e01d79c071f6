"""Checking user-given values and wording the answer.

One rule across the package for what counts as a number: strings, bytes and bools
are not numbers here (``float("1")`` and ``float(True)`` would
pass them silently); anything ``float()`` cannot take becomes NaN, so a single
finiteness test refuses it.
"""

from __future__ import annotations

import math

from demcal.errors import ConfigError


def as_float(value) -> float:
    """``value`` as a float; NaN when it is not a number (a string, None, a list)."""
    if isinstance(value, (str, bytes, bool)):
        return math.nan
    try:
        return float(value)
    except (TypeError, ValueError, OverflowError):
        return math.nan


def checked_float(value, name: str, what: str = "a finite number", ok=math.isfinite) -> float:
    """``value`` as a float, or a ConfigError naming ``name`` when it is not a number or
    fails ``ok`` (finite by default); ``what`` says what is wanted."""
    v = as_float(value)
    if not ok(v):
        raise ConfigError(f"{name} must be {what}, got {value!r}.")
    return v


def checked_whole(value, name: str, minimum: int) -> int:
    """``value`` as an int >= ``minimum`` (integer-valued floats accepted)."""
    return int(checked_float(value, name, f"a whole number >= {minimum}",
                             lambda x: math.isfinite(x) and x == int(x) and x >= minimum))


def and_list(words) -> str:
    """``a``, ``a and b``, ``a, b and c``: a list of words for a message."""
    words = [str(w) for w in words]
    return words[0] if len(words) == 1 else ", ".join(words[:-1]) + " and " + words[-1]


# --------------------------------------------------------------------------- seeds and workers

#: Every random seed demcal takes lies in ``0 .. MAX_SEED``: 2^63 - 1, the largest whole
#: number the campaign store (SQLite INTEGER) holds; numpy seeds with any of them.
MAX_SEED = 2**63 - 1


def check_seed(value, name: str) -> int:
    """``value`` as a seed in ``0 .. MAX_SEED``, or a ConfigError naming ``name``."""
    if isinstance(value, bool) or not isinstance(value, int):
        raise ConfigError(f"{name} must be a whole number from 0 to 2^63 - 1, got {value!r}.")
    if not 0 <= value <= MAX_SEED:
        raise ConfigError(f"{name} must lie in 0 .. 2^63 - 1 ({MAX_SEED}), got {value}.")
    return value


def check_workers(value, name: str = "--workers") -> int:
    """``value`` as a worker count: 1 or more, or 0 for one per CPU core."""
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ConfigError(f"{name} must be 1 or more, or 0 for one per core, got {value!r}.")
    return value


# --------------------------------------------------------------------------- input files

#: The most demcal reads of each kind of input file [bytes]: a campaign or lab file is a
#: few kB, a run table of the largest design (100,000 runs) a few MB, a camera photo
#: tens of MB. A larger file (or a device such as /dev/zero) is refused, not read until
#: memory runs out.
MAX_TOML_BYTES = 1 << 20
MAX_CSV_BYTES = 64 << 20
MAX_PHOTO_BYTES = 256 << 20


def format_bytes(n: int) -> str:
    """``1 MiB``, ``64 MiB``, ``512 kiB``: a size for a message."""
    for unit, size in (("GiB", 1 << 30), ("MiB", 1 << 20), ("kiB", 1 << 10)):
        if n >= size:
            return f"{n / size:g} {unit}"
    return f"{n} bytes"


def read_limited(path, limit: int, what: str, error=ConfigError) -> bytes:
    """The bytes of the file ``path``, refused with ``error`` (naming ``what``, the path
    and ``limit``) when it holds more than ``limit`` bytes; at most ``limit + 1`` bytes
    are ever read, so a device or a growing file cannot exhaust memory. File-system
    errors (missing file, a folder, no permission) are raised as :class:`OSError`."""
    import os

    with open(path, "rb") as fh:
        try:
            size = os.fstat(fh.fileno()).st_size
        except OSError:  # pragma: no cover - every open file has a status
            size = 0
        data = fh.read(limit + 1) if size <= limit else b""
    if size > limit or len(data) > limit:
        raise error(f"{what} '{path}' holds more than {format_bytes(limit)}, the most demcal reads "
                    f"for a {what}; check that it is the right file.")
    return data


def control_character(text: str) -> tuple[int, str] | None:
    """``(line, character)`` of the first control character of ``text`` that text files do
    not hold (anything below U+0020 but tab, newline, carriage return and form feed,
    and DEL), or None: what tells a binary file from a text one."""
    import re

    found = re.search(r"[\x00-\x08\x0b\x0e-\x1f\x7f]", text)
    if found is None:
        return None
    return text.count("\n", 0, found.start()) + 1, found.group()


def printable(text: str, limit: int = 80) -> str:
    """``text`` for a message: control characters as ``\\xNN``, cut to ``limit`` characters."""
    out = "".join(ch if ch.isprintable() else ascii(ch)[1:-1] for ch in str(text))
    return out if len(out) <= limit else out[: limit - 3] + "..."


def significant(value: float, digits: int = 12) -> float:
    """``value`` to ``digits`` significant digits: a level or a calibrated parameter without
    binary noise (0.6000000000000001 -> 0.6 at 12 digits; 0.60734 -> 0.607 at 3)."""
    return float(f"{float(value):.{digits}g}")
