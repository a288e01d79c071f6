"""The engine's spatial order of the particles, and the user's.

Particles are reordered in space (cell order, as LIGGGHTS' ``atom_modify sort``) so that
neighbours in space become neighbours in memory. Users never see it: they number the
particles in insertion order, the *user order*. :class:`Ordering` keeps the permutation
between the two, the renumbering the next neighbour rebuild must carry the contact
history through (``old_of_new``: new sphere -> old sphere, -1 for a new one), and puts
the arrays of a :class:`~demcal.dem.storage.Store` in either order *in place*, so that
views handed to users stay live.
"""

from __future__ import annotations

import numpy as np

from .storage import Store


def _closed_up(perm, kept):
    """``perm`` (engine index -> user index) over the kept entries, with the user indices
    of the kept entries renumbered 0, 1, ... in their order."""
    user_kept = np.zeros(perm.size, bool)
    user_kept[perm[kept]] = True
    rank = np.cumsum(user_kept) - 1
    return rank[perm[kept]]


class Ordering:
    """Engine order vs user order of one store's bodies and spheres.

    ``perm`` is None while the engine order is the user order, else ``(bodies,
    spheres)``: engine index -> user index. ``user_view`` is true while the arrays are
    in user order but the engine keeps its sort (to be redone before the next step).
    """

    def __init__(self):
        self.perm = None
        self.old_of_new = None     # renumbering pending for the next rebuild
        self.user_view = False
        self._carry_engine = None  # the engine view's old_of_new during a user view
        self.last_sort = None      # step of the last sort
        self.sorts = 0             # spatial reorderings done

    # -- queries --------------------------------------------------------------------
    def sort_due(self, n_spheres, step, threshold, interval) -> bool:
        return n_spheres >= threshold and (self.last_sort is None
                                           or step - self.last_sort >= interval)

    def user_spheres(self, i):
        """User indices of engine sphere indices ``i`` (while the engine order holds)."""
        return i if self.perm is None else self.perm[1][i]

    # -- changes ----------------------------------------------------------------------
    def _renumbered(self, sorder):
        prev = self.old_of_new
        self.old_of_new = sorder if prev is None else prev[sorder]

    def sort(self, store: Store, cell: float, step: int) -> None:
        """Sort the bodies by the cell (side ``cell`` [m]) of their centre of mass."""
        pos = store.bodies.pos
        key = np.floor((pos - pos.min(axis=0)) / cell).astype(np.int64)
        dims = key.max(axis=0) + 1
        border = np.argsort(key[:, 0] + dims[0] * (key[:, 1] + dims[1] * key[:, 2]),
                            kind="stable")
        self.last_sort = step
        if np.array_equal(border, np.arange(border.size)):
            return
        sorder = store.permute(border)
        self.sorts += 1
        self._renumbered(sorder)
        if self.perm is None:
            self.perm = (border, sorder)
        else:
            self.perm = (self.perm[0][border], self.perm[1][sorder])

    def to_user(self, store: Store) -> None:
        """Put the arrays in user order (a no-op unless the engine has sorted them)."""
        if self.perm is None or self.user_view:
            return
        sorder = store.permute(np.argsort(self.perm[0]))
        self._carry_engine = self.old_of_new
        self._renumbered(sorder)
        self.user_view = True

    def to_engine(self, store: Store) -> None:
        """Redo the engine's sort after :meth:`to_user` (the lists stay valid)."""
        if not self.user_view:
            return
        store.permute(self.perm[0])
        self.old_of_new = self._carry_engine
        self._carry_engine = None
        self.user_view = False

    def release(self, store: Store) -> None:
        """The particle set is about to change: the user order becomes the engine's
        order (the next rebuild carries the contacts over through ``old_of_new``)."""
        self.to_user(store)
        self.perm = None
        self.user_view = False
        self._carry_engine = None

    def added(self, n_spheres: int) -> None:
        """``n_spheres`` new spheres at the end: they have no old contacts."""
        if self.old_of_new is not None:
            self.old_of_new = np.concatenate([self.old_of_new,
                                              np.full(n_spheres, -1, np.int64)])

    def kept(self, keep, skeep, old_sphere) -> None:
        """Bodies ``keep`` (spheres ``skeep``, old index of each kept sphere
        ``old_sphere``) stay, the others are gone."""
        self._renumbered(old_sphere)
        if self.perm is not None:
            # the user numbering closes up in order over the particles that stay
            self.perm = tuple(_closed_up(perm, k) for perm, k in zip(self.perm,
                                                                     (keep, skeep)))

    def rebuilt(self) -> None:
        """The lists were rebuilt: no renumbering is pending any more."""
        self.old_of_new = None

    # -- checkpoints ----------------------------------------------------------------------
    def arrays(self) -> dict:
        """The arrays a checkpoint keeps (only those set)."""
        out = dict(perm_b=None if self.perm is None else self.perm[0],
                   perm_s=None if self.perm is None else self.perm[1],
                   carry_engine=self._carry_engine, old_of_new=self.old_of_new)
        return {k: v for k, v in out.items() if v is not None}

    def restore(self, arrays: dict, last_sort) -> None:
        """Restore from :meth:`arrays` (missing keys: not set) and the last sort's step."""
        self.old_of_new = arrays.get("old_of_new")
        self.perm = (None if arrays.get("perm_b") is None
                     else (arrays["perm_b"], arrays["perm_s"]))
        self.user_view = self.perm is not None
        self._carry_engine = arrays.get("carry_engine")
        self.last_sort = last_sort
