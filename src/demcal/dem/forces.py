"""Contact drivers: loop over the neighbour list and the wall candidates.

Only these loops iterate over contacts (over a range [lo, hi) of spheres, so the host can
split the work between threads); each contact is evaluated by ``contact.kernel.contact``
through :func:`_at_contact`, which both drivers share.

Where the results go (each slot is written by exactly one thread, and every sum is taken
in a fixed order, so results are bitwise identical for any number of threads):

* ``sacc[i]`` (per sphere i): the force on i and the torque on body(i) about its centre
  of mass, summed over row i of the pair list (in row order) and then over i's wall
  candidates. :func:`pair_forces` starts the sum, :func:`wall_forces` adds to it.
* ``pair_out[p]`` for an active pair slot p = (i, j): the force on i (j gets the
  opposite) and the torque on body(j); ``integrator.gather_kick`` adds those to body(j)
  through the reverse index.
* ``wall_out[q]`` for an active wall slot: the force on the body and the torque on the
  wall about its origin (for :func:`wall_totals`).

Geometry: ``n`` points from j (or the wall) to i, the overlap is
``delta = r_i + r_j - |x_i - x_j|`` (walls: ``r_i - d``), and the contact point is the
middle of the overlap, ``x_c = x_i - (r_i - delta/2) n``. Velocities at the contact point
include the bodies' rotation about their centres of mass; R* = r_i r_j/(r_i + r_j) from
the sphere radii (r_i against a wall), m* from the body masses (m_i against a wall).
"""

import math

from numba import njit

from demcal.geometry.kernels import wall_distance

from .contact.kernel import HIST_WIDTH, contact
from .contact.registry import ROLLING_CONSTANT, ROLLING_EPSD

ACC_WIDTH = 6   # sacc columns: force on the sphere (3), torque on its body (3)
OUT_WIDTH = 6   # pair_out / wall_out columns: force on i (3), torque on the other side (3)


@njit(cache=True, nogil=True, error_model="numpy")
def _contact_motion(rolling, delta, nx, ny, nz, xi, yi, zi, ri, bi, bpos, bvel, bomega, mi,
                    iso_i, ox, oy, oz, vx, vy, vz, wjx, wjy, wjz, mj, iso_j):
    """Levers and slip of one overlapping contact of sphere i (body ``bi``) with a partner
    j whose reference point (centre of mass or wall origin) is ``o``, moving with
    velocity ``v`` and angular velocity ``wj``; ``mj`` = 0 for a wall (no rolling
    inertia on that side).

    Returns the levers ``a_i`` (contact point minus i's centre of mass) and ``a_j``
    (contact point minus ``o``), the relative velocity of i against j at the contact
    point, and, for the rolling models that need them, the lever lengths and
    ``1/I_r`` summed over the bodies (``I = iso + m l^2``).
    """
    a = ri - 0.5 * delta
    cx = xi - a * nx
    cy = yi - a * ny
    cz = zi - a * nz
    aix = cx - bpos[bi, 0]
    aiy = cy - bpos[bi, 1]
    aiz = cz - bpos[bi, 2]
    ajx = cx - ox
    ajy = cy - oy
    ajz = cz - oz
    wix = bomega[bi, 0]
    wiy = bomega[bi, 1]
    wiz = bomega[bi, 2]
    vrx = (bvel[bi, 0] + wiy * aiz - wiz * aiy) - (vx + wjy * ajz - wjz * ajy)
    vry = (bvel[bi, 1] + wiz * aix - wix * aiz) - (vy + wjz * ajx - wjx * ajz)
    vrz = (bvel[bi, 2] + wix * aiy - wiy * aix) - (vz + wjx * ajy - wjy * ajx)
    li = 0.0
    lj = 0.0
    inv_ir = 0.0
    if rolling == ROLLING_CONSTANT or rolling == ROLLING_EPSD:
        li = math.sqrt(aix * aix + aiy * aiy + aiz * aiz)
        inv_ir = 1.0 / (iso_i + mi * li * li)
        if mj > 0.0:
            lj = math.sqrt(ajx * ajx + ajy * ajy + ajz * ajz)
            inv_ir += 1.0 / (iso_j + mj * lj * lj)
    return aix, aiy, aiz, ajx, ajy, ajz, vrx, vry, vrz, li, lj, inv_ir


