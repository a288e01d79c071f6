"""The chosen sub-models as a compile-time constant of the compiled loops.

The pair and wall drivers (``dem/forces.py``) call every slot's kernel with the slot's
sub-model id, and each kernel branches on it. Read from an array at run time, those ids
leave LLVM a loop over one contact kernel that holds every sub-model of every slot, and
each sub-model added to it made the Hertz path slower (``docs/performance.md``, "Compiled
for the chosen combination": -14 to -19 % on one thread against the loop before the
sub-models declared themselves). Given as constants, the branches of the sub-models not
chosen fold away and the loop compiles as if it had been written for the chosen four.

:class:`Chosen` carries the four ids into numba as part of the *type* of the argument
(``ChosenType(normal, damping, tangential, rolling)``): numba compiles, and caches on
disk like any other signature, one specialisation of each driver and step loop per
combination a process actually runs, and ``chosen.normal`` etc. inside compiled code are
literal integers. numba's ``literally`` would give the same code but types the whole
step loop with plain integers first on every call from Python (milliseconds a call), and
a module generated per combination would need a writable package folder; numba's
extension API (a type with no run-time data, its ids read by ``overload_attribute``) is
the well-kept way, so it is used here.
"""

from __future__ import annotations

from numba import types
from numba.extending import (NativeValue, models, overload_attribute, register_model,
                             unbox)

from .declare import SLOTS


class ChosenType(types.Type):
    """numba type of a :class:`Chosen`: the four ids are part of the type (and of its
    name, which keys numba's dispatch and its on-disk cache)."""

    def __init__(self, ids):
        self.ids = tuple(int(i) for i in ids)
        super().__init__(name="Chosen(%s)" % ", ".join(str(i) for i in self.ids))


class Chosen:
    """The sub-model ids (normal, damping, tangential, rolling) a simulation runs, to be
    passed to the compiled drivers; ``ids`` as a tuple of ints."""

    __slots__ = ("ids", "_numba_type_")

    def __init__(self, ids):
        self.ids = tuple(int(i) for i in ids)
        if len(self.ids) != len(SLOTS):
            raise ValueError(f"one id per slot {SLOTS}, got {ids!r}")
        # numba types an argument from this attribute without a typeof call
        self._numba_type_ = ChosenType(self.ids)

    def __repr__(self) -> str:
        return f"Chosen({self.ids})"

    def __eq__(self, other) -> bool:
        return isinstance(other, Chosen) and other.ids == self.ids

    def __hash__(self) -> int:
        return hash(self.ids)


# no run-time data: the value is a null pointer, everything lives in the type
register_model(ChosenType)(models.OpaqueModel)


@unbox(ChosenType)
def _unbox(typ, obj, c):
    return NativeValue(c.context.get_dummy_value())


def _slot_attribute(k: int):
    def typer(chosen):
        if isinstance(chosen, ChosenType):
            ident = chosen.ids[k]
            return lambda chosen: ident
        return None
    return typer


for _k, _slot in enumerate(SLOTS):
    overload_attribute(ChosenType, _slot, inline="always")(_slot_attribute(_k))
