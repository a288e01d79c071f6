"""Numbers as a reader wants them: rounded to the precision their uncertainty supports,
with their unit.

The rule is the GUM's (JCGM 100:2008, *Guide to the expression of uncertainty in
measurement*, §7.2.6): quote an uncertainty to at most two significant digits, and round
the value to the same decimal place. ``33.2085 ± 2.02636`` is ``33.2 ± 2.0``, and a
value without a usable uncertainty (none, zero, NaN) keeps :data:`FALLBACK` significant
digits. A calibrated parameter is read against the width of its solution set, the
settings that all meet the target: its digits stop where that width's second digit does,
and stay between two and three significant digits (:func:`ranged`).

Every figure ``demcal calibrate`` prints and the report renders for a reader goes
through here; the stored record (calibration.json, the report's CSV tables) keeps every
digit.
"""

from __future__ import annotations

import math

#: Significant digits of an uncertainty (GUM §7.2.6: "at most two").
DIGITS = 2
#: Significant digits of a value with no usable uncertainty.
FALLBACK = 3
#: Significant digits of a calibrated parameter: at least the first, at most the second.
PARAMETER_DIGITS = (2, 3)
#: Below 10**LOW or from 10**HIGH on, a number is written with a power of ten.
LOW, HIGH = -3, 6
#: Units written straight after the number (``33.2°``); any other takes a space (``12 %``).
CLOSE_UNITS = ("°", "′", "″")
_SUPERSCRIPT = str.maketrans("-0123456789", "⁻⁰¹²³⁴⁵⁶⁷⁸⁹")


def decimals(uncertainty: float, digits: int = DIGITS) -> int | None:
    """Decimal places that keep ``digits`` significant digits of ``uncertainty``
    (negative: tens, hundreds, ...); None when it is zero, NaN or infinite.
    ``2.02636`` -> 1 (``2.0``); ``0.0996`` -> 2 (``0.10``: the rounding carries)."""
    try:
        u = abs(float(uncertainty))
    except (TypeError, ValueError):
        return None
    if not math.isfinite(u) or u == 0:
        return None
    places = digits - 1 - math.floor(math.log10(u))
    if round(u, places) >= 10.0 ** (digits - places):  # 9.96 -> 10: one digit fewer
        places -= 1
    return places


def with_unit(text: str, unit: str | None) -> str:
    """``33.2°``, ``12 %``, ``0.6`` (no unit, or ``-`` for a dimensionless one)."""
    unit = (unit or "").strip()
    if not unit or unit == "-":
        return text
    return f"{text}{unit}" if unit in CLOSE_UNITS else f"{text} {unit}"


def rounded(value: float, uncertainty: float = float("nan"), unit: str | None = None,
            digits: int = DIGITS) -> str:
    """``value`` alone, to the decimal place of ``uncertainty`` (:func:`decimals`), with
    its unit: ``rounded(33.2085, 2.02636, "°")`` is ``33.2°``. Without a usable
    uncertainty, :data:`FALLBACK` significant digits; NaN is ``n/a``."""
    return with_unit(_number(value, decimals(uncertainty, digits)), unit)


def measured(value: float, uncertainty: float, unit: str | None = None, digits: int = DIGITS) -> str:
    """``value ± uncertainty`` by the GUM's rule: ``measured(33.2085, 2.02636, "°")`` is
    ``33.2 ± 2.0°``. An uncertainty of zero is ``± 0`` (the value keeps
    :data:`FALLBACK` digits); a NaN or infinite one is left out. Very large or small
    numbers share a power of ten: ``(1.23 ± 0.05) × 10⁹ Pa``."""
    try:
        u = abs(float(uncertainty))
    except (TypeError, ValueError):
        u = float("nan")
    if not math.isfinite(u) or not _finite(value):
        return rounded(value, unit=unit)
    places = decimals(u, digits)
    power = _power(value if float(value) != 0 else u)
    if power:
        scale = 10.0 ** -power
        body = measured(float(value) * scale, u * scale, None, digits)
        return with_unit(f"({body}) × 10{str(power).translate(_SUPERSCRIPT)}", unit)
    if places is None:  # u == 0
        return with_unit(f"{_number(value, None)} ± 0", unit)
    return with_unit(f"{_number(value, places)} ± {_fixed(u, places)}", unit)


def ranged(value: float, low: float, high: float, unit: str | None = None) -> tuple[str, str, str]:
    """A calibrated parameter and the ends of its solution set, as text, all to one
    decimal place: the place of the set's width to two significant digits, kept
    between two and three significant digits of the value (:data:`PARAMETER_DIGITS`).
    ``ranged(0.3837, 0.35, 0.42)`` is ``("0.384", "0.350", "0.420")``; without a set
    (NaN ends, or none wide) three significant digits. A very large or small value and its
    ends share its power of ten."""
    if (power := _power(value) if _finite(value) else 0):
        scale, times = 10.0 ** -power, f" × 10{str(power).translate(_SUPERSCRIPT)}"
        texts = ranged(float(value) * scale, float(low) * scale, float(high) * scale)
        return tuple(with_unit(t + times, unit) if t else t for t in texts)
    places = decimals(float(high) - float(low)) if _finite(low) and _finite(high) else None
    if _finite(value) and float(value) != 0:
        order = math.floor(math.log10(abs(float(value))))
        least, most = (d - 1 - order for d in PARAMETER_DIGITS)
        places = most if places is None else min(max(places, least), most)
    elif places is None:
        places = FALLBACK - 1
    ends = [with_unit(_fixed(float(x), places), unit) if _finite(x) else "" for x in (low, high)]
    return with_unit(_number(value, places), unit), ends[0], ends[1]


def _finite(x) -> bool:
    try:
        return math.isfinite(float(x))
    except (TypeError, ValueError):
        return False


def _power(x: float) -> int:
    """The power of ten a number is written with (0: none)."""
    x = abs(float(x))
    if x == 0 or not math.isfinite(x):
        return 0
    order = math.floor(math.log10(x))
    return order if order < LOW or order >= HIGH else 0


def _number(value, places: int | None) -> str:
    """``value`` to ``places`` decimals, :data:`FALLBACK` significant digits if None."""
    try:
        x = float(value)
    except (TypeError, ValueError):
        return str(value)
    if math.isnan(x):
        return "n/a"
    if math.isinf(x):
        return "∞" if x > 0 else "−∞"
    if places is None:
        if x == 0:
            return "0"
        power = _power(x)
        if power:
            return f"{_number(x * 10.0 ** -power, None)} × 10{str(power).translate(_SUPERSCRIPT)}"
        places = FALLBACK - 1 - math.floor(math.log10(abs(x)))
    return _fixed(x, places)


def _fixed(x: float, places: int) -> str:
    """``x`` rounded to ``places`` decimals (negative: to tens, hundreds, ...), no ``-0``."""
    text = f"{x:.{places}f}" if places >= 0 else f"{round(x, places):.0f}"
    return text.lstrip("-") if float(text) == 0 else text
