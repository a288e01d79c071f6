"""The engine's spatial order of the particles, and the user's.

Particles are reordered in space (cell order, as LIGGGHTS' ``atom_modify sort``) so that
neighbours in space become neighbours in memory. Users never see it: they number the
particles in insertion order, the *user order*. :class:`Ordering` keeps the permutation
between the two and the renumbering the next neighbour rebuild must carry the contact
history through (``old_of_new``: new sphere -> old sphere, -1 for a new one).

Users read the particles through :meth:`Ordering.view`: copies gathered in user order,
so reading never reorders the engine and the next run needs no re-sort. The fields of
:data:`WRITABLE` stay writable, and :meth:`Ordering.write_back` scatters them into the
engine's arrays before the next step. Only a change of the particle set (adding,
removing) puts the arrays themselves in user order (:meth:`Ordering.release`).
"""

from __future__ import annotations

import numpy as np

from .storage import State, Store

#: The fields of a :class:`~demcal.dem.storage.State` a user may write (State field ->
#: engine field): the next run starts from the values written into them.
WRITABLE = {"positions": "pos", "velocities": "vel", "omegas": "omega",
            "quaternions": "quat", "angular_momenta": "angmom", "fixed": "fixed"}


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
    in user order but the engine keeps its sort (to be redone before the next step):
    only after a checkpoint of format 4 or older, which kept the arrays in user order.
    """

    def __init__(self):
        self.perm = None
        self.old_of_new = None     # renumbering pending for the next rebuild
        self.user_view = False
        self._carry_engine = None  # the engine view's old_of_new during a user view
        self.last_sort = None      # step of the last sort
        self.sorts = 0             # spatial reorderings done
        self._inverse = None       # (perm, user -> engine bodies, spheres), see user_index

    # -- queries --------------------------------------------------------------------
    def sort_due(self, n_spheres, step, threshold, interval) -> bool:
        return n_spheres >= threshold and (self.last_sort is None
                                           or step - self.last_sort >= interval)

    def sort_step(self, n_spheres, step, threshold, interval) -> float:
        """The first step count, from ``step`` on, at which :meth:`sort_due` holds (inf:
        never, for fewer than ``threshold`` spheres)."""
        if n_spheres < threshold:
            return float("inf")
        if self.last_sort is None:
            return step
        return max(step, self.last_sort + interval)

    def user_index(self):
        """``(bodies, spheres)``: the engine index of each user index, or None while the
        arrays are in user order."""
        if self.perm is None or self.user_view:
            return None
        if self._inverse is None or self._inverse[0] is not self.perm:
            inverse = []
            for perm in self.perm:
                inv = np.empty_like(perm)
                inv[perm] = np.arange(perm.size)
                inverse.append(inv)
            self._inverse = (self.perm, *inverse)
        return self._inverse[1:]

    # -- what users see -------------------------------------------------------------------
    def view(self, store: Store, time: float, step: int) -> State:
        """The particles in user order, as copies (the engine's arrays are untouched);
        the fields of :data:`WRITABLE` writable, the others read-only."""
        index = self.user_index()
        b, s = store.bodies, store.spheres
        if index is None:
            bodies, spheres = (lambda a: a.copy()), (lambda a: a.copy())
            body = s.body.copy()
        else:
            bodies, spheres = (lambda a: a[index[0]]), (lambda a: a[index[1]])
            body = self.perm[0][s.body[index[1]]]
        state = State(positions=bodies(b.pos), velocities=bodies(b.vel),
                      omegas=bodies(b.omega), quaternions=bodies(b.quat),
                      angular_momenta=bodies(b.angmom), forces=bodies(b.force),
                      torques=bodies(b.torque), masses=bodies(b.mass),
                      inertias=bodies(b.inertia), materials=bodies(b.mat),
                      templates=bodies(b.template), scales=bodies(b.scale),
                      fixed=bodies(b.fixed), sphere_positions=spheres(s.pos),
                      radii=spheres(s.radius), sphere_body=body, time=time, step=step)
        for name, value in vars(state).items():
            if isinstance(value, np.ndarray) and name not in WRITABLE:
                value.flags.writeable = False
        return state

    def write_back(self, store: Store, state: State) -> None:
        """Copy the writable fields of ``state`` (made by :meth:`view` with this order)
        into the engine's arrays."""
        index = self.user_index()
        for name, field in WRITABLE.items():
            engine = getattr(store.bodies, field)
            if index is None:
                engine[...] = getattr(state, name)
            else:
                engine[index[0]] = getattr(state, name)

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

    def to_engine(self, store: Store) -> None:
        """Redo the engine's sort over arrays restored in user order (``user_view``, a
        checkpoint of format 4 or older); the lists stay valid."""
        if not self.user_view:
            return
        store.permute(self.perm[0])
        self.old_of_new = self._carry_engine
        self._carry_engine = None
        self.user_view = False

    def release(self, store: Store) -> None:
        """The particle set is about to change: the user order becomes the engine's
        order (the next rebuild carries the contacts over through ``old_of_new``)."""
        if self.perm is not None and not self.user_view:
            self._renumbered(store.permute(self.user_index()[0]))
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
                   carry_engine=self._carry_engine, old_of_new=self.old_of_new,
                   user_view=np.asarray(self.user_view))
        return {k: v for k, v in out.items() if v is not None}

    def restore(self, arrays: dict, last_sort) -> None:
        """Restore from :meth:`arrays` (missing keys: not set) and the last sort's step.
        Without ``user_view`` (format 4 and older) a sorted store is in user order."""
        self.old_of_new = arrays.get("old_of_new")
        self.perm = (None if arrays.get("perm_b") is None
                     else (arrays["perm_b"], arrays["perm_s"]))
        self.user_view = (bool(arrays["user_view"]) if "user_view" in arrays
                          else self.perm is not None)
        self._carry_engine = arrays.get("carry_engine")
        self.last_sort = last_sort


