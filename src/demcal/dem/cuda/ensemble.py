"""Ensembles: independent simulations stepped together on one device.

A calibration run is small (1,500-40,000 spheres) and cannot fill a GPU alone; a design
is 17-29 such runs that differ only in parameters and seeds. :class:`Ensemble` runs them
together. Each run is an ordinary *job*, a function of no argument that builds and runs
its own :class:`~demcal.dem.Simulation` on backend ``cuda`` (a bench run, for instance),
in a thread of its own. A simulation made inside a job gets a :class:`Member` backend,
whose ``steps`` launches nothing itself: it hands its request to the ensemble and waits.
Once every live job waits in ``steps`` (or has ended), the ensemble lays the waiting
systems side by side in one device state (:func:`merge`: the arrays concatenated, each
system's indices shifted, its materials one block of a common pair table) and steps
them together with the backend's own kernels, each system with its own clock, step,
gravity, skin test, walls and rebuild flag (:mod:`.kernels`, "Systems"). A system whose
lists fall due, or whose request is complete, goes back to its job with its arrays
copied into its own store; the job rebuilds its lists on the host, measures, inserts,
stops or asks for more steps, as it would alone, and the others wait for it.

Bits: everything a job does between two ``steps`` calls is its own simulation's code,
and the kernels leave a system's numbers untouched by the others', so a run in an
ensemble gives the bits of the same run alone on the cuda backend (whose rebuilds on
the device give the host's lists), on every launch. Single steps (``forces`` and
``drift``, a wall placed from Python) run alone, one job at a time.

Systems of one round must share the contact sub-models (the kernels' compile-time
constants): requests are grouped by them, and each group is stepped as one state.

Example::

    from demcal.bench.common import on_backend
    from demcal.bench.registry import get_experiment
    from demcal.dem.cuda.ensemble import Ensemble

    def job(restitution):
        def run():
            with on_backend("cuda"):
                return get_experiment("impact").run({"particle.restitution": restitution}, profile="tiny")
        return run

    results = Ensemble().run([job(e) for e in (0.3, 0.5, 0.7)])   # a RunResult (or the error) each
"""

from __future__ import annotations

import contextvars
import threading
from dataclasses import dataclass, field
from typing import Any, Callable, Sequence

import numpy as np

from ..storage import Bodies, ContactList, Spheres, Store
from ..walltable import WallRows
from .backend import (BATCH, CudaBackend, Systems, _BODY_OUT, _Device, _LIST_OUT,
                      _SPHERE_OUT, _WALL_OUT, cuda_module, transposed)

#: The ensemble and slot of the job this thread runs (set by :meth:`Ensemble.run`).
_JOB: contextvars.ContextVar = contextvars.ContextVar("ensemble_job", default=None)


def member_backend(threads: int):
    """A :class:`Member` backend when this thread runs an ensemble's job, else None
    (``demcal.dem.backend.make_backend``)."""
    job = _JOB.get()
    if job is None:
        return None
    ensemble, slot = job
    return Member(threads, ensemble, slot)


@dataclass(eq=False)
class Request:
    """A member's ``steps`` call waiting for the ensemble: up to ``nsteps`` steps from
    the clock ``time`` [s] and the walls' travel ``travel`` [m] (both carried from round
    to round); ``done`` steps taken so far; ``reply`` what ``steps`` returns, or the
    exception it raises."""

    slot: int
    nsteps: int
    params: Any
    store: Store
    walls: WallRows
    motions: tuple
    time: float
    travel: float
    done: int = 0
    reply: Any = None


class Member(CudaBackend):
    """The cuda backend of a simulation made inside an ensemble's job: ``steps`` is
    stepped by the ensemble together with the other jobs' systems; ``forces`` and
    ``drift`` (single steps) run alone, holding the device."""

    def __init__(self, threads: int, ensemble: "Ensemble", slot: int):
        super().__init__(threads)
        self.ensemble = ensemble
        self.slot = slot

    def steps(self, nsteps, params, store, walls, motions):
        if nsteps <= 0:
            return 0, False, params.time, params.travel
        return self.ensemble._wait(Request(self.slot, int(nsteps), params, store, walls,
                                           motions, params.time, params.travel))

    def forces(self, *args, **kwargs) -> None:
        with self.ensemble.device:
            super().forces(*args, **kwargs)

    def drift(self, *args, **kwargs) -> float:
        # a drift from Python is a step on its own (a wall moved by a function of
        # time): the rounds need not wait for this job until it asks for steps again
        self.ensemble.single(self.slot)
        with self.ensemble.device:
            return super().drift(*args, **kwargs)

    @staticmethod
    def pop_rebuilds() -> int:
        """The ensemble leaves every rebuild to the host: none to count here."""
        return 0


