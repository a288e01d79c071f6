"""Many velocity-Verlet steps in one compiled call.

:func:`run_steps` strings together the same kernels the host calls for one step
(``integrator.drift``, then :func:`forces_whole`: ``forces.pair_forces``,
``forces.wall_forces``, ``integrator.gather_kick``) for up to ``nsteps`` steps, so a
run pays Python's dispatch once per neighbour-list period instead of twice per step;
results are bitwise those of the step-by-step path. It stops early, right after a
drift, when the neighbour list must be rebuilt (a sphere moved more than half the skin
since the last build, counting the walls' travel, or a position became NaN); the host
then rebuilds and finishes that step. Walls that move by a constant-velocity
translation or a constant-rate rotation are placed at every step's time by
:func:`~demcal.geometry.placement.place_moving`; the others keep their geometry during
the call (the host only uses it while no other wall needs re-placing).
``travel_per_step`` bounds how far any wall point moves in a step.

:func:`run_steps_split` is the same loop for several threads: each kernel runs over
fixed contiguous chunks of bodies in a numba ``prange`` (each chunk evaluates the pair
slots that reach into it from earlier chunks again, see ``forces.pair_forces``), which
gives bitwise the numbers of :func:`run_steps`. It pays two fork-joins per step instead
of Python's dispatch of each kernel.
"""

import math
from typing import NamedTuple

import numpy as np
from numba import njit, prange

from demcal.geometry.placement import place_moving

from .contact.chosen import Chosen
from .forces import commit_deferred, pair_forces, wall_forces
from .integrator import drift, gather_kick


class StepParams(NamedTuple):
    """The scalars and constants of one compiled call: time step [s], time [s], gravity
    [m/s2], the chosen sub-models (:class:`~demcal.dem.contact.chosen.Chosen`, whose ids
    the loop is compiled for), pair table, half the skin [m], the walls' travel since the
    last build [m] and its bound per step [m]."""

    dt: float
    time: float
    gravity: np.ndarray
    chosen: Chosen
    table: np.ndarray
    half_skin: float
    travel: float
    travel_per_step: float


class WallMotions(NamedTuple):
    """The walls the compiled loop places itself (``WallSet.compiled_motions``): a flag per
    row (:mod:`demcal.geometry.placement`), a translation's velocity [m/s], start and
    stop times [s], the reference rows, and a rotation's unit axis, point [m] and rate
    [rad/s]."""

    tflag: np.ndarray
    tvel: np.ndarray
    tstart: np.ndarray
    tstop: np.ndarray
    ref_params: np.ndarray
    ref_origin: np.ndarray
    axis: np.ndarray
    point: np.ndarray
    rate: np.ndarray


@njit(cache=True, nogil=True, error_model="numpy")
def run_steps(nsteps, params, bodies, spheres, pairs, wcontacts, walls, motions):
    """Advance up to ``nsteps`` steps; returns ``(steps, rebuild, time, travel)``.

    ``params`` is a :class:`StepParams`; ``bodies``, ``spheres``, ``pairs`` and
    ``wcontacts`` are the store's containers (:mod:`demcal.dem.storage`), ``walls`` the
    engine's wall rows (:class:`demcal.dem.walltable.WallRows`) and ``motions`` the
    walls this loop places itself (:class:`WallMotions`): those flagged in ``tflag``
    are placed at each step's time by
    :func:`~demcal.geometry.placement.place_moving`; the others keep their
    geometry.

    With ``rebuild`` true the last step has drifted but its forces are not evaluated:
    the host rebuilds the lists, then evaluates forces and kicks.
    """
    b, s, p, q, w, m = bodies, spheres, pairs, wcontacts, walls, motions
    return _run_steps(nsteps, params.dt, params.time, params.gravity, params.chosen,
                      params.table, params.half_skin, params.travel,
                      params.travel_per_step, b.pos, b.vel, b.quat, b.angmom, b.omega,
                      b.force, b.torque, b.mass, b.inertia, b.iso, b.mat, b.fixed,
                      b.start, s.body, s.offset, s.radius, s.pos, s.ref, s.dsq, s.acc,
                      p.start, p.other, p.hist, p.out, p.act,
                      q.start, q.other, q.hist, q.out, q.act,
                      w.kind, w.params, w.velocity, w.omega, w.origin, w.material,
                      m.tflag, m.tvel, m.tstart, m.tstop, m.ref_params, m.ref_origin,
                      m.axis, m.point, m.rate)


