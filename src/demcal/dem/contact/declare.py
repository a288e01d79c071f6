"""What a contact sub-model declares about itself (LAMMPS GRANULAR's pattern).

A contact model is one sub-model per slot (``normal``, ``damping``, ``tangential``,
``rolling``). Each sub-model is a :class:`SubModel` row next to its kernel, and the rest
of the engine reads these rows instead of knowing the sub-models by name:

* its **coefficients** (:class:`Coefficient`: name, unit, physical range, default, the
  range the bench settings offer): one value per material pair, EDEM's interaction
  table. ``Interaction(...)`` takes them by name; :mod:`.table` checks them and lays
  out the pair table; the bench tests offer ``particle.<name>``, ``wall.<name>`` and
  ``film.<name>`` settings for each;
* the **pair constants** it derives from the two materials and the interaction
  (:class:`PairConstant`, with the mixing rule in words), also pair-table columns;
* its **history** (:class:`HistoryField`, a 3-vector turned into the tangent plane and
  negated when the two sides swap, or a scalar), laid out in the history rows by
  :mod:`.registry`;
* whether it **acts beyond touching** (``reach``: the gap [m] up to which an existing
  contact holds, a function of the pair row and R*), which the touch test, the
  neighbour skin and the lists use;
* the **other slots' sub-models it fits with** (``requires``), checked when a
  :class:`~demcal.dem.contact.registry.ContactModel` is resolved;
* for a normal sub-model, the **contact-duration rule** of the automatic time step
  (``contact_time``) and whether the Rayleigh time bounds the step too.

The critical normal force that caps friction and rolling resistance is a kernel
function of the normal slot (``normal.critical_force``), since it runs per contact.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

from demcal.errors import ConfigError

#: numba's ``fastmath`` for every compiled function of the engine (the contact kernels,
#: the contact loops of ``dem/forces.py`` into which they are inlined, the geometry
#: kernels): none. Each licence lets LLVM pick the arithmetic per instruction set:
#: ``contract`` fuses a multiply and an add into one FMA where the target has it,
#: ``reassoc`` reorders sums to fill the vector registers the target has, ``arcp`` turns
#: a division into a reciprocal estimate and a multiply, ``nsz`` folds expressions whose
#: zero's sign then depends on what was folded. Without them every operation rounds as
#: written, so the bits are the same for every x86-64 compile target
#: (``NUMBA_CPU_NAME=generic``, ``haswell``, ``znver2``, unset) as well as for every
#: thread count (docs/performance.md, "Portable bits"; tests/dem/test_portable_bits.py).
FASTMATH = False

SLOTS = ("normal", "damping", "tangential", "rolling")

#: Every pair-table column declared so far (coefficients and pair constants), in the
#: order of declaration: a declaration takes the next column when it is made, so the
#: kernels can read ``table[mi, mj, X.column]`` with ``X.column`` a compile-time
#: constant, wherever X is declared.
COLUMNS: list = []


def _take_column(entry) -> None:
    if any(c.name == entry.name for c in COLUMNS):
        raise ValueError(f"pair-table column {entry.name!r} declared twice")
    object.__setattr__(entry, "column", len(COLUMNS))
    COLUMNS.append(entry)


@dataclass(frozen=True)
class Coefficient:
    """An interaction coefficient (one value per material pair) a sub-model reads.

    ``low``/``high`` bound the physical values (``low_open``: ``low`` itself excluded);
    ``bench`` is the (low, high) the bench settings accept (the physical range where
    None).
    """

    name: str
    unit: str
    default: float
    low: float
    high: float = math.inf
    low_open: bool = False
    bench: tuple | None = None
    doc: str = ""

    def __post_init__(self):
        _take_column(self)

    def check(self, value) -> float:
        """``value`` as a float; ConfigError (one sentence) outside the range."""
        try:
            x = float(value)
        except (TypeError, ValueError):
            raise ConfigError(f"{self.name} must be a number, got {value!r}.") from None
        if not math.isfinite(x):
            raise ConfigError(f"{self.name} must be a finite number, got {value!r}.")
        below = x <= self.low if self.low_open else x < self.low
        if below or x > self.high:
            lo = "(" if self.low_open else "["
            hi = f"{self.high:g}]" if math.isfinite(self.high) else "inf)"
            unit = f" {self.unit}" if self.unit != "-" else ""
            raise ConfigError(f"{self.name} must be in {lo}{self.low:g}, {hi}{unit}, "
                              f"got {x:g}.")
        return x

    @property
    def bench_range(self) -> tuple:
        return self.bench if self.bench is not None else (self.low, self.high)


@dataclass(frozen=True)
class PairConstant:
    """A per-pair constant derived from the two materials and their interaction,
    ``derive(material_i, material_j, interaction) -> float``; ``rule`` says how in
    words (the mixing rule, with its source)."""

    name: str
    unit: str
    derive: Callable
    rule: str = ""
    #: derived only where a chosen sub-model declares it, 0 in every other pair table:
    #: a term a kernel may then add without asking which sub-model is chosen
    chosen_only: bool = False

    def __post_init__(self):
        _take_column(self)


@dataclass(frozen=True)
class HistoryField:
    """A per-contact history entry: a 3-vector of side i (turned into the current
    tangent plane by the kernel, negated when a reordering swaps the two sides) or a
    scalar."""

    name: str
    unit: str
    vector: bool

    @property
    def width(self) -> int:
        return 3 if self.vector else 1


@dataclass(frozen=True)
class SubModel:
    """One sub-model of one slot, as the engine sees it (see the module docstring).

    ``id`` is the integer the kernels dispatch on (unique within the slot); ``reach``
    (``(row, r_eff) -> m``, vectorised over numpy arrays) is None for a model that acts
    only while the surfaces overlap; ``contact_time`` (``(row, r_eff, m_eff, speed) ->
    s``) and ``rayleigh_bound`` matter for normal sub-models only. ``requires`` lists
    ``(slot, names)`` pairs: the other slots' sub-models this one fits with (any where
    a slot is not named).
    """

    slot: str
    name: str
    id: int
    aliases: tuple = ()
    coefficients: tuple = ()
    constants: tuple = ()
    history: tuple = ()
    reach: Callable | None = None
    contact_time: Callable | None = None
    rayleigh_bound: bool = False
    requires: tuple = ()
    source: str = ""

    def __post_init__(self):
        if self.slot not in SLOTS:
            raise ValueError(f"unknown slot {self.slot!r}")

    @property
    def names(self) -> tuple:
        return (self.name,) + tuple(self.aliases)

    @property
    def acts_beyond_touch(self) -> bool:
        return self.reach is not None
