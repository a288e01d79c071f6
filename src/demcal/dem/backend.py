"""Compute backends: where the compiled force, drift and step loops run.

A backend takes the engine's containers (:mod:`demcal.dem.storage`) and evaluates the
physics on them; the :class:`~demcal.dem.Simulation` decides *when* (neighbour rebuilds,
walls, reporters). ``cpu`` runs numba on the host's cores; ``cuda``
(:mod:`demcal.dem.cuda`) runs the same kernels' source on a GPU. Each implements four
methods, plus ``prepare()`` (called before anything else in the process touches the
device or its threads) and ``default_threads()``:

* ``forces(chosen, table, dt, gravity, store, walls, kick)``: contact forces of the
  pair and wall lists, then the per-body sums and (``kick``) the half kick;
* ``drift(dt, store)``: one drift, returning the largest sphere move since the last
  neighbour build [m];
* ``steps(nsteps, params, store, walls, motions)``: up to ``nsteps`` whole steps in
  one call (:func:`demcal.dem.stepper.run_steps`), stopping when the lists need a
  rebuild;
* ``map_range(n_particles, fn, n, *args)``: a kernel over [0, n) (the neighbour search).

Every backend must give the same bits for any thread count (tests run one body on each
backend present, :data:`BACKENDS`).
"""

from __future__ import annotations

import math
from typing import NamedTuple

import numba
import numpy as np

from . import _cache
from . import forces as _forces
from . import integrator as _integ
from . import neighbours as _nl
from . import stepper as _stepper
from .contact.kernel import HIST_WIDTH
from .storage import Store
from .threads import Workers

_NO_HALO = np.zeros(1, np.int64)                # an unsplit pair loop's empty halo index
_NO_DEFERRED = np.zeros((0, HIST_WIDTH))


class HaloIndex(NamedTuple):
    """A split's chunks (equal runs of bodies), their sphere bounds, and the pair list's
    halo index for them (``neighbours.halo_index``) with its history buffer."""

    chunks: np.ndarray
    bounds: np.ndarray
    rows: np.ndarray
    row: np.ndarray
    slots: np.ndarray
    slot: np.ndarray
    slot_deferred: np.ndarray
    deferred_start: np.ndarray
    deferred: np.ndarray