@njit(cache=True, nogil=True, error_model="numpy")
def run_steps_split(nsteps, params, bodies, spheres, pairs, wcontacts, walls, motions,
                    halo):
    """:func:`run_steps` split between numba's threads; same arguments plus the split
    (``halo``, a :class:`~demcal.dem.backend.HaloIndex`: the chunks and the pair list's
    halo index built for them, ``neighbours.halo_index``, with its buffer
    ``deferred``). The parallel loop itself (:func:`_run_steps_split`) takes the arrays
    one by one: numba's parallel lowering is fastest with plain array arguments."""
    b, s, p, q, w, m, h = bodies, spheres, pairs, wcontacts, walls, motions, halo
    return _run_steps_split(nsteps, h.chunks, params.dt, params.time, params.gravity,
                            params.chosen, params.table, params.half_skin, params.travel,
                            params.travel_per_step, b.pos, b.vel, b.quat, b.angmom,
                            b.omega, b.force, b.torque, b.mass, b.inertia, b.iso, b.mat,
                            b.fixed, b.start, s.body, s.offset, s.radius, s.pos, s.ref,
                            s.dsq, s.acc, p.start, p.other, p.hist, p.out, p.act,
                            h.rows, h.row, h.slots, h.slot, h.slot_deferred,
                            h.deferred_start, h.deferred,
                            q.start, q.other, q.hist, q.out, q.act,
                            w.kind, w.params, w.velocity, w.omega, w.origin, w.material,
                            m.tflag, m.tvel, m.tstart, m.tstop, m.ref_params,
                            m.ref_origin, m.axis, m.point, m.rate)


@njit(cache=True, nogil=True, error_model="numpy")
def _run_steps(nsteps, dt, time, gravity, chosen, table, half_skin, travel, travel_per_step,
              bpos, bvel, bquat, bangmom, bomega, bforce, btorque, bmass, binertia, biso,
              bmat, bfixed, bstart,
              sbody, soffset, srad, spos, sref, sdsq, sacc,
              p_start, p_nbr, p_hist, p_out, p_act,
              q_start, q_wid, q_hist, q_out, q_act,
              wkind, wparams, wvel, womega, worigin, wmat,
              tflag, tvel, tstart, tstop, ref_params, ref_origin, axis, point, rate):
    """Advance up to ``nsteps`` steps; returns ``(steps, rebuild, time, travel)``.

    Walls flagged in ``tflag`` are placed at each step's time by
    :func:`~demcal.geometry.placement.place_moving` (the arguments after ``wmat``); the
    others keep their
    geometry.

    With ``rebuild`` true the last step has drifted but its forces are not evaluated:
    the host rebuilds the lists, then evaluates forces and kicks.
    """
    nb = bpos.shape[0]
    none = np.zeros(1, np.int64)        # no halo: one chunk
    no_deferred = np.zeros((0, p_hist.shape[1]))
    for k in range(nsteps):
        mx = drift(dt, bpos, bvel, bquat, bangmom, bomega, bforce, btorque, bmass, binertia,
                   bfixed, bstart, soffset, spos, sref, sdsq, 0, nb)
        time += dt
        travel += travel_per_step
        if math.sqrt(mx) + travel > half_skin:
            return k + 1, True, time, travel
        place_moving(time, tflag, tvel, tstart, tstop, axis, point, rate, ref_params,
                     ref_origin, wkind, wparams, worigin, wvel, womega)
        forces_whole(chosen, table, dt, gravity, True, none, no_deferred, bpos, bvel, bquat,
                     bangmom, bomega, bforce, btorque, bmass, binertia, biso, bmat, bfixed,
                     bstart, spos, srad, sbody, sacc, p_start, p_nbr, p_hist, p_out, p_act,
                     q_start, q_wid, q_hist, q_out, q_act, wkind, wparams, wvel, womega,
                     worigin, wmat)
    return nsteps, False, time, travel


