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
