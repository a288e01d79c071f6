"""Contact drivers: loop over the neighbour list and the wall candidates.

Only these loops iterate over contacts (over a range [lo, hi) of spheres, so the
host can split the work between threads); each contact is evaluated by
``contact.kernel.contact``. A pair slot ``p`` (sphere i, sphere j) writes
``pair_out[p] = (F on i, torque on body(i) about its centre of mass, torque on
body(j))`` and ``active[p]`` (only active slots are read); a wall slot ``q`` writes
``wall_out[q] = (F on the body, torque on the body, torque on the wall about its
origin)`` and ``wactive[q]``. Each slot is written by exactly one thread and
``integrator.gather_kick`` sums them in a fixed order, so results are bitwise identical
for any number of threads.

Geometry: ``n`` points from j (or the wall) to i, the overlap is
``delta = r_i + r_j - |x_i - x_j|`` (walls: ``r_i - d``), and the contact point is the
middle of the overlap, ``x_c = x_i - (r_i - delta/2) n``. Velocities at the contact
point include the bodies' rotation about their centres of mass; R* = r_i r_j/(r_i + r_j)
from the sphere radii (r_i against a wall), m* from the body masses (m_i against a wall).
"""

import math

from numba import njit

from demcal.geometry.kernels import wall_distance

from .contact.kernel import HIST_WIDTH, contact
from .contact.registry import ROLLING_CONSTANT, ROLLING_EPSD


@njit(cache=True, nogil=True, error_model="numpy")
def pair_forces(models, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass,
                binertia, bmat, row_start, nbr, hist, pair_out, active, lo, hi):
    ns = spos.shape[0]
    for i in range(lo, hi):
        bi = sbody[i]
        ri = srad[i]
        for p in range(row_start[i], row_start[i + 1]):
            j = nbr[p]
            rj = srad[j]
            dx = spos[i, 0] - spos[j, 0]
            dy = spos[i, 1] - spos[j, 1]
            dz = spos[i, 2] - spos[j, 2]
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
            delta = rs - d
            nx = dx / d
            ny = dy / d
            nz = dz / d
            a = ri - 0.5 * delta
            cx = spos[i, 0] - a * nx
            cy = spos[i, 1] - a * ny
            cz = spos[i, 2] - a * nz
            aix = cx - bpos[bi, 0]
            aiy = cy - bpos[bi, 1]
            aiz = cz - bpos[bi, 2]
            ajx = cx - bpos[bj, 0]
            ajy = cy - bpos[bj, 1]
            ajz = cz - bpos[bj, 2]
            wix = bomega[bi, 0]
            wiy = bomega[bi, 1]
            wiz = bomega[bi, 2]
            wjx = bomega[bj, 0]
            wjy = bomega[bj, 1]
            wjz = bomega[bj, 2]
            vrx = (bvel[bi, 0] + wiy * aiz - wiz * aiy) - (bvel[bj, 0] + wjy * ajz - wjz * ajy)
            vry = (bvel[bi, 1] + wiz * aix - wix * aiz) - (bvel[bj, 1] + wjz * ajx - wjx * ajz)
            vrz = (bvel[bi, 2] + wix * aiy - wiy * aix) - (bvel[bj, 2] + wjx * ajy - wjy * ajx)
            mi = bmass[bi]
            mj = bmass[bj]
            li = 0.0
            lj = 0.0
            inv_ir = 0.0
            if models[3] == ROLLING_CONSTANT or models[3] == ROLLING_EPSD:
                li = math.sqrt(aix * aix + aiy * aiy + aiz * aiz)
                lj = math.sqrt(ajx * ajx + ajy * ajy + ajz * ajz)
                ii = (binertia[bi, 0] + binertia[bi, 1] + binertia[bi, 2]) / 3.0
                ij = (binertia[bj, 0] + binertia[bj, 1] + binertia[bj, 2]) / 3.0
                inv_ir = 1.0 / (ii + mi * li * li) + 1.0 / (ij + mj * lj * lj)
            fx, fy, fz, tix, tiy, tiz, tjx, tjy, tjz = contact(
                models, table, bmat[bi], bmat[bj], hist, p, delta, nx, ny, nz,
                vrx, vry, vrz, wix, wiy, wiz, wjx, wjy, wjz, li, lj,
                ri * rj / rs, mi * mj / (mi + mj), inv_ir, dt)
            pair_out[p, 0] = fx
            pair_out[p, 1] = fy
            pair_out[p, 2] = fz
            pair_out[p, 3] = aiy * fz - aiz * fy + tix
            pair_out[p, 4] = aiz * fx - aix * fz + tiy
            pair_out[p, 5] = aix * fy - aiy * fx + tiz
            pair_out[p, 6] = -(ajy * fz - ajz * fy) + tjx
            pair_out[p, 7] = -(ajz * fx - ajx * fz) + tjy
            pair_out[p, 8] = -(ajx * fy - ajy * fx) + tjz


