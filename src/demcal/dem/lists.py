"""Building the contact lists: candidates within the skin, history carried over.

A rebuild finds, for every sphere, the spheres (of other bodies) and the wall rows
within ``skin`` (cell search, :mod:`demcal.dem.neighbours`), packs them into a fresh
:class:`~demcal.dem.storage.ContactList` and carries each touching contact's history
over from the old list through the renumbering since (``old_of_new``: new sphere ->
old sphere). Scratch widths grow as needed and are kept between rebuilds.
"""

from __future__ import annotations

import numpy as np

from demcal.errors import ConfigError

from . import neighbours as _nl
from .contact.registry import H_FLAG, HIST_WIDTH
from .contact.table import largest_reach
from .forces import OUT_WIDTH, PAIR_OUT_WIDTH
from .storage import ContactList, Store


def skin(description, r_max: float | None) -> float:
    """Neighbour skin [m] of a simulation whose largest sphere radius is ``r_max`` (None:
    no spheres yet): the one given, or half the largest radius; at least twice the gap a
    cohesive contact holds across (its declared reach), since a contact must stay in the
    lists until it opens. ConfigError when a given skin does not exceed that gap."""
    d = description
    if r_max is None:
        return 0.0 if d.skin is None else d.skin
    reach = largest_reach(d.models[0], d.table, r_max)
    if d.skin is not None:
        if reach > 0.0 and d.skin <= reach:
            raise ConfigError(
                f"skin = {d.skin:.3g} m is not larger than the gap of {reach:.3g} m a "
                f"{d.contact_model.normal} contact holds across; use skin > "
                f"{reach:.3g} m or leave it unset.")
        return d.skin
    return max(0.5 * r_max, 2.0 * reach)


class ListBuilder:
    """Rebuilds a store's two contact lists on a backend (which runs the searches)."""

    def __init__(self, backend):
        self.backend = backend
        self.row_width = 16    # scratch width of the pair search (grows as needed)
        self.wall_width = 4    # the same for the wall search
        self._spare = None     # the pair list before last, reused when large enough

    def _search(self, kernel, width_attr, nb, ns, start, *args):
        """Run a one-pass neighbour search ``kernel(*args, tmp, counts, lo, hi)`` into a
        scratch table of width ``self.<width_attr>``, widening it and searching again when
        a row did not fit; leaves the counts in ``start[1:]`` and returns the table."""
        counts = start[1:]
        while True:
            width = getattr(self, width_attr)
            tmp = np.empty((ns, width), np.int64)
            self.backend.map_range(nb, kernel, ns, *args, tmp, counts)
            longest = int(counts.max()) if ns else 0
            if longest <= width:
                return tmp
            setattr(self, width_attr, int(1.25 * longest) + 1)

    def rebuild(self, store: Store, skin: float, walls, old_of_new) -> None:
        """New pair and wall lists for ``store`` (``walls``: the engine's wall rows)."""
        s = store.spheres
        ns, nb = s.n, store.bodies.n
        old_p, old_q = store.pairs, store.walls
        if old_of_new is None:
            old_of_new = np.arange(ns, dtype=np.int64)
            old_of_new[old_of_new >= old_p.start.shape[0] - 1] = -1
        start = np.zeros(ns + 1, np.int64)
        if ns:
            max_cells = max(8 * ns, 1000)
            lo, h, dims, rmax, cell_start, cell_order = _nl.build_cells(
                s.pos, s.radius, skin, max_cells)
            tmp = self._search(_nl.pair_rows, "row_width", nb, ns, start, s.pos, s.radius,
                               s.body, skin, lo, h, dims, rmax, cell_start, cell_order)
        npair = _nl.prefix_sum(start)
        cap = old_p.capacity
        if npair > cap:
            cap = _nl.grown(cap, npair)
        spare = self._spare
        if spare is not None and spare.capacity >= cap:
            new_p = spare._replace(start=start)
        else:
            new_p = ContactList(start, np.empty(cap, np.int64), np.empty((cap, HIST_WIDTH)),
                                np.zeros((cap, PAIR_OUT_WIDTH)), np.zeros(cap, np.bool_))
        if ns:
            run = self.backend.map_range
            run(nb, _nl.pack_rows, ns, tmp, start, new_p.other)
            run(nb, _nl.carry_history, ns, start, new_p.other, new_p.hist, old_p.start,
                old_p.other, old_p.hist, old_of_new, True)
            run(nb, _nl.touching_last, ns, start, new_p.other, new_p.hist)
        new_p.act[:npair] = new_p.hist[:npair, H_FLAG] != 0.0
        new_p.act[npair:] = False
        self._spare = old_p if old_p.capacity >= cap else None
        # walls
        wstart = np.zeros(ns + 1, np.int64)
        if ns:
            wtmp = self._search(_nl.wall_rows, "wall_width", nb, ns, wstart, s.pos,
                                s.radius, skin, walls.kind, walls.params, walls.aabb)
        nq = _nl.prefix_sum(wstart)
        wcap = max(old_q.capacity, 0)
        if nq > wcap:
            wcap = _nl.grown(wcap, nq)
        new_q = ContactList(wstart, np.empty(wcap, np.int64), np.empty((wcap, HIST_WIDTH)),
                            np.zeros((wcap, OUT_WIDTH)), np.zeros(wcap, np.bool_))
        if ns:
            self.backend.map_range(nb, _nl.pack_rows, ns, wtmp, wstart, new_q.other)
            self.backend.map_range(nb, _nl.carry_history, ns, wstart, new_q.other,
                                   new_q.hist, old_q.start, old_q.other, old_q.hist,
                                   old_of_new, False)
        new_q.act[:nq] = new_q.hist[:nq, H_FLAG] != 0.0
        store.pairs, store.walls = new_p, new_q
        s.ref[:] = s.pos
        self.backend.lists_changed()

    def forget_spare(self) -> None:
        self._spare = None
