"""CUDA grid drivers of one velocity-Verlet step.

The physics is the CPU kernels' own source (:mod:`.compile`): the contact law
(``contact.kernel.contact``), the slip and levers (``forces._relative_motion``), the wall
contacts (``forces.wall_forces``), the integrator (``integrator.drift``,
``integrator.gather_kick``) and the wall placement (``placement.place_moving``), each
called by one thread over a range of one (``lo = i``, ``hi = i + 1``) where the CPU loop
takes a range of many. Per step (:class:`.backend.CudaBackend`), four kinds of launch:

* ``k_drift`` (one thread per body): half kick, drift, sphere positions; the largest
  squared move since the last build, reduced per block and then by one atomic max per
  block (a maximum is exact in any order);
* ``k_check`` (one thread per system): the clock, the skin test of
  ``stepper._run_steps``, then the compiled wall motions. Once a rebuild is due it
  raises the system's flag and every later kernel of the batch leaves that system
  alone, so the host queues many steps and reads the flags once;
* ``k_slots`` (one thread per pair slot): the contact of slot p = (i, j) with the
  expressions of ``forces.pair_forces``; the history in place, and the force on i, i's
  torque term and j's reaction term in ``slot_out[p]``. Each contact is evaluated once;
* ``k_spheres`` (one thread per sphere): :func:`gather_pairs` sums sphere i's terms in
  ``forces.pair_forces``' order (the reactions of the slots whose j side it is, by the
  transposed half list, then its own row), then its wall contacts are added;
* ``k_kick`` (one thread per body): the body's sums, gravity and the closing half kick.

Every sum is taken by one thread in the CPU's order and no floating-point atomics enter
a sum, so a run gives the same bits on every launch; with NVVM's FMA contraction off
(:func:`.compile.exact_arithmetic`) they are the CPU's operations too.

**Systems.** The arrays may hold several independent systems side by side (an ensemble,
:mod:`.ensemble`; one system for a single simulation): ``sys_sphere`` and ``sys_body``
name each sphere's and body's system, and each system has its own row of ``flag`` (its
rebuild flag and the step that raised it), its own step ``dts``, clock ``times``, walls'
travel ``travels``, gravity row, largest move ``mx`` and wall rows ``wall_lo[s]:
wall_lo[s + 1]``. A system whose flag is up is left alone by every later kernel of the
batch while the others go on. The systems never meet: their spheres are in no common
list (:mod:`.ensemble` concatenates each system's own lists) and their materials are
separate blocks of one pair table.
"""

from __future__ import annotations

import functools
import math
import sys
import threading

import numpy as np
from numba import config, cuda, float64

from demcal.geometry.placement import place_moving

from .. import forces as _forces
from .. import integrator as _integ
from ..contact import kernel as _contact
from .compile import ChosenIds, device_function

#: Threads per block of every driver (numba-cuda's simulator runs each thread as a
#: Python thread: small blocks keep its tests fast).
BLOCK = 16 if config.ENABLE_CUDASIM else 128


def _simulator_shared_arrays_locked() -> None:
    """Make numba-cuda's simulator hand every thread of a block the same shared array.

    The simulator (numba-cuda 0.30) allocates a block's ``cuda.shared.array`` when the
    first of its threads reaches the call, keyed by the caller's file and line, with no
    lock: two threads that reach it together may each allocate, and keep, an array of
    their own. A reduction (:func:`block_max`) then reads slots that no thread of its
    array wrote (an uninitialised ``np.empty``: once a rebuild falls due at a move of
    0.01 m**2 instead of 1e-7). The odds grow with Python's thread switch rate (the
    simulator tests run at 10 us). On a GPU the array is one per block by construction;
    this only serialises the simulator's allocation, with its own keying.
    """
    from numba import types
    from numba.cuda.simulator import kernelapi
    from numba.np import numpy_support

    shared = kernelapi.FakeCUDAShared
    if getattr(shared.array, "demcal_locked", False):
        return
    inner = shared.array
    lock = threading.Lock()

    def array(self, shape, dtype, alignment=None):
        if shape == 0 or alignment is not None:
            return inner(self, shape, dtype, alignment)   # dynamic memory: one buffer
        caller = sys._getframe(1)
        key = (caller.f_code.co_filename, caller.f_lineno)
        with lock:
            res = self._allocations.get(key)
            if res is None:
                if isinstance(dtype, types.Type):
                    dtype = numpy_support.as_dtype(dtype)
                res = self._allocations[key] = np.empty(shape, dtype)
        return res

    array.demcal_locked = True
    array.__wrapped__ = inner
    shared.array = array


if config.ENABLE_CUDASIM:
    _simulator_shared_arrays_locked()