@njit(cache=True, nogil=True, error_model="numpy")
def pair_forces(models, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass,
                biso, bmat, row_start, nbr, hist, pair_out, active, sacc, lo, hi):
    """Pair contacts of rows [lo, hi); starts ``sacc`` of those spheres.

    ``biso[b]`` is the mean principal moment of inertia of body b (rolling inertia)."""
    for i in range(lo, hi):
        bi = sbody[i]
        ri = srad[i]
        xi = spos[i, 0]
        yi = spos[i, 1]
        zi = spos[i, 2]
        fsx = 0.0
        fsy = 0.0
        fsz = 0.0
        tsx = 0.0
        tsy = 0.0
        tsz = 0.0
        for p in range(row_start[i], row_start[i + 1]):
            j = nbr[p]
            rj = srad[j]
            dx = xi - spos[j, 0]
            dy = yi - spos[j, 1]
            dz = zi - spos[j, 2]
            rs = ri + rj
            d2 = dx * dx + dy * dy + dz * dz
            if d2 >= rs * rs:
                if active[p]:
                    for k in range(HIST_WIDTH):
                        hist[p, k] = 0.0
                    active[p] = False
                continue
            hist[p, 7] = 1.0
            active[p] = True
            bj = sbody[j]
            d = math.sqrt(d2)
            inv_d = 1.0 / d
            mi = bmass[bi]
            mj = bmass[bj]
            delta = rs - d
            nx = dx * inv_d
            ny = dy * inv_d
            nz = dz * inv_d
            wjx = bomega[bj, 0]
            wjy = bomega[bj, 1]
            wjz = bomega[bj, 2]
            aix, aiy, aiz, ajx, ajy, ajz, vrx, vry, vrz, li, lj, inv_ir = _contact_motion(
                models[3], delta, nx, ny, nz, xi, yi, zi, ri, bi, bpos, bvel, bomega, mi,
                biso[bi], bpos[bj, 0], bpos[bj, 1], bpos[bj, 2], bvel[bj, 0], bvel[bj, 1],
                bvel[bj, 2], wjx, wjy, wjz, mj, biso[bj])
            fx, fy, fz, tix, tiy, tiz, tjx, tjy, tjz = contact(
                models, table, bmat[bi], bmat[bj], hist, p, delta, nx, ny, nz,
                vrx, vry, vrz, bomega[bi, 0], bomega[bi, 1], bomega[bi, 2], wjx, wjy, wjz,
                li, lj, ri * rj / rs, mi * mj / (mi + mj), inv_ir, dt)
            fsx += fx
            fsy += fy
            fsz += fz
            tsx += aiy * fz - aiz * fy + tix
            tsy += aiz * fx - aix * fz + tiy
            tsz += aix * fy - aiy * fx + tiz
            pair_out[p, 0] = fx
            pair_out[p, 1] = fy
            pair_out[p, 2] = fz
            pair_out[p, 3] = -(ajy * fz - ajz * fy) + tjx
            pair_out[p, 4] = -(ajz * fx - ajx * fz) + tjy
            pair_out[p, 5] = -(ajx * fy - ajy * fx) + tjz
        sacc[i, 0] = fsx
        sacc[i, 1] = fsy
        sacc[i, 2] = fsz
        sacc[i, 3] = tsx
        sacc[i, 4] = tsy
        sacc[i, 5] = tsz


@njit(cache=True, nogil=True, error_model="numpy")
def wall_forces(models, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass,
                biso, bmat, wall_start, wid, whist, wall_out, wactive, sacc,
                wkind, wparams, wvel, womega, worigin, wmat, lo, hi):
    """Wall contacts of spheres [lo, hi); adds to ``sacc`` (after :func:`pair_forces`)."""
    for i in range(lo, hi):
        q0 = wall_start[i]
        q1 = wall_start[i + 1]
        if q0 == q1:
            continue
        bi = sbody[i]
        ri = srad[i]
        xi = spos[i, 0]
        yi = spos[i, 1]
        zi = spos[i, 2]
        for q in range(q0, q1):
            w = wid[q]
            d, nx, ny, nz = wall_distance(wkind[w], wparams[w], xi, yi, zi)
            delta = ri - d
            if delta <= 0.0:
                if wactive[q]:
                    for k in range(HIST_WIDTH):
                        whist[q, k] = 0.0
                    wactive[q] = False
                continue
            whist[q, 7] = 1.0
            wactive[q] = True
            mi = bmass[bi]
            aix, aiy, aiz, ajx, ajy, ajz, vrx, vry, vrz, li, _, inv_ir = _contact_motion(
                models[3], delta, nx, ny, nz, xi, yi, zi, ri, bi, bpos, bvel, bomega, mi,
                biso[bi], worigin[w, 0], worigin[w, 1], worigin[w, 2], wvel[w, 0], wvel[w, 1],
                wvel[w, 2], womega[w, 0], womega[w, 1], womega[w, 2], 0.0, 0.0)
            fx, fy, fz, tix, tiy, tiz, _, _, _ = contact(
                models, table, bmat[bi], wmat[w], whist, q, delta, nx, ny, nz, vrx, vry, vrz,
                bomega[bi, 0], bomega[bi, 1], bomega[bi, 2], womega[w, 0], womega[w, 1],
                womega[w, 2], li, 0.0, ri, mi, inv_ir, dt)
            sacc[i, 0] += fx
            sacc[i, 1] += fy
            sacc[i, 2] += fz
            sacc[i, 3] += aiy * fz - aiz * fy + tix
            sacc[i, 4] += aiz * fx - aix * fz + tiy
            sacc[i, 5] += aix * fy - aiy * fx + tiz
            # the wall takes the moment of -F about its origin and the reaction of i's
            # rolling torque
            wall_out[q, 0] = fx
            wall_out[q, 1] = fy
            wall_out[q, 2] = fz
            wall_out[q, 3] = -(ajy * fz - ajz * fy) - tix
            wall_out[q, 4] = -(ajz * fx - ajx * fz) - tiy
            wall_out[q, 5] = -(ajx * fy - ajy * fx) - tiz


@njit(cache=True, error_model="numpy")
def wall_totals(wall_start, wid, wall_out, wactive, nw, out):
    """Force and torque per wall row, ``out[w] = (F, T about origin)``, fixed order."""
    for w in range(nw):
        for k in range(6):
            out[w, k] = 0.0
    ns = wall_start.shape[0] - 1
    for q in range(wall_start[ns]):
        if not wactive[q]:
            continue
        w = wid[q]
        out[w, 0] -= wall_out[q, 0]
        out[w, 1] -= wall_out[q, 1]
        out[w, 2] -= wall_out[q, 2]
        out[w, 3] += wall_out[q, 3]
        out[w, 4] += wall_out[q, 4]
        out[w, 5] += wall_out[q, 5]
