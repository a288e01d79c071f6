"""Contact drivers: loop over the neighbour list and the wall candidates.

Only these loops iterate over contacts (over a range [lo, hi) of spheres, so the host can
split the work between threads); each contact is evaluated by ``contact.kernel.contact``,
which both drivers call with the same levers and slip (:func:`_relative_motion`).

Where the results go (every sum is taken in a fixed order, so results are bitwise
identical for any number of threads):

* ``sacc[i]`` (per sphere i): the force on i and the torque on body(i) about its centre
  of mass: first the reactions of the slots where i is the j side (in row order), then
  row i's own contacts (summed in row order, added as one number), then i's wall
  contacts. With one thread :func:`pair_forces` scatters the reactions as it goes; with
  several, each row stores them in ``pair_out`` and :func:`reverse_sums` adds them per
  sphere through the reverse index, which gives the same numbers.
  :func:`wall_forces` adds the walls; ``integrator.gather_kick`` sums per body.
* ``pair_out[p]`` for an active pair slot p = (i, j): the force on i (j gets the
  opposite) and, on the split path, the torque on body(j).
* ``wall_out[q]`` for an active wall slot: the force on the body and the torque on the
  wall about its origin (for :func:`wall_totals`).

Geometry: ``n`` points from j (or the wall) to i, the overlap is
``delta = r_i + r_j - |x_i - x_j|`` (walls: ``r_i - d``), and the contact point is the
middle of the overlap, ``x_c = x_i - (r_i - delta/2) n``. Velocities at the contact point
include the bodies' rotation about their centres of mass; R* = r_i r_j/(r_i + r_j) from
the sphere radii (r_i against a wall), m* from the body masses (m_i against a wall).
"""

from numba import njit

from demcal.geometry.kernels import wall_distance

from .contact.kernel import contact, reset_history, store_history
from .contact.llvm_math import sqrt
from .contact.registry import LOOP_FASTMATH, ROLLING_CONSTANT, ROLLING_EPSD

ACC_WIDTH = 6   # sacc columns: force on the sphere (3), torque on its body (3)
OUT_WIDTH = 6   # pair_out / wall_out columns: force on i (3), torque on the other side (3)


@njit(cache=True, nogil=True, error_model="numpy", inline="always")
def _relative_motion(rolling, aix, aiy, aiz, ajx, ajy, ajz, vix, viy, viz, wix, wiy, wiz,
                     mi, iso_i, vjx, vjy, vjz, wjx, wjy, wjz, mj, iso_j):
    """Slip of one contact and, for the rolling models that need them, its lever lengths.

    ``a_i`` and ``a_j`` are the levers from i's centre of mass and from j's reference
    point (centre of mass, or a wall's origin) to the contact point; ``v``, ``w`` the
    velocities and angular velocities of the two sides; ``mj`` = 0 for a wall (no rolling
    inertia on that side). Returns the relative velocity of i against j at the contact
    point, the lever lengths and ``1/I_r`` summed over the bodies (``I = iso + m l^2``).
    """
    vrx = (vix + wiy * aiz - wiz * aiy) - (vjx + wjy * ajz - wjz * ajy)
    vry = (viy + wiz * aix - wix * aiz) - (vjy + wjz * ajx - wjx * ajz)
    vrz = (viz + wix * aiy - wiy * aix) - (vjz + wjx * ajy - wjy * ajx)
    li = 0.0
    lj = 0.0
    inv_ir = 0.0
    if rolling == ROLLING_CONSTANT or rolling == ROLLING_EPSD:
        li = sqrt(aix * aix + aiy * aiy + aiz * aiz)
        inv_ir = 1.0 / (iso_i + mi * li * li)
        if mj > 0.0:
            lj = sqrt(ajx * ajx + ajy * ajy + ajz * ajz)
            inv_ir += 1.0 / (iso_j + mj * lj * lj)
    return vrx, vry, vrz, li, lj, inv_ir