class UserView:
    """The :class:`~demcal.dem.storage.State` handed out by ``sim.state``: one object per
    step and particle set (``key``), written back into the engine before it steps."""

    def __init__(self, ordering: Ordering):
        self.ordering = ordering
        self._view = None   # (key, State)

    def state(self, store: Store, time: float, step: int, key) -> State:
        if self._view is None or self._view[0] != key:
            self.close(store)
            self._view = (key, self.ordering.view(store, time, step))
        return self._view[1]

    def close(self, store: Store, keep: bool = False) -> None:
        """Take what was written into the state into ``store``; unless ``keep``, the
        state becomes a read-only record of its step."""
        if self._view is None:
            return
        state = self._view[1]
        self.ordering.write_back(store, state)
        if not keep:
            self._view = None
            for name in WRITABLE:
                getattr(state, name).flags.writeable = False

    def contacts(self, pairs):
        """``(i, j, force on i)`` of the touching pairs of a contact list, the spheres in
        user order. The list is numbered as the arrays were at its last rebuild: when
        particles were added or removed since (``old_of_new`` pending), its spheres are
        renumbered through that, and the pairs of removed spheres left out."""
        o = self.ordering
        rows = np.repeat(np.arange(pairs.start.shape[0] - 1), np.diff(pairs.start))
        active = pairs.act[:pairs.size]
        i, j = rows[active], pairs.other[:pairs.size][active]
        force = pairs.out[:pairs.size][active, :3]
        if o.old_of_new is not None:
            now_of_list = np.full(pairs.start.shape[0] - 1, -1, np.int64)
            kept = o.old_of_new >= 0
            now_of_list[o.old_of_new[kept]] = np.nonzero(kept)[0]
            i, j = now_of_list[i], now_of_list[j]
            both = (i >= 0) & (j >= 0)
            i, j, force = i[both], j[both], force[both]
        if o.perm is not None and not o.user_view:
            i, j = o.perm[1][i], o.perm[1][j]
        return i, j, force
