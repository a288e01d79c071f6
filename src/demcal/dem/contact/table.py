"""The pair table: one row of constants per material pair, laid out from the declarations.

Column ``c`` of a row is the declared entry ``declare.COLUMNS[c]``: an interaction
coefficient (taken from the pair's :class:`~demcal.particles.materials.Interaction`,
checked against its declared range) or a pair constant (derived from the two materials
by its mixing rule). The kernels read ``table[mi, mj, P_X]``.
"""

from __future__ import annotations

import numpy as np

from demcal.errors import ConfigError
from demcal.particles.materials import Interaction

from . import registry  # every sub-model is declared before the columns are read
from .declare import COLUMNS, Coefficient


def coefficient_names() -> tuple:
    """Every interaction coefficient some sub-model declares."""
    return tuple(c.name for c in COLUMNS if isinstance(c, Coefficient))


def declared_coefficient(name: str) -> Coefficient:
    for c in COLUMNS:
        if isinstance(c, Coefficient) and c.name == name:
            return c
    raise KeyError(name)


def pair_row(mi, mj, it, chosen=None) -> np.ndarray:
    """Engine constants for one material pair (materials ``mi``, ``mj``, interaction
    ``it``); ConfigError (one sentence) for a coefficient no sub-model declares or out
    of its range. ``chosen``: the contact model's sub-models (a constant declared
    ``chosen_only`` is 0 unless one of them declares it; all are derived where None)."""
    declared = None if chosen is None else {c.name for m in chosen for c in m.constants}
    known = coefficient_names()
    for name, _ in it.coefficients:
        if name not in known:
            raise ConfigError(f"unknown interaction coefficient {name!r}; the contact "
                              f"sub-models read {sorted(known)}.")
    row = np.zeros(len(COLUMNS))
    for c in COLUMNS:
        if isinstance(c, Coefficient):
            row[c.column] = c.check(it.value(c.name, c.default))
        elif not c.chosen_only or declared is None or c.name in declared:
            row[c.column] = c.derive(mi, mj, it)
    return row


def pair_table(material_table, model=None) -> np.ndarray:
    """float64[nmat, nmat, len(COLUMNS)] of a
    :class:`~demcal.particles.materials.MaterialTable` for the
    :class:`~demcal.dem.contact.registry.ContactModel` ``model`` (see :func:`pair_row`)."""
    chosen = None if model is None else model.submodels()
    mats = material_table.materials
    n = len(mats)
    tab = np.zeros((n, n, len(COLUMNS)))
    for i in range(n):
        for j in range(n):
            # a pair left out never meets (MaterialTable.check_meets): the engine's
            # default interaction fills its row
            it = material_table.interaction(i, j)
            tab[i, j] = pair_row(mats[i], mats[j], Interaction() if it is None else it, chosen)
    return tab


def largest_reach(normal_id: int, table: np.ndarray, r_max: float) -> float:
    """The largest gap [m] a contact of the normal sub-model ``normal_id`` holds across,
    over every material pair, for spheres up to ``r_max`` [m] (the neighbour skin must
    exceed it); 0 for sub-models that act only while touching."""
    rule = registry.submodel("normal", int(normal_id)).reach
    if rule is None or r_max <= 0.0:
        return 0.0
    n = table.shape[0]
    return max(float(rule(table[i, j], r_max)) for i in range(n) for j in range(n))
