"""The ``cuda`` backend: the engine's step loop on an NVIDIA GPU (numba-cuda).

It implements the protocol of :mod:`demcal.dem.backend` with the CPU kernels' own
source compiled for the device (:mod:`.compile`, :mod:`.kernels`). ``steps`` copies the
store to the device, runs up to ``nsteps`` whole steps there, and copies it back.
Neighbour lists are rebuilt on the device inside the loop (:mod:`.lists`, the CPU's
lists to the bit) unless the rebuild has more to do: a spatial sort due
(:mod:`demcal.dem.ordering`, at the same steps as on the CPU), a particle out of the
domain, or walls that the loop moves (their bounding boxes are the host's); otherwise the call stops right after the drift that makes a rebuild due, as the
CPU loop does, and the host rebuilds (the host's ``map_range`` runs the CPU search).
``forces`` and ``drift`` (single steps, moving walls placed from Python) copy around
each call.

Bits: one thread sums each quantity in the CPU's order, and no floating-point atomics
enter a sum, so the same seed gives the same bits on every run on one GPU. Against
the CPU backend the results differ only in the last bits of libdevice's
transcendental functions (and of FMAs, where ``DEMCAL_CUDA_FMA=1`` lets NVVM fuse);
``benchmarks/gpu/check.py`` measures the difference on a GPU, and the tests run the
kernels in numba-cuda's simulator (``NUMBA_ENABLE_CUDASIM=1``), where they agree with
the CPU to the bit.


numba-cuda is an optional extra (``pip install 'demcal[cuda]'``); without it, or
without a device, choosing this backend is one sentence (:class:`ConfigError`).
"""

from __future__ import annotations

import importlib
import math
import os
import time as time_module
import warnings
from typing import NamedTuple

import numba
import numpy as np

from demcal.errors import ConfigError

from .. import _cache
from ..storage import ContactList
from ..threads import Workers
from .layout import SLOT_OUT_WIDTH

#: The arrays the device changes (copied back after each call), by container.
_BODY_OUT = ("pos", "vel", "quat", "angmom", "omega", "force", "torque")
_SPHERE_OUT = ("pos", "dsq", "acc")
_LIST_OUT = ("hist", "out", "act")
_WALL_OUT = ("params", "origin", "velocity", "omega")
#: Steps queued between two reads of the rebuild flag.
BATCH = 32


def cuda_module():
    """``numba.cuda``, or one sentence saying how to get it."""
    if not hasattr(np, "row_stack"):
        # numba-cuda 0.30 registers np.row_stack, an alias numpy 2.5 removed (it was
        # deprecated in 2.0 for np.vstack, the same function); without it numba.cuda
        # fails on import with such a numpy
        np.row_stack = np.vstack
    try:
        cuda = importlib.import_module("numba.cuda")
    except ImportError:
        cuda = None
    # numba-cuda warns at every launch of a grid smaller than the device (the one-thread
    # rebuild check, small systems): not a user's concern
    warnings.filterwarnings("ignore", message=r".*Grid size \d+ will likely result in GPU")
    if cuda is None or not hasattr(cuda, "jit"):
        raise ConfigError(
            "backend 'cuda' needs numba-cuda, which is not installed; install it with "
            "pip install 'demcal[cuda]', or use backend 'cpu'.")
    return cuda


def numba_cuda_installed() -> bool:
    """Whether numba-cuda is installed (its simulator, ``NUMBA_ENABLE_CUDASIM=1``, then
    runs the cuda backend without a GPU)."""
    try:
        cuda_module()
    except ConfigError:
        return False
    return True


def device_present() -> bool:
    """Whether numba-cuda is installed and sees a GPU (its simulator does not count)."""
    if os.environ.get("NUMBA_ENABLE_CUDASIM") == "1":
        return False
    try:
        return bool(cuda_module().is_available())
    except ConfigError:
        return False


def transposed(start: np.ndarray, other: np.ndarray):
    """The half pair list seen from the j side: ``tstart`` (CSR over spheres) and for
    each entry the slot ``tslot[t]`` (ascending within a sphere: the rows' order), and
    the row of each slot ``srow[p]`` (see :mod:`.kernels`)."""
    ns = start.shape[0] - 1
    npair = int(start[-1])
    nbr = other[:npair]
    tslot = np.argsort(nbr, kind="stable").astype(np.int64)
    tstart = np.zeros(ns + 1, np.int64)
    np.cumsum(np.bincount(nbr, minlength=ns), out=tstart[1:])
    srow = np.repeat(np.arange(ns, dtype=np.int64), np.diff(start[:ns + 1]))
    return tstart, tslot, srow