@dataclass
class Merged:
    """Several systems' arrays side by side (:func:`merge`) and where each one's lie."""

    store: Store
    walls: WallRows
    motions: tuple
    table: np.ndarray
    systems: Systems
    bodies: np.ndarray          # offsets, one more than systems
    spheres: np.ndarray
    pairs: np.ndarray
    wall_contacts: np.ndarray
    wall_rows: np.ndarray


def _offsets(sizes) -> np.ndarray:
    out = np.zeros(len(sizes) + 1, np.int64)
    np.cumsum(sizes, out=out[1:])
    return out


def _csr(starts, offsets) -> np.ndarray:
    """CSR starts of the systems one after the other (each counted from 0), shifted
    by the systems' ``offsets``."""
    parts = [s[:-1] + o for s, o in zip(starts, offsets)]
    return np.concatenate(parts + [np.array([offsets[-1]], np.int64)]).astype(np.int64)


def _contacts(lists, sizes, slot_offsets, other_offsets) -> ContactList:
    """Contact lists side by side: the used slots of each, ``other`` shifted (sphere or
    wall row indices), with one spare slot so that no array is empty."""
    def cat(name, shift=None):
        parts = [getattr(c, name)[:n] + (0 if shift is None else shift[k])
                 for k, (c, n) in enumerate(zip(lists, sizes))]
        like = getattr(lists[0], name)
        spare = np.zeros((1,) + like.shape[1:], like.dtype)
        return np.ascontiguousarray(np.concatenate(parts + [spare]))
    return ContactList(start=_csr([c.start for c in lists], slot_offsets),
                       other=cat("other", other_offsets), hist=cat("hist"), out=cat("out"),
                       act=cat("act"))


def merge(requests: Sequence[Request]) -> Merged:
    """The waiting systems side by side in one store: bodies, spheres, the used slots of
    both contact lists, wall rows and motions concatenated, each system's sphere, body,
    slot, wall row and material indices shifted by the systems before it; the pair
    tables as the diagonal blocks of one table (no two systems' materials meet, and no
    list pairs them)."""
    stores = [r.store for r in requests]
    sb = _offsets([st.bodies.n for st in stores])
    ss = _offsets([st.spheres.n for st in stores])
    sizes_p = [st.pairs.size for st in stores]
    sizes_q = [st.walls.size for st in stores]
    sw = _offsets([r.walls.kind.shape[0] for r in requests])
    tables = [np.asarray(r.params.table) for r in requests]
    sm = _offsets([t.shape[0] for t in tables])

    def body_field(name):
        parts = [getattr(st.bodies, name) for st in stores]
        if name == "mat":
            parts = [p + sm[k] for k, p in enumerate(parts)]
        return np.ascontiguousarray(np.concatenate(parts))

    bodies = Bodies(**{f: (_csr([st.bodies.start for st in stores], ss) if f == "start"
                           else body_field(f)) for f in Bodies._fields})
    spheres = Spheres(**{f: np.ascontiguousarray(np.concatenate(
        [getattr(st.spheres, f) + (sb[k] if f == "body" else 0) for k, st in enumerate(stores)]))
        for f in Spheres._fields})
    pairs = _contacts([st.pairs for st in stores], sizes_p, _offsets(sizes_p), ss)
    wall_contacts = _contacts([st.walls for st in stores], sizes_q, _offsets(sizes_q), sw)
    walls = WallRows(**{f: np.ascontiguousarray(np.concatenate(
        [getattr(r.walls, f) + (sm[k] if f == "material" else 0) for k, r in enumerate(requests)]))
        for f in WallRows._fields})
    motions = tuple(np.ascontiguousarray(np.concatenate([np.asarray(r.motions[i]) for r in requests]))
                    for i in range(len(requests[0].motions)))
    width = tables[0].shape[2]
    table = np.zeros((sm[-1], sm[-1], width))
    for k, t in enumerate(tables):
        table[sm[k]:sm[k + 1], sm[k]:sm[k + 1]] = t
    n = len(requests)
    systems = Systems(
        sphere=np.repeat(np.arange(n, dtype=np.int64), np.diff(ss)),
        body=np.repeat(np.arange(n, dtype=np.int64), np.diff(sb)),
        wall_lo=sw,
        dt=np.array([r.params.dt for r in requests], np.float64),
        time=np.array([r.time for r in requests], np.float64),
        travel=np.array([r.travel for r in requests], np.float64),
        travel_per_step=np.array([r.params.travel_per_step for r in requests], np.float64),
        half_skin=np.array([r.params.half_skin for r in requests], np.float64),
        gravity=np.array([np.asarray(r.params.gravity, np.float64) for r in requests]).reshape(n, 3))
    return Merged(Store(bodies, spheres, pairs, wall_contacts), walls, motions, table, systems,
                  sb, ss, _offsets(sizes_p), _offsets(sizes_q), sw)