def blocks(n: int) -> int:
    return max(1, (n + BLOCK - 1) // BLOCK)


@cuda.jit(device=True)
def block_max(v):
    """The largest ``v`` of the block's threads, returned to every thread (each thread
    of the block must call it; ``v`` not NaN). Exact in any order."""
    sm = cuda.shared.array(BLOCK, float64)
    t = cuda.threadIdx.x
    sm[t] = v
    cuda.syncthreads()
    h = BLOCK // 2
    while h > 0:
        if t < h and sm[t + h] > sm[t]:
            sm[t] = sm[t + h]
        cuda.syncthreads()
        h //= 2
    out = sm[0]
    cuda.syncthreads()   # all have read it before a next call writes the array again
    return out


@cuda.jit(device=True)
def block_min(v):
    """:func:`block_max` of the smallest."""
    return -block_max(-v)


@cuda.jit(device=True)
def gather_pairs(i, row_start, act, slot_out, tstart, tslot, sacc):
    """``forces.pair_forces``' sums for sphere i, in its order, from the slots' terms
    (``k_slots``): the reactions of the earlier rows' slots whose j side i is (slot
    order), then its own row's sum."""
    fx = 0.0
    fy = 0.0
    fz = 0.0
    tx = 0.0
    ty = 0.0
    tz = 0.0
    for t in range(tstart[i], tstart[i + 1]):
        p = tslot[t]
        if act[p]:
            fx -= slot_out[p, 0]
            fy -= slot_out[p, 1]
            fz -= slot_out[p, 2]
            tx += slot_out[p, 6]
            ty += slot_out[p, 7]
            tz += slot_out[p, 8]
    sx = 0.0
    sy = 0.0
    sz = 0.0
    ux = 0.0
    uy = 0.0
    uz = 0.0
    for p in range(row_start[i], row_start[i + 1]):
        if act[p]:
            sx += slot_out[p, 0]
            sy += slot_out[p, 1]
            sz += slot_out[p, 2]
            ux += slot_out[p, 3]
            uy += slot_out[p, 4]
            uz += slot_out[p, 5]
    sacc[i, 0] = fx + sx
    sacc[i, 1] = fy + sy
    sacc[i, 2] = fz + sz
    sacc[i, 3] = tx + ux
    sacc[i, 4] = ty + uy
    sacc[i, 5] = tz + uz


@functools.lru_cache(maxsize=None)
def common_kernels():
    """The drivers that do not depend on the contact model."""
    drift = device_function(_integ.drift)
    gather_kick = device_function(_integ.gather_kick)
    place = device_function(place_moving)

    @cuda.jit
    def k_drift(flag, sys_body, dts, bpos, bvel, bquat, bangmom, bomega, bforce, btorque,
                bmass, binertia, bfixed, bstart, soffset, spos, sref, sdsq, mx):
        b = cuda.grid(1)
        nb = bpos.shape[0]
        if nb == 0:
            return
        m = 0.0
        s = 0
        if b < nb:
            s = sys_body[b]
            if flag[s, 0] == 0:
                m = drift(dts[s], bpos, bvel, bquat, bangmom, bomega, bforce, btorque, bmass,
                          binertia, bfixed, bstart, soffset, spos, sref, sdsq, b, b + 1)
        # a block of one system: its largest move first, then one atomic per block (one
        # address contended by every thread of a million-body grid would serialise the
        # step); a block across systems: one atomic per thread, into its own system's
        first = cuda.blockIdx.x * cuda.blockDim.x
        last = min(first + cuda.blockDim.x, nb) - 1
        if sys_body[first] == sys_body[last]:
            m = block_max(m)
            if cuda.threadIdx.x == 0 and m > 0.0:
                cuda.atomic.max(mx, sys_body[first], m)
        elif m > 0.0:
            cuda.atomic.max(mx, s, m)

    @cuda.jit
    def k_check(flag, step, times, travels, dts, travel_per_step, half_skin, mx, wall_lo,
                tflag, tvel, tstart, tstop, ref_params, ref_origin, axis, point, rate,
                wkind, wparams, worigin, wvel, womega):
        # one thread per system: its clock, then the skin test of stepper._run_steps
        # (a rebuild when the largest move plus the walls' travel passes half the skin;
        # NaN positions give mx = inf), then its compiled wall motions
        s = cuda.grid(1)
        if s >= flag.shape[0] or flag[s, 0] != 0:
            return
        time = times[s] + dts[s]
        times[s] = time
        travel = travels[s] + travel_per_step[s]
        travels[s] = travel
        m = mx[s]
        mx[s] = 0.0
        if not math.sqrt(m) + travel <= half_skin[s]:
            flag[s, 0] = 2 if m == math.inf else 1   # 2: NaN or infinite positions
            flag[s, 1] = step
            return
        a = wall_lo[s]
        z = wall_lo[s + 1]
        if z > a:
            place(time, tflag[a:z], tvel[a:z], tstart[a:z], tstop[a:z], axis[a:z], point[a:z],
                  rate[a:z], ref_params[a:z], ref_origin[a:z], wkind[a:z], wparams[a:z],
                  worigin[a:z], wvel[a:z], womega[a:z])

    @cuda.jit
    def k_kick(flag, sys_body, dts, gravity, bvel, bquat, bangmom, bomega, bforce, btorque,
               bmass, binertia, bfixed, bstart, sacc, kick):
        b = cuda.grid(1)
        if b >= bvel.shape[0]:
            return
        s = sys_body[b]
        if flag[s, 0] != 0:
            return
        gather_kick(dts[s], gravity[s], bvel, bquat, bangmom, bomega, bforce, btorque, bmass,
                    binertia, bfixed, bstart, sacc, kick, b, b + 1)

    return k_drift, k_check, k_kick


@functools.lru_cache(maxsize=None)
def contact_kernels(ids: tuple):
    """The pair and wall drivers for one combination of sub-model ids (constants of
    the compiled kernels, as :class:`~demcal.dem.contact.chosen.Chosen` makes them on
    the CPU)."""
    pair_contact = device_function(_forces.pair_contact)
    separation = device_function(_forces.separation)
    apart = device_function(_forces.apart)
    reset_history = device_function(_contact.reset_history)
    store_history = device_function(_contact.store_history)
    wall_forces = device_function(_forces.wall_forces)
    normal, damping, tangential, rolling = (int(v) for v in ids)

    @cuda.jit
    def k_slots(flag, sys_sphere, npair, table, dts, spos, srad, sbody, bpos, bvel, bomega,
                bmass, biso, bmat, srow, nbr, hist, pair_out, act, slot_out):
        # one pair slot p = (i, j), as forces.pair_forces evaluates it in row i
        # (forces.pair_contact; its sums are gather_pairs'): the force on i, i's torque
        # term and j's to slot_out, the new history in place
        p = cuda.grid(1)
        if p >= npair:
            return
        i = srow[p]
        s = sys_sphere[i]
        if flag[s, 0] != 0:
            return
        dt = dts[s]
        j = nbr[p]
        bi = sbody[i]
        ri = srad[i]
        xi = spos[i, 0]
        yi = spos[i, 1]
        zi = spos[i, 2]
        mati = bmat[bi]
        gap = separation(xi, yi, zi, ri, j, spos, srad)
        if apart(gap, act[p], normal, table, mati, ri, sbody, bmat):
            if act[p]:
                reset_history(hist, p)
                act[p] = False
            return
        (fx, fy, fz, tix, tiy, tiz, tjx, tjy, tjz,
         h0, h1, h2, h3, h4, h5, h6) = pair_contact(
            normal, damping, tangential, rolling, table, dt, hist, p,
            (ri, xi - bpos[bi, 0], yi - bpos[bi, 1], zi - bpos[bi, 2], bvel[bi, 0],
             bvel[bi, 1], bvel[bi, 2], bomega[bi, 0], bomega[bi, 1], bomega[bi, 2], bmass[bi],
             biso[bi], mati),
            gap, sbody, bpos, bvel, bomega, bmass, biso, bmat)
        store_history(hist, p, h0, h1, h2, h3, h4, h5, h6)
        act[p] = True
        pair_out[p, 0] = fx
        pair_out[p, 1] = fy
        pair_out[p, 2] = fz
        slot_out[p, 0] = fx
        slot_out[p, 1] = fy
        slot_out[p, 2] = fz
        slot_out[p, 3] = tix
        slot_out[p, 4] = tiy
        slot_out[p, 5] = tiz
        slot_out[p, 6] = tjx
        slot_out[p, 7] = tjy
        slot_out[p, 8] = tjz

    @cuda.jit
    def k_spheres(flag, sys_sphere, table, dts, spos, srad, sbody, bpos, bvel, bomega, bmass,
                  biso, bmat, row_start, act, slot_out, tstart, tslot, wall_start, wid,
                  whist, wall_out, wactive, sacc, wkind, wparams, wvel, womega, worigin,
                  wmat):
        # sphere i's contact sums: its pair terms (gather_pairs), then its wall contacts
        i = cuda.grid(1)
        if i >= spos.shape[0] or flag[sys_sphere[i], 0] != 0:
            return
        dt = dts[sys_sphere[i]]
        gather_pairs(i, row_start, act, slot_out, tstart, tslot, sacc)
        chosen = ChosenIds(normal, damping, tangential, rolling)
        wall_forces(chosen, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass, biso,
                    bmat, wall_start, wid, whist, wall_out, wactive, sacc, wkind, wparams,
                    wvel, womega, worigin, wmat, i, i + 1)

    return k_slots, k_spheres
