"""The engine's arrays as named fields: bodies, spheres and contact lists.

Storage only: how the arrays are laid out, grown, compacted and reordered. The engine
keeps them in *engine order* (see :mod:`demcal.dem.ordering`); users see them through
:class:`State`. Each container is a :class:`~typing.NamedTuple` of numpy arrays, which
numba takes as it is (:mod:`demcal.dem.stepper` reads the fields by name), so a kernel's
signature names a handful of containers instead of fifty arrays.

Units are SI. Bodies (one row per rigid particle): ``pos`` [m] (centre of mass), ``vel``
[m/s], ``quat`` (w, x, y, z; principal frame -> world), ``angmom`` [kg m2/s] (world),
``omega`` [rad/s], ``force`` [N] and ``torque`` [N m] of the last evaluation, ``mass``
[kg], ``inertia`` [kg m2] (principal; ``inf`` for a translation-only particle), ``iso``
[kg m2] (mean principal moment, the rolling models' inertia), ``mat`` (material index),
``template`` (template index), ``scale`` (size factor), ``fixed``, ``start`` (CSR: the
spheres of body b are ``start[b]:start[b + 1]``).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .contact.registry import HIST_WIDTH
from .forces import ACC_WIDTH, OUT_WIDTH, PAIR_OUT_WIDTH


class Bodies(NamedTuple):
    """One row per particle (see the module docstring for the fields and units)."""

    pos: np.ndarray
    vel: np.ndarray
    quat: np.ndarray
    angmom: np.ndarray
    omega: np.ndarray
    force: np.ndarray
    torque: np.ndarray
    mass: np.ndarray
    inertia: np.ndarray
    iso: np.ndarray
    mat: np.ndarray
    template: np.ndarray
    scale: np.ndarray
    fixed: np.ndarray
    start: np.ndarray

    @classmethod
    def empty(cls, n: int = 0) -> "Bodies":
        return cls(pos=np.zeros((n, 3)), vel=np.zeros((n, 3)), quat=np.zeros((n, 4)),
                   angmom=np.zeros((n, 3)), omega=np.zeros((n, 3)),
                   force=np.zeros((n, 3)), torque=np.zeros((n, 3)), mass=np.zeros(n),
                   inertia=np.zeros((n, 3)), iso=np.zeros(n), mat=np.zeros(n, np.int64),
                   template=np.zeros(n, np.int64), scale=np.zeros(n),
                   fixed=np.zeros(n, np.bool_), start=np.zeros(n + 1, np.int64))

    @property
    def n(self) -> int:
        return self.pos.shape[0]


class Spheres(NamedTuple):
    """One row per sphere: owning ``body``, ``offset`` from the body's centre of mass in
    the principal frame [m], ``radius`` [m], world ``pos`` [m], ``ref`` (position at the
    last neighbour build [m]), ``dsq`` (scratch: squared move since then [m2]) and
    ``acc`` (force on the sphere and torque on its body, summed per step)."""

    body: np.ndarray
    offset: np.ndarray
    radius: np.ndarray
    pos: np.ndarray
    ref: np.ndarray
    dsq: np.ndarray
    acc: np.ndarray

    @classmethod
    def empty(cls, n: int = 0) -> "Spheres":
        return cls(body=np.zeros(n, np.int64), offset=np.zeros((n, 3)), radius=np.zeros(n),
                   pos=np.zeros((n, 3)), ref=np.zeros((n, 3)), dsq=np.zeros(n),
                   acc=np.zeros((n, ACC_WIDTH)))

    @property
    def n(self) -> int:
        return self.pos.shape[0]


class ContactList(NamedTuple):
    """A contact list in CSR form over the spheres: the candidates of sphere i are slots
    ``start[i]:start[i + 1]``, each naming the ``other`` side (a sphere, or a wall row),
    with its history row (``contact.kernel``'s layout), its output row (the force on i,
    and for walls the torque on the wall) and whether it is touching (``act``)."""

    start: np.ndarray
    other: np.ndarray
    hist: np.ndarray
    out: np.ndarray
    act: np.ndarray

    @classmethod
    def empty(cls, ns: int, capacity: int, out_width: int) -> "ContactList":
        return cls(start=np.zeros(ns + 1, np.int64), other=np.zeros(capacity, np.int64),
                   hist=np.zeros((capacity, HIST_WIDTH)),
                   out=np.zeros((capacity, out_width)), act=np.zeros(capacity, np.bool_))

    @property
    def size(self) -> int:
        """Slots in use."""
        return int(self.start[-1])

    @property
    def capacity(self) -> int:
        return self.other.shape[0]


def empty_pairs(ns: int = 0, capacity: int = 0) -> ContactList:
    return ContactList.empty(ns, capacity, PAIR_OUT_WIDTH)


def empty_wall_contacts(ns: int = 0, capacity: int = 0) -> ContactList:
    return ContactList.empty(ns, capacity, OUT_WIDTH)


@dataclass
class Store:
    """Everything that changes as the simulation runs: bodies, spheres and the two
    contact lists (pairs, sphere-wall)."""

    bodies: Bodies
    spheres: Spheres
    pairs: ContactList
    walls: ContactList

    @classmethod
    def empty(cls) -> "Store":
        return cls(Bodies.empty(), Spheres.empty(), empty_pairs(), empty_wall_contacts())

    @property
    def nbytes(self) -> int:
        """Bytes held by the arrays."""
        return sum(a.nbytes for c in (self.bodies, self.spheres, self.pairs, self.walls)
                   for a in c)

    def append(self, bodies: Bodies, spheres: Spheres) -> None:
        """Add new bodies and their spheres at the end (``bodies.start`` of the new
        ones counted from 0; ``spheres.body`` already the new bodies' final indices).
        The contact lists get empty rows for the new spheres until the next rebuild."""
        b, s = self.bodies, self.spheres
        start = np.concatenate([b.start, s.n + bodies.start[1:]])
        self.bodies = Bodies(*(start if k == "start" else np.concatenate([old, new])
                               for k, old, new in zip(Bodies._fields, b, bodies)))
        # the scratch columns (moves, per-step sums) start from zero for all spheres
        self.spheres = Spheres(*(np.zeros((s.n + spheres.n,) + old.shape[1:])
                                 if k in ("dsq", "acc") else np.concatenate([old, new])
                                 for k, old, new in zip(Spheres._fields, s, spheres)))
        k = spheres.n
        for name in ("pairs", "walls"):
            c = getattr(self, name)
            setattr(self, name, c._replace(start=np.concatenate(
                [c.start, np.full(k, c.start[-1], np.int64)])))

    def keep(self, keep: np.ndarray) -> np.ndarray:
        """Keep the bodies where ``keep`` is true (and their spheres); returns the old
        index of each sphere kept. The contact lists are stale afterwards."""
        b, s = self.bodies, self.spheres
        counts = np.diff(b.start)
        skeep = np.repeat(keep, counts)
        new_start = np.concatenate([[0], np.cumsum(counts[keep])]).astype(np.int64)
        new_body_of_old = np.full(b.n, -1, np.int64)
        new_body_of_old[keep] = np.arange(keep.sum())
        self.bodies = Bodies(*(new_start if k == "start" else v[keep]
                               for k, v in zip(Bodies._fields, b)))
        kept = Spheres(*(v[skeep] for v in s))
        self.spheres = kept._replace(body=new_body_of_old[kept.body])
        return np.nonzero(skeep)[0]

    def permute(self, border: np.ndarray) -> np.ndarray:
        """Reorder the bodies in place so that new body k is old body ``border[k]`` (its
        spheres follow it; views of the arrays stay valid); returns the sphere order
        (new sphere -> old sphere)."""
        b, s = self.bodies, self.spheres
        start = b.start
        counts = np.diff(start)
        c_new = counts[border]
        new_start = np.concatenate([[0], np.cumsum(c_new)]).astype(np.int64)
        sorder = (np.arange(new_start[-1], dtype=np.int64) - np.repeat(new_start[:-1], c_new)
                  + np.repeat(start[:-1][border], c_new))
        new_of_old = np.empty_like(border)
        new_of_old[border] = np.arange(border.size)
        for k, v in zip(Bodies._fields, b):
            v[...] = new_start if k == "start" else v[border]
        for v in s:
            v[...] = v[sorder]
        s.body[...] = new_of_old[s.body]
        return sorder


@dataclass(frozen=True)
class State:
    """The particles at one step, in user order (SI units): ``sim.state``.

    Copies of the engine's arrays, made when read (:meth:`Ordering.view
    <demcal.dem.ordering.Ordering.view>`), so reading never disturbs the engine.
    ``positions``, ``velocities``, ``omegas``, ``quaternions``, ``angular_momenta`` and
    ``fixed`` may be written in place (``sim.state.velocities[0] = ...``): the next run
    (or change of the particles, or checkpoint) starts from what was written. From then
    on this state is a record of its ``time`` and ``step``, read-only; ``sim.state``
    gives the new one. The other fields are read-only throughout.

    Bodies (one per particle, ``n`` rows): ``positions`` [m] (centre of mass),
    ``velocities`` [m/s], ``omegas`` [rad/s] (world frame), ``quaternions`` (w, x, y, z;
    body principal frame -> world), ``angular_momenta`` [kg m2/s] (world),
    ``forces`` [N] and ``torques`` [N m] of the last evaluation (gravity included),
    ``masses`` [kg], ``inertias`` [kg m2] (principal; ``inf`` for a particle added
    with ``rotation=False``), ``materials`` (index),
    ``templates`` (index into ``Simulation.templates``), ``scales`` (size factor),
    ``fixed`` (bool). Spheres (``ns`` rows): ``sphere_positions`` [m], ``radii`` [m],
    ``sphere_body`` (owning body).
    """

    positions: np.ndarray
    velocities: np.ndarray
    omegas: np.ndarray
    quaternions: np.ndarray
    angular_momenta: np.ndarray
    forces: np.ndarray
    torques: np.ndarray
    masses: np.ndarray
    inertias: np.ndarray
    materials: np.ndarray
    templates: np.ndarray
    scales: np.ndarray
    fixed: np.ndarray
    sphere_positions: np.ndarray
    radii: np.ndarray
    sphere_body: np.ndarray
    time: float
    step: int

    @property
    def n(self) -> int:
        """Number of particles (bodies)."""
        return self.positions.shape[0]