class CpuBackend:
    """numba on the host's cores, ``threads`` of them (see :class:`Workers`)."""

    name = "cpu"

    @staticmethod
    def prepare() -> None:
        """Before anything touches numba's threads in this process: the cache guard and
        the threading layer (:func:`demcal.dem._cache.ensure`)."""
        _cache.ensure()

    @staticmethod
    def default_threads() -> int:
        """numba's thread count: the cores, or what NUMBA_NUM_THREADS or a campaign
        worker (numba.set_num_threads) allows this process."""
        return numba.get_num_threads()

    #: The CPU backend never rebuilds the lists inside ``steps`` (the host does; see
    #: ``CudaBackend`` for what the step loop tells a backend that can).
    host_rebuild_at = 0

    def __init__(self, threads: int):
        self.prepare()
        self.workers = Workers(threads)
        self.halo = None   # the split of the current pair list, built on first use

    @staticmethod
    def pop_rebuilds() -> int:
        """Rebuilds done inside ``steps`` since the last call: none on the CPU."""
        return 0

    @property
    def threads(self) -> int:
        return self.workers.threads

    def split(self, n_particles: int) -> bool:
        return self.workers.split(n_particles)

    def map_range(self, n_particles, fn, n, *args):
        return self.workers.map_range(self.split(n_particles), fn, n, *args)

    def lists_changed(self) -> None:
        """The pair list was rebuilt: its halo index must be built again."""
        self.halo = None

    def halo_index(self, store: Store) -> HaloIndex:
        """The split's chunks (``threads`` equal runs of bodies) and the pair list's halo
        index for them, built once per list."""
        t = self.threads
        if self.halo is None or self.halo.chunks.shape[0] != t + 1:
            nb = store.bodies.n
            chunks = np.array([nb * c // t for c in range(t + 1)], np.int64)
            bounds = store.bodies.start[chunks]
            rows, row, slots, slot, slot_deferred, deferred_start = _nl.halo_index(
                store.pairs.start, store.pairs.other, bounds)
            self.halo = HaloIndex(chunks, bounds, rows, row, slots, slot, slot_deferred,
                                  deferred_start, np.zeros((slot.shape[0], HIST_WIDTH)))
        return self.halo

    def forces(self, chosen, table, dt, gravity, store: Store, walls, kick) -> None:
        b, s, p, q = store.bodies, store.spheres, store.pairs, store.walls
        nb, ns = b.n, s.n
        if not self.split(nb):  # one compiled call, sharing the step loop's kernels
            _stepper.forces_whole(chosen, table, dt, gravity, bool(kick), _NO_HALO, _NO_DEFERRED,
                                  b.pos, b.vel, b.quat, b.angmom, b.omega, b.force, b.torque,
                                  b.mass, b.inertia, b.iso, b.mat, b.fixed, b.start, s.pos,
                                  s.radius, s.body, s.acc, p.start, p.other, p.hist, p.out,
                                  p.act, q.start, q.other, q.hist, q.out, q.act, walls.kind,
                                  walls.params, walls.velocity, walls.omega, walls.origin,
                                  walls.material)
            return
        if ns:  # split between the threads: chunk by chunk (module docstring of stepper)
            args = (chosen, table, dt, s.pos, s.radius, s.body, b.pos, b.vel, b.omega,
                    b.mass, b.iso, b.mat, p.start, p.other, p.hist, p.out, p.act, s.acc)
            h = self.halo_index(store)
            rows, bounds, slots = h.rows, h.bounds, h.slots
            self.workers.each_chunk(lambda c: _forces.pair_forces(
                *args, h.row, slots, h.slot, rows[c], rows[c + 1], h.deferred,
                h.deferred_start[c], bounds[c], bounds[c + 1]))
            self.workers.each_chunk(lambda c: _forces.commit_deferred(
                p.hist, p.act, h.deferred, h.slot, h.slot_deferred,
                slots[rows[c]], slots[rows[c + 1]]))
            self.map_range(nb, _forces.wall_forces, ns, chosen, table, dt, s.pos,
                           s.radius, s.body, b.pos, b.vel, b.omega, b.mass, b.iso, b.mat,
                           q.start, q.other, q.hist, q.out, q.act, s.acc, walls.kind,
                           walls.params, walls.velocity, walls.omega, walls.origin,
                           walls.material)
        self.map_range(nb, _integ.gather_kick, nb, dt, gravity, b.vel, b.quat, b.angmom,
                       b.omega, b.force, b.torque, b.mass, b.inertia, b.fixed, b.start,
                       s.acc, kick)

    def drift(self, dt, store: Store) -> float:
        b, s = store.bodies, store.spheres
        if not self.split(b.n):  # the step loop's copy of the kernel (stepper.drift_whole)
            return math.sqrt(_stepper.drift_whole(dt, b.pos, b.vel, b.quat, b.angmom, b.omega,
                                                  b.force, b.torque, b.mass, b.inertia, b.fixed,
                                                  b.start, s.offset, s.pos, s.ref, s.dsq))
        res = self.map_range(b.n, _integ.drift, b.n, dt, b.pos, b.vel, b.quat, b.angmom,
                             b.omega, b.force, b.torque, b.mass, b.inertia, b.fixed,
                             b.start, s.offset, s.pos, s.ref, s.dsq)
        return math.sqrt(max(res))

    def steps(self, nsteps, params, store: Store, walls, motions):
        """Up to ``nsteps`` steps in one compiled call (:mod:`demcal.dem.stepper`), on
        numba's threads when the particles are split between threads."""
        args = (nsteps, params, store.bodies, store.spheres, store.pairs, store.walls,
                walls, _stepper.WallMotions(*motions))
        if not self.split(store.bodies.n):
            return _stepper.run_steps(*args)
        h = self.halo_index(store)
        before = numba.get_num_threads()
        numba.set_num_threads(min(self.threads, numba.config.NUMBA_NUM_THREADS))
        try:
            return _stepper.run_steps_split(*args, h)
        finally:
            numba.set_num_threads(before)


from .cuda.backend import CudaBackend  # noqa: E402  (numba.cuda is imported on first use)

#: Compute backends, by name: ``cuda`` needs numba-cuda and a GPU (or its simulator),
#: and says so in one sentence when chosen without them.
BACKENDS = {"cpu": CpuBackend, "cuda": CudaBackend}


def make_backend(name: str, threads: int):
    """The backend object of a new simulation: ``BACKENDS[name](threads)``, or, for
    ``cuda`` inside an ensemble's job, a member of that ensemble
    (:mod:`demcal.dem.cuda.ensemble`)."""
    if name == "cuda":
        from .cuda.ensemble import member_backend
        member = member_backend(threads)
        if member is not None:
            return member
    return BACKENDS[name](threads)
