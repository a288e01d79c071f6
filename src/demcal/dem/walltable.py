"""The engine's copy of the walls: their rows as arrays, kept in step with the
:class:`~demcal.geometry.WallSet` the user builds and moves.

The wall set (``demcal.geometry``) describes the walls and their motions; the engine
evaluates contacts against :class:`WallRows`, one row per wall primitive (row layouts in
:mod:`demcal.geometry.kernels`). :class:`WallTable` copies the rows in, places moving
walls at a time, notices a wall set changed between runs (``WallSet.set_motion``,
``WallSet.remove``) and renumbers the wall contacts when rows go.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from demcal.errors import ConfigError
from demcal.geometry.kernels import CONE, CYLINDER, DISK
from demcal.geometry.placement import ROTATION, TRANSLATION

from .forces import wall_totals
from .storage import ContactList


class WallRows(NamedTuple):
    """One row per wall primitive: ``kind``, ``params`` (16 floats), ``velocity``
    [m/s], ``omega`` [rad/s], ``origin`` [m] (what the torque is taken about),
    ``aabb`` [m], ``material``, ``group`` (the wall it belongs to) and ``id`` (the
    wall set's stable row id)."""

    kind: np.ndarray
    params: np.ndarray
    velocity: np.ndarray
    omega: np.ndarray
    origin: np.ndarray
    aabb: np.ndarray
    material: np.ndarray
    group: np.ndarray
    id: np.ndarray

    @classmethod
    def none(cls) -> "WallRows":
        return cls(kind=np.zeros(0, np.int32), params=np.zeros((0, 16)),
                   velocity=np.zeros((0, 3)), omega=np.zeros((0, 3)),
                   origin=np.zeros((0, 3)), aabb=np.zeros((0, 6)),
                   material=np.zeros(0, np.int32), group=np.zeros(0, np.int32),
                   id=np.zeros(0, np.int64))

    @classmethod
    def of(cls, w) -> "WallRows":
        return cls(kind=np.ascontiguousarray(w.kind, dtype=np.int64),
                   params=np.ascontiguousarray(w.params, dtype=float),
                   velocity=np.ascontiguousarray(w.velocity, dtype=float),
                   omega=np.ascontiguousarray(w.omega, dtype=float),
                   origin=np.ascontiguousarray(w.origin, dtype=float),
                   aabb=np.ascontiguousarray(w.aabb, dtype=float),
                   material=np.ascontiguousarray(w.material, dtype=np.int64),
                   group=np.ascontiguousarray(w.group, dtype=np.int64),
                   id=np.array(getattr(w, "row_id", np.arange(len(w.kind))),
                               dtype=np.int64))

    @property
    def n(self) -> int:
        return self.kind.shape[0]


class WallTable:
    """The rows of ``walls`` (a WallSet, or None) as the engine sees them."""

    def __init__(self, walls, time: float, materials):
        """``materials``: the simulation's
        :class:`~demcal.particles.materials.MaterialTable`, which resolves each wall's
        material, a name or an index."""
        self.walls = walls
        if walls is not None and hasattr(walls, "resolve_materials"):
            try:
                walls.resolve_materials(materials.index)
            except ConfigError as err:
                raise ConfigError(f"a wall's material: {err}") from None
        self.load(time)

    def load(self, time: float) -> None:
        """Copy every row of the wall set (placed at ``time``)."""
        w = self.walls
        if w is None:
            self.rows = WallRows.none()
            self.moving = False
            self.version = 0
            self.names = []
            return
        if w.moving:
            w.update(time)
        self.rows = WallRows.of(w)
        self.moving = bool(w.moving)
        self.version = getattr(w, "version", 0)
        self.names = list(getattr(w, "names", []))

    def place(self, time: float) -> None:
        """Move the walls to ``time`` and copy their rows into the engine."""
        w = self.walls
        w.update(time)
        for key in ("params", "velocity", "omega", "origin", "aabb"):
            getattr(self.rows, key)[...] = getattr(w, key)

    def compiled_motions(self):
        """The compiled loop's table of walls it places itself (constant-velocity
        translations and constant-rate rotations, ``WallSet.compiled_motions``), or None
        when some moving wall must be placed from Python before every step (a function
        of time)."""
        w = self.walls
        nw = self.rows.n
        if (self.moving and w is not None
                and any(g.motion.moving for g in getattr(w, "walls", ()))):
            return w.compiled_motions() if hasattr(w, "compiled_motions") else None
        return (np.zeros(nw, np.int64), np.zeros((nw, 3)), np.zeros(nw), np.zeros(nw),
                np.zeros((nw, 16)), np.zeros((nw, 3)), np.zeros((nw, 3)), np.zeros((nw, 3)),
                np.zeros(nw))

    def speed(self, sphere_pos, skin, moves=None) -> float:
        """Upper bound of the speed [m/s] at which any wall surface within reach of a
        sphere moves (what may bring it within the skin). A row the compiled loop moves
        counts with its motion, moving yet or not: a translation's velocity, a
        rotation's angular velocity about its axis point, except a disk, cylinder or
        cone turning about its own axis, whose surface stays where it is."""
        vel = self.rows.velocity
        om = self.rows.omega
        centre = self.rows.origin
        if moves is not None and moves[0].any():
            tr = moves[0] == TRANSLATION
            ro = moves[0] == ROTATION
            vel, om, centre = vel.copy(), om.copy(), centre.copy()
            vel[tr] = moves[1][tr]
            vel[ro] = 0.0
            om[ro] = moves[8][ro, None] * moves[6][ro]
            om[ro & self._turns_in_place(moves)] = 0.0
            centre[ro] = moves[7][ro]
        if not vel.size or not (np.any(vel) or np.any(om)):
            return 0.0
        lo, hi = sphere_pos.min(axis=0), sphere_pos.max(axis=0)
        corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                            for z in (lo[2], hi[2])])
        reach = np.linalg.norm(corners[None, :, :] - centre[:, None, :],
                               axis=2).max(axis=1) + skin
        speed = np.linalg.norm(vel, axis=1) + np.linalg.norm(om, axis=1) * reach
        return float(speed.max())

    def _turns_in_place(self, moves) -> np.ndarray:
        """Rows a rotation maps onto themselves: a disk, cylinder or cone whose axis is
        the rotation's axis (a drum turning about its own axis). Their surface does not
        move, so they add nothing to the travel that triggers a neighbour rebuild."""
        rows = self.rows
        axis, point = moves[6], moves[7]
        own = rows.params[:, 3:6]
        along = np.linalg.norm(np.cross(own, axis), axis=1) < 1e-12
        on_axis = np.linalg.norm(np.cross(rows.params[:, 0:3] - point, axis), axis=1) < 1e-12
        return np.isin(rows.kind, (DISK, CYLINDER, CONE)) & along & on_axis

    def changed(self) -> bool:
        """Whether the wall set changed since the rows were last taken."""
        w = self.walls
        return w is not None and getattr(w, "version", 0) != self.version

    def sync(self, contacts: ContactList, time: float) -> None:
        """Take a changed wall set's rows (see :meth:`changed`): when rows were removed
        or added, point the wall contacts at their rows' new numbers first."""
        w = self.walls
        ids = getattr(w, "row_id", None)
        if ids is not None and not np.array_equal(ids, self.rows.id):
            self._renumber(contacts, np.asarray(ids, dtype=np.int64))
            self.load(time)
        else:
            self.version = w.version
            self.moving = bool(w.moving)
            self.place(time)

    def _renumber(self, contacts: ContactList, ids) -> None:
        """The wall rows are now those of ``ids`` (their ``row_id``s, in order): point
        the wall contacts at their rows' new numbers, and mark the contacts with a row
        that is gone (-1, inactive), so that the next rebuild drops their history."""
        old = self.rows.id
        lookup = np.full(max(old.max(initial=-1), ids.max(initial=-1)) + 1, -1, np.int64)
        lookup[ids] = np.arange(ids.size)
        nq = contacts.size
        wid = contacts.other[:nq]
        gone = wid < 0                # a row removed before, not rebuilt since
        wid[...] = np.where(gone, -1, lookup[old[np.where(gone, 0, wid)]])
        contacts.act[:nq] &= wid >= 0

    def group_names(self) -> list:
        groups = self.rows.group
        return self.names or [f"wall{g}" for g in range(int(groups.max()) + 1
                                                        if self.rows.n else 0)]

    def forces(self, contacts: ContactList, valid: bool) -> dict:
        """``{group name: (force (3,), torque (3,))}`` on each wall group from the wall
        contacts' outputs (zero until the forces have been evaluated: ``valid``)."""
        rows = self.rows
        out = np.zeros((rows.n, 6))
        if rows.n and contacts.start.shape[0] > 1 and valid:
            wall_totals(contacts.start, contacts.other, contacts.out, contacts.act, rows.n, out)
        return {name: (out[rows.group == g, :3].sum(axis=0),
                       out[rows.group == g, 3:].sum(axis=0))
                for g, name in enumerate(self.group_names())}
