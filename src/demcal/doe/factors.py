"""Factors of a designed experiment and the coded <-> actual conversion.

A factor is a named quantity varied between a low and a high actual level. Designs and
response surfaces work in *coded* units, where the low level is -1 and the high level +1
(Design-Expert's convention; Montgomery, *Design and Analysis of Experiments*, 8th ed.,
Sec. 6.2)::

    coded = (actual - centre) / half_range,   centre = (low + high) / 2,
    half_range = (high - low) / 2
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

import numpy as np

from demcal.errors import ConfigError

_SPEC = re.compile(
    r"^\s*(?P<name>[A-Za-z_][\w.]*)\s*=\s*(?P<low>[-+0-9.eE]+)\s*:\s*(?P<high>[-+0-9.eE]+)"
    r"\s*(?:\[(?P<units>[^\]]*)\])?\s*$"
)


@dataclass(frozen=True)
class Factor:
    """One experimental factor.

    Parameters
    ----------
    name : str
        Column name, e.g. ``"A"`` or ``"restitution"``.
    low, high : float
        Actual levels coded as -1 and +1 [units of the factor].
    units : str
        Units for display only, e.g. ``"-"`` or ``"Pa"``.
    description : str
        Long name for reports, e.g. ``"coefficient of restitution e"``.
    """

    name: str
    low: float = -1.0
    high: float = 1.0
    units: str = ""
    description: str = ""

    def __post_init__(self):
        if not (math.isfinite(self.low) and math.isfinite(self.high)) or self.high <= self.low:
            raise ConfigError(
                f"factor {self.name!r} needs a low level below its high level "
                f"(got {self.low} and {self.high})."
            )

    @property
    def centre(self) -> float:
        """Actual level coded as 0."""
        return 0.5 * (self.low + self.high)

    @property
    def half_range(self) -> float:
        """Actual distance between coded 0 and coded 1."""
        return 0.5 * (self.high - self.low)

    def to_coded(self, actual):
        """Actual level(s) -> coded level(s)."""
        return (np.asarray(actual, dtype=float) - self.centre) / self.half_range

    def to_actual(self, coded):
        """Coded level(s) -> actual level(s)."""
        return np.asarray(coded, dtype=float) * self.half_range + self.centre

    def describe(self) -> str:
        units = f" [{self.units}]" if self.units else ""
        desc = f" ({self.description})" if self.description else ""
        return f"{self.name}{desc}{units}: {self.low:g} (-1) .. {self.high:g} (+1)"

    @property
    def label(self) -> str:
        """Axis label: description (or name) with units."""
        base = f"{self.description} ({self.name})" if self.description else self.name
        return base + (f" [{self.units}]" if self.units else "")


def parse_factor(spec: str) -> Factor:
    """Parse ``NAME=LOW:HIGH`` or ``NAME=LOW:HIGH[units]`` into a :class:`Factor`.

    >>> parse_factor("e=0.5:0.7")
    Factor(name='e', low=0.5, high=0.7, units='')
    """
    m = _SPEC.match(spec)
    if not m:
        raise ConfigError(
            f"cannot read factor {spec!r}; write it as NAME=LOW:HIGH, e.g. e=0.5:0.7."
        )
    try:
        low, high = float(m["low"]), float(m["high"])
    except ValueError:
        raise ConfigError(
            f"cannot read the levels of factor {spec!r}; write them as numbers, e.g. e=0.5:0.7."
        ) from None
    return Factor(m["name"], low, high, (m["units"] or "").strip())


def default_names(k: int) -> list[str]:
    """Design-Expert's factor letters A, B, C, ... (skipping I, as Design-Expert does)."""
    letters = [c for c in "ABCDEFGHJKLMNOPQRSTUVWXYZ"]
    if k <= len(letters):
        return letters[:k]
    return [f"X{i + 1}" for i in range(k)]


def coded_factors(names) -> list[Factor]:
    """Factors whose actual levels are their coded levels (-1 .. +1)."""
    return [Factor(str(n)) for n in names]