@njit(cache=True, nogil=True, error_model="numpy", fastmath=LOOP_FASTMATH)
def pair_forces(models, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass,
                biso, bmat, row_start, nbr, hist, pair_out, active, sacc, scatter, lo, hi):
    """Pair contacts of rows [lo, hi).

    ``scatter`` false (rows split between threads): ``sacc[i]`` is set to row i's own
    sums and each active slot stores the force on i and the torque on body(j) in
    ``pair_out``, for :func:`reverse_sums`. ``scatter`` true (one thread, all rows):
    the reaction goes straight to ``sacc[j]`` (zeroed here first), only the force is
    stored, and the sums come out bitwise the same as the split path's.
    ``biso[b]`` is the mean principal moment of inertia of body b (rolling inertia).
    """
    normal = models[0]
    damping = models[1]
    tangential = models[2]
    rolling = models[3]
    if scatter:
        for i in range(lo, hi):
            for k in range(ACC_WIDTH):
                sacc[i, k] = 0.0
    for i in range(lo, hi):
        bi = sbody[i]
        ri = srad[i]
        xi = spos[i, 0]
        yi = spos[i, 1]
        zi = spos[i, 2]
        # sphere centre relative to its body's centre of mass (zero for a sphere)
        oix = xi - bpos[bi, 0]
        oiy = yi - bpos[bi, 1]
        oiz = zi - bpos[bi, 2]
        vix = bvel[bi, 0]
        viy = bvel[bi, 1]
        viz = bvel[bi, 2]
        wix = bomega[bi, 0]
        wiy = bomega[bi, 1]
        wiz = bomega[bi, 2]
        mi = bmass[bi]
        iso_i = biso[bi]
        mati = bmat[bi]
        fsx = 0.0
        fsy = 0.0
        fsz = 0.0
        tsx = 0.0
        tsy = 0.0
        tsz = 0.0
        for p in range(row_start[i], row_start[i + 1]):
            j = nbr[p]
            rj = srad[j]
            xj = spos[j, 0]
            yj = spos[j, 1]
            zj = spos[j, 2]
            dx = xi - xj
            dy = yi - yj
            dz = zi - zj
            rs = ri + rj
            d2 = dx * dx + dy * dy + dz * dz
            if d2 >= rs * rs:
                if active[p]:
                    reset_history(hist, p)
                    active[p] = False
                continue
            bj = sbody[j]
            mj = bmass[bj]
            d = sqrt(d2)
            inv_d = 1.0 / d
            delta = rs - d
            nx = dx * inv_d
            ny = dy * inv_d
            nz = dz * inv_d
            # levers to the middle of the overlap: x_c = x_i - a n = x_j + b n
            a = ri - 0.5 * delta
            b = rj - 0.5 * delta
            aix = oix - a * nx
            aiy = oiy - a * ny
            aiz = oiz - a * nz
            ajx = (xj - bpos[bj, 0]) + b * nx
            ajy = (yj - bpos[bj, 1]) + b * ny
            ajz = (zj - bpos[bj, 2]) + b * nz
            wjx = bomega[bj, 0]
            wjy = bomega[bj, 1]
            wjz = bomega[bj, 2]
            vrx, vry, vrz, li, lj, inv_ir = _relative_motion(
                rolling, aix, aiy, aiz, ajx, ajy, ajz, vix, viy, viz, wix, wiy, wiz, mi,
                iso_i, bvel[bj, 0], bvel[bj, 1], bvel[bj, 2], wjx, wjy, wjz, mj, biso[bj])
            (fx, fy, fz, tix, tiy, tiz, tjx, tjy, tjz,
             h0, h1, h2, h3, h4, h5, h6) = contact(
                normal, damping, tangential, rolling, table, mati, bmat[bj], hist, p, delta,
                nx, ny, nz, vrx, vry, vrz, wix, wiy, wiz, wjx, wjy, wjz,
                li, lj, ri * rj / rs, mi * mj / (mi + mj), inv_ir, dt)
            store_history(hist, p, h0, h1, h2, h3, h4, h5, h6)
            active[p] = True
            fsx += fx
            fsy += fy
            fsz += fz
            tsx += aiy * fz - aiz * fy + tix
            tsy += aiz * fx - aix * fz + tiy
            tsz += aix * fy - aiy * fx + tiz
            pair_out[p, 0] = fx
            pair_out[p, 1] = fy
            pair_out[p, 2] = fz
            tx = -(ajy * fz - ajz * fy) + tjx
            ty = -(ajz * fx - ajx * fz) + tjy
            tz = -(ajx * fy - ajy * fx) + tjz
            if scatter:
                sacc[j, 0] -= fx
                sacc[j, 1] -= fy
                sacc[j, 2] -= fz
                sacc[j, 3] += tx
                sacc[j, 4] += ty
                sacc[j, 5] += tz
            else:
                pair_out[p, 3] = tx
                pair_out[p, 4] = ty
                pair_out[p, 5] = tz
        if scatter:
            sacc[i, 0] += fsx
            sacc[i, 1] += fsy
            sacc[i, 2] += fsz
            sacc[i, 3] += tsx
            sacc[i, 4] += tsy
            sacc[i, 5] += tsz
        else:
            sacc[i, 0] = fsx
            sacc[i, 1] = fsy
            sacc[i, 2] = fsz
            sacc[i, 3] = tsx
            sacc[i, 4] = tsy
            sacc[i, 5] = tsz