def scatter(merged: Merged, requests: Sequence[Request]) -> None:
    """Copy what the device changed from the merged arrays back into each system's own
    store and wall rows (in place)."""
    m = merged.store
    for k, r in enumerate(requests):
        st = r.store
        b0, b1 = merged.bodies[k], merged.bodies[k + 1]
        s0, s1 = merged.spheres[k], merged.spheres[k + 1]
        for name in _BODY_OUT:
            getattr(st.bodies, name)[:] = getattr(m.bodies, name)[b0:b1]
        for name in _SPHERE_OUT:
            getattr(st.spheres, name)[:] = getattr(m.spheres, name)[s0:s1]
        for own, side, lo in ((st.pairs, m.pairs, merged.pairs), (st.walls, m.walls, merged.wall_contacts)):
            a, z = lo[k], lo[k + 1]
            for name in _LIST_OUT:
                getattr(own, name)[:z - a] = getattr(side, name)[a:z]
        w0, w1 = merged.wall_rows[k], merged.wall_rows[k + 1]
        for name in _WALL_OUT:
            getattr(r.walls, name)[:] = getattr(merged.walls, name)[w0:w1]


@dataclass
class Stats:
    """What an ensemble did: device rounds (one merged state per group of systems that
    share their sub-models), batches of steps queued, the systems stepped per round and
    the sub-model groups seen."""

    rounds: int = 0
    batches: int = 0
    systems: list = field(default_factory=list)
    _seen: set = field(default_factory=set, repr=False)

    @property
    def groups(self) -> int:
        return len(self._seen)