@njit(cache=True, nogil=True, error_model="numpy")
def _largest(mxs):
    """Largest entry, NaN and inf kept (they force a rebuild, which reports them)."""
    mx = 0.0
    for c in range(mxs.shape[0]):
        if not mxs[c] <= mx:
            mx = mxs[c]
    return mx


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _run_steps_split(nsteps, chunks, dt, time, gravity, chosen, table, half_skin, travel,
                    travel_per_step,
                    bpos, bvel, bquat, bangmom, bomega, bforce, btorque, bmass, binertia,
                    biso, bmat, bfixed, bstart,
                    sbody, soffset, srad, spos, sref, sdsq, sacc,
                    p_start, p_nbr, p_hist, p_out, p_act,
                    halo_rows, halo_row, halo_slots, halo_slot, halo_deferred,
                    deferred_start, deferred,
                    q_start, q_wid, q_hist, q_out, q_act,
                    wkind, wparams, wvel, womega, worigin, wmat,
                    tflag, tvel, tstart, tstop, ref_params, ref_origin, axis, point, rate):
    """:func:`_run_steps` split between numba's threads; same arguments plus the chunks
    and the halo index of the pair list (``neighbours.halo_index``, built for these
    chunks) with its buffer ``deferred``.

    Chunk c holds the bodies ``[chunks[c], chunks[c + 1])`` and their spheres. A step is
    two parallel regions: the pair contacts of each chunk's spheres (its halo slots,
    then its rows), then, chunk by chunk, the new history of its halo slots, the wall
    contacts of its spheres, the kick of its bodies and their drift into the next step,
    which touch nothing of another chunk.
    """
    nchunks = chunks.shape[0] - 1
    mxs = np.zeros(nchunks)
    for c in prange(nchunks):
        mxs[c] = drift(dt, bpos, bvel, bquat, bangmom, bomega, bforce, btorque, bmass,
                       binertia, bfixed, bstart, soffset, spos, sref, sdsq,
                       chunks[c], chunks[c + 1])
    for k in range(nsteps):
        time += dt
        travel += travel_per_step
        if not math.sqrt(_largest(mxs)) + travel <= half_skin:
            return k + 1, True, time, travel
        place_moving(time, tflag, tvel, tstart, tstop, axis, point, rate, ref_params,
                     ref_origin, wkind, wparams, worigin, wvel, womega)
        for c in prange(nchunks):
            pair_forces(chosen, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass,
                        biso, bmat, p_start, p_nbr, p_hist, p_out, p_act, sacc, halo_row,
                        halo_slots, halo_slot, halo_rows[c], halo_rows[c + 1], deferred,
                        deferred_start[c], bstart[chunks[c]], bstart[chunks[c + 1]])
        last = k + 1 == nsteps
        for c in prange(nchunks):
            b0 = chunks[c]
            b1 = chunks[c + 1]
            s0 = bstart[b0]
            s1 = bstart[b1]
            commit_deferred(p_hist, p_act, deferred, halo_slot, halo_deferred,
                            halo_slots[halo_rows[c]], halo_slots[halo_rows[c + 1]])
            wall_forces(chosen, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass,
                        biso, bmat, q_start, q_wid, q_hist, q_out, q_act, sacc, wkind,
                        wparams, wvel, womega, worigin, wmat, s0, s1)
            gather_kick(dt, gravity, bvel, bquat, bangmom, bomega, bforce, btorque, bmass,
                        binertia, bfixed, bstart, sacc, True, b0, b1)
            if not last:
                mxs[c] = drift(dt, bpos, bvel, bquat, bangmom, bomega, bforce, btorque,
                               bmass, binertia, bfixed, bstart, soffset, spos, sref, sdsq,
                               b0, b1)
    return nsteps, False, time, travel


# One step's forces of an unsplit simulation, for the step loop and for the host's
# single-step calls (``CpuBackend.forces`` and ``drift``) alike: the kernels' bounds go in
# as literals (``0``), so numba compiles one copy of each kernel for both. Called from
# Python with plain integers, the kernels were typed ``int64`` there and
# ``Literal[int](0)`` in the step loop: two copies, about 12 s of a fresh compile.
# (Plain integers in the loop too would share one copy, but cost the loop 4-5 %: the
# literal bounds let LLVM drop the halo branches of the unsplit pair loop.)


@njit(cache=True, nogil=True, error_model="numpy")
def forces_whole(chosen, table, dt, gravity, kick, halo, deferred,
                 bpos, bvel, bquat, bangmom, bomega, bforce, btorque, bmass, binertia, biso,
                 bmat, bfixed, bstart, spos, srad, sbody, sacc,
                 p_start, p_nbr, p_hist, p_out, p_act, q_start, q_wid, q_hist, q_out, q_act,
                 wkind, wparams, wvel, womega, worigin, wmat):
    """One step's forces of an unsplit simulation: the pair and wall contacts, the
    per-body sums and (``kick``) the half kick; ``halo`` and ``deferred`` are the
    empty halo index and history buffer of an unsplit pair loop."""
    nb = bpos.shape[0]
    ns = spos.shape[0]
    if ns:
        pair_forces(chosen, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass, biso,
                    bmat, p_start, p_nbr, p_hist, p_out, p_act, sacc, halo, halo, halo, 0,
                    0, deferred, 0, 0, ns)
        wall_forces(chosen, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass, biso,
                    bmat, q_start, q_wid, q_hist, q_out, q_act, sacc, wkind, wparams, wvel,
                    womega, worigin, wmat, 0, ns)
    if kick:
        gather_kick(dt, gravity, bvel, bquat, bangmom, bomega, bforce, btorque, bmass,
                    binertia, bfixed, bstart, sacc, True, 0, nb)
    else:
        gather_kick(dt, gravity, bvel, bquat, bangmom, bomega, bforce, btorque, bmass,
                    binertia, bfixed, bstart, sacc, False, 0, nb)


@njit(cache=True, nogil=True, error_model="numpy")
def drift_whole(dt, bpos, bvel, bquat, bangmom, bomega, bforce, btorque, bmass, binertia,
                bfixed, bstart, soffset, spos, sref, sdsq):
    """:func:`~demcal.dem.integrator.drift` over every body of an unsplit simulation."""
    return drift(dt, bpos, bvel, bquat, bangmom, bomega, bforce, btorque, bmass, binertia,
                 bfixed, bstart, soffset, spos, sref, sdsq, 0, bpos.shape[0])