class Systems(NamedTuple):
    """The systems side by side in one device state (:mod:`.kernels`, "Systems"): each
    sphere's and body's system, each system's wall rows ``wall_lo[s]:wall_lo[s + 1]``,
    time step [s], clock [s], walls' travel since its last build and bound per step [m],
    half skin [m] and gravity row [m/s2]."""

    sphere: np.ndarray
    body: np.ndarray
    wall_lo: np.ndarray
    dt: np.ndarray
    time: np.ndarray
    travel: np.ndarray
    travel_per_step: np.ndarray
    half_skin: np.ndarray
    gravity: np.ndarray

    @classmethod
    def single(cls, ns, nb, nw, dt, time=0.0, travel=0.0, travel_per_step=0.0, half_skin=0.0,
               gravity=(0.0, 0.0, 0.0)) -> "Systems":
        """One system of ``ns`` spheres, ``nb`` bodies and ``nw`` wall rows."""
        return cls(np.zeros(ns, np.int64), np.zeros(nb, np.int64), np.array([0, nw], np.int64),
                   np.array([dt], np.float64), np.array([time], np.float64),
                   np.array([travel], np.float64), np.array([travel_per_step], np.float64),
                   np.array([half_skin], np.float64),
                   np.asarray(gravity, np.float64).reshape(1, 3).copy())


class _Device:
    """The store's arrays on the device for one call (uploaded on construction), with the
    systems they hold (:class:`Systems`)."""

    def __init__(self, cuda, store, systems: Systems, walls=None, index=None, motions=None,
                 table=None):
        self.cuda = cuda
        put = cuda.to_device
        self.b = {k: put(v) for k, v in zip(store.bodies._fields, store.bodies)}
        self.s = {k: put(v) for k, v in zip(store.spheres._fields, store.spheres)}
        self.p = {k: put(v) for k, v in zip(store.pairs._fields, store.pairs)}
        self.q = {k: put(v) for k, v in zip(store.walls._fields, store.walls)}
        self.w = None if walls is None else {k: put(v) for k, v in zip(walls._fields, walls)}
        self.m = None if motions is None else [put(np.ascontiguousarray(v)) for v in motions]
        self.index = None if index is None else [put(v) for v in index]
        self.table = None if table is None else put(table)
        self.sys = {k: put(v) for k, v in zip(systems._fields, systems)}
        self.nsys = int(systems.dt.shape[0])
        self.npair = int(store.pairs.start[-1])
        self.slot_out = cuda.device_array((max(self.npair, 1), SLOT_OUT_WIDTH))
        self.flag = put(np.zeros((self.nsys, 2), np.int64))
        self.mx = put(np.zeros(self.nsys))
        self.lists_rebuilt = False

    def clocks(self):
        """Each system's clock [s] and walls' travel [m], from the device."""
        return self.sys["time"].copy_to_host(), self.sys["travel"].copy_to_host()

    def download(self, store, walls=None) -> None:
        """Copy what the device changed into the host store (and wall rows); lists rebuilt
        on the device replace the store's, and the spheres' reference positions follow."""
        parts = [(_BODY_OUT, self.b, store.bodies), (_SPHERE_OUT, self.s, store.spheres)]
        if self.lists_rebuilt:
            store.pairs = ContactList(*(self.p[k].copy_to_host() for k in ContactList._fields))
            store.walls = ContactList(*(self.q[k].copy_to_host() for k in ContactList._fields))
            self.s["ref"].copy_to_host(store.spheres.ref)
        else:
            parts += [(_LIST_OUT, self.p, store.pairs), (_LIST_OUT, self.q, store.walls)]
        for names, dev, host in parts:
            for k in names:
                dev[k].copy_to_host(getattr(host, k))
        if walls is not None and self.w is not None:
            for k in _WALL_OUT:
                self.w[k].copy_to_host(getattr(walls, k))