@njit(cache=True, nogil=True, error_model="numpy")
def reverse_sums(sacc, pair_out, active, rev_start, rev_pair, lo, hi):
    """After a split :func:`pair_forces`: add to each sphere j of [lo, hi) the reactions
    of the slots where it is the j side, in row order, in front of its own row sum
    (the order in which the scatter path adds them)."""
    for j in range(lo, hi):
        fx = 0.0
        fy = 0.0
        fz = 0.0
        tx = 0.0
        ty = 0.0
        tz = 0.0
        for q in range(rev_start[j], rev_start[j + 1]):
            p = rev_pair[q]
            if active[p]:
                fx -= pair_out[p, 0]
                fy -= pair_out[p, 1]
                fz -= pair_out[p, 2]
                tx += pair_out[p, 3]
                ty += pair_out[p, 4]
                tz += pair_out[p, 5]
        sacc[j, 0] = fx + sacc[j, 0]
        sacc[j, 1] = fy + sacc[j, 1]
        sacc[j, 2] = fz + sacc[j, 2]
        sacc[j, 3] = tx + sacc[j, 3]
        sacc[j, 4] = ty + sacc[j, 4]
        sacc[j, 5] = tz + sacc[j, 5]


@njit(cache=True, nogil=True, error_model="numpy", fastmath=LOOP_FASTMATH)
def wall_forces(models, table, dt, spos, srad, sbody, bpos, bvel, bomega, bmass,
                biso, bmat, wall_start, wid, whist, wall_out, wactive, sacc,
                wkind, wparams, wvel, womega, worigin, wmat, lo, hi):
    """Wall contacts of spheres [lo, hi); adds to ``sacc`` (after :func:`pair_forces`)."""
    normal = models[0]
    damping = models[1]
    tangential = models[2]
    rolling = models[3]
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
        oix = xi - bpos[bi, 0]
        oiy = yi - bpos[bi, 1]
        oiz = zi - bpos[bi, 2]
        mi = bmass[bi]
        for q in range(q0, q1):
            w = wid[q]
            d, nx, ny, nz = wall_distance(wkind[w], wparams[w], xi, yi, zi)
            delta = ri - d
            if delta <= 0.0:
                if wactive[q]:
                    reset_history(whist, q)
                    wactive[q] = False
                continue
            a = ri - 0.5 * delta
            aix = oix - a * nx
            aiy = oiy - a * ny
            aiz = oiz - a * nz
            ajx = (xi - worigin[w, 0]) - a * nx
            ajy = (yi - worigin[w, 1]) - a * ny
            ajz = (zi - worigin[w, 2]) - a * nz
            wix = bomega[bi, 0]
            wiy = bomega[bi, 1]
            wiz = bomega[bi, 2]
            vrx, vry, vrz, li, _, inv_ir = _relative_motion(
                rolling, aix, aiy, aiz, ajx, ajy, ajz, bvel[bi, 0], bvel[bi, 1], bvel[bi, 2],
                wix, wiy, wiz, mi, biso[bi], wvel[w, 0], wvel[w, 1], wvel[w, 2],
                womega[w, 0], womega[w, 1], womega[w, 2], 0.0, 0.0)
            fx, fy, fz, tix, tiy, tiz, _, _, _, h0, h1, h2, h3, h4, h5, h6 = contact(
                normal, damping, tangential, rolling, table, bmat[bi], wmat[w], whist, q,
                delta, nx, ny, nz, vrx, vry, vrz, wix, wiy, wiz, womega[w, 0],
                womega[w, 1], womega[w, 2], li, 0.0, ri, mi, inv_ir, dt)
            store_history(whist, q, h0, h1, h2, h3, h4, h5, h6)
            wactive[q] = True
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