class Ensemble:
    """Runs jobs together on one device (see the module docstring).

    Parameters
    ----------
    batch : int
        Steps queued between two reads of the systems' flags.
    """

    def __init__(self, batch: int = BATCH):
        CudaBackend.prepare()
        self.cuda = cuda_module()
        self.batch = int(batch)
        #: Held by whoever launches on the device: the ensemble's rounds, a member's
        #: single steps.
        self.device = threading.Lock()
        self.stats = Stats()
        self._cond = threading.Condition()
        self._waiting: dict[int, Request] = {}
        self._live: set[int] = set()
        self._single: set[int] = set()
        self._next = 0
        self._closed = False

    def run(self, jobs: Sequence[Callable[[], Any]]) -> list:
        """Run ``jobs`` (functions of no argument that simulate on backend ``cuda``)
        together; returns each job's result, or the exception it raised, in order."""
        results: list = [None] * len(jobs)
        for k, job in enumerate(jobs):
            self.add(job, lambda result, k=k: results.__setitem__(k, result))
        self.close()
        self.serve()
        return results

    def add(self, job: Callable[[], Any], done: Callable[[Any], None] | None = None) -> None:
        """Start ``job`` in a thread of its own now; it joins the rounds once its
        simulation asks for steps. ``done(result)`` is called in that thread when the
        job ends, with its result or the exception it raised."""
        with self._cond:
            if self._closed:
                raise RuntimeError("this ensemble takes no more jobs (closed)")
            slot = self._next
            self._next += 1
            self._live.add(slot)
        threading.Thread(target=self._job, args=(slot, job, done), daemon=True,
                         name=f"demcal-ensemble-{slot}").start()

    def close(self) -> None:
        """No more jobs: :meth:`serve` returns once the live ones have ended."""
        with self._cond:
            self._closed = True
            self._cond.notify_all()

    def serve(self) -> None:
        """Step rounds whenever every live job waits in ``steps`` (or steps on its own,
        see :meth:`single`), until the ensemble is closed and no job is live (run this
        in one thread while others add jobs)."""
        while True:
            with self._cond:
                self._cond.wait_for(lambda: (self._waiting and self._live
                                             <= self._waiting.keys() | self._single)
                                    or (self._closed and not self._live))
                if not self._live:
                    return
                pending = [self._waiting[k] for k in sorted(self._waiting)]
            with self.device:
                replies = self._round(pending)
            # the replies are handed over under the lock: a job woken by another's end
            # must not see its reply and ask again before its request is taken away
            with self._cond:
                for r, reply in replies:
                    r.reply = reply
                    if self._waiting.get(r.slot) is r:
                        del self._waiting[r.slot]
                self._cond.notify_all()

    def single(self, slot: int) -> None:
        """Job ``slot`` steps on its own (``forces`` and ``drift`` from Python: a wall
        moved by a function of time) until it next asks for ``steps``: the rounds go on
        without waiting for it."""
        with self._cond:
            if slot not in self._single:
                self._single.add(slot)
                self._cond.notify_all()

    def _job(self, slot: int, job, done) -> None:
        token = _JOB.set((self, slot))
        try:
            result = job()
        except BaseException as exc:  # the job's own error, handed over as its result
            result = exc
        finally:
            _JOB.reset(token)
        try:
            if done is not None:
                done(result)
        finally:
            with self._cond:
                self._live.discard(slot)
                self._single.discard(slot)
                self._cond.notify_all()

    def _wait(self, request: Request):
        """A member's ``steps``: wait for the rounds to answer ``request``."""
        with self._cond:
            self._single.discard(request.slot)
            self._waiting[request.slot] = request
            self._cond.notify_all()
            self._cond.wait_for(lambda: request.reply is not None)
        if isinstance(request.reply, BaseException):
            raise request.reply
        return request.reply

    def _round(self, pending: Sequence[Request]) -> list:
        """Step the waiting systems, grouped by their sub-models, until some system's
        lists fall due or its request is complete; returns ``(request, reply)`` for each
        request answered. A group whose device step fails answers each of its requests
        with that error; the other groups are stepped as usual."""
        groups: dict = {}
        for r in pending:
            groups.setdefault(tuple(int(v) for v in r.params.chosen.ids), []).append(r)
        replies = []
        for ids, group in groups.items():
            self.stats._seen.add(ids)
            try:
                replies += self._step_group(ids, group)
            except Exception as exc:  # noqa: BLE001 - the device's error, each job raises it
                replies += [(r, exc) for r in group]
        return replies

    def _step_group(self, ids, requests: Sequence[Request]) -> list:
        from .kernels import common_kernels, contact_kernels
        pk, ck = common_kernels(), contact_kernels(ids)
        merged = merge(requests)
        st = merged.store
        dev = _Device(self.cuda, st, merged.systems, merged.walls,
                      transposed(st.pairs.start, st.pairs.other), merged.motions, merged.table)
        left = np.array([r.nsteps - r.done for r in requests], np.int64)
        taken = np.zeros(len(requests), np.int64)
        self.stats.rounds += 1
        self.stats.systems.append(len(requests))
        while True:
            batch = min(self.batch, int(left.min()))
            for k in range(batch):
                CudaBackend._drift(dev, pk)
                CudaBackend._check(dev, pk, k)
                CudaBackend._forces(dev, pk, ck, True)
            self.stats.batches += 1
            flag = dev.flag.copy_to_host()
            raised = flag[:, 0] != 0
            steps = np.where(raised, flag[:, 1] + 1, batch)
            left -= steps
            taken += steps
            if raised.any() or not left.all():
                break
        time, travel = dev.clocks()
        dev.download(st, merged.walls)
        scatter(merged, requests)
        replies = []
        for k, r in enumerate(requests):
            r.done += int(taken[k])
            r.time, r.travel = float(time[k]), float(travel[k])
            if raised[k] or left[k] == 0:
                replies.append((r, (r.done, bool(raised[k]), r.time, r.travel)))
        return replies