class CudaBackend:
    """numba-cuda on the first GPU; one host thread runs the neighbour search."""

    name = "cuda"

    @staticmethod
    def prepare() -> None:
        """The CPU cache guard (the host runs the neighbour search), numba-cuda and a
        device, or a :class:`ConfigError` saying which is missing."""
        _cache.ensure()
        cuda = cuda_module()
        if not cuda.is_available():
            raise ConfigError(
                "backend 'cuda' found no CUDA device (numba-cuda sees no NVIDIA GPU or "
                "driver on this machine); use backend 'cpu', or run on a machine with a GPU.")

    @staticmethod
    def default_threads() -> int:
        """The host threads of the neighbour search: numba's thread count."""
        return numba.get_num_threads()

    def __init__(self, threads: int = 1):
        self.prepare()
        self.cuda = cuda_module()
        self.workers = Workers(threads)
        self._index = None
        #: Seconds spent copying to and from the device and running steps there.
        self.seconds = {"upload": 0.0, "device": 0.0, "download": 0.0}
        #: Where ``steps`` may rebuild the lists on the device (the simulation says, see
        #: ``stepping.advance``): the step count from which a rebuild is the host's (a
        #: spatial sort due), the domain a particle must not have left, the step count
        #: when ``steps`` is called; rebuilds done there, not yet counted by the host.
        self.host_rebuild_at = 0
        self.domain = None
        self.step_count = 0
        self.device_rebuilds = 0
        self._lists = None

    threads = property(lambda self: self.workers.threads)

    def split(self, n_particles: int) -> bool:
        return self.workers.split(n_particles)

    def map_range(self, n_particles, fn, n, *args):
        """A host kernel over [0, n) (the neighbour search), on the host's threads."""
        return self.workers.map_range(self.split(n_particles), fn, n, *args)

    def lists_changed(self) -> None:
        self._index = None

    def index(self, store):
        if self._index is None:
            self._index = transposed(store.pairs.start, store.pairs.other)
        return self._index

    # the kernels, compiled on first use
    def _kernels(self, chosen):
        from .kernels import common_kernels, contact_kernels
        return common_kernels(), contact_kernels(tuple(chosen.ids))

    @staticmethod
    def _forces(dev, pk, chosen_kernels, kick) -> None:
        """Launch one step's force kernels: the pair slots, each sphere's sums (pairs,
        then walls), each body's sum and kick."""
        from .kernels import blocks, BLOCK
        k_kick = pk[2]
        k_slots, k_spheres = chosen_kernels
        b, s, p, q, w, y = dev.b, dev.s, dev.p, dev.q, dev.w, dev.sys
        ns = s["pos"].shape[0]
        nb = b["pos"].shape[0]
        tstart, tslot, srow = dev.index
        table, dts = dev.table, y["dt"]
        k_slots[blocks(dev.npair), BLOCK](
            dev.flag, y["sphere"], dev.npair, table, dts, s["pos"], s["radius"], s["body"],
            b["pos"], b["vel"], b["omega"], b["mass"], b["iso"], b["mat"], srow, p["other"],
            p["hist"], p["out"], p["act"], dev.slot_out)
        k_spheres[blocks(ns), BLOCK](
            dev.flag, y["sphere"], table, dts, s["pos"], s["radius"], s["body"], b["pos"],
            b["vel"], b["omega"], b["mass"], b["iso"], b["mat"], p["start"], p["act"],
            dev.slot_out, tstart, tslot, q["start"], q["other"], q["hist"], q["out"], q["act"],
            s["acc"], w["kind"], w["params"], w["velocity"], w["omega"], w["origin"],
            w["material"])
        k_kick[blocks(nb), BLOCK](dev.flag, y["body"], dts, y["gravity"], b["vel"], b["quat"],
                                  b["angmom"], b["omega"], b["force"], b["torque"], b["mass"],
                                  b["inertia"], b["fixed"], b["start"], s["acc"], kick)

    @staticmethod
    def _drift(dev, pk) -> None:
        from .kernels import blocks, BLOCK
        b, s = dev.b, dev.s
        pk[0][blocks(b["pos"].shape[0]), BLOCK](
            dev.flag, dev.sys["body"], dev.sys["dt"], b["pos"], b["vel"], b["quat"],
            b["angmom"], b["omega"], b["force"], b["torque"], b["mass"], b["inertia"],
            b["fixed"], b["start"], s["offset"], s["pos"], s["ref"], s["dsq"], dev.mx)

    @staticmethod
    def _check(dev, pk, step) -> None:
        """Each system's clock, skin test and wall motions after a drift (``k_check``)."""
        from .kernels import blocks, BLOCK
        y, w = dev.sys, dev.w
        pk[1][blocks(dev.nsys), BLOCK](
            dev.flag, step, y["time"], y["travel"], y["dt"], y["travel_per_step"],
            y["half_skin"], dev.mx, y["wall_lo"], *dev.m, w["kind"], w["params"],
            w["origin"], w["velocity"], w["omega"])

    def forces(self, chosen, table, dt, gravity, store, walls, kick) -> None:
        if store.spheres.n == 0:
            return
        pk, ck = self._kernels(chosen)
        systems = Systems.single(store.spheres.n, store.bodies.n, walls.kind.shape[0], dt,
                                 gravity=gravity)
        dev = _Device(self.cuda, store, systems, walls, self.index(store), table=table)
        self._forces(dev, pk, ck, bool(kick))
        dev.download(store)

    def drift(self, dt, store) -> float:
        if store.bodies.n == 0:
            return 0.0
        from .kernels import common_kernels
        dev = _Device(self.cuda, store, Systems.single(store.spheres.n, store.bodies.n, 0, dt))
        self._drift(dev, common_kernels())
        mx = float(dev.mx.copy_to_host()[0])
        dev.download(store)
        return math.sqrt(mx)

    def steps(self, nsteps, params, store, walls, motions):
        """Up to ``nsteps`` steps on the device (see the module docstring); returns
        ``(steps, rebuild, time, travel)`` as ``stepper.run_steps`` does. A rebuild
        that falls due is done on the device (:class:`.lists.DeviceLists`) and the loop
        goes on; NaN positions, or a rebuild the host must do (see the module
        docstring), end the call as on the CPU."""
        if nsteps <= 0:
            return 0, False, params.time, params.travel
        pk, ck = self._kernels(params.chosen)
        # rebuilds on the device need the walls' bounding boxes, which only the host
        # moves along with the walls
        on_device = not np.any(motions[0])
        t0 = time_module.perf_counter()
        systems = Systems.single(store.spheres.n, store.bodies.n, walls.kind.shape[0],
                                 params.dt, params.time, params.travel,
                                 params.travel_per_step, params.half_skin, params.gravity)
        dev = _Device(self.cuda, store, systems, walls, self.index(store), motions,
                      params.table)
        self.cuda.synchronize()
        t1 = time_module.perf_counter()
        self.seconds["upload"] += t1 - t0
        done = 0
        while done < nsteps:
            batch = min(BATCH, nsteps - done)
            for k in range(batch):
                self._drift(dev, pk)
                self._check(dev, pk, k)
                self._forces(dev, pk, ck, True)
            flag = dev.flag.copy_to_host()
            if not flag[0, 0]:
                done += batch
                continue
            done += int(flag[0, 1]) + 1
            if self._lists is None and on_device:
                from .lists import DeviceLists
                self._lists = DeviceLists()
            if (flag[0, 0] != 1 or not on_device or self.step_count + done >= self.host_rebuild_at
                    or self._lists.left_domain(dev, self.domain)):
                time, travel = dev.clocks()
                self._download(dev, store, walls, t1)
                return done, True, float(time[0]), float(travel[0])
            # stepping.advance on the host: rebuild, then this step's forces and kick
            self._lists.rebuild(dev, 2.0 * params.half_skin)
            dev.lists_rebuilt = True
            self.device_rebuilds += 1
            dev.sys["travel"].copy_to_device(np.zeros(1))
            dev.flag.copy_to_device(np.zeros((1, 2), np.int64))
            self._forces(dev, pk, ck, True)
        time, travel = dev.clocks()
        self._download(dev, store, walls, t1)
        return nsteps, False, float(time[0]), float(travel[0])

    def pop_rebuilds(self) -> int:
        """Rebuilds done on the device since the last call (the host counts them)."""
        n, self.device_rebuilds = self.device_rebuilds, 0
        return n

    def _download(self, dev, store, walls, t1) -> None:
        t2 = time_module.perf_counter()
        self.seconds["device"] += t2 - t1
        dev.download(store, walls)
        if dev.lists_rebuilt:
            self.lists_changed()
        self.seconds["download"] += time_module.perf_counter() - t2