@njit(cache=True, nogil=True, error_model="numpy")
def wall_forces(models, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass,
                binertia, bmat, wall_start, wid, whist, wall_out, wactive,
                wkind, wparams, wvel, womega, worigin, wmat, lo, hi):
    ns = spos.shape[0]
    for i in range(lo, hi):
        bi = sbody[i]
        ri = srad[i]
        for q in range(wall_start[i], wall_start[i + 1]):
            w = wid[q]
            d, nx, ny, nz = wall_distance(wkind[w], wparams[w], spos[i, 0], spos[i, 1],
                                          spos[i, 2])
            delta = ri - d
            if delta <= 0.0:
                if wactive[q]:
                    for k in range(HIST_WIDTH):
                        whist[q, k] = 0.0
                    wactive[q] = False
                continue
            whist[q, 7] = 1.0
            wactive[q] = True
            a = ri - 0.5 * delta
            cx = spos[i, 0] - a * nx
            cy = spos[i, 1] - a * ny
            cz = spos[i, 2] - a * nz
            aix = cx - bpos[bi, 0]
            aiy = cy - bpos[bi, 1]
            aiz = cz - bpos[bi, 2]
            ajx = cx - worigin[w, 0]
            ajy = cy - worigin[w, 1]
            ajz = cz - worigin[w, 2]
            wix = bomega[bi, 0]
            wiy = bomega[bi, 1]
            wiz = bomega[bi, 2]
            wjx = womega[w, 0]
            wjy = womega[w, 1]
            wjz = womega[w, 2]
            vrx = (bvel[bi, 0] + wiy * aiz - wiz * aiy) - (wvel[w, 0] + wjy * ajz - wjz * ajy)
            vry = (bvel[bi, 1] + wiz * aix - wix * aiz) - (wvel[w, 1] + wjz * ajx - wjx * ajz)
            vrz = (bvel[bi, 2] + wix * aiy - wiy * aix) - (wvel[w, 2] + wjx * ajy - wjy * ajx)
            mi = bmass[bi]
            li = 0.0
            inv_ir = 0.0
            if models[3] == ROLLING_CONSTANT or models[3] == ROLLING_EPSD:
                li = math.sqrt(aix * aix + aiy * aiy + aiz * aiz)
                ii = (binertia[bi, 0] + binertia[bi, 1] + binertia[bi, 2]) / 3.0
                inv_ir = 1.0 / (ii + mi * li * li)
            fx, fy, fz, tix, tiy, tiz, tjx, tjy, tjz = contact(
                models, table, bmat[bi], wmat[w], whist, q, delta, nx, ny, nz,
                vrx, vry, vrz, wix, wiy, wiz, wjx, wjy, wjz, li, 0.0,
                ri, mi, inv_ir, dt)
            wall_out[q, 0] = fx
            wall_out[q, 1] = fy
            wall_out[q, 2] = fz
            wall_out[q, 3] = aiy * fz - aiz * fy + tix
            wall_out[q, 4] = aiz * fx - aix * fz + tiy
            wall_out[q, 5] = aix * fy - aiy * fx + tiz
            wall_out[q, 6] = -(ajy * fz - ajz * fy) - tix
            wall_out[q, 7] = -(ajz * fx - ajx * fz) - tiy
            wall_out[q, 8] = -(ajx * fy - ajy * fx) - tiz


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
        out[w, 3] += wall_out[q, 6]
        out[w, 4] += wall_out[q, 7]
        out[w, 5] += wall_out[q, 8]
